//! One constant gantry speed per arc: the controller of the one-speed workflow (AAPM 2026, "A
//! Novel Deliverable Workflow for Dynamic Proton Arc Treatment", which adapts the beam's
//! intensity so each layer fits its window at the one speed). The gantry runs up from rest
//! between the first two layers, irradiates every other layer and cruises between them at the
//! arc's speed ω, and brakes into the last layer; the first and last layers are at rest, as in
//! every arc-ends-at-rest delivery.
//!
//! ω is the fastest speed every layer and move of the arc allow ([`arc_speed`]); every condition
//! only tightens as ω grows, so the allowed speeds are an interval `(0, ω]`:
//! - each inner layer's sweep fits its window and V: ω ≤ min(V, w_k / t_k) (DOMAIN, layer speed);
//! - each cruise between inner layers lasts its ELST: the gap `D − ω(t_{k−1} + t_k)/2` (planner
//!   eq. 5) covered at ω takes at least `ELST_k`, so ω ≤ D / (ELST_k + (t_{k−1} + t_k)/2);
//! - the run-up (rest → ω) and the braking (ω → rest) fit their gaps within J, A, D and last
//!   their ELSTs: found by bisection on the planner's own feasibility.
//!
//! The beam's time per layer is the beam model's (its fastest). Spreading a layer's irradiation
//! at a lower intensity changes neither the gantry's motion nor the total, only how the time
//! between beam-ons is labelled. The delivery is built and verified by integration as a
//! constant-speed delivery whose inner moves are held to their cruise durations.

use arcsim_plan::ResolvedArc;
use arcsim_planner::{Limits, MoveAnalysis, Reversal};

use crate::constant::{assemble, limiter_counts};
use crate::problem::ArcProblem;
use crate::raise::{label_by_raise, raised_limits, timed, GANTRY_LIMITS};
use crate::schedule::ChosenSpeeds;
use crate::{
    Delivery, Infeasibility, Limiter, LostTime, Motion, Options, SequenceError, SpeedBound,
    LIMIT_RAISE_FACTOR,
};

/// Bisection steps for the run-up and braking bound (2⁻⁶⁰ of the bracket: below rounding).
const BISECTION_STEPS: usize = 60;

/// The one-speed delivery of `arcs`; `constant` is the constant-speed delivery under the options'
/// schedule, kept as the what-if total.
pub(crate) fn simulate_one_speed(
    arcs: &[ResolvedArc],
    problems: &[ArcProblem],
    lim: &Limits,
    opts: &Options,
    constant: Delivery,
) -> Result<Delivery, SequenceError> {
    let mut chosen = ChosenSpeeds {
        speeds: Vec::with_capacity(arcs.len()),
        bounds: Vec::with_capacity(arcs.len()),
        violations: Vec::new(),
        min_move_s: Vec::with_capacity(arcs.len()),
    };
    let mut omegas = Vec::with_capacity(arcs.len());
    for (arc, p) in arcs.iter().zip(problems) {
        let omega = arc_speed(p, lim).map_err(|(layer, why)| SequenceError::Infeasible {
            arc: arc.arc_index,
            layer,
            reason: Infeasibility::NoArcSpeed { why },
        })?;
        let n = p.len();
        let inner = |k: usize| k > 0 && k + 1 < n;
        chosen
            .speeds
            .push((0..n).map(|k| if inner(k) { omega } else { 0.0 }).collect());
        chosen.bounds.push(
            (0..n)
                .map(|k| {
                    if inner(k) {
                        SpeedBound::OneSpeed
                    } else {
                        SpeedBound::Rest
                    }
                })
                .collect(),
        );
        chosen.min_move_s.push(
            (0..n)
                .map(|k| cruise_s(p, k, omega).unwrap_or(0.0))
                .collect(),
        );
        omegas.push(omega);
    }
    let mut d = assemble(arcs, problems, &chosen, lim, opts)?;
    label_cruises(&mut d, problems, lim, &omegas);
    d.motion = Motion::OneSpeed;
    d.constant_speed_total_s = Some(constant.total_s);
    d.limiter_counts = limiter_counts(&d.transitions);
    d.lost_time = LostTime::of(&d.layers, &d.transitions);
    Ok(d)
}

