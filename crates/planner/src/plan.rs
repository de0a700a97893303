//! The planner's one entry point: a move, the limits and the options in, a verified profile out.

use crate::discretize::discretize;
use crate::min_duration::min_time_profile;
use crate::{Limits, MoveAnalysis, PlannerError, Profile};

/// A single-axis move: signed distance and signed boundary speeds (units, units/s), with zero
/// acceleration at both ends.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Move {
    /// Signed distance from the start to the end position (units).
    pub distance: f64,
    /// Signed speed at the start (units/s).
    pub v_start: f64,
    /// Signed speed at the end (units/s).
    pub v_end: f64,
}

impl Move {
    /// Direction of travel (±1): the sign of the distance, or for a zero distance the direction
    /// the boundary speeds point to. [`Limits::max_accel`] acts along it.
    pub fn direction(&self) -> f64 {
        crate::profile::travel_direction(self.distance, self.v_start, self.v_end)
    }
}

/// What the planner may do when `v_end` cannot be reached within the distance, or the move must
/// last longer than its minimum time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Reversal {
    /// The speed may go against the direction of travel, down to -V (time-optimal, as Ruckig).
    Allow,
    /// The speed stays in [0, V] along the direction of travel (a gantry inside an arc never
    /// turns back).
    #[default]
    Forbid,
}

/// Options of [`plan`]. `MoveOptions::default()` is the minimum-time move without reversal, in
/// continuous time.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct MoveOptions {
    /// The move lasts at least this long (s; 0: no minimum), as Ruckig's `minimum_duration`:
    /// exactly this long when the move can last it, else the shortest feasible duration above
    /// (paper section 2.2 with a cruise filling the time; see [`MoveAnalysis::durations`]).
    pub min_duration_s: f64,
    /// Servo period (s): every phase becomes a whole number of periods, every limit kept, the
    /// move no shorter ([`Profile::servo_added_time`] says by how much it grew). `None`:
    /// continuous time.
    pub servo_period_s: Option<f64>,
    /// Whether the speed may go against the direction of travel.
    pub reversal: Reversal,
}

/// Plans one move: the shortest profile lasting at least `options.min_duration_s` from
/// `(0, mv.v_start, 0)` to `(mv.distance, mv.v_end, 0)` within `limits` (paper eq. 1–8), then
/// with a servo period every phase on the grid. The profile returned has been re-integrated and
/// checked against its target and the limits.
///
/// Errors: invalid input ([`PlannerError::InvalidLimit`], [`PlannerError::InvalidInput`],
/// [`PlannerError::SpeedAboveLimit`], [`PlannerError::SpeedAgainstTravel`]); no profile under the
/// options ([`PlannerError::Unreachable`] with the reachable speeds,
/// [`PlannerError::DurationInfeasible`] with the feasible durations,
/// [`PlannerError::PeriodTooCoarse`]); never a silently wrong profile.
pub fn plan(mv: &Move, limits: &Limits, options: &MoveOptions) -> Result<Profile, PlannerError> {
    // The minimum time needs no duration analysis.
    let profile = if options.min_duration_s == 0.0 {
        min_time_profile(mv, limits, options.reversal)?
    } else {
        MoveAnalysis::new(mv, limits, options.reversal)?.profile(options.min_duration_s)?
    };
    match options.servo_period_s {
        None => Ok(profile),
        Some(period) => discretize(&profile, period, limits),
    }
}
