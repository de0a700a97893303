//! Step 1: the minimum-time move over a distance (paper section 2.2, eq. 5–8).
//!
//! With zero acceleration at both ends the fastest profile changes speed once towards an extreme
//! speed `c` and once back: `v_s → c` (cruise at `c` only when `c = ±V`) `→ v_e`. In the direction
//! of travel (distance d >= 0) with d0 the distance of the direct change `v_s → v_e` (eq. 6):
//! - d >= d0: a *peak* `c >= max(v_s, v_e)`. Case 1 of the paper: `c = V` with a cruise;
//!   case 2: `c < V` solves eq. 7, `D(c) = d`, which is increasing in `c` on `[max(v_s, v_e, 0), V]`.
//! - d < d0: the gap is too short to reach `v_e` (case 3). With reversal allowed the axis first
//!   moves backwards: a *valley* `c < 0` (the paper's negative v_m rows); with reversal forbidden
//!   there is no profile, and the caller gets the reachable speeds instead (see [`crate::reach`]).
//!
//! `c` is found by a safeguarded Newton iteration started from the closed form that is exact when
//! both speed changes reach the acceleration limit, so it is exact to machine precision.

use crate::profile::{Profile, Segment, TwoStep};
use crate::reach;
use crate::roots::{golden_max, newton_bracketed};
use crate::speed_change::{duration, duration_deriv, SpeedChange};
use crate::{Limits, PlannerError};

/// A single-axis move: signed distance and signed boundary speeds (units, units/s).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Move {
    pub distance: f64,
    pub v_start: f64,
    pub v_end: f64,
}

/// What the planner may do when `v_end` cannot be reached within the distance.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Reversal {
    /// The axis may move against the direction of travel (time-optimal, as Ruckig).
    Allow,
    /// Speed stays along the direction of travel (a gantry inside an arc never turns back).
    Forbid,
}

/// Duration and distance of `v_s → c → v_e` with no cruise, in the direction of travel.
#[inline]
pub(crate) fn two_change(vs: f64, c: f64, ve: f64, lim: &Limits) -> (f64, f64) {
    let a1 = if c >= vs {
        lim.max_accel
    } else {
        lim.max_decel
    };
    let a2 = if ve >= c {
        lim.max_accel
    } else {
        lim.max_decel
    };
    let t1 = duration((c - vs).abs(), lim.max_jerk, a1);
    let t2 = duration((ve - c).abs(), lim.max_jerk, a2);
    (t1 + t2, 0.5 * (vs + c) * t1 + 0.5 * (c + ve) * t2)
}

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

impl Shape {
    /// Total duration, from the speed changes as solved (not re-derived from `c`).
    pub(crate) fn duration(&self, lim: &Limits) -> f64 {
        let a1 = if self.c >= self.vs {
            lim.max_accel
        } else {
            lim.max_decel
        };
        let a2 = if self.ve >= self.c {
            lim.max_accel
        } else {
            lim.max_decel
        };
        duration(self.u1, lim.max_jerk, a1) + self.cruise + duration(self.u2, lim.max_jerk, a2)
    }
}

/// Distance of `v_s → c → v_e` at offset `x` from `base`, its derivative in `x`, and the speed
/// changes. Peak (`sgn = 1`): accelerate under A then brake under D; valley: the reverse.
#[inline]
fn offset_eval(
    vs: f64,
    ve: f64,
    base: f64,
    sgn: f64,
    x: f64,
    lim: &Limits,
) -> (f64, f64, f64, f64) {
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
            return solve_offset(vs, ve, d, lim, -1.0, m, m - c_top, m);
        }
    }
    let (sgn, base) = if peak {
        (1.0, vs.max(ve).max(0.0))
    } else {
        (-1.0, m.min(0.0))
    };
    let x_max = v_max - sgn * base;
    let (d_lim, _, u1, u2) = offset_eval(vs, ve, base, sgn, x_max, lim);
    // Case 1: the limit speed is reached (with the cruise at ±V).
    if (peak && d_lim <= d) || (!peak && d_lim >= d) {
        return Shape {
            vs,
            c: sgn * v_max,
            cruise: sgn * (d - d_lim) / v_max,
            ve,
            u1,
            u2,
        };
    }
    solve_offset(vs, ve, d, lim, sgn, base, 0.0, x_max)
}

/// Case 2 (peak) or 3 (valley): `D(c) = d` for `c = base + sgn·x`, `x in [x_lo, x_hi]`, where
/// `sgn·(D - d)` increases with `x`; exact by safeguarded Newton from the closed-form guess.
#[allow(clippy::too_many_arguments)]
fn solve_offset(
    vs: f64,
    ve: f64,
    d: f64,
    lim: &Limits,
    sgn: f64,
    base: f64,
    x_lo: f64,
    x_hi: f64,
) -> Shape {
    // Already there at the bracket's low end (e.g. d = d0): no extreme beyond it.
    let (d_lo, _, u1, u2) = offset_eval(vs, ve, base, sgn, x_lo, lim);
    if sgn * (d_lo - d) >= 0.0 {
        return Shape {
            vs,
            c: base + sgn * x_lo,
            cruise: 0.0,
            ve,
            u1,
            u2,
        };
    }
    let guess = sgn * (closed_form_guess(vs, ve, d, lim, sgn > 0.0) - base);
    let x = newton_bracketed(
        |x| {
            let (dist, dd, _, _) = offset_eval(vs, ve, base, sgn, x, lim);
            (sgn * (dist - d), sgn * dd)
        },
        x_lo,
        x_hi,
        guess,
    );
    let (_, _, u1, u2) = offset_eval(vs, ve, base, sgn, x, lim);
    Shape {
        vs,
        c: base + sgn * x,
        cruise: 0.0,
        ve,
        u1,
        u2,
    }
}

