//! One arc as a scheduling problem, its transition cost, and the bidirectional scan.
//!
//! Layer `k` sits at `s_k` degrees along the direction of travel and is irradiated for `t_k` at
//! speed `v_k`, sweeping `v_k·t_k` of its window. Transition `k` (layer k → k+1) covers the gap
//! `s_{k+1} - s_k - (v_k·t_k + v_{k+1}·t_{k+1})/2` from `v_k` to `v_{k+1}` without reversing and
//! lasts at least the ELST of layer k+1.
//!
//! The scan puts every speed as high as its neighbours allow. Where that leaves a long ELST that
//! the move can only last by stopping and dwelling (the ELST falls in the gap between the
//! durations a move can last without stopping and those with a stop), slightly lower speeds
//! last it without the stop and cost less: [`stop_avoiding_scan`] tries them (at low jerk the
//! plain scan lost up to 4.8 % this way on the ATOM cases). It then [`rebalance`]s the
//! transitions that the ELST made it slow down for: a lower end speed lets the braking before
//! them stay faster (up to 0.46 % on the bundled plans and the ATOM cases). Last, a local
//! search ([`polish`]) moves single speeds and pairs of neighbours in opposite directions where
//! that shortens the arc: the scan only lowers, and on closely spaced layers whose transitions
//! barely exceed their ELSTs the shorter schedule raises one speed and lowers its neighbour
//! (bundled head-neck at J 4, A 1, V 2: 1.14 % above `optimal` before it, 0.33 % after).

use crate::servo::grid_duration_in;
use arcsim_plan::ResolvedArc;
use arcsim_planner::{Limits, LinearGap, Move, MoveAnalysis, Reversal};

use crate::SpeedBound;

/// One arc, ready for scheduling (all speeds are magnitudes along the arc's direction).
#[derive(Clone, Debug)]
pub(crate) struct ArcProblem {
    /// +1 for CW (angle increases), -1 for CC.
    pub dir: f64,
    /// Each layer's angle (deg).
    pub angle: Vec<f64>,
    /// Position along travel, from the first layer (deg, non-decreasing).
    pub travel_deg: Vec<f64>,
    /// Each layer's irradiation time (s).
    pub irradiation_s: Vec<f64>,
    /// Each layer's tolerance window (deg).
    pub window: Vec<f64>,
    /// ELST of the switch into each layer (s); entry 0 is the switch into the arc.
    pub elst: Vec<f64>,
    /// Highest speed each layer may have on its own (deg/s): 0 at the ends, else
    /// min(V, window / irradiation time).
    pub speed_cap: Vec<f64>,
    /// What sets each layer's `speed_cap`.
    pub cap_bound: Vec<SpeedBound>,
}

impl ArcProblem {
    pub fn new(arc: &ResolvedArc, lim: &Limits) -> Self {
        let dir = arc.direction.sign();
        let n = arc.layers.len();
        let first = arc.layers.first().map_or(0.0, |l| l.angle_deg);
        let mut p = ArcProblem {
            dir,
            angle: Vec::with_capacity(n),
            travel_deg: Vec::with_capacity(n),
            irradiation_s: Vec::with_capacity(n),
            window: Vec::with_capacity(n),
            elst: Vec::with_capacity(n),
            speed_cap: Vec::with_capacity(n),
            cap_bound: Vec::with_capacity(n),
        };
        for (k, l) in arc.layers.iter().enumerate() {
            p.angle.push(l.angle_deg);
            p.travel_deg.push((dir * (l.angle_deg - first)).max(0.0));
            p.irradiation_s.push(l.irradiation_s);
            p.window.push(l.window_deg);
            p.elst.push(l.switch_in_s);
            let (cap, bound) = if k == 0 || k + 1 == n {
                (0.0, SpeedBound::Rest)
            } else if l.irradiation_s > 0.0 && l.window_deg / l.irradiation_s < lim.max_vel {
                (l.window_deg / l.irradiation_s, SpeedBound::Window)
            } else {
                (lim.max_vel, SpeedBound::MaxSpeed)
            };
            p.speed_cap.push(cap);
            p.cap_bound.push(bound);
        }
        p
    }

    pub fn len(&self) -> usize {
        self.travel_deg.len()
    }

