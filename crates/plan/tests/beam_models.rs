//! Beam models: spot timing under `per_mu` and `scanning`, checked against answers worked out by
//! hand and against an independent computation on random spot maps; machine files of both kinds.

use arcsim_plan::{
    layer_beam_time, parse_machine, parse_plan, resolve, time_spots, BeamModel, Machine, PerMuBeam,
    PlanError, ScanDistance, ScanningBeam, SpotEvent, Spots,
};
use arcsim_test_support::Rng;
use serde_json::{json, Value};

fn scanning(speed: Option<f64>, xy: Option<(f64, f64)>) -> ScanningBeam {
    ScanningBeam {
        s_per_mu_by_energy: vec![[60.0, 0.038], [70.0, 0.023], [100.0, 0.010]],
        scan_speed_mm_per_s: speed,
        scan_speed_x_mm_per_s: xy.map(|v| v.0),
        scan_speed_y_mm_per_s: xy.map(|v| v.1),
        scan_distance: ScanDistance::PerAxis,
        min_spot_time_s: 0.00025,
        settling_time_s: 0.001,
        max_mu_per_spot: None,
        layer_overhead_s: 0.5,
        burst_switching_time_s: 0.0,
        spill: None,
    }
}

fn spots(mu: &[f64], positions: &[[f64; 2]]) -> Spots {
    Spots {
        count: mu.len() as u32,
        mu: Some(mu.to_vec()),
        total_mu: None,
        positions_mm: Some(positions.to_vec()),
        paintings: None,
    }
}

fn events(s: &Spots, energy: f64, beam: &BeamModel) -> (Vec<SpotEvent>, f64, f64) {
    let mut ev = Vec::new();
    let t = time_spots(s, energy, beam, |e| ev.push(*e)).expect("timed");
    // Everything between spots: moves, settling, overhead, bursts, spill waits.
    (ev, t.spot_irradiation_s, t.total_s() - t.spot_irradiation_s)
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * (1.0 + b.abs())
}

#[test]
fn interpolation_is_linear_and_clamped() {
    let b = scanning(Some(8000.0), None);
    assert!(close(b.s_per_mu_at(65.0), 0.0305));
    assert!(close(b.s_per_mu_at(85.0), 0.0165));
    assert_eq!(b.s_per_mu_at(10.0), 0.038);
    assert_eq!(b.s_per_mu_at(60.0), 0.038);
    assert_eq!(b.s_per_mu_at(250.0), 0.010);
}

/// Three spots at 100 MeV (0.010 s/MU), x at 10 m/s and y at 5 m/s, 1 ms settling, 0.5 s overhead:
/// spot 0 0.5–0.51 s; move 10 mm in x: 1 ms + 1 ms; spot 1 0.512–0.532 s; move 20 mm in y: 4 ms
/// + 1 ms; spot 2 (0.001 MU, below the 0.25 ms minimum) 0.537–0.53725 s.
#[test]
fn scanning_layer_by_hand() {
    let beam = BeamModel::Scanning(scanning(None, Some((10_000.0, 5_000.0))));
    let s = spots(&[1.0, 2.0, 0.001], &[[0.0, 0.0], [10.0, 0.0], [10.0, 20.0]]);
    let (ev, irr, scan) = events(&s, 100.0, &beam);
    let want = [(0.5, 0.51), (0.512, 0.532), (0.537, 0.53725)];
    assert_eq!(ev.len(), 3);
    for (e, (t0, t1)) in ev.iter().zip(want) {
        assert!(close(e.start_s, t0) && close(e.end_s, t1), "{e:?}");
        assert_eq!(e.painting, 0);
    }
    assert!(close(irr, 0.01 + 0.02 + 0.00025), "{irr}");
    assert!(close(scan, 0.5 + 0.002 + 0.005), "{scan}");
    assert_eq!(ev[2].position_mm, Some([10.0, 20.0]));
}

