//! The integration tests of `arcsim-report`, one module per file, linked into one test binary.

mod beam_axes;
