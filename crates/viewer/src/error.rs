//! Errors of the viewer output.

use std::path::PathBuf;

/// What can go wrong while logging or sending to Rerun.
#[derive(Debug, thiserror::Error)]
pub enum ViewerError {
    #[error("the delivery has no timeline (simulate it with a timeline to view it)")]
    NoTimeline,

    #[error("invalid sample interval {0} s (expected a finite number > 0)")]
    InvalidSampleDt(f64),

    #[error("sample interval {dt_s} s gives {samples} samples over {total_s:.1} s (at most {max}); use a larger interval")]
    TooManySamples {
        dt_s: f64,
        total_s: f64,
        samples: f64,
        max: usize,
    },

    #[error("cannot write {}: {source}", path.display())]
    Save {
        path: PathBuf,
        source: rerun::RecordingStreamError,
    },

    #[error("cannot start a Rerun viewer: {0}\nInstall the viewer of the same version (`pip install rerun-sdk==0.36.3`, which provides `rerun`), or write a file instead and open it later.")]
    Spawn(rerun::SpawnError),

    #[error("invalid Rerun viewer URL '{url}' (expected e.g. rerun+http://127.0.0.1:9876/proxy): {source}")]
    Url {
        url: String,
        source: rerun::RecordingStreamError,
    },

    #[error("could not deliver the recording to {target}: {source}")]
    Flush {
        target: String,
        source: rerun::sink::SinkFlushError,
    },

    #[error("Rerun logging failed: {0}")]
    Log(#[from] rerun::RecordingStreamError),

    #[error("Rerun serialization failed: {0}")]
    Serialize(#[from] rerun::SerializationError),
}