/// The same three spots with the straight-line distance at 8 m/s (`euclidean`): the moves of
/// 10 mm and 20 mm take 1.25 and 2.5 ms (+1 ms settling each); a diagonal move of 30 mm in x and
/// 40 mm in y covers 50 mm in 6.25 ms, where `per_axis` takes the longer axis, 40 mm in 5 ms.
#[test]
fn euclidean_scanning_by_hand() {
    let mut b = scanning(Some(8_000.0), None);
    b.scan_distance = ScanDistance::Euclidean;
    let beam = BeamModel::Scanning(b.clone());
    let s = spots(&[1.0, 2.0, 0.001], &[[0.0, 0.0], [10.0, 0.0], [10.0, 20.0]]);
    let (ev, irr, scan) = events(&s, 100.0, &beam);
    let want = [(0.5, 0.51), (0.51225, 0.53225), (0.53575, 0.536)];
    for (e, (t0, t1)) in ev.iter().zip(want) {
        assert!(close(e.start_s, t0) && close(e.end_s, t1), "{e:?}");
    }
    assert!(close(irr, 0.01 + 0.02 + 0.00025), "{irr}");
    assert!(close(scan, 0.5 + 0.00225 + 0.0035), "{scan}");
    assert!(close(b.move_time_s([0.0, 0.0], [30.0, -40.0]), 0.00725));
    b.scan_distance = ScanDistance::PerAxis;
    assert!(close(b.move_time_s([0.0, 0.0], [30.0, -40.0]), 0.006));
}

/// A spot above `max_mu_per_spot` is split into equal parts over extra passes; lighter spots are
/// delivered once, in the first pass.
#[test]
fn heavy_spots_are_repainted() {
    let mut b = scanning(Some(1000.0), None);
    b.max_mu_per_spot = Some(1.5);
    b.layer_overhead_s = 0.0;
    b.settling_time_s = 0.0;
    let beam = BeamModel::Scanning(b);
    let s = spots(&[4.0, 1.0, 3.0], &[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]);
    let (ev, irr, _) = events(&s, 100.0, &beam);
    let seen: Vec<(usize, usize)> = ev.iter().map(|e| (e.painting, e.spot)).collect();
    // spot 0: 3 parts of 4/3; spot 1: one part; spot 2: 2 parts of 1.5.
    assert_eq!(seen, [(0, 0), (0, 1), (0, 2), (1, 0), (1, 2), (2, 0)]);
    assert!(close(ev[0].mu, 4.0 / 3.0) && close(ev[4].mu, 1.5));
    let mu: f64 = ev.iter().map(|e| e.mu).sum();
    assert!(close(mu, 8.0));
    assert!(close(irr, 8.0 * 0.010));
    // From spot 2 back to spot 0 at the start of the second pass: 2 mm at 1 m/s.
    assert!(close(ev[3].start_s - ev[2].end_s, 0.002));
}

