//! The timeline's own check, by integrating its pieces, and its kinematic margins.

use arcsim_planner::Limits;

use crate::problem::ArcProblem;
use crate::timeline::{Piece, PieceKind, Timeline};
use crate::{LayerRow, Margin, Margins, TransitionRow, VerificationError};

/// Relative tolerance of every check.
const TOL: f64 = 1e-9;

/// Integrates the timeline piece by piece and checks: continuous time, angle, speed and
/// acceleration; every layer inside its window (at constant speed unless `free_motion`); every
/// transition at least its ELST; |speed| <= V, |acceleration| <= A (D when braking), |jerk| <= J;
/// no reversal in an arc.
pub(crate) fn verify_timeline(
    tl: &Timeline,
    problems: &[ArcProblem],
    layers: &[LayerRow],
    transitions: &[TransitionRow],
    lim: &Limits,
    free_motion: bool,
) -> Result<(), VerificationError> {
    let scale_angle = 360.0f64.max(layers.iter().map(|l| l.angle_deg.abs()).fold(0.0, f64::max));
    let mut dir_of_layer = Vec::with_capacity(layers.len());
    for p in problems {
        dir_of_layer.extend(std::iter::repeat_n(p.dir, p.len()));
    }
    check_continuity(tl, lim, scale_angle)?;
    let rows = Rows {
        problems,
        layers,
        transitions,
        dir_of_layer: &dir_of_layer,
    };
    for p in &tl.pieces {
        check_piece(p, &rows, lim, scale_angle, free_motion)?;
    }
    check_elsts(transitions)?;
    let total = layers.last().map_or(0.0, |l| l.t_end_s);
    if (tl.duration_s() - total).abs() > TOL * (1.0 + total) {
        return Err(VerificationError::DurationMismatch {
            timeline_s: tl.duration_s(),
            layers_end_s: total,
        });
    }
    Ok(())
}

/// The delivery's rows a piece is checked against, and the direction of each layer's arc.
struct Rows<'a> {
    problems: &'a [ArcProblem],
    layers: &'a [LayerRow],
    transitions: &'a [TransitionRow],
    dir_of_layer: &'a [f64],
}

/// Each piece ends where the next starts: in time, angle, speed and acceleration.
fn check_continuity(
    tl: &Timeline,
    lim: &Limits,
    scale_angle: f64,
) -> Result<(), VerificationError> {
    let a_max = lim.max_accel.max(lim.max_decel);
    for (i, w) in tl.pieces.windows(2).enumerate() {
        let (a, b) = (&w[0], &w[1]);
        let end = a.state_after(a.duration_s);
        if (a.t_start_s + a.duration_s - b.t_start_s).abs() > TOL * (1.0 + b.t_start_s) {
            return Err(VerificationError::TimeJump { piece: i });
        }
        if (end.angle_deg - b.angle_deg).abs() > TOL * scale_angle {
            return Err(VerificationError::AngleJump {
                jump_deg: end.angle_deg - b.angle_deg,
                t_s: b.t_start_s,
            });
        }
        if (end.speed_deg_per_s - b.speed_deg_per_s).abs() > TOL * lim.max_vel {
            return Err(VerificationError::SpeedJump {
                jump_deg_per_s: end.speed_deg_per_s - b.speed_deg_per_s,
                t_s: b.t_start_s,
            });
        }
        if (end.accel_deg_per_s2 - b.accel_deg_per_s2).abs() > TOL * a_max {
            return Err(VerificationError::AccelJump { t_s: b.t_start_s });
        }
    }
    Ok(())
}

/// One piece within the limits: its jerk, its beam inside the window (at constant speed unless
/// `free_motion`), its acceleration and speed, and no reversal inside an arc.
fn check_piece(
    p: &Piece,
    rows: &Rows,
    lim: &Limits,
    scale_angle: f64,
    free_motion: bool,
) -> Result<(), VerificationError> {
    let (s0, s1) = (p.state_after(0.0), p.state_after(p.duration_s));
    if p.jerk_deg_per_s3.abs() > lim.max_jerk * (1.0 + TOL) {
        return Err(VerificationError::JerkAboveLimit {
            jerk_deg_per_s3: p.jerk_deg_per_s3,
            t_s: p.t_start_s,
        });
    }
    // Acceleration is linear in a piece: its ends bound it. Speed peaks at an end or where a = 0.
    let mut speeds = vec![s0.speed_deg_per_s, s1.speed_deg_per_s];
    if p.jerk_deg_per_s3 != 0.0 {
        let tv = -p.accel_deg_per_s2 / p.jerk_deg_per_s3;
        if tv > 0.0 && tv < p.duration_s {
            speeds.push(p.state_after(tv).speed_deg_per_s);
        }
    }
    let current_dir = direction_of(p, rows, scale_angle, free_motion)?;
    let a_max = lim.max_accel.max(lim.max_decel);
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
            return Err(VerificationError::AccelAboveLimit {
                accel_deg_per_s2: acc,
                limit_deg_per_s2: bound,
                t_s: p.t_start_s + k as f64 * p.duration_s,
            });
        }
    }
    for v in speeds {
        if v.abs() > lim.max_vel * (1.0 + TOL) {
            return Err(VerificationError::SpeedAboveLimit {
                speed_deg_per_s: v,
                t_s: p.t_start_s,
            });
        }
        if current_dir != 0.0 && v * current_dir < -TOL * lim.max_vel {
            return Err(VerificationError::Reversal {
                t_s: p.t_start_s,
                speed_deg_per_s: v,
            });
        }
    }
    Ok(())
}

/// The direction the gantry must keep during piece `p` (0 where it may go either way, in a
/// stop-and-turn); a beam piece is checked against its window on the way.
fn direction_of(
    p: &Piece,
    rows: &Rows,
    scale_angle: f64,
    free_motion: bool,
) -> Result<f64, VerificationError> {
    match p.kind {
        PieceKind::Beam { layer } => {
            let l = &rows.layers[layer];
            let lo = l.angle_deg - 0.5 * l.window_deg;
            let hi = l.angle_deg + 0.5 * l.window_deg;
            let tol = TOL * scale_angle;
            for a in [
                p.state_after(0.0).angle_deg,
                p.state_after(p.duration_s).angle_deg,
            ] {
                if a < lo - tol || a > hi + tol {
                    return Err(VerificationError::BeamOutsideWindow {
                        layer,
                        angle_deg: a,
                        lo_deg: lo,
                        hi_deg: hi,
                    });
                }
            }
            if !free_motion && (p.accel_deg_per_s2 != 0.0 || p.jerk_deg_per_s3 != 0.0) {
                return Err(VerificationError::SpeedNotConstant { layer });
            }
            Ok(rows.dir_of_layer[layer])
        }
        PieceKind::RunUp { arc } => Ok(rows.problems.get(arc).map_or(0.0, |p| p.dir)),
        PieceKind::Move { transition } => {
            let Some(tr) = rows.transitions.get(transition) else {
                return Err(VerificationError::UnknownTransition { transition });
            };
            // A stop-and-turn may go either way, at rest at both ends.
            Ok(if tr.arc_change {
                0.0
            } else {
                rows.dir_of_layer[tr.to_layer]
            })
        }
    }
}

/// Every transition lasts at least its ELST.
fn check_elsts(transitions: &[TransitionRow]) -> Result<(), VerificationError> {
    for tr in transitions {
        if tr.duration_s < tr.elst_s * (1.0 - TOL) {
            return Err(VerificationError::ShorterThanElst {
                transition: tr.index,
                duration_s: tr.duration_s,
                elst_s: tr.elst_s,
            });
        }
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
