//! Step 2: a move that lasts exactly a requested duration, longer than the minimum time.
//!
//! Between two energy layers the gantry must not arrive before the next energy is ready, so a
//! transition lasts at least the energy-layer switching time. The speed stays in [0, V] (no
//! reversal inside an arc). Durations are covered by continuous families of profiles, each
//! monotone in its parameter, so an exact duration is one safeguarded root solve:
//! - *peak* `v_s → c → v_e` with a cruise at `c` from the optimum down to `c = max(v_s, v_e)`;
//! - *split cruise*: the direct speed change with cruises at `v_s` and at `v_e`;
//! - *valley* `v_s → c → v_e` with a cruise at `c <= min(v_s, v_e)`, down to where the
//!   slow-down no longer fits in the gap (its duration grows as the valley deepens);
//! - *stop*: cruise at the faster end speed, brake to rest, dwell, start again (when stopping fits).
//!
//! The union of these families is reported as the feasible durations; a request outside it is a
//! typed error that lists them.

use crate::min_time::{
    build_two_step, min_forward_distance, solve_shape, travel_frame, two_change, unreachable, Move, Shape,
    Travel,
};
use crate::profile::{Profile, Segment};
use crate::roots::{brent, golden_max};
use crate::speed_change::SpeedChange;
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
    /// Longest feasible duration (may be infinite when the axis can stop and dwell).
    pub fn max(&self) -> f64 {
        self.intervals.last().map_or(f64::NEG_INFINITY, |i| i.1)
    }
    /// Whether `t` is feasible (with a relative tolerance of 1e-12).
    pub fn contains(&self, t: f64) -> bool {
        self.intervals.iter().any(|&(lo, hi)| t >= lo * (1.0 - 1e-12) && t <= hi * (1.0 + 1e-12))
    }
}

/// The families' parameters for one move in its direction of travel.
struct Families {
    tr: Travel,
    lim: Limits,
    opt: Shape,
    t_opt: f64,
    hi: f64,
    t_direct: f64,
    d_direct: f64,
    /// Durations at the ends of the peak / split-cruise / valley families.
    h_hi: f64,
    h_lo: f64,
    /// Shallowest and deepest valley speeds of the valley family, and the duration at the deepest.
    valley_top: f64,
    c_deep: f64,
    h_deep: f64,
    /// Shortest stop-and-dwell duration, if stopping fits in the gap.
    w_min: Option<f64>,
}

impl Families {
    fn new(tr: Travel, lim: Limits) -> Self {
        let (vs, ve, d) = (tr.vs, tr.ve, tr.d);
        let opt = solve_shape(vs, ve, d, &lim);
        let t_opt = opt.duration(&lim);
        let (lo, hi) = (vs.min(ve), vs.max(ve));
        let (t_direct, d_direct) = two_change(vs, ve, ve, &lim);
        let h_at = |c: f64| if c > 0.0 { t_direct + (d - d_direct) / c } else { f64::INFINITY };
        let (h_hi, h_lo) = (h_at(hi), h_at(lo));
        let mut fam = Families {
            tr,
            lim,
            opt,
            t_opt,
            hi,
            t_direct,
            d_direct,
            h_hi,
            h_lo,
            valley_top: lo,
            c_deep: lo,
            h_deep: h_lo,
            w_min: None,
        };
        if d < d_direct {
            // The optimum is already a valley c_opt in [0, lo] (see `solve_shape`): only deeper
            // valleys remain, and D(c) <= d all the way down to rest.
            let (t0, d0) = two_change(vs, 0.0, ve, &lim);
            fam.h_hi = t_opt;
            fam.h_lo = t_opt;
            fam.valley_top = opt.c;
            fam.c_deep = 0.0;
            fam.h_deep = if d0 < d { f64::INFINITY } else { t0 };
            fam.w_min = Some(t0 + (d - d0) / hi);
        } else if lo > 0.0 {
            let dist = |c: f64| two_change(vs, c, ve, &lim).1;
            let (c_top, d_top) = golden_max(dist, 0.0, lo);
            if d_top <= d {
                fam.c_deep = 0.0;
                let (t0, d0) = two_change(vs, 0.0, ve, &lim);
                fam.h_deep = if d0 < d { f64::INFINITY } else { t0 };
            } else {
                fam.c_deep = brent(|c| dist(c) - d, c_top, lo);
                fam.h_deep = fam.h(fam.c_deep);
            }
            let (t_stop, d_stop) = two_change(vs, 0.0, ve, &lim);
            if d_stop <= d {
                fam.w_min = Some(t_stop + (d - d_stop) / hi);
            }
        }
        fam
    }

    /// Duration of `v_s → c`, cruise at `c` for the rest of the distance, `c → v_e`.
    fn h(&self, c: f64) -> f64 {
        let (t, dist) = two_change(self.tr.vs, c, self.tr.ve, &self.lim);
        t + (self.tr.d - dist) / c
    }

    fn durations(&self) -> DurationSet {
        let first = (self.t_opt, self.h_deep.max(self.t_opt));
        let intervals = match self.w_min {
            Some(w) if w > first.1 => vec![first, (w, f64::INFINITY)],
            Some(_) => vec![(self.t_opt, f64::INFINITY)],
            None => vec![first],
        };
        DurationSet { intervals }
    }

    /// Cruise speed `c` in `[a, b]` whose profile lasts `t` (H is decreasing in `c`).
    fn solve_c(&self, t: f64, a: f64, b: f64) -> f64 {
        let mut a = a;
        if a <= 0.0 {
            // H grows without bound as c -> 0: find a positive lower end that brackets t.
            a = b;
            while self.h(a) < t && a > f64::MIN_POSITIVE {
                a *= 0.5;
            }
        }
        brent(|c| self.h(c) - t, a, b)
    }