/// Bursts (a synchrocyclotron): every pass over the spots after the first starts with the burst
/// switching time, then the move back to its first spot. Worked out step by step on the layer of
/// `heavy_spots_are_repainted` (three passes).
#[test]
fn bursts_by_hand() {
    let mut b = scanning(Some(1000.0), None);
    b.max_mu_per_spot = Some(1.5);
    b.layer_overhead_s = 0.0;
    b.settling_time_s = 0.0;
    b.burst_switching_time_s = 0.15;
    let beam = BeamModel::Scanning(b);
    let s = spots(&[4.0, 1.0, 3.0], &[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]);
    let (ev, irr, scan) = events(&s, 100.0, &beam);
    // 0.010 s/MU at 100 MeV; 1 mm takes 0.001 s.
    let (rate, mm) = (0.010, 0.001);
    let burst = 0.15;
    let mut t = 0.0;
    let mut want = Vec::new();
    // Burst 1: spot 0 (4/3 MU), 1 mm, spot 1 (1 MU), 1 mm, spot 2 (1.5 MU).
    want.push(t);
    t += 4.0 / 3.0 * rate + mm;
    want.push(t);
    t += rate + mm;
    want.push(t);
    t += 1.5 * rate;
    // Burst 2: the pause, 2 mm back to spot 0, spot 0, 2 mm, spot 2.
    t += burst + 2.0 * mm;
    want.push(t);
    t += 4.0 / 3.0 * rate + 2.0 * mm;
    want.push(t);
    t += 1.5 * rate;
    // Burst 3: the pause, 2 mm back, spot 0.
    t += burst + 2.0 * mm;
    want.push(t);
    t += 4.0 / 3.0 * rate;
    let starts: Vec<f64> = ev.iter().map(|e| e.start_s).collect();
    assert_eq!(starts.len(), want.len());
    for (got, want) in starts.iter().zip(&want) {
        assert!(close(*got, *want), "{starts:?} vs {want:?}");
    }
    assert!(close(irr, 8.0 * rate));
    assert!(close(scan, 8.0 * mm + 2.0 * burst), "{scan}");
    assert!(close(irr + scan, t));
    let parts = time_spots(&s, 100.0, &beam, |_| {}).expect("timed");
    assert!(close(parts.burst_switching_s, 2.0 * burst), "{parts:?}");
    assert!(close(parts.scanning_s, 8.0 * mm) && parts.spill_waiting_s == 0.0);
    // One pass: no burst switching at all.
    let light = spots(&[1.0, 0.0], &[[0.0, 0.0], [1.0, 0.0]]);
    let (ev, irr, scan) = events(&light, 100.0, &beam);
    assert_eq!(ev.len(), 2);
    assert!(
        close(irr, rate + 0.00025) && close(scan, mm),
        "{irr} {scan}"
    );
}

/// Random layers with plan paintings and bursts against a sum written here: every painting
/// delivers each spot's MU / paintings along the plan's order, each painting after the first
/// starts with a burst switch and the move back to the first spot.
#[test]
fn random_bursts_match_an_independent_sum() {
    let mut rng = Rng::new(29);
    for case in 0..300 {
        let n = 1 + (rng.unit() * 40.0) as usize;
        let paintings = 1 + (rng.unit() * 4.0) as usize;
        let v = rng.range(500.0, 20_000.0);
        let mut b = scanning(Some(v), None);
        b.settling_time_s = rng.range(0.0, 0.002);
        b.layer_overhead_s = rng.range(0.0, 1.0);
        b.min_spot_time_s = rng.range(0.0, 0.003);
        b.burst_switching_time_s = rng.range(0.0, 0.3);
        let mu: Vec<f64> = (0..n).map(|_| rng.range(0.0, 3.0)).collect();
        let pos: Vec<[f64; 2]> = (0..n)
            .map(|_| [rng.range(-100.0, 100.0), rng.range(-100.0, 100.0)])
            .collect();
        let rate = 0.010;
        let p = paintings as f64;
        let mv = |a: [f64; 2], c: [f64; 2]| {
            f64::max((c[0] - a[0]).abs(), (c[1] - a[1]).abs()) / v + b.settling_time_s
        };
        let spot_s: f64 = mu
            .iter()
            .map(|m| (m / p * rate).max(b.min_spot_time_s))
            .sum();
        let within: f64 = pos.windows(2).map(|w| mv(w[0], w[1])).sum();
        let back = mv(pos[n - 1], pos[0]) + b.burst_switching_time_s;
        let want_irr = p * spot_s;
        let want_scan = b.layer_overhead_s + p * within + (p - 1.0) * back;
        let beam = BeamModel::Scanning(b);
        let mut s = spots(&mu, &pos);
        s.paintings = Some(paintings as u32);
        let (ev, irr, scan) = events(&s, 150.0, &beam);
        assert_eq!(ev.len(), n * paintings, "case {case}");
        assert!(
            (irr - want_irr).abs() <= 1e-12 * (1.0 + want_irr),
            "case {case}"
        );
        assert!(
            (scan - want_scan).abs() <= 1e-12 * (1.0 + want_scan),
            "case {case}: {scan} vs {want_scan}"
        );
        let last = ev.last().map_or(0.0, |e| e.end_s);
        assert!((last - irr - scan).abs() <= 1e-9, "case {case}");
    }
}

