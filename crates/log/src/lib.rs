//! arcsim-log: delivery logs in the `arcsim-log/1` CSV format (documented in `docs/results.md`).
//!
//! [`read_log`] streams a log file, checks it row by row (times strictly increasing, numbers
//! finite, required columns present, columns found by name or through a [`ColumnMap`]) and
//! locates every problem by file, line and column. [`virtual_log`] samples a simulated delivery
//! as the log a machine would write, with optional seeded encoder noise; [`to_csv`] writes it.
//!
//! [`match_layers`] finds the plan's layers in a log's beam-on segments, [`compare`] sets a log
//! beside a simulation of its plan, and [`calibrate`] fits a machine to one or more logs
//! ([`kinematics`]: what the angle trace shows of the gantry's limits). [`calibrate_spots`] fits
//! the `scanning` beam model to per-spot logs ([`read_spot_log`]; [`read_spots`] also takes an
//! IBA-style log folder, which [`iba`] reads and writes).

#![warn(missing_docs)]

mod calibrate;
mod columns;
mod compare;
mod controller;
mod error;
pub mod iba;
mod joint;
pub mod kinematics;
mod matching;
mod mu_check;
mod plateau_replay;
mod read;
mod sample;
mod spots;
mod transitions;
mod virtual_log;
mod write;

pub use calibrate::{
    calibrate, lowest_cluster, CalibrateError, Calibration, CalibrationReport, Cluster, ElstFit,
    FittedValue, LoggedRun, Residual, BOOTSTRAP_DRAWS,
};
pub use columns::{ColumnMap, Field};
pub use compare::{
    compare, ClassStats, Comparison, LayerComparison, MotionFit, TimeSplit, WORST_LAYERS,
};
pub use controller::{calibrate_controller, RESIDUAL_WARNING_PCT};
pub use error::LogError;
pub use matching::{
    angle_diff_deg, beam_segments, match_layers, BeamSegment, LoggedLayer, MatchError,
    ANGLE_TOLERANCE_DEG, LOG_ENERGY_TOLERANCE_MEV, UNIT_SLIP_BAND,
};
pub use mu_check::{check_mu, LAYER_MU_TOLERANCE, MU_RATIO_TOLERANCE};
pub use read::{
    parse_log, read_log, MAX_ANGLE_MAGNITUDE_DEG, MAX_LOG_BYTES, MAX_SPAN_S, MAX_TIME_S,
};
pub use sample::{
    BeamInterval, DeliveryLog, LogSample, GLITCH_FLOOR_DEG, GLITCH_MAD_FACTOR, GLITCH_NEIGHBOURS,
    LONG_GAP_PERIODS,
};
pub use spots::{
    calibrate_spots, is_spot_log_header, parse_spot_log, read_spot_log, read_spots, LoggedSpot,
    SpotCalibrateError, SpotCalibration, SpotLog, SpotResidual, SpotRun, SPOT_LOG_COLUMNS,
};
pub use virtual_log::{
    check_options, virtual_log, VirtualLogError, VirtualLogOptions, MAX_ANGLE_NOISE_DEG,
    MAX_LOG_SAMPLES,
};
pub use write::to_csv;

/// The format tag of a delivery log, as `docs/results.md` names it.
pub const LOG_FORMAT: &str = "arcsim-log/1";
