//! ELST tables: `by_energy` (an upward and a downward table by the energy switched to) and
//! `by_energy_pair` (a grid of times by the energies switched from and to), worked out by hand,
//! against an interpolation written here on random pairs, through a plan's resolution, and their
//! machine-file errors.

use arcsim_plan::{parse_machine, parse_plan, resolve, ElstModel, Machine, PlanError};
use arcsim_test_support::Rng;
use serde_json::{json, Value};

fn machine_json(elst: Value) -> Value {
    json!({
        "format": "arcsim-machine/1",
        "name": "tables",
        "gantry": { "max_speed_deg_per_s": 5.0, "max_accel_deg_per_s2": 0.5, "max_jerk_deg_per_s3": 0.5 },
        "beam": { "s_per_mu": 0.005, "spot_switch_time_s": 0.002 },
        "elst": elst,
        "default_window_deg": 1.0
    })
}

fn by_energy() -> Machine {
    let v = machine_json(json!({
        "kind": "by_energy",
        "up_s_by_energy": [[100, 2.0], [200, 4.0]],
        "down_s_by_energy": [[100, 0.5], [150, 0.7], [200, 1.0]],
        "same_s": 0.1
    }));
    parse_machine(&v.to_string(), "m.json").expect("by_energy machine")
}

/// Grid energies and times (from row, to column) of the pair table used below.
const GRID: [f64; 3] = [100.0, 150.0, 200.0];
const TABLE: [[f64; 3]; 3] = [[0.2, 3.0, 5.0], [0.8, 0.2, 3.5], [1.0, 0.9, 0.2]];

fn by_pair() -> Machine {
    let v = machine_json(json!({
        "kind": "by_energy_pair",
        "energies_mev": GRID,
        "switch_s": TABLE,
        "same_s": 0.05
    }));
    parse_machine(&v.to_string(), "m.json").expect("by_energy_pair machine")
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * (1.0 + b.abs())
}

/// Up 120 → 150 MeV: the up table at 150 (halfway from 2 to 4 s) is 3 s; down 150 → 120: the
/// down table at 120 (0.5 + 0.4 · 0.2) is 0.58 s; the same energy takes `same_s`; outside the
/// table the end rows hold.
#[test]
fn by_energy_by_hand() {
    let e = by_energy().elst;
    assert_eq!(e.kind(), "by_energy");
    assert!(close(e.switch_time_s(120.0, 150.0), 3.0));
    assert!(close(e.switch_time_s(150.0, 120.0), 0.58));
    assert!(close(e.switch_time_s(175.0, 175.0), 0.1));
    assert!(close(e.switch_time_s(70.0, 90.0), 2.0));
    assert!(close(e.switch_time_s(210.0, 250.0), 4.0));
    assert!(close(e.switch_time_s(250.0, 60.0), 0.5));
}

/// On the grid the table's own entries; (125, 175) MeV is the mean of the four around it:
/// (3.0 + 5.0 + 0.2 + 3.5) / 4 = 2.925 s; (50, 300) clamps to (100, 200): 5 s.
#[test]
fn by_energy_pair_by_hand() {
    let e = by_pair().elst;
    for (i, from) in GRID.iter().enumerate() {
        for (j, to) in GRID.iter().enumerate() {
            let want = if i == j { 0.05 } else { TABLE[i][j] };
            assert!(close(e.switch_time_s(*from, *to), want), "{from} -> {to}");
        }
    }
    assert!(close(e.switch_time_s(125.0, 175.0), 2.925));
    assert!(close(e.switch_time_s(50.0, 300.0), 5.0));
    assert!(close(e.switch_time_s(300.0, 50.0), 1.0));
}

/// The pair table between grid points: interpolated along "to" within the two rows around
/// "from", then along "from", found by a scan of the grid (not the library's search).
fn bilinear(from: f64, to: f64) -> f64 {
    let clamp = |x: f64| x.clamp(GRID[0], GRID[GRID.len() - 1]);
    let (from, to) = (clamp(from), clamp(to));
    let cell = |x: f64| {
        let mut i = 0;
        while i + 2 < GRID.len() && x > GRID[i + 1] {
            i += 1;
        }
        (i, (x - GRID[i]) / (GRID[i + 1] - GRID[i]))
    };
    let (i, u) = cell(from);
    let (j, w) = cell(to);
    let along_to = |row: &[f64; 3]| row[j] + w * (row[j + 1] - row[j]);
    let (lo, hi) = (along_to(&TABLE[i]), along_to(&TABLE[i + 1]));
    lo + u * (hi - lo)
}

#[test]
fn by_energy_pair_matches_an_independent_bilinear_interpolation() {
    let e = by_pair().elst;
    let mut rng = Rng::new(29);
    for _ in 0..20_000 {
        let (from, to) = (rng.range(60.0, 240.0), rng.range(60.0, 240.0));
        let want = bilinear(from, to);
        let got = e.switch_time_s(from, to);
        assert!(
            (got - want).abs() <= 1e-12,
            "{from} -> {to}: {got} vs {want}"
        );
    }
}

