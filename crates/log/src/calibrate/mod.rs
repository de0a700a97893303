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
//!   enough is not the limit (the base value is kept, or raised to it when it is higher). A log
//!   without an angle trace (a treatment record) under constant speed per layer: A, J and V by
//!   the model, from the switches' durations ([`gantry::gantry_by_gaps`]).
//!
//! Intervals: bootstrap over the switches and layers (a fixed seed, [`BOOTSTRAP_DRAWS`] draws)
//! for the timings, the fit noise over the plateau for the gantry.

use arcsim_plan::{Machine, TimingSpread};
use arcsim_sequencer::{Delivery, Options};

use crate::kinematics::{observe, trace};

mod beam;
mod elst;
mod gantry;
mod gaps;
mod report;
mod stats;
mod types;

use beam::*;
use elst::*;
use gantry::*;
use gaps::*;
use report::*;
pub use stats::lowest_cluster;
pub(crate) use stats::{mad_sd, median};
pub use types::{
    CalibrateError, Calibration, CalibrationReport, Cluster, ElstFit, FittedValue, LoggedRun,
    Residual, BOOTSTRAP_DRAWS,
};

/// Fits a machine to `runs`, starting from `base` (see the module documentation); `options` are
/// the simulations' (for the residuals).
pub fn calibrate(
    base: &Machine,
    runs: &[LoggedRun],
    elst_fit: ElstFit,
    options: &Options,
) -> Result<Calibration, CalibrateError> {
    calibrate_simulated(base, runs, elst_fit, options).map(|(cal, _)| cal)
}

/// [`calibrate`], with the fitted machine's simulation of each run (without a timeline, under
/// `options`), so that a caller comparing the fit with the logs need not simulate it again.
pub(crate) fn calibrate_simulated(
    base: &Machine,
    runs: &[LoggedRun],
    elst_fit: ElstFit,
    options: &Options,
) -> Result<(Calibration, Vec<Delivery>), CalibrateError> {
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
    // The coarsest clock among logs without an angle trace (treatment records), s.
    let clock_s = runs
        .iter()
        .filter_map(|r| r.log.edge_resolution_s)
        .fold(0.0, f64::max);
    fit_gantry(base, (&observed, traced), &mut machine, &mut values);
    if options.motion == arcsim_sequencer::Motion::Constant && moving(base, &observed) {
        question_speed_plateau(base, &mut machine, runs, options, &observed, &mut values);
        // A seed for the second ELST pass and the joint fit, which refines it: 0.1 % is enough.
        refine_jerk(&mut machine, (runs, &matched), options, &mut values);
    } else if options.motion == arcsim_sequencer::Motion::Constant && !traced {
        gantry_by_gaps(
            &mut machine,
            (runs, &matched),
            clock_s,
            options,
            &mut values,
        );
    } else if !traced {
        for v in values.iter_mut().filter(|v| v.field.starts_with("gantry.")) {
            v.note.push_str("; nor by the model: under free motion a switch's duration is not one move between two known layer speeds (the fit by the model of records needs constant speed per layer)");
        }
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
        decel_follows_accel(&machine, &mut values);
    }
    bound_unseen_elst(
        &mut machine,
        runs,
        &matched,
        &all_gaps,
        options,
        &mut values,
    );
    unresolved_by_clock(&mut machine, clock_s, &mut values);
    machine.spread = Some(spread);
    let uncertainty = uncertainty_of(&values);
    machine.uncertainty = uncertainty.any().then_some(uncertainty);
    describe(&mut machine, base, runs, &values);
    let (residuals, fitted) = residuals(base, &machine, runs, &matched, options)?;
    let warnings = table_replaced(base, &machine).into_iter().collect();
    let cal = Calibration {
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
    };
    Ok((cal, fitted))
}
