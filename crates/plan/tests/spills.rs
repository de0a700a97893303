//! Spills (a synchrotron): layers worked out by hand, the edge cases (a spot larger than a spill,
//! a layer exactly filling one, zero-MU spots), random layers against sums and laws written here,
//! multi-energy extraction through resolution, and the machine file's errors.

use arcsim_plan::{
    parse_machine, parse_plan, resolve, time_spots, BeamModel, LayerBeamTime, ScanDistance,
    ScanningBeam, SpillModel, SpotAcrossSpills, SpotEvent, Spots,
};
use arcsim_test_support::Rng;
use serde_json::{json, Value};

/// 0.1 s per MU at every energy, 1000 mm/s on both axes (1 mm = 1 ms), nothing else.
fn beam(charge_mu: f64, refill_time_s: f64, mode: SpotAcrossSpills) -> BeamModel {
    BeamModel::Scanning(ScanningBeam {
        s_per_mu_by_energy: vec![[100.0, 0.1]],
        scan_speed_mm_per_s: Some(1000.0),
        scan_speed_x_mm_per_s: None,
        scan_speed_y_mm_per_s: None,
        scan_distance: ScanDistance::PerAxis,
        min_spot_time_s: 0.0,
        settling_time_s: 0.0,
        max_mu_per_spot: None,
        layer_overhead_s: 0.0,
        burst_switching_time_s: 0.0,
        spill: Some(SpillModel {
            charge_mu,
            refill_time_s,
            multi_energy_extraction: false,
            in_spill_switching_time_s: 0.0,
            max_layers_per_spill: None,
            spot_across_spills: mode,
            continue_spill_if: Default::default(),
        }),
    })
}

/// Spots 1 mm apart along x.
fn line(mu: &[f64]) -> Spots {
    Spots {
        count: mu.len() as u32,
        mu: Some(mu.to_vec()),
        total_mu: None,
        positions_mm: Some((0..mu.len()).map(|i| [i as f64, 0.0]).collect()),
        paintings: None,
    }
}

fn timed(s: &Spots, beam: &BeamModel) -> (Vec<SpotEvent>, LayerBeamTime) {
    let mut ev = Vec::new();
    let t = time_spots(s, 100.0, beam, |e| ev.push(*e)).expect("timed");
    (ev, t)
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * (1.0 + b.abs())
}

/// (spot, spill, mu, start, end) of every event.
fn table(ev: &[SpotEvent]) -> Vec<(usize, Option<usize>, f64, f64, f64)> {
    ev.iter()
        .map(|e| (e.spot, e.spill, e.mu, e.start_s, e.end_s))
        .collect()
}

fn assert_events(ev: &[SpotEvent], want: &[(usize, usize, f64, f64, f64)]) {
    let got = table(ev);
    assert_eq!(got.len(), want.len(), "{got:?}");
    for (g, w) in got.iter().zip(want) {
        assert!(
            g.0 == w.0 && g.1 == Some(w.1) && close(g.2, w.2) && close(g.3, w.3) && close(g.4, w.4),
            "{got:?} vs {want:?}"
        );
    }
}

/// A 2 MU spill, 1 s to the next, spots of 1.5, 1.0 and 0.5 MU: the second does not fit in what
/// is left (0.5 MU). Split: it takes the 0.5 MU, waits, takes the rest. Next spill: it waits whole,
/// the magnets' 1 ms move hidden in the wait.
#[test]
fn a_spot_that_does_not_fit_by_hand() {
    let s = line(&[1.5, 1.0, 0.5]);
    let (ev, t) = timed(&s, &beam(2.0, 1.0, SpotAcrossSpills::Split));
    assert_events(
        &ev,
        &[
            (0, 0, 1.5, 0.0, 0.15),
            (1, 0, 0.5, 0.151, 0.201),
            (1, 1, 0.5, 1.201, 1.251),
            (2, 1, 0.5, 1.252, 1.302),
        ],
    );
    assert!(close(t.spot_irradiation_s, 0.3) && close(t.scanning_s, 0.002));
    assert!(
        close(t.spill_waiting_s, 1.0) && close(t.total_s(), 1.302),
        "{t:?}"
    );

    let (ev, t) = timed(&s, &beam(2.0, 1.0, SpotAcrossSpills::NextSpill));
    assert_events(
        &ev,
        &[
            (0, 0, 1.5, 0.0, 0.15),
            (1, 1, 1.0, 1.15, 1.25),
            (2, 1, 0.5, 1.251, 1.301),
        ],
    );
    assert!(close(t.scanning_s, 0.002) && close(t.spill_waiting_s, 0.999));
    assert!(close(t.total_s(), 1.301), "{t:?}");
}

