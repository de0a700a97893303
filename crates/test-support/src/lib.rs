#![warn(missing_docs)]
//! Test support for the arcsim workspace: what several crates' tests (and the DICOM example) share.
//! A dev-dependency only, never published or used by library code.
//!
//! - [`temp_dir`] and [`temp_file`]: a fresh temporary directory per call, in the target directory;
//! - [`Rng`]: a small seeded generator, so random test cases are the same in every run;
//! - [`cannot_run`] and [`atom_reference`]: a test that cannot run fails and says why; the ATOM
//!   article's data from the repository's `reference/`;
//! - [`HIDDEN_MACHINE_JSON`]: the machine whose simulated deliveries stand in for delivery logs;
//! - [`in_own_process`]: a test run alone in a child process, for one that changes what the whole
//!   test binary shares;
//! - `dicom` (feature `dicom`): DICOM RT (Ion) Plan files generated in memory, complete or with
//!   chosen attributes missing or malformed.

mod alone;
mod ci;
#[cfg(feature = "dicom")]
pub mod dicom;
mod machines;
mod rng;
mod temp;

pub use alone::in_own_process;
pub use ci::{atom_reference, atom_reference_path, cannot_run};
pub use machines::HIDDEN_MACHINE_JSON;
pub use rng::Rng;
pub use temp::{temp_dir, temp_file};