/// The duration of the cruise into layer `k` at `omega` (s): `None` unless layers `k − 1` and
/// `k` are both inner layers of the arc (the moves at its ends start or stop at rest).
fn cruise_s(p: &ArcProblem, k: usize, omega: f64) -> Option<f64> {
    let n = p.len();
    if k < 2 || k + 1 >= n || omega <= 0.0 {
        return None;
    }
    Some(p.transition_move(k - 1, omega, omega).distance / omega)
}

/// What limits each cruise: the gantry limit whose raise (by [`crate::LIMIT_RAISE_FACTOR`])
/// shortens it most through a faster arc speed, or the ELST when none does (the speed is set by
/// a window or a cruise's ELST).
fn label_cruises(d: &mut Delivery, problems: &[ArcProblem], lim: &Limits, omegas: &[f64]) {
    let mut first = 0;
    for (p, &omega) in problems.iter().zip(omegas) {
        // The arc's speed under each raised limit, once per arc (not once per cruise).
        let faster: Vec<(Limits, Option<f64>)> = GANTRY_LIMITS
            .iter()
            .map(|&which| {
                let raised = raised_limits(lim, which, LIMIT_RAISE_FACTOR);
                (raised, arc_speed(p, &raised).ok())
            })
            .collect();
        for k in 0..p.len() {
            let Some(base) = cruise_s(p, k, omega) else {
                continue;
            };
            let to = first + k;
            let label = label_by_raise(base, p.elst[k], lim, |raised| {
                let speed = match faster.iter().find(|(l, _)| l == raised) {
                    Some(&(_, speed)) => speed?,
                    None => arc_speed(p, raised).ok()?,
                };
                cruise_s(p, k, speed)
            });
            for tr in d.transitions.iter_mut().filter(|t| t.to_layer == to) {
                tr.limited_by = if base > 0.0 { label } else { Limiter::None };
            }
        }
        first += p.len();
    }
}

