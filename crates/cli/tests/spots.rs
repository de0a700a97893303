//! Spot-level delivery end to end: DICOM plans with spot maps simulated on the `scanning` beam
//! model (`scenarios/machine-opentps-pbs.json`), `simulate --spots` and the JSON checked against
//! the layer rows, and static beams against the plain sum computed here independently.

use std::path::Path;

use arcsim_test_support::dicom::{self, BeamSpec, Layer, PlanSpec};
use arcsim_test_support::{temp_dir, temp_file, Rng};
use serde_json::Value;

use crate::util::{arcsim, path_str, repo, text};

const MACHINE: &str = "scenarios/machine-opentps-pbs.json";

/// The OpenTPS numbers of the machine file, read back here with an interpolation of our own.
struct Opentps {
    table: Vec<(f64, f64)>,
    speed_mm_per_s: f64,
    min_spot_s: f64,
    up_s: f64,
    down_s: f64,
}

impl Opentps {
    fn read() -> Opentps {
        let m = read_json(&repo().join(MACHINE));
        let b = &m["beam"];
        let f = |v: &Value| v.as_f64().expect("number");
        Opentps {
            table: b["s_per_mu_by_energy"]
                .as_array()
                .expect("table")
                .iter()
                .map(|r| (f(&r[0]), f(&r[1])))
                .collect(),
            speed_mm_per_s: f(&b["scan_speed_mm_per_s"]),
            min_spot_s: f(&b["min_spot_time_s"]),
            up_s: f(&m["elst"]["up_s"]),
            down_s: f(&m["elst"]["down_s"]),
        }
    }

    fn s_per_mu(&self, e: f64) -> f64 {
        let t = &self.table;
        if e <= t[0].0 {
            return t[0].1;
        }
        for w in t.windows(2) {
            if e <= w[1].0 {
                let f = (e - w[0].0) / (w[1].0 - w[0].0);
                return w[0].1 * (1.0 - f) + w[1].1 * f;
            }
        }
        t[t.len() - 1].1
    }

    /// Beam-on time of one layer: spots one after another, the scanning moves between them (the
    /// straight-line distance at one speed, as OpenTPS has it).
    fn layer_s(&self, energy: f64, mu: &[f64], pos: &[[f64; 2]]) -> f64 {
        let spots: f64 = mu
            .iter()
            .map(|m| (m * self.s_per_mu(energy)).max(self.min_spot_s))
            .sum();
        let moves: f64 = pos
            .windows(2)
            .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]) / self.speed_mm_per_s)
            .sum();
        spots + moves
    }
}

fn simulate(plan: &Path, dir: &Path, extra: &[&str]) -> (Value, Vec<Vec<f64>>) {
    simulate_on(MACHINE, plan, dir, extra)
}

/// `simulate --spots` of `plan` on `machine`: the JSON result and the spot rows (the header
/// checked).
fn simulate_on(machine: &str, plan: &Path, dir: &Path, extra: &[&str]) -> (Value, Vec<Vec<f64>>) {
    let json = dir.join("result.json");
    let csv = dir.join("spots.csv");
    let mut args = vec![
        "simulate",
        path_str(plan),
        "--machine",
        machine,
        "--json",
        path_str(&json),
        "--spots",
        path_str(&csv),
    ];
    args.extend_from_slice(extra);
    let out = arcsim(&args);
    let (so, se) = text(&out);
    assert!(out.status.success(), "{so}\n{se}");
    let result = read_json(&json);
    let table = std::fs::read_to_string(&csv).expect("spots csv");
    let mut lines = table.lines();
    assert_eq!(
        lines.next(),
        Some("layer_index,arc,control_point,layer,spot,painting,x_mm,y_mm,mu,t_start_s,t_end_s,angle_start_deg,angle_end_deg,burst,spill")
    );
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|c| match c {
                    // No burst or spill index on machines without them.
                    "" => f64::NAN,
                    c => c
                        .parse::<f64>()
                        .expect("a number or nothing in every column"),
                })
                .collect()
        })
        .collect();
    (result, rows)
}

fn f(v: &Value) -> f64 {
    v.as_f64().expect("number")
}

