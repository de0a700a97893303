//! One planner move with `arcsim profile`'s options: minimum time, or a minimum duration, then
//! optionally every phase on a servo period.

use arcsim_planner::{plan, Limits, Move, MoveOptions, PlannerError, Profile, Reversal};

/// A move and its options, as `arcsim profile` takes them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MoveRequest {
    /// The move (deg, deg/s).
    pub mv: Move,
    /// Maximum jerk (deg/s³).
    pub jerk_deg_per_s3: f64,
    /// Maximum acceleration (deg/s²).
    pub accel_deg_per_s2: f64,
    /// Maximum deceleration (deg/s²); `None`: equal to the acceleration.
    pub decel_deg_per_s2: Option<f64>,
    /// Maximum speed (deg/s).
    pub speed_deg_per_s: f64,
    /// Last at least this long (s); `None` or 0: the minimum time. The move lasts exactly this
    /// long when it can, else the shortest feasible duration above it (with [`Reversal::Allow`]
    /// backing up if need be); it is infeasible only when it cannot last this long or longer.
    pub min_duration_s: Option<f64>,
    /// Put every phase on this servo period (s).
    pub period_s: Option<f64>,
    /// Whether the speed may go against the direction of travel.
    pub reverse: Reversal,
}

/// A solved move.
#[derive(Clone, Debug)]
pub struct SolvedMove {
    /// The verified profile.
    pub profile: Profile,
    /// The limits it was planned with.
    pub limits: Limits,
    /// Time the servo grid added against the continuous profile (s), with a period.
    pub added_time_s: Option<f64>,
}

/// Why a move has no profile.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MoveError {
    /// The planner's answer: invalid input, or no profile (unreachable, infeasible duration, …).
    #[error("{0}")]
    Planner(#[from] PlannerError),
}

impl MoveRequest {
    /// The profile: [`plan`] with the request's options.
    pub fn solve(&self) -> Result<SolvedMove, MoveError> {
        let limits = Limits::with_decel(
            self.jerk_deg_per_s3,
            self.accel_deg_per_s2,
            self.decel_deg_per_s2.unwrap_or(self.accel_deg_per_s2),
            self.speed_deg_per_s,
        )?;
        let min_duration_s = self.min_duration_s.unwrap_or(0.0);
        let options = MoveOptions {
            min_duration_s,
            servo_period_s: self.period_s,
            reversal: self.reverse,
        };
        let profile = plan(&self.mv, &limits, &options)?;
        Ok(SolvedMove {
            added_time_s: profile.servo_added_time(),
            profile,
            limits,
        })
    }
}
