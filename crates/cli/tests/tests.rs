//! The integration tests of `arcsim`, one module per file, linked into one test binary.

mod answers;
mod build_reuse;
mod cli;
mod controller_figures;
mod csv_tables;
mod docs_examples;
mod edges;
mod free_motion_oracle;
mod hardening;
mod log_tools;
mod logs;
mod messages;
mod one_speed;
mod probe;
mod profile_reversal;
mod python;
mod report;
mod resequence;
mod slurm;
mod spots;
mod sweep_beam;
mod util;