/// A spot of 5 MU with 2 MU spills takes three spills in either mode; after a 0.5 MU spot, split
/// starts it in what is left, next-spill in a new spill.
#[test]
fn a_spot_larger_than_a_spill() {
    for mode in [SpotAcrossSpills::Split, SpotAcrossSpills::NextSpill] {
        let (ev, t) = timed(&line(&[5.0]), &beam(2.0, 1.0, mode));
        assert_events(
            &ev,
            &[
                (0, 0, 2.0, 0.0, 0.2),
                (0, 1, 2.0, 1.2, 1.4),
                (0, 2, 1.0, 2.4, 2.5),
            ],
        );
        assert!(close(t.spill_waiting_s, 2.0) && close(t.total_s(), 2.5));
    }
    let s = line(&[0.5, 5.0]);
    let (ev, _) = timed(&s, &beam(2.0, 1.0, SpotAcrossSpills::Split));
    let parts: Vec<(Option<usize>, f64)> = ev.iter().map(|e| (e.spill, e.mu)).collect();
    assert_eq!(parts.len(), 4, "{parts:?}");
    assert!(close(parts[1].1, 1.5) && close(parts[2].1, 2.0) && close(parts[3].1, 1.5));
    let (ev, t) = timed(&s, &beam(2.0, 1.0, SpotAcrossSpills::NextSpill));
    let parts: Vec<(Option<usize>, f64)> = ev.iter().map(|e| (e.spill, e.mu)).collect();
    assert_eq!(
        parts,
        vec![
            (Some(0), 0.5),
            (Some(1), 2.0),
            (Some(2), 2.0),
            (Some(3), 1.0)
        ]
    );
    // The wait before the spot (the 1 ms move hidden in it), then two more inside it.
    assert!(close(t.spill_waiting_s, 0.999 + 2.0), "{t:?}");
}

/// A layer that exactly fills a spill never waits; a zero-MU spot needs no charge, so it is
/// delivered from an empty spill without waiting.
#[test]
fn exact_fills_and_zero_mu_spots() {
    let (ev, t) = timed(
        &line(&[0.7, 0.6, 0.7]),
        &beam(2.0, 1.0, SpotAcrossSpills::Split),
    );
    assert!(ev.iter().all(|e| e.spill == Some(0)), "{ev:?}");
    assert_eq!(t.spill_waiting_s, 0.0);
    let (ev, t) = timed(
        &line(&[2.0, 0.0, 1.0]),
        &beam(2.0, 1.0, SpotAcrossSpills::Split),
    );
    let spills: Vec<Option<usize>> = ev.iter().map(|e| e.spill).collect();
    assert_eq!(spills, vec![Some(0), Some(0), Some(1)]);
    // The wait comes before the third spot; its 1 ms move is inside it.
    assert!(close(t.spill_waiting_s, 0.999) && close(t.scanning_s, 0.002));
    assert!(close(ev[2].start_s, 0.2 + 0.001 + 1.0), "{ev:?}");
}

