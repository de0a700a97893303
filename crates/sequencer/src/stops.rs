//! Stop avoidance: lower the speeds of a transition that stops and dwells to last its ELST
//! until it lasts the ELST without the stop (or the stop fits within it).

use crate::problem::ArcProblem;
use crate::scan::{highest_end, highest_start};
use arcsim_planner::Limits;

/// Whether transition `k` at `vs`, `ve` lasts its ELST without stopping (the ELST is in the
/// first interval of its feasible durations), so it costs no more than the ELST.
fn lasts_elst_without_stop(p: &ArcProblem, k: usize, vs: f64, ve: f64, lim: &Limits) -> bool {
    p.analysis(k, vs, ve, lim).is_some_and(|a| {
        let e = p.elst[k + 1];
        e <= a.min_time() || a.durations().intervals()[0].1 * (1.0 + 1e-9) >= e
    })
}

/// Transitions that the scan left on the stop-and-dwell branch (the move lasting exactly the
/// ELST does not fit, so the gantry stops and the transition lasts longer than the ELST) are
/// where its speeds lose most at low jerk: slower speeds that last the ELST without a stop cost
/// the neighbours less than the stop costs. For each such transition, three lowerings are tried
/// (the start speed, the end speed, both by one factor, each to where the ELST fits without a
/// stop, neighbours lowered as the passes would); where the stop-and-go itself is longer than the
/// ELST, three more, each only to where it fits within the ELST (a dwell then makes the
/// transition last exactly the ELST, for a much smaller lowering). The one that shortens the
/// transitions it changes most is kept; the scan then settles the result again.
/// Returns the ranges of transitions changed.
pub(crate) fn avoid_stops(p: &ArcProblem, lim: &Limits, v: &mut Vec<f64>) -> Vec<(usize, usize)> {
    let mut changed = Vec::new();
    for k in 0..p.len().saturating_sub(1) {
        let e = p.elst[k + 1];
        let (vs, ve) = (v[k], v[k + 1]);
        if e <= 0.0 || (vs <= 0.0 && ve <= 0.0) || lasts_elst_without_stop(p, k, vs, ve, lim) {
            continue;
        }
        let highest = |pair: &dyn Fn(f64) -> (f64, f64)| {
            let (mut a, mut b) = (0.0f64, 1.0f64);
            while b - a > 1.0 / 256.0 {
                let mid = 0.5 * (a + b);
                let (x, y) = pair(mid);
                if lasts_elst_without_stop(p, k, x, y, lim) {
                    a = mid;
                } else {
                    b = mid;
                }
            }
            (a > 0.0).then(|| pair(a))
        };
        // Or lower them only as far as the stop-and-go fits in the ELST (a dwell then makes
        // it last exactly the ELST): at low jerk that costs the neighbours much less.
        let fits_with_stop =
            |x: f64, y: f64| p.cost(k, x, y, lim).is_some_and(|c| c <= e * (1.0 + 1e-12));
        let highest_stop = |pair: &dyn Fn(f64) -> (f64, f64)| {
            let (mut a, mut b) = (0.0f64, 1.0f64);
            while b - a > 1.0 / 4096.0 {
                let mid = 0.5 * (a + b);
                let (x, y) = pair(mid);
                if fits_with_stop(x, y) {
                    a = mid;
                } else {
                    b = mid;
                }
            }
            (a > 0.0).then(|| pair(a))
        };
        let mut candidates = vec![
            highest(&|s| (s * vs, ve)),
            highest(&|s| (vs, s * ve)),
            highest(&|s| (s * vs, s * ve)),
        ];
        // Only where the stop-and-go does not fit the ELST already.
        if !fits_with_stop(vs, ve) {
            candidates.extend([
                highest_stop(&|s| (s * vs, ve)),
                highest_stop(&|s| (vs, s * ve)),
                highest_stop(&|s| (s * vs, s * ve)),
            ]);
        }
        let mut best: Option<(f64, Vec<f64>, (usize, usize))> = None;
        // The current durations, each computed once for the three candidates.
        let mut now: Vec<Option<f64>> = vec![None; p.len() - 1];
        for (x, y) in candidates.into_iter().flatten() {
            let (there, (first, last)) = lowered(p, k, v, (x, y), lim);
            let mut gain = 0.0;
            for j in first..=last {
                let before = *now[j]
                    .get_or_insert_with(|| p.cost(j, v[j], v[j + 1], lim).unwrap_or(f64::INFINITY));
                let after = p.cost(j, there[j], there[j + 1], lim);
                gain += before - after.unwrap_or(f64::INFINITY);
            }
            if gain > 1e-9 && best.as_ref().is_none_or(|b| gain > b.0) {
                best = Some((gain, there, (first, last)));
            }
        }
        if let Some((_, w, range)) = best {
            *v = w;
            changed.push(range);
        }
    }
    changed
}

/// The speeds `v` with transition `k`'s two set to `pair` and the neighbours lowered as the
/// scan's passes would (each as high as still reaches or leaves the next), and the first and
/// last transitions they change.
fn lowered(
    p: &ArcProblem,
    k: usize,
    v: &[f64],
    pair: (f64, f64),
    lim: &Limits,
) -> (Vec<f64>, (usize, usize)) {
    let mut w = v.to_vec();
    (w[k], w[k + 1]) = pair;
    let mut first = k;
    while first > 0 && w[first - 1] > w[first] {
        let b = highest_start(p, first - 1, w[first], lim);
        if w[first - 1] <= b {
            break;
        }
        w[first - 1] = b;
        first -= 1;
    }
    let last = lower_speed_up_after(p, k, &mut w, lim);
    let range = (first.saturating_sub(1), (last + 1).min(w.len() - 2));
    (w, range)
}

/// Lowers the speeds after layer `k + 1` that rise above what the layer before them can reach,
/// as the scan's forward pass would, until one already can; returns the last transition index
/// `last` such that layers up to `last + 1` may have changed.
pub(crate) fn lower_speed_up_after(p: &ArcProblem, k: usize, w: &mut [f64], lim: &Limits) -> usize {
    let mut last = k;
    while last + 2 < w.len() && w[last + 2] > w[last + 1] {
        let b = highest_end(p, last + 1, w[last + 1], lim);
        if w[last + 2] <= b {
            break;
        }
        w[last + 2] = b;
        last += 1;
    }
    last
}
