//! The files shipped in plans/ and scenarios/: generator and files cannot drift, every plan resolves
//! on every machine, and each example plan has the shape its README promises.

use std::path::PathBuf;

use arcsim_plan::{
    generate, load_machine, load_plan, resolve, to_json, ArcPlan, Machine, PlanKind,
    RotationDirection,
};

fn repo(rel: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../..")).join(rel)
}

fn json_files(dir: &str, prefix: &str) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(repo(dir))
        .expect("directory exists")
        .map(|e| e.expect("dir entry").path())
        .filter(|p| {
            let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
            name.starts_with(prefix) && name.ends_with(".json")
        })
        .collect();
    files.sort();
    files
}

fn machines() -> Vec<Machine> {
    json_files("scenarios", "machine-")
        .iter()
        .map(|p| load_machine(p).unwrap_or_else(|e| panic!("{e}")))
        .collect()
}

fn atom() -> Machine {
    load_machine(repo("scenarios/machine-atom.json")).expect("ATOM machine")
}

fn committed(kind: PlanKind) -> ArcPlan {
    load_plan(repo(&format!("plans/{}.json", kind.name()))).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn committed_plans_equal_the_generator_output() {
    for kind in PlanKind::ALL {
        let path = repo(&format!("plans/{}.json", kind.name()));
        let on_disk = std::fs::read_to_string(&path).expect("committed plan");
        let fresh = to_json(&generate(kind, 1));
        assert!(
            on_disk == fresh,
            "{} differs from `arcsim generate-plan --kind {kind} --seed 1`; regenerate it (see plans/README.md)",
            path.display()
        );
        // The compact writer must round-trip to the same plan.
        assert_eq!(
            arcsim_plan::parse_plan(&fresh, "fresh").unwrap(),
            generate(kind, 1)
        );
    }
}

#[test]
fn generator_is_seeded() {
    for kind in PlanKind::ALL {
        assert_eq!(generate(kind, 7), generate(kind, 7));
        assert_ne!(
            generate(kind, 7),
            generate(kind, 8),
            "{kind}: seed has no effect"
        );
        assert_eq!(kind.name().parse::<PlanKind>(), Ok(kind));
    }
    assert!("liver"
        .parse::<PlanKind>()
        .unwrap_err()
        .contains("expected one of prostate, head-neck, two-arc, lung"));
}

#[test]
fn every_bundled_plan_resolves_on_every_bundled_machine() {
    let plans = json_files("plans", "");
    let machines = machines();
    assert_eq!(plans.len(), 4, "{plans:?}");
    assert_eq!(
        machines.iter().map(|m| m.name.as_str()).collect::<Vec<_>>(),
        vec![
            "atom",
            "fast",
            "opentps-pbs",
            "opentps",
            "probeat-v5-like-mee",
            "probeat-v5-like",
            "proteusone-like"
        ]
    );
    for p in &plans {
        let plan = load_plan(p).unwrap_or_else(|e| panic!("{e}"));
        for m in &machines {
            let arcs =
                resolve(&plan, m).unwrap_or_else(|e| panic!("{} on {}: {e}", p.display(), m.name));
            for l in arcs.iter().flat_map(|a| &a.layers) {
                assert!(l.irradiation_s.is_finite() && l.irradiation_s > 0.0);
                assert!(l.spot_irradiation_s > 0.0 && l.scanning_s > 0.0);
                let parts =
                    l.spot_irradiation_s + l.scanning_s + l.burst_switching_s + l.spill_waiting_s;
                assert!((parts - l.irradiation_s).abs() <= 1e-12 * l.irradiation_s);
                assert!(l.switch_in_s.is_finite() && l.switch_in_s >= 0.0);
                assert!(l.window_deg > 0.0 && l.angle_deg.is_finite());
            }
        }
    }
}

#[test]
fn generated_plans_also_resolve_for_other_seeds() {
    for kind in PlanKind::ALL {
        for seed in [0, 2, 3, 12345, u64::MAX] {
            let plan = generate(kind, seed);
            assert!(
                arcsim_plan::validate_plan(&plan, "gen").is_empty(),
                "{kind} seed {seed}"
            );
            for m in machines() {
                resolve(&plan, &m)
                    .unwrap_or_else(|e| panic!("{kind} seed {seed} on {}: {e}", m.name));
            }
        }
    }
}

fn times(plan: &ArcPlan) -> Vec<f64> {
    resolve(plan, &atom())
        .unwrap()
        .iter()
        .flat_map(|a| a.layers.iter().map(|l| l.irradiation_s))
        .collect()
}

fn energies(plan: &ArcPlan) -> Vec<f64> {
    plan.arcs
        .iter()
        .flat_map(|a| &a.control_points)
        .flat_map(|c| &c.layers)
        .map(|l| l.energy_mev)
        .collect()
}

fn upward(plan: &ArcPlan) -> usize {
    energies(plan).windows(2).filter(|w| w[1] > w[0]).count()
}

fn angles(plan: &ArcPlan, arc: usize) -> Vec<f64> {
    plan.arcs[arc]
        .control_points
        .iter()
        .map(|c| c.angle_deg)
        .collect()
}

fn in_range(xs: &[f64], lo: f64, hi: f64) -> bool {
    xs.iter().all(|x| (lo..=hi).contains(x))
}

#[test]
fn prostate_shape() {
    let p = committed(PlanKind::Prostate);
    assert_eq!(p.arcs.len(), 1);
    assert_eq!(p.arcs[0].direction, RotationDirection::Cw);
    let a = angles(&p, 0);
    assert_eq!(a.len(), 180);
    assert!(a.windows(2).all(|w| w[1] - w[0] == 2.0));
    assert!(p.arcs[0].control_points.iter().all(|c| c.layers.len() == 1));
    assert!(in_range(&energies(&p), 100.0, 180.0));
    assert_eq!(upward(&p), 10);
    assert!(in_range(&times(&p), 0.05, 0.3), "{:?}", times(&p));
    assert!(p.arcs[0]
        .control_points
        .iter()
        .all(|c| c.layers[0].spots.as_ref().is_some_and(|s| s.mu.is_some())));
}

#[test]
fn head_neck_shape() {
    let p = committed(PlanKind::HeadNeck);
    let a = angles(&p, 0);
    assert_eq!(a.len(), 360);
    assert!(a.windows(2).all(|w| w[1] - w[0] == 1.0));
    let counts: Vec<usize> = p.arcs[0]
        .control_points
        .iter()
        .map(|c| c.layers.len())
        .collect();
    assert!(counts.iter().all(|n| (1..=3).contains(n)));
    assert!(counts.contains(&1) && counts.contains(&3));
    assert!(in_range(&energies(&p), 70.0, 160.0));
    assert!(in_range(&times(&p), 0.05, 0.35));
}

#[test]
fn two_arc_shape() {
    let p = committed(PlanKind::TwoArc);
    assert_eq!(p.arcs.len(), 2);
    assert_eq!(
        (p.arcs[0].direction, p.arcs[1].direction),
        (RotationDirection::Cw, RotationDirection::Cc)
    );
    assert!(angles(&p, 0).windows(2).all(|w| w[1] > w[0]));
    assert!(angles(&p, 1).windows(2).all(|w| w[1] < w[0]));
    assert!(in_range(&times(&p), 0.05, 0.3));
}

#[test]
fn lung_shape() {
    let p = committed(PlanKind::Lung);
    let a = angles(&p, 0);
    assert_eq!(a.last().unwrap() - a[0], 120.0);
    assert!(p.arcs[0]
        .control_points
        .iter()
        .flat_map(|c| &c.layers)
        .all(|l| l.spots.as_ref().is_some_and(|s| s.total_mu.is_some())));
    assert!(in_range(&times(&p), 0.05, 0.3));
}
