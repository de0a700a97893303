//! Which controller a machine follows, learnt from its logs: the calibration is fitted under
//! every motion model it can fit under ([`Motion::calibrates_from_logs`]), each fitted machine simulates every logged plan under its model, and the
//! model whose layer beam-on times come out closest to the logged ones is chosen when its error
//! is at least [`CONTROLLER_DECISION_RATIO`] times smaller than every other's. Otherwise the
//! controller is "not determined" and the base machine's is kept, said so. Timings fitted under
//! the wrong controller are wrong (a constant-speed machine's ELST read through free motion comes
//! out 20 % long), so the choice comes before the timings, not after.

use std::collections::BTreeMap;

use arcsim_plan::{
    resolve, Controller, ControllerEvidence, Machine, Motion, CONTROLLER_DECISION_RATIO,
};
use arcsim_sequencer::{Delivery, Options};
use rayon::prelude::*;

use crate::calibrate::{calibrate_simulated, CalibrateError, Calibration, ElstFit, LoggedRun};
use crate::compare::compare;

/// A residual after the fit is worth a warning above this many percent (or above 3 × the logs'
/// own timing noise, when that is larger).
pub const RESIDUAL_WARNING_PCT: f64 = 0.5;

/// Fits `base` to `runs` under the controller the logs show (or `forced`), and writes that
/// controller with its evidence into the fitted machine. `options` give the schedule (and arc
/// ends) of the simulations; their motion is replaced by each candidate's.
pub fn calibrate_controller(
    base: &Machine,
    runs: &[LoggedRun],
    elst_fit: ElstFit,
    options: &Options,
    forced: Option<Motion>,
) -> Result<Calibration, CalibrateError> {
    let logs: Vec<String> = runs.iter().map(|r| r.log.source.clone()).collect();
    let candidates: Vec<Motion> = match forced {
        Some(m) if !m.calibrates_from_logs() => {
            return Err(CalibrateError::NotCalibratable { motion: m })
        }
        Some(m) => vec![m],
        None => Motion::ALL
            .into_iter()
            .filter(|m| m.calibrates_from_logs())
            .collect(),
    };
    let fits = candidates
        .par_iter()
        .map(|&motion| {
            let opts = Options {
                motion,
                ..options.clone()
            };
            let (cal, simulated) = calibrate_simulated(base, runs, elst_fit, &opts)?;
            let rms = rms_beam_on_start(&cal.machine, runs, &simulated)?;
            Ok((motion, cal, rms))
        })
        .collect::<Result<Vec<_>, CalibrateError>>()?;
    let rms_by_name: BTreeMap<String, f64> = fits
        .iter()
        .map(|(m, _, rms)| (m.name().to_string(), *rms))
        .collect();
    let rms: Vec<(Motion, f64)> = fits.iter().map(|(m, _, r)| (*m, *r)).collect();
    let (chosen, decision, source) = decide(
        &rms,
        &rms_by_name,
        &base.controller_or_assumed(),
        forced.is_some(),
        logs.len(),
    );
    let mut fits = fits;
    let (motion, mut cal, _) = fits.swap_remove(chosen);
    let evidence = ControllerEvidence {
        logs,
        rms_beam_on_start_s: rms_by_name,
        decision: decision.to_string(),
    };
    cal.machine.controller = Some(Controller {
        motion,
        schedule: options.schedule,
        source,
        evidence: Some(evidence.clone()),
    });
    cal.report.controller = Some(evidence);
    residual_warnings(&mut cal, runs);
    heterogeneity_warning(&mut cal);
    extrapolation_warning(&mut cal, runs);
    Ok(cal)
}