/// Plan paintings repeat the list with MU / paintings; per_mu times them as the repeated list.
#[test]
fn paintings_repeat_the_spot_list() {
    let beam = BeamModel::PerMu(PerMuBeam {
        s_per_mu: 0.005,
        spot_switch_time_s: 0.002,
        min_spot_time_s: 0.0,
    });
    let mut s = spots(&[1.0, 2.0], &[[0.0, 0.0], [5.0, 0.0]]);
    s.paintings = Some(3);
    let (ev, irr, scan) = events(&s, 150.0, &beam);
    assert_eq!(ev.len(), 6);
    assert_eq!(
        ev.iter().map(|e| e.painting).collect::<Vec<_>>(),
        [0, 0, 1, 1, 2, 2]
    );
    assert!(close(irr, 3.0 * 0.005) && close(scan, 5.0 * 0.002));
    let expanded = spots(&[1.0 / 3.0, 2.0 / 3.0].repeat(3), &[[0.0, 0.0]; 6]);
    let (_, irr2, scan2) = events(&expanded, 150.0, &beam);
    assert!(close(irr, irr2) && close(scan, scan2));
}

/// The per_mu model is Σ max(MU × s/MU, minimum) + (n − 1) × switch, summed here directly.
#[test]
fn per_mu_is_the_sum_of_spot_times_and_switches() {
    let b = PerMuBeam {
        s_per_mu: 0.005,
        spot_switch_time_s: 0.002,
        min_spot_time_s: 0.004,
    };
    let mu = [0.3, 1.2, 0.5, 2.0];
    let s = spots(&mu, &[[0.0; 2]; 4]);
    let direct: f64 = mu
        .iter()
        .map(|m| (m * b.s_per_mu).max(b.min_spot_time_s))
        .sum::<f64>()
        + 3.0 * b.spot_switch_time_s;
    let layer = arcsim_plan::EnergyLayer {
        energy_mev: 120.0,
        spots: Some(s),
        irradiation_time_s: None,
        switching_time_s: None,
        window_share: None,
    };
    let t = layer_beam_time(&layer, &BeamModel::PerMu(b)).expect("timed");
    assert_eq!(t.total_s(), direct);
}

/// Random spot maps against a direct sum written independently of the model's loop: the spots'
/// times, the scanning moves between consecutive spots (slower axis) with settling, the overhead;
/// spots never overlap, each starts when the previous move ends.
#[test]
fn random_spot_maps_match_an_independent_sum() {
    let mut rng = Rng::new(7);
    for case in 0..500 {
        let n = 1 + (rng.unit() * 60.0) as usize;
        let energy = rng.range(50.0, 240.0);
        let (vx, vy) = (rng.range(500.0, 20_000.0), rng.range(500.0, 20_000.0));
        let mut b = scanning(None, Some((vx, vy)));
        b.settling_time_s = rng.range(0.0, 0.002);
        b.layer_overhead_s = rng.range(0.0, 1.0);
        b.min_spot_time_s = rng.range(0.0, 0.003);
        let mu: Vec<f64> = (0..n).map(|_| rng.range(0.0, 3.0)).collect();
        let pos: Vec<[f64; 2]> = (0..n)
            .map(|_| [rng.range(-100.0, 100.0), rng.range(-100.0, 100.0)])
            .collect();
        let rate = if energy <= 60.0 {
            0.038
        } else if energy <= 70.0 {
            0.038 + (0.023 - 0.038) * (energy - 60.0) / 10.0
        } else if energy <= 100.0 {
            0.023 + (0.010 - 0.023) * (energy - 70.0) / 30.0
        } else {
            0.010
        };
        let spot_s: f64 = mu.iter().map(|m| (m * rate).max(b.min_spot_time_s)).sum();
        let moves_s: f64 = pos
            .windows(2)
            .map(|w| {
                let (dx, dy) = ((w[1][0] - w[0][0]).abs(), (w[1][1] - w[0][1]).abs());
                f64::max(dx / vx, dy / vy) + b.settling_time_s
            })
            .sum();
        let overhead = b.layer_overhead_s;
        let beam = BeamModel::Scanning(b);
        let (ev, irr, scan) = events(&spots(&mu, &pos), energy, &beam);
        assert_eq!(ev.len(), n, "case {case}");
        assert!(
            (irr - spot_s).abs() <= 1e-12,
            "case {case}: {irr} vs {spot_s}"
        );
        assert!(
            (scan - moves_s - overhead).abs() <= 1e-12,
            "case {case}: {scan}"
        );
        assert!(close(ev[0].start_s, overhead), "case {case}");
        for w in ev.windows(2) {
            assert!(w[1].start_s >= w[0].end_s, "case {case}: overlap");
        }
        let last = ev.last().map_or(0.0, |e| e.end_s);
        assert!((last - irr - scan).abs() <= 1e-9, "case {case}");
    }
}