/// Random layers: the events conserve every spot's MU, no spill gives more than its charge,
/// spills follow one another, and the totals match sums written here (in split mode a wait
/// happens exactly where the running MU crosses a multiple of the charge).
#[test]
fn random_layers_against_sums_and_laws() {
    let mut rng = Rng::new(32);
    for case in 0..400 {
        let n = 1 + (rng.unit() * 30.0) as usize;
        let mu: Vec<f64> = (0..n).map(|_| rng.range(0.0, 3.0)).collect();
        let charge = rng.range(0.5, 8.0);
        let refill = rng.range(0.0, 2.5);
        let split = rng.unit() < 0.5;
        let mode = if split {
            SpotAcrossSpills::Split
        } else {
            SpotAcrossSpills::NextSpill
        };
        let b = beam(charge, refill, mode);
        let s = line(&mu);
        let (ev, t) = timed(&s, &b);
        let mut per_spot = vec![0.0; n];
        let mut per_spill = Vec::<f64>::new();
        let mut last_spill = 0;
        for e in &ev {
            per_spot[e.spot] += e.mu;
            let k = e.spill.expect("a spill index");
            assert!(k == last_spill || k == last_spill + 1, "case {case}");
            last_spill = k;
            per_spill.resize(k + 1, 0.0);
            per_spill[k] += e.mu;
        }
        for (got, want) in per_spot.iter().zip(&mu) {
            assert!((got - want).abs() <= 1e-9, "case {case}: {got} vs {want}");
        }
        assert!(
            per_spill.iter().all(|q| *q <= charge * (1.0 + 1e-9)),
            "case {case}"
        );
        let total_mu: f64 = mu.iter().sum();
        assert!(close(t.spot_irradiation_s, 0.1 * total_mu), "case {case}");
        assert!(close(t.scanning_s, 0.001 * (n - 1) as f64), "case {case}");
        if split {
            let crossings = ((total_mu / charge).ceil() as usize).max(1) - 1;
            assert_eq!(per_spill.len(), crossings + 1, "case {case}");
            // Each wait is the refill less any move it hides (a crossing at a spot's end).
            assert!(
                t.spill_waiting_s <= crossings as f64 * refill + 1e-12
                    && t.spill_waiting_s >= crossings as f64 * (refill - 0.001) - 1e-12,
                "case {case}"
            );
        } else {
            // Whole spots go in order into spills, a new one when the next does not fit.
            let mut spills = 1;
            let mut left = charge;
            for &m in &mu {
                if m > left && left < charge {
                    spills += 1;
                    left = charge;
                }
                while m > left {
                    spills += 1;
                    left += charge;
                }
                left -= m;
            }
            assert_eq!(per_spill.len(), spills, "case {case}");
        }
        let end = ev.last().map_or(0.0, |e| e.end_s);
        assert!((end - t.total_s()).abs() <= 1e-9, "case {case}");
    }
}

fn machine(spill: Value) -> Value {
    json!({
        "format": "arcsim-machine/1",
        "name": "synchrotron",
        "gantry": { "max_speed_deg_per_s": 5.0, "max_accel_deg_per_s2": 0.5, "max_jerk_deg_per_s3": 0.5 },
        "beam": {
            "kind": "scanning",
            "s_per_mu_by_energy": [[70, 0.1], [230, 0.1]],
            "scan_speed_mm_per_s": 1000,
            "spill": spill
        },
        "elst": { "kind": "constant", "up_s": 2.0, "down_s": 1.9, "same_s": 1.9 },
        "default_window_deg": 1.0
    })
}

/// One arc of layers with one 1 MU spot each, at the given energies, then a second arc of one.
fn plan(energies: &[f64]) -> String {
    let layer = |e: &f64| json!({ "energy_mev": e, "spots": { "count": 1, "mu": [1.0], "positions_mm": [[0, 0]] } });
    let cps: Vec<Value> = energies
        .iter()
        .enumerate()
        .map(|(i, e)| json!({ "angle_deg": 2.0 * i as f64, "layers": [layer(e)] }))
        .collect();
    json!({
        "format": "arcsim-plan/1",
        "name": "p",
        "arcs": [
            { "direction": "CW", "control_points": cps },
            { "direction": "CC", "control_points": [{ "angle_deg": 40.0, "layers": [layer(&100.0)] }] }
        ]
    })
    .to_string()
}

