//! A certified lower bound on an arc's moving time (Σ transition durations) over every choice of
//! continuous layer speeds: the certificate of the `optimal` schedule.
//!
//! **One transition over a box of speeds.** For a cruise speed `c`, the move `vs → c → ve` (two
//! time-optimal speed changes, eq. 3–4, with a cruise at `c` between them) covers the gap `d` in
//! `G(c) = [d + ½(c − vs)·T(vs, c) + ½(c − ve)·T(c, ve)] / c`, since each change covers its mean
//! speed times its duration (eq. 4); it is a move iff its cruise is not negative, and the
//! minimum-time move is one of them (step 1), so `T_min = min G(c)` over those `c`. For a fixed
//! `c`, `x·T(|x|)` rises with `x` and the gap falls with both speeds (eq. 5), so `G` is least at
//! the box's top corner; a cruise of at least zero gives `G >= T(vs, c) + T(c, ve)`, least at the
//! box's points nearest `c`; and a `c` whose cruise is negative at every point of the box is no
//! candidate (the change distances are monotone or quasi-concave in each speed: products of a
//! rising line and a concave duration, so the least over an interval is at its ends). Bisecting
//! `c` over `[0, V]` with these interval bounds gives a lower bound of `T_min` over the box, and
//! with the ELST one of the transition's duration.
//!
//! The box is first cut down to the speeds that can have a move at all ([`clip_to_moves`]: each
//! speed is tested against the other span's ends, with the gap and the change distance taken at
//! the same pair of speeds), so its top corner is not far beyond reach. Where no point of the
//! box has a move that lasts the ELST (none stops, and every candidate is shorter: `G` is
//! greatest at the bottom corner), the box has no transition at all.
//!
//! **The arc.** Each layer's speed lies in `[0, speed_bound]`; the ranges are cut into cells,
//! finest around a feasible schedule's speeds, and dynamic programming over cell pairs, each
//! costing its box bound, bounds the arc from below (every schedule's speeds lie in one cell per
//! layer). A cell whose best path (forward plus backward values) is above the feasible schedule
//! cannot hold the optimum and is dropped; the cells on the bound's path and the few with the
//! best paths per layer are halved, round after round, until the bound is within the target or
//! the rounds are spent. After each round every cell is cut to the speeds that have a move to
//! and from some kept cell of its neighbours ([`reduce_cells`]): a cell's top often reaches past
//! where the next transition can still brake, and the box bound of the transition before it
//! would otherwise take that speed. The bound holds whenever it stops. Not yet bounded: the
//! extra time of a move that must stop and dwell to last its ELST (the box bound then only says
//! "the ELST"), which is one reason the gap stays above 0.01 %. The main one: on ATOM prostate
//! the bound's path after 12 rounds runs through cells where every pair of neighbours has moves,
//! and each box bound is close to the least duration sampled in its box (0.04 s summed over the
//! path), yet no schedule has its speeds in all of those cells: the speeds of a cell that the
//! transition before it can reach are not those from which the next transition has a move.
//!
//! Floating point: feasibility is tested with a tolerance in the permissive direction and the
//! result is lowered by a relative 1e-9, far above the rounding of these closed forms.

use std::collections::HashMap;

use arcsim_plan::ResolvedArc;
use arcsim_planner::{Limits, LinearGap};
use serde::{Deserialize, Serialize};

use crate::optimal::speed_bound;
use crate::problem::arc_time_on_grid;
use crate::problem::{moving_time, ArcProblem};
use crate::servo::ticks;
use crate::{Delivery, InputError, Motion, SequenceError};

/// A closed interval of speeds (deg/s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Span {
    pub lo: f64,
    pub hi: f64,
}

impl Span {
    fn mid(self) -> f64 {
        0.5 * (self.lo + self.hi)
    }
}

/// Relative margin the final bound is lowered by (outward rounding).
const ROUNDING: f64 = 1e-9;
/// Most interval evaluations in one transition's bisection over `c`.
const MAX_C_STEPS: usize = 40;

