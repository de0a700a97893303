//! What a calibration says: the fitted machine's description and the residuals of every logged
//! plan re-simulated on it.

use arcsim_plan::Machine;
use arcsim_sequencer::{simulate, Delivery, Options};
use rayon::prelude::*;

use super::gaps::*;
use super::types::*;

pub(super) fn describe(
    machine: &mut Machine,
    base: &Machine,
    runs: &[LoggedRun],
    values: &[FittedValue],
) {
    let fitted: Vec<&str> = values
        .iter()
        .filter(|v| v.determined)
        .map(|v| v.field.as_str())
        .collect();
    let changed = |lower: bool| -> Vec<&str> {
        values
            .iter()
            .filter(|v| {
                !v.determined
                    && v.base
                        .is_some_and(|b| (v.value < b) == lower && b != v.value)
            })
            .map(|v| v.field.as_str())
            .collect()
    };
    let (raised, lowered) = (changed(false), changed(true));
    let kept: Vec<&str> = values
        .iter()
        .filter(|v| !v.determined && v.base.is_none_or(|b| b == v.value))
        .map(|v| v.field.as_str())
        .collect();
    machine.name = format!("{}-calibrated", base.name);
    machine.description = Some(format!(
        "{} calibrated by arcsim calibrate on {} log(s). Fitted: {}. Raised to what the logs show (a lower bound, the limit not resolved): {}. Lowered to what the logs allow (an upper bound), or moved with a fitted value: {}. Kept from the base machine: {}. Spreads measured in the logs.",
        base.name,
        runs.len(),
        list(&fitted),
        list(&raised),
        list(&lowered),
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
pub(super) fn percent(x: f64, of: f64) -> f64 {
    if of > 0.0 {
        100.0 * x / of
    } else {
        0.0
    }
}

/// Each run's residual before and after the fit, and the fitted machine's simulation of it
/// (without a timeline), which the controller's choice compares beam-on starts with.
pub(super) fn residuals(
    base: &Machine,
    fitted: &Machine,
    runs: &[LoggedRun],
    matched: &[Matched],
    options: &Options,
) -> Result<(Vec<Residual>, Vec<Delivery>), CalibrateError> {
    let opts = Options {
        build_timeline: false,
        ..options.clone()
    };
    let per_run = runs
        .par_iter()
        .zip(matched)
        .map(|(r, m)| {
            let sim = |machine: &Machine| {
                simulate(&r.plan, machine, &opts).map_err(|source| CalibrateError::Simulate {
                    plan: r.plan_name.clone(),
                    source,
                })
            };
            let logged = m.layers[m.layers.len() - 1].end_s - m.layers[0].start_s;
            let (b, f) = (sim(base)?.total_s, sim(fitted)?);
            let residual = Residual {
                plan: r.plan_name.clone(),
                log: r.log.source.clone(),
                logged_total_s: logged,
                base_total_s: b,
                fitted_total_s: f.total_s,
                base_error_pct: percent(b - logged, logged),
                fitted_error_pct: percent(f.total_s - logged, logged),
            };
            Ok((residual, f))
        })
        .collect::<Result<Vec<_>, CalibrateError>>()?;
    Ok(per_run.into_iter().unzip())
}
