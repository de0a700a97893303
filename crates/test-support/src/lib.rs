//! Test support for the arcsim workspace: what several crates' tests (and the DICOM example) share.
//! A dev-dependency only, never published or used by library code.
//!
//! - [`temp_dir`] and [`temp_file`]: a fresh temporary directory per call, in the target directory;
//! - [`Rng`]: a small seeded generator, so random test cases are the same in every run;
//! - `dicom` (feature `dicom`): DICOM RT (Ion) Plan files generated in memory, complete or with
//!   chosen attributes missing or malformed.

#[cfg(feature = "dicom")]
pub mod dicom;
mod rng;
mod temp;

pub use rng::Rng;
pub use temp::{temp_dir, temp_file};
