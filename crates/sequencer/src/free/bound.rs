//! A rigorous lower bound of every free-motion delivery of an arc: the certificate of free
//! motion.
//!
//! Every free-motion delivery irradiates layer `k` for `t_k` seconds inside its window
//! `[lo_k, hi_k]`, lets at least the ELST pass between one beam-off and the next beam-on, never
//! reverses, and keeps the speed in `[0, V]` and the acceleration in `[-D, A]`. The bound keeps
//! only these facts (it drops the jerk limit and every window between the two layers it
//! compares), so it holds for every such delivery, whatever the solver finds:
//!
//! - **Speed at a beam's edges.** A beam that ends at speed `v` was, `τ` seconds before, at
//!   least at `v - A·τ` (the acceleration is at most `A`), so it covered at least
//!   `∫ max(0, v - A·τ) dτ` over its `t_k` seconds, which cannot exceed the window `w_k`:
//!   `v ≤ √(2·A·w_k)` when `w_k ≤ A·t_k²/2`, else `v ≤ w_k/t_k + A·t_k/2` (and `v ≤ V`). A beam
//!   that starts at speed `v` likewise with `D`. A layer irradiated at rest has speed 0.
//! - **From beam-off of `i` to beam-on of `j > i`.** That interval holds the beams between them
//!   and at least each switch's ELST: `Σ t_k + Σ ELST`. It also takes the gantry from at most
//!   `hi_i` to at least `lo_j`, leaving at a speed of at most `v̄_off(i)` and arriving at a speed
//!   of at most `v̄_on(j)`. On any such motion the speed at time `t` of an interval of length `T`
//!   is at most `u(t) = min(v̄_off(i) + A·t, V, v̄_on(j) + D·(T - t))`, and `u` is itself such a
//!   motion, so the interval lasts at least the least `T` with `∫₀ᵀ u ≥ lo_j - hi_i`.
//! - **The arc.** Cutting the arc at any chain of layers `0 = i₀ < i₁ < … < n-1` splits its
//!   delivery (first beam-on to last beam-off) into the chain's beams and the intervals between
//!   them, each at least its bound above; dynamic programming takes the best chain.
//!
//! Between arcs the delivery lasts at least the next arc's first ELST; a run-up before an arc
//! and braking after it last at least nothing. The sum is lowered by a relative 1e-9, far above
//! the rounding of these closed forms and of the bisection, which keeps its lower end.
//!
//! **How loose it is.** On the ATOM article cases the free-motion totals are 5.6–14.5 % above
//! this bound, on the bundled lung 20–22 %, on the bundled 722-layer head-neck (little time
//! lost) 0.55 % (docs/model.md). What it leaves out is what the deliveries spend their lost
//! time on: short same-energy switches where the gantry, a few layers after slowing down for a
//! long upward switch, cannot yet move fast enough. Only the jerk and the speeds carried from
//! layer to layer say so. Speed cells per beam edge with a shortest path over them (each switch
//! costing the least time any speeds of its cells allow, with the far window edge as a second
//! distance constraint) gained 0.2–3 s on those cases, not worth its cost; a bound within 1 %
//! needs the acceleration in the state, as the jerk limit (`A/J = 1 s` on the ATOM machine) is
//! what shapes these switches.

use arcsim_planner::Limits;

use super::arc_ends;
use super::solve::{beam_at_rest, End, Start};
use crate::problem::ArcProblem;
use crate::ArcEnds;

/// Longest chain link the dynamic programme tries (layers apart): a longer interval is still
/// bounded through the links between.
const MAX_LINK: usize = 128;

