//! Per-spot logs: reading them ([`read_spot_log`]) and fitting the `scanning` beam model to
//! them ([`calibrate_spots`]), a synchrotron's spills included.

mod fit;
mod moves;
mod read;
mod spills;

pub use fit::{calibrate_spots, SpotCalibrateError, SpotCalibration, SpotResidual, SpotRun};
pub use read::{
    is_spot_log_header, parse_spot_log, read_spot_log, read_spots, LoggedSpot, SpotLog,
    SPOT_LOG_COLUMNS,
};
