//! The integration tests of `arcsim-plan`, one module per file, linked into one test binary.

mod atom_cases;
mod beam_models;
mod bundled;
mod elst_tables;
mod machine_resolve;
mod opentps;
mod spills;
mod validation;
mod window_shares;
