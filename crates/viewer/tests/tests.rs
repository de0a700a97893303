//! The integration tests of `arcsim-viewer`, one module per file, linked into one test binary.

#![allow(
    clippy::too_many_lines,
    reason = "the 100-line rule is for the crates' code; a test or benchmark reads top to bottom"
)]

mod grpc;
mod rrd_roundtrip;
mod spawn;
mod spots;
mod util;