/// The acceptance checks of a spot timeline against the delivery's layer rows: every spot once,
/// inside its layer's window and beam-on, no overlap, and spot and scanning times adding up to
/// each layer's beam-on time.
fn check_spots(result: &Value, rows: &[Vec<f64>], spots_per_layer: &[usize]) {
    let layers = result["layers"].as_array().expect("layers");
    assert_eq!(layers.len(), spots_per_layer.len());
    assert_eq!(rows.len(), spots_per_layer.iter().sum::<usize>());
    let json_spots = result["spots"].as_array().expect("spots in the JSON");
    assert_eq!(json_spots.len(), rows.len());
    let mut seen = std::collections::BTreeSet::new();
    let mut per_layer = vec![0usize; layers.len()];
    for (k, r) in rows.iter().enumerate() {
        let li = r[0] as usize;
        assert!(
            seen.insert((li, r[4] as usize, r[5] as usize)),
            "spot listed twice: {r:?}"
        );
        per_layer[li] += 1;
        let l = &layers[li];
        let (centre, half) = (f(&l["angle_deg"]), f(&l["window_deg"]) / 2.0);
        for a in [r[11], r[12]] {
            assert!(
                (a - centre).abs() <= half + 1e-9,
                "spot {k} at {a} deg outside the window {centre} ± {half}"
            );
        }
        let (t0, t1) = (f(&l["t_start_s"]), f(&l["t_end_s"]));
        assert!(
            r[9] >= t0 - 1e-9 && r[10] <= t1 + 1e-9 && r[10] >= r[9],
            "{r:?}"
        );
        if k > 0 {
            assert!(
                r[9] >= rows[k - 1][10] - 1e-12,
                "spots {} and {k} overlap",
                k - 1
            );
        }
        assert_eq!(f(&json_spots[k]["t_start_s"]), r[9]);
    }
    assert_eq!(per_layer, spots_per_layer);
    // Last spot end = the layer's beam-on (no layer overhead in this machine).
    for (li, l) in layers.iter().enumerate() {
        let end = rows
            .iter()
            .filter(|r| r[0] as usize == li)
            .map(|r| r[10])
            .fold(f64::NEG_INFINITY, f64::max);
        let on = f(&l["t_start_s"]) + f(&l["irradiation_s"]);
        assert!((end - on).abs() <= 1e-9, "layer {li}: {end} vs {on}");
    }
    let b = &result["breakdown"];
    let spot_sum: f64 = rows.iter().map(|r| r[10] - r[9]).sum();
    assert!((spot_sum - f(&b["spot_irradiation_s"])).abs() <= 1e-9);
    assert!(
        (f(&b["spot_irradiation_s"]) + f(&b["scanning_s"]) - f(&b["beam_on_s"])).abs() <= 1e-9,
        "{b}"
    );
    assert!(f(&b["scanning_s"]) > 0.0);
}

#[test]
fn dynamic_arc_with_spot_maps_lists_every_spot_inside_its_window() {
    let dir = temp_dir().join("spots-arc");
    std::fs::create_dir_all(&dir).expect("dir");
    let n = 40;
    let positions: Vec<Vec<[f32; 2]>> = (0..n).map(dicom::positions_of).collect();
    let mut beam = BeamSpec::from_layers(
        1,
        "DYNAMIC",
        "CW",
        600.0,
        &dicom::dynamic_arc_layers(181.0, 2.0, n),
    )
    .with_layer_positions(&positions);
    // Layer 3 painted twice: its spots are listed twice, once per painting. (Every control point
    // says its count: the reader carries a value over to control points that leave it out.)
    for (k, cp) in beam.cps.iter_mut().enumerate() {
        cp.paintings = Some(if k / 2 == 3 { 2 } else { 1 });
    }
    let plan = temp_file(
        "spots-arc.dcm",
        &PlanSpec::ion("SPOTARC", vec![beam]).to_bytes(),
    );
    let spots: Vec<usize> = (0..n)
        .map(|i| dicom::weights_of(i).len() * if i == 3 { 2 } else { 1 })
        .collect();
    for motion in ["free", "constant"] {
        let (result, rows) = simulate(&plan, &dir, &["--motion", motion]);
        check_spots(&result, &rows, &spots);
        // The plan's positions, in the file's order.
        let first = &dicom::positions_of(0);
        assert!(
            (rows[1][6] - f64::from(first[1][0])).abs() < 1e-5,
            "{:?}",
            rows[1]
        );
        assert!(rows.iter().any(|r| r[5] == 1.0), "a second painting");
    }
}

/// One layer as the test computes it: energy (MeV), spot MU, spot positions (mm).
type LayerData = (f64, Vec<f64>, Vec<[f64; 2]>);

