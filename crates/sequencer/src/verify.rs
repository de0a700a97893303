//! The timeline's own check, by integrating its pieces, and its kinematic margins.

use arcsim_planner::Limits;

use crate::problem::ArcProblem;
use crate::timeline::{PieceKind, Timeline};
use crate::{LayerRow, Margin, Margins, SequenceError, TransitionRow};

/// Relative tolerance of every check.
const TOL: f64 = 1e-9;

/// Integrates the timeline piece by piece and checks: continuous time, angle, speed and
/// acceleration; every layer inside its window (at constant speed unless `free_motion`); every transition at least its
/// ELST; |speed| <= V, |acceleration| <= A (D when braking), |jerk| <= J; no reversal in an arc.
pub(crate) fn verify_timeline(
    tl: &Timeline,
    problems: &[ArcProblem],
    layers: &[LayerRow],
    transitions: &[TransitionRow],
    lim: &Limits,
    free_motion: bool,
) -> Result<(), SequenceError> {
    let fail = |msg: String| Err(SequenceError::Verification(msg));
    let a_max = lim.max_accel.max(lim.max_decel);
    let scale_angle = 360.0f64.max(layers.iter().map(|l| l.angle_deg.abs()).fold(0.0, f64::max));
    let mut dir_of_layer = Vec::with_capacity(layers.len());
    for p in problems {
        dir_of_layer.extend(std::iter::repeat_n(p.dir, p.len()));
    }
    check_continuity(tl, lim, a_max, scale_angle)?;
    for p in &tl.pieces {
        let current_dir: f64;
        let (s0, s1) = (p.state_after(0.0), p.state_after(p.duration_s));
        if p.jerk_deg_per_s3.abs() > lim.max_jerk * (1.0 + TOL) {
            return fail(format!(
                "jerk {} above J at t = {:.6} s",
                p.jerk_deg_per_s3, p.t_start_s
            ));
        }
        // Acceleration is linear in a piece: its ends bound it. Speed peaks at an end or where a = 0.
        let mut speeds = vec![s0.speed_deg_per_s, s1.speed_deg_per_s];
        if p.jerk_deg_per_s3 != 0.0 {
            let tv = -p.accel_deg_per_s2 / p.jerk_deg_per_s3;
            if tv > 0.0 && tv < p.duration_s {
                speeds.push(p.state_after(tv).speed_deg_per_s);
            }
        }
        match p.kind {
            PieceKind::Beam { layer } => {
                current_dir = dir_of_layer[layer];
                let l = &layers[layer];
                let lo = l.angle_deg - 0.5 * l.window_deg;
                let hi = l.angle_deg + 0.5 * l.window_deg;
                let tol = TOL * scale_angle;
                for a in [s0.angle_deg, s1.angle_deg] {
                    if a < lo - tol || a > hi + tol {
                        return fail(format!("layer {layer}: beam at {a:.9} deg outside its window [{lo:.6}, {hi:.6}]"));
                    }
                }
                if !free_motion && (p.accel_deg_per_s2 != 0.0 || p.jerk_deg_per_s3 != 0.0) {
                    return fail(format!(
                        "layer {layer}: speed not constant while irradiating"
                    ));
                }
            }
            PieceKind::RunUp { arc } => {
                current_dir = problems.get(arc).map_or(0.0, |p| p.dir);
            }
            PieceKind::Move { transition } => {
                let Some(tr) = transitions.get(transition) else {
                    return fail(format!(
                        "a move belongs to transition {transition}, which does not exist"
                    ));
                };
                if tr.arc_change {
                    current_dir = 0.0; // a stop-and-turn may go either way, at rest at both ends
                } else {
                    current_dir = dir_of_layer[tr.to_layer];
                }
            }
        }
        for (k, acc) in [s0.accel_deg_per_s2, s1.accel_deg_per_s2]
            .into_iter()
            .enumerate()
        {
            let braking = current_dir != 0.0 && acc * current_dir < 0.0;
            let bound = if current_dir == 0.0 {
                a_max
            } else if braking {
                lim.max_decel
            } else {
                lim.max_accel
            };
            if acc.abs() > bound * (1.0 + TOL) {
                return fail(format!(
                    "acceleration {acc} above its limit {bound} at t = {:.6} s",
                    p.t_start_s + k as f64 * p.duration_s
                ));
            }
        }
        for v in speeds {
            if v.abs() > lim.max_vel * (1.0 + TOL) {
                return fail(format!("speed {v} above V at t = {:.6} s", p.t_start_s));
            }
            if current_dir != 0.0 && v * current_dir < -TOL * lim.max_vel {
                return fail(format!(
                    "gantry reverses inside an arc at t = {:.6} s (speed {v})",
                    p.t_start_s
                ));
            }
        }
    }
    check_elsts_and_end(tl, layers, transitions)
}

