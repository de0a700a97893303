//! The integration tests of `arcsim`, one module per file, linked into one test binary.

#![allow(
    clippy::too_many_lines,
    reason = "the 100-line rule is for the crates' code; a test or benchmark reads top to bottom"
)]

mod answers;
mod build_reuse;
mod cli;
mod csv_tables;
mod docs_examples;
mod docs_figures;
mod edges;
mod free_motion_oracle;
mod hardening;
mod iba;
mod log_tools;
mod logs;
mod messages;
mod one_speed;
mod probe;
mod profile_reversal;
mod python;
mod records;
mod report;
mod resequence;
mod slurm;
mod spot_calibration;
mod spots;
mod sweep_beam;
mod util;
