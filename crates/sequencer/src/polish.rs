//! Polish: a local search after the scan that moves single speeds and pairs of neighbours.

use crate::problem::ArcProblem;
use arcsim_planner::Limits;

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::moving_time;
    use crate::problem::tests::{random_arc_of, random_limits};
    use crate::scan::{polished_scan, scan, stop_avoiding_scan};
    use crate::SpeedBound;
    use arcsim_plan::ResolvedArc;
    use arcsim_test_support::Rng;

    /// A random arc of closely spaced layers with short irradiation times and ELSTs of
    /// 0–2 s: the setting where transitions barely exceed their ELSTs.
    fn random_arc(rng: &mut Rng) -> ResolvedArc {
        let n = 4 + rng.below(12);
        random_arc_of(
            rng,
            n,
            (0.2, 3.0),
            (0.05, 1.0),
            (0.2, 3.0),
            &[0.0, 0.3, 0.5, 1.0, 2.0],
        )
    }

    /// The polish keeps only moves that shorten the arc: on random arcs and limits its schedule
    /// is never longer than the scan it starts from, every transition has a move, and every
    /// speed stays within its cap; it shortens some.
    #[test]
    fn polish_never_lengthens_the_scan_and_keeps_it_feasible() {
        let mut rng = Rng::new(0x9011_5800);
        let (mut shorter, mut cases) = (0, 0);
        for _ in 0..300 {
            let lim = random_limits(&mut rng);
            let p = ArcProblem::new(&random_arc(&mut rng), &lim);
            let settled = scan(&p, &lim, &p.speed_cap, &p.cap_bound, true, None);
            let (start, _) = stop_avoiding_scan(&p, &lim, settled.clone());
            let before = moving_time(&p, &lim, &start);
            assert!(before.is_finite(), "the scan is feasible");
            let (v, bounds) = polished_scan(&p, &lim, settled);
            let after = moving_time(&p, &lim, &v);
            cases += 1;
            assert!(
                after <= before,
                "polish lengthened {p:?} on {lim:?}: {before} -> {after} s"
            );
            for k in 0..p.len() {
                assert!(
                    (0.0..=p.speed_cap[k]).contains(&v[k]),
                    "speed {} of layer {k} outside [0, {}]",
                    v[k],
                    p.speed_cap[k]
                );
                if v[k] != start[k] {
                    assert_eq!(bounds[k], SpeedBound::Optimised);
                }
                if k + 1 < p.len() {
                    assert!(
                        p.cost(k, v[k], v[k + 1], &lim).is_some(),
                        "transition {k} infeasible"
                    );
                }
            }
            if after < before * (1.0 - 1e-9) {
                shorter += 1;
            }
        }
        assert!(
            shorter >= cases / 4,
            "polish shortened only {shorter} of {cases} random arcs"
        );
        println!("polish shortened {shorter} of {cases} random arcs");
    }
}