/// Checks that time, angle, speed and acceleration are continuous between pieces.
fn check_continuity(
    tl: &Timeline,
    lim: &Limits,
    a_max: f64,
    scale_angle: f64,
) -> Result<(), SequenceError> {
    let fail = |msg: String| Err(SequenceError::Verification(msg));
    for (i, w) in tl.pieces.windows(2).enumerate() {
        let (a, b) = (&w[0], &w[1]);
        let end = a.state_after(a.duration_s);
        if (a.t_start_s + a.duration_s - b.t_start_s).abs() > TOL * (1.0 + b.t_start_s) {
            return fail(format!("time jumps between pieces {i} and {}", i + 1));
        }
        if (end.angle_deg - b.angle_deg).abs() > TOL * scale_angle {
            return fail(format!(
                "angle jumps by {:e} deg at t = {:.6} s",
                end.angle_deg - b.angle_deg,
                b.t_start_s
            ));
        }
        if (end.speed_deg_per_s - b.speed_deg_per_s).abs() > TOL * lim.max_vel {
            return fail(format!(
                "speed jumps by {:e} deg/s at t = {:.6} s",
                end.speed_deg_per_s - b.speed_deg_per_s,
                b.t_start_s
            ));
        }
        if (end.accel_deg_per_s2 - b.accel_deg_per_s2).abs() > TOL * a_max {
            return fail(format!("acceleration jumps at t = {:.6} s", b.t_start_s));
        }
    }
    Ok(())
}

/// Checks that every transition lasts at least its ELST and the timeline ends with the last layer.
fn check_elsts_and_end(
    tl: &Timeline,
    layers: &[LayerRow],
    transitions: &[TransitionRow],
) -> Result<(), SequenceError> {
    let fail = |msg: String| Err(SequenceError::Verification(msg));
    for tr in transitions {
        if tr.duration_s < tr.elst_s * (1.0 - TOL) {
            return fail(format!(
                "transition {} lasts {} s, less than its ELST {} s",
                tr.index, tr.duration_s, tr.elst_s
            ));
        }
    }
    let total = layers.last().map_or(0.0, |l| l.t_end_s);
    if (tl.duration_s() - total).abs() > TOL * (1.0 + total) {
        return fail(format!(
            "timeline lasts {} s but the layers end at {} s",
            tl.duration_s(),
            total
        ));
    }
    Ok(())
}

/// Peak use of each limit, the smallest window slack and the smallest ELST slack, with where.
pub(crate) fn margins(
    tl: &Timeline,
    layers: &[LayerRow],
    transitions: &[TransitionRow],
    lim: &Limits,
) -> Margins {
    let layer_near = |t: f64| {
        layers
            .iter()
            .position(|l| l.t_end_s >= t)
            .unwrap_or(layers.len().saturating_sub(1))
    };
    let zero = Margin {
        value: 0.0,
        t_s: 0.0,
        layer: 0,
    };
    let (mut speed, mut accel, mut jerk) = (zero, zero, zero);
    for p in &tl.pieces {
        let mut probe = vec![0.0, p.duration_s];
        if p.jerk_deg_per_s3 != 0.0 {
            let tv = -p.accel_deg_per_s2 / p.jerk_deg_per_s3;
            if tv > 0.0 && tv < p.duration_s {
                probe.push(tv);
            }
        }
        for dt in probe {
            let s = p.state_after(dt);
            let t = p.t_start_s + dt;
            let v = s.speed_deg_per_s.abs() / lim.max_vel;
            if v > speed.value {
                speed = Margin {
                    value: v,
                    t_s: t,
                    layer: layer_near(t),
                };
            }
            let braking = s.accel_deg_per_s2 * s.speed_deg_per_s < 0.0;
            let a = s.accel_deg_per_s2.abs()
                / if braking {
                    lim.max_decel
                } else {
                    lim.max_accel
                };
            if a > accel.value {
                accel = Margin {
                    value: a,
                    t_s: t,
                    layer: layer_near(t),
                };
            }
        }
        let j = p.jerk_deg_per_s3.abs() / lim.max_jerk;
        if j > jerk.value {
            jerk = Margin {
                value: j,
                t_s: p.t_start_s,
                layer: layer_near(p.t_start_s),
            };
        }
    }
    let window_slack_deg = layers
        .iter()
        .map(|l| Margin {
            value: l.window_deg - l.window_used_deg,
            t_s: l.t_start_s,
            layer: l.index,
        })
        .min_by(|a, b| a.value.total_cmp(&b.value))
        .unwrap_or(zero);
    let elst_slack_s = transitions
        .iter()
        .filter(|tr| tr.elst_s > 0.0)
        .map(|tr| Margin {
            value: tr.duration_s - tr.elst_s,
            t_s: tr.t_start_s,
            layer: tr.to_layer,
        })
        .min_by(|a, b| a.value.total_cmp(&b.value))
        .unwrap_or(Margin {
            value: f64::INFINITY,
            ..zero
        });
    Margins {
        speed_use: speed,
        accel_use: accel,
        jerk_use: jerk,
        window_slack_deg,
        elst_slack_s,
    }
}