    fn cruise_profile(&self, c: f64) -> Profile {
        let (_, dist) = two_change(self.tr.vs, c, self.tr.ve, &self.lim);
        let cruise = ((self.tr.d - dist) / c).max(0.0);
        build_two_step(Shape::from_peak(self.tr.vs, c, cruise, self.tr.ve), self.tr.dir, &self.lim)
    }

    fn profile_for(&self, t: f64) -> Result<Profile, PlannerError> {
        let (vs, ve, d, dir) = (self.tr.vs, self.tr.ve, self.tr.d, self.tr.dir);
        let lim = &self.lim;
        if t <= self.t_opt {
            return Ok(build_two_step(self.opt, dir, lim));
        }
        if self.hi == 0.0 && d == 0.0 {
            // At rest and going nowhere: dwell.
            return Ok(Profile::new(0.0, 0.0, 0.0, &[Segment { duration: t, jerk: 0.0 }]));
        }
        if t <= self.h_hi {
            let c = self.solve_c(t, self.hi, self.opt.c);
            return Ok(self.cruise_profile(c));
        }
        if t <= self.h_lo {
            // Direct change with cruises at both end speeds: t_a + t_b = tau, vs t_a + ve t_b = rest.
            let tau = t - self.t_direct;
            let rest = d - self.d_direct;
            let (t_a, t_b) = if vs == ve {
                (0.5 * tau, 0.5 * tau)
            } else {
                let t_a = ((rest - ve * tau) / (vs - ve)).clamp(0.0, tau);
                (t_a, tau - t_a)
            };
            let ch = SpeedChange::new(vs, ve, lim.max_jerk, if ve >= vs { lim.max_accel } else { lim.max_decel });
            let segs = [
                Segment { duration: t_a, jerk: 0.0 },
                Segment { duration: ch.t1, jerk: dir * ch.jerk },
                Segment { duration: ch.t2, jerk: 0.0 },
                Segment { duration: ch.t1, jerk: -dir * ch.jerk },
                Segment { duration: t_b, jerk: 0.0 },
            ];
            return Ok(Profile::new(0.0, dir * vs, 0.0, &segs));
        }
        if t <= self.h_deep {
            let c = self.solve_c(t, self.c_deep, self.valley_top);
            return Ok(self.cruise_profile(c));
        }
        if let Some(w) = self.w_min {
            if t >= w * (1.0 - 1e-12) {
                let (_, d_stop) = two_change(vs, 0.0, ve, lim);
                let cruise = (d - d_stop) / self.hi;
                let dwell = (t - w).max(0.0);
                let brake = SpeedChange::new(vs, 0.0, lim.max_jerk, lim.max_decel);
                let go = SpeedChange::new(0.0, ve, lim.max_jerk, lim.max_accel);
                let (c_a, c_b) = if vs >= ve { (cruise, 0.0) } else { (0.0, cruise) };
                let segs = [
                    Segment { duration: c_a, jerk: 0.0 },
                    Segment { duration: brake.t1, jerk: dir * brake.jerk },
                    Segment { duration: brake.t2, jerk: 0.0 },
                    Segment { duration: brake.t1, jerk: -dir * brake.jerk },
                    Segment { duration: dwell, jerk: 0.0 },
                    Segment { duration: go.t1, jerk: dir * go.jerk },
                    Segment { duration: go.t2, jerk: 0.0 },
                    Segment { duration: go.t1, jerk: -dir * go.jerk },
                    Segment { duration: c_b, jerk: 0.0 },
                ];
                return Ok(Profile::new(0.0, dir * vs, 0.0, &segs));
            }
        }
        Err(PlannerError::DurationInfeasible { requested: t, feasible: self.durations().intervals })
    }
}

fn families(mv: &Move, lim: &Limits) -> Result<Families, PlannerError> {
    let tr = travel_frame(mv, lim, true)?;
    if tr.d < min_forward_distance(tr.vs, tr.ve, lim) {
        return Err(unreachable(mv, &tr, lim));
    }
    Ok(Families::new(tr, *lim))
}

/// All durations a move can last with speed in [0, V] along its direction of travel.
pub fn feasible_durations(mv: Move, lim: &Limits) -> Result<DurationSet, PlannerError> {
    Ok(families(&mv, lim)?.durations())
}

/// Longest duration a move can last (infinite when the axis can stop and dwell, or creep).
pub fn max_duration(mv: Move, lim: &Limits) -> Result<f64, PlannerError> {
    Ok(families(&mv, lim)?.durations().max())
}

/// A profile covering `mv` in exactly `max(t_min, minimum time)` with speed in [0, V].
/// Errors with the feasible durations when no such profile exists.
pub fn exact_duration(mv: Move, lim: &Limits, t_min: f64) -> Result<Profile, PlannerError> {
    if !(t_min.is_finite() && t_min >= 0.0) {
        return Err(PlannerError::InvalidInput { name: "min_duration", value: t_min, expected: "a finite number >= 0" });
    }
    let fam = families(&mv, lim)?;
    let target = t_min.max(fam.t_opt);
    let prof = fam.profile_for(target)?;
    prof.verify(mv.distance, fam.tr.dir * fam.tr.ve, lim, true, 1e-9)?;
    if (prof.duration() - target).abs() > 1e-9 * target.max(1.0) {
        return Err(PlannerError::Verification(format!(
            "duration {} instead of the requested {target}",
            prof.duration()
        )));
    }
    Ok(prof)
}
