//! A synchrotron's spills in per-spot logs: the refill time from the pauses inside a pass where
//! a spill ran out, the charge from the MU delivered between two of them.

use arcsim_plan::{ScanningBeam, SpillModel, SpotAcrossSpills};

use super::fit::{fitted_value, kept_value, med, spread, Layer};
use crate::calibrate::FittedValue;
use crate::transitions::student_t95;
use crate::LoggedSpot;

/// A pause inside a pass longer than its move (at the base's scanning) by more than this, s, is
/// a refill (or a gating pause): far above a move's misfit, far below a synchrotron's refill
/// (around a second).
pub(super) const REFILL_MIN_EXCESS_S: f64 = 0.05;

/// Whether the pause from `p` to `s` (one pass) is a refill: `beam` has spills and the pause is
/// longer than the move by [`REFILL_MIN_EXCESS_S`].
pub(super) fn is_refill(beam: &ScanningBeam, p: &LoggedSpot, s: &LoggedSpot) -> bool {
    beam.spill.is_some()
        && p.painting == s.painting
        && s.t_start_s - p.t_end_s - beam.move_time_s([p.x_mm, p.y_mm], [s.x_mm, s.y_mm])
            > REFILL_MIN_EXCESS_S
}

/// The refill time and the spill charge of `base`'s spill, fitted into `fitted`'s.
pub(super) fn fit_spills(
    base: &ScanningBeam,
    layers: &[&Layer],
    clock: f64,
    fitted: &mut ScanningBeam,
    values: &mut Vec<FittedValue>,
    outliers: &mut usize,
) {
    let (Some(model), Some(out)) = (base.spill.as_ref(), fitted.spill.as_mut()) else {
        return;
    };
    let mut pauses = Vec::new();
    // MU of each whole spill (one that ran out), and of the delivery that waited for the next.
    let mut spills: Vec<(f64, f64)> = Vec::new();
    for layer in layers {
        let s = layer.spots;
        // Without multi-energy extraction every layer starts with a full spill.
        let mut from = (!model.multi_energy_extraction).then_some(0);
        for k in 1..s.len() {
            if !is_refill(base, &s[k - 1], &s[k]) {
                continue;
            }
            pauses.push(s[k].t_start_s - s[k - 1].t_end_s);
            if let Some(f) = from {
                spills.push((s[f..k].iter().map(|x| x.mu).sum(), s[k].mu));
            }
            from = Some(k);
        }
    }
    fit_refill(model, &pauses, clock, out, values, outliers);
    fit_charge(model, &spills, out, values);
    values.push(kept_value(
        "beam.spill.in_spill_switching_time_s",
        "s",
        model.in_spill_switching_time_s,
        "not determined: a per-spot log holds no layer switch; the base value is kept",
    ));
}

fn fit_refill(
    model: &SpillModel,
    pauses: &[f64],
    clock: f64,
    out: &mut SpillModel,
    values: &mut Vec<FittedValue>,
    outliers: &mut usize,
) {
    const FIELD: &str = "beam.spill.refill_time_s";
    if pauses.len() < 3 {
        values.push(kept_value(FIELD, "s", model.refill_time_s, &format!("not determined: {} pauses inside a pass longer than their move by {REFILL_MIN_EXCESS_S} s (fewer than 3 refills); the base value is kept", pauses.len())));
        return;
    }
    let (m, half, n) = super::moves::robust_median(pauses, clock);
    *outliers += pauses.len() - n;
    out.refill_time_s = m;
    values.push(fitted_value(
        (FIELD, "s", model.refill_time_s),
        m,
        [(m - half).max(0.0), m + half],
        n,
        format!("the median of the {n} pauses inside a pass longer than their move by {REFILL_MIN_EXCESS_S} s (the scanning magnets move while the next spill comes), {} further off left out; interval: the median's, widened by the clock's resolution {clock} s", pauses.len() - n),
    ));
}

fn fit_charge(
    model: &SpillModel,
    spills: &[(f64, f64)],
    out: &mut SpillModel,
    values: &mut Vec<FittedValue>,
) {
    const FIELD: &str = "beam.spill.charge_mu";
    let n = spills.len();
    if n < 3 {
        values.push(kept_value(FIELD, "MU", model.charge_mu, &format!("not determined: {n} whole spills (from a layer's start or a refill to the next refill) in the logs, fewer than 3; the base value is kept")));
        return;
    }
    match model.spot_across_spills {
        SpotAcrossSpills::Split => {
            // Each spill ran out exactly: its MU is its charge.
            let mu: Vec<f64> = spills.iter().map(|s| s.0).collect();
            let m = med(&mu);
            let half =
                student_t95((n - 1) as f64) * 1.2533 * spread(&mu) / (n as f64).sqrt() + 1e-9 * m;
            out.charge_mu = m;
            values.push(fitted_value(
                (FIELD, "MU", model.charge_mu),
                m,
                [m - half, m + half],
                n,
                format!("the median MU of the {n} whole spills (from a layer's start or a refill to the next refill; a spot takes what is left, `split`); interval: the median's"),
            ));
        }
        SpotAcrossSpills::NextSpill => {
            // A spill holds at least what it gave and less than that plus the spot that waited.
            let lo = spills.iter().map(|s| s.0).fold(0.0, f64::max);
            let hi = spills
                .iter()
                .map(|s| s.0 + s.1)
                .fold(f64::INFINITY, f64::min)
                .max(lo);
            let m = 0.5 * (lo + hi);
            out.charge_mu = m;
            values.push(fitted_value(
                (FIELD, "MU", model.charge_mu),
                m,
                [lo, hi],
                n,
                format!("between the most MU a whole spill gave and the least that plus the spot that waited for the next (`next_spill`), over {n} whole spills; the middle"),
            ));
        }
    }
}
