//! Small random arc plans and the bundled machines.

use arcsim_plan::{parse_machine, parse_plan, ArcPlan, Machine};
use arcsim_test_support::Rng;

/// A machine file of `scenarios/`.
pub fn machine(name: &str) -> Machine {
    let path = format!("{}/../../scenarios/{name}", env!("CARGO_MANIFEST_DIR"));
    parse_machine(&std::fs::read_to_string(&path).expect("machine"), &path).expect("machine")
}

/// A bundled plan of `plans/`.
pub fn bundled(name: &str) -> ArcPlan {
    let path = format!("{}/../../plans/{name}", env!("CARGO_MANIFEST_DIR"));
    parse_plan(&std::fs::read_to_string(&path).expect("plan"), &path).expect("plan")
}

/// One arc (or two) of `cps` control points 2° apart with `layers(i)` layers each, random
/// energies in 70–200 MeV (a fifth of them within 1 MeV of another layer of the control point)
/// and random MU; windows of 2°.
pub fn small_plan(
    rng: &mut Rng,
    arcs: usize,
    cps: usize,
    layers: &dyn Fn(&mut Rng) -> usize,
) -> ArcPlan {
    let mut arcs_json = Vec::new();
    for a in 0..arcs {
        let mut points = Vec::new();
        for c in 0..cps {
            let k = layers(rng);
            let mut ls = Vec::new();
            let mut last = rng.range(70.0, 200.0);
            for _ in 0..k {
                let e = if rng.unit() < 0.2 {
                    last + rng.range(-0.9, 0.9)
                } else {
                    rng.range(70.0, 200.0)
                };
                last = e;
                let mu = rng.range(2.0, 30.0);
                ls.push(serde_json::json!({
                    "energy_mev": (e * 10.0).round() / 10.0,
                    "spots": {"count": 5 + rng.below(20), "total_mu": (mu * 1000.0).round() / 1000.0}
                }));
            }
            let base = 40.0 + 100.0 * a as f64;
            points.push(serde_json::json!({
                "angle_deg": base + 2.0 * c as f64, "window_deg": 2.0, "layers": ls
            }));
        }
        arcs_json.push(serde_json::json!({"direction": "CW", "control_points": points}));
    }
    let v = serde_json::json!({"format": "arcsim-plan/1", "name": "small", "arcs": arcs_json});
    parse_plan(&v.to_string(), "small plan").expect("small plan")
}