    /// The gap of transition `k` as a linear function of its boundary speeds (planner eq. 5).
    pub fn gap(&self, k: usize) -> LinearGap {
        LinearGap {
            distance: (self.travel_deg[k + 1] - self.travel_deg[k]).max(0.0),
            t_start: self.irradiation_s[k],
            t_end: self.irradiation_s[k + 1],
        }
    }

    /// The planner move of transition `k` at speeds `vs`, `ve`.
    pub fn transition_move(&self, k: usize, vs: f64, ve: f64) -> Move {
        Move {
            distance: self.gap(k).at(vs, ve).max(0.0),
            v_start: vs,
            v_end: ve,
        }
    }

    /// Whether the gap of transition `k` is not negative at speeds `vs`, `ve` (the two layers'
    /// swept windows do not overlap), to rounding.
    fn gap_open(&self, k: usize, vs: f64, ve: f64) -> bool {
        self.gap(k).at(vs, ve) >= -1e-12 * (1.0 + self.travel_deg[k + 1])
    }

    /// The planner's analysis of transition `k`'s forward move at speeds `vs`, `ve`; `None` when
    /// the two layers' sweeps overlap or no forward move fits the gap.
    fn analysis(&self, k: usize, vs: f64, ve: f64, lim: &Limits) -> Option<MoveAnalysis> {
        if !self.gap_open(k, vs, ve) {
            return None;
        }
        let mv = self.transition_move(k, vs, ve);
        MoveAnalysis::new(&mv, lim, Reversal::Forbid).ok()
    }

    /// Layer `k`'s window along travel, `[θ_k − w_k/2, θ_k + w_k/2]` (deg).
    pub fn window_edges(&self, k: usize) -> (f64, f64) {
        let half = 0.5 * self.window[k];
        (self.travel_deg[k] - half, self.travel_deg[k] + half)
    }

    /// Duration of transition `k` at speeds `vs`, `ve`: the shortest feasible duration of at least
    /// max(minimum time, ELST), or `None` when no forward move fits the gap or none lasts the ELST.
    pub fn cost(&self, k: usize, vs: f64, ve: f64, lim: &Limits) -> Option<f64> {
        self.cost_on(k, vs, ve, lim, None)
    }

    /// [`Self::cost`] on a servo period: the shortest whole number of periods, at least the
    /// continuous cost, that the move can last ([`grid_duration_in`]); the continuous cost
    /// without a period.
    pub fn cost_on(
        &self,
        k: usize,
        vs: f64,
        ve: f64,
        lim: &Limits,
        period: Option<f64>,
    ) -> Option<f64> {
        let analysis = self.analysis(k, vs, ve, lim)?;
        let t_opt = analysis.min_time();
        let e = self.elst[k + 1];
        let d = if e <= t_opt {
            t_opt
        } else {
            analysis.shortest_duration_at_least(e)?
        };
        match period {
            Some(ts) => grid_duration_in(&analysis.durations(), d, ts),
            None => Some(d),
        }
    }
}

/// Bidirectional scan: start from `caps`, then lower speeds that cannot be reached (forward
/// pass) or left (backward pass) within their gaps, with the planner's exact bounds; with
/// `with_elst`, also lower both speeds of a transition that cannot last its ELST (by a common
/// factor, bisected). Repeats until nothing changes; the result is feasible.
pub(crate) fn scan(
    p: &ArcProblem,
    lim: &Limits,
    caps: &[f64],
    bounds: &[SpeedBound],
    with_elst: bool,
    period: Option<f64>,
) -> (Vec<f64>, Vec<SpeedBound>) {
    scan_converged(p, lim, caps, bounds, with_elst, period).unwrap_or_else(|| {
        // Not settled after MAX_ROUNDS (never seen in continuous time): rest is always feasible.
        (vec![0.0; p.len()], vec![SpeedBound::StepAndShoot; p.len()])
    })
}

