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

/// The median (the mean of the middle two for an even count); sorts `v`.
pub(crate) fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

pub(crate) fn mad_sd(v: &[f64], centre: f64) -> f64 {
    let mut dev: Vec<f64> = v.iter().map(|x| (x - centre).abs()).collect();
    1.4826 * median(&mut dev)
}

/// The lowest cluster of `residuals` (gaps less a model, or the gaps themselves): from the
/// median of the lowest tenth, a mean shift (Gaussian kernel, bandwidth 3 % of that start, at
/// least `floor_sd`, the time resolution) climbs to the nearest peak of the values' density;
/// the spread is 1.4826 × the median distance below the peak (which the gaps the gantry
/// lengthened do not reach); the cluster holds the values within three spreads of the peak.
pub fn lowest_cluster(residuals: &[f64], floor_sd: f64) -> Option<Cluster> {
    if residuals.is_empty() {
        return None;
    }
    let mut sorted = residuals.to_vec();
    sorted.sort_by(f64::total_cmp);
    let k0 = (sorted.len() / 10).max(3).min(sorted.len());
    let mut centre = median(&mut sorted[..k0].to_vec());
    let h = (0.03 * centre.abs()).max(floor_sd).max(1e-9);
    for _ in 0..500 {
        let (mut sw, mut swx) = (0.0, 0.0);
        for x in &sorted {
            let w = (-0.5 * ((x - centre) / h).powi(2)).exp();
            sw += w;
            swx += w * x;
        }
        let next = if sw > 0.0 { swx / sw } else { centre };
        let settled = (next - centre).abs() <= 1e-12 * centre.abs().max(1.0);
        centre = next;
        if settled {
            break;
        }
    }
    let mut below: Vec<f64> = sorted
        .iter()
        .filter(|x| **x < centre)
        .map(|x| centre - x)
        .collect();
    let sd = match below.len() {
        0 | 1 => floor_sd,
        _ => (1.4826 * median(&mut below)).max(floor_sd),
    };
    let count = sorted
        .iter()
        .filter(|x| (**x - centre).abs() <= 3.0 * sd)
        .count();
    Some(Cluster { centre, sd, count })
}