fn machine_json(beam: Value) -> Value {
    json!({
        "format": "arcsim-machine/1",
        "name": "scan",
        "gantry": { "max_speed_deg_per_s": 5.0, "max_accel_deg_per_s2": 0.5, "max_jerk_deg_per_s3": 0.5 },
        "beam": beam,
        "elst": { "kind": "constant", "up_s": 6.0, "down_s": 0.6, "same_s": 0.6 },
        "default_window_deg": 1.0
    })
}

fn issues(v: &Value) -> String {
    match parse_machine(&v.to_string(), "m.json") {
        Err(e) => e.to_string(),
        Ok(m) => panic!("expected an error, got {m:?}"),
    }
}

#[test]
fn machine_files_of_both_kinds() {
    let old = machine_json(json!({ "s_per_mu": 0.005, "spot_switch_time_s": 0.002 }));
    let m = parse_machine(&old.to_string(), "m.json").expect("a file without kind");
    assert_eq!(m.beam.kind(), "per_mu");
    let scan = machine_json(json!({
        "kind": "scanning",
        "s_per_mu_by_energy": [[60, 0.038], [227, 0.006]],
        "scan_speed_mm_per_s": 8000,
        "min_spot_time_s": 0.00025
    }));
    let m: Machine = parse_machine(&scan.to_string(), "m.json").expect("scanning");
    assert_eq!(m.beam.kind(), "scanning");
    // Round trip through serde keeps the kind.
    let again = parse_machine(&serde_json::to_string(&m).expect("json"), "again").expect("again");
    assert_eq!(again, m);

    let e = issues(&machine_json(json!({ "kind": "laser" })));
    assert!(e.contains("unknown beam model kind \"laser\""), "{e}");
    let mut bad = scan.clone();
    bad["beam"]["scan_sped_mm_per_s"] = json!(1);
    let e = issues(&bad);
    assert!(e.contains("scan_sped_mm_per_s"), "{e}");
    let mut bad = scan.clone();
    bad["beam"]["scan_speed_x_mm_per_s"] = json!(1000);
    let e = issues(&bad);
    assert!(
        e.contains("beam.scan_speed_mm_per_s") && e.contains("either"),
        "{e}"
    );
    let mut euclid = scan.clone();
    euclid["beam"]["scan_distance"] = json!("euclidean");
    let m = parse_machine(&euclid.to_string(), "m.json").expect("euclidean");
    let again = parse_machine(&serde_json::to_string(&m).expect("json"), "again").expect("again");
    assert_eq!(again, m);
    let written = serde_json::to_value(&m).expect("json");
    assert_eq!(written["beam"]["scan_distance"], json!("euclidean"));
    let plain = serde_json::to_value(parse_machine(&scan.to_string(), "m.json").expect("scan"))
        .expect("json");
    assert!(plain["beam"].get("scan_distance").is_none(), "{plain}");
    let mut bad = euclid.clone();
    bad["beam"]["scan_distance"] = json!("diagonal");
    let e = issues(&bad);
    assert!(e.contains("diagonal") && e.contains("euclidean"), "{e}");
    let mut bad = euclid;
    bad["beam"]
        .as_object_mut()
        .expect("beam")
        .remove("scan_speed_mm_per_s");
    bad["beam"]["scan_speed_x_mm_per_s"] = json!(8000);
    bad["beam"]["scan_speed_y_mm_per_s"] = json!(4000);
    let e = issues(&bad);
    assert!(
        e.contains("beam.scan_distance") && e.contains("one speed"),
        "{e}"
    );
    let mut bad = scan.clone();
    bad["beam"]["s_per_mu_by_energy"] = json!([[100, 0.01], [90, 0.02]]);
    let e = issues(&bad);
    assert!(
        e.contains("beam.s_per_mu_by_energy[1][0]") && e.contains("increasing"),
        "{e}"
    );
    let mut bad = scan.clone();
    bad["beam"]["s_per_mu_by_energy"] = json!([[100, -0.01]]);
    let e = issues(&bad);
    assert!(e.contains("beam.s_per_mu_by_energy[0][1]"), "{e}");
    // Burst switching: written only when set, a located error when negative.
    let mut bursts = scan.clone();
    bursts["beam"]["burst_switching_time_s"] = json!(0.15);
    let m = parse_machine(&bursts.to_string(), "m.json").expect("bursts");
    let written = serde_json::to_value(&m).expect("json");
    assert_eq!(written["beam"]["burst_switching_time_s"], json!(0.15));
    assert!(
        plain["beam"].get("burst_switching_time_s").is_none(),
        "{plain}"
    );
    let mut bad = scan;
    bad["beam"]["burst_switching_time_s"] = json!(-0.15);
    let e = issues(&bad);
    assert!(e.contains("beam.burst_switching_time_s"), "{e}");
}

