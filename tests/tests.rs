//! The integration tests of the workspace (`arcsim-suite`), one module per file, linked into one test binary.

mod atom_cases;
mod optimal_monotone;
mod pinned_totals;
mod structure;
