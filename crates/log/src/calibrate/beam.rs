//! The beam fits: the time per MU and between spots (`per_mu`), or the scanning model's speeds
//! and settling, from every logged layer's beam-on time.

use arcsim_plan::{layer_beam_time, BeamModel, Machine, PerMuBeam};

use super::gaps::*;
use super::stats::*;
use super::types::*;

/// The fitted beam model (when fitted) and the spread of a layer's beam time.
pub(super) struct BeamResult {
    pub(super) model: Option<BeamModel>,
    pub(super) sd_fraction: f64,
}

/// `(MU term, moves term, logged beam-on)` of each logged layer with spots.
pub(super) fn beam_rows(runs: &[LoggedRun], matched: &[Matched]) -> Vec<(f64, f64, f64)> {
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
pub(super) fn beam_ls(rows: &[(f64, f64, f64)], idx: &[usize]) -> Option<[f64; 2]> {
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

pub(super) fn fit_beam(
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
pub(super) fn beam_time_sd_fraction(pairs: &[(f64, f64)], res_sd: f64) -> f64 {
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
pub(super) fn scanning_rows(matched: &[Matched], burst_s: f64) -> (Vec<[f64; 4]>, Vec<f64>) {
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
pub(super) fn fit_scanning_beam(
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
