//! Phase durations on a servo period.
//!
//! A servo runs at a fixed period Ts, so each phase must last a whole number of periods. With
//! the durations fixed, the distance is linear in the extreme speed `c` (eq. 4 summed over the
//! phases), so `c` and then each jerk are re-solved exactly. Phases are rounded up, which needs
//! less jerk and acceleration; where that alone cannot keep a limit (a move on a reachability
//! bound, a phase of zero length that the new `c` needs), neighbouring whole counts are searched
//! and the shortest that keeps every limit wins. Rounding every phase down regardless of the
//! limits would exceed them, so a phase never loses a period unless the limits still hold.

use crate::profile::{Profile, Segment, SevenPhases};
use crate::{Limits, PlannerError};

/// Rounds up to a whole number of periods (an exact multiple stays as it is).
fn round_up(t: f64, period: f64) -> f64 {
    if t <= 0.0 {
        return 0.0;
    }
    (t / period - 1e-9).ceil().max(1.0) * period
}

/// Re-times `profile` so every phase is a whole multiple of `period`, keeping its start and end
/// state and every limit in `lim`, and lasting at least as long; the result carries the time
/// added ([`Profile::servo_added_time`]). Works on seven-phase (peak/valley, cruise) profiles.
pub(crate) fn discretize(
    profile: &Profile,
    period: f64,
    lim: &Limits,
) -> Result<Profile, PlannerError> {
    if !(period.is_finite() && period > 0.0) {
        return Err(PlannerError::InvalidInput {
            name: "period",
            value: period,
            expected: "a finite number > 0",
        });
    }
    lim.validate()?;
    let Some(shape) = profile.seven_phases().copied() else {
        return Err(PlannerError::PeriodTooCoarse {
            period,
            detail:
                "only single peak/valley profiles can be re-timed; this one has several cruises"
                    .into(),
        });
    };
    let SevenPhases {
        direction: dir,
        v_start: vs,
        v_end: ve,
        ..
    } = shape;
    let start = profile.start_state();
    if profile.duration() <= 0.0 {
        return Ok(profile.clone().with_servo_added_time(0.0));
    }
    let distance = dir * (profile.end_state().position - start.position);
    let scale = lim.max_vel.max(vs.abs()).max(ve.abs());
    let forbid_reversal = shape.v_peak >= 0.0 && vs >= 0.0 && ve >= 0.0;
    // Never shorter than the profile given: it may have been stretched on purpose (an ELST).
    let min_total = profile.duration() * (1.0 - 1e-12);
    let Some(best) = search_grid(
        &shape,
        distance,
        period,
        lim,
        scale,
        forbid_reversal,
        min_total,
    ) else {
        return Err(PlannerError::PeriodTooCoarse {
            period,
            detail: format!(
                "no phase durations within {SEARCH_BELOW} period below to {SEARCH_ABOVE} above the \
                 continuous ones reach the end state within the limits"
            ),
        });
    };
    let new = grid_profile(start.position, start.velocity, dir, vs, ve, best);
    new.verify(
        profile.end_state().position,
        profile.end_state().velocity,
        lim,
        forbid_reversal,
        1e-9,
    )?;
    let added_time = new.duration() - profile.duration();
    Ok(new.with_servo_added_time(added_time))
}

/// The seven-phase profile of the phases `best` from `position` and `velocity`, in direction
/// `dir`, from `vs` to `ve`.
fn grid_profile(
    position: f64,
    velocity: f64,
    dir: f64,
    vs: f64,
    ve: f64,
    best: GridPhases,
) -> Profile {
    let GridPhases {
        t1,
        t2,
        t3,
        t4,
        t5,
        c,
        j1,
        j2,
    } = best;
    let segs = [
        Segment {
            duration: t1,
            jerk: dir * j1,
        },
        Segment {
            duration: t2,
            jerk: 0.0,
        },
        Segment {
            duration: t1,
            jerk: -dir * j1,
        },
        Segment {
            duration: t3,
            jerk: 0.0,
        },
        Segment {
            duration: t4,
            jerk: dir * j2,
        },
        Segment {
            duration: t5,
            jerk: 0.0,
        },
        Segment {
            duration: t4,
            jerk: -dir * j2,
        },
    ];
    Profile::new(position, velocity, 0.0, &segs).with_seven_phases(SevenPhases {
        direction: dir,
        v_start: vs,
        v_peak: c,
        v_end: ve,
        t1,
        t2,
        t3,
        t4,
        t5,
    })
}

