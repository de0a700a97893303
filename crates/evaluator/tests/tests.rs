//! The integration tests of `arcsim-evaluator`, one module per file, linked into one test binary.

#![allow(
    clippy::too_many_lines,
    reason = "the 100-line rule is for the crates' code; a test or benchmark reads top to bottom"
)]

mod beam_axes;
mod csv_schema;
mod lazy_memory;
mod monte_carlo;
mod sweep;
mod util;
