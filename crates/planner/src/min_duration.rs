//! Step 2: the durations a move can last, and a move that lasts a requested (longer) duration.
//!
//! Between two energy layers the gantry must not arrive before the next energy is ready, so a
//! transition lasts at least the energy-layer switching time.
//!
//! For a duration T, consider the profiles `v_s → c`, cruise at `c`, `c → v_e` (bang-bang speed
//! changes as in step 1, eq. 3–4) with the cruise filling the time: `t_c = T - T(c) >= 0`. Their
//! distance `f(c) = D(c) + c·(T - T(c))` is continuous in `c`; with the speed changes `u1`, `u2`,
//! `df/dc = T - T(c)/2 - Σ u_i·T'(u_i)/2 >= T - T(c) >= 0` on the peak side and `<= 0` (in the
//! same form, sign flipped) as a valley deepens, since `u·T'(u) <= T(u)` for eq. 3–4.
//! The set of trajectories lasting T is convex (linear dynamics, convex bounds), so the distances
//! they cover form an interval `[m(T), M(T)]`: `M(T)` is the highest peak lasting T, `m(T)` the
//! deepest valley lasting T (the hardest slow-down, then the hardest speed-up), and T is feasible
//! iff `m(T) <= d <= M(T)`; a root of `f(c) = d` is then the profile. `M(T) >= d` holds for every T
//! above the minimum time. Where two separate speed changes would take longer than T, the direct
//! change with cruises at both end speeds fills in.
//!
//! With `D(x)`, `T(x)` of the cruise-free valley at depth `x` below `lo = min(v_s, v_e)`, `D`
//! rises from `d0` (eq. 6) to a hump (at `x_top`) while the valley stays above rest and falls
//! once it is at or below rest (for `c <= 0`, `D'(x) <= 0` by the same bound), so the feasible
//! durations are
//! `[T_min, T(x_b)] ∪ [T(x_a), ∞)`, `x_b < x_a` the roots of `D(x) = d` on either side of the
//! hump, or everything from `T_min` when `d` is above the hump:
//! - [`Reversal::Forbid`]: the speed stays in `[0, V]`, so the valley stops at rest (`x <= lo`)
//!   and then dwells: the second interval exists iff stopping fits (`D(lo) <= d`).
//! - [`Reversal::Allow`]: the speed may go down to `-V`, so the valley continues below rest to
//!   `c = -V` and then cruises there, `m(T) = D(lo + V) - V·(T - T(lo + V))`, which falls without
//!   bound: the second interval always exists, starting at the root `x_a` of `D(x) = d` in
//!   `(x_top, lo + V]`, or at `T(lo + V) + (D(lo + V) - d)/V` when even the valley at `-V` covers
//!   more than `d`.

use crate::min_time::{build_seven_phases, solve_shape, unreachable, Shape};
use crate::profile::{Profile, Segment, SevenPhases};
use crate::roots::{brent, golden_max, golden_max_tol};
use crate::speed_change::{duration, periods, SpeedChange};
use crate::travel::{min_forward_distance, travel_frame, Travel};
use crate::{Limits, Move, PlannerError, Reversal};

/// Feasible durations of a move: a union of closed intervals (s), in increasing order; the last
/// upper end may be infinite.
#[derive(Clone, Debug, PartialEq)]
pub struct DurationSet {
    intervals: Vec<(f64, f64)>,
}

impl DurationSet {
    /// The intervals `[lo, hi]` (s), in increasing order; the last `hi` may be infinite.
    pub fn intervals(&self) -> &[(f64, f64)] {
        &self.intervals
    }

    /// Shortest feasible duration (the minimum time).
    pub fn min(&self) -> f64 {
        self.intervals.first().map_or(f64::INFINITY, |i| i.0)
    }

    /// Longest feasible duration (infinite when the axis can stop and dwell, or reverse).
    pub fn max(&self) -> f64 {
        self.intervals.last().map_or(f64::NEG_INFINITY, |i| i.1)
    }