/// Builds the seven-phase profile of a shape; `dir` = ±1 maps travel frame to coordinates.
pub(crate) fn build_two_step(shape: Shape, dir: f64, lim: &Limits) -> Profile {
    let Shape {
        vs,
        c,
        cruise,
        ve,
        u1,
        u2,
        ..
    } = shape;
    let a1 = if c >= vs {
        lim.max_accel
    } else {
        lim.max_decel
    };
    let a2 = if ve >= c {
        lim.max_accel
    } else {
        lim.max_decel
    };
    let up = SpeedChange::from_delta(u1, c >= vs, lim.max_jerk, a1);
    let down = SpeedChange::from_delta(u2, ve >= c, lim.max_jerk, a2);
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
    Profile::new(0.0, dir * vs, 0.0, &segs).with_two_step(TwoStep {
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

/// A move seen in its direction of travel: `dir` = ±1, distance >= 0, speeds along travel.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Travel {
    pub dir: f64,
    pub d: f64,
    pub vs: f64,
    pub ve: f64,
}

/// Validates a move against the limits and maps it to its direction of travel.
pub(crate) fn travel_frame(mv: &Move, lim: &Limits, forbid: bool) -> Result<Travel, PlannerError> {
    lim.validate()?;
    for (name, value) in [
        ("distance", mv.distance),
        ("v_start", mv.v_start),
        ("v_end", mv.v_end),
    ] {
        if !value.is_finite() {
            return Err(PlannerError::InvalidInput {
                name,
                value,
                expected: "a finite number",
            });
        }
    }
    let slack = lim.max_vel * 1e-12;
    for (name, value) in [("v_start", mv.v_start), ("v_end", mv.v_end)] {
        if value.abs() > lim.max_vel + slack {
            return Err(PlannerError::SpeedAboveLimit {
                name,
                value,
                limit: lim.max_vel,
            });
        }
    }
    let dir = crate::profile::travel_direction(mv.distance, mv.v_start, mv.v_end);
    let clamp = |v: f64| (dir * v).clamp(-lim.max_vel, lim.max_vel);
    let (mut vs, mut ve) = (clamp(mv.v_start), clamp(mv.v_end));
    if forbid {
        for (name, value, v) in [
            ("v_start", mv.v_start, &mut vs),
            ("v_end", mv.v_end, &mut ve),
        ] {
            if *v < -slack {
                return Err(PlannerError::SpeedAgainstTravel { name, value });
            }
            *v = v.max(0.0);
        }
    }
    Ok(Travel {
        dir,
        d: dir * mv.distance,
        vs,
        ve,
    })
}

/// The minimum-time profile for `mv` under `lim`.
///
/// With [`Reversal::Forbid`], a move whose end speed cannot be reached in the distance returns
/// [`PlannerError::Unreachable`] carrying the reachable speeds, never a silently wrong profile.
pub fn min_time(mv: Move, lim: &Limits, reversal: Reversal) -> Result<Profile, PlannerError> {
    let forbid = reversal == Reversal::Forbid;
    let tr = travel_frame(&mv, lim, forbid)?;
    let shape = solve_shape(tr.vs, tr.ve, tr.d, lim);
    if forbid && shape.c < -1e-12 * lim.max_vel {
        return Err(unreachable(&mv, &tr, lim));
    }
    let prof = build_two_step(shape, tr.dir, lim);
    prof.verify(mv.distance, tr.dir * tr.ve, lim, forbid, 1e-9)?;
    Ok(prof)
}

/// Shortest distance a move `v_s → v_e` can cover without reversing: the direct speed change,
/// or stopping and starting again, whichever is shorter.
pub(crate) fn min_forward_distance(vs: f64, ve: f64, lim: &Limits) -> f64 {
    let d0 = two_change(vs, ve, ve, lim).1;
    let d_stop = two_change(vs, 0.0, ve, lim).1;
    d0.min(d_stop)
}

/// The typed "gap too short" result with both reachable-speed bounds.
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

/// The minimum-time seven-phase shape of `mv` without building or verifying a profile: for
/// schedulers that evaluate many candidate moves and verify only the timeline they keep.
pub fn min_time_shape(mv: Move, lim: &Limits, reversal: Reversal) -> Result<TwoStep, PlannerError> {
    let forbid = reversal == Reversal::Forbid;
    let tr = travel_frame(&mv, lim, forbid)?;
    let shape = solve_shape(tr.vs, tr.ve, tr.d, lim);
    if forbid && shape.c < -1e-12 * lim.max_vel {
        return Err(unreachable(&mv, &tr, lim));
    }
    let a1 = if shape.c >= shape.vs {
        lim.max_accel
    } else {
        lim.max_decel
    };
    let a2 = if shape.ve >= shape.c {
        lim.max_accel
    } else {
        lim.max_decel
    };
    let (t1, t2) = crate::speed_change::periods(shape.u1, lim.max_jerk, a1);
    let (t4, t5) = crate::speed_change::periods(shape.u2, lim.max_jerk, a2);
    Ok(TwoStep {
        direction: tr.dir,
        v_start: tr.vs,
        v_peak: shape.c,
        v_end: tr.ve,
        t1,
        t2,
        t3: shape.cruise,
        t4,
        t5,
    })
}

impl TwoStep {
    /// Total duration 2·t1 + t2 + t3 + 2·t4 + t5.
    pub fn duration(&self) -> f64 {
        2.0 * self.t1 + self.t2 + self.t3 + 2.0 * self.t4 + self.t5
    }
}
