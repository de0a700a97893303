//! The integration tests of `arcsim-sequencer`, one module per file, linked into one test binary.

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