    /// Whether `t` is feasible (with a relative tolerance of 1e-9).
    pub fn contains(&self, t: f64) -> bool {
        self.intervals
            .iter()
            .any(|&(lo, hi)| t >= lo * (1.0 - 1e-9) && t <= hi * (1.0 + 1e-9))
    }

    /// The shortest feasible duration >= `t` (e.g. an ELST that falls in a gap of the set), or
    /// `None` when every feasible duration is shorter.
    pub fn at_least(&self, t: f64) -> Option<f64> {
        self.intervals
            .iter()
            .find(|&&(_, hi)| hi * (1.0 + 1e-9) >= t)
            .map(|&(lo, _)| lo.max(t))
    }
}

/// A move in its direction of travel and its minimum-time shape (step 1), or why there is none.
fn min_time_shape(
    mv: &Move,
    limits: &Limits,
    reversal: Reversal,
) -> Result<(Travel, Shape), PlannerError> {
    let forbid = reversal == Reversal::Forbid;
    let tr = travel_frame(mv, limits, forbid)?;
    if forbid && tr.d < min_forward_distance(tr.vs, tr.ve, limits) {
        return Err(unreachable(mv, &tr, limits));
    }
    let opt = solve_shape(tr.vs, tr.ve, tr.d, limits);
    if forbid && opt.c < -1e-12 * limits.max_vel {
        return Err(unreachable(mv, &tr, limits));
    }
    Ok((tr, opt))
}

/// The verified minimum-time profile of a move: what [`MoveAnalysis::profile`] returns for a
/// zero minimum duration, without the duration analysis.
pub(crate) fn min_time_profile(
    mv: &Move,
    limits: &Limits,
    reversal: Reversal,
) -> Result<Profile, PlannerError> {
    let (tr, opt) = min_time_shape(mv, limits, reversal)?;
    let prof = build_seven_phases(opt, tr.dir, limits);
    let forbid = reversal == Reversal::Forbid;
    prof.verify(tr.dir * tr.d, tr.dir * tr.ve, limits, forbid, 1e-9)?;
    Ok(prof)
}

/// The phases of a shape (eq. 3 for each speed change), `dir` its direction of travel.
fn seven_phases(s: &Shape, dir: f64, lim: &Limits) -> SevenPhases {
    let (t1, t2) = periods(s.u1, lim.max_jerk, lim.accel_bound(s.vs, s.c));
    let (t4, t5) = periods(s.u2, lim.max_jerk, lim.accel_bound(s.c, s.ve));
    SevenPhases {
        direction: dir,
        v_start: s.vs,
        v_peak: s.c,
        v_end: s.ve,
        t1,
        t2,
        t3: s.cruise,
        t4,
        t5,
    }
}

/// Samples of `f` used to bracket the root on one part of the profile family.
const SAMPLES: usize = 24;

/// One move analysed once: its minimum time and the durations it can last, for schedulers that
/// ask several questions of the same move (each answer costs a few root solves at most).
///
/// Built by [`MoveAnalysis::new`]; [`crate::plan`] is this analysis followed by
/// [`MoveAnalysis::profile`] and, with a servo period, the discretisation.
#[derive(Clone, Debug)]
pub struct MoveAnalysis {
    /// The move in its direction of travel.
    tr: Travel,
    lim: Limits,
    reversal: Reversal,
    /// The minimum-time shape (step 1), its phases and its duration.
    opt: Shape,
    opt_phases: SevenPhases,
    t_opt: f64,
}

/// Which single-cruise profiles a parameter `x >= 0` describes (offsets keep tiny speed changes
/// at full precision, as in step 1).
#[derive(Clone, Copy, Debug)]
enum Side {
    /// Valley `c = min(v_s, v_e) - x`.
    Valley,
    /// Between the end speeds: `c = v_s + x` towards `v_e`.
    Plateau,
    /// Peak `c = max(v_s, v_e) + x`.
    Peak,
}

