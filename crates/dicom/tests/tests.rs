//! The integration tests of `arcsim-dicom`, one module per file, linked into one test binary.

mod bundled;
mod import;
mod records;
mod write_back;
