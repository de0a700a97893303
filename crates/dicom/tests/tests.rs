//! The integration tests of `arcsim-dicom`, one module per file, linked into one test binary.

mod bundled;
mod import;
mod write_back;