/// The controller the logs show: (index into `rms`, decision, source sentence). `rms` holds each
/// candidate model's pooled beam-on timing error; one is chosen when it is at least
/// [`CONTROLLER_DECISION_RATIO`] times smaller than every other's, else the base machine's is
/// kept as "not determined"; `forced` takes the one candidate.
fn decide(
    rms: &[(Motion, f64)],
    rms_by_name: &BTreeMap<String, f64>,
    base_controller: &Controller,
    forced: bool,
    logs: usize,
) -> (usize, &'static str, String) {
    let best = rms
        .iter()
        .enumerate()
        .min_by(|a, b| a.1 .1.total_cmp(&b.1 .1))
        .map_or(0, |(i, _)| i);
    let best_rms = rms[best].1;
    let separated = rms
        .iter()
        .enumerate()
        .all(|(i, f)| i == best || f.1 >= CONTROLLER_DECISION_RATIO * best_rms);
    if forced {
        (
            best,
            "forced",
            format!(
                "forced by --motion in the calibration from {} log(s); rms beam-on timing error {:.3} s",
                logs,
                best_rms
            ),
        )
    } else if separated {
        let second = rms
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != best)
            .map(|(_, f)| f.1)
            .fold(f64::INFINITY, f64::min);
        (
            best,
            "chosen",
            format!(
                "fitted from {} delivery log(s): {} fits the layers' beam-on times {:.1} times better (rms {:.3} s against {:.3} s; the rule asks {}×)",
                logs,
                rms[best].0.describe(),
                second / best_rms.max(f64::MIN_POSITIVE),
                best_rms,
                second,
                CONTROLLER_DECISION_RATIO
            ),
        )
    } else {
        let errors = rms_by_name
            .iter()
            .map(|(k, v)| format!("{k} {v:.3} s"))
            .collect::<Vec<_>>()
            .join(", ");
        let why = format!(
            "not determined by {logs} delivery log(s) (the models' rms beam-on timing errors differ by less than {CONTROLLER_DECISION_RATIO}×: {errors})"
        );
        match rms.iter().position(|f| f.0 == base_controller.motion) {
            Some(kept) => (
                kept,
                "not determined",
                format!(
                    "{why}; kept from the base machine: {}",
                    base_controller.source
                ),
            ),
            // The base's model is one a calibration cannot fit under (one speed per arc).
            None => (
                best,
                "not determined",
                format!(
                    "{why}; the base machine's {} is not fitted from logs, so the closest model, {}, is used",
                    base_controller.motion.describe(),
                    rms[best].0.describe()
                ),
            ),
        }
    }
}

/// Residuals of opposite signs, each beyond [`RESIDUAL_WARNING_PCT`], are logs no one machine
/// explains (issue 44: logs of two machines pooled gave +8.7 % and −13.7 % without a word); the
/// jitter such logs put into the spreads would hide them from the per-log warning.
fn heterogeneity_warning(cal: &mut Calibration) {
    let r = &cal.report.residuals;
    let hi = r
        .iter()
        .max_by(|a, b| a.fitted_error_pct.total_cmp(&b.fitted_error_pct));
    let lo = r
        .iter()
        .min_by(|a, b| a.fitted_error_pct.total_cmp(&b.fitted_error_pct));
    if let (Some(hi), Some(lo)) = (hi, lo) {
        if hi.fitted_error_pct > RESIDUAL_WARNING_PCT && lo.fitted_error_pct < -RESIDUAL_WARNING_PCT
        {
            let text = format!(
                "the logs disagree: the fitted machine is {:+.2} % off {} but {:+.2} % off {}; logs of different machines or controllers pooled? Calibrate each machine from its own logs",
                hi.fitted_error_pct, hi.log, lo.fitted_error_pct, lo.log
            );
            cal.report.warnings.push(text);
        }
    }
}

/// An upward ELST fitted as a line in the energy step holds over the steps the logs show; the
/// warning gives that range and what the line says beyond it.
fn extrapolation_warning(cal: &mut Calibration, runs: &[LoggedRun]) {
    let arcsim_plan::ElstModel::Polynomial { up_coeffs_s, .. } = &cal.machine.elst else {
        return;
    };
    let steps: Vec<f64> = runs
        .iter()
        .flat_map(|r| {
            r.plan.arcs.iter().flat_map(|a| {
                let e: Vec<f64> = a
                    .control_points
                    .iter()
                    .flat_map(|cp| cp.layers.iter().map(|l| l.energy_mev))
                    .collect();
                e.windows(2)
                    .map(|w| w[1] - w[0])
                    .filter(|d| *d > arcsim_plan::SAME_ENERGY_TOLERANCE_MEV)
                    .collect::<Vec<_>>()
            })
        })
        .collect();
    let (lo, hi) = steps
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(a, b), &d| (a.min(d), b.max(d)));
    if steps.is_empty() {
        return;
    }
    let at = |de: f64| up_coeffs_s.iter().rev().fold(0.0, |acc, c| acc * de + c);
    let probe = (2.0 * hi).max(50.0);
    let text = format!(
        "elst.up_coeffs_s is a line fitted to upward steps of {lo:.2}–{hi:.2} MeV ({} switches); a plan with larger steps is an extrapolation (the line gives {:.3} s at {hi:.1} MeV and {:.3} s at {probe:.0} MeV)",
        steps.len(),
        at(hi),
        at(probe)
    );
    // Steps of tens of MeV span what arcs switch; a line from small steps only is a guess
    // beyond them: a warning then, a note otherwise.
    if hi < EXTRAPOLATION_WARNING_BELOW_MEV {
        cal.report.warnings.push(text);
    } else if let Some(v) = cal
        .report
        .values
        .iter_mut()
        .find(|v| v.field.starts_with("elst.up_coeffs_s"))
    {
        v.note = format!("{}; {text}", v.note);
    }
}

/// An upward ELST line fitted only to steps below this (MeV) is a warning: arcs switch up by
/// tens of MeV.
pub const EXTRAPOLATION_WARNING_BELOW_MEV: f64 = 20.0;

