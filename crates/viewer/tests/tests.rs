//! The integration tests of `arcsim-viewer`, one module per file, linked into one test binary.

mod grpc;
mod rrd_roundtrip;
mod spawn;
mod spots;
mod util;