/// The least distance of the speed change `vs → c` over `vs ∈ s`, `c ∈ [c0, c1]`.
fn least_change_in(s: Span, c0: f64, c1: f64, lim: &Limits) -> f64 {
    if c0 > s.hi {
        // Rising in c, quasi-concave in vs below it.
        lim.speed_change_distance(s.lo, c0)
            .min(lim.speed_change_distance(s.hi, c0))
    } else if c1 < s.lo {
        // Rising in vs, quasi-concave in c below it.
        lim.speed_change_distance(s.lo, c0)
            .min(lim.speed_change_distance(s.lo, c1))
    } else {
        0.0
    }
}

/// The least distance of the speed change `c → ve` over `ve ∈ e`, `c ∈ [c0, c1]`.
fn least_change_out(e: Span, c0: f64, c1: f64, lim: &Limits) -> f64 {
    if c0 > e.hi {
        lim.speed_change_distance(c0, e.lo)
            .min(lim.speed_change_distance(c0, e.hi))
    } else if c1 < e.lo {
        lim.speed_change_distance(c0, e.lo)
            .min(lim.speed_change_distance(c1, e.lo))
    } else {
        0.0
    }
}

/// The box of one transition: start speeds `s`, end speeds `e`, and the gap's range over them.
struct TransitionBox {
    s: Span,
    e: Span,
    /// Gap at the box's top corner (least).
    d_min: f64,
    /// Gap at the box's bottom corner (most).
    d_max: f64,
}

impl TransitionBox {
    /// Whether some point of the box may have a candidate profile with cruise speed in
    /// `[c0, c1]`: its cruise cannot be negative everywhere (least change distances against the
    /// most gap).
    fn may_cruise(&self, c0: f64, c1: f64, lim: &Limits) -> bool {
        let room = self.d_max
            - least_change_in(self.s, c0, c1, lim)
            - least_change_out(self.e, c0, c1, lim);
        room >= -1e-9 * (1.0 + self.d_max.abs())
    }

    /// A lower bound of every candidate profile's duration with cruise speed in `[c0, c1]`
    /// over the box; infinite when no point of the box has such a candidate.
    fn over(&self, c0: f64, c1: f64, lim: &Limits) -> f64 {
        let (s, e) = (self.s, self.e);
        if !self.may_cruise(c0, c1, lim) {
            return f64::INFINITY;
        }
        let t_in = if c0 > s.hi {
            lim.speed_change_duration(s.hi, c0)
        } else if c1 < s.lo {
            lim.speed_change_duration(s.lo, c1)
        } else {
            0.0
        };
        let t_out = if c0 > e.hi {
            lim.speed_change_duration(c0, e.hi)
        } else if c1 < e.lo {
            lim.speed_change_duration(c1, e.lo)
        } else {
            0.0
        };
        let num = self.d_min
            + 0.5 * (c0 - s.hi) * lim.speed_change_duration(s.hi, c0)
            + 0.5 * (c0 - e.hi) * lim.speed_change_duration(c0, e.hi);
        let g = if c1 <= 0.0 {
            // At rest the cruise covers nothing: the stop fits exactly or not at all. The cruise
            // left at c = 0 is `num`, least at the top corner (the stops' distances rise with the
            // speeds), so a positive `num` leaves every point of the box with distance to cover.
            if num > 1e-9 * (1.0 + self.d_max.abs()) {
                return f64::INFINITY;
            }
            f64::NEG_INFINITY
        } else if num >= 0.0 {
            num / c1
        } else if c0 > 0.0 {
            num / c0
        } else {
            f64::NEG_INFINITY
        };
        g.max(t_in + t_out)
    }

    /// An upper bound of every candidate profile's duration with cruise speed in `[c0, c1]` over
    /// the box (`G` is greatest at the bottom corner and its numerator rises with `c`);
    /// -inf when no point of the box has such a candidate, +inf when `c0` is rest.
    fn longest_over(&self, c0: f64, c1: f64, lim: &Limits) -> f64 {
        let (s, e) = (self.s, self.e);
        if !self.may_cruise(c0, c1, lim) {
            return f64::NEG_INFINITY;
        }
        if c0 <= 0.0 {
            return f64::INFINITY;
        }
        let num = self.d_max
            + 0.5 * (c1 - s.lo) * lim.speed_change_duration(s.lo, c1)
            + 0.5 * (c1 - e.lo) * lim.speed_change_duration(c1, e.lo);
        if num >= 0.0 {
            num / c0
        } else {
            num / c1
        }
    }

