//! Axis limits: jerk J, acceleration A, deceleration D and speed V.

use crate::speed_change::duration;
use crate::PlannerError;

/// Kinematic limits of one axis, all finite and > 0.
///
/// `max_accel` bounds the acceleration *along* the direction of travel (speeding up when moving
/// forward) and `max_decel` the acceleration against it (braking), so a move and its mirror image
/// behave alike. In Ruckig terms, for a move with d >= 0: a_max = A, a_min = -D.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Limits {
    /// Maximum |jerk| (units/s³).
    pub max_jerk: f64,
    /// Maximum acceleration along the direction of travel (units/s²).
    pub max_accel: f64,
    /// Maximum deceleration, i.e. acceleration against the direction of travel (units/s²).
    pub max_decel: f64,
    /// Maximum |speed| (units/s).
    pub max_vel: f64,
}

impl Limits {
    /// Limits with equal acceleration and deceleration.
    pub fn new(max_jerk: f64, max_accel: f64, max_vel: f64) -> Result<Self, PlannerError> {
        Self::with_decel(max_jerk, max_accel, max_accel, max_vel)
    }

    /// Limits with a separate deceleration bound.
    pub fn with_decel(
        max_jerk: f64,
        max_accel: f64,
        max_decel: f64,
        max_vel: f64,
    ) -> Result<Self, PlannerError> {
        let lim = Limits {
            max_jerk,
            max_accel,
            max_decel,
            max_vel,
        };
        lim.validate()?;
        Ok(lim)
    }

    /// Checks every limit is finite and > 0 (for limits built as a struct literal).
    pub fn validate(&self) -> Result<(), PlannerError> {
        for (name, value) in [
            ("max_jerk", self.max_jerk),
            ("max_accel", self.max_accel),
            ("max_decel", self.max_decel),
            ("max_vel", self.max_vel),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(PlannerError::InvalidLimit { name, value });
            }
        }
        Ok(())
    }

    /// The acceleration bound of a speed change from `v0` to `v1` along the direction of travel:
    /// `max_accel` when the speed rises (`v1 >= v0`), `max_decel` when it falls.
    #[inline]
    pub fn accel_bound(&self, v0: f64, v1: f64) -> f64 {
        if v1 >= v0 {
            self.max_accel
        } else {
            self.max_decel
        }
    }

    /// Duration of the time-optimal speed change from `v0` to `v1` with zero acceleration at both
    /// ends (paper eq. 3–4): `|Δv|/a + a/J` when the acceleration limit `a` (see
    /// [`Limits::accel_bound`]) is reached (`|Δv| >= a²/J`), else `2·sqrt(|Δv|/J)`.
    #[inline]
    pub fn speed_change_duration(&self, v0: f64, v1: f64) -> f64 {
        duration((v1 - v0).abs(), self.max_jerk, self.accel_bound(v0, v1))
    }

    /// Distance covered by the time-optimal speed change from `v0` to `v1` (paper eq. 4):
    /// `(v0 + v1)/2 ·` [`Limits::speed_change_duration`].
    #[inline]
    pub fn speed_change_distance(&self, v0: f64, v1: f64) -> f64 {
        0.5 * (v0 + v1) * self.speed_change_duration(v0, v1)
    }

    /// The same limits seen from a move in the opposite direction (A and D swap roles).
    pub(crate) fn time_reversed(&self) -> Limits {
        Limits {
            max_accel: self.max_decel,
            max_decel: self.max_accel,
            ..*self
        }
    }
}