/// The `scan` schedule in continuous time: `settled` ([`scan`] from the caps with ELSTs), then
/// [`avoid_stops`] and [`rebalance`].
pub(crate) fn stop_avoiding_scan(
    p: &ArcProblem,
    lim: &Limits,
    settled: (Vec<f64>, Vec<SpeedBound>),
) -> (Vec<f64>, Vec<SpeedBound>) {
    let mut v = settled.0.clone();
    let mut changed = avoid_stops(p, lim, &mut v);
    changed.extend(rebalance(p, lim, &mut v));
    if changed.is_empty() {
        return settled;
    }
    let bound: Vec<SpeedBound> = v
        .iter()
        .zip(settled.0.iter().zip(&settled.1))
        .map(|(&new, (&old, &b))| {
            if new < old {
                SpeedBound::Elst
            } else if new > old {
                SpeedBound::Gap
            } else {
                b
            }
        })
        .collect();
    // Each lowering was kept for a gain over the transitions it changed (all feasible), so the
    // speeds as they are shorten the arc: a check of those transitions confirms it, and the scan
    // settles the speeds again only if one fails.
    let feasible = changed.iter().all(|&(first, last)| {
        (first..=last).all(|k| transition_check(p, k, v[k], v[k + 1], lim, true, None) == Check::Ok)
    });
    if feasible {
        return (v, bound);
    }
    match scan_converged(p, lim, &v, &bound, true, None) {
        Some(again) if moving_time(p, lim, &again.0) < moving_time(p, lim, &settled.0) => again,
        _ => settled,
    }
}

/// The `scan` schedule: [`stop_avoiding_scan`], then [`polish`]; a speed the polish moved is
/// labelled [`SpeedBound::Optimised`].
pub(crate) fn polished_scan(
    p: &ArcProblem,
    lim: &Limits,
    settled: (Vec<f64>, Vec<SpeedBound>),
) -> (Vec<f64>, Vec<SpeedBound>) {
    let (mut v, mut bounds) = stop_avoiding_scan(p, lim, settled);
    let before = v.clone();
    if polish(p, lim, &mut v) {
        for (b, (new, old)) in bounds.iter_mut().zip(v.iter().zip(&before)) {
            if new != old {
                *b = SpeedBound::Optimised;
            }
        }
    }
    (v, bounds)
}

/// Σ transition durations of an arc at speeds `v` (infinite if one is infeasible).
pub(crate) fn moving_time(p: &ArcProblem, lim: &Limits, v: &[f64]) -> f64 {
    moving_time_on(p, lim, v, None)
}

/// Σ transition durations of speeds `v`, on `period` when given; infinite if one is infeasible.
pub(crate) fn moving_time_on(p: &ArcProblem, lim: &Limits, v: &[f64], period: Option<f64>) -> f64 {
    (0..p.len().saturating_sub(1))
        .map(|k| {
            p.cost_on(k, v[k], v[k + 1], lim, period)
                .unwrap_or(f64::INFINITY)
        })
        .sum()
}

/// The highest start speed of transition `k` that still reaches `ve` within its gap (the
/// braking pass's bound); `ve` itself when the planner finds none.
fn highest_start(p: &ArcProblem, k: usize, ve: f64, lim: &Limits) -> f64 {
    p.gap(k)
        .max_start_speed(ve, lim)
        .ok()
        .flatten()
        .unwrap_or(ve)
}

/// The highest end speed of transition `k` reachable from `vs` within its gap (the speed-up
/// pass's bound); `vs` itself when the planner finds none.
fn highest_end(p: &ArcProblem, k: usize, vs: f64, lim: &Limits) -> f64 {
    p.gap(k).max_end_speed(vs, lim).ok().flatten().unwrap_or(vs)
}

/// Rounds of passes after which [`scan_converged`] gives up.
const MAX_ROUNDS: usize = 200;