/// A profile candidate: duration and distance without cruise, extreme speed and speed changes.
#[derive(Clone, Copy, Debug)]
struct Candidate {
    t: f64,
    d: f64,
    c: f64,
    u1: f64,
    u2: f64,
}

/// Where the second interval of feasible durations starts: a cruise-free valley at depth `x`,
/// or (reversal allowed) the valley at `-V` with a cruise, at duration `t`.
#[derive(Clone, Copy, Debug)]
struct SecondStart {
    x: f64,
    t: f64,
}

impl MoveAnalysis {
    /// Analyses `mv` under `limits`: validates it, maps it to its direction of travel and solves
    /// its minimum-time shape (step 1, eq. 5–8).
    ///
    /// With [`Reversal::Forbid`] a move whose end speed cannot be reached in the distance without
    /// reversing is [`PlannerError::Unreachable`] (carrying the reachable speeds); bad input is
    /// [`PlannerError::InvalidLimit`], [`PlannerError::InvalidInput`],
    /// [`PlannerError::SpeedAboveLimit`] or [`PlannerError::SpeedAgainstTravel`].
    pub fn new(mv: &Move, limits: &Limits, reversal: Reversal) -> Result<Self, PlannerError> {
        let (tr, opt) = min_time_shape(mv, limits, reversal)?;
        let opt_phases = seven_phases(&opt, tr.dir, limits);
        Ok(MoveAnalysis {
            tr,
            lim: *limits,
            reversal,
            opt,
            t_opt: opt_phases.duration(),
            opt_phases,
        })
    }

    /// The minimum time of the move (s): step 1, eq. 5–8.
    pub fn min_time(&self) -> f64 {
        self.t_opt
    }

    /// The seven phases of the minimum-time profile (speed change to the extreme speed, cruise,
    /// speed change to the end speed; eq. 3 for each change), without building the profile.
    pub fn min_time_phases(&self) -> SevenPhases {
        self.opt_phases
    }

    /// Every duration the move can last (see the module documentation): one or two intervals
    /// from the minimum time; the last is unbounded when the axis can stop and dwell, and always
    /// with reversal allowed.
    pub fn durations(&self) -> DurationSet {
        let all = DurationSet {
            intervals: vec![(self.t_opt, f64::INFINITY)],
        };
        match self.valley_ends() {
            None => all,
            Some((x_b, second)) => {
                let first = (self.t_opt, self.eval(Side::Valley, x_b).t.max(self.t_opt));
                match second {
                    Some(s) => DurationSet {
                        intervals: vec![first, (s.t, f64::INFINITY)],
                    },
                    None => DurationSet {
                        intervals: vec![first],
                    },
                }
            }
        }
    }

    /// The shortest duration >= `t` that the move can last (Ruckig's `minimum_duration`
    /// semantics): the minimum time when `t` is below it, `t` itself when feasible, else the start
    /// of the next feasible interval; `None` when every feasible duration is shorter than `t`.
    ///
    /// With reversal forbidden one root solve decides most cases, as in
    /// [`MoveAnalysis::can_last_at_least`]: the cruise-free valley lasting `t` covers the least
    /// distance of any profile lasting `t`, so `t` is feasible iff that valley fits the gap.
    /// Only a `t` between the two intervals, where stopping fits, needs the whole
    /// [`DurationSet`] (the start of the second interval).
    pub fn shortest_duration_at_least(&self, t: f64) -> Option<f64> {
        if t <= self.t_opt {
            return Some(self.t_opt);
        }
        if self.every_duration_fits() {
            return Some(t);
        }
        let lo = self.tr.vs.min(self.tr.ve);
        // Stopping fits and t is at least the stop-and-go time: a dwell at rest makes it.
        let stop = self.eval(Side::Valley, lo);
        let stop_fits = stop.d <= self.tr.d;
        if stop_fits && t >= stop.t {
            return Some(t);
        }
        if self.reversal == Reversal::Forbid {
            // The same 1e-9 tolerance as `DurationSet::at_least` at an interval's end.
            let t_in = t / (1.0 + 1e-9);
            if t_in >= stop.t {
                // Stopping does not fit: the first interval ends below the stop-and-go time.
                return None;
            }
            if let Some(x) = self.x_limit(Side::Valley, lo, t_in) {
                if self.eval(Side::Valley, x).d <= self.tr.d {
                    return Some(t);
                }
                if !stop_fits {
                    return None;
                }
            }
        }
        self.durations().at_least(t)
    }