/// Periods a phase may lose (rounding down is fine while the limits hold) or gain in the search.
const SEARCH_BELOW: usize = 1;
const SEARCH_ABOVE: usize = 2;

/// Phase durations on the grid, the extreme speed they imply and the jerks of the two changes.
#[derive(Clone, Copy, Debug)]
struct GridPhases {
    t1: f64,
    t2: f64,
    t3: f64,
    t4: f64,
    t5: f64,
    c: f64,
    j1: f64,
    j2: f64,
}

/// The shortest whole-period phase durations near the continuous ones, lasting at least
/// `min_total`, that keep every limit.
///
/// With the durations fixed, the distance is linear in the extreme speed `c` (eq. 4 summed over
/// the phases), so `c` and then the jerks `Δv / (t_a (t_a + t_b))` follow exactly. Rounding every
/// phase up alone is not enough: a move on a reachability bound (its only duration) or a zero
/// phase that the new `c` needs cannot be kept that way, so neighbouring counts are searched too.
fn search_grid(
    shape: &SevenPhases,
    distance: f64,
    period: f64,
    lim: &Limits,
    scale: f64,
    forbid_reversal: bool,
    min_total: f64,
) -> Option<GridPhases> {
    let (vs, ve) = (shape.v_start, shape.v_end);
    let tol = 1e-12;
    let counts = |t: f64| {
        let up = round_up(t, period) / period;
        let up = up.round() as usize;
        let lo = if t <= 0.0 {
            0
        } else {
            up.saturating_sub(SEARCH_BELOW)
        };
        (lo..=up + SEARCH_ABOVE)
            .map(|n| n as f64 * period)
            .collect::<Vec<f64>>()
    };
    // A positive jerk along travel starts a rising speed.
    let acc_bound = |j: f64| lim.accel_bound(0.0, j);
    // The jerk of a speed change by `dv` over (t_a, t_b, t_a), if it keeps J and the acceleration.
    // Without a change phase only a rounding's difference of the speeds involved is let pass:
    // against V instead, a move of micro-degrees over hours (extreme speed 1e-9 °/s with V at
    // 1e4 °/s) was "reached" without any jerk and the profile did not move at all.
    let change = |dv: f64, t_a: f64, t_b: f64, c: f64| -> Option<f64> {
        if t_a <= 0.0 {
            let speeds = vs.abs().max(ve.abs()).max(c.abs());
            return (dv.abs() <= tol * speeds && t_b <= 0.0).then_some(0.0);
        }
        let j = dv / (t_a * (t_a + t_b));
        (j.abs() <= lim.max_jerk * (1.0 + tol) && (j * t_a).abs() <= acc_bound(j) * (1.0 + tol))
            .then_some(j)
    };
    let (c1, c2, c3, c4, c5) = (
        counts(shape.t1),
        counts(shape.t2),
        counts(shape.t3),
        counts(shape.t4),
        counts(shape.t5),
    );
    let mut best: Option<(f64, GridPhases)> = None;
    for &t1 in &c1 {
        for &t2 in &c2 {
            if t1 <= 0.0 && t2 > 0.0 {
                continue;
            }
            for &t3 in &c3 {
                for &t4 in &c4 {
                    for &t5 in &c5 {
                        if t4 <= 0.0 && t5 > 0.0 {
                            continue;
                        }
                        let total = 2.0 * t1 + t2 + t3 + 2.0 * t4 + t5;
                        if total < min_total || best.is_some_and(|(b, _)| total >= b) {
                            continue;
                        }
                        let (tau1, tau2) = (2.0 * t1 + t2, 2.0 * t4 + t5);
                        let weight = 0.5 * tau1 + t3 + 0.5 * tau2;
                        if weight <= 0.0 {
                            continue;
                        }
                        let c = (distance - 0.5 * vs * tau1 - 0.5 * ve * tau2) / weight;
                        if c.abs() > lim.max_vel * (1.0 + tol)
                            || (forbid_reversal && c < -tol * scale)
                        {
                            continue;
                        }
                        let (Some(j1), Some(j2)) =
                            (change(c - vs, t1, t2, c), change(ve - c, t4, t5, c))
                        else {
                            continue;
                        };
                        best = Some((
                            total,
                            GridPhases {
                                t1,
                                t2,
                                t3,
                                t4,
                                t5,
                                c,
                                j1,
                                j2,
                            },
                        ));
                    }
                }
            }
        }
    }
    best.map(|(_, g)| g)
}
