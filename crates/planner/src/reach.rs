//! Exact reachable-speed bounds for look-ahead schedulers (the paper's case 3, eq. 8).
//!
//! Inside an arc the gantry never reverses, and the gap between two layers shrinks with the layer
//! speeds: each layer sweeps `v·t` degrees centred on its angle, so the beam-off gap is
//! `d - (v_s·t_s + v_e·t_e)/2` (eq. 5). The bounds below solve that coupled condition exactly.
//!
//! Note that the set of reachable speeds is not always an interval: with a jerk limit, braking
//! from `v_s` to a *partial* stop can need more distance than braking to rest. The bounds here
//! are the monotone branches a scheduler uses: speeding up (`v_e >= v_s`) for
//! [`LinearGap::max_end_speed`], braking (`v_s >= v_e`) for [`LinearGap::max_start_speed`]. A move
//! fits without reversing iff the gap is at least the shorter of the direct speed change and
//! stopping and starting again ([`LinearGap::fits`]).

use crate::roots::{brent, newton_bracketed};
use crate::speed_change::{duration, duration_deriv};
use crate::travel::{min_forward_distance, travel_frame};
use crate::{Limits, Move, PlannerError};

/// The beam-off gap as a linear function of the boundary speeds (eq. 5):
/// `distance - (v_start·t_start + v_end·t_end) / 2`, and the reachable speeds across it without
/// reversing (eq. 8). Speeds are magnitudes along the direction of travel.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct LinearGap {
    /// Distance between the two layer centres (>= 0).
    pub distance: f64,
    /// Irradiation time of the layer before the gap (s).
    pub t_start: f64,
    /// Irradiation time of the layer after the gap (s).
    pub t_end: f64,
}

impl LinearGap {
    /// A fixed gap that does not depend on the speeds.
    pub fn plain(distance: f64) -> Self {
        LinearGap {
            distance,
            t_start: 0.0,
            t_end: 0.0,
        }
    }

    /// The gap left at boundary speeds `vs`, `ve`.
    pub fn at(&self, vs: f64, ve: f64) -> f64 {
        self.distance - 0.5 * (vs * self.t_start + ve * self.t_end)
    }

    /// Highest end speed `v_e in [v_s, V]` reachable from `v_start` without reversing, when the
    /// speed change must fit in `self.at(v_start, v_e)` (eq. 8, solved exactly). `None` when not
    /// even `v_e = v_start` fits.
    pub fn max_end_speed(&self, v_start: f64, lim: &Limits) -> Result<Option<f64>, PlannerError> {
        lim.validate()?;
        self.validate()?;
        let vs = check_speed("v_start", v_start, lim)?;
        Ok(max_end_speed_travel(vs, self, lim))
    }

    /// Highest start speed `v_s in [v_e, V]` from which `v_end` is reached without reversing
    /// within `self.at(v_s, v_end)` (eq. 8 with time reversed). `None` when not even
    /// `v_s = v_end` fits.
    pub fn max_start_speed(&self, v_end: f64, lim: &Limits) -> Result<Option<f64>, PlannerError> {
        lim.validate()?;
        self.validate()?;
        let ve = check_speed("v_end", v_end, lim)?;
        Ok(max_start_speed_travel(ve, self, lim))
    }

    /// Whether a move from `v_start` to `v_end` fits in the gap without reversing: whether the
    /// gap left at these speeds is at least the shorter of the direct speed change (eq. 6) and
    /// stopping and starting again; equivalent to [`crate::MoveAnalysis::new`] succeeding with
    /// [`crate::Reversal::Forbid`]. Closed form, no root solve. False for invalid input.
    pub fn fits(&self, v_start: f64, v_end: f64, lim: &Limits) -> bool {
        let d = self.at(v_start, v_end);
        if d < 0.0 {
            return false;
        }
        let mv = Move {
            distance: d,
            v_start,
            v_end,
        };
        match travel_frame(&mv, lim, true) {
            Ok(tr) => min_forward_distance(tr.vs, tr.ve, lim) <= tr.d,
            Err(_) => false,
        }
    }

    /// Largest factor `s in [0, 1]` such that the axis can brake from `s·v_start` to rest and
    /// speed up again to `s·v_end` within `self.at(s·v_start, s·v_end)` (eq. 4 for each change),
    /// on the safe side of the root; a dwell at rest then makes the move last as long as wanted.
    /// 1 when stopping already fits at the given speeds.
    pub fn max_stop_scale(
        &self,
        v_start: f64,
        v_end: f64,
        lim: &Limits,
    ) -> Result<f64, PlannerError> {
        lim.validate()?;
        self.validate()?;
        let vs = check_speed("v_start", v_start, lim)?;
        let ve = check_speed("v_end", v_end, lim)?;
        let excess = |s: f64| {
            let (a, b) = (s * vs, s * ve);
            lim.speed_change_distance(a, 0.0) + lim.speed_change_distance(0.0, b) - self.at(a, b)
        };
        if excess(1.0) <= 0.0 {
            return Ok(1.0);
        }
        // excess(0) = -distance <= 0 and excess increases with s: the root is where stopping
        // just fits (nudged to the safe side).
        let s = brent(excess, 0.0, 1.0);
        Ok(if excess(s) <= 0.0 {
            s
        } else {
            (s * (1.0 - 1e-12)).max(0.0)
        })
    }

