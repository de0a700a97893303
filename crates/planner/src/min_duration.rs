//! Step 2: a move that lasts exactly a requested duration, longer than the minimum time.
//!
//! Between two energy layers the gantry must not arrive before the next energy is ready, so a
//! transition lasts at least the energy-layer switching time. The speed stays in [0, V] (no
//! reversal inside an arc).
//!
//! For a duration T, consider the profiles `v_s → c`, cruise at `c`, `c → v_e` (bang-bang speed
//! changes as in step 1) with the cruise filling the time: `t_c = T - T(c) >= 0`. Their distance
//! `f(c) = D(c) + c·(T - T(c))` is continuous in `c` over the connected set `T(c) <= T` — from the
//! deepest valley that still fits in T (with `c = 0` the axis stops and dwells) to the highest
//! peak — so T is feasible iff `min f <= d` there (`max f >= d` holds for every T above the
//! minimum time), and then a root of `f(c) = d` is the profile. Where two separate speed changes
//! would take longer than T, the direct change with cruises at both end speeds fills in.

use crate::min_time::{
    build_two_step, min_forward_distance, solve_shape, travel_frame, unreachable, Move, Shape,
    Travel,
};
use crate::profile::{Profile, Segment};
use crate::roots::brent;
use crate::speed_change::duration;
use crate::{Limits, PlannerError};

/// Feasible durations of a move: a union of closed intervals (s); an upper end may be infinite.
#[derive(Clone, Debug, PartialEq)]
pub struct DurationSet {
    pub intervals: Vec<(f64, f64)>,
}

impl DurationSet {
    /// Shortest feasible duration (the minimum time).
    pub fn min(&self) -> f64 {
        self.intervals.first().map_or(f64::INFINITY, |i| i.0)
    }
    /// Longest feasible duration (infinite when the axis can stop and dwell).
    pub fn max(&self) -> f64 {
        self.intervals.last().map_or(f64::NEG_INFINITY, |i| i.1)
    }
    /// Whether `t` is feasible (with a relative tolerance of 1e-9).
    pub fn contains(&self, t: f64) -> bool {
        self.intervals
            .iter()
            .any(|&(lo, hi)| t >= lo * (1.0 - 1e-9) && t <= hi * (1.0 + 1e-9))
    }
}

/// Samples of `f` used to bracket its minimum and the root (f need not be unimodal).
const SAMPLES: usize = 24;

/// A move in its direction of travel with its minimum time.
struct Stretch {
    tr: Travel,
    lim: Limits,
    opt: Shape,
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

impl Stretch {
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
                let a = if ve >= vs {
                    lim.max_accel
                } else {
                    lim.max_decel
                };
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