/// [`scan`], or `None` when the speeds have not settled after [`MAX_ROUNDS`] rounds (on a servo
/// period, speeds on a reachability bound can keep failing the grid one neighbour after another).
pub(crate) fn scan_converged(
    p: &ArcProblem,
    lim: &Limits,
    caps: &[f64],
    bounds: &[SpeedBound],
    with_elst: bool,
    period: Option<f64>,
) -> Option<(Vec<f64>, Vec<SpeedBound>)> {
    let n = p.len();
    let mut v = caps.to_vec();
    let mut bound = bounds.to_vec();
    if n < 2 {
        return Some((v, bound));
    }
    // Speeds only ever come down; each check is skipped while the pair it last passed with is
    // unchanged (most transitions settle in the first round).
    let mut braked_ok: Vec<Option<(f64, f64)>> = vec![None; n - 1];
    let mut sped_ok: Vec<Option<(f64, f64)>> = vec![None; n - 1];
    let mut move_ok: Vec<Option<(f64, f64)>> = vec![None; n - 1];
    for round in 0..MAX_ROUNDS {
        let mut changed = false;
        for k in (0..n - 1).rev() {
            // Braking branch (v_k >= v_k+1): the highest start speed that still reaches v_k+1.
            if v[k] > v[k + 1] && braked_ok[k] != Some((v[k], v[k + 1])) {
                let b = highest_start(p, k, v[k + 1], lim);
                if v[k] > b {
                    v[k] = b;
                    bound[k] = SpeedBound::Gap;
                    changed = true;
                }
                braked_ok[k] = Some((v[k], v[k + 1]));
            }
        }
        for k in 1..n {
            // Speed-up branch (v_k > v_k-1): the highest end speed reachable from v_k-1.
            if v[k] > v[k - 1] && sped_ok[k - 1] != Some((v[k - 1], v[k])) {
                let b = highest_end(p, k - 1, v[k - 1], lim);
                if v[k] > b {
                    v[k] = b;
                    bound[k] = SpeedBound::Gap;
                    changed = true;
                }
                sped_ok[k - 1] = Some((v[k - 1], v[k]));
            }
        }
        for k in 0..n - 1 {
            if move_ok[k] == Some((v[k], v[k + 1])) {
                continue;
            }
            // A move that does not fit its gap is the passes' job (next round); here only the
            // transitions whose move fits but cannot last the ELST, or that the passes could not
            // settle after many rounds.
            let check = transition_check(p, k, v[k], v[k + 1], lim, with_elst, period);
            if check == Check::DoesNotFit && round < 100 {
                changed = true;
                continue;
            }
            if check != Check::Ok {
                // Largest common factor that makes the transition feasible (rest always is), to
                // 2^-12 of the range searched. Below the factor at which stopping fits in the
                // gap, a stop and dwell lasts any ELST (and any whole number of servo periods
                // beyond it), so the search starts there, with or without a period: the same
                // search keeps a period from choosing speeds whose transitions are shorter.
                let (mut lo, mut hi) = (
                    if with_elst {
                        stop_fits_scale(p, k, v[k], v[k + 1], lim)
                    } else {
                        0.0
                    },
                    1.0f64,
                );
                let ok = |s: f64| {
                    transition_check(p, k, s * v[k], s * v[k + 1], lim, with_elst, period)
                        == Check::Ok
                };
                let resolution = (hi - lo) / 4096.0;
                // Often nothing above the start is feasible: one test settles it.
                if ok(lo + resolution) {
                    lo += resolution;
                    while hi - lo > resolution {
                        let mid = 0.5 * (lo + hi);
                        if ok(mid) {
                            lo = mid;
                        } else {
                            hi = mid;
                        }
                    }
                }
                let why = if check == Check::OffServoGrid {
                    SpeedBound::Servo
                } else if with_elst {
                    SpeedBound::Elst
                } else {
                    SpeedBound::Gap
                };
                for i in [k, k + 1] {
                    if v[i] > 0.0 {
                        v[i] *= lo;
                        bound[i] = why;
                    }
                }
                changed = true;
            }
            move_ok[k] = Some((v[k], v[k + 1]));
        }
        if !changed {
            break;
        }
        if round == MAX_ROUNDS - 1 {
            return None;
        }
    }
    Some((v, bound))
}

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
fn avoid_stops(p: &ArcProblem, lim: &Limits, v: &mut Vec<f64>) -> Vec<(usize, usize)> {
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

/// End speeds, as fractions of the scan's, that [`rebalance`] tries: every 2.5 % from half down
/// to rest. With four (0.5, 0.25, 0.1, 0) the choice jumped between far-apart fractions as a
/// limit changed: at J 0.287, D 0.698 the ATOM head-and-neck case took 347.14 s at A 0.47 and
/// 347.51 s at every A from 0.6 up (issue 30); the finer steps cost about a third more scan time.
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
fn rebalance(p: &ArcProblem, lim: &Limits, v: &mut Vec<f64>) -> Vec<(usize, usize)> {
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
fn lower_speed_up_after(p: &ArcProblem, k: usize, w: &mut [f64], lim: &Limits) -> usize {
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

/// Largest factor `s` in [0, 1] such that the gantry can brake from `s·vs` to rest and start
/// again to `s·ve` within the gap of transition `k` (then a dwell at rest makes the transition
/// last as long as any ELST); 0 (rest) if the speeds are out of range.
fn stop_fits_scale(p: &ArcProblem, k: usize, vs: f64, ve: f64, lim: &Limits) -> f64 {
    p.gap(k).max_stop_scale(vs, ve, lim).unwrap_or(0.0)
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Check {
    Ok,
    DoesNotFit,
    TooShortForElst,
    /// Feasible in continuous time, but no duration of a whole number of servo periods is.
    OffServoGrid,
}

/// Whether transition `k` at `vs`, `ve` is feasible: a forward move fits its gap and (with
/// `with_elst`) some such move lasts at least the ELST, and (with a servo `period`) lasts a
/// whole number of periods. Closed-form tests first; root solves only where they cannot decide.
fn transition_check(
    p: &ArcProblem,
    k: usize,
    vs: f64,
    ve: f64,
    lim: &Limits,
    with_elst: bool,
    period: Option<f64>,
) -> Check {
    if !p.gap_open(k, vs, ve) {
        return Check::DoesNotFit;
    }
    let mv = p.transition_move(k, vs, ve);
    // Closed form: the move fits iff its shortest forward distance does.
    if !LinearGap::plain(mv.distance).fits(vs, ve, lim) {
        return Check::DoesNotFit;
    }
    let e = if with_elst { p.elst[k + 1] } else { 0.0 };
    if period.is_none() {
        // Every move lasts at least its speed change and d / V: when that already covers the
        // ELST, nothing need be solved; else only whether some duration lasts it matters.
        let lower = lim
            .speed_change_duration(vs, ve)
            .max(mv.distance / lim.max_vel);
        if e <= lower {
            return Check::Ok;
        }
    }
    let Ok(analysis) = MoveAnalysis::new(&mv, lim, Reversal::Forbid) else {
        return Check::DoesNotFit;
    };
    let Some(ts) = period else {
        return if analysis.can_last_at_least(e) {
            Check::Ok
        } else {
            Check::TooShortForElst
        };
    };
    // One duration analysis answers both: a duration >= the ELST (the set starts at the minimum
    // time), and one on the grid.
    let set = analysis.durations();
    if set.at_least(e).is_none() {
        return Check::TooShortForElst;
    }
    match grid_duration_in(&set, e, ts) {
        Some(_) => Check::Ok,
        None => Check::OffServoGrid,
    }
}

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
pub(crate) mod tests {
    use super::*;
    use arcsim_plan::{ResolvedLayer, RotationDirection};
    use arcsim_test_support::Rng;

    /// Random limits of the unit tests: J 0.1–4, A and D 0.1–2, V 1–8.
    pub(crate) fn random_limits(rng: &mut Rng) -> Limits {
        Limits::with_decel(
            rng.range(0.1, 4.0),
            rng.range(0.1, 2.0),
            rng.range(0.1, 2.0),
            rng.range(1.0, 8.0),
        )
        .expect("limits")
    }

    /// A random arc of `n` layers: spacing, irradiation time and window drawn uniformly from
    /// the given ranges (deg, s, deg), the ELST of each switch one of `elsts_s`.
    pub(crate) fn random_arc_of(
        rng: &mut Rng,
        n: usize,
        spacing_deg: (f64, f64),
        irradiation_s: (f64, f64),
        window_deg: (f64, f64),
        elsts_s: &[f64],
    ) -> ResolvedArc {
        let mut angle = 0.0;
        let layers = (0..n)
            .map(|k| {
                if k > 0 {
                    angle += rng.range(spacing_deg.0, spacing_deg.1);
                }
                let t = rng.range(irradiation_s.0, irradiation_s.1);
                ResolvedLayer {
                    control_point: k,
                    layer: 0,
                    angle_deg: angle,
                    window_deg: rng.range(window_deg.0, window_deg.1),
                    energy_mev: 100.0,
                    irradiation_s: t,
                    spot_irradiation_s: t,
                    scanning_s: 0.0,
                    required_speed_deg_per_s: None,
                    switch_in_s: elsts_s[rng.below(elsts_s.len())],
                }
            })
            .collect();
        ResolvedArc {
            arc_index: 0,
            direction: RotationDirection::Cw,
            layers,
        }
    }

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