    /// Whether the move can last `t` seconds or longer: whether
    /// [`MoveAnalysis::shortest_duration_at_least`] has an answer, decided with one root solve
    /// instead of the whole [`DurationSet`]. The shortest distance coverable in a time `t` is the
    /// cruise-free valley lasting `t`; it rises with `t` to a hump and then falls, so (with
    /// reversal forbidden) a duration >= `t` exists iff stopping fits or the valley lasting `t`
    /// fits. Conservative by 1e-9 in time against [`DurationSet::at_least`]. Always true with
    /// reversal allowed.
    pub fn can_last_at_least(&self, t: f64) -> bool {
        if t <= self.t_opt || self.reversal == Reversal::Allow {
            return true;
        }
        if self.every_duration_fits() {
            return true;
        }
        let lo = self.tr.vs.min(self.tr.ve);
        let stop = self.eval(Side::Valley, lo);
        if stop.d <= self.tr.d {
            return true;
        }
        let t = t * (1.0 + 1e-9);
        if t >= stop.t {
            return false;
        }
        match self.x_limit(Side::Valley, lo, t) {
            // The valley lasting exactly t (T(0) < t < T(lo), T increasing in the depth).
            Some(x) => self.eval(Side::Valley, x).d <= self.tr.d,
            // Even the shallowest valley lasts longer than t: inside the first interval.
            None => true,
        }
    }

    /// The verified profile lasting [`MoveAnalysis::shortest_duration_at_least`]`(min_duration)`
    /// (the minimum time for `min_duration = 0`), re-integrated and checked against the target
    /// and the limits. [`PlannerError::DurationInfeasible`] (with the feasible durations) when
    /// every feasible duration is shorter than `min_duration`.
    pub fn profile(&self, min_duration: f64) -> Result<Profile, PlannerError> {
        if !(min_duration.is_finite() && min_duration >= 0.0) {
            return Err(PlannerError::InvalidInput {
                name: "min_duration",
                value: min_duration,
                expected: "a finite number >= 0",
            });
        }
        if min_duration <= self.t_opt {
            let prof = build_seven_phases(self.opt, self.tr.dir, &self.lim);
            self.verify(&prof, self.t_opt)?;
            return Ok(prof);
        }
        let infeasible = |requested: f64| PlannerError::DurationInfeasible {
            requested,
            feasible: self.durations().intervals,
        };
        // A duration with a profile is feasible: the set is only needed when there is none.
        match self.profile_at(min_duration) {
            Some(prof) => self.verify(&prof, min_duration).map(|()| prof),
            None => {
                let target = self
                    .shortest_duration_at_least(min_duration)
                    .ok_or_else(|| infeasible(min_duration))?;
                let prof = self.profile_at(target).ok_or_else(|| infeasible(target))?;
                self.verify(&prof, target).map(|()| prof)
            }
        }
    }

    /// The integration check of `prof` against the move, the limits and the duration `target`.
    fn verify(&self, prof: &Profile, target: f64) -> Result<(), PlannerError> {
        let forbid = self.reversal == Reversal::Forbid;
        let distance = self.tr.dir * self.tr.d;
        prof.verify(distance, self.tr.dir * self.tr.ve, &self.lim, forbid, 1e-9)?;
        if (prof.duration() - target).abs() > 1e-9 * target.max(1.0) {
            return Err(PlannerError::Verification(format!(
                "duration {} instead of the requested {target}",
                prof.duration()
            )));
        }
        Ok(())
    }

