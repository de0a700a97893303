//! What a calibration takes and gives: the logged runs, the fitted values with their intervals,
//! the residuals and the report, and the errors.

use arcsim_plan::{ArcPlan, Machine, TimingSpread};
use arcsim_sequencer::SequenceError;
use serde::Serialize;
use thiserror::Error;

use crate::kinematics::ObservedKinematics;
use crate::matching::MatchError;
use crate::DeliveryLog;

/// Bootstrap draws behind each timing's interval.
pub const BOOTSTRAP_DRAWS: usize = 200;

/// How the ELST is fitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ElstFit {
    /// One time up, one down, one at the same energy.
    #[default]
    Constant,
    /// The upward time a line in the energy step (`up_coeffs_s = [c0, c1]`).
    Polynomial,
}

/// One logged delivery of one plan.
#[derive(Debug, Clone)]
pub struct LoggedRun {
    /// The plan's name (as the user gave it).
    pub plan_name: String,
    /// The plan.
    pub plan: ArcPlan,
    /// Its log.
    pub log: DeliveryLog,
}

/// Why a calibration cannot be made.
#[derive(Debug, Error)]
pub enum CalibrateError {
    /// A plan does not resolve on the base machine.
    #[error("{plan}: {source}")]
    Plan {
        /// The plan.
        plan: String,
        /// Why.
        source: arcsim_plan::PlanError,
    },
    /// A log does not fit its plan.
    #[error(transparent)]
    Match(#[from] MatchError),
    /// A simulation for the residuals failed.
    #[error("{plan}: {source}")]
    Simulate {
        /// The plan.
        plan: String,
        /// Why.
        source: SequenceError,
    },
    /// No run given.
    #[error("no plan and log to calibrate from")]
    NoRuns,
    /// A motion model the calibration cannot fit timings under.
    #[error("calibration under {} is not built (its inner moves are cruises, which show no switching time or gantry limit to fit): calibrate under {} and simulate with --motion {}", .motion.describe(), arcsim_plan::Motion::names_where(arcsim_plan::Motion::calibrates_from_logs), .motion.name())]
    NotCalibratable {
        /// The motion model asked for.
        motion: arcsim_plan::Motion,
    },
}

/// One fitted (or kept) machine value.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FittedValue {
    /// The machine file's field, e.g. `elst.up_s`.
    pub field: String,
    /// Its unit.
    pub unit: String,
    /// The base machine's value (`None`: the base has no such field).
    pub base: Option<f64>,
    /// The value written to the fitted machine.
    pub value: f64,
    /// 95 % interval, when fitted.
    pub interval: Option<[f64; 2]>,
    /// Observations behind it.
    pub observations: usize,
    /// Whether the logs determine it (otherwise the base value is kept).
    pub determined: bool,
    /// How it was found, or why it was not.
    pub note: String,
}

/// A log's total, logged and predicted by the base and the fitted machine.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Residual {
    /// The plan.
    pub plan: String,
    /// The log.
    pub log: String,
    /// From the first beam-on to the last beam-off in the log, s.
    pub logged_total_s: f64,
    /// The base machine's simulated total, s.
    pub base_total_s: f64,
    /// The fitted machine's simulated total, s.
    pub fitted_total_s: f64,
    /// (base − logged) / logged, %.
    pub base_error_pct: f64,
    /// (fitted − logged) / logged, %.
    pub fitted_error_pct: f64,
}

/// What a calibration found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CalibrationReport {
    /// The logs, in the order given.
    pub logs: Vec<String>,
    /// Every value the calibration considers.
    pub values: Vec<FittedValue>,
    /// The spreads written to the fitted machine.
    pub spread: TimingSpread,
    /// The observed gantry motion over all logs.
    pub observed: ObservedKinematics,
    /// Per log, the residual before and after.
    pub residuals: Vec<Residual>,
    /// Angle samples the reader rejected as encoder glitches and replaced, over all the logs
    /// ([`DeliveryLog::glitches_rejected`]).
    pub glitches_rejected: usize,
    /// How the controller was decided (`None` from [`calibrate`] alone, which fits under the
    /// motion it is given).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub controller: Option<arcsim_plan::ControllerEvidence>,
    /// What the fit leaves doubtful: residuals above the noise, with their likely cause.
    pub warnings: Vec<String>,
}

impl CalibrationReport {
    /// The value row of `field` (e.g. `elst.down_s`), if the calibration considered it.
    pub fn value(&self, field: &str) -> Option<&FittedValue> {
        self.values.iter().find(|v| v.field == field)
    }
}

/// The fitted machine and its report.
#[derive(Debug, Clone)]
pub struct Calibration {
    /// A complete machine: the base with the fitted values.
    pub machine: Machine,
    /// What was fitted, how well, and what was not.
    pub report: CalibrationReport,
}

/// The lowest cluster of durations: its centre and spread, and how many it holds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cluster {
    /// The peak of the values' density.
    pub centre: f64,
    /// Robust standard deviation of the cluster: 1.4826 × the median distance below the centre.
    pub sd: f64,
    /// Members.
    pub count: usize,
}

pub(super) fn kept(field: &str, unit: &str, base: Option<f64>, n: usize, why: &str) -> FittedValue {
    FittedValue {
        field: field.into(),
        unit: unit.into(),
        base,
        value: base.unwrap_or(0.0),
        interval: None,
        observations: n,
        determined: false,
        note: why.into(),
    }
}

/// A value row determined by a fit by the model ([`crate::transitions::fit_by_gaps`]).
pub(super) fn record_gap_fit(
    row: &mut FittedValue,
    fit: &crate::transitions::GapFit,
    note: String,
) {
    row.value = fit.value;
    row.interval = Some(fit.interval);
    row.observations = fit.transitions;
    row.determined = true;
    row.note = note;
}

pub(super) fn list(fields: &[&str]) -> String {
    if fields.is_empty() {
        "nothing".to_string()
    } else {
        fields.join(", ")
    }
}
