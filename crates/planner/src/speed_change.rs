//! The basic three-period profile: change speed from v0 to v1 with zero acceleration at both ends
//! in the least time (paper eq. 1–4).

/// Time-optimal speed change: jerk `jerk` for `t1`, zero jerk for `t2`, jerk `-jerk` for `t1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SpeedChange {
    /// Duration of each jerk period (eq. 3).
    pub t1: f64,
    /// Duration of the constant-acceleration period (eq. 3); 0 for a triangular acceleration.
    pub t2: f64,
    /// Signed jerk of the first period: +J when speeding up, -J when slowing down.
    pub jerk: f64,
}

impl SpeedChange {
    /// The speed change of magnitude `u >= 0`, up (`speed_up`) or down, under jerk `max_jerk` and
    /// the acceleration bound `max_acc` of that direction of change.
    pub(crate) fn from_delta(u: f64, speed_up: bool, max_jerk: f64, max_acc: f64) -> Self {
        let (t1, t2) = periods(u, max_jerk, max_acc);
        SpeedChange {
            t1,
            t2,
            jerk: if speed_up { max_jerk } else { -max_jerk },
        }
    }
}

/// (t1, t2) of eq. 3 for a speed change of magnitude `u`.
#[inline]
pub(crate) fn periods(u: f64, j: f64, a: f64) -> (f64, f64) {
    if u * j >= a * a {
        (a / j, u / a - a / j)
    } else {
        ((u / j).sqrt(), 0.0)
    }
}

/// Duration 2·t1 + t2 of a speed change of magnitude `u >= 0` (eq. 3–4).
#[inline]
pub(crate) fn duration(u: f64, j: f64, a: f64) -> f64 {
    if u * j >= a * a {
        u / a + a / j
    } else {
        2.0 * (u / j).sqrt()
    }
}

/// Derivative of [`duration`] with respect to `u` (infinite at u = 0 for the triangle).
#[inline]
pub(crate) fn duration_deriv(u: f64, j: f64, a: f64) -> f64 {
    if u * j >= a * a {
        1.0 / a
    } else if u > 0.0 {
        1.0 / (u * j).sqrt()
    } else {
        f64::INFINITY
    }
}
