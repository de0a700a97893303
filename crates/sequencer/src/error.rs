//! Sequencer errors.

use thiserror::Error;

#[derive(Debug, Error)]
pub enum SequenceError {
    /// The plan or machine failed validation / resolution.
    #[error("{0}")]
    Plan(#[from] arcsim_plan::PlanError),
    /// Machine limits the planner rejects.
    #[error("machine gantry limits: {0}")]
    Limits(arcsim_planner::PlannerError),
    /// No feasible timeline (should not happen for valid plans: rest is always feasible).
    #[error("arc {arc}, layer {layer}: {message}")]
    Infeasible {
        arc: usize,
        layer: usize,
        message: String,
    },
    /// The integrated timeline broke a constraint: a bug, reported instead of ignored.
    #[error("timeline verification failed (a bug): {0}")]
    Verification(String),
    /// Wrong input to a lower-level entry point (e.g. speed list of the wrong length).
    #[error("{0}")]
    Input(String),
}