/// A plan's layers get the table's switching times when resolved, and a machine written back
/// reads the same.
#[test]
fn tables_reach_the_resolved_layers_and_round_trip() {
    let plan = parse_plan(
        &json!({
            "format": "arcsim-plan/1",
            "name": "three",
            "arcs": [{ "direction": "CW", "control_points": [
                { "angle_deg": 10.0, "layers": [{ "energy_mev": 125.0, "irradiation_time_s": 0.1 }] },
                { "angle_deg": 12.0, "layers": [{ "energy_mev": 175.0, "irradiation_time_s": 0.1 }] },
                { "angle_deg": 14.0, "layers": [{ "energy_mev": 175.0, "irradiation_time_s": 0.1 }] },
                { "angle_deg": 16.0, "layers": [{ "energy_mev": 150.0, "irradiation_time_s": 0.1 }] }
            ] }]
        })
        .to_string(),
        "p.json",
    )
    .expect("plan");
    for m in [by_energy(), by_pair()] {
        let arcs = resolve(&plan, &m).expect("resolve");
        let got: Vec<f64> = arcs[0].layers.iter().map(|l| l.switch_in_s).collect();
        let want = [
            0.0,
            m.elst.switch_time_s(125.0, 175.0),
            m.elst.switch_time_s(175.0, 175.0),
            m.elst.switch_time_s(175.0, 150.0),
        ];
        assert_eq!(got, want, "{}", m.elst.kind());
        let again =
            parse_machine(&serde_json::to_string(&m).expect("json"), "again").expect("again");
        assert_eq!(again, m);
    }
    // by_energy: up to 175 is 3.5 s, down to 150 is 0.7 s; the pair grid: (125, 175) 2.925 s,
    // (175, 150) halfway between 0.2 and 0.9 s.
    let arcs = resolve(&plan, &by_energy()).expect("resolve");
    assert!(close(arcs[0].layers[1].switch_in_s, 3.5) && close(arcs[0].layers[3].switch_in_s, 0.7));
    let arcs = resolve(&plan, &by_pair()).expect("resolve");
    assert!(
        close(arcs[0].layers[1].switch_in_s, 2.925) && close(arcs[0].layers[3].switch_in_s, 0.55)
    );
}

fn issues(elst: Value) -> String {
    match parse_machine(&machine_json(elst).to_string(), "m.json") {
        Err(e @ PlanError::Invalid { .. }) => e.to_string(),
        other => panic!("expected machine issues, got {other:?}"),
    }
}

#[test]
fn table_errors_name_the_entry() {
    let e = issues(json!({
        "kind": "by_energy",
        "up_s_by_energy": [[100, 2.0], [90, 4.0]],
        "down_s_by_energy": [],
        "same_s": -1
    }));
    assert!(
        e.contains("elst.up_s_by_energy[1][0]") && e.contains("increasing"),
        "{e}"
    );
    assert!(
        e.contains("elst.down_s_by_energy") && e.contains("0 rows"),
        "{e}"
    );
    assert!(e.contains("elst.same_s"), "{e}");
    let e = issues(json!({
        "kind": "by_energy",
        "up_s_by_energy": [[100, 2.0]],
        "down_s_by_energy": [[100, -0.5]],
        "same_s": 0
    }));
    assert!(e.contains("elst.down_s_by_energy[0][1]"), "{e}");
    let e = issues(json!({
        "kind": "by_energy_pair",
        "energies_mev": [100, 150],
        "switch_s": [[0.1, 2.0], [0.5]],
        "same_s": 0
    }));
    assert!(
        e.contains("elst.switch_s[1]") && e.contains("1 columns"),
        "{e}"
    );
    let e = issues(json!({
        "kind": "by_energy_pair",
        "energies_mev": [100, 100],
        "switch_s": [[0.1, 2.0]],
        "same_s": 0
    }));
    assert!(
        e.contains("elst.energies_mev[1]") && e.contains("increasing"),
        "{e}"
    );
    assert!(e.contains("elst.switch_s") && e.contains("1 rows"), "{e}");
    let e = issues(json!({
        "kind": "by_energy_pair",
        "energies_mev": [100, 150],
        "switch_s": [[0.1, 2.0], [0.5, 1e6]],
        "same_s": 0
    }));
    assert!(e.contains("elst.switch_s[1][1]"), "{e}");
    let e = match parse_machine(
        &machine_json(json!({ "kind": "by_energy", "up_s_by_energy": [[100, 1]], "same_s": 0 }))
            .to_string(),
        "m.json",
    ) {
        Err(e) => e.to_string(),
        Ok(m) => panic!("expected an error, got {m:?}"),
    };
    assert!(e.contains("down_s_by_energy"), "{e}");
    assert!(matches!(by_pair().elst, ElstModel::ByEnergyPair { .. }));
}
