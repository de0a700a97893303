//! A machine fitted to delivery logs: what the logs determine, with 95 % intervals, and the
//! base machine's value (said so) where they do not.
//!
//! - **ELST** (up, down, same energy): a switch lasts its ELST unless the gantry makes it wait.
//!   A first fit takes the peak of the lowest cluster of each kind's beam-off gaps
//!   ([`lowest_cluster`]); then each plan is simulated on the first fit, and the ELST is the
//!   median of the gaps whose switch the simulation times at its ELST (when there are 3), its
//!   spread their robust spread less the log's time resolution. With [`ElstFit::Polynomial`]
//!   the upward time is a line in the energy step, fitted to those switches.
//! - **Beam** (`per_mu` machines): a layer's beam-on time is linear in the time per MU and the
//!   time between spots (its MU and its number of spot-to-spot moves); least squares over every
//!   logged layer.
//! - **Gantry**: the plateau levels of the observed speed, acceleration and deceleration, the
//!   jerk from the acceleration's reversals ([`crate::kinematics`]); a level not held long
//!   enough is not the limit (the base value is kept, or raised to it when it is higher).
//!
//! Intervals: bootstrap over the switches and layers (a fixed seed, [`BOOTSTRAP_DRAWS`] draws)
//! for the timings, the fit noise over the plateau for the gantry.

use arcsim_plan::{
    layer_beam_time, resolve, ArcPlan, BeamModel, ElstModel, Machine, PerMuBeam, ResolvedArc,
    TimingSpread,
};
use arcsim_sequencer::{simulate, Options, SequenceError};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;
use thiserror::Error;

use crate::compare::switch_class;
use crate::kinematics::{observe, trace, ObservedKinematics, Plateau};
use crate::matching::{match_layers, LoggedLayer, MatchError};
use crate::DeliveryLog;

mod beam;
mod elst;
mod gantry;
mod gaps;
mod report;
mod stats;

use beam::*;
use elst::*;
use gantry::*;
use gaps::*;
use report::*;
use stats::*;
pub use stats::lowest_cluster;
pub(crate) use stats::{mad_sd, median};


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

/// Fits a machine to `runs`, starting from `base` (see the module documentation); `options` are
/// the simulations' (for the residuals).
pub fn calibrate(
    base: &Machine,
    runs: &[LoggedRun],
    elst_fit: ElstFit,
    options: &Options,
) -> Result<Calibration, CalibrateError> {
    if runs.is_empty() {
        return Err(CalibrateError::NoRuns);
    }
    let matched = match_runs(base, runs)?;
    let period = matched.iter().map(|m| m.period_s).fold(0.0, f64::max);
    // Each edge is within half a period: a gap or a beam-on time is off by up to one period,
    // variance period²/6.
    let resolution_sd = period / 6f64.sqrt();
    let all_gaps: Vec<Gap> = matched.iter().flat_map(|m| gaps(m, base)).collect();
    let mut values = Vec::new();
    let mut machine = base.clone();
    let first = fit_elst(base, &all_gaps, None, elst_fit, resolution_sd, &mut values);
    machine.elst = first.model;
    let beam = fit_beam(base, runs, &matched, resolution_sd, &mut values);
    if let Some(b) = beam.model {
        machine.beam = b;
    }
    let traces: Vec<_> = runs.iter().map(|r| trace(&r.log)).collect();
    let observed = observe(&traces);
    let traced = runs.iter().any(|r| r.log.edge_resolution_s.is_none());
    fit_gantry(base, (&observed, traced), &mut machine, &mut values);
    if options.motion == arcsim_sequencer::Motion::Constant && moving(base, &observed) {
        question_speed_plateau(base, &mut machine, runs, options, &observed, &mut values);
        // A seed for the second ELST pass and the joint fit, which refines it: 0.1 % is enough.
        refine_jerk(&mut machine, (runs, &matched), options, &mut values);
    }
    // After the J seed: a replay simulates moves shaped by J as the logs' are.
    crate::plateau_replay::correct_plateaus(&mut machine, runs, options, &observed, &mut values);
    let clean = clean_gaps(base, &machine, runs, &matched, options)?;
    let mut elst_values = Vec::new();
    let elst = fit_elst(
        base,
        &all_gaps,
        Some(&clean),
        elst_fit,
        resolution_sd,
        &mut elst_values,
    );
    machine.elst = elst.model;
    values.retain(|v| !v.field.starts_with("elst."));
    values.splice(0..0, elst_values);
    let elst_sd = elst.sd;
    let spread = TimingSpread {
        elst_up_sd_s: elst_sd[0],
        elst_down_sd_s: elst_sd[1],
        elst_same_sd_s: elst_sd[2],
        beam_time_sd_fraction: beam.sd_fraction,
    };
    if options.motion == arcsim_sequencer::Motion::Constant {
        elst_by_model(&mut machine, runs, &matched, options, &mut values);
        let noise = crate::joint::Noise {
            spread: &spread,
            resolution_sd_s: resolution_sd,
        };
        refine_by_model_jointly(&mut machine, (runs, &matched), options, noise, &mut values);
    }
    bound_unseen_elst(
        &mut machine,
        runs,
        &matched,
        &all_gaps,
        options,
        &mut values,
    );
    let clock_s = runs
        .iter()
        .filter_map(|r| r.log.edge_resolution_s)
        .fold(0.0, f64::max);
    unresolved_by_clock(&mut machine, clock_s, &mut values);
    machine.spread = Some(spread);
    let uncertainty = uncertainty_of(&values);
    machine.uncertainty = uncertainty.any().then_some(uncertainty);
    describe(&mut machine, base, runs, &values);
    let residuals = residuals(base, &machine, runs, &matched, options)?;
    let warnings = table_replaced(base, &machine).into_iter().collect();
    Ok(Calibration {
        machine,
        report: CalibrationReport {
            logs: runs.iter().map(|r| r.log.source.clone()).collect(),
            values,
            spread,
            observed,
            residuals,
            glitches_rejected: runs.iter().map(|r| r.log.glitches_rejected).sum(),
            controller: None,
            warnings,
        },
    })
}
