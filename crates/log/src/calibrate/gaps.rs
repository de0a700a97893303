//! The logs matched to their plans, layer by layer, and the beam-off gaps between their layers.

use arcsim_plan::{resolve, ElstModel, Machine, ResolvedArc};
use arcsim_sequencer::{simulate, Options};
use rayon::prelude::*;

use crate::compare::switch_class;
use crate::matching::{match_layers, LoggedLayer};
use crate::DeliveryLog;

use super::stats::*;
use super::types::*;

/// One logged run, resolved and matched.
pub(super) struct Matched {
    pub(super) arcs: Vec<ResolvedArc>,
    pub(super) layers: Vec<LoggedLayer>,
    pub(super) period_s: f64,
}

/// A beam-off gap between two layers of one arc.
#[derive(Debug, Clone, Copy)]
pub(super) struct Gap {
    pub(super) class: &'static str,
    pub(super) step_mev: f64,
    pub(super) duration_s: f64,
    /// The layer it leads to (delivery order).
    pub(super) to_layer: usize,
}

/// The beam-off gaps between a run's consecutive layers of one arc that are energy switches of
/// `base`'s ELST model: a layer changed inside a spill (multi-energy extraction: the spill
/// model's in-spill switching time) or with the plan's own switching time is not, and neither
/// is the gap after a layer that ends early ([`LoggedLayer::ends_early`]).
pub(super) fn gaps(m: &Matched, base: &Machine) -> Vec<Gap> {
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
pub(super) fn typical_period(log: &DeliveryLog) -> f64 {
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

/// The warning when the base machine's ELST is a table by energy, which a calibration does not
/// fit: the fitted machine carries a constant or polynomial model in its place (it once did so
/// without a word).
pub(super) fn table_replaced(base: &Machine, fitted: &Machine) -> Option<String> {
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
pub(super) fn clean_gaps(
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
pub(super) fn match_runs(
    base: &Machine,
    runs: &[LoggedRun],
) -> Result<Vec<Matched>, CalibrateError> {
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
pub(super) fn mark_early_ends(base: &Machine, arcs: &[ResolvedArc], layers: &mut [LoggedLayer]) {
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
pub(super) fn simulated_burst_pauses(layer: &arcsim_plan::ResolvedLayer, burst_s: f64) -> usize {
    if burst_s > 0.0 {
        (layer.burst_switching_s / burst_s).round() as usize
    } else {
        0
    }
}

/// Per run, by delivery-order layer index: whether a simulation on `machine` times the switch
/// into that layer at its ELST (lost time within 5 ms + 1 %).
pub(super) fn lasting_switches(
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

/// Under constant speed per layer, a switch carries its ELST alone when its move needs at most
/// this fraction of it (10 % is over 3 standard deviations of a few-% ELST jitter).
pub(super) const ELST_CLEARANCE: f64 = 0.9;