/// Energies, spot MU and positions of random static-beam layers (seeded), and the DICOM beam.
fn random_static_beam(seed: u64) -> (BeamSpec, Vec<LayerData>) {
    let mut rng = Rng::new(seed);
    let mut next = move || rng.unit();
    let n_layers = 1 + (next() * 5.0) as usize;
    let angle = (next() * 360.0).floor();
    let mut layers = Vec::new();
    let mut maps = Vec::new();
    for _ in 0..n_layers {
        let n = 1 + (next() * 30.0) as usize;
        let energy = (60.0 + next() * 167.0).round();
        let weights: Vec<f32> = (0..n).map(|_| (0.05 + next() * 2.0) as f32).collect();
        let pos: Vec<[f32; 2]> = (0..n)
            .map(|_| {
                [
                    ((next() - 0.5) * 200.0) as f32,
                    ((next() - 0.5) * 200.0) as f32,
                ]
            })
            .collect();
        layers.push(Layer {
            angle,
            energy,
            weights,
        });
        maps.push(pos);
    }
    let meterset = 50.0 + next() * 200.0;
    let beam =
        BeamSpec::from_layers(1, "STATIC", "NONE", meterset, &layers).with_layer_positions(&maps);
    let total_w: f64 = layers
        .iter()
        .flat_map(|l| &l.weights)
        .map(|&w| f64::from(w))
        .sum();
    let expected = layers
        .iter()
        .zip(&maps)
        .map(|(l, p)| {
            (
                l.energy,
                l.weights
                    .iter()
                    .map(|&w| f64::from(w) * meterset / total_w)
                    .collect(),
                p.iter()
                    .map(|q| [f64::from(q[0]), f64::from(q[1])])
                    .collect(),
            )
        })
        .collect();
    (beam, expected)
}

/// One static beam: the gantry stands at the beam's angle and the delivery time is the plain
/// OpenTPS-style sum of energy switches and layer times, computed here from the beam's data.
#[test]
fn a_static_beam_takes_the_plain_sum_of_its_layers() {
    let o = Opentps::read();
    let dir = temp_dir().join("spots-static");
    std::fs::create_dir_all(&dir).expect("dir");
    for seed in 1..=12u64 {
        let (beam, layers) = random_static_beam(seed);
        let plan = temp_file(
            &format!("static-{seed}.dcm"),
            &PlanSpec::ion("STATIC", vec![beam]).to_bytes(),
        );
        let mut expected = 0.0;
        let mut previous: Option<f64> = None;
        for (e, mu, pos) in &layers {
            if let Some(p) = previous {
                expected += if *e > p + 1e-6 { o.up_s } else { o.down_s };
            }
            previous = Some(*e);
            // MU as the importer rounds them (1e-9 MU).
            let mu: Vec<f64> = mu.iter().map(|m| (m * 1e9).round() / 1e9).collect();
            expected += o.layer_s(*e, &mu, pos);
        }
        for motion in ["free", "constant"] {
            let (result, rows) = simulate(&plan, &dir, &["--motion", motion]);
            let total = f(&result["total_s"]);
            assert!(
                (total - expected).abs() <= 1e-9 * expected,
                "seed {seed}, {motion}: {total} s, expected {expected} s"
            );
            let angle = f(&result["layers"][0]["angle_deg"]);
            assert!(rows
                .iter()
                .all(|r| (r[11] - angle).abs() < 1e-9 && (r[12] - angle).abs() < 1e-9));
            let counts: Vec<usize> = layers.iter().map(|l| l.1.len()).collect();
            check_spots(&result, &rows, &counts);
        }
    }
}