    /// The lowest speed along travel a profile may reach: rest, or `-V` with reversal allowed.
    fn floor(&self) -> f64 {
        match self.reversal {
            Reversal::Forbid => 0.0,
            Reversal::Allow => -self.lim.max_vel,
        }
    }

    /// Deepest valley offset: down to the floor speed.
    fn valley_depth(&self) -> f64 {
        (self.tr.vs.min(self.tr.ve) - self.floor()).max(0.0)
    }

    fn eval(&self, side: Side, x: f64) -> Candidate {
        let (vs, ve, lim) = (self.tr.vs, self.tr.ve, &self.lim);
        let (lo, hi) = (vs.min(ve), vs.max(ve));
        let (c, u1, u2, a1, a2) = match side {
            Side::Valley => (
                lo - x,
                (vs - lo) + x,
                (ve - lo) + x,
                lim.max_decel,
                lim.max_accel,
            ),
            Side::Peak => (
                hi + x,
                (hi - vs) + x,
                (hi - ve) + x,
                lim.max_accel,
                lim.max_decel,
            ),
            Side::Plateau => {
                let a = lim.accel_bound(vs, ve);
                let c = if ve >= vs { vs + x } else { vs - x };
                (c, x, ((ve - vs).abs() - x).max(0.0), a, a)
            }
        };
        let t1 = duration(u1, lim.max_jerk, a1);
        let t2 = duration(u2, lim.max_jerk, a2);
        Candidate {
            t: t1 + t2,
            d: 0.5 * (vs + c) * t1 + 0.5 * (c + ve) * t2,
            c,
            u1,
            u2,
        }
    }

    /// Largest offset on `side` (up to `x_max`) whose cruise-free profile fits in `t`; T grows
    /// with the offset on the valley and peak sides.
    fn x_limit(&self, side: Side, x_max: f64, t: f64) -> Option<f64> {
        if self.eval(side, 0.0).t > t {
            return None;
        }
        if self.eval(side, x_max).t <= t {
            return Some(x_max);
        }
        Some(brent(|x| self.eval(side, x).t - t, 0.0, x_max))
    }

    /// The parameter ranges of single-cruise profiles that fit in `t` (at most four, no
    /// allocation).
    fn parts(&self, t: f64) -> [Option<(Side, f64, f64)>; 4] {
        let (vs, ve, v_max) = (self.tr.vs, self.tr.ve, self.lim.max_vel);
        let (lo, hi) = (vs.min(ve), vs.max(ve));
        let mut parts = [None; 4];
        if let Some(x) = self.x_limit(Side::Peak, v_max - hi, t) {
            parts[0] = Some((Side::Peak, 0.0, x));
        }
        let span = hi - lo;
        if span > 0.0 {
            // T rises to a maximum between the end speeds; keep the parts where it fits in t.
            let (xm, tm) = golden_max(|x| self.eval(Side::Plateau, x).t, 0.0, span);
            if tm <= t {
                parts[1] = Some((Side::Plateau, 0.0, span));
            } else {
                if self.eval(Side::Plateau, span).t <= t {
                    parts[1] = Some((
                        Side::Plateau,
                        brent(|x| self.eval(Side::Plateau, x).t - t, xm, span),
                        span,
                    ));
                }
                if self.eval(Side::Plateau, 0.0).t <= t {
                    parts[2] = Some((
                        Side::Plateau,
                        0.0,
                        brent(|x| self.eval(Side::Plateau, x).t - t, 0.0, xm),
                    ));
                }
            }
        }
        if let Some(x) = self.x_limit(Side::Valley, self.valley_depth(), t) {
            parts[3] = Some((Side::Valley, 0.0, x));
        }
        parts
    }