    /// The parameter ranges of single-cruise profiles that fit in `t`.
    fn parts(&self, t: f64) -> Vec<(Side, f64, f64)> {
        let (vs, ve, v_max) = (self.tr.vs, self.tr.ve, self.lim.max_vel);
        let (lo, hi) = (vs.min(ve), vs.max(ve));
        let mut parts = Vec::with_capacity(4);
        if let Some(x) = self.x_limit(Side::Peak, v_max - hi, t) {
            parts.push((Side::Peak, 0.0, x));
        }
        let span = hi - lo;
        if span > 0.0 {
            // T rises to a maximum between the end speeds; keep the parts where it fits in t.
            let (xm, tm) = crate::roots::golden_max(|x| self.eval(Side::Plateau, x).t, 0.0, span);
            if tm <= t {
                parts.push((Side::Plateau, 0.0, span));
            } else {
                if self.eval(Side::Plateau, span).t <= t {
                    parts.push((
                        Side::Plateau,
                        brent(|x| self.eval(Side::Plateau, x).t - t, xm, span),
                        span,
                    ));
                }
                if self.eval(Side::Plateau, 0.0).t <= t {
                    parts.push((
                        Side::Plateau,
                        0.0,
                        brent(|x| self.eval(Side::Plateau, x).t - t, 0.0, xm),
                    ));
                }
            }
        }
        if let Some(x) = self.x_limit(Side::Valley, lo, t) {
            parts.push((Side::Valley, 0.0, x));
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
            .find_map(|(side, a, b)| self.solve_in(side, t, a, b).map(|x| self.eval(side, x)))
    }

    /// A root of f(x) = d for duration `t` with `x` in `[a, b]` (T <= t throughout).
    fn solve_in(&self, side: Side, t: f64, a: f64, b: f64) -> Option<f64> {
        if b < a {
            return None;
        }
        let f = |x: f64| self.excess(side, x, t);
        let xs: Vec<f64> = (0..=SAMPLES)
            .map(|i| a + (b - a) * i as f64 / SAMPLES as f64)
            .collect();
        let fs: Vec<f64> = xs.iter().map(|&x| f(x)).collect();
        // At the ends of a feasible interval the root sits on a sample (e.g. the valley that
        // lasts t with no cruise): accept it within rounding.
        let tol = 1e-12 * (self.tr.d + self.lim.max_vel * t);
        if let Some(i) = fs.iter().position(|&v| v.abs() <= tol) {
            return Some(xs[i]);
        }
        // Any sign change between neighbouring samples brackets a root.
        (0..SAMPLES)
            .find(|&i| (fs[i] < 0.0) != (fs[i + 1] < 0.0))
            .map(|i| brent(f, xs[i], xs[i + 1]))
    }

    /// Cruise times (at v_s, at v_e) around the direct speed change that make it last `t`, when
    /// that split-cruise profile exists: durations from `T_direct + (d - d0)/max(v_s, v_e)` to
    /// `T_direct + (d - d0)/min(v_s, v_e)`. It covers what single-cruise profiles cannot when
    /// two separate speed changes would take longer than `t`.
    fn split_cruise(&self, t: f64) -> Option<(f64, f64)> {
        let (vs, ve, d) = (self.tr.vs, self.tr.ve, self.tr.d);
        let k = self.eval(Side::Plateau, 0.0);
        let (t_direct, d_direct) = (k.t, k.d);
        let (lo, hi) = (vs.min(ve), vs.max(ve));
        let rest = d - d_direct;
        if rest < 0.0 || hi <= 0.0 {
            return None;
        }
        let tau = t - t_direct;
        if tau < rest / hi * (1.0 - 1e-12) || (lo > 0.0 && tau > rest / lo * (1.0 + 1e-12)) {
            return None;
        }
        // t_a + t_b = tau, vs·t_a + ve·t_b = rest.
        let t_a = if vs == ve {
            0.5 * tau
        } else {
            ((rest - ve * tau) / (vs - ve)).clamp(0.0, tau)
        };
        Some((t_a, tau - t_a))
    }

    fn profile(&self, t: f64) -> Option<Profile> {
        let (vs, ve, dir, lim) = (self.tr.vs, self.tr.ve, self.tr.dir, &self.lim);
        if t <= self.t_opt {
            return Some(build_two_step(self.opt, dir, lim));
        }
        if let Some((t_a, t_b)) = self.split_cruise(t) {
            let a = if ve >= vs {
                lim.max_accel
            } else {
                lim.max_decel
            };
            let ch = crate::SpeedChange::new(vs, ve, lim.max_jerk, a);
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
        Some(build_two_step(shape, dir, lim))
    }

    fn feasible(&self, t: f64) -> bool {
        self.durations().contains(t)
    }

    /// The feasible durations. The shortest distance any profile can cover in time t is the
    /// hardest slow-down followed by the hardest speed-up: the valley that lasts t with no
    /// cruise, or a stop and dwell once t >= T(0). With `D(x)`, `T(x)` of the valley at depth
    /// `x` below `min(v_s, v_e)`, a duration `T(x)` is feasible iff `D(x) <= d`; `D` rises from `d0`
    /// to a hump and falls to the stop-and-go distance at rest, so the set is one or two intervals.
    fn durations(&self) -> DurationSet {
        let all = DurationSet {
            intervals: vec![(self.t_opt, f64::INFINITY)],
        };
        match self.valley_ends() {
            None => all,
            Some((x_b, x_a)) => {
                let first = (self.t_opt, self.eval(Side::Valley, x_b).t.max(self.t_opt));
                match x_a {
                    Some(x_a) => DurationSet {
                        intervals: vec![first, (self.eval(Side::Valley, x_a).t, f64::INFINITY)],
                    },
                    None => DurationSet {
                        intervals: vec![first],
                    },
                }
            }
        }
    }

    /// Depths of the valleys with no cruise and distance exactly d on both sides of the hump
    /// (shallow `x_b`, and deep `x_a` when stopping fits); `None` when every duration is feasible.
    fn valley_ends(&self) -> Option<(f64, Option<f64>)> {
        let (vs, ve, d) = (self.tr.vs, self.tr.ve, self.tr.d);
        let lo = vs.min(ve);
        if lo == 0.0 || d < self.eval(Side::Valley, 0.0).d {
            // One end at rest (dwell there), or the optimum is already a valley above rest.
            return None;
        }
        let dist = |x: f64| self.eval(Side::Valley, x).d;
        // The hump only brackets the two roots; they are then solved to machine precision.
        let (x_top, d_top) = crate::roots::golden_max_tol(dist, 0.0, lo, 1e-6);
        if d_top <= d {
            return None;
        }
        let x_b = brent(|x| dist(x) - d, 0.0, x_top);
        let x_a = (dist(lo) <= d).then(|| brent(|x| dist(x) - d, x_top, lo));
        Some((x_b, x_a))
    }

    /// The cruise-free valley at an end of a feasible interval, when `t` is (within 1e-9) there.
    fn interval_end(&self, t: f64) -> Option<Candidate> {
        let (x_b, x_a) = self.valley_ends()?;
        [Some(x_b), x_a]
            .into_iter()
            .flatten()
            .map(|x| self.eval(Side::Valley, x))
            .find(|k| (k.t - t).abs() <= 1e-9 * t)
    }
}

fn stretch(mv: &Move, lim: &Limits) -> Result<Stretch, PlannerError> {
    let tr = travel_frame(mv, lim, true)?;
    if tr.d < min_forward_distance(tr.vs, tr.ve, lim) {
        return Err(unreachable(mv, &tr, lim));
    }
    let opt = solve_shape(tr.vs, tr.ve, tr.d, lim);
    let t_opt = opt.duration(lim);
    Ok(Stretch {
        tr,
        lim: *lim,
        opt,
        t_opt,
    })
}

/// All durations a move can last with speed in [0, V] along its direction of travel.
pub fn feasible_durations(mv: Move, lim: &Limits) -> Result<DurationSet, PlannerError> {
    Ok(stretch(&mv, lim)?.durations())
}

/// Longest duration a move can last (infinite when the axis can stop and dwell).
pub fn max_duration(mv: Move, lim: &Limits) -> Result<f64, PlannerError> {
    Ok(stretch(&mv, lim)?.durations().max())
}

/// Whether `mv` can last exactly `t` seconds with speed in [0, V].
pub fn duration_feasible(mv: Move, lim: &Limits, t: f64) -> Result<bool, PlannerError> {
    let s = stretch(&mv, lim)?;
    Ok(s.feasible(t))
}

/// A profile covering `mv` in exactly `max(t_min, minimum time)` with speed in [0, V].
/// Errors with the feasible durations when no such profile exists.
pub fn exact_duration(mv: Move, lim: &Limits, t_min: f64) -> Result<Profile, PlannerError> {
    if !(t_min.is_finite() && t_min >= 0.0) {
        return Err(PlannerError::InvalidInput {
            name: "min_duration",
            value: t_min,
            expected: "a finite number >= 0",
        });
    }
    let s = stretch(&mv, lim)?;
    let target = t_min.max(s.t_opt);
    let Some(prof) = s.profile(target) else {
        return Err(PlannerError::DurationInfeasible {
            requested: target,
            feasible: s.durations().intervals,
        });
    };
    prof.verify(mv.distance, s.tr.dir * s.tr.ve, lim, true, 1e-9)?;
    if (prof.duration() - target).abs() > 1e-9 * target.max(1.0) {
        return Err(PlannerError::Verification(format!(
            "duration {} instead of the requested {target}",
            prof.duration()
        )));
    }
    Ok(prof)
}

impl DurationSet {
    /// The shortest feasible duration >= `t` (e.g. an ELST that falls in a gap of the set).
    pub fn at_least(&self, t: f64) -> Option<f64> {
        self.intervals
            .iter()
            .find(|&&(_, hi)| hi * (1.0 + 1e-9) >= t)
            .map(|&(lo, _)| lo.max(t))
    }
}

/// The shortest duration >= `t_min` that `mv` can last with speed in [0, V] (Ruckig's
/// `minimum_duration` semantics): `t_min` itself when feasible, else the start of the next
/// feasible interval. `None` when every feasible duration is shorter.
pub fn shortest_duration_at_least(
    mv: Move,
    lim: &Limits,
    t_min: f64,
) -> Result<Option<f64>, PlannerError> {
    let s = stretch(&mv, lim)?;
    if t_min <= s.t_opt {
        return Ok(Some(s.t_opt));
    }
    // Stopping fits and t_min is at least the stop-and-go time: a dwell at rest makes it.
    let stop = s.eval(Side::Valley, s.tr.vs.min(s.tr.ve));
    if stop.d <= s.tr.d && t_min >= stop.t {
        return Ok(Some(t_min));
    }
    Ok(s.durations().at_least(t_min))
}

/// Whether `mv` can last `t_min` seconds or longer with speed in [0, V]: whether
/// [`shortest_duration_at_least`] has an answer, decided with one root solve instead of the whole
/// [`DurationSet`] (schedulers ask this many times). The shortest distance coverable in a time t
/// is the cruise-free valley lasting t; it rises with t to a hump and falls to the stop-and-go
/// distance, so a duration >= `t_min` exists iff stopping fits or the valley lasting `t_min`
/// fits. Conservative by 1e-9 in time against [`DurationSet::at_least`].
pub fn can_last_at_least(mv: Move, lim: &Limits, t_min: f64) -> Result<bool, PlannerError> {
    let s = stretch(&mv, lim)?;
    if t_min <= s.t_opt {
        return Ok(true);
    }
    let lo = s.tr.vs.min(s.tr.ve);
    if lo == 0.0 || s.tr.d < s.eval(Side::Valley, 0.0).d {
        // As in `valley_ends`: one end at rest (dwell there), or the optimum is already a valley
        // above rest; every duration is feasible.
        return Ok(true);
    }
    let stop = s.eval(Side::Valley, lo);
    if stop.d <= s.tr.d {
        return Ok(true);
    }
    let t = t_min * (1.0 + 1e-9);
    if t >= stop.t {
        return Ok(false);
    }
    match s.x_limit(Side::Valley, lo, t) {
        // The valley lasting exactly t (T(0) < t < T(lo), T increasing in the depth).
        Some(x) => Ok(s.eval(Side::Valley, x).d <= s.tr.d),
        // Even the shallowest valley lasts longer than t: inside the first interval.
        None => Ok(true),
    }
}

/// A profile lasting [`shortest_duration_at_least`]`(mv, t_min)`: what a transition that must not
/// end before an energy switch is ready does.
pub fn at_least_duration(mv: Move, lim: &Limits, t_min: f64) -> Result<Profile, PlannerError> {
    if !(t_min.is_finite() && t_min >= 0.0) {
        return Err(PlannerError::InvalidInput {
            name: "min_duration",
            value: t_min,
            expected: "a finite number >= 0",
        });
    }
    let s = stretch(&mv, lim)?;
    let target = if t_min <= s.t_opt {
        s.t_opt
    } else {
        let set = s.durations();
        set.at_least(t_min)
            .ok_or(PlannerError::DurationInfeasible {
                requested: t_min,
                feasible: set.intervals,
            })?
    };
    exact_duration(mv, lim, target)
}
