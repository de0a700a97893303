//! The per-spot timeline on generated plans (spot positions on every layer), under both beam
//! models, constant and free motion: every spot delivery listed once, inside its layer's window
//! and beam-on, in order without overlap, ending where the layer's beam-on ends.

use crate::util::machine;
use arcsim_plan::generate::{generate, PlanKind};
use arcsim_plan::resolve;
use arcsim_sequencer::{simulate, spot_timeline, Motion, Options, Schedule};

#[test]
fn spots_lie_in_their_layers_on_generated_plans() {
    for kind in PlanKind::ALL {
        let plan = generate(kind, 3);
        for m in [
            machine("machine-atom.json"),
            machine("machine-opentps-pbs.json"),
        ] {
            let motions: &[Motion] = match kind {
                PlanKind::Prostate | PlanKind::Lung => &[Motion::Constant, Motion::Free],
                _ => &[Motion::Constant],
            };
            for &motion in motions {
                let what = format!("{kind} on {} ({})", m.name, motion.name());
                let opts = Options {
                    motion,
                    ..Options::new(Schedule::Optimal)
                };
                let d = simulate(&plan, &m, &opts).unwrap_or_else(|e| panic!("{what}: {e}"));
                let spots = spot_timeline(&plan, &m, &d).expect("spots");
                let expected: usize = plan
                    .arcs
                    .iter()
                    .flat_map(|a| &a.control_points)
                    .flat_map(|cp| &cp.layers)
                    .map(|l| l.spots.as_ref().map_or(0, |s| s.count as usize))
                    .sum();
                assert_eq!(spots.len(), expected, "{what}");
                let arcs = resolve(&plan, &m).expect("resolve");
                let resolved: Vec<_> = arcs.iter().flat_map(|a| &a.layers).collect();
                let mut last_end = f64::NEG_INFINITY;
                let mut first_of_layer = vec![f64::NAN; d.layers.len()];
                let mut end_of_layer = vec![f64::NAN; d.layers.len()];
                for s in &spots {
                    let row = &d.layers[s.layer_index];
                    assert!(s.t_start_s >= last_end - 1e-12, "{what}: overlap at {s:?}");
                    assert!(s.t_end_s >= s.t_start_s);
                    last_end = s.t_end_s;
                    assert!(
                        s.t_start_s >= row.t_start_s - 1e-9 && s.t_end_s <= row.t_end_s + 1e-9,
                        "{what}: {s:?} outside {row:?}"
                    );
                    let half = row.window_deg / 2.0 + 1e-9;
                    for a in [s.angle_start_deg, s.angle_end_deg] {
                        assert!((a - row.angle_deg).abs() <= half, "{what}: {s:?} at {a}");
                    }
                    if first_of_layer[s.layer_index].is_nan() {
                        first_of_layer[s.layer_index] = s.t_start_s;
                    }
                    end_of_layer[s.layer_index] = s.t_end_s;
                }
                for (k, row) in d.layers.iter().enumerate() {
                    let l = resolved[k];
                    // The first spot starts at beam-on (no layer overhead in these machines), the
                    // last ends at beam-off.
                    assert!(
                        (first_of_layer[k] - row.t_start_s).abs() <= 1e-9,
                        "{what}: {k}"
                    );
                    assert!(
                        (end_of_layer[k] - row.t_start_s - l.irradiation_s).abs() <= 1e-9,
                        "{what}: layer {k}"
                    );
                }
                let b = d.breakdown;
                assert!((b.spot_irradiation_s + b.scanning_s - b.beam_on_s).abs() <= 1e-9);
                let spot_sum: f64 = spots.iter().map(|s| s.t_end_s - s.t_start_s).sum();
                assert!((spot_sum - b.spot_irradiation_s).abs() <= 1e-9, "{what}");
            }
        }
    }
}
