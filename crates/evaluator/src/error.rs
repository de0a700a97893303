//! Evaluator errors: every message says where (file, field) and what was expected.

use thiserror::Error;

/// Why loading, evaluating a shard spec or merging shard outputs failed.
#[derive(Debug, Error)]
pub enum EvalError {
    /// A sweep file (or a file it names) is unreadable or wrong; `field` is the JSON path
    /// (e.g. `axes.jerk_deg_per_s3.steps`), empty for the whole file.
    #[error("{file}: {}{message}", located(field))]
    Sweep {
        /// The sweep file, or the file it names that is wrong.
        file: String,
        /// JSON path of the offending value; empty for the whole file.
        field: String,
        /// What is wrong and what was expected.
        message: String,
    },
    /// A plan, machine or reference file named by the sweep failed to load.
    #[error("{file}: {field}: {message}")]
    Input {
        /// The file that failed to load.
        file: String,
        /// The sweep file's field naming it.
        field: String,
        /// Why it failed to load.
        message: String,
    },
    /// A `--shard K/N` argument that is not two integers with 1 <= K <= N.
    #[error("shard \"{0}\": expected K/N with 1 <= K <= N (e.g. 2/3)")]
    Shard(String),
    /// Shard outputs that cannot be merged into one table.
    #[error("{file}: {message}")]
    Merge {
        /// The shard output that cannot be merged.
        file: String,
        /// Why it cannot be merged.
        message: String,
    },
    /// Reading or writing a file failed.
    #[error("{0}")]
    Io(#[from] std::io::Error),
}

/// Why a (plan × window/ELST/beam) variant does not resolve. Its combinations become `invalid`
/// rows whose message is this error's text, so one bad variant does not stop the sweep.
#[derive(Debug, Error)]
pub(crate) enum VariantError {
    /// A scanning speed or burst switching setting on a machine whose beam model has none (a
    /// loaded sweep refuses those axes on such a machine, so this is a guard).
    #[error("machine \"{machine}\": its beam model has no {lacks} (kind {kind})")]
    NotScanning {
        machine: String,
        kind: &'static str,
        lacks: &'static str,
    },
    /// A spill setting on a machine without spills (a loaded sweep refuses those axes on such a
    /// machine, so this is a guard).
    #[error("machine \"{machine}\": its beam model has no spills")]
    NoSpills { machine: String },
    /// The plan does not resolve on the varied machine (e.g. a window wider than the spacing).
    #[error(transparent)]
    Plan(#[from] arcsim_plan::PlanError),
}

fn located(field: &str) -> String {
    if field.is_empty() {
        String::new()
    } else {
        format!("{field}: ")
    }
}

impl EvalError {
    pub(crate) fn sweep(file: &str, field: impl Into<String>, message: impl Into<String>) -> Self {
        EvalError::Sweep {
            file: file.to_string(),
            field: field.into(),
            message: message.into(),
        }
    }
}
