//! Sequencer errors.

use arcsim_planner::PlannerError;
use thiserror::Error;

/// Why a delivery cannot be sequenced.
#[derive(Debug, Error)]
pub enum SequenceError {
    /// The plan or machine failed validation / resolution.
    #[error("{0}")]
    Plan(#[from] arcsim_plan::PlanError),
    /// Machine limits the planner rejects.
    #[error("machine gantry limits: {0}")]
    Limits(PlannerError),
    /// No feasible timeline (should not happen for valid plans: rest is always feasible).
    #[error("arc {arc}, layer {layer}: {reason}")]
    Infeasible {
        /// The arc's index in the plan.
        arc: usize,
        /// The layer's index within the arc.
        layer: usize,
        /// What could not be done; a planner refusal is kept as it is.
        #[source]
        reason: Infeasibility,
    },
    /// The integrated timeline broke a constraint: a bug, reported instead of ignored.
    #[error("timeline verification failed (a bug): {0}")]
    Verification(String),
    /// Wrong input to a lower-level entry point (e.g. speed list of the wrong length).
    #[error("{0}")]
    Input(String),
}

/// What made one transition or layer infeasible.
#[derive(Debug, Error)]
pub enum Infeasibility {
    /// The planner refused the move (gap too short, end speed unreachable, …).
    #[error(transparent)]
    Planner(#[from] PlannerError),
    /// The move has no duration at least as long as the energy switch.
    #[error("the move cannot last its {elst_s} s energy switch")]
    CannotLastElst {
        /// The energy-layer switching time (s).
        elst_s: f64,
    },
    /// The move has no duration that is a whole number of servo periods.
    #[error("the move cannot last a whole number of {period_s} s servo periods")]
    NotOnServoGrid {
        /// The servo period (s).
        period_s: f64,
    },
    /// A given layer speed is outside what the layer allows.
    #[error(
        "speed {speed_deg_per_s} deg/s is outside [0, {cap_deg_per_s}] (window, V, or rest at the arc's ends)"
    )]
    SpeedOutOfRange {
        /// The speed given (deg/s).
        speed_deg_per_s: f64,
        /// The layer's cap (deg/s).
        cap_deg_per_s: f64,
    },
    /// Free motion could not rebuild the constant-speed schedule.
    #[error("the constant-speed schedule could not be rebuilt as free motion")]
    FreeMotionRebuild,
    /// No stop-and-turn move between two arcs reaches the next arc's start.
    #[error("no stop-and-turn move reaches the arc's start")]
    NoStopAndTurn,
}
