//! The integration tests of `arcsim-evaluator`, one module per file, linked into one test binary.

mod beam_axes;
mod csv_schema;
mod lazy_memory;
mod monte_carlo;
mod sweep;
mod util;
