//! The switching breakdown against a recount from the plan file's energies and the delivery's
//! rows, on generated plans with small upward steps planted at random.

use arcsim_plan::{generate_shaped, resolve, PlanKind, Shape};
use arcsim_sequencer::{simulate, Options, SwitchKind, Switching, SMALL_UPWARD_STEP_MEV};
use arcsim_test_support::Rng;

use crate::util::machine;

#[test]
fn switching_by_class_and_step_agrees_with_a_recount() {
    let atom = machine("machine-atom.json");
    let mut rng = Rng::new(48);
    let mut planted_total = 0;
    for kind in PlanKind::ALL {
        for seed in 0..3 {
            let shape = Shape {
                layers_per_cp: Some((1, 3)),
                ..Shape::default()
            };
            let mut plan = generate_shaped(kind, seed, &shape).expect("plan");
            // Plant small upward steps: a layer a fraction of an MeV above the one before it.
            let mut last: Option<f64> = None;
            for arc in &mut plan.arcs {
                last = None;
                for cp in &mut arc.control_points {
                    for layer in &mut cp.layers {
                        if let Some(e) = last {
                            if rng.unit() < 0.05 {
                                layer.energy_mev = e + rng.range(0.05, 0.95);
                                planted_total += 1;
                            }
                        }
                        last = Some(layer.energy_mev);
                    }
                }
            }
            let _ = last;
            let d = simulate(&plan, &atom, &Options::default()).expect("delivery");
            let arcs = resolve(&plan, &atom).expect("resolved");
            let s = Switching::of(&arcs, Some(&d), &atom.elst, SMALL_UPWARD_STEP_MEV);

            // The recount: energies in plan order, arc by arc, straight from the plan.
            let energies: Vec<(usize, f64)> = plan
                .arcs
                .iter()
                .enumerate()
                .flat_map(|(a, arc)| {
                    arc.control_points
                        .iter()
                        .flat_map(move |cp| cp.layers.iter().map(move |l| (a, l.energy_mev)))
                })
                .collect();
            let (mut up, mut down, mut same, mut change, mut small) = (0, 0, 0, 0, 0);
            let mut small_cost = 0.0;
            for w in energies.windows(2) {
                let ((a0, e0), (a1, e1)) = (w[0], w[1]);
                if a0 != a1 {
                    change += 1;
                } else if e1 > e0 + 1e-6 {
                    up += 1;
                    if e1 - e0 < 1.0 {
                        small += 1;
                        small_cost += 5.0 - 0.0; // ATOM: up 5 s, same 0 s, down 0.5 s
                    }
                } else if e1 < e0 - 1e-6 {
                    down += 1;
                } else {
                    same += 1;
                }
            }
            let count = |k| s.class(k).map_or(0, |g| g.count);
            let what = format!("{} seed {seed}", kind.name());
            assert_eq!(count(SwitchKind::Up), up, "{what}");
            assert_eq!(count(SwitchKind::Down), down, "{what}");
            assert_eq!(count(SwitchKind::Same), same, "{what}");
            assert_eq!(count(SwitchKind::ArcChange), change, "{what}");
            assert_eq!(s.small_upward.len(), small, "{what}");
            assert!((s.small_upward_cost_s - small_cost).abs() < 1e-9, "{what}");

            // The groups partition the delivery's transitions: counts, ELSTs, times, lost.
            let sum = |gs: &[arcsim_sequencer::SwitchGroup],
                       f: &dyn Fn(&arcsim_sequencer::SwitchGroup) -> f64| {
                gs.iter().map(f).sum::<f64>()
            };
            for groups in [&s.by_class, &s.by_step] {
                let n: usize = groups.iter().map(|g| g.count).sum();
                assert_eq!(n, d.transitions.len(), "{what}");
                let time = sum(groups, &|g| g.time_s.expect("simulated"));
                let all: f64 = d.transitions.iter().map(|t| t.duration_s).sum();
                assert!(
                    (time - all).abs() < 1e-9 * all.max(1.0),
                    "{what}: {time} vs {all}"
                );
                let elst = sum(groups, &|g| g.elst_s);
                let want = d.breakdown.energy_switching_s;
                assert!(
                    (elst - want).abs() < 1e-9 * want.max(1.0),
                    "{what}: {elst} vs {want}"
                );
                let lost = sum(groups, &|g| g.lost_s.expect("simulated"));
                let want: f64 = d.transitions.iter().map(|t| t.lost_s).sum();
                assert!((lost - want).abs() < 1e-9 * want.max(1.0), "{what}");
            }
            // Each step band holds only steps inside it.
            for g in &s.by_step {
                assert!(g.count > 0 && g.step_to_mev.is_none_or(|hi| hi > g.step_from_mev));
            }
            for st in &s.small_upward {
                assert!(
                    st.step_mev > 0.0 && st.step_mev < 1.0 && st.cost_s == 5.0,
                    "{st:?}"
                );
            }
            // Without a delivery: the same counts and ELSTs, no times.
            let plain = Switching::of(&arcs, None, &atom.elst, SMALL_UPWARD_STEP_MEV);
            assert_eq!(plain.small_upward, s.small_upward);
            for (a, b) in plain.by_step.iter().zip(&s.by_step) {
                assert_eq!((a.count, a.elst_s, a.time_s), (b.count, b.elst_s, None));
            }
        }
    }
    assert!(
        planted_total > 20,
        "only {planted_total} small steps planted"
    );
}