fn switches(spill: Value, energies: &[f64]) -> Vec<f64> {
    let m = parse_machine(&machine(spill).to_string(), "m.json").expect("machine");
    let p = parse_plan(&plan(energies), "p.json").expect("plan");
    let arcs = resolve(&p, &m).expect("resolves");
    arcs.iter()
        .flat_map(|a| &a.layers)
        .map(|l| l.switch_in_s)
        .collect()
}

/// Multi-energy extraction: a layer at the same or a lower energy continues the spill (the in-spill
/// switch instead of the ELST) while charge is left and the spill has served fewer layers than
/// allowed; a step up, an exhausted spill or a new arc starts a new spill (the ELST).
#[test]
fn multi_energy_extraction_through_resolution() {
    let energies = [150.0, 140.0, 140.0, 160.0, 120.0];
    let mee = json!({ "charge_mu": 10, "refill_time_s": 2.0, "multi_energy_extraction": true, "in_spill_switching_time_s": 0.2 });
    assert_eq!(
        switches(mee.clone(), &energies),
        vec![0.0, 0.2, 0.2, 2.0, 0.2, 1.9]
    );
    let off = json!({ "charge_mu": 10, "refill_time_s": 2.0 });
    assert_eq!(switches(off, &energies), vec![0.0, 1.9, 1.9, 2.0, 1.9, 1.9]);
    let mut two = mee.clone();
    two["max_layers_per_spill"] = json!(2);
    assert_eq!(switches(two, &energies), vec![0.0, 0.2, 1.9, 2.0, 0.2, 1.9]);
    // 2 MU spills: the second layer empties the first spill, so the third starts a new one.
    let mut small = mee;
    small["charge_mu"] = json!(2);
    assert_eq!(
        switches(small, &energies),
        vec![0.0, 0.2, 1.9, 2.0, 0.2, 1.9]
    );
}

/// Spill fields are checked and located; a machine without spills writes none.
#[test]
fn spill_machine_file_errors() {
    let ok = json!({ "charge_mu": 10, "refill_time_s": 2.0, "spot_across_spills": "next_spill" });
    let m = parse_machine(&machine(ok).to_string(), "m.json").expect("machine");
    let again = parse_machine(&serde_json::to_string(&m).expect("json"), "again").expect("again");
    assert_eq!(again, m);
    let cases = [
        (
            json!({ "charge_mu": 0, "refill_time_s": 2.0 }),
            "beam.spill.charge_mu",
        ),
        (
            json!({ "charge_mu": 5, "refill_time_s": -1 }),
            "beam.spill.refill_time_s",
        ),
        (
            json!({ "charge_mu": 5, "refill_time_s": 1, "multi_energy_extraction": true, "max_layers_per_spill": 0 }),
            "beam.spill.max_layers_per_spill",
        ),
        (
            json!({ "charge_mu": 5, "refill_time_s": 1, "in_spill_switching_time_s": 0.2 }),
            "multi_energy_extraction",
        ),
        (json!({ "charge_mu": 5 }), "refill_time_s"),
        (
            json!({ "charge_mu": 5, "refill_time_s": 1, "spot_across_spills": "wait" }),
            "next_spill",
        ),
        (
            json!({ "charge_mu": 5, "refill_time_s": 1, "rate": 3 }),
            "rate",
        ),
    ];
    for (spill, want) in cases {
        match parse_machine(&machine(spill.clone()).to_string(), "m.json") {
            Err(e) => assert!(e.to_string().contains(want), "{spill}: {e}"),
            Ok(_) => panic!("{spill}: expected an error naming {want}"),
        }
    }
}