/// Percentile interval (2.5 %, 97.5 %) of a statistic over bootstrap resamples of `n` items.
fn bootstrap(n: usize, seed: u64, stat: &dyn Fn(&[usize]) -> Option<f64>) -> Option<[f64; 2]> {
    if n < 2 {
        return None;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut values: Vec<f64> = (0..BOOTSTRAP_DRAWS)
        .filter_map(|_| {
            let idx: Vec<usize> = (0..n).map(|_| rng.random_range(0..n)).collect();
            stat(&idx).filter(|x| x.is_finite())
        })
        .collect();
    if values.len() < BOOTSTRAP_DRAWS / 2 {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let at = |q: f64| values[((values.len() - 1) as f64 * q).round() as usize];
    Some([at(0.025), at(0.975)])
}

/// One logged run, resolved and matched.
struct Matched {
    arcs: Vec<ResolvedArc>,
    layers: Vec<LoggedLayer>,
    period_s: f64,
}

/// A beam-off gap between two layers of one arc.
#[derive(Debug, Clone, Copy)]
struct Gap {
    class: &'static str,
    step_mev: f64,
    duration_s: f64,
    /// The layer it leads to (delivery order).
    to_layer: usize,
}

/// The beam-off gaps between a run's consecutive layers of one arc that are energy switches of
/// `base`'s ELST model: a layer changed inside a spill (multi-energy extraction: the spill
/// model's in-spill switching time) or with the plan's own switching time is not, and neither
/// is the gap after a layer that ends early ([`LoggedLayer::ends_early`]).
fn gaps(m: &Matched, base: &Machine) -> Vec<Gap> {
    let flat: Vec<(usize, &arcsim_plan::ResolvedLayer)> = m
        .arcs
        .iter()
        .flat_map(|a| a.layers.iter().map(move |l| (a.arc_index, l)))
        .collect();
    m.layers
        .windows(2)
        .filter(|w| !w[0].ends_early)
        .filter_map(|w| {
            let ((arc_a, a), (arc_b, b)) = (flat[w[0].index], flat[w[1].index]);
            let elst = base.elst.switch_time_s(a.energy_mev, b.energy_mev);
            let by_elst = (b.switch_in_s - elst).abs() <= 1e-9 * elst.max(1.0);
            (arc_a == arc_b && by_elst).then(|| Gap {
                class: switch_class(a.energy_mev, b.energy_mev),
                step_mev: b.energy_mev - a.energy_mev,
                duration_s: w[1].start_s - w[0].end_s,
                to_layer: w[1].index,
            })
        })
        .collect()
}

/// The median step between the log's samples (the mean of the middle two for an even count),
/// or a log of intervals' edge resolution.
fn typical_period(log: &DeliveryLog) -> f64 {
    if let Some(r) = log.edge_resolution_s {
        return r;
    }
    let mut d: Vec<f64> = log
        .samples
        .windows(2)
        .map(|w| w[1].t_s - w[0].t_s)
        .collect();
    if d.is_empty() {
        0.0
    } else {
        median(&mut d)
    }
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

/// The warning when the base machine's ELST is a table by energy, which a calibration does not
/// fit: the fitted machine carries a constant or polynomial model in its place (it once did so
/// without a word).
fn table_replaced(base: &Machine, fitted: &Machine) -> Option<String> {
    let entries = match &base.elst {
        ElstModel::ByEnergy {
            up_s_by_energy,
            down_s_by_energy,
            ..
        } => up_s_by_energy.len() + down_s_by_energy.len(),
        ElstModel::ByEnergyPair { switch_s, .. } => switch_s.iter().map(Vec::len).sum(),
        ElstModel::Constant { .. } | ElstModel::Polynomial { .. } => return None,
    };
    Some(format!(
        "the base machine's ELST is a table ({}, {entries} entries), which a calibration does not \
         fit: the fitted machine has a {} model in its place, fitted from the logs' switches \
         (to keep the table, copy the base machine's `elst` into the fitted file)",
        base.elst.kind(),
        fitted.elst.kind()
    ))
}

/// The second ELST pass's gaps: those whose switch a simulation on the first fit (`machine`)
/// times at its ELST carry the ELST alone (no gap the gantry lengthened pulls it up).
fn clean_gaps(
    base: &Machine,
    machine: &Machine,
    runs: &[LoggedRun],
    matched: &[Matched],
    options: &Options,
) -> Result<Vec<Gap>, CalibrateError> {
    let lasting = lasting_switches(machine, runs, options)?;
    Ok(matched
        .iter()
        .zip(&lasting)
        .flat_map(|(m, lasts)| {
            gaps(m, base)
                .into_iter()
                .filter(|g| lasts.get(g.to_layer).copied().unwrap_or(false))
        })
        .collect())
}

/// Each run's log matched to its plan's layers on `base` (its MU column checked too).
fn match_runs(base: &Machine, runs: &[LoggedRun]) -> Result<Vec<Matched>, CalibrateError> {
    runs.iter()
        .map(|r| {
            let arcs = resolve(&r.plan, base).map_err(|source| CalibrateError::Plan {
                plan: r.plan_name.clone(),
                source,
            })?;
            let mut layers = match_layers(&r.log, &arcs)?;
            mark_early_ends(base, &arcs, &mut layers);
            crate::mu_check::check_mu(&r.log, &r.plan, &arcs, &layers)?;
            Ok(Matched {
                arcs,
                layers,
                period_s: typical_period(&r.log),
            })
        })
        .collect()
}

/// Marks the layers whose log shows fewer pauses between bursts than the base machine's
/// simulation has ([`LoggedLayer::ends_early`]).
fn mark_early_ends(base: &Machine, arcs: &[ResolvedArc], layers: &mut [LoggedLayer]) {
    let Some(burst) = base.beam.burst_switching_time_s().filter(|b| *b > 0.0) else {
        return;
    };
    let flat: Vec<&arcsim_plan::ResolvedLayer> = arcs.iter().flat_map(|a| &a.layers).collect();
    for l in layers {
        if let Some(p) = flat.get(l.index) {
            l.ends_early = l.pauses() < simulated_burst_pauses(p, burst);
        }
    }
}

/// How many pauses between bursts a layer's simulation has, with `burst_s` between bursts (0:
/// no bursts).
fn simulated_burst_pauses(layer: &arcsim_plan::ResolvedLayer, burst_s: f64) -> usize {
    if burst_s > 0.0 {
        (layer.burst_switching_s / burst_s).round() as usize
    } else {
        0
    }
}

/// The fitted ELST model and the spreads (up, down, same).
struct ElstResult {
    model: ElstModel,
    sd: [f64; 3],
}

fn base_elst(base: &Machine) -> (Option<f64>, Option<f64>, f64) {
    match &base.elst {
        ElstModel::Constant { up_s, down_s, .. } => {
            (Some(*up_s), Some(*down_s), base.elst.same_s())
        }
        ElstModel::Polynomial { down_s, .. } => (None, Some(*down_s), base.elst.same_s()),
        _ => (None, None, base.elst.same_s()),
    }
}

/// Per run, by delivery-order layer index: whether a simulation on `machine` times the switch
/// into that layer at its ELST (lost time within 5 ms + 1 %).
fn lasting_switches(
    machine: &Machine,
    runs: &[LoggedRun],
    options: &Options,
) -> Result<Vec<Vec<bool>>, CalibrateError> {
    let opts = Options {
        build_timeline: false,
        ..options.clone()
    };
    runs.par_iter()
        .map(|r| {
            let d =
                simulate(&r.plan, machine, &opts).map_err(|source| CalibrateError::Simulate {
                    plan: r.plan_name.clone(),
                    source,
                })?;
            let mut lasts = vec![false; d.layers.len()];
            for t in &d.transitions {
                if let Some(x) = lasts.get_mut(t.to_layer) {
                    // With constant speed per layer the move's own minimum time is known: a
                    // switch whose move needs nearly its ELST is left out too, since its logged
                    // gap is max(ELST + jitter, move) and would pull the median up.
                    let clear = opts.motion != arcsim_sequencer::Motion::Constant
                        || t.min_time_s <= ELST_CLEARANCE * t.elst_s;
                    *x = t.lost_s <= 0.005 + 0.01 * t.elst_s && clear;
                }
            }
            Ok(lasts)
        })
        .collect()
}

/// The fitted values' standard deviations from their 95 % intervals (half-width / 1.96), for
/// the values the logs determined; 0 for the rest.
fn uncertainty_of(values: &[FittedValue]) -> arcsim_plan::FitUncertainty {
    let sd = |field: &str| {
        values
            .iter()
            .find(|v| v.field == field && v.determined)
            .and_then(|v| v.interval)
            .map_or(0.0, |[lo, hi]| ((hi - lo) / (2.0 * 1.96)).max(0.0))
    };
    arcsim_plan::FitUncertainty {
        elst_up_s_sd: sd("elst.up_s"),
        elst_down_s_sd: sd("elst.down_s"),
        elst_same_s_sd: sd("elst.same_s"),
        s_per_mu_sd: sd("beam.s_per_mu"),
        spot_switch_time_s_sd: sd("beam.spot_switch_time_s"),
        max_speed_deg_per_s_sd: sd("gantry.max_speed_deg_per_s"),
        max_accel_deg_per_s2_sd: sd("gantry.max_accel_deg_per_s2"),
        max_jerk_deg_per_s3_sd: sd("gantry.max_jerk_deg_per_s3"),
        s_per_mu_scale_sd_fraction: values
            .iter()
            .find(|v| v.field == "beam.s_per_mu_scale" && v.determined && v.value > 0.0)
            .map_or(0.0, |v| sd("beam.s_per_mu_scale") / v.value),
        burst_switching_time_s_sd: sd("beam.burst_switching_time_s"),
    }
}

/// The bracket (in the logarithm) the one-at-a-time fits by the model (J, each ELST) stop at:
/// 0.2 %, a start for the joint fit ([`crate::joint::refine_jointly`]), which refines them
/// together; golden sections to finer brackets cost a simulation per 0.48 of a bracket's log.
const SEED_TOLERANCE: f64 = 2e-3;

/// The single-valued ELSTs: field, class of switches, slot ([`elst_slot`]).
const ELST_KINDS: [(&str, &str, usize); 3] = [
    ("elst.up_s", "upward switch", 0),
    ("elst.down_s", "downward switch", 1),
    ("elst.same_s", "same energy", 2),
];

/// Sets the ELST of kind `k` ([`elst_slot`]) of a machine (nothing where the model has none).
fn set_elst(k: usize) -> impl Fn(&mut Machine, f64) + Copy + Send + Sync {
    move |m: &mut Machine, e: f64| {
        if let Some(x) = elst_slot(&mut m.elst, k) {
            *x = e;
        }
    }
}

/// The ELST slot of kind `k` (0 up, 1 down, 2 same) of a constant (or, for down and same, a
/// polynomial) ELST model.
fn elst_slot(elst: &mut ElstModel, k: usize) -> Option<&mut f64> {
    match (elst, k) {
        (ElstModel::Constant { up_s, .. }, 0) => Some(up_s),
        (ElstModel::Constant { down_s, .. }, 1) | (ElstModel::Polynomial { down_s, .. }, 1) => {
            Some(down_s)
        }
        (ElstModel::Constant { same_s, .. }, 2) | (ElstModel::Polynomial { same_s, .. }, 2) => {
            Some(same_s)
        }
        _ => None,
    }
}

/// Under constant speed per layer, each single-valued ELST by the model
/// ([`crate::transitions::fit_by_gaps`]): the ELST whose simulated gaps of its kind last as the
/// logged ones, the schedule re-simulated at each candidate. The schedule stretches most moves to
/// their switch's ELST, so few gaps show the ELST alone and a median of those few, or a
/// censored fit with moves simulated at one ELST, reads it several percent off; the gaps
/// themselves, stretched moves included, follow the ELST.
fn elst_by_model(
    machine: &mut Machine,
    runs: &[LoggedRun],
    matched: &[Matched],
    options: &Options,
    values: &mut [FittedValue],
) {
    let logged: Vec<&[LoggedLayer]> = matched.iter().map(|m| m.layers.as_slice()).collect();
    // The kinds are fitted side by side from the same machine (each its own switches), in
    // parallel: with one log the simulations inside a fit cannot be.
    let fitting: &Machine = machine;
    let fits: Vec<_> = ELST_KINDS
        .par_iter()
        .map(|&(field, class, k)| {
            let start = elst_slot(&mut fitting.elst.clone(), k).map(|x| *x)?;
            // A same-energy ELST of 0 (ATOM's) has no logarithm to search: those switches are
            // the gantry's alone and the value stays as the first fits left it.
            if start <= 1e-6 {
                return None;
            }
            let fit = crate::transitions::fit_by_gaps(
                fitting,
                &set_elst(k),
                (
                    start,
                    1.5,
                    (0.0, arcsim_plan::MAX_SWITCH_TIME_S),
                    SEED_TOLERANCE,
                ),
                (runs, &logged),
                crate::transitions::Switches::Kind(class),
                options,
            )?;
            Some((field, class, k, start, fit))
        })
        .collect();
    for (field, class, k, start, fit) in fits.into_iter().flatten() {
        let Some(row) = values.iter_mut().find(|v| v.field == field) else {
            continue;
        };
        set_elst(k)(machine, fit.value);
        let note = format!(
            "by the model: the ELST whose simulated gaps ({class}; constant speed per layer, the schedule re-simulated at each candidate) last as the logged ones (golden section over its logarithm from {start:.4}; a gap off by more than 0.3 s counts as 0.3 s); interval: the sandwich over the {} gaps it moves, Student's t",
            fit.transitions
        );
        record_gap_fit(row, &fit, note);
    }
}

/// The values fitted by the model one at a time (J, each ELST) refined together
/// ([`crate::joint::refine_jointly`]): J's fit saw the ELSTs of the cluster pass, each
/// ELST's the J of then; their intervals become the joint sandwich's, which carries what each
/// value's error does to the others'.
fn refine_by_model_jointly(
    machine: &mut Machine,
    (runs, matched): (&[LoggedRun], &[Matched]),
    options: &Options,
    noise: crate::joint::Noise,
    values: &mut [FittedValue],
) {
    const JERK: &str = "gantry.max_jerk_deg_per_s3";
    let by_model = |field: &str| {
        values
            .iter()
            .any(|v| v.field == field && v.determined && v.note.starts_with("by the model"))
    };
    const ACCEL: &str = "gantry.max_accel_deg_per_s2";
    let set_jerk = |m: &mut Machine, j: f64| m.gantry.max_jerk_deg_per_s3 = j;
    // A, from the trace's plateaus, moves every gap J does: held (the gaps' fit would absorb
    // any model error into it), its error carried into J's and the ELSTs' intervals (a trace's
    // A 0.5 % low reads J 1 % high).
    let set_accel = |m: &mut Machine, a: f64| {
        let shift = a - m.gantry.max_accel_deg_per_s2;
        m.gantry.max_accel_deg_per_s2 = a;
        if let Some(d) = &mut m.gantry.max_decel_deg_per_s2 {
            *d += shift;
        }
    };
    let accel: Vec<crate::joint::Nuisance> = values
        .iter()
        .filter(|v| v.field == ACCEL && v.determined && v.value > 0.0)
        .filter_map(|v| {
            let [lo, hi] = v.interval?;
            Some(crate::joint::Nuisance {
                set: &set_accel,
                value: v.value,
                sd_ln: (hi.max(1e-12).ln() - lo.max(1e-12).ln()) / (2.0 * 1.96),
            })
        })
        .collect();
    let setters: Vec<_> = ELST_KINDS.iter().map(|&(_, _, k)| set_elst(k)).collect();
    let mut fields = Vec::new();
    let mut params = Vec::new();
    if by_model(JERK) {
        fields.push(JERK);
        params.push(crate::joint::Param {
            set: &set_jerk,
            start: machine.gantry.max_jerk_deg_per_s3,
            range: arcsim_plan::JERK_RANGE_DEG_PER_S3,
        });
    }
    for (&(field, _, k), set) in ELST_KINDS.iter().zip(&setters) {
        let Some(start) = elst_slot(&mut machine.elst.clone(), k).map(|x| *x) else {
            continue;
        };
        if by_model(field) && start > 1e-6 {
            fields.push(field);
            params.push(crate::joint::Param {
                set,
                start,
                range: (0.0, arcsim_plan::MAX_SWITCH_TIME_S),
            });
        }
    }
    let logged: Vec<&[LoggedLayer]> = matched.iter().map(|m| m.layers.as_slice()).collect();
    let Some(fit) = crate::joint::refine_jointly(
        machine,
        &params,
        (runs, &logged),
        options,
        Some(noise),
        &accel,
    ) else {
        return;
    };
    for (k, (field, q)) in fields.iter().zip(&params).enumerate() {
        (q.set)(machine, fit.values[k]);
        if let Some(row) = values.iter_mut().find(|v| v.field == *field) {
            row.value = fit.values[k];
            row.interval = Some(fit.intervals[k]);
            row.observations = fit.moved[k];
            row.note = format!(
                "{}; then refined with {} by Gauss–Newton on every beam-off gap, interval: the wider of the joint sandwich and the spread of the fit over the fitted machine replayed 12 times with the logs' measured jitter, plus what A's own error moves ({} gaps move it)",
                row.note.split("; interval:").next().unwrap_or(&row.note),
                list(&fields),
                fit.moved[k]
            );
        }
    }
}

/// Each single-valued ELST that no logged gap shows: with it at 0 the simulated gaps of its kind
/// fit the logged ones as well as at its fitted value (within the larger of 20 ms and a tenth),
/// so the gantry's moves alone explain them. It is then not determined, and at most the
/// shortest such gap (a switch never lasts less than its ELST): the base value kept, or lowered
/// to that bound.
fn bound_unseen_elst(
    machine: &mut Machine,
    runs: &[LoggedRun],
    matched: &[Matched],
    all_gaps: &[Gap],
    options: &Options,
    values: &mut [FittedValue],
) {
    let logged: Vec<&[LoggedLayer]> = matched.iter().map(|m| m.layers.as_slice()).collect();
    for &(field, class, k) in &ELST_KINDS {
        let Some(fitted) = elst_slot(&mut machine.elst, k).map(|x| *x) else {
            continue;
        };
        let Some(row) = values.iter_mut().find(|v| v.field == field && v.determined) else {
            continue;
        };
        if fitted <= 1e-6 {
            continue;
        }
        let set = set_elst(k);
        let which = crate::transitions::Switches::Kind(class);
        let rms =
            |e: f64| crate::transitions::gap_rms(machine, &set, e, (runs, &logged), which, options);
        let (Some((at_fit, n)), Some((at_zero, _))) = rayon::join(|| rms(fitted), || rms(0.0))
        else {
            continue;
        };
        if n < 3 || at_zero > at_fit + (0.1 * at_fit).max(0.02) {
            continue;
        }
        // A gap is read to within a log period (each edge to within half of one).
        let period = matched.iter().map(|m| m.period_s).fold(0.0, f64::max);
        let shortest = durations_of(all_gaps, class)
            .into_iter()
            .fold(f64::INFINITY, f64::min);
        let bound = shortest + period;
        let base = row.base.unwrap_or(fitted);
        let value = base.min(bound);
        row.note = format!(
            "not determined: no {class} gap shows it (simulated with it at 0 the {n} gaps fit as well: rms {at_zero:.3} s against {at_fit:.3} s at {fitted:.4} s; the gantry's moves alone explain them); it is at most {bound:.4} s, the shortest such gap ({shortest:.4} s) plus the log's period ({period:.4} s): the base value {base} {}",
            if value < base { "lowered to that bound" } else { "kept" }
        );
        row.value = value;
        row.interval = None;
        row.determined = false;
        set(machine, value);
    }
}

/// A clock this many times coarser than a switch cannot time it (s per s).
const CLOCK_RESOLVES: f64 = 3.0;

/// An ELST fitted from logs of intervals whose clock (`clock_s`, their coarsest time
/// resolution; 0 for sampled logs) is too coarse to time it (below [`CLOCK_RESOLVES`] ×
/// `clock_s`): a record in whole seconds reads a 0.7 s switch as 0 or 1 s, and the fit's own
/// interval does not know it. Not determined; the base value is kept.
fn unresolved_by_clock(machine: &mut Machine, clock_s: f64, values: &mut [FittedValue]) {
    if clock_s <= 0.0 {
        return;
    }
    for &(field, _, k) in &ELST_KINDS {
        let Some(row) = values.iter_mut().find(|v| v.field == field && v.determined) else {
            continue;
        };
        let shortest = CLOCK_RESOLVES * clock_s;
        if row.value >= shortest {
            continue;
        }
        let base = row.base.unwrap_or(row.value);
        row.note = format!(
            "not determined: the logs' clock (times to {clock_s} s) cannot time a switch shorter than {shortest} s ({CLOCK_RESOLVES} × its resolution), and the fit gave {:.4} s; the base value {base} is kept",
            row.value
        );
        row.value = base;
        row.interval = None;
        row.determined = false;
        set_elst(k)(machine, base);
    }
}

/// Under constant speed per layer, a switch carries its ELST alone when its move needs at most
/// this fraction of it (10 % is over 3 standard deviations of a few-% ELST jitter).
const ELST_CLEARANCE: f64 = 0.9;

/// One ELST value being fitted: its field, the class of switches, the base value, a seed.
struct ElstKind<'a> {
    field: &'a str,
    class: &'a str,
    base: Option<f64>,
    seed: u64,
}

fn durations_of(gaps: &[Gap], class: &str) -> Vec<f64> {
    gaps.iter()
        .filter(|g| g.class == class)
        .map(|g| g.duration_s)
        .collect()
}

/// Gap durations are whole log periods (each edge halfway between two samples), so their median
/// and its bootstrap land on that grid: an interval [0.80, 0.81] s missed a true 0.80 by
/// rounding, and one of [0.30, 0.30] s claimed no uncertainty at all. A uniform dither of one
/// period (seeded, so the fit stays a function of its inputs) makes the bootstrap's medians
/// continuous again without bias: jittering, as for quantiles of counts. The period is
/// `res_sd`·√6 (an edge within half a period each end).
fn dithered(durations: &[f64], res_sd: f64, seed: u64) -> Vec<f64> {
    let period = res_sd * 6f64.sqrt();
    let mut rng = ChaCha8Rng::seed_from_u64(0xd17e_0000 + seed);
    durations
        .iter()
        .map(|x| (x + period * (rng.random::<f64>() - 0.5)).max(0.0))
        .collect()
}

/// One ELST (see [`fit_elst`]) and its spread; its value row pushed to `values`.
fn fit_one_elst(
    kind: &ElstKind,
    gaps: &[Gap],
    clean: Option<&[Gap]>,
    res_sd: f64,
    values: &mut Vec<FittedValue>,
) -> (f64, f64) {
    let spread_of = |sd: f64| (sd * sd - res_sd * res_sd).max(0.0).sqrt();
    let d = durations_of(gaps, kind.class);
    // Values from the logged durations, intervals from their dithered copies ([`dithered`]),
    // widened to hold the value (a median on the period grid may sit just outside them).
    let d_dithered = dithered(&d, res_sd, kind.seed);
    let holding = |i: Option<[f64; 2]>, v: f64| i.map(|[lo, hi]| [lo.min(v), hi.max(v)]);
    let row = |value: f64, interval, observations, note: String| FittedValue {
        field: kind.field.into(),
        unit: "s".into(),
        base: kind.base,
        value,
        interval,
        observations,
        determined: true,
        note,
    };
    if let Some(c) = clean
        .map(|c| durations_of(c, kind.class))
        .filter(|c| c.len() >= 3)
    {
        let centre = median(&mut c.clone());
        let sd = mad_sd(&c, centre).max(res_sd);
        let c_dithered = dithered(&c, res_sd, kind.seed);
        let interval = bootstrap(c.len(), kind.seed, &|idx| {
            let mut s: Vec<f64> = idx.iter().map(|&i| c_dithered[i]).collect();
            Some(median(&mut s))
        });
        let interval = holding(interval, centre);
        let note = format!(
            "median of the {} of {} switches that a simulation on the first fit times at their ELST",
            c.len(),
            d.len()
        );
        values.push(row(centre, interval, c.len(), note));
        return (centre, spread_of(sd));
    }
    match lowest_cluster(&d, res_sd).filter(|c| c.count >= 3) {
        Some(c) => {
            let interval = bootstrap(d.len(), kind.seed, &|idx| {
                let s: Vec<f64> = idx.iter().map(|&i| d_dithered[i]).collect();
                lowest_cluster(&s, res_sd).map(|c| c.centre)
            });
            let interval = holding(interval, c.centre);
            let note = format!(
                "peak of the lowest cluster of the {} beam-off gaps ({} within three spreads of it)",
                d.len(),
                c.count
            );
            values.push(row(c.centre, interval, c.count, note));
            (c.centre, spread_of(c.sd))
        }
        None => {
            values.push(kept(
                kind.field,
                "s",
                kind.base,
                d.len(),
                "fewer than 3 such switches in the logs: the base value is kept",
            ));
            (kind.base.unwrap_or(0.0), 0.0)
        }
    }
}

/// The ELST of each kind: with `clean` (the switches a simulation times at their ELST), the
/// median of those of the kind when there are 3 or more; otherwise the lowest cluster of all
/// the kind's gaps.
fn fit_elst(
    base: &Machine,
    gaps: &[Gap],
    clean: Option<&[Gap]>,
    fit: ElstFit,
    res_sd: f64,
    values: &mut Vec<FittedValue>,
) -> ElstResult {
    let (base_up, base_down, base_same) = base_elst(base);
    let mut one = |field: &str, class: &str, base_value: Option<f64>, seed: u64| {
        let kind = ElstKind {
            field,
            class,
            base: base_value,
            seed,
        };
        fit_one_elst(&kind, gaps, clean, res_sd, values)
    };
    let (down, down_sd) = one("elst.down_s", "downward switch", base_down, 2);
    let (same, same_sd) = one("elst.same_s", "same energy", Some(base_same), 3);
    let (model, up_sd) = match fit {
        ElstFit::Constant => {
            let (up, up_sd) = one("elst.up_s", "upward switch", base_up, 1);
            (
                ElstModel::Constant {
                    up_s: up,
                    down_s: down,
                    same_s: same,
                },
                up_sd,
            )
        }
        ElstFit::Polynomial => {
            let ups_of = |gaps: &[Gap]| -> Vec<(f64, f64)> {
                gaps.iter()
                    .filter(|g| g.class == "upward switch")
                    .map(|g| (g.step_mev, g.duration_s))
                    .collect()
            };
            // The cleaned switches when they are enough (their lowest cluster is all of them).
            let ups = clean
                .map(ups_of)
                .filter(|u| u.len() >= 3)
                .unwrap_or_else(|| ups_of(gaps));
            let (coeffs, sd) = fit_up_line(&ups, res_sd, base_up.unwrap_or(1.0), values);
            (
                ElstModel::Polynomial {
                    down_s: down,
                    same_s: same,
                    up_coeffs_s: coeffs.to_vec(),
                },
                sd,
            )
        }
    };
    ElstResult {
        model,
        sd: [up_sd, down_sd, same_sd],
    }
}

fn kept(field: &str, unit: &str, base: Option<f64>, n: usize, why: &str) -> FittedValue {
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

/// Least squares of `y = c0 + c1 x` over the points `idx` of `pts`.
fn line(pts: &[(f64, f64)], idx: &[usize]) -> Option<[f64; 2]> {
    let n = idx.len() as f64;
    let (sx, sy) = idx
        .iter()
        .fold((0.0, 0.0), |(a, b), &i| (a + pts[i].0, b + pts[i].1));
    let (mx, my) = (sx / n, sy / n);
    let (sxx, sxy) = idx.iter().fold((0.0, 0.0), |(a, b), &i| {
        let dx = pts[i].0 - mx;
        (a + dx * dx, b + dx * (pts[i].1 - my))
    });
    (sxx > 0.0).then(|| [my - sxy / sxx * mx, sxy / sxx])
}

/// The upward ELST as a line in the energy step, over the lowest cluster of its residuals.
fn line_cluster(pts: &[(f64, f64)], res_sd: f64) -> Option<([f64; 2], f64, usize)> {
    let all: Vec<usize> = (0..pts.len()).collect();
    let first = lowest_cluster(&pts.iter().map(|p| p.1).collect::<Vec<_>>(), res_sd)?;
    let mut c = [first.centre, 0.0];
    let mut sd = first.sd;
    let mut members = all.clone();
    for _ in 0..20 {
        let r: Vec<f64> = pts.iter().map(|p| p.1 - c[0] - c[1] * p.0).collect();
        members = all.iter().copied().filter(|&i| r[i] <= 3.0 * sd).collect();
        let next = line(pts, &members)?;
        let rm: Vec<f64> = members
            .iter()
            .map(|&i| pts[i].1 - next[0] - next[1] * pts[i].0)
            .collect();
        sd = mad_sd(&rm, 0.0)
            .max(res_sd)
            .min(0.1 * c[0].abs().max(res_sd));
        let settled = (next[0] - c[0]).abs() + (next[1] - c[1]).abs() < 1e-12;
        c = next;
        if settled {
            break;
        }
    }
    Some((c, sd, members.len()))
}

fn fit_up_line(
    pts: &[(f64, f64)],
    res_sd: f64,
    scale: f64,
    values: &mut Vec<FittedValue>,
) -> ([f64; 2], f64) {
    let Some((c, sd, count)) = line_cluster(pts, res_sd).filter(|x| x.2 >= 3) else {
        values.push(kept("elst.up_coeffs_s", "s, s/MeV", None, pts.len(), "fewer than 3 upward switches over distinct energy steps: the upward time is the base machine's constant"));
        return ([scale, 0.0], 0.0);
    };
    for (k, name) in ["elst.up_coeffs_s[0]", "elst.up_coeffs_s[1]"]
        .iter()
        .enumerate()
    {
        let interval = bootstrap(pts.len(), 10 + k as u64, &|idx| {
            let s: Vec<(f64, f64)> = idx.iter().map(|&i| pts[i]).collect();
            line_cluster(&s, res_sd).map(|x| x.0[k])
        });
        values.push(FittedValue {
            field: (*name).into(),
            unit: if k == 0 { "s".into() } else { "s/MeV".into() },
            base: None,
            value: c[k],
            interval,
            observations: count,
            determined: true,
            note: format!("line in the energy step through the {count} of {} upward switches that last their ELST", pts.len()),
        });
    }
    (c, (sd * sd - res_sd * res_sd).max(0.0).sqrt())
}

/// The fitted beam model (when fitted) and the spread of a layer's beam time.
struct BeamResult {
    model: Option<BeamModel>,
    sd_fraction: f64,
}

/// `(MU term, moves term, logged beam-on)` of each logged layer with spots.
fn beam_rows(runs: &[LoggedRun], matched: &[Matched]) -> Vec<(f64, f64, f64)> {
    let unit = |s, w| {
        BeamModel::PerMu(PerMuBeam {
            s_per_mu: s,
            spot_switch_time_s: w,
            min_spot_time_s: 0.0,
        })
    };
    let (mu_unit, move_unit) = (unit(1.0, 0.0), unit(0.0, 1.0));
    let mut rows = Vec::new();
    for (r, m) in runs.iter().zip(matched) {
        let flat = crate::mu_check::delivery_order(&m.arcs);
        for l in &m.layers {
            let (a, cp, k) = flat[l.index];
            let Some(layer) = r
                .plan
                .arcs
                .get(a)
                .and_then(|a| a.control_points.get(cp))
                .and_then(|c| c.layers.get(k))
            else {
                continue;
            };
            if layer.irradiation_time_s.is_some() || layer.spots.is_none() {
                continue;
            }
            let (Ok(x1), Ok(x2)) = (
                layer_beam_time(layer, &mu_unit),
                layer_beam_time(layer, &move_unit),
            ) else {
                continue;
            };
            rows.push((x1.spot_irradiation_s, x2.scanning_s, l.beam_on_s));
        }
    }
    rows
}

/// Least squares of `y = s x1 + w x2` over `idx`.
fn beam_ls(rows: &[(f64, f64, f64)], idx: &[usize]) -> Option<[f64; 2]> {
    let (mut a11, mut a12, mut a22, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &i in idx {
        let (x1, x2, y) = rows[i];
        a11 += x1 * x1;
        a12 += x1 * x2;
        a22 += x2 * x2;
        b1 += x1 * y;
        b2 += x2 * y;
    }
    let det = a11 * a22 - a12 * a12;
    (det.abs() > 1e-12 * (a11 * a22).max(1e-300))
        .then(|| [(a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det])
}

fn fit_beam(
    base: &Machine,
    runs: &[LoggedRun],
    matched: &[Matched],
    res_sd: f64,
    values: &mut Vec<FittedValue>,
) -> BeamResult {
    let BeamModel::PerMu(b) = &base.beam else {
        return fit_scanning_beam(base, matched, res_sd, values);
    };
    let rows = beam_rows(runs, matched);
    let all: Vec<usize> = (0..rows.len()).collect();
    let fit = (rows.len() >= 3).then(|| beam_ls(&rows, &all)).flatten();
    let Some([s, w]) = fit else {
        for (f, u, v) in [
            ("beam.s_per_mu", "s/MU", b.s_per_mu),
            ("beam.spot_switch_time_s", "s", b.spot_switch_time_s),
        ] {
            values.push(kept(f, u, Some(v), rows.len(), "fewer than 3 logged layers with spots and distinct spot counts: the base value is kept"));
        }
        return BeamResult {
            model: None,
            sd_fraction: 0.0,
        };
    };
    for (k, (f, u, base_v, v)) in [
        ("beam.s_per_mu", "s/MU", b.s_per_mu, s),
        ("beam.spot_switch_time_s", "s", b.spot_switch_time_s, w),
    ]
    .into_iter()
    .enumerate()
    {
        let interval = bootstrap(rows.len(), 20 + k as u64, &|idx| {
            beam_ls(&rows, idx).map(|x| x[k])
        });
        values.push(FittedValue {
            field: f.into(),
            unit: u.into(),
            base: Some(base_v),
            value: v,
            interval,
            observations: rows.len(),
            determined: true,
            note: format!(
                "least squares of the {} logged layers' beam-on times on their MU and spot moves",
                rows.len()
            ),
        });
    }
    if b.min_spot_time_s > 0.0 {
        values.push(kept("beam.min_spot_time_s", "s", Some(b.min_spot_time_s), 0, "not fitted (the fit assumes no spot is held at its minimum time): the base value is kept"));
    }
    let pairs: Vec<(f64, f64)> = rows.iter().map(|r| (r.2, s * r.0 + w * r.1)).collect();
    BeamResult {
        model: Some(BeamModel::PerMu(PerMuBeam {
            s_per_mu: s,
            spot_switch_time_s: w,
            min_spot_time_s: b.min_spot_time_s,
        })),
        sd_fraction: beam_time_sd_fraction(&pairs, res_sd),
    }
}

/// The spread of a layer's beam-on time as a fraction of the model's, from `(logged, model)`
/// pairs: the relative residuals' variance less what the log's time resolution `res_sd` alone
/// gives.
fn beam_time_sd_fraction(pairs: &[(f64, f64)], res_sd: f64) -> f64 {
    let rel: Vec<f64> = pairs
        .iter()
        .map(|(y, p)| y / p - 1.0)
        .filter(|x| x.is_finite())
        .collect();
    let res_rel: f64 = pairs
        .iter()
        .map(|(_, p)| (res_sd / p).powi(2))
        .filter(|x| x.is_finite())
        .sum::<f64>()
        / pairs.len().max(1) as f64;
    let n = rel.len().max(2) as f64;
    let mean = rel.iter().sum::<f64>() / n;
    let var = rel.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (var - res_rel).max(0.0).sqrt()
}

/// Per uninterrupted logged layer with spots whose pauses between bursts are all in the log:
/// `(spot irradiation at the base's times per MU,
/// its scanning, the pauses between bursts the simulation has, the logged beam-on with those
/// pauses)`; and every logged pause between bursts, s.
#[allow(clippy::type_complexity)]
fn scanning_rows(matched: &[Matched], burst_s: f64) -> (Vec<[f64; 4]>, Vec<f64>) {
    let mut rows = Vec::new();
    let mut pauses = Vec::new();
    for m in matched {
        let flat: Vec<&arcsim_plan::ResolvedLayer> =
            m.arcs.iter().flat_map(|a| &a.layers).collect();
        for l in &m.layers {
            let Some(p) = flat.get(l.index) else { continue };
            // A layer that ends early (a last burst too short to be sampled) lacks pauses and
            // beam-on: it is left out.
            if !l.ends_early
                && l.interruptions == 0
                && p.spot_irradiation_s > 0.0
                && p.spill_waiting_s == 0.0
            {
                let bursts = simulated_burst_pauses(p, burst_s) as f64;
                rows.push([p.spot_irradiation_s, p.scanning_s, bursts, l.beam_on_s]);
            }
            if p.burst_switching_s > 0.0 {
                pauses.extend_from_slice(&l.pause_gaps_s);
            }
        }
    }
    (rows, pauses)
}

/// A `scanning` beam: for a beam in bursts the burst switching time first (the median of the
/// logged pauses between bursts: a burst too short to be sampled merges two pauses, which a
/// mean would count), then its times per MU scaled by one factor: least squares of each
/// uninterrupted layer's logged beam-on, less its bursts' pauses (as many as the simulation
/// has, at the fitted time) and its scanning, on its spot irradiation at the base's times. The
/// rest of the model (scanning speeds, spills) is the base's.
fn fit_scanning_beam(
    base: &Machine,
    matched: &[Matched],
    res_sd: f64,
    values: &mut Vec<FittedValue>,
) -> BeamResult {
    let base_burst = base.beam.burst_switching_time_s().unwrap_or(0.0);
    let (rows, pauses) = scanning_rows(matched, base_burst);
    let mut model = base.beam.clone();
    let mut burst = base_burst;
    if base_burst > 0.0 {
        if pauses.len() >= 3 {
            burst = median(&mut pauses.clone());
            values.push(FittedValue {
                field: "beam.burst_switching_time_s".into(),
                unit: "s".into(),
                base: Some(base_burst),
                value: burst,
                // Each pause is read to within a period: the bootstrap of identical readings
                // is widened by that resolution over the pauses' number.
                interval: bootstrap(pauses.len(), 25, &|idx| {
                    let mut v: Vec<f64> = idx.iter().map(|&i| pauses[i]).collect();
                    Some(median(&mut v))
                })
                .map(|[lo, hi]| {
                    let r = 1.96 * res_sd / (pauses.len() as f64).sqrt();
                    [lo - r, hi + r]
                }),
                observations: pauses.len(),
                determined: true,
                note: format!(
                    "median of the {} logged pauses between bursts (the machine's pauses inside layers)",
                    pauses.len()
                ),
            });
            model = model.with_burst_switching_time(burst).unwrap_or(model);
        } else {
            values.push(kept(
                "beam.burst_switching_time_s",
                "s",
                Some(base_burst),
                pauses.len(),
                "fewer than 3 pauses between bursts in the logs: the base value is kept",
            ));
        }
    }
    let factor = |idx: &[usize]| {
        let (mut sxy, mut sxx) = (0.0, 0.0);
        for &i in idx {
            let [x, w, n, y] = rows[i];
            sxy += x * (y - w - n * burst);
            sxx += x * x;
        }
        (sxx > 0.0).then(|| sxy / sxx).filter(|c| *c > 0.0)
    };
    let all: Vec<usize> = (0..rows.len()).collect();
    let Some(c) = (rows.len() >= 3).then(|| factor(&all)).flatten() else {
        values.push(kept(
            "beam.s_per_mu_scale",
            "",
            Some(1.0),
            rows.len(),
            "fewer than 3 uninterrupted logged layers with spots (and no spill waits): the base's times per MU are kept",
        ));
        return BeamResult {
            model: (base_burst > 0.0).then_some(model),
            sd_fraction: 0.0,
        };
    };
    values.push(FittedValue {
        field: "beam.s_per_mu_scale".into(),
        unit: "".into(),
        base: Some(1.0),
        value: c,
        interval: bootstrap(rows.len(), 24, &|idx| factor(idx)),
        observations: rows.len(),
        determined: true,
        note: format!(
            "the factor on every time per MU of the base's table: least squares of the {} uninterrupted logged layers with every pause between bursts logged: their beam-on (less their scanning and those pauses) on their spot irradiation",
            rows.len()
        ),
    });
    model = model.with_dose_rate_scale(1.0 / c);
    let predicted = |r: &[f64; 4]| c * r[0] + r[1] + r[2] * burst;
    let pairs: Vec<(f64, f64)> = rows.iter().map(|r| (r[3], predicted(r))).collect();
    BeamResult {
        model: Some(model),
        sd_fraction: beam_time_sd_fraction(&pairs, res_sd),
    }
}

fn gantry_value(
    field: &str,
    unit: &str,
    base: Option<f64>,
    p: Option<&Plateau>,
    what: &str,
) -> FittedValue {
    match p {
        Some(p) if p.reached => FittedValue {
            field: field.into(),
            unit: unit.into(),
            base,
            value: p.level,
            interval: Some(p.interval),
            observations: 1,
            determined: true,
            note: format!("plateau of the observed {what}, held {:.1} s (local fits over 2 s)", p.held_s),
        },
        Some(p) if base.is_some_and(|b| p.level > b) => FittedValue {
            value: p.level,
            ..kept(field, unit, base, 1, &format!("the observed {what} is not held as a limit (plateau {:.4} held {:.2} s) but exceeds the base value: raised to it, a lower bound of the limit", p.level, p.held_s))
        },
        Some(p) => kept(field, unit, base, 1, &format!("the observed {what} peaks at {:.4} (held {:.2} s): the limit is not resolved, the base value is kept", p.peak, p.held_s)),
        None => kept(field, unit, base, 0, &format!("no {what} in the logs: the base value is kept")),
    }
}

/// Below this fraction of the base machine's speed limit the gantry is not moving at a
/// meaningful speed: creeping through narrow windows (or standing still, its trace pure encoder
/// noise) it approaches none of its limits, and a plateau of such motion is the plan's pace or
/// noise, not the machine's limit (a still gantry's noise gave a "jerk limit" of 1e9 deg/s³).
const MOVING_FRACTION_OF_BASE_SPEED: f64 = 0.2;

/// Whether the logs show the gantry moving at a meaningful speed (see
/// [`MOVING_FRACTION_OF_BASE_SPEED`]).
fn moving(base: &Machine, obs: &ObservedKinematics) -> bool {
    obs.speed.map_or(0.0, |p| p.peak)
        >= MOVING_FRACTION_OF_BASE_SPEED * base.gantry.max_speed_deg_per_s
}

/// A fitted V that changes the plans' simulated totals by less than this fraction, when raised
/// tenfold from the logged peak speed, does not bind in those plans.
const V_BINDS_FRACTION: f64 = 1e-3;

/// Under a constant-speed controller a speed plateau in the logs is a layer's constant speed
/// (its window and beam-on set it), not V, unless V is what held it there. The logged plans are
/// simulated with V at the logged peak speed and at ten times it: when the totals differ by less
/// than [`V_BINDS_FRACTION`], V does not bind in these logs and is not determined (the base value
/// kept, never below the logged peak).
fn question_speed_plateau(
    base: &Machine,
    machine: &mut Machine,
    runs: &[LoggedRun],
    options: &Options,
    observed: &ObservedKinematics,
    values: &mut [FittedValue],
) {
    let Some(row) = values
        .iter_mut()
        .find(|v| v.field == "gantry.max_speed_deg_per_s" && v.determined)
    else {
        return;
    };
    let plateau = row.value;
    let logged_peak = observed.speed.map_or(plateau, |s| s.peak.max(plateau));
    let opts = Options {
        build_timeline: false,
        ..options.clone()
    };
    let total_at = |v: f64| -> Option<f64> {
        let mut m = machine.clone();
        m.gantry.max_speed_deg_per_s = v;
        runs.par_iter()
            .map(|r| simulate(&r.plan, &m, &opts).ok().map(|d| d.total_s))
            .sum()
    };
    let (Some(at_peak), Some(unbound)) =
        rayon::join(|| total_at(logged_peak), || total_at(10.0 * logged_peak))
    else {
        return;
    };
    let saved = (at_peak - unbound) / at_peak.max(f64::MIN_POSITIVE);
    if saved >= V_BINDS_FRACTION {
        row.note.push_str(&format!(
            "; V binds: the plans (constant speed per layer) take {:.2} % less time with V ten times the logged peak",
            100.0 * saved
        ));
        return;
    }
    let value = base.gantry.max_speed_deg_per_s.max(logged_peak);
    row.note = format!(
        "not determined: under constant speed per layer the plateau {plateau:.4} deg/s is a layer's speed, not V (the plans simulated with V at the logged peak {logged_peak:.4} and at ten times it last alike: {:+.3} %); the base value is kept, never below the logged peak",
        -100.0 * saved
    );
    row.value = value;
    row.interval = None;
    row.determined = false;
    machine.gantry.max_speed_deg_per_s = value;
}

/// Under a constant-speed controller, J by the model ([`crate::transitions::fit_by_gaps`]): the
/// reversals of the trace read the beam-on dwells between a move's turns as a slow jerk. The
/// search spans a factor 4 each way: wider, the constant-speed model takes a free-motion
/// gantry's logs for a jerk of 21 deg/s³ (the README's fast machine, J 3) and fits them almost
/// as well as free motion does, and the controller is no longer told apart. The joint
/// refinement reaches up to a third beyond the bracket's end (three steps of at most 10 %): the
/// tests' constant-speed machine, whose J the trace reads 4.2 times low.
fn refine_jerk(
    machine: &mut Machine,
    (runs, matched): (&[LoggedRun], &[Matched]),
    options: &Options,
    values: &mut [FittedValue],
) {
    let logged: Vec<&[LoggedLayer]> = matched.iter().map(|m| m.layers.as_slice()).collect();
    let start = machine.gantry.max_jerk_deg_per_s3;
    let set = |m: &mut Machine, j: f64| m.gantry.max_jerk_deg_per_s3 = j;
    let Some(fit) = crate::transitions::fit_by_gaps(
        machine,
        &set,
        (
            start,
            4.0,
            arcsim_plan::JERK_RANGE_DEG_PER_S3,
            SEED_TOLERANCE,
        ),
        (runs, &logged),
        crate::transitions::Switches::All,
        options,
    ) else {
        return;
    };
    machine.gantry.max_jerk_deg_per_s3 = fit.value;
    if let Some(v) = values
        .iter_mut()
        .find(|v| v.field == "gantry.max_jerk_deg_per_s3")
    {
        let note = format!(
            "by the model: the J whose simulated moves (constant speed per layer) last as the logged beam-off gaps (golden section over ln J from the trace's {:.4}; a gap off by more than 0.3 s counts as 0.3 s); interval: the sandwich over the {} gaps it moves, Student's t",
            start, fit.transitions
        );
        record_gap_fit(v, &fit, note);
    }
}

/// A value row determined by a fit by the model ([`crate::transitions::fit_by_gaps`]).
fn record_gap_fit(row: &mut FittedValue, fit: &crate::transitions::GapFit, note: String) {
    row.value = fit.value;
    row.interval = Some(fit.interval);
    row.observations = fit.transitions;
    row.determined = true;
    row.note = note;
}

fn fit_gantry(
    base: &Machine,
    (obs, traced): (&ObservedKinematics, bool),
    machine: &mut Machine,
    values: &mut Vec<FittedValue>,
) {
    let g = &base.gantry;
    let base_d = g.max_decel_deg_per_s2.unwrap_or(g.max_accel_deg_per_s2);
    let top_speed = obs.speed.map_or(0.0, |p| p.peak);
    let meaningful = MOVING_FRACTION_OF_BASE_SPEED * g.max_speed_deg_per_s;
    if !traced || top_speed < meaningful {
        let why = if traced {
            format!(
                "the gantry never moves faster than {top_speed:.4} deg/s in the logs, under {:.0} % of the base machine's speed limit {} deg/s: no limit is approached, the base value is kept",
                100.0 * MOVING_FRACTION_OF_BASE_SPEED,
                g.max_speed_deg_per_s
            )
        } else {
            "not determined: the logs hold no angle trace (a treatment record holds each layer's beam-on and beam-off, not the gantry's motion between them), the base value is kept".to_string()
        };
        let n = usize::from(obs.speed.is_some());
        for (field, unit, kept_value) in [
            ("gantry.max_speed_deg_per_s", "deg/s", g.max_speed_deg_per_s),
            (
                "gantry.max_accel_deg_per_s2",
                "deg/s^2",
                g.max_accel_deg_per_s2,
            ),
            ("gantry.max_decel_deg_per_s2", "deg/s^2", base_d),
            (
                "gantry.max_jerk_deg_per_s3",
                "deg/s^3",
                g.max_jerk_deg_per_s3,
            ),
        ] {
            values.push(kept(field, unit, Some(kept_value), n, &why));
        }
        let out = &mut machine.gantry;
        out.max_speed_deg_per_s = g.max_speed_deg_per_s;
        out.max_accel_deg_per_s2 = g.max_accel_deg_per_s2;
        out.max_decel_deg_per_s2 = g.max_decel_deg_per_s2;
        out.max_jerk_deg_per_s3 = g.max_jerk_deg_per_s3;
        return;
    }
    let v = gantry_value(
        "gantry.max_speed_deg_per_s",
        "deg/s",
        Some(g.max_speed_deg_per_s),
        obs.speed.as_ref(),
        "speed",
    );
    let a = gantry_value(
        "gantry.max_accel_deg_per_s2",
        "deg/s^2",
        Some(g.max_accel_deg_per_s2),
        obs.accel.as_ref(),
        "acceleration",
    );
    let mut d = gantry_value(
        "gantry.max_decel_deg_per_s2",
        "deg/s^2",
        Some(base_d),
        obs.decel.as_ref(),
        "deceleration",
    );
    let j = match obs.jerk_reversals.filter(|r| r.reached) {
        Some(r) => FittedValue {
            field: "gantry.max_jerk_deg_per_s3".into(),
            unit: "deg/s^3".into(),
            base: Some(g.max_jerk_deg_per_s3),
            value: r.level,
            interval: Some(r.interval),
            observations: (r.held_s * r.level / (2.0 * obs.accel.map_or(1.0, |a| a.level))).round() as usize,
            determined: true,
            note: "median over the acceleration's reversals between its plateaus: the slope between the half-way points, the 2 s fits' averaging undone".into(),
        },
        None => gantry_value(
            "gantry.max_jerk_deg_per_s3",
            "deg/s^3",
            Some(g.max_jerk_deg_per_s3),
            obs.jerk.as_ref(),
            "jerk (fewer than 3 reversals of the acceleration between its plateaus)",
        ),
    };
    let out = &mut machine.gantry;
    out.max_speed_deg_per_s = v.value;
    out.max_jerk_deg_per_s3 = j.value;
    // One limit A unless the deceleration differs from it by more than 5 %.
    out.max_accel_deg_per_s2 = a.value;
    let same = (a.value - d.value).abs() <= 0.05 * a.value.max(d.value);
    out.max_decel_deg_per_s2 = match (a.determined || d.determined, same) {
        (true, true) => {
            d.note
                .push_str("; within 5 % of the acceleration: the machine keeps one limit, A");
            None
        }
        (_, false) => Some(d.value),
        (false, true) => g.max_decel_deg_per_s2.filter(|_| d.value != a.value),
    };
    values.extend([v, a, d, j]);
}

fn list(fields: &[&str]) -> String {
    if fields.is_empty() {
        "nothing".to_string()
    } else {
        fields.join(", ")
    }
}

fn describe(machine: &mut Machine, base: &Machine, runs: &[LoggedRun], values: &[FittedValue]) {
    let fitted: Vec<&str> = values
        .iter()
        .filter(|v| v.determined)
        .map(|v| v.field.as_str())
        .collect();
    let raised: Vec<&str> = values
        .iter()
        .filter(|v| !v.determined && v.base.is_some_and(|b| b != v.value))
        .map(|v| v.field.as_str())
        .collect();
    let kept: Vec<&str> = values
        .iter()
        .filter(|v| !v.determined && !raised.contains(&v.field.as_str()))
        .map(|v| v.field.as_str())
        .collect();
    machine.name = format!("{}-calibrated", base.name);
    machine.description = Some(format!(
        "{} calibrated by arcsim calibrate on {} log(s). Fitted: {}. Raised to what the logs show (a lower bound, the limit not resolved): {}. Kept from the base machine: {}. Spreads measured in the logs.",
        base.name,
        runs.len(),
        list(&fitted),
        list(&raised),
        list(&kept),
    ));
    for r in runs {
        machine.sources.push(format!(
            "delivery log {} (plan {})",
            r.log.source, r.plan_name
        ));
    }
}

/// `100 x / of` (0 for a log of no duration: one sample).
fn percent(x: f64, of: f64) -> f64 {
    if of > 0.0 {
        100.0 * x / of
    } else {
        0.0
    }
}

fn residuals(
    base: &Machine,
    fitted: &Machine,
    runs: &[LoggedRun],
    matched: &[Matched],
    options: &Options,
) -> Result<Vec<Residual>, CalibrateError> {
    let opts = Options {
        build_timeline: false,
        ..options.clone()
    };
    runs.par_iter()
        .zip(matched)
        .map(|(r, m)| {
            let sim = |machine: &Machine| {
                simulate(&r.plan, machine, &opts)
                    .map(|d| d.total_s)
                    .map_err(|source| CalibrateError::Simulate {
                        plan: r.plan_name.clone(),
                        source,
                    })
            };
            let logged = m.layers[m.layers.len() - 1].end_s - m.layers[0].start_s;
            let (b, f) = (sim(base)?, sim(fitted)?);
            Ok(Residual {
                plan: r.plan_name.clone(),
                log: r.log.source.clone(),
                logged_total_s: logged,
                base_total_s: b,
                fitted_total_s: f,
                base_error_pct: percent(b - logged, logged),
                fitted_error_pct: percent(f - logged, logged),
            })
        })
        .collect()
}
