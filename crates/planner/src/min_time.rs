//! Step 1: the minimum-time move over a distance (paper section 2.2, eq. 5–8).
//!
//! With zero acceleration at both ends the fastest profile changes speed once towards an extreme
//! speed `c` and once back: `v_s → c` (cruise at `c` only when `c = ±V`) `→ v_e`. In the direction
//! of travel (distance d >= 0) with d0 the distance of the direct change `v_s → v_e` (eq. 6):
//! - d >= d0: a *peak* `c >= max(v_s, v_e)`. Case 1 of the paper: `c = V` with a cruise;
//!   case 2: `c < V` solves eq. 7, `D(c) = d`, which is increasing in `c` on `[max(v_s, v_e, 0), V]`.
//! - d < d0: the gap is too short to reach `v_e` (case 3). With reversal allowed the axis first
//!   moves backwards: a *valley* `c < 0` (the paper's negative v_m rows); with reversal forbidden
//!   there is no profile, and the caller gets the reachable speeds instead (see
//!   [`crate::LinearGap`]).
//!
//! `c` is found by a safeguarded Newton iteration started from the closed form that is exact when
//! both speed changes reach the acceleration limit, so it is exact to machine precision.

use crate::profile::{Profile, Segment, SevenPhases};
use crate::reach;
use crate::roots::{golden_max, newton_bracketed};
use crate::speed_change::{duration, duration_deriv, SpeedChange};
use crate::travel::{two_change, Travel};
use crate::{Limits, Move, PlannerError};

/// The solved shape in the direction of travel: extreme speed `c = base + sgn·x` (a peak above
/// `base` for `sgn = 1`, a valley below it for `sgn = -1`) and the cruise time at it. The speed
/// changes `u1 = |c - v_s|`, `u2 = |c - v_e|` are kept as computed from the offset `x`, so a
/// peak a few ulps above `v_s` keeps its full relative precision.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Shape {
    pub vs: f64,
    pub c: f64,
    pub cruise: f64,
    pub ve: f64,
    pub u1: f64,
    pub u2: f64,
}

/// The peaks (`sgn = 1`) or valleys (`sgn = -1`) of a move `v_s → c → v_e`, with the extreme
/// speed `c = base + sgn·x` at an offset `x >= 0` from `base`.
#[derive(Clone, Copy, Debug)]
struct Extremes {
    vs: f64,
    ve: f64,
    base: f64,
    sgn: f64,
}

impl Extremes {
    /// Distance of `v_s → c → v_e` at offset `x` (eq. 4 for each change, eq. 7 summed), its
    /// derivative in `x`, and the speed changes. Peak: accelerate under A then brake under D;
    /// valley: the reverse.
    #[inline]
    fn eval(&self, x: f64, lim: &Limits) -> (f64, f64, f64, f64) {
        let Extremes { vs, ve, base, sgn } = *self;
        let j = lim.max_jerk;
        let (a1, a2) = if sgn > 0.0 {
            (lim.max_accel, lim.max_decel)
        } else {
            (lim.max_decel, lim.max_accel)
        };
        let c = base + sgn * x;
        let u1 = sgn * (base - vs) + x;
        let u2 = sgn * (base - ve) + x;
        let (t1, t2) = (duration(u1, j, a1), duration(u2, j, a2));
        let dist = 0.5 * (vs + c) * t1 + 0.5 * (c + ve) * t2;
        let mut dd = 0.5 * sgn * (t1 + t2);
        if u1 > 0.0 {
            dd += 0.5 * (vs + c) * duration_deriv(u1, j, a1);
        }
        if u2 > 0.0 {
            dd += 0.5 * (c + ve) * duration_deriv(u2, j, a2);
        }
        (dist, dd, u1, u2)
    }

    /// The shape at offset `x` with the given cruise.
    fn shape(&self, x: f64, cruise: f64, lim: &Limits) -> Shape {
        let (_, _, u1, u2) = self.eval(x, lim);
        Shape {
            vs: self.vs,
            c: self.base + self.sgn * x,
            cruise,
            ve: self.ve,
            u1,
            u2,
        }
    }
}

/// Closed-form extreme speed when both speed changes saturate the acceleration (quadratic in c).
fn closed_form_guess(vs: f64, ve: f64, d: f64, lim: &Limits, peak: bool) -> f64 {
    let (a, dm, j) = (lim.max_accel, lim.max_decel, lim.max_jerk);
    if peak {
        // (c²-vs²)/2A + (vs+c)A/2J + (c²-ve²)/2D + (c+ve)D/2J = d
        let qa = 0.5 / a + 0.5 / dm;
        let qb = (a + dm) / (2.0 * j);
        let qc = -vs * vs / (2.0 * a) + vs * a / (2.0 * j) - ve * ve / (2.0 * dm)
            + ve * dm / (2.0 * j)
            - d;
        (-qb + (qb * qb - 4.0 * qa * qc).max(0.0).sqrt()) / (2.0 * qa)
    } else {
        // (vs²-c²)/2D + (vs+c)D/2J + (ve²-c²)/2A + (c+ve)A/2J = d
        let qa = -(0.5 / a + 0.5 / dm);
        let qb = (a + dm) / (2.0 * j);
        let qc =
            vs * vs / (2.0 * dm) + vs * dm / (2.0 * j) + ve * ve / (2.0 * a) + ve * a / (2.0 * j)
                - d;
        (-qb + (qb * qb - 4.0 * qa * qc).max(0.0).sqrt()) / (2.0 * qa)
    }
}

