//! # arcsim-planner
//!
//! The single-axis minimum-time S-curve planner of arcsim: every gantry move between two energy
//! layers is a jerk-, acceleration- and velocity-limited profile with zero acceleration at both
//! ends (Dai & Zhu, "A minimum time velocity scheduling method for single-axis movement",
//! sections 2.1–2.2; equation numbers in the docs refer to that paper).
//!
//! One file per idea, in the order a move is planned:
//! - [`limits`]: the axis limits J, A (and a separate deceleration), V.
//! - [`speed_change`]: the basic three-period profile (eq. 1–4).
//! - [`min_time`]: step 1, the minimum-time distance-constrained move (eq. 5–8, all three cases).
//! - [`reach`]: exact reachable-speed bounds for look-ahead schedulers.
//! - [`min_duration`]: step 2, a move that lasts exactly a requested (longer) duration.
//! - [`discretize`]: phase durations on a servo period, limits kept.
//! - [`profile`]: the resulting constant-jerk segments, sampled at any time and verified.
//! - [`roots`]: the safeguarded root finders behind the exact solutions.
//!
//! Units are whatever the caller uses consistently (arcsim: degrees and seconds). Every profile the
//! planner returns has been re-integrated and checked against its target and the limits.

pub mod discretize;
pub mod error;
pub mod limits;
pub mod min_duration;
pub mod min_time;
pub mod profile;
pub mod reach;
pub mod roots;
pub mod speed_change;

pub use discretize::{discretize, Discretized};
pub use error::PlannerError;
pub use limits::Limits;
pub use min_duration::{
    at_least_duration, can_last_at_least, duration_feasible, exact_duration, feasible_durations,
    max_duration, shortest_duration_at_least, DurationSet,
};
pub use min_time::{min_time, min_time_shape, Move, Reversal};
pub use profile::{Extrema, Profile, Segment, State, TwoStep};
pub use reach::{fits, max_end_speed, max_start_speed, LinearGap};
pub use speed_change::SpeedChange;
