//! Issue 45's acceptance checks for free motion, against the problem's own laws: the same
//! question gives the same answer (to the last bit, whatever the thread count); a relative change
//! ε of an input changes the total by at most 10·ε + 5e-5 relative; raising a limit never
//! lengthens the delivery by more than 5e-5 relative. The first holds today. The other two fail
//! on today's solver, whose refinement stops where a step's exact build happens to fail, so its
//! total jumps with inputs 1e-12 apart; they are ignored with that reason and run with
//! `cargo test -p arcsim-sequencer --test integration -- --ignored free_acceptance --nocapture`,
//! which prints every case and its figure.

use crate::util::{edited_machine, machine};
use arcsim_plan::generate::{generate, PlanKind};
use arcsim_plan::{ArcPlan, Machine};
use arcsim_sequencer::{simulate, ArcEnds, Motion, Options, Schedule};

fn free(ends: ArcEnds) -> Options {
    Options {
        motion: Motion::Free,
        arc_ends: ends,
        build_timeline: false,
        ..Options::new(Schedule::Optimal)
    }
}

/// The bundled plans and the ATOM article's cases, with the arc ends each allows (free ends
/// need a single arc).
fn cases() -> Vec<(String, ArcPlan, Vec<ArcEnds>)> {
    let mut out = Vec::new();
    for kind in PlanKind::ALL {
        let ends = match kind {
            PlanKind::TwoArc => vec![ArcEnds::Rest],
            _ => vec![ArcEnds::Rest, ArcEnds::Free],
        };
        out.push((format!("bundled {kind}"), generate(kind, 1), ends));
    }
    for name in ["prostate", "head-and-neck", "liver"] {
        let path = format!(
            "{}/../../plans/atom/{name}.json",
            env!("CARGO_MANIFEST_DIR")
        );
        let plan = arcsim_plan::load_plan(&path).unwrap_or_else(|e| panic!("{e}"));
        out.push((
            format!("ATOM {name}"),
            plan,
            vec![ArcEnds::Rest, ArcEnds::Free],
        ));
    }
    out
}

fn total(plan: &ArcPlan, m: &Machine, ends: ArcEnds) -> f64 {
    simulate(plan, m, &free(ends)).expect("free motion").total_s
}

/// A cold solve is deterministic: the same plan and machine, solved twice on one thread and
/// twice on two, give the same total to the last bit.
#[test]
fn a_cold_solve_gives_the_same_total_on_any_thread_count() {
    let m = machine("machine-atom.json");
    for kind in [PlanKind::Lung, PlanKind::TwoArc] {
        let plan = generate(kind, 1);
        let mut totals = Vec::new();
        for threads in [1, 2, 1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool");
            totals.push(pool.install(|| total(&plan, &m, ArcEnds::Rest)));
        }
        assert!(
            totals.iter().all(|t| t.to_bits() == totals[0].to_bits()),
            "{kind}: {totals:?}"
        );
    }
}

/// The inputs a relative change is applied to: the time per MU (every irradiation time), both
/// ELSTs, and J, A, V.
const INPUTS: [(&str, &[&str]); 5] = [
    ("s/MU", &["/beam/s_per_mu"]),
    ("ELST", &["/elst/up_s", "/elst/down_s"]),
    ("J", &["/gantry/max_jerk_deg_per_s3"]),
    ("A", &["/gantry/max_accel_deg_per_s2"]),
    ("V", &["/gantry/max_speed_deg_per_s"]),
];

#[test]
#[ignore = "issue 45: free motion is not yet a function of its inputs (lung moves 0.2 % for a 1e-12 change of s/MU)"]
fn a_small_change_of_an_input_makes_a_small_change_of_the_total() {
    let mut failures = Vec::new();
    for (name, plan, ends) in cases() {
        for &e in &ends {
            let base = total(&plan, &machine("machine-atom.json"), e);
            for (input, fields) in INPUTS {
                for eps in [1e-12, 1e-9, 1e-6] {
                    let m = edited_machine("machine-atom.json", |v| {
                        for f in fields {
                            let slot = v.pointer_mut(f).expect("field");
                            let x = slot.as_f64().expect("number");
                            *slot = serde_json::json!(x * (1.0 + eps));
                        }
                    });
                    let t = total(&plan, &m, e);
                    let rel = (t - base).abs() / base;
                    let allowed = 10.0 * eps + 5e-5;
                    println!(
                        "{name} ({e:?}) {input} x(1+{eps:e}): {base:.6} -> {t:.6} s, {rel:.2e} (allowed {allowed:.2e})"
                    );
                    if rel > allowed {
                        failures.push(format!("{name} ({e:?}) {input} ε {eps:e}: {rel:.2e}"));
                    }
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} cases:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// Ten values of each limit from half to twice the ATOM machine's, geometrically spaced.
fn ladder(base: f64) -> Vec<f64> {
    (0..10)
        .map(|i| base * 2f64.powf(-1.0 + 2.0 * i as f64 / 9.0))
        .collect()
}

#[test]
#[ignore = "issue 45: free motion is not yet monotone in the limits (the 872-layer two-arc plan is 0.04 % longer at A = 1.0 than at A = 0.55)"]
fn raising_a_limit_never_lengthens_the_delivery() {
    let shape = arcsim_plan::Shape {
        spacing_deg: Some(2.2),
        layers_per_cp: Some((2, 4)),
        energy_mev: Some((70.0, 230.0)),
        spot_spacing_mm: None,
    };
    let mut all = cases();
    all.push((
        "two-arc, 888 layers".into(),
        arcsim_plan::generate_shaped(PlanKind::TwoArc, 1, &shape).expect("shape"),
        vec![ArcEnds::Rest],
    ));
    let axes = [
        ("J", "max_jerk_deg_per_s3", 0.5),
        ("A", "max_accel_deg_per_s2", 0.5),
        ("D", "max_decel_deg_per_s2", 0.5),
        ("V", "max_speed_deg_per_s", 5.0),
    ];
    let mut failures = Vec::new();
    for (name, plan, ends) in all {
        for &e in &ends {
            for (axis, field, base) in axes {
                let totals: Vec<(f64, f64)> = ladder(base)
                    .into_iter()
                    .map(|x| {
                        let m = edited_machine("machine-atom.json", |v| {
                            v["gantry"][field] = serde_json::json!(x);
                        });
                        (x, total(&plan, &m, e))
                    })
                    .collect();
                println!("{name} ({e:?}) {axis}: {totals:?}");
                for (i, &(lo, t_lo)) in totals.iter().enumerate() {
                    for &(hi, t_hi) in &totals[i + 1..] {
                        if t_hi > t_lo * (1.0 + 5e-5) {
                            failures.push(format!(
                                "{name} ({e:?}) {axis} {hi:.3} gives {t_hi:.3} s, above {t_lo:.3} s at {lo:.3}"
                            ));
                        }
                    }
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} cases:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
