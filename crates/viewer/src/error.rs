//! Errors of the viewer output.

use std::path::PathBuf;

/// What can go wrong while logging or sending to Rerun.
#[derive(Debug, thiserror::Error)]
pub enum ViewerError {
    /// The delivery was simulated without a timeline: there is nothing to sample.
    #[error("the delivery has no timeline (simulate it with a timeline to view it)")]
    NoTimeline,

    /// The sample interval is not a finite number > 0.
    #[error("invalid sample interval {0} s (expected a finite number > 0)")]
    InvalidSampleDt(f64),

    /// The sample interval gives more samples than a recording takes (it would not fit in
    /// memory or the viewer).
    #[error("sample interval {dt_s} s gives {samples} samples over {total_s:.1} s (at most {max}); use a larger interval")]
    TooManySamples {
        /// The sample interval, s.
        dt_s: f64,
        /// The delivery's duration, s.
        total_s: f64,
        /// The samples it gives.
        samples: f64,
        /// The most samples accepted.
        max: usize,
    },

    /// The `.rrd` file could not be created.
    #[error("cannot write {}: {source}", path.display())]
    Save {
        /// The file.
        path: PathBuf,
        /// Why it failed.
        source: rerun::RecordingStreamError,
    },

    /// No viewer could be started (the `rerun` binary is missing or failed).
    #[error("cannot start a Rerun viewer: {0}\nInstall the viewer of the same version (`pip install rerun-sdk==0.36.3`, which provides `rerun`), or write a file instead and open it later.")]
    Spawn(rerun::SpawnError),

    /// The viewer URL is not valid.
    #[error("invalid Rerun viewer URL '{url}' (expected e.g. rerun+http://127.0.0.1:9876/proxy): {source}")]
    Url {
        /// The URL as given.
        url: String,
        /// Why it is not valid.
        source: rerun::RecordingStreamError,
    },

    /// The recording could not be delivered to its file or viewer.
    #[error("could not deliver the recording to {target}: {source}")]
    Flush {
        /// The file or viewer URL.
        target: String,
        /// Why it failed.
        source: rerun::sink::SinkFlushError,
    },

    /// Logging into the recording stream failed.
    #[error("Rerun logging failed: {0}")]
    Log(#[from] rerun::RecordingStreamError),

    /// A component could not be serialized.
    #[error("Rerun serialization failed: {0}")]
    Serialize(#[from] rerun::SerializationError),
}
