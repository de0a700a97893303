//! A move seen in its direction of travel, shared by step 1 ([`crate::min_time`]), step 2
//! ([`crate::min_duration`]) and the reachable-speed bounds ([`crate::reach`]).

use crate::{Limits, Move, PlannerError};

/// A move seen in its direction of travel: `dir` = ±1, distance >= 0, speeds along travel.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Travel {
    pub dir: f64,
    pub d: f64,
    pub vs: f64,
    pub ve: f64,
}

/// Validates a move against the limits and maps it to its direction of travel. With `forbid`,
/// a boundary speed against the travel is an error and the speeds are clamped to [0, V].
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
    let dir = mv.direction();
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

/// Duration and distance of `v_s → c → v_e` with no cruise, in the direction of travel (eq. 4
/// for each speed change).
#[inline]
pub fn two_change(vs: f64, c: f64, ve: f64, lim: &Limits) -> (f64, f64) {
    let t1 = lim.speed_change_duration(vs, c);
    let t2 = lim.speed_change_duration(c, ve);
    (t1 + t2, 0.5 * (vs + c) * t1 + 0.5 * (c + ve) * t2)
}

/// Shortest distance a move `v_s → v_e` can cover without reversing: the direct speed change,
/// or stopping and starting again, whichever is shorter.
pub(crate) fn min_forward_distance(vs: f64, ve: f64, lim: &Limits) -> f64 {
    let d0 = two_change(vs, ve, ve, lim).1;
    let d_stop = two_change(vs, 0.0, ve, lim).1;
    d0.min(d_stop)
}