/// Worked out by hand: one static control point at 90° with three layers on the OpenTPS machine.
/// 150 MeV (0.006 s/MU): spots 1, 2 and 0.001 MU take 6, 12 and 0.25 (the minimum) ms, moves of
/// 10 mm in x and 20 mm in y 1.25 and 2.5 ms: 22 ms. Down to 140 MeV: 0.6 s; 0.007 s/MU, two 1 MU
/// spots 8 mm apart: 7 + 1 + 7 ms = 15 ms. Up to 145 MeV: 6 s; 0.0065 s/MU (halfway between
/// 140 and 150 MeV) × 0.5 MU = 3.25 ms. Total 6.64025 s, every spot at 90°.
#[test]
fn a_static_control_point_by_hand() {
    let dir = temp_dir().join("spots-hand");
    std::fs::create_dir_all(&dir).expect("dir");
    let plan = dir.join("static.json");
    let text = serde_json::json!({
        "format": "arcsim-plan/1",
        "name": "static by hand",
        "arcs": [{ "direction": "CW", "control_points": [{
            "angle_deg": 90.0, "window_deg": 0.0, "layers": [
                { "energy_mev": 150.0, "spots": { "count": 3, "mu": [1.0, 2.0, 0.001],
                  "positions_mm": [[0.0, 0.0], [10.0, 0.0], [10.0, 20.0]] } },
                { "energy_mev": 140.0, "spots": { "count": 2, "mu": [1.0, 1.0],
                  "positions_mm": [[0.0, 0.0], [8.0, 0.0]] } },
                { "energy_mev": 145.0, "spots": { "count": 1, "mu": [0.5],
                  "positions_mm": [[0.0, 0.0]] } }
            ]
        }]}]
    });
    std::fs::write(&plan, text.to_string()).expect("plan");
    for motion in ["free", "constant"] {
        let (result, rows) = simulate(&plan, &dir, &["--motion", motion]);
        assert!(
            (f(&result["total_s"]) - 6.64025).abs() < 1e-12,
            "{motion}: {result}"
        );
        let b = &result["breakdown"];
        assert!((f(&b["spot_irradiation_s"]) - 0.0355).abs() < 1e-12, "{b}");
        assert!((f(&b["scanning_s"]) - 0.00475).abs() < 1e-12, "{b}");
        assert!((f(&b["energy_switching_s"]) - 6.6).abs() < 1e-12, "{b}");
        assert_eq!(rows.len(), 6);
        assert!(rows
            .iter()
            .all(|r| (r[11] - 90.0).abs() < 1e-9 && (r[12] - 90.0).abs() < 1e-9));
        check_spots(&result, &rows, &[3, 2, 1]);
    }
}

#[test]
fn scanning_machine_without_positions_names_the_layer() {
    let dir = temp_dir().join("spots-bare");
    std::fs::create_dir_all(&dir).expect("dir");
    let plan = temp_file(
        "spots-bare.dcm",
        &dicom::dynamic_arc_plan().without_spot_maps().to_bytes(),
    );
    let out = arcsim(&["simulate", path_str(&plan), "--machine", MACHINE]);
    let (_, err) = text(&out);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("arc 0, control point 0, layer 0")
            && err.contains("spots.positions_mm")
            && err.contains("scanning"),
        "{err}"
    );
}

/// Bursts end to end (`scenarios/machine-proteusone-like.json`): in `--spots`, a layer's spots
/// come in as many passes as its heaviest spot needs (1 MU per spot per burst), a new pass starts
/// at least the burst switching time after the last spot of the one before, the spots of one
/// pass follow each other within the scanning time, and every layer delivers its plan's MU.
#[test]
fn bursts_are_passes_apart_by_the_burst_switching_time() {
    let dir = temp_dir().join("spots-bursts");
    std::fs::create_dir_all(&dir).expect("dir");
    let machine = "scenarios/machine-proteusone-like.json";
    let (_, rows) = simulate_on(machine, &repo().join("plans/lung.json"), &dir, &[]);
    let m = read_json(&repo().join(machine));
    let burst = f(&m["beam"]["burst_switching_time_s"]);
    let max_mu = f(&m["beam"]["max_mu_per_spot"]);
    assert!(burst > 0.0 && max_mu > 0.0);
    let mut bursts_seen = 0;
    for (i, mu) in spot_mu(&repo().join("plans/lung.json")).iter().enumerate() {
        let mine: Vec<&Vec<f64>> = rows.iter().filter(|r| r[0] as usize == i).collect();
        let heaviest = mu.iter().copied().fold(0.0, f64::max);
        let passes = (heaviest / max_mu).ceil().max(1.0);
        // The burst column is the pass; no spills on this machine.
        assert!(mine.iter().all(|r| r[13] == r[5] && r[14].is_nan()));
        let last_pass = mine.iter().map(|r| r[5]).fold(0.0, f64::max);
        assert_eq!(last_pass + 1.0, passes, "layer {i}");
        let delivered: f64 = mine.iter().map(|r| r[8]).sum();
        let planned: f64 = mu.iter().sum();
        assert!((delivered - planned).abs() <= 1e-9 * planned, "layer {i}");
        for w in mine.windows(2) {
            let gap = w[1][9] - w[0][10];
            if w[1][5] > w[0][5] {
                assert!(gap >= burst - 1e-9, "layer {i}: a burst after {gap} s");
                bursts_seen += 1;
            } else {
                assert!(
                    (0.0..burst).contains(&gap),
                    "layer {i}: {gap} s between spots"
                );
            }
        }
    }
    assert!(bursts_seen > 10, "only {bursts_seen} burst switches");
}

