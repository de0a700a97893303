//! The integration tests of `arcsim-log`, one module per file, linked into one test binary.

mod calibration;
mod compare;
mod controller;
mod faults;
mod read_errors;
mod reggui;
mod spots;
mod virtual_logs;