fn plan_json(spots: Value) -> String {
    json!({
        "format": "arcsim-plan/1",
        "name": "p",
        "arcs": [{ "direction": "CW", "control_points": [
            { "angle_deg": 0.0, "layers": [{ "energy_mev": 100.0, "spots": spots.clone() }] },
            { "angle_deg": 2.0, "layers": [{ "energy_mev": 90.0, "spots": spots }] }
        ]}]
    })
    .to_string()
}

#[test]
fn scanning_needs_positions_and_resolves_the_split() {
    let scan = machine_json(json!({
        "kind": "scanning",
        "s_per_mu_by_energy": [[60, 0.038], [227, 0.006]],
        "scan_speed_mm_per_s": 8000,
        "layer_overhead_s": 0.1
    }));
    let machine = parse_machine(&scan.to_string(), "m.json").expect("machine");
    let bare = parse_plan(&plan_json(json!({ "count": 2, "mu": [1, 2] })), "p.json")
        .expect("a plan without positions is valid");
    match resolve(&bare, &machine) {
        Err(PlanError::Invalid { issues, .. }) => {
            let text: Vec<String> = issues.iter().map(|i| i.to_string()).collect();
            assert_eq!(text.len(), 2, "{text:?}");
            assert!(
                text[0].contains("control point 0")
                    && text[0].contains("spots.positions_mm")
                    && text[0].contains("scanning"),
                "{text:?}"
            );
        }
        other => panic!("expected the missing positions, got {other:?}"),
    }
    let plan = parse_plan(
        &plan_json(json!({ "count": 2, "mu": [1, 2], "positions_mm": [[0, 0], [8, 0]] })),
        "p.json",
    )
    .expect("plan");
    let arcs = resolve(&plan, &machine).expect("resolves");
    let l = &arcs[0].layers[0];
    assert!(close(l.scanning_s, 0.1 + 0.001), "{l:?}");
    assert!(close(l.irradiation_s, l.spot_irradiation_s + l.scanning_s));
    let wrong = plan_json(json!({ "count": 2, "mu": [1, 2], "positions_mm": [[0, 0]] }));
    let e = parse_plan(&wrong, "p.json").expect_err("one position for two spots");
    assert!(
        e.to_string().contains("spots.positions_mm") && e.to_string().contains("1 positions"),
        "{e}"
    );
    let wrong = plan_json(json!({ "count": 2, "mu": [1, 2], "paintings": 0 }));
    let e = parse_plan(&wrong, "p.json").expect_err("no paintings");
    assert!(e.to_string().contains("spots.paintings"), "{e}");
}