/// A lower bound of the time from an arc's first beam-on to its last beam-off over every
/// free-motion delivery with these arc ends.
pub(crate) fn arc_lower_bound(p: &ArcProblem, lim: &Limits, start: Start, end: End) -> f64 {
    let n = p.len();
    if n == 0 {
        return 0.0;
    }
    let edges: Vec<(f64, f64)> = (0..n).map(|k| p.window_edges(k)).collect();
    let edge_speed = |k: usize, acc: f64| {
        if beam_at_rest(k, n, start, end) {
            0.0
        } else {
            speed_within(p.window[k], p.irradiation_s[k], acc, lim.max_vel)
        }
    };
    let v_on: Vec<f64> = (0..n).map(|k| edge_speed(k, lim.max_decel)).collect();
    let v_off: Vec<f64> = (0..n).map(|k| edge_speed(k, lim.max_accel)).collect();
    // Prefix sums: beams before layer k, ELSTs of the switches into layers 1..=k.
    let mut beams = vec![0.0; n + 1];
    let mut elsts = vec![0.0; n + 1];
    for k in 0..n {
        beams[k + 1] = beams[k] + p.irradiation_s[k];
        elsts[k + 1] = elsts[k] + if k > 0 { p.elst[k] } else { 0.0 };
    }
    // best[j]: the bound from the first beam-on to beam-off of layer j.
    let mut best = vec![0.0; n];
    best[0] = p.irradiation_s[0];
    for j in 1..n {
        let mut b = f64::NEG_INFINITY;
        for i in j.saturating_sub(MAX_LINK)..j {
            let held = (beams[j] - beams[i + 1]) + (elsts[j + 1] - elsts[i + 1]);
            let gap = edges[j].0 - edges[i].1;
            let travel = least_travel_time(gap, v_off[i], v_on[j], lim, held);
            b = b.max(best[i] + held.max(travel));
        }
        best[j] = b + p.irradiation_s[j];
    }
    best[n - 1]
}

/// A lower bound of every free-motion delivery of `problems` (a plan's arcs, in order) with
/// these arc ends: each arc's bound, the next arc's first ELST between arcs.
pub(crate) fn plan_lower_bound(problems: &[ArcProblem], lim: &Limits, ends: ArcEnds) -> f64 {
    let mut total = 0.0;
    for (ai, p) in problems.iter().enumerate() {
        let (start, end) = arc_ends(ends, ai + 1 == problems.len());
        total += arc_lower_bound(p, lim, start, end);
        if ai > 0 {
            total += p.elst.first().copied().unwrap_or(0.0);
        }
    }
    total * (1.0 - 1e-9)
}

/// The highest speed (at most `v_max`) a beam can have at one of its edges when it lasts `t_s`
/// inside a window `w_deg` wide and its speed changes by at most `acc` per second.
fn speed_within(w_deg: f64, t_s: f64, acc: f64, v_max: f64) -> f64 {
    if t_s <= 0.0 {
        return v_max;
    }
    let v = if w_deg <= 0.5 * acc * t_s * t_s {
        (2.0 * acc * w_deg).sqrt()
    } else {
        w_deg / t_s + 0.5 * acc * t_s
    };
    v.min(v_max)
}

/// The farthest the gantry can go in `t` seconds leaving at a speed of at most `v0` and arriving
/// at most at `v1`: the integral of `min(v0 + A·s, V, v1 + D·(t - s))`.
fn farthest(t: f64, v0: f64, v1: f64, lim: &Limits) -> f64 {
    let (a, d, v) = (lim.max_accel, lim.max_decel, lim.max_vel);
    let (v0, v1) = (v0.min(v), v1.min(v));
    let up = (v - v0) / a;
    let down = (v - v1) / d;
    if up + down <= t {
        // Up to V, cruise, down.
        return (v0 + v) * 0.5 * up + v * (t - up - down) + (v + v1) * 0.5 * down;
    }
    // The rising and falling lines cross at s* (clamped to the interval).
    let s = ((v1 + d * t - v0) / (a + d)).clamp(0.0, t);
    let rise = v0 * s + 0.5 * a * s * s;
    let r = t - s;
    let fall = v1 * r + 0.5 * d * r * r;
    rise + fall
}

