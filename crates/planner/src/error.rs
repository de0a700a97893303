//! Planner errors: bad input, and moves that have no profile under the chosen policy.

use std::fmt;

/// Why the planner returned no profile. Infeasible moves are not bugs: they carry what *is*
/// reachable so that a scheduler can adjust its speeds.
#[derive(Clone, Debug, PartialEq)]
pub enum PlannerError {
    /// A limit is not a finite number > 0.
    InvalidLimit {
        /// The limit's field name in [`crate::Limits`].
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// An input is not finite (or otherwise malformed).
    InvalidInput {
        /// The input's name.
        name: &'static str,
        /// The value given.
        value: f64,
        /// What was expected instead.
        expected: &'static str,
    },
    /// A boundary speed exceeds the speed limit V.
    SpeedAboveLimit {
        /// `v_start` or `v_end`.
        name: &'static str,
        /// The speed given (units/s).
        value: f64,
        /// The speed limit V (units/s).
        limit: f64,
    },
    /// Reversal is forbidden and a boundary speed points against the direction of travel.
    SpeedAgainstTravel {
        /// `v_start` or `v_end`.
        name: &'static str,
        /// The speed given (units/s).
        value: f64,
    },
    /// Reversal is forbidden and `v_end` cannot be reached within the distance (paper case 3,
    /// eq. 8).
    Unreachable {
        /// Start speed of the move (units/s).
        v_start: f64,
        /// End speed of the move (units/s).
        v_end: f64,
        /// Distance of the move (units).
        distance: f64,
        /// The highest end speed reachable from `v_start` (along travel).
        max_end_speed: f64,
        /// The highest start speed from which `v_end` is still reachable (along travel).
        max_start_speed: f64,
    },
    /// No profile lasts the requested duration or longer.
    DurationInfeasible {
        /// The duration asked for (s).
        requested: f64,
        /// The feasible durations, as closed intervals (s); an upper end may be infinite.
        feasible: Vec<(f64, f64)>,
    },
    /// The servo period is too coarse to keep the limits for this move.
    PeriodTooCoarse {
        /// The servo period (s).
        period: f64,
        /// What could not be kept.
        detail: String,
    },
    /// A profile failed its own integration check: a planner bug, never silently returned.
    Verification(String),
}

impl fmt::Display for PlannerError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PlannerError::InvalidLimit { name, value } => {
                write!(f, "limit {name} = {value}: expected a finite number > 0")
            }
            PlannerError::InvalidInput {
                name,
                value,
                expected,
            } => {
                write!(f, "{name} = {value}: expected {expected}")
            }
            PlannerError::SpeedAboveLimit { name, value, limit } => {
                write!(f, "{name} = {value} exceeds the speed limit {limit}")
            }
            PlannerError::SpeedAgainstTravel { name, value } => write!(
                f,
                "{name} = {value} points against the direction of travel and reversal is forbidden"
            ),
            PlannerError::Unreachable {
                v_start,
                v_end,
                distance,
                max_end_speed,
                max_start_speed,
            } => {
                write!(
                    f,
                    "end speed {v_end} is not reachable from {v_start} within distance {distance} \
                     without reversing: "
                )?;
                if v_end.abs() < v_start.abs() {
                    // Braking: the start speed is what is too high for the gap.
                    write!(
                        f,
                        "the gap is too short to slow down; the highest start speed that still \
                         reaches {v_end} is {max_start_speed:.6} (the highest end speed reachable \
                         from {v_start} is {max_end_speed:.6})"
                    )
                } else {
                    write!(
                        f,
                        "the highest reachable end speed is {max_end_speed:.6}, the highest start \
                         speed that still reaches {v_end} is {max_start_speed:.6}"
                    )
                }
            }
            PlannerError::DurationInfeasible {
                requested,
                feasible,
            } => {
                write!(f, "no profile lasts {requested} s; feasible durations:")?;
                for (i, (lo, hi)) in feasible.iter().enumerate() {
                    let sep = if i == 0 { " " } else { ", " };
                    if hi.is_infinite() {
                        write!(f, "{sep}>= {lo:.6} s")?;
                    } else {
                        write!(f, "{sep}[{lo:.6}, {hi:.6}] s")?;
                    }
                }
                Ok(())
            }
            PlannerError::PeriodTooCoarse { period, detail } => {
                write!(
                    f,
                    "servo period {period} s is too coarse for this move: {detail}"
                )
            }
            PlannerError::Verification(msg) => {
                write!(f, "planner self-check failed (a bug): {msg}")
            }
        }
    }
}

impl std::error::Error for PlannerError {}
