//! One planner move with `arcsim profile`'s options: minimum time, or an exact minimum duration,
//! then optionally every phase on a servo period.

use arcsim_planner::{
    discretize, exact_duration, min_time, Limits, Move, PlannerError, Profile, Reversal,
};

/// A move and its options, as `arcsim profile` takes them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MoveRequest {
    pub mv: Move,
    /// Limits (deg/s³, deg/s², deg/s); `decel_deg_per_s2` `None`: equal to the acceleration.
    pub jerk_deg_per_s3: f64,
    pub accel_deg_per_s2: f64,
    pub decel_deg_per_s2: Option<f64>,
    pub speed_deg_per_s: f64,
    /// Last exactly this long (s) instead of the minimum time.
    pub min_duration_s: Option<f64>,
    /// Put every phase on this servo period (s).
    pub period_s: Option<f64>,
    pub reverse: Reversal,
}

/// A solved move.
#[derive(Clone, Debug)]
pub struct SolvedMove {
    pub profile: Profile,
    pub limits: Limits,
    /// Time the servo grid added against the continuous profile (s), with a period.
    pub added_time_s: Option<f64>,
}

/// Why a move has no profile.
#[derive(Debug, thiserror::Error)]
pub enum MoveError {
    /// The planner's answer: invalid input, or no profile (unreachable, infeasible duration, …).
    #[error("{0}")]
    Planner(#[from] PlannerError),
    /// A minimum duration keeps the speed within [0, V]; it does not combine with reversal.
    #[error("min_duration keeps the speed in [0, V]: use reverse = forbid")]
    MinDurationWithReversal,
}

impl MoveRequest {
    /// The profile: [`min_time`] or [`exact_duration`], then [`discretize`] with a period.
    pub fn solve(&self) -> Result<SolvedMove, MoveError> {
        let limits = Limits::with_decel(
            self.jerk_deg_per_s3,
            self.accel_deg_per_s2,
            self.decel_deg_per_s2.unwrap_or(self.accel_deg_per_s2),
            self.speed_deg_per_s,
        )?;
        let profile = match self.min_duration_s {
            Some(_) if self.reverse == Reversal::Allow => {
                return Err(MoveError::MinDurationWithReversal)
            }
            Some(t) => exact_duration(self.mv, &limits, t)?,
            None => min_time(self.mv, &limits, self.reverse)?,
        };
        Ok(match self.period_s {
            None => SolvedMove {
                profile,
                limits,
                added_time_s: None,
            },
            Some(ts) => {
                let d = discretize(&profile, ts, &limits)?;
                SolvedMove {
                    profile: d.profile,
                    limits,
                    added_time_s: Some(d.added_time),
                }
            }
        })
    }
}