/// Spills end to end (`scenarios/machine-probeat-v5-like-mee.json`): in `--spots`, spill indices
/// never go back, no spill gives more than its charge, a layer's spots change spill only after at
/// least the refill time, every layer delivers its plan's MU; a layer that starts in the previous
/// layer's spill is switched into in the in-spill time, every other in an ELST (≥ 1.9 s).
#[test]
fn spills_carry_from_layer_to_layer() {
    let dir = temp_dir().join("spots-spills");
    std::fs::create_dir_all(&dir).expect("dir");
    let machine = "scenarios/machine-probeat-v5-like-mee.json";
    let (result, rows) = simulate_on(machine, &repo().join("plans/lung.json"), &dir, &[]);
    let m = read_json(&repo().join(machine));
    let spill = &m["beam"]["spill"];
    let (charge, refill, in_spill) = (
        f(&spill["charge_mu"]),
        f(&spill["refill_time_s"]),
        f(&spill["in_spill_switching_time_s"]),
    );
    let (mu, t0, t1, spill_of) = (8, 9, 10, 14);
    let mut per_spill = std::collections::BTreeMap::<u64, f64>::new();
    for r in &rows {
        *per_spill.entry(r[spill_of] as u64).or_default() += r[mu];
        assert!(r[13].is_nan(), "no bursts on this machine");
    }
    assert!(per_spill.values().all(|q| *q <= charge * (1.0 + 1e-9)));
    let mut waits = 0.0;
    for w in rows.windows(2) {
        assert!(w[1][spill_of] >= w[0][spill_of]);
        if w[1][0] == w[0][0] && w[1][spill_of] > w[0][spill_of] {
            assert!(w[1][t0] - w[0][t1] >= refill - 1e-9);
            waits += 1.0;
        }
    }
    assert!(waits > 0.0, "no layer waited for a spill");
    for (i, spots) in spot_mu(&repo().join("plans/lung.json")).iter().enumerate() {
        let planned: f64 = spots.iter().sum();
        let delivered: f64 = rows
            .iter()
            .filter(|r| r[0] as usize == i)
            .map(|r| r[mu])
            .sum();
        assert!((delivered - planned).abs() <= 1e-9 * planned, "layer {i}");
    }
    let transitions = result["transitions"].as_array().expect("transitions");
    let mut continued = 0;
    for (k, tr) in transitions.iter().enumerate() {
        let last = rows.iter().rfind(|r| r[0] as usize == k).expect("rows");
        let first = rows.iter().find(|r| r[0] as usize == k + 1).expect("rows");
        let elst = f(&tr["elst_s"]);
        if first[spill_of] == last[spill_of] {
            assert!((elst - in_spill).abs() < 1e-12, "transition {k}: {elst}");
            continued += 1;
        } else {
            assert!(elst >= 1.9 - 1e-12, "transition {k}: {elst}");
        }
    }
    assert!(continued > 0, "no layer continued a spill");
    let b = &result["breakdown"];
    assert!(f(&b["spill_waiting_s"]) > 0.0);
    let parts = f(&b["spot_irradiation_s"])
        + f(&b["scanning_s"])
        + f(&b["burst_switching_s"])
        + f(&b["spill_waiting_s"]);
    assert!((parts - f(&b["beam_on_s"])).abs() <= 1e-9 * parts);
}

/// The spot MU of every layer of a JSON plan, in delivery order: its list, or its total shared
/// equally.
fn spot_mu(plan: &Path) -> Vec<Vec<f64>> {
    let plan = read_json(plan);
    plan["arcs"]
        .as_array()
        .expect("arcs")
        .iter()
        .flat_map(|a| a["control_points"].as_array().expect("cps"))
        .flat_map(|cp| cp["layers"].as_array().expect("layers"))
        .map(|layer| {
            let s = &layer["spots"];
            match s["mu"].as_array() {
                Some(list) => list.iter().map(f).collect(),
                None => {
                    let n = s["count"].as_u64().expect("count") as usize;
                    vec![f(&s["total_mu"]) / n as f64; n]
                }
            }
        })
        .collect()
}

/// A JSON file (a machine, a plan, a result) as a value.
fn read_json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}
