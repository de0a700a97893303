//! Polish: a local search over single speeds and pairs of neighbours after the scan.

use arcsim_planner::Limits;

use crate::problem::ArcProblem;

/// First relative step of [`polish`]; it halves down to [`POLISH_LAST_STEP`].
const POLISH_FIRST_STEP: f64 = 0.1;
/// The last relative step of [`polish`] (then 0.0125: four levels).
const POLISH_LAST_STEP: f64 = 0.01;

/// A local search after the scan. The scan only ever lowers speeds; where closely spaced layers'
/// transitions barely exceed their ELSTs, a shorter schedule raises one speed and lowers its
/// neighbour. Each layer's speed is moved up and down by a relative step, and each pair of
/// neighbours in opposite directions; a move is kept when the exact durations of the
/// transitions it touches sum to less (so every kept schedule is feasible and shorter). Layers
/// near a kept move are tried again; when a pass keeps nothing the step halves. Returns whether
/// any speed changed.
pub(crate) fn polish(p: &ArcProblem, lim: &Limits, v: &mut [f64]) -> bool {
    let n = p.len();
    if n < 3 {
        return false;
    }
    let cost = |k: usize, a: f64, b: f64| p.cost(k, a, b, lim).unwrap_or(f64::INFINITY);
    let better = |c: f64, than: f64| c < than - 1e-12 * (1.0 + than);
    // The duration of each transition at the current speeds.
    let mut t: Vec<f64> = (0..n - 1).map(|k| cost(k, v[k], v[k + 1])).collect();
    let mut changed = false;
    let mut step = POLISH_FIRST_STEP;
    let mut todo = vec![true; n];
    while step >= POLISH_LAST_STEP {
        let mut again = vec![false; n];
        let mut kept = false;
        for k in 1..n - 1 {
            let cap = p.speed_cap[k];
            if !todo[k] || cap <= 0.0 {
                continue;
            }
            // One speed, up or down.
            let mut best = (t[k - 1] + t[k], v[k], 0.0, 0.0);
            for x in [v[k] * (1.0 + step), v[k] * (1.0 - step)] {
                let x = x.min(cap);
                let (a, b) = (cost(k - 1, v[k - 1], x), cost(k, x, v[k + 1]));
                if better(a + b, best.0) {
                    best = (a + b, x, a, b);
                }
            }
            if best.1 != v[k] {
                (v[k], t[k - 1], t[k]) = (best.1, best.2, best.3);
                kept = true;
                // Every move that reads v[k] (a superset of the layers whose moves could change).
                again[k.saturating_sub(2)..(k + 3).min(n)].fill(true);
            }
            // This speed and the next, in opposite directions.
            if k + 2 < n && p.speed_cap[k + 1] > 0.0 {
                let cap_next = p.speed_cap[k + 1];
                let mut best = (t[k - 1] + t[k] + t[k + 1], v[k], v[k + 1], [0.0; 3]);
                for (fx, fy) in [(1.0 + step, 1.0 - step), (1.0 - step, 1.0 + step)] {
                    let (x, y) = ((v[k] * fx).min(cap), (v[k + 1] * fy).min(cap_next));
                    let c = [
                        cost(k - 1, v[k - 1], x),
                        cost(k, x, y),
                        cost(k + 1, y, v[k + 2]),
                    ];
                    if better(c.iter().sum(), best.0) {
                        best = (c.iter().sum(), x, y, c);
                    }
                }
                if (best.1, best.2) != (v[k], v[k + 1]) {
                    (v[k], v[k + 1]) = (best.1, best.2);
                    t[k - 1..k + 2].copy_from_slice(&best.3);
                    kept = true;
                    again[k.saturating_sub(2)..(k + 4).min(n)].fill(true);
                }
            }
        }
        changed |= kept;
        if kept {
            todo = again;
        } else {
            // A finer step can help where a coarser one overshot: every layer again.
            step *= 0.5;
            todo = vec![true; n];
        }
    }
    changed
}
