//! arcsim-log: delivery logs in the `arcsim-log/1` CSV format (documented in `docs/results.md`).
//!
//! [`read_log`] streams a log file, checks it row by row (times strictly increasing, numbers
//! finite, required columns present, columns found by name or through a [`ColumnMap`]) and
//! locates every problem by file, line and column. [`virtual_log`] samples a simulated delivery
//! as the log a machine would write, with optional seeded encoder noise; [`to_csv`] writes it.

#![warn(missing_docs)]

mod columns;
mod error;
mod read;
mod sample;
mod virtual_log;
mod write;

pub use columns::{ColumnMap, Field};
pub use error::LogError;
pub use read::{parse_log, read_log, MAX_LOG_BYTES};
pub use sample::{DeliveryLog, LogSample};
pub use virtual_log::{
    check_options, virtual_log, VirtualLogError, VirtualLogOptions, MAX_LOG_SAMPLES,
};
pub use write::to_csv;

/// The format tag of a delivery log, as `docs/results.md` names it.
pub const LOG_FORMAT: &str = "arcsim-log/1";
