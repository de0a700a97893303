//! Rebalance: where the scan braked into a transition that lasts exactly its ELST, a lower end
//! speed lets the braking chain before it stay faster.

use crate::problem::ArcProblem;
use crate::scan::{highest_end, highest_start};
use crate::stops::lower_speed_up_after;
use arcsim_planner::Limits;

/// End speeds, as fractions of the scan's, that [`rebalance`] tries: every 2.5 % from half down
/// to rest. Fine steps keep the choice from jumping between far-apart fractions as a limit
/// changes (a few coarse ones make the total step with A on the ATOM head-and-neck case); they
/// cost about a third more scan time than four.
const REBALANCE_END_SPEEDS: [f64; 21] = [
    0.5, 0.475, 0.45, 0.425, 0.4, 0.375, 0.35, 0.325, 0.3, 0.275, 0.25, 0.225, 0.2, 0.175, 0.15,
    0.125, 0.1, 0.075, 0.05, 0.025, 0.0,
];

/// The scan lowers both speeds of a transition that cannot last its ELST by one factor; where
/// the gantry brakes into it, that factor also slows every layer of the braking chain before it.
/// Lowering the end speed further instead (at low jerk, often nearly to rest) lets the start and
/// the chain before it stay faster: for each transition that lasts exactly its ELST with both
/// ends moving and is entered braking, a few lower end speeds are tried, each with the highest
/// start that still lasts the ELST, the braking chain before it raised as far as it can still
/// reach that start (and be reached), and the speed-up after it lowered as the passes would. The
/// largest gain over the transitions changed, each costed exactly, is kept. Returns the ranges
/// of transitions changed.
pub(crate) fn rebalance(p: &ArcProblem, lim: &Limits, v: &mut Vec<f64>) -> Vec<(usize, usize)> {
    let n = p.len();
    let mut changed = Vec::new();
    for k in 1..n.saturating_sub(2) {
        let e = p.elst[k + 1];
        let (vs, ve) = (v[k], v[k + 1]);
        if e <= 0.0 || vs <= 0.0 || ve <= 0.0 || v[k - 1] <= vs {
            continue;
        }
        match p.cost(k, vs, ve, lim) {
            Some(c) if c <= e * (1.0 + 1e-12) => {}
            _ => continue,
        }
        let fits = |x: f64, y: f64| p.cost(k, x, y, lim).is_some_and(|c| c <= e * (1.0 + 1e-12));
        let mut best: Option<(f64, Vec<f64>, (usize, usize))> = None;
        for frac in REBALANCE_END_SPEEDS {
            let y = frac * ve;
            let top = p.speed_cap[k].min(highest_start(p, k, y, lim));
            if top <= vs || !fits(vs, y) {
                continue;
            }
            let (mut a, mut b) = (vs, top);
            if fits(top, y) {
                a = top;
            } else {
                for _ in 0..12 {
                    let m = 0.5 * (a + b);
                    if fits(m, y) {
                        a = m;
                    } else {
                        b = m;
                    }
                }
            }
            let mut w = v.clone();
            (w[k], w[k + 1]) = (a, y);
            let mut first = k;
            while first > 0 {
                let i = first - 1;
                let mut t = p.speed_cap[i].min(highest_start(p, i, w[i + 1], lim));
                if i > 0 && w[i - 1] < t {
                    t = t.min(highest_end(p, i - 1, w[i - 1], lim));
                }
                if t <= w[i]
                    || p.cost(i, t, w[i + 1], lim).is_none()
                    || (i > 0 && p.cost(i - 1, w[i - 1], t, lim).is_none())
                {
                    break;
                }
                w[i] = t;
                first = i;
            }
            let last = lower_speed_up_after(p, k, &mut w, lim);
            let (lo, hi) = (first.saturating_sub(1), (last + 1).min(n - 2));
            let cost = |x: &[f64]| -> f64 {
                (lo..=hi)
                    .map(|j| p.cost(j, x[j], x[j + 1], lim).unwrap_or(f64::INFINITY))
                    .sum()
            };
            let gain = cost(v) - cost(&w);
            if gain > 1e-9 && best.as_ref().is_none_or(|b| gain > b.0) {
                best = Some((gain, w, (lo, hi)));
            }
        }
        if let Some((_, w, r)) = best {
            *v = w;
            changed.push(r);
        }
    }
    changed
}
