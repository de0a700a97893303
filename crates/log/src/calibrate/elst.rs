//! The ELST fits: the lowest cluster of each kind's gaps, then the model (the value whose
//! re-simulated gaps last as the logged ones), a line in the energy step, and the bounds of what
//! the logs do not show.

use arcsim_plan::{ElstModel, Machine};
use arcsim_sequencer::{Delivery, Options};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::matching::LoggedLayer;

use super::gaps::*;
use super::stats::*;
use super::types::*;

/// The fitted ELST model and the spreads (up, down, same).
pub(super) struct ElstResult {
    pub(super) model: ElstModel,
    pub(super) sd: [f64; 3],
}

pub(super) fn base_elst(base: &Machine) -> (Option<f64>, Option<f64>, f64) {
    match &base.elst {
        ElstModel::Constant { up_s, down_s, .. } => {
            (Some(*up_s), Some(*down_s), base.elst.same_s())
        }
        ElstModel::Polynomial { down_s, .. } => (None, Some(*down_s), base.elst.same_s()),
        _ => (None, None, base.elst.same_s()),
    }
}

/// The fitted values' standard deviations from their 95 % intervals (half-width / 1.96), for
/// the values the logs determined; 0 for the rest.
pub(super) fn uncertainty_of(values: &[FittedValue]) -> arcsim_plan::FitUncertainty {
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

/// The single-valued ELSTs: field, class of switches, slot ([`elst_slot`]).
pub(super) const ELST_KINDS: [(&str, &str, usize); 3] = [
    ("elst.up_s", "upward switch", 0),
    ("elst.down_s", "downward switch", 1),
    ("elst.same_s", "same energy", 2),
];

/// Sets the ELST of kind `k` ([`elst_slot`]) of a machine (nothing where the model has none).
pub(super) fn set_elst(k: usize) -> impl Fn(&mut Machine, f64) + Copy + Send + Sync {
    move |m: &mut Machine, e: f64| {
        if let Some(x) = elst_slot(&mut m.elst, k) {
            *x = e;
        }
    }
}

/// The ELST slot of kind `k` (0 up, 1 down, 2 same) of a constant (or, for down and same, a
/// polynomial) ELST model.
pub(super) fn elst_slot(elst: &mut ElstModel, k: usize) -> Option<&mut f64> {
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
pub(super) fn elst_by_model(
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
pub(super) fn refine_by_model_jointly(
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
    // A 0.5 % low reads J 1 % high). Fitted by the model itself (a record: no trace), it is
    // refined with them.
    let set_accel = super::gantry::set_accel;
    let accel_by_model = by_model(ACCEL);
    let accel: Vec<crate::joint::Nuisance> = values
        .iter()
        .filter(|v| v.field == ACCEL && v.determined && v.value > 0.0 && !accel_by_model)
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
    if accel_by_model {
        fields.push(ACCEL);
        params.push(crate::joint::Param {
            set: &set_accel,
            start: machine.gantry.max_accel_deg_per_s2,
            range: arcsim_plan::ACCEL_RANGE_DEG_PER_S2,
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
pub(super) fn bound_unseen_elst(
    machine: &mut Machine,
    runs: &[LoggedRun],
    matched: &[Matched],
    all_gaps: &[Gap],
    options: &Options,
    values: &mut [FittedValue],
) {
    let logged: Vec<&[LoggedLayer]> = matched.iter().map(|m| m.layers.as_slice()).collect();
    let no_timeline = Options {
        build_timeline: false,
        ..options.clone()
    };
    // The machine as it stands, simulated once for every kind until a kind changes it.
    let mut as_is: Option<Option<Vec<Delivery>>> = None;
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
        let (sims, at_zero) = match as_is.take() {
            Some(sims) => (sims, rms(0.0)),
            None => rayon::join(
                || crate::transitions::simulate_runs(machine, runs, &no_timeline),
                || rms(0.0),
            ),
        };
        let at_fit = sims
            .as_deref()
            .map(|d| crate::transitions::rms_of(d, &logged, which));
        as_is = Some(sims);
        let (Some((at_fit, n)), Some((at_zero, _))) = (at_fit, at_zero) else {
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
        as_is = None;
    }
}

/// A clock this many times coarser than a switch cannot time it (s per s).
pub(super) const CLOCK_RESOLVES: f64 = 3.0;

/// An ELST fitted from logs of intervals whose clock (`clock_s`, their coarsest time
/// resolution; 0 for sampled logs) is too coarse to time it (below [`CLOCK_RESOLVES`] ×
/// `clock_s`): a record in whole seconds reads a 0.7 s switch as 0 or 1 s, and the fit's own
/// interval does not know it. Not determined; the base value is kept.
pub(super) fn unresolved_by_clock(machine: &mut Machine, clock_s: f64, values: &mut [FittedValue]) {
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

/// One ELST value being fitted: its field, the class of switches, the base value, a seed.
pub(super) struct ElstKind<'a> {
    pub(super) field: &'a str,
    pub(super) class: &'a str,
    pub(super) base: Option<f64>,
    pub(super) seed: u64,
}

pub(super) fn durations_of(gaps: &[Gap], class: &str) -> Vec<f64> {
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
pub(super) fn dithered(durations: &[f64], res_sd: f64, seed: u64) -> Vec<f64> {
    let period = res_sd * 6f64.sqrt();
    let mut rng = ChaCha8Rng::seed_from_u64(0xd17e_0000 + seed);
    durations
        .iter()
        .map(|x| (x + period * (rng.random::<f64>() - 0.5)).max(0.0))
        .collect()
}

/// One ELST (see [`fit_elst`]) and its spread; its value row pushed to `values`.
pub(super) fn fit_one_elst(
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
pub(super) fn fit_elst(
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

/// Least squares of `y = c0 + c1 x` over the points `idx` of `pts`.
pub(super) fn line(pts: &[(f64, f64)], idx: &[usize]) -> Option<[f64; 2]> {
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
pub(super) fn line_cluster(pts: &[(f64, f64)], res_sd: f64) -> Option<([f64; 2], f64, usize)> {
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

pub(super) fn fit_up_line(
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