/// The least time to cover `gap_deg` under [`farthest`], or a value not above it: 0 when there
/// is nothing to cover, `at_most` when that is already enough (the caller takes the larger).
fn least_travel_time(gap_deg: f64, v0: f64, v1: f64, lim: &Limits, at_most: f64) -> f64 {
    if gap_deg <= 0.0 {
        return 0.0;
    }
    if at_most > 0.0 && farthest(at_most, v0, v1, lim) >= gap_deg {
        return at_most;
    }
    let mut lo = at_most.max(0.0);
    let mut hi = lo.max(1e-3);
    while farthest(hi, v0, v1, lim) < gap_deg {
        lo = hi;
        hi *= 2.0;
        if !hi.is_finite() {
            return lo;
        }
    }
    // `farthest` rises with t: keep lo below the crossing.
    for _ in 0..64 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if farthest(mid, v0, v1, lim) < gap_deg {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lim() -> Limits {
        Limits {
            max_jerk: 0.5,
            max_accel: 0.5,
            max_decel: 0.4,
            max_vel: 5.0,
        }
    }

    /// Two layers irradiated at rest 10° apart with 1° windows (9° between them), A 0.5, D 0.4:
    /// without the jerk limit the fastest switch accelerates at A to a peak `v` and brakes at
    /// D, `9 = ½·v²·(1/A + 1/D)`, lasting `v/A + v/D`; the bound is the two beams plus that (or
    /// the ELST when longer).
    #[test]
    fn two_layers_at_rest_are_bounded_by_the_jerk_free_switch() {
        use arcsim_plan::{ResolvedArc, ResolvedLayer, RotationDirection};
        let lim = lim();
        let layer = |k: usize, angle_deg: f64, t: f64, elst: f64| ResolvedLayer {
            control_point: k,
            layer: 0,
            angle_deg,
            window_deg: 1.0,
            energy_mev: 100.0,
            irradiation_s: t,
            spot_irradiation_s: t,
            scanning_s: 0.0,
            burst_switching_s: 0.0,
            spill_waiting_s: 0.0,
            required_speed_deg_per_s: None,
            switch_in_s: elst,
            mu: 0.0,
        };
        for elst in [0.5, 20.0] {
            let arc = ResolvedArc {
                arc_index: 0,
                direction: RotationDirection::Cw,
                layers: vec![layer(0, 0.0, 0.3, 0.0), layer(1, 10.0, 0.7, elst)],
            };
            let p = ArcProblem::new(&arc, &lim);
            let (a, d) = (lim.max_accel, lim.max_decel);
            let peak = (2.0 * 9.0 / (1.0 / a + 1.0 / d)).sqrt();
            assert!(peak < lim.max_vel);
            let switch = (peak / a + peak / d).max(elst);
            let bound = arc_lower_bound(&p, &lim, Start::Rest, End::Rest);
            assert!(
                (bound - (1.0 + switch)).abs() < 1e-9,
                "elst {elst}: {bound} vs {}",
                1.0 + switch
            );
        }
    }

    #[test]
    fn farthest_is_the_integral_of_its_envelope() {
        let lim = lim();
        for &(t, v0, v1) in &[
            (0.5, 0.0, 0.0),
            (3.0, 1.0, 0.2),
            (30.0, 4.0, 5.0),
            (2.0, 5.0, 0.0),
            (1.0, 0.0, 5.0),
        ] {
            let steps = 200_000;
            let h = t / steps as f64;
            let sum: f64 = (0..steps)
                .map(|i| {
                    let s = (i as f64 + 0.5) * h;
                    (v0 + lim.max_accel * s)
                        .min(lim.max_vel)
                        .min(v1 + lim.max_decel * (t - s))
                        * h
                })
                .sum();
            let f = farthest(t, v0, v1, &lim);
            assert!(
                (f - sum).abs() < 1e-6 * (1.0 + sum),
                "{t} {v0} {v1}: {f} vs {sum}"
            );
        }
    }

    #[test]
    fn least_travel_time_is_where_farthest_reaches_the_gap() {
        let lim = lim();
        for &(gap, v0, v1) in &[(0.3, 0.0, 0.0), (10.0, 1.0, 2.0), (200.0, 5.0, 0.0)] {
            let t = least_travel_time(gap, v0, v1, &lim, 0.0);
            assert!(farthest(t, v0, v1, &lim) <= gap);
            assert!(farthest(t * (1.0 + 1e-9) + 1e-12, v0, v1, &lim) >= gap);
        }
        assert_eq!(least_travel_time(-1.0, 0.0, 0.0, &lim, 3.0), 0.0);
    }

    #[test]
    fn a_beam_edge_speed_covers_exactly_the_window() {
        // At the bound's speed the slowest motion (the speed falling at `acc` backwards in
        // time) covers the whole window.
        for &(w, t, acc) in &[(1.0, 0.2, 0.5), (1.0, 5.0, 0.5), (0.1, 3.0, 0.3)] {
            let v = speed_within(w, t, acc, f64::INFINITY);
            let covered = if v <= acc * t {
                v * v / (2.0 * acc)
            } else {
                v * t - 0.5 * acc * t * t
            };
            assert!((covered - w).abs() < 1e-12, "{w} {t} {acc}: {covered}");
        }
        assert_eq!(speed_within(1.0, 0.0, 0.5, 5.0), 5.0);
        assert_eq!(speed_within(0.0, 1.0, 0.5, 5.0), 0.0);
    }
}
