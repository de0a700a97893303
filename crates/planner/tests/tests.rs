//! The integration tests of `arcsim-planner`, one module per file, linked into one test binary.

mod integration;
mod known_answers;
mod min_duration_and_servo;
mod random_moves;
mod reversal_min_duration;
mod util;
