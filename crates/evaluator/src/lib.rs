#![warn(missing_docs)]
//! # arcsim-evaluator
//!
//! Evaluates many (plan × machine variant × schedule) combinations in parallel and summarises
//! them: how long each plan takes at each setting of the gantry limits (J, A, V), energy switching
//! (ELST), window and beam (scanning speed, dose-rate scale), what limited it, and which change of
//! the base machine buys how much.
//!
//! A sweep file (`arcsim-sweep/1`, see [`sweep_file`] and `scenarios/README.md`) names the plans,
//! the base machine, the axes and the schedules. [`Sweep::load`] reads it, [`Evaluator::new`]
//! resolves each (plan × ELST/window/beam variant) once, [`Evaluator::run`] evaluates combinations
//! on the current rayon pool and delivers [`Row`]s in index order (identical for any thread count),
//! [`Evaluator::summarize`] builds the [`Summary`]. [`Shard`] splits a sweep for a job array and
//! [`merge_csv`] joins the shards' CSV tables into the single-run table, byte for byte.
//!
//! Nothing is allocated per combination before its rows are computed: axes are kept as written and
//! combinations decoded from their index, shards are index progressions ([`ShardIndices`]), and
//! [`Evaluator::run`] reads its [`IndexList`] a chunk at a time. A sweep of more than
//! [`MAX_COMBINATIONS`] combinations is refused when it is loaded.
//!
//! [`monte_carlo`] draws a machine's timing spreads (measured by `arcsim calibrate`) per switch
//! and per layer and gives the percentiles of one plan's total.

mod csv;
mod error;
mod mode;
mod monte_carlo;
mod run;
mod shard;
mod summary;
mod sweep;
pub mod sweep_file;

pub use csv::{merge_csv, write_csv_header, write_csv_row, CsvLineNumbers, CSV_HEADER};
pub use error::EvalError;
pub use mode::RunMode;
pub use monte_carlo::{
    machine_monte_carlo, machine_monte_carlo_observed, monte_carlo, monte_carlo_passes,
    MachineMonteCarlo, MonteCarlo, MAX_DRAWS,
};
pub use run::{Evaluator, Outcome, Row, Status};
pub use shard::{IndexList, Shard, ShardIndices};
pub use summary::{
    describe_setting, describe_steps, short, table, AxisTotal, AxisTotals, Change, Entry, Point,
    Sensitivity, Step, Summary, PROFILE_MAX_POINTS, TIE_TOLERANCE,
};
pub use sweep::{
    Axis, Defaults, Grid, ResequencedPlan, ScheduleGrid, Setting, Sweep, SweepPlan,
    DOSE_RATE_SCALE_RANGE, MAX_COMBINATIONS, RESEQUENCED_SUFFIX,
};
pub use sweep_file::{parse_sweep_file, AxisSpec, Resequence, Scale, Target, SWEEP_FORMAT};

/// Format of the JSON results document ([`Results`]).
pub const RESULTS_FORMAT: &str = "arcsim-sweep-results/1";

/// The JSON results of a run: its rows and summary (borrowed: written once, at the end).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Results<'a> {
    /// Always [`RESULTS_FORMAT`].
    pub format: &'static str,
    /// The sweep's name.
    pub sweep: String,
    /// Combinations in the whole sweep.
    pub combinations: usize,
    /// `"K/N"` for a shard.
    pub shard: Option<String>,
    /// False when the run was interrupted: `rows` holds those finished.
    pub complete: bool,
    /// The evaluated rows, in index order.
    pub rows: &'a [Row],
    /// Absent when the run was interrupted.
    pub summary: Option<&'a Summary>,
}