    /// Whether no point of the box has a move lasting `t` or longer: every candidate profile
    /// is shorter, and none stops (a move that can stop can dwell). Without a stop the
    /// longest move is a candidate (the deepest valley that still covers the gap, step 2).
    fn cannot_last(&self, t: f64, lim: &Limits, cuts: &[f64]) -> bool {
        let short = t * (1.0 - 1e-9) - 1e-12;
        let mut open: Vec<(f64, f64)> = cuts.windows(2).map(|w| (w[0], w[1])).collect();
        if cuts.len() == 1 {
            open.push((cuts[0], cuts[0]));
        }
        let mut steps = 0;
        while let Some((c0, c1)) = open.pop() {
            if self.longest_over(c0, c1, lim) < short {
                continue;
            }
            if steps >= MAX_C_STEPS || c1 <= c0 {
                return false;
            }
            steps += 1;
            let m = 0.5 * (c0 + c1);
            open.push((c0, m));
            open.push((m, c1));
        }
        true
    }
}

/// The box cut down to the speeds that can have a move at all; `None` when none can. A forward
/// move from `vs` to `ve` fits iff the gap `g(vs, ve)` holds the shorter of the direct speed
/// change `D(vs, ve)` and stopping and starting again `S(vs, ve)` (planner, `reach`).
///
/// For start speeds above every end speed (braking), fix `vs`: with the change `Δ = vs − ve`,
/// `D = vs·T(Δ) − Δ·T(Δ)/2` where the duration `T` is concave in `Δ` and `Δ·T` convex (eq. 3–4:
/// `2√(Δ/J)`, then `Δ/a + a/J` with `a` the deceleration limit, joined with equal slopes), so
/// `D` is concave in `ve` and `g − D` (`g` linear) convex: it is greatest at `e.lo` or `e.hi`;
/// `g − S` is greatest at `e.lo` (`S` rises, `g` falls with `ve`). So `vs` has a move to some
/// end speed iff one of those three, each taken at one pair of speeds, is not negative. Each
/// falls as `vs` rises (a larger change at a higher mean speed, a narrower gap), so bisection
/// finds the highest start speed that passes. Likewise for end speeds above every start speed,
/// with `vs` at `s.lo` or `s.hi`.
fn clip_to_moves(gap: &LinearGap, s: Span, e: Span, lim: &Limits) -> Option<(Span, Span)> {
    let tol = 1e-9 * (1.0 + gap.distance);
    let dist = |a: f64, b: f64| lim.speed_change_distance(a, b);
    let stop = |a: f64, b: f64| dist(a, 0.0) + dist(0.0, b);
    let fits = |a: f64, b: f64| gap.at(a, b) + tol >= dist(a, b);
    let stop_fits = |a: f64, b: f64| gap.at(a, b) + tol >= stop(a, b);
    let braking = |vs: f64| fits(vs, e.lo) || fits(vs, e.hi) || stop_fits(vs, e.lo);
    let s = highest_passing(s, e.hi, braking)?;
    let speeding = |ve: f64| fits(s.lo, ve) || fits(s.hi, ve) || stop_fits(s.lo, ve);
    let e = highest_passing(e, s.hi, speeding)?;
    Some((s, e))
}

/// `span` without its speeds above `floor` that fail `passes` (monotone: true up to some speed,
/// false above); `None` when none is left.
fn highest_passing(span: Span, floor: f64, passes: impl Fn(f64) -> bool) -> Option<Span> {
    if span.hi <= floor || passes(span.hi) {
        return Some(span);
    }
    let lo = span.lo.max(floor);
    if !passes(lo) {
        return (span.lo < floor).then_some(Span { hi: floor, ..span });
    }
    let (mut ok, mut bad) = (lo, span.hi);
    for _ in 0..40 {
        let m = 0.5 * (ok + bad);
        if passes(m) {
            ok = m;
        } else {
            bad = m;
        }
    }
    Some(Span { hi: bad, ..span })
}

