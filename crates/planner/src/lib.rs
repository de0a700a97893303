//! # arcsim-planner
//!
//! The single-axis minimum-time S-curve planner of arcsim: every gantry move between two energy
//! layers is a jerk-, acceleration- and velocity-limited profile with zero acceleration at both
//! ends (Dai & Zhu, "A minimum time velocity scheduling method for single-axis movement",
//! sections 2.1–2.2; equation numbers in the docs refer to that paper).
//!
//! One input, one result: a [`Move`] (distance, start and end speed), the axis [`Limits`] and
//! [`MoveOptions`] (minimum duration, servo period, [`Reversal`]) go into [`plan`], which returns
//! a verified [`Profile`] or a typed [`PlannerError`]. Schedulers that ask many questions of the
//! same move use a [`MoveAnalysis`] (minimum time, feasible durations as a [`DurationSet`],
//! the shortest duration of at least a given time) and the reachable speeds across a
//! [`LinearGap`] (eq. 5, 8).
//!
//! ```
//! use arcsim_planner::{plan, Limits, Move, MoveOptions, Reversal};
//!
//! // The ATOM gantry: J = 0.5 deg/s³, A = 0.5 deg/s², V = 5 deg/s.
//! let limits = Limits::new(0.5, 0.5, 5.0)?;
//! let mv = Move { distance: 4.0, v_start: 1.5, v_end: 0.5 };
//! let fastest = plan(&mv, &limits, &MoveOptions::default())?;
//! let end = fastest.end_state();
//! assert!((end.position - 4.0).abs() < 1e-9 && (end.velocity - 0.5).abs() < 1e-9);
//!
//! // The same move lasting at least an energy switch of 5 s, still never backing up.
//! let elst = MoveOptions {
//!     min_duration_s: 5.0,
//!     reversal: Reversal::Forbid,
//!     ..Default::default()
//! };
//! let slow = plan(&mv, &limits, &elst)?;
//! assert!((slow.duration() - 5.0).abs() < 1e-9);
//!
//! // The minimum-time move on a 4 ms servo period: every phase a whole number of periods.
//! let servo = MoveOptions { servo_period_s: Some(0.004), ..Default::default() };
//! let on_grid = plan(&mv, &limits, &servo)?;
//! assert!(on_grid.duration() >= fastest.duration());
//! assert!(on_grid.servo_added_time().is_some_and(|added| added >= 0.0));
//! # Ok::<(), arcsim_planner::PlannerError>(())
//! ```
//!
//! Inside, one file per idea, in the order a move is planned: the limits; the basic
//! three-period speed change (eq. 1–4); the move in its direction of travel; step 1, the
//! minimum-time distance-constrained move (eq. 5–8, all three cases); the reachable-speed bounds;
//! step 2, the durations a move can last and a move lasting one of them; the servo
//! discretisation; the profile as constant-jerk segments, sampled and verified; the safeguarded
//! root finders behind the exact solutions.
//!
//! Units are whatever the caller uses consistently (arcsim: degrees and seconds).
#![warn(missing_docs)]

mod discretize;
mod error;
mod limits;
mod min_duration;
mod min_time;
mod plan;
mod profile;
mod reach;
mod roots;
mod speed_change;
mod travel;

pub use error::PlannerError;
pub use limits::Limits;
pub use min_duration::{DurationSet, MoveAnalysis};
pub use plan::{plan, Move, MoveOptions, Reversal};
pub use profile::{Extrema, Profile, Segment, SevenPhases, State};
pub use reach::LinearGap;
pub use travel::two_change;