    fn reversed(&self) -> Self {
        LinearGap {
            distance: self.distance,
            t_start: self.t_end,
            t_end: self.t_start,
        }
    }

    fn validate(&self) -> Result<(), PlannerError> {
        for (name, value) in [
            ("gap distance", self.distance),
            ("t_start", self.t_start),
            ("t_end", self.t_end),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(PlannerError::InvalidInput {
                    name,
                    value,
                    expected: "a finite number >= 0",
                });
            }
        }
        Ok(())
    }
}

fn check_speed(name: &'static str, value: f64, lim: &Limits) -> Result<f64, PlannerError> {
    if !value.is_finite() {
        return Err(PlannerError::InvalidInput {
            name,
            value,
            expected: "a finite number",
        });
    }
    if value < -lim.max_vel * 1e-12 {
        return Err(PlannerError::SpeedAgainstTravel { name, value });
    }
    if value > lim.max_vel * (1.0 + 1e-12) {
        return Err(PlannerError::SpeedAboveLimit {
            name,
            value,
            limit: lim.max_vel,
        });
    }
    Ok(value.clamp(0.0, lim.max_vel))
}

pub(crate) fn max_end_speed_travel(vs: f64, gap: &LinearGap, lim: &Limits) -> Option<f64> {
    // Either branch may reach higher: the direct speed-up, or braking to rest and starting again
    // (shorter when v_s is small against A²/J). Both distances increase with v_e.
    let direct = highest_fit(vs, gap, lim, false);
    // Via rest can only reach higher if its distance at the direct branch's speed still fits.
    if let Some(d) = direct {
        if via_rest_distance(vs, d, lim) > gap.at(vs, d) {
            return direct;
        }
    }
    let via_rest = highest_fit(vs, gap, lim, true);
    match (direct, via_rest) {
        (Some(a), Some(b)) => Some(a.max(b)),
        (a, b) => a.or(b),
    }
}

/// Distance of braking from `vs` to rest and speeding up to `ve` (as [`highest_fit`] counts it).
fn via_rest_distance(vs: f64, ve: f64, lim: &Limits) -> f64 {
    let j = lim.max_jerk;
    0.5 * vs * duration(vs, j, lim.max_decel) + 0.5 * ve * duration(ve, j, lim.max_accel)
}

/// Highest `v_e in [v_s, V]` whose speed-up (directly, or via rest) fits in the gap.
fn highest_fit(vs: f64, gap: &LinearGap, lim: &Limits, via_rest: bool) -> Option<f64> {
    let (j, a) = (lim.max_jerk, lim.max_accel);
    let (from, fixed) = if via_rest {
        (0.0, 0.5 * vs * duration(vs, j, lim.max_decel))
    } else {
        (vs, 0.0)
    };
    // f(ve) = distance(from -> ve) + fixed - gap(vs, ve), increasing on [vs, V].
    let f = |ve: f64| {
        let u = ve - from;
        let t = duration(u, j, a);
        let val = fixed + 0.5 * (from + ve) * t - gap.at(vs, ve);
        let slope = if u > 0.0 {
            0.5 * (from + ve) * duration_deriv(u, j, a)
        } else {
            0.0
        };
        (val, 0.5 * t + 0.5 * gap.t_end + slope)
    };
    if f(vs).0 > 0.0 {
        return None;
    }
    if f(lim.max_vel).0 <= 0.0 {
        return Some(lim.max_vel);
    }
    // Start from the root of the acceleration-limited (trapezoid) form, where the distance is
    // quadratic in v_e: v_e² + v_e·(A²/J + A·t_end) - from² + (A²/J)·from
    // + 2A·(fixed - d) + A·v_s·t_start = 0 (exact when the change reaches A).
    let a2j = a * a / j;
    let b = a2j + a * gap.t_end;
    let c = -from * from + a2j * from + 2.0 * a * (fixed - gap.distance) + a * vs * gap.t_start;
    let disc = b * b - 4.0 * c;
    let guess = if disc >= 0.0 {
        0.5 * (-b + disc.sqrt())
    } else {
        vs
    };
    // The root to machine precision, then nudged down to the feasible side by whole ulps.
    let mut v = newton_bracketed(f, vs, lim.max_vel, guess);
    for _ in 0..64 {
        if f(v).0 <= 0.0 || v <= vs {
            break;
        }
        v = v.next_down();
    }
    // Degenerate roots (e.g. at v_s itself, where f has an infinite slope) fall back to v_s,
    // which is feasible.
    Some(if f(v).0 <= 0.0 { v.max(vs) } else { vs })
}

pub(crate) fn max_start_speed_travel(ve: f64, gap: &LinearGap, lim: &Limits) -> Option<f64> {
    // Braking v_s -> v_e under D is speeding up v_e -> v_s under D with time reversed.
    max_end_speed_travel(ve, &gap.reversed(), &lim.time_reversed())
}
