//! One speed per arc, checked from outside its solver: every timeline meets every constraint
//! (the property checks of `properties.rs`); the inner layers and the moves between them run at
//! one speed; that speed is the fastest the arc allows, shown by the plan's own geometry and the
//! constant-speed sequencer just above it; a one-speed delivery is never faster than the
//! constant-speed delivery at the same layer speeds; and raising a gantry limit never lowers it.

use crate::properties::check;
use crate::util::machine;
use arcsim_plan::generate::{generate, PlanKind};
use arcsim_plan::{resolve, ArcPlan, Machine, ResolvedArc};
use arcsim_sequencer::{
    machine_limits, simulate, simulate_with_speeds, Delivery, Motion, Options, PieceKind, Schedule,
};

fn one_speed() -> Options {
    Options {
        motion: Motion::OneSpeed,
        ..Options::new(Schedule::Optimal)
    }
}

/// Each arc's one speed, read from its inner layers' rows (which must all agree); 0 for an arc
/// of at most two layers.
fn arc_speeds(d: &Delivery, arcs: &[ResolvedArc], what: &str) -> Vec<f64> {
    let mut first = 0;
    let mut out = Vec::new();
    for a in arcs {
        let rows = &d.layers[first..first + a.layers.len()];
        let n = rows.len();
        let omega = if n >= 3 { rows[1].speed_deg_per_s } else { 0.0 };
        for (k, r) in rows.iter().enumerate() {
            let want = if k == 0 || k + 1 == n { 0.0 } else { omega };
            assert_eq!(
                r.speed_deg_per_s, want,
                "{what}: arc {} layer {k}",
                a.arc_index
            );
        }
        first += n;
        out.push(omega);
    }
    out
}

/// The inner moves are cruises: speed ω and no acceleration anywhere inside them.
fn check_cruises(d: &Delivery, arcs: &[ResolvedArc], omegas: &[f64], what: &str) {
    let tl = d.timeline.as_ref().expect("timeline");
    let mut first = 0;
    for (a, &omega) in arcs.iter().zip(omegas) {
        let n = a.layers.len();
        for tr in d
            .transitions
            .iter()
            .filter(|t| t.to_layer >= first + 2 && t.to_layer + 1 < first + n)
        {
            for piece in tl.pieces.iter().filter(
                |p| matches!(p.kind, PieceKind::Move { transition } if transition == tr.index),
            ) {
                for x in [0.0, 0.5 * piece.duration_s, piece.duration_s] {
                    let s = piece.state_after(x);
                    assert!(
                        (s.speed_deg_per_s.abs() - omega).abs() <= 1e-9 * (1.0 + omega)
                            && s.accel_deg_per_s2.abs() <= 1e-9,
                        "{what}: transition {} is not a cruise at {omega}: {s:?}",
                        tr.index
                    );
                }
            }
        }
        first += n;
    }
}

/// Why `omega` is too fast for arc `a` on `m`, from the plan's geometry (windows, V, cruises that
/// would be shorter than their ELST) or, failing those, the constant-speed sequencer refusing the
/// run-up or braking at that speed; `None` if nothing rules it out.
fn too_fast(m: &Machine, arcs: &[ResolvedArc], omegas: &[f64], arc: usize) -> Option<String> {
    let a = &arcs[arc];
    let omega = omegas[arc];
    let n = a.layers.len();
    let l = &a.layers;
    for (k, layer) in l.iter().enumerate().take(n - 1).skip(1) {
        if omega > m.gantry.max_speed_deg_per_s || omega * layer.irradiation_s > layer.window_deg {
            return Some(format!("layer {k}'s window or V"));
        }
    }
    for k in 2..n - 1 {
        let apart = (l[k].angle_deg - l[k - 1].angle_deg).abs();
        let gap = apart - 0.5 * omega * (l[k - 1].irradiation_s + l[k].irradiation_s);
        if gap / omega < l[k].switch_in_s {
            return Some(format!(
                "the cruise into layer {k} is shorter than its ELST"
            ));
        }
    }
    let limits = machine_limits(m).expect("limits");
    let speeds: Vec<f64> = arcs
        .iter()
        .zip(omegas)
        .flat_map(|(a, &w)| {
            let n = a.layers.len();
            (0..n).map(move |k| if k == 0 || k + 1 == n { 0.0 } else { w })
        })
        .collect();
    simulate_with_speeds(arcs, &limits, &speeds, &Options::new(Schedule::Prescribed))
        .err()
        .map(|e| format!("the constant-speed sequencer refuses it: {e}"))
}

