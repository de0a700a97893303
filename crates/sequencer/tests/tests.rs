//! The integration tests of `arcsim-sequencer`, one module per file, linked into one test binary.

#![allow(
    clippy::too_many_lines,
    reason = "the 100-line rule is for the crates' code; a test or benchmark reads top to bottom"
)]

mod free_acceptance;
mod free_motion;
mod free_optimality;
mod limiter;
mod one_speed;
mod properties;
mod small_arcs;
mod spots;
mod switching;
mod util;