/// A lower bound of transition `k`'s duration over start speeds `s` and end speeds `e`;
/// infinite when no speeds of the box have a move.
pub(crate) fn transition_bound(p: &ArcProblem, k: usize, s: Span, e: Span, lim: &Limits) -> f64 {
    let gap = p.gap(k);
    let Some((s, e)) = clip_to_moves(&gap, s, e, lim) else {
        return f64::INFINITY;
    };
    let b = TransitionBox {
        s,
        e,
        d_min: gap.at(s.hi, e.hi),
        d_max: gap.at(s.lo, e.lo),
    };
    if b.d_max < -1e-9 * (1.0 + gap.distance) {
        return f64::INFINITY;
    }
    let elst = p.elst[k + 1];
    let v = lim.max_vel;
    // Cut [0, V] at the box's ends, where the interval bounds change form.
    let mut cuts = vec![0.0, s.lo, s.hi, e.lo, e.hi, v];
    cuts.iter_mut().for_each(|c| *c = c.clamp(0.0, v));
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    if elst > 0.0 && b.cannot_last(elst, lim, &cuts) {
        return f64::INFINITY;
    }
    let mut open: Vec<(f64, f64, f64)> = Vec::with_capacity(MAX_C_STEPS + 8);
    let mut best_point = f64::INFINITY;
    for &c in &cuts {
        best_point = best_point.min(b.over(c, c, lim));
    }
    for w in cuts.windows(2) {
        open.push((b.over(w[0], w[1], lim), w[0], w[1]));
    }
    if cuts.len() == 1 {
        open.push((best_point, cuts[0], cuts[0]));
    }
    let mut steps = 0;
    loop {
        // The interval with the least bound decides the bound over c.
        let Some((i, &(lb, c0, c1))) = open
            .iter()
            .enumerate()
            .min_by(|x, y| x.1 .0.total_cmp(&y.1 .0))
        else {
            return f64::INFINITY;
        };
        if best_point <= elst {
            // Some c has a bound at most the ELST: the ELST is the transition's bound.
            return elst;
        }

        if lb >= elst && best_point - lb <= 1e-7 * (1.0 + lb) || steps >= MAX_C_STEPS || c1 <= c0 {
            return lb.max(elst);
        }
        let m = 0.5 * (c0 + c1);
        open.swap_remove(i);
        best_point = best_point.min(b.over(m, m, lim));
        open.push((b.over(c0, m, lim), c0, m));
        open.push((b.over(m, c1, lim), m, c1));
        steps += 1;
    }
}

/// The finest first cells, around a feasible schedule's speed, are the layer's speed range
/// times 2^-FINEST wide.
const FINEST: i32 = 12;
/// Cells with the best paths through them halved per layer and round.
const SPLITS_PER_LAYER: usize = 4;
/// Cells of the finest width on either side of the schedule's speed.
const FINE_CELLS: usize = 8;

/// A layer's first cells: finest around `v` (where the optimum most likely is), doubling in
/// width away from it, covering `[0, hi]`.
fn first_cells(v: f64, hi: f64) -> Vec<Span> {
    if hi <= 0.0 {
        return vec![Span { lo: 0.0, hi: 0.0 }];
    }
    let v = v.clamp(0.0, hi);
    let mut cuts = vec![0.0, hi, v];
    let fine = hi * 2f64.powi(-FINEST);
    for i in 1..=FINE_CELLS {
        cuts.push((v - fine * i as f64).max(0.0));
        cuts.push((v + fine * i as f64).min(hi));
    }
    let mut w = fine * FINE_CELLS as f64;
    while w < hi {
        w *= 2.0;
        cuts.push((v - w).max(0.0));
        cuts.push((v + w).min(hi));
    }
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    cuts.windows(2)
        .map(|w| Span { lo: w[0], hi: w[1] })
        .collect()
}

/// Pair bounds of one arc, computed when first needed.
struct PairBounds<'a> {
    p: &'a ArcProblem,
    lim: &'a Limits,
    period: Option<f64>,
    cache: HashMap<(usize, [u64; 4]), f64>,
}