/// Checks one plan on one machine; returns the arcs' speeds.
fn check_plan(plan: &ArcPlan, m: &Machine, what: &str) -> Vec<f64> {
    let d = simulate(plan, m, &one_speed()).unwrap_or_else(|e| panic!("{what}: {e}"));
    assert_eq!(d.motion, Motion::OneSpeed);
    check(&d, m, what);
    let arcs = resolve(plan, m).expect("resolves");
    let omegas = arc_speeds(&d, &arcs, what);
    check_cruises(&d, &arcs, &omegas, what);
    let limits = machine_limits(m).expect("limits");
    // The same layer speeds with the quickest moves between them (constant speed per layer).
    let speeds: Vec<f64> = d.layers.iter().map(|l| l.speed_deg_per_s).collect();
    let quickest =
        simulate_with_speeds(&arcs, &limits, &speeds, &Options::new(Schedule::Prescribed))
            .expect("the same speeds, constant motion");
    assert!(
        d.total_s >= quickest.total_s * (1.0 - 1e-12),
        "{what}: one speed {} beats the quickest moves at its speeds {}",
        d.total_s,
        quickest.total_s
    );
    assert_eq!(d.constant_speed_total_s.map(|c| c > 0.0), Some(true));
    for i in 0..arcs.len() {
        if arcs[i].layers.len() < 3 {
            continue;
        }
        assert!(omegas[i] > 0.0, "{what}: arc {i} at rest");
        let mut above = omegas.clone();
        above[i] *= 1.0 + 1e-6;
        assert!(
            too_fast(m, &arcs, &above, i).is_some(),
            "{what}: arc {i} could run at {} (above its {})",
            above[i],
            omegas[i]
        );
    }
    omegas
}

/// Every generated kind (the lung's and head-and-neck's control points hold up to three layers,
/// spread across their windows) on the bundled machines, and on a gantry that brakes harder or
/// more gently.
#[test]
fn one_speed_is_the_fastest_single_speed_and_meets_every_constraint() {
    for (kind, seeds) in [
        (PlanKind::Prostate, 1..4u64),
        (PlanKind::TwoArc, 1..4),
        (PlanKind::Lung, 1..3),
        (PlanKind::HeadNeck, 1..2),
    ] {
        for seed in seeds {
            let plan = generate(kind, seed);
            for name in [
                "machine-atom.json",
                "machine-fast.json",
                "machine-opentps.json",
            ] {
                let m = machine(name);
                let what = format!("{kind:?} seed {seed} on {name}");
                let omegas = check_plan(&plan, &m, &what);
                // Raising any limit never lowers an arc's speed.
                for (which, factor) in [("V", 1.3), ("A", 1.5), ("J", 2.0)] {
                    let mut faster = m.clone();
                    let g = &mut faster.gantry;
                    match which {
                        "V" => g.max_speed_deg_per_s *= factor,
                        "A" => {
                            g.max_accel_deg_per_s2 *= factor;
                            g.max_decel_deg_per_s2 = g.max_decel_deg_per_s2.map(|d| d * factor);
                        }
                        _ => g.max_jerk_deg_per_s3 *= factor,
                    }
                    let raised = check_plan(&plan, &faster, &format!("{what}, {which} ×{factor}"));
                    for (lo, hi) in omegas.iter().zip(&raised) {
                        assert!(hi >= lo, "{what}: raising {which} lowered {lo} to {hi}");
                    }
                }
            }
            for decel in [1.6, 0.6] {
                let mut m = machine("machine-atom.json");
                m.gantry.max_decel_deg_per_s2 = Some(decel * m.gantry.max_accel_deg_per_s2);
                check_plan(&plan, &m, &format!("{kind:?} seed {seed}, D = {decel} A"));
            }
        }
    }
}

/// One speed per arc has no servo-period version, and takes no schedule that fixes speeds: both
/// are refused with the reason.
#[test]
fn one_speed_refuses_a_servo_period_and_fixed_speeds() {
    let plan = generate(PlanKind::Prostate, 1);
    let m = machine("machine-atom.json");
    let on_period = Options {
        servo_period_s: Some(0.004),
        ..one_speed()
    };
    let text = simulate(&plan, &m, &on_period)
        .expect_err("period")
        .to_string();
    assert!(text.contains("continuous-time only"), "{text}");
    let fixed = Options {
        schedule: Schedule::StepAndShoot,
        ..one_speed()
    };
    let text = simulate(&plan, &m, &fixed)
        .expect_err("schedule")
        .to_string();
    assert!(text.contains("step-and-shoot"), "{text}");
}