/// The fastest single speed the arc's inner layers and moves allow (deg/s); 0 for an arc of at
/// most two layers (both at rest). Err: the layer where no speed works, and why.
pub(crate) fn arc_speed(p: &ArcProblem, lim: &Limits) -> Result<f64, (usize, String)> {
    let n = p.len();
    if n < 3 {
        return Ok(0.0);
    }
    // Each inner sweep within its window and V, from `lim` (not the problem's own caps, made
    // with the limits it was built under: the labels ask for the speed under a raised V).
    let mut top = f64::INFINITY;
    for k in 1..n - 1 {
        let t = p.irradiation_s[k];
        let window_cap = if t > 0.0 {
            p.window[k] / t
        } else {
            f64::INFINITY
        };
        top = top.min(window_cap.min(lim.max_vel));
    }
    for k in 2..n - 1 {
        let distance = p.travel_deg[k] - p.travel_deg[k - 1];
        let floor = p.elst[k] + 0.5 * (p.irradiation_s[k - 1] + p.irradiation_s[k]);
        if floor > 0.0 {
            top = top.min(distance / floor);
        }
        if top <= 0.0 {
            return Err((
                k,
                format!(
                    "layers {} and {k} are {distance} deg apart, and moving at any speed the gantry covers more than that in their irradiation and the {} s energy switch",
                    k - 1,
                    p.elst[k]
                ),
            ));
        }
    }
    if ends_fit(p, lim, top) {
        return Ok(top);
    }
    // The run-up and braking only get harder as ω grows: bisect (0, top].
    let (mut lo, mut hi) = (0.0, top);
    for _ in 0..BISECTION_STEPS {
        let mid = 0.5 * (lo + hi);
        if ends_fit(p, lim, mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    if lo > 0.0 {
        Ok(lo)
    } else {
        Err((
            1,
            "no run-up from rest into the second layer (or braking into the last) fits its gap"
                .to_string(),
        ))
    }
}

/// Whether the run-up into layer 1 and the braking into the last layer fit their gaps at `omega`
/// and can last their ELSTs.
fn ends_fit(p: &ArcProblem, lim: &Limits, omega: f64) -> bool {
    let n = p.len();
    let fits = |k: usize, vs: f64, ve: f64| {
        p.gap_open(k, vs, ve)
            && MoveAnalysis::new(&p.transition_move(k, vs, ve), lim, Reversal::Forbid)
                .is_ok_and(|a| timed(&a).at_least(p.elst[k + 1]).is_some())
    };
    fits(0, 0.0, omega) && fits(n - 2, omega, 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use arcsim_plan::{ResolvedLayer, RotationDirection};

    fn arc(angles: &[f64], t: f64, elst: f64, window: f64) -> ResolvedArc {
        ResolvedArc {
            arc_index: 0,
            direction: RotationDirection::Cw,
            layers: angles
                .iter()
                .enumerate()
                .map(|(i, &a)| ResolvedLayer {
                    control_point: i,
                    layer: 0,
                    angle_deg: a,
                    energy_mev: 100.0,
                    irradiation_s: t,
                    window_deg: window,
                    spot_irradiation_s: t,
                    scanning_s: 0.0,
                    burst_switching_s: 0.0,
                    spill_waiting_s: 0.0,
                    required_speed_deg_per_s: None,
                    switch_in_s: if i == 0 { 0.0 } else { elst },
                    mu: 0.0,
                })
                .collect(),
        }
    }

    /// The cruise bound in closed form: layers 2° apart, 0.5 s of beam and 1 s of ELST give at
    /// most 2 / (1 + 0.5) deg/s, below V, the windows' 4 deg/s and (with these limits) the ends.
    #[test]
    fn the_cruise_sets_the_speed_in_closed_form() {
        let a = arc(&[0.0, 10.0, 12.0, 14.0, 16.0, 26.0], 0.5, 1.0, 2.0);
        let lim = Limits::new(2.0, 1.0, 6.0).expect("limits");
        let p = ArcProblem::new(&a, &lim);
        let omega = arc_speed(&p, &lim).expect("a speed");
        assert!((omega - 2.0 / 1.5).abs() < 1e-12, "{omega}");
    }

    /// An arc whose speed only V holds: its cruises are labelled V (the speed is found again
    /// under the raised V, not from the caps the problem was built with).
    #[test]
    fn cruises_held_by_v_are_labelled_v() {
        let a = arc(&[0.0, 20.0, 40.0, 60.0, 80.0, 100.0], 0.1, 0.5, 2.0);
        let lim = Limits::new(2.0, 1.0, 1.0).expect("limits");
        let opts = Options {
            motion: Motion::OneSpeed,
            ..Options::new(crate::Schedule::Optimal)
        };
        let d = crate::simulate_resolved(std::slice::from_ref(&a), &lim, &opts).expect("one speed");
        assert_eq!(d.layers[2].speed_deg_per_s, 1.0);
        let cruises: Vec<Limiter> = d.transitions[2..4].iter().map(|t| t.limited_by).collect();
        assert_eq!(cruises, vec![Limiter::Speed, Limiter::Speed]);
    }

    /// Two inner layers at one angle leave no speed, and the error names the layer.
    #[test]
    fn inner_layers_at_one_angle_have_no_speed() {
        let a = arc(&[0.0, 10.0, 10.0, 20.0], 0.5, 1.0, 2.0);
        let lim = Limits::new(2.0, 1.0, 6.0).expect("limits");
        let p = ArcProblem::new(&a, &lim);
        let (layer, why) = arc_speed(&p, &lim).expect_err("no speed");
        assert_eq!(layer, 2, "{why}");
    }
}
