//! The integration tests of `arcsim-resequence`, one module per file, linked into one test binary.

mod brute_force;
mod dose;
mod util;
mod window_shares;