    /// f(x) - d: the distance of the profile lasting exactly `t`, minus d.
    fn excess(&self, side: Side, x: f64, t: f64) -> f64 {
        let k = self.eval(side, x);
        k.d + k.c * (t - k.t).max(0.0) - self.tr.d
    }

    /// A profile candidate lasting exactly `t` with distance d, if one is found.
    fn solve(&self, t: f64) -> Option<Candidate> {
        self.parts(t)
            .into_iter()
            .flatten()
            .find_map(|(side, a, b)| self.solve_in(side, t, a, b).map(|x| self.eval(side, x)))
    }

    /// A root of f(x) = d for duration `t` with `x` in `[a, b]` (T <= t throughout).
    fn solve_in(&self, side: Side, t: f64, a: f64, b: f64) -> Option<f64> {
        if b < a {
            return None;
        }
        let f = |x: f64| self.excess(side, x, t);
        let x_at = |i: usize| a + (b - a) * i as f64 / SAMPLES as f64;
        let mut fs = [0.0; SAMPLES + 1];
        for (i, v) in fs.iter_mut().enumerate() {
            *v = f(x_at(i));
        }
        // At the ends of a feasible interval the root sits on a sample (e.g. the valley that
        // lasts t with no cruise): accept it within the rounding of that sample's own terms (a
        // tolerance scaled by the speed limit would accept rest for a move of 1e-10 deg in 60 s).
        let rounding = |x: f64| {
            let k = self.eval(side, x);
            1e-12 * (self.tr.d.abs() + k.d.abs() + k.c.abs() * t)
        };
        if let Some(i) = (0..fs.len()).find(|&i| fs[i].abs() <= rounding(x_at(i))) {
            return Some(x_at(i));
        }
        // Any sign change between neighbouring samples brackets a root.
        (0..SAMPLES)
            .find(|&i| (fs[i] < 0.0) != (fs[i + 1] < 0.0))
            .map(|i| brent(f, x_at(i), x_at(i + 1)))
    }

    /// Cruise times (at v_s, at v_e) around the direct speed change that make it last `t`, when
    /// that split-cruise profile exists: `t_a + t_b = t - T_direct` and
    /// `v_s·t_a + v_e·t_b = d - d0` with both >= 0. It covers what single-cruise profiles cannot
    /// when two separate speed changes would take longer than `t`.
    fn split_cruise(&self, t: f64) -> Option<(f64, f64)> {
        let (vs, ve, d) = (self.tr.vs, self.tr.ve, self.tr.d);
        let k = self.eval(Side::Plateau, 0.0);
        let (t_direct, d_direct) = (k.t, k.d);
        let (lo, hi) = (vs.min(ve), vs.max(ve));
        let rest = d - d_direct;
        let tau = t - t_direct;
        if lo >= 0.0 {
            // Durations from `T_direct + (d - d0)/max(v_s, v_e)` to `T_direct + (d - d0)/min`.
            if rest < 0.0 || hi <= 0.0 {
                return None;
            }
            if tau < rest / hi * (1.0 - 1e-12) || (lo > 0.0 && tau > rest / lo * (1.0 + 1e-12)) {
                return None;
            }
        } else {
            // An end speed against the travel (reversal allowed): the mean cruise speed
            // rest / tau lies between the end speeds.
            let slack = 1e-12 * (hi - lo) * tau.max(0.0);
            if tau < 0.0 || rest > hi * tau + slack || rest < lo * tau - slack {
                return None;
            }
        }
        // t_a + t_b = tau, vs·t_a + ve·t_b = rest.
        let t_a = if vs == ve {
            0.5 * tau
        } else {
            ((rest - ve * tau) / (vs - ve)).clamp(0.0, tau)
        };
        Some((t_a, tau - t_a))
    }