/// Solves the minimum-time shape for `d >= 0` in the direction of travel, reversal allowed.
///
/// For `d < d0` the valley is not always a reversal: when the speeds are small against A²/J,
/// dipping towards rest *shortens* the distance of the following speed-up, so any
/// `d >= D(0)` (stop-and-go distance) is covered by a valley `c in [0, min(v_s, v_e)]`.
pub(crate) fn solve_shape(vs: f64, ve: f64, d: f64, lim: &Limits) -> Shape {
    let v_max = lim.max_vel;
    let (_, d0) = two_change(vs, ve, ve, lim);
    let peak = d >= d0;
    let m = vs.min(ve);
    if !peak && m > 0.0 {
        let (_, d_stop) = two_change(vs, 0.0, ve, lim);
        if d_stop <= d {
            // D(c) on [0, m] rises from D(0) to a hump and falls back to d0: the shallowest valley
            // with D(c) = d lies below the hump, where D increases with c.
            let (c_top, _) = golden_max(|c| two_change(vs, c, ve, lim).1, 0.0, m);
            let valleys = Extremes {
                vs,
                ve,
                base: m,
                sgn: -1.0,
            };
            return solve_offset(&valleys, d, lim, m - c_top, m);
        }
    }
    let (sgn, base) = if peak {
        (1.0, vs.max(ve).max(0.0))
    } else {
        (-1.0, m.min(0.0))
    };
    let family = Extremes { vs, ve, base, sgn };
    let x_max = v_max - sgn * base;
    let (d_lim, _, _, _) = family.eval(x_max, lim);
    // Case 1: the limit speed is reached (with the cruise at ±V).
    if (peak && d_lim <= d) || (!peak && d_lim >= d) {
        return family.shape(x_max, sgn * (d - d_lim) / v_max, lim);
    }
    solve_offset(&family, d, lim, 0.0, x_max)
}

/// Case 2 (peak, eq. 7) or 3 (valley): `D(c) = d` for `c = base + sgn·x`, `x in [x_lo, x_hi]`,
/// where `sgn·(D - d)` increases with `x`; exact by safeguarded Newton from the closed-form guess.
fn solve_offset(family: &Extremes, d: f64, lim: &Limits, x_lo: f64, x_hi: f64) -> Shape {
    let sgn = family.sgn;
    // Already there at the bracket's low end (e.g. d = d0): no extreme beyond it.
    let (d_lo, _, _, _) = family.eval(x_lo, lim);
    if sgn * (d_lo - d) >= 0.0 {
        return family.shape(x_lo, 0.0, lim);
    }
    let guess = sgn * (closed_form_guess(family.vs, family.ve, d, lim, sgn > 0.0) - family.base);
    let x = newton_bracketed(
        |x| {
            let (dist, dd, _, _) = family.eval(x, lim);
            (sgn * (dist - d), sgn * dd)
        },
        x_lo,
        x_hi,
        guess,
    );
    family.shape(x, 0.0, lim)
}

/// Builds the seven-phase profile of a shape; `dir` = ±1 maps travel frame to coordinates.
pub(crate) fn build_seven_phases(shape: Shape, dir: f64, lim: &Limits) -> Profile {
    let Shape {
        vs,
        c,
        cruise,
        ve,
        u1,
        u2,
    } = shape;
    let up = SpeedChange::from_delta(u1, c >= vs, lim.max_jerk, lim.accel_bound(vs, c));
    let down = SpeedChange::from_delta(u2, ve >= c, lim.max_jerk, lim.accel_bound(c, ve));
    let segs = [
        Segment {
            duration: up.t1,
            jerk: dir * up.jerk,
        },
        Segment {
            duration: up.t2,
            jerk: 0.0,
        },
        Segment {
            duration: up.t1,
            jerk: -dir * up.jerk,
        },
        Segment {
            duration: cruise,
            jerk: 0.0,
        },
        Segment {
            duration: down.t1,
            jerk: dir * down.jerk,
        },
        Segment {
            duration: down.t2,
            jerk: 0.0,
        },
        Segment {
            duration: down.t1,
            jerk: -dir * down.jerk,
        },
    ];
    Profile::new(0.0, dir * vs, 0.0, &segs).with_seven_phases(SevenPhases {
        direction: dir,
        v_start: vs,
        v_peak: c,
        v_end: ve,
        t1: up.t1,
        t2: up.t2,
        t3: cruise,
        t4: down.t1,
        t5: down.t2,
    })
}

/// The typed "gap too short" result with both reachable-speed bounds (eq. 8).
pub(crate) fn unreachable(mv: &Move, tr: &Travel, lim: &Limits) -> PlannerError {
    let gap = reach::LinearGap::plain(tr.d);
    PlannerError::Unreachable {
        v_start: mv.v_start,
        v_end: mv.v_end,
        distance: mv.distance,
        max_end_speed: reach::max_end_speed_travel(tr.vs, &gap, lim).unwrap_or(tr.vs),
        max_start_speed: reach::max_start_speed_travel(tr.ve, &gap, lim).unwrap_or(tr.ve),
    }
}