impl PairBounds<'_> {
    /// A cheap lower bound: the ELST and the speed change between the spans' nearest speeds.
    fn quick(&self, k: usize, s: Span, e: Span) -> f64 {
        let change = if e.lo > s.hi {
            self.lim.speed_change_duration(s.hi, e.lo)
        } else if s.lo > e.hi {
            self.lim.speed_change_duration(s.lo, e.hi)
        } else {
            0.0
        };
        self.on_period(change.max(self.p.elst[k + 1]))
    }

    fn exact(&mut self, k: usize, s: Span, e: Span) -> f64 {
        let key = (
            k,
            [
                s.lo.to_bits(),
                s.hi.to_bits(),
                e.lo.to_bits(),
                e.hi.to_bits(),
            ],
        );
        if let Some(&t) = self.cache.get(&key) {
            return t;
        }
        let t = self.on_period(transition_bound(self.p, k, s, e, self.lim));
        self.cache.insert(key, t);
        t
    }

    fn on_period(&self, t: f64) -> f64 {
        match self.period {
            Some(ts) if t.is_finite() => ticks(t, ts),
            _ => t,
        }
    }

    /// One DP step: the best values `to_values[j] = min_i from_values[i] + pair(i, j)` and
    /// their arguments. `forward`: transition `k` runs from `from` to `to`; else from `to` to
    /// `from` (the backward pass). Pairs that cannot improve are skipped unevaluated.
    fn step(
        &mut self,
        k: usize,
        from: &[Span],
        from_values: &[f64],
        to: &[Span],
        forward: bool,
    ) -> (Vec<f64>, Vec<usize>) {
        let mut order: Vec<usize> = (0..from.len())
            .filter(|&i| from_values[i].is_finite())
            .collect();
        order.sort_by(|&a, &b| from_values[a].total_cmp(&from_values[b]));
        let floor = self.on_period(self.p.elst[k + 1]);
        let mut values = vec![f64::INFINITY; to.len()];
        let mut args = vec![usize::MAX; to.len()];
        for (j, &t) in to.iter().enumerate() {
            for &i in &order {
                let f = from_values[i];
                if f + floor >= values[j] {
                    break;
                }
                let (s, e) = if forward { (from[i], t) } else { (t, from[i]) };
                if f + self.quick(k, s, e) >= values[j] {
                    continue;
                }
                let c = f + self.exact(k, s, e);
                if c < values[j] {
                    values[j] = c;
                    args[j] = i;
                }
            }
        }
        (values, args)
    }
}

/// A lower bound of the arc's moving time over every feasible choice of layer speeds.
/// `speeds`: a feasible schedule, of moving time `feasible` (it centres the first cells and
/// prunes; the result is at most it, to rounding); `target`: stop once the bound is within this
/// of `feasible` (s); `period`: the servo period, when transitions last whole periods;
/// `rounds`: most rounds of bound, prune and split (the bound holds whenever it stops).
pub(crate) fn moving_time_bound(
    p: &ArcProblem,
    lim: &Limits,
    speeds: &[f64],
    feasible: f64,
    target: f64,
    period: Option<f64>,
    rounds: usize,
) -> f64 {
    let n = p.len();
    if n < 2 {
        return 0.0;
    }
    let mut cells: Vec<Vec<Span>> = (0..n)
        .map(|k| first_cells(speeds[k], speed_bound(p, lim, k)))
        .collect();
    let mut pairs = PairBounds {
        p,
        lim,
        period,
        cache: HashMap::new(),
    };
    let keep = feasible + 1e-9 * (1.0 + feasible);
    let mut bound = 0.0;
    for _ in 0..rounds {
        let mut fwd: Vec<Vec<f64>> = Vec::with_capacity(n);
        let mut back: Vec<Vec<usize>> = Vec::with_capacity(n);
        fwd.push(vec![0.0; cells[0].len()]);
        back.push(Vec::new());
        for k in 0..n - 1 {
            let (v, a) = pairs.step(k, &cells[k], &fwd[k], &cells[k + 1], true);
            fwd.push(v);
            back.push(a);
        }
        let Some((mut j, &b)) = fwd[n - 1]
            .iter()
            .enumerate()
            .min_by(|x, y| x.1.total_cmp(y.1))
        else {
            break;
        };
        bound = b;
        if !bound.is_finite() || bound >= feasible - target {
            break;
        }
        // The lower-bound path: its cells are where the bound is loose.
        let mut on_path = vec![usize::MAX; n];
        for k in (0..n).rev() {
            on_path[k] = j;
            if k > 0 {
                j = back[k][j];
            }
        }
        let mut bwd: Vec<Vec<f64>> = vec![Vec::new(); n];
        bwd[n - 1] = vec![0.0; cells[n - 1].len()];
        for k in (0..n - 1).rev() {
            let (v, _) = pairs.step(k, &cells[k + 1], &bwd[k + 1], &cells[k], false);
            bwd[k] = v;
        }
        // Drop the cells no schedule as fast as `feasible` can use; halve those on the path.
        for k in 0..n {
            let mut next = Vec::with_capacity(cells[k].len() + 1);
            let mut through: Vec<f64> =
                (0..cells[k].len()).map(|i| fwd[k][i] + bwd[k][i]).collect();
            through.sort_by(f64::total_cmp);
            let split_below = through
                .get(SPLITS_PER_LAYER)
                .copied()
                .unwrap_or(f64::INFINITY);
            for (i, &c) in cells[k].iter().enumerate() {
                if fwd[k][i] + bwd[k][i] > keep {
                    continue;
                }
                let promising = fwd[k][i] + bwd[k][i] < split_below;
                if (i == on_path[k] || promising) && c.hi > c.lo {
                    let m = c.mid();
                    next.push(Span { lo: c.lo, hi: m });
                    next.push(Span { lo: m, hi: c.hi });
                } else {
                    next.push(c);
                }
            }
            if next.is_empty() {
                // Rounding only: nothing beats `feasible`, and the bound found stands.
                return bound * (1.0 - ROUNDING);
            }
            cells[k] = next;
        }
        reduce_cells(p, lim, &mut cells);
    }
    bound * (1.0 - ROUNDING)
}