    /// A profile lasting `t` (not yet verified), when one is found.
    fn profile_at(&self, t: f64) -> Option<Profile> {
        let (vs, ve, dir, lim) = (self.tr.vs, self.tr.ve, self.tr.dir, &self.lim);
        if t <= self.t_opt {
            return Some(build_seven_phases(self.opt, dir, lim));
        }
        if let Some((t_a, t_b)) = self.split_cruise(t) {
            let up = ve >= vs;
            let ch =
                SpeedChange::from_delta((ve - vs).abs(), up, lim.max_jerk, lim.accel_bound(vs, ve));
            let segs = [
                Segment {
                    duration: t_a,
                    jerk: 0.0,
                },
                Segment {
                    duration: ch.t1,
                    jerk: dir * ch.jerk,
                },
                Segment {
                    duration: ch.t2,
                    jerk: 0.0,
                },
                Segment {
                    duration: ch.t1,
                    jerk: -dir * ch.jerk,
                },
                Segment {
                    duration: t_b,
                    jerk: 0.0,
                },
            ];
            return Some(Profile::new(0.0, dir * vs, 0.0, &segs));
        }
        let k = self.solve(t).or_else(|| self.interval_end(t))?;
        let shape = Shape {
            vs,
            c: k.c,
            cruise: (t - k.t).max(0.0),
            ve,
            u1: k.u1,
            u2: k.u2,
        };
        Some(build_seven_phases(shape, dir, lim))
    }

    /// Whether every duration from the minimum time on is feasible without looking at the
    /// valleys: one end at (or against) rest, where the valley distance only falls with depth
    /// (dwell there), or the optimum is already a valley past the hump.
    fn every_duration_fits(&self) -> bool {
        self.tr.vs.min(self.tr.ve) <= 0.0 || self.tr.d < self.eval(Side::Valley, 0.0).d
    }

    /// Depth `x_b` of the shallow valley with no cruise and distance exactly d (the first
    /// interval ends at `T(x_b)`), and where the second interval starts (see the module
    /// documentation); `None` when every duration from the minimum time is feasible.
    fn valley_ends(&self) -> Option<(f64, Option<SecondStart>)> {
        let (vs, ve, d) = (self.tr.vs, self.tr.ve, self.tr.d);
        let lo = vs.min(ve);
        if self.every_duration_fits() {
            return None;
        }
        let dist = |x: f64| self.eval(Side::Valley, x).d;
        // The hump only brackets the two roots; they are then solved to machine precision.
        let (x_top, d_top) = golden_max_tol(dist, 0.0, lo, 1e-6);
        if d_top <= d {
            return None;
        }
        let x_b = brent(|x| dist(x) - d, 0.0, x_top);
        let at = |x: f64| SecondStart {
            x,
            t: self.eval(Side::Valley, x).t,
        };
        let second = if dist(lo) <= d {
            Some(at(brent(|x| dist(x) - d, x_top, lo)))
        } else if self.reversal == Reversal::Allow {
            // Below rest D falls with depth down to the valley at -V, then the cruise at -V.
            let deepest = self.valley_depth();
            let k = self.eval(Side::Valley, deepest);
            if k.d <= d {
                Some(at(brent(|x| dist(x) - d, lo, deepest)))
            } else {
                Some(SecondStart {
                    x: deepest,
                    t: k.t + (k.d - d) / self.lim.max_vel,
                })
            }
        } else {
            None
        };
        Some((x_b, second))
    }

    /// The valley at an end of a feasible interval, when `t` is (within 1e-9) there.
    fn interval_end(&self, t: f64) -> Option<Candidate> {
        let (x_b, second) = self.valley_ends()?;
        let close = |t_end: f64| (t_end - t).abs() <= 1e-9 * t;
        let first = self.eval(Side::Valley, x_b);
        if close(first.t) {
            return Some(first);
        }
        second
            .filter(|s| close(s.t))
            .map(|s| self.eval(Side::Valley, s.x))
    }
}
