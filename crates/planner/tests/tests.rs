//! The integration tests of `arcsim-planner`, one module per file, linked into one test binary.

#![allow(
    clippy::too_many_lines,
    reason = "the 100-line rule is for the crates' code; a test or benchmark reads top to bottom"
)]

mod integration;
mod known_answers;
mod min_duration_and_servo;
mod random_moves;
mod reversal_min_duration;
mod util;