/// Cuts every cell down to the speeds that have a move to some cell of the next layer and from
/// some cell of the previous one ([`clip_to_moves`] over each pair, which keeps every speed of a
/// box that has a move); drops cells with none. A schedule faster than the feasible one has its
/// speeds in kept cells and a move in every transition, so its speeds stay in the cut cells.
fn reduce_cells(p: &ArcProblem, lim: &Limits, cells: &mut [Vec<Span>]) {
    let n = cells.len();
    for k in 0..n {
        let mut next = Vec::with_capacity(cells[k].len());
        for &c in &cells[k] {
            let mut hi = c.hi;
            if k + 1 < n {
                let gap = p.gap(k);
                let top = cells[k + 1]
                    .iter()
                    .filter_map(|&e| clip_to_moves(&gap, c, e, lim))
                    .map(|(s, _)| s.hi)
                    .fold(f64::NEG_INFINITY, f64::max);
                hi = hi.min(top);
            }
            if k > 0 {
                let gap = p.gap(k - 1);
                let top = cells[k - 1]
                    .iter()
                    .filter_map(|&s| clip_to_moves(&gap, s, c, lim))
                    .map(|(_, e)| e.hi)
                    .fold(f64::NEG_INFINITY, f64::max);
                hi = hi.min(top);
            }
            if hi >= c.lo {
                next.push(Span { lo: c.lo, hi });
            }
        }
        if !next.is_empty() {
            cells[k] = next;
        }
    }
}

/// A proven lower bound of the delivery time and how far a delivery is above it: over every
/// choice of constant layer speeds for a constant-speed delivery, over every free motion for a
/// free-motion one.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Certificate {
    /// Constant motion: no schedule of these layers with a constant speed per layer is faster on
    /// this machine (s); on a servo period, none whose transitions last whole periods. Free
    /// motion: no delivery with these windows, ELSTs, limits and arc ends is faster (a far
    /// looser bound: it leaves out the jerk limit; docs/model.md).
    pub lower_bound_s: f64,
    /// The delivery's total minus the bound (s): at most this much is left to gain.
    pub gap_s: f64,
}

/// Rounds of bound, prune and split that [`certify`] runs at most.
pub const CERTIFY_ROUNDS: usize = 12;