/// Pooled over every layer of every log: the rms of (logged − simulated) beam-on start, each
/// log aligned on its first layer, `simulated` being `machine`'s simulation of each run.
fn rms_beam_on_start(
    machine: &Machine,
    runs: &[LoggedRun],
    simulated: &[Delivery],
) -> Result<f64, CalibrateError> {
    let per_run = runs
        .par_iter()
        .zip(simulated)
        .map(|(r, sim)| {
            let arcs = resolve(&r.plan, machine).map_err(|source| CalibrateError::Plan {
                plan: r.plan_name.clone(),
                source,
            })?;
            let c = compare(&arcs, sim, &[], &r.log)?;
            let n = c.layers.len() as f64;
            let rms = c.motion_fits.first().map_or(0.0, |f| f.rms_start_s);
            Ok((rms * rms * n, n))
        })
        .collect::<Result<Vec<_>, CalibrateError>>()?;
    let (ss, n) = per_run
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
    Ok((ss / n.max(1.0)).sqrt())
}

/// A log of intervals whose times are this coarse or coarser (s) names its clock as a likely
/// cause of a residual.
const COARSE_CLOCK_S: f64 = 0.1;

/// A residual after the fit above max([`RESIDUAL_WARNING_PCT`], 3 × the log's own timing noise)
/// is a warning with its likely cause.
fn residual_warnings(cal: &mut Calibration, runs: &[LoggedRun]) {
    let spread = cal.report.spread;
    let sd = spread
        .elst_up_sd_s
        .max(spread.elst_down_sd_s)
        .max(spread.elst_same_sd_s);
    for (r, run) in cal.report.residuals.iter().zip(runs) {
        let switches = run
            .plan
            .arcs
            .iter()
            .map(|a| {
                a.control_points
                    .iter()
                    .map(|cp| cp.layers.len())
                    .sum::<usize>()
            })
            .sum::<usize>()
            .saturating_sub(1) as f64;
        let noise_pct = 100.0 * sd * switches.sqrt() / r.logged_total_s.max(f64::MIN_POSITIVE);
        let limit = RESIDUAL_WARNING_PCT.max(3.0 * noise_pct);
        if r.fitted_error_pct.abs() > limit {
            // A record's clock in whole (or tenths of) seconds reads a sub-second switch as 0
            // or 1 s.
            let clock = run
                .log
                .edge_resolution_s
                .filter(|&res| res >= COARSE_CLOCK_S)
                .map(|res| format!("a clock too coarse for the switches it times (this log's times are to {res} s), "))
                .unwrap_or_default();
            cal.report.warnings.push(format!(
                "{}: the fitted machine is {:+.2} % off this log (above {:.2} %, the larger of {} % and 3 × the timing noise of its switches); likely causes: {clock}a log of another machine or controller than the others, interruptions, or a timing the model does not have (bursts, spills, a gantry limit the logs do not show)",
                r.log, r.fitted_error_pct, limit, RESIDUAL_WARNING_PCT
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn by_name(rms: &[(Motion, f64)]) -> BTreeMap<String, f64> {
        rms.iter()
            .map(|(m, r)| (m.name().to_string(), *r))
            .collect()
    }

    #[test]
    fn a_model_is_chosen_only_three_times_better_else_the_base_is_kept() {
        let base = Controller::assumed();
        let close = [(Motion::Constant, 2.0), (Motion::Free, 1.0)];
        let (i, decision, source) = decide(&close, &by_name(&close), &base, false, 3);
        assert_eq!((close[i].0, decision), (Motion::Constant, "not determined"));
        assert!(
            source.contains("free 1.000 s") && source.contains("assumed"),
            "{source}"
        );
        let apart = [(Motion::Constant, 3.1), (Motion::Free, 1.0)];
        let (i, decision, source) = decide(&apart, &by_name(&apart), &base, false, 3);
        assert_eq!((apart[i].0, decision), (Motion::Free, "chosen"));
        assert!(source.contains("3.1 times better"), "{source}");
        let one = [(Motion::Free, 5.0)];
        let (i, decision, _) = decide(&one, &by_name(&one), &base, true, 1);
        assert_eq!((one[i].0, decision), (Motion::Free, "forced"));
    }

    /// A base machine whose controller logs cannot calibrate (one speed per arc): when the models
    /// that can are not told apart, the closer one is used and the source says why, rather than
    /// claiming the base's was kept.
    #[test]
    fn a_base_controller_logs_cannot_fit_is_replaced_by_the_closer_model_said_so() {
        let base = Controller {
            motion: Motion::OneSpeed,
            ..Controller::assumed()
        };
        let close = [(Motion::Constant, 2.0), (Motion::Free, 1.0)];
        let (i, decision, source) = decide(&close, &by_name(&close), &base, false, 3);
        assert_eq!((close[i].0, decision), (Motion::Free, "not determined"));
        assert!(
            source.contains("is not fitted from logs") && !source.contains("kept from the base"),
            "{source}"
        );
    }
}