/// The certificate of a delivery of `arcs` on `limits`. Constant motion (any schedule): a lower
/// bound of every constant-speed schedule, within 0.01 % of the delivery's total or as close
/// as `rounds` rounds get. Free motion: a lower bound of every free-motion delivery with the
/// delivery's arc ends (closed forms and one dynamic programme; `rounds` unused).
pub fn certify(
    arcs: &[ResolvedArc],
    limits: &Limits,
    delivery: &Delivery,
    rounds: usize,
) -> Result<Certificate, SequenceError> {
    limits.validate().map_err(SequenceError::Limits)?;
    if delivery.motion == Motion::Free {
        let problems: Vec<ArcProblem> = arcs.iter().map(|a| ArcProblem::new(a, limits)).collect();
        if delivery.layers.len() != problems.iter().map(ArcProblem::len).sum::<usize>() {
            return Err(InputError::DeliveryNotOfArcs.into());
        }
        let bound = crate::free::plan_lower_bound(&problems, limits, delivery.arc_ends);
        return Ok(Certificate {
            lower_bound_s: bound,
            gap_s: (delivery.total_s - bound).max(0.0),
        });
    }
    let period = delivery.servo_period_s;
    let mut first = 0;
    let mut gained = 0.0;
    for arc in arcs {
        let p = ArcProblem::new(arc, limits);
        let n = p.len();
        let rows = delivery
            .layers
            .get(first..first + n)
            .ok_or_else(|| SequenceError::from(InputError::DeliveryNotOfArcs))?;
        let speeds: Vec<f64> = rows.iter().map(|r| r.speed_deg_per_s.abs()).collect();
        first += n;
        let found = match period {
            Some(ts) => {
                arc_time_on_grid(&p, &speeds, limits, ts) - p.irradiation_s.iter().sum::<f64>()
            }
            None => moving_time(&p, limits, &speeds),
        };
        let target = 1e-4 * delivery.total_s / arcs.len() as f64;
        let bound = moving_time_bound(&p, limits, &speeds, found, target, period, rounds);
        if found.is_finite() {
            gained += (found - bound).max(0.0);
        }
    }
    Ok(Certificate {
        lower_bound_s: delivery.total_s - gained,
        gap_s: gained,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::tests::{random_arc_of, random_limits};
    use arcsim_planner::{MoveAnalysis, Reversal};
    use arcsim_test_support::Rng;

    fn random_problem(rng: &mut Rng, lim: &Limits) -> ArcProblem {
        let arc = random_arc_of(
            rng,
            6,
            (0.3, 4.0),
            (0.05, 1.5),
            (0.3, 4.0),
            &[0.0, 0.5, 1.0, 2.0, 5.0],
        );
        ArcProblem::new(&arc, lim)
    }

    /// Random limits, a random arc, one of its transitions and a box of speeds whose sides are
    /// up to one of `widths` (fractions of V) long.
    fn random_box(rng: &mut Rng, widths: &[f64]) -> (Limits, ArcProblem, usize, Span, Span, f64) {
        let lim = random_limits(rng);
        let p = random_problem(rng, &lim);
        let k = rng.below(p.len() - 1);
        let v = lim.max_vel;
        let width = widths[rng.below(widths.len())] * v;
        let mut span = || {
            let lo = rng.range(0.0, v);
            Span {
                lo,
                hi: (lo + width * rng.unit()).min(v),
            }
        };
        let (s, e) = (span(), span());
        (lim, p, k, s, e, width)
    }

    /// Point `q` of a box's sample: its four corners, then random points.
    fn box_point(rng: &mut Rng, s: Span, e: Span, q: usize) -> (f64, f64) {
        match q {
            0 => (s.lo, e.lo),
            1 => (s.hi, e.hi),
            2 => (s.lo, e.hi),
            3 => (s.hi, e.lo),
            _ => (rng.range(s.lo, s.hi), rng.range(e.lo, e.hi)),
        }
    }

    /// The box bound against the delivery model's duration at points of the box (its corners
    /// and random points), over boxes from the whole speed range down to 1e-5 of it: never
    /// above a feasible duration; on the smallest boxes, close to the least one found.
    #[test]
    fn box_bound_is_below_every_duration_in_the_box() {
        let mut rng = Rng::new(0xb0b0_0008);
        let (mut checked, mut tight) = (0, 0.0f64);
        for _ in 0..400 {
            let (lim, p, k, s, e, width) = random_box(&mut rng, &[1.0, 0.1, 1e-2, 1e-3, 1e-5]);
            let v = lim.max_vel;
            let bound = transition_bound(&p, k, s, e, &lim);
            assert!(!bound.is_nan());
            let mut least = f64::INFINITY;
            for q in 0..80 {
                let (vs, ve) = box_point(&mut rng, s, e, q);
                if let Some(t) = p.cost(k, vs, ve, &lim) {
                    checked += 1;
                    least = least.min(t);
                    assert!(
                        t >= bound * (1.0 - 1e-9) - 1e-12,
                        "transition {k} of {p:?} at {vs}, {ve} on {lim:?}: lasts {t} s, bound {bound} s over {s:?} x {e:?}"
                    );
                }
            }
            if width <= 1e-5 * v && least.is_finite() {
                tight = tight.max((least - bound) / least);
            }
        }
        assert!(checked > 4000, "only {checked} feasible points");
        // Boxes of 1e-5 of the speed range: the bound is within 1 % of the least duration found.
        assert!(
            tight < 1e-2,
            "bound {tight} below the least duration on the smallest boxes"
        );
    }

    /// The clip keeps every speed pair of a box that has a forward move (the planner's own
    /// analysis at random points and corners of boxes from the whole speed range down to 1e-3
    /// of it), and it cuts boxes: whole ones and parts of ones that have moves.
    #[test]
    fn clip_keeps_every_speed_pair_with_a_move() {
        let mut rng = Rng::new(0xc11b_0001);
        let (mut moves, mut dropped, mut cut, mut tight) = (0, 0, 0, 0);
        for _ in 0..3000 {
            let (lim, p, k, s, e, _) = random_box(&mut rng, &[1.0, 0.3, 0.1, 1e-2, 1e-3]);
            let clipped = clip_to_moves(&p.gap(k), s, e, &lim);
            let moves_between = |a: f64, b: f64| {
                p.gap(k).at(a, b) >= 0.0
                    && MoveAnalysis::new(&p.transition_move(k, a, b), &lim, Reversal::Forbid)
                        .is_ok()
            };
            let mut has_move = false;
            for q in 0..100 {
                let (vs, ve) = box_point(&mut rng, s, e, q);
                if !moves_between(vs, ve) {
                    continue;
                }
                has_move = true;
                moves += 1;
                let (cs, ce) = clipped.unwrap_or_else(|| {
                    panic!("{vs}, {ve} has a move, yet {s:?} x {e:?} was dropped ({lim:?}, {p:?}, k {k})")
                });
                let inside = |x: f64, sp: Span| x >= sp.lo && x <= sp.hi * (1.0 + 1e-9) + 1e-12;
                assert!(
                    inside(vs, cs) && inside(ve, ce),
                    "{vs}, {ve} has a move, outside the clip {cs:?} x {ce:?} of {s:?} x {e:?} ({lim:?}, {p:?}, k {k})"
                );
            }
            match clipped {
                None => dropped += 1,
                Some((cs, ce)) if has_move && (cs != s || ce != e) => {
                    cut += 1;
                    tight +=
                        usize::from(cs.hi < s.hi && cs.hi > e.hi || ce.hi < e.hi && ce.hi > cs.hi);
                    // Tight: just below a cut end, a speed still has a move (the cut is where
                    // moves end, not a loose estimate below it). A cut at the other span's top
                    // only ends the speeds the test covers (above every speed of the other span).
                    if cs.hi < s.hi && cs.hi > cs.lo && cs.hi > e.hi {
                        let x = cs.hi - 1e-6 * (cs.hi - cs.lo);
                        assert!(
                            moves_between(x, e.lo) || moves_between(x, e.hi),
                            "start speeds cut at {} of {s:?}, yet {x} has no move ({lim:?}, {p:?}, k {k})",
                            cs.hi
                        );
                    }
                    if ce.hi < e.hi && ce.hi > ce.lo && ce.hi > cs.hi {
                        let x = ce.hi - 1e-6 * (ce.hi - ce.lo);
                        assert!(
                            moves_between(cs.lo, x) || moves_between(cs.hi, x),
                            "end speeds cut at {} of {e:?}, yet {x} has no move ({lim:?}, {p:?}, k {k})",
                            ce.hi
                        );
                    }
                }
                _ => {}
            }
        }
        println!(
            "{moves} points with a move, {dropped} boxes dropped, {cut} cut ({tight} checked)"
        );
        assert!(
            moves > 50_000 && dropped > 1000 && cut > 150 && tight > 100,
            "{moves} points with a move, {dropped} boxes dropped, {cut} cut ({tight} checked)"
        );
    }
}
