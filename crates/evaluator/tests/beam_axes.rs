//! The beam axes of a sweep: `dose_rate_scale` (any beam model), `scan_speed_mm_per_s` and
//! `burst_switching_time_s` (a `scanning` beam model only) change the resolved plan, and only
//! its beam-on time; rows carry
//! them and the split of the beam-on time (CSV and JSON), and the CSV reads back.

use std::path::Path;

use crate::util::{csv, from_text_in, scenarios};
use arcsim_evaluator::{merge_csv, Axis, Evaluator, Outcome, Row, Shard, Status, CSV_HEADER};
use arcsim_plan::{BeamModel, PlanKind, ScanningBeam};
use arcsim_test_support::temp_dir;

/// Prostate under `scan` on the ATOM machine (`per_mu` beam: 0.005 s/MU, 2 ms between spots)
/// over `axes`.
fn atom_sweep(axes: &str) -> String {
    format!(
        r#"{{"format": "arcsim-sweep/1", "name": "beam", "plans": ["../plans/prostate.json"],
            "machine": "machine-atom.json", "axes": {axes}, "schedules": ["scan"]}}"#
    )
}

fn error_of(text: &str, dir: &Path) -> String {
    match from_text_in(text, dir) {
        Ok(_) => panic!("expected an error for {text}"),
        Err(e) => e.to_string(),
    }
}

fn all_rows(ev: &Evaluator) -> Vec<Row> {
    ev.run_collect(&(0..ev.len()).collect::<Vec<_>>())
}

fn ok(r: &Row) -> Outcome {
    assert_eq!(r.status, Status::Ok, "{r:?}");
    r.outcome.expect("ok row")
}

/// `a` and `b` equal to a relative `tol`.
fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs())
}

/// One column of a CSV table by its header name.
fn column<'a>(table: &'a str, name: &str) -> Vec<&'a str> {
    let mut lines = table.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let i = header.iter().position(|h| *h == name).expect(name);
    lines
        .map(|l| {
            assert!(!l.contains('"'), "a quoted field: {l}");
            l.split(',').nth(i).expect("field")
        })
        .collect()
}

/// Twice the dose rate halves the spots' irradiation and leaves the spot switching (and the
/// energy switching) alone: beam-on 2 = beam-on 1 − spot irradiation 1 / 2. Rows and the summary
/// name the axis with its unit.
#[test]
fn dose_rate_scale_halves_the_spot_irradiation_on_a_per_mu_machine() {
    let ev = Evaluator::new(
        from_text_in(&atom_sweep(r#"{"dose_rate_scale": [1, 2]}"#), &scenarios()).expect("sweep"),
    )
    .expect("prepare");
    assert_eq!(ev.len(), 2);
    let rows = all_rows(&ev);
    assert_eq!(
        rows.iter()
            .map(|r| (r.setting.dose_rate_scale, r.setting.scan_speed_mm_per_s))
            .collect::<Vec<_>>(),
        [(Some(1.0), None), (Some(2.0), None)]
    );
    let (o1, o2) = (ok(&rows[0]), ok(&rows[1]));
    let (b1, b2) = (o1.breakdown, o2.breakdown);
    for b in [b1, b2] {
        assert!(
            close(b.beam_on_s, b.spot_irradiation_s + b.scanning_s, 1e-12),
            "{b:?}"
        );
    }
    assert!(b1.scanning_s > 0.0 && b1.spot_irradiation_s > 0.0, "{b1:?}");
    assert!(
        close(b2.spot_irradiation_s, b1.spot_irradiation_s / 2.0, 1e-9),
        "{b1:?} {b2:?}"
    );
    assert!(close(b2.scanning_s, b1.scanning_s, 1e-12), "{b1:?} {b2:?}");
    assert!(
        close(
            b2.beam_on_s,
            b1.beam_on_s - b1.spot_irradiation_s / 2.0,
            1e-9
        ),
        "{b1:?} {b2:?}"
    );
    assert!(b2.beam_on_s < b1.beam_on_s);
    assert_eq!(b2.energy_switching_s, b1.energy_switching_s);
    assert!(o2.total_s <= o1.total_s, "{} > {}", o2.total_s, o1.total_s);
    // Scale 1 is the base machine itself.
    assert_eq!(o1.speedup, Some(1.0));
    assert_eq!(Some(o1.total_s), ev.base_total_s(0, 0));

    // JSON rows: the setting has the scale, null for the scanning speed the sweep does not set.
    let json = serde_json::to_value(&rows[1]).expect("json");
    assert_eq!(json["setting"]["dose_rate_scale"], 2.0);
    assert!(json["setting"]["scan_speed_mm_per_s"].is_null(), "{json}");
    assert_eq!(
        json["outcome"]["breakdown"]["spot_irradiation_s"],
        b2.spot_irradiation_s
    );
    assert_eq!(json["outcome"]["breakdown"]["scanning_s"], b2.scanning_s);

    // The summary: a sensitivity (base 1) and a profile of the scale, named with its unit.
    let s = ev.summarize(&rows);
    let table = s.to_table();
    print!("{table}");
    let e = &s.entries[0];
    let sens = e
        .sensitivity
        .iter()
        .find(|x| x.axis == Axis::DoseRateScale)
        .expect("dose-rate sensitivity");
    assert_eq!(sens.base_value, 1.0);
    assert!(sens.s_per_10_percent.is_some_and(|d| d <= 0.0), "{sens:?}");
    assert_eq!(e.profiles.len(), 1);
    assert_eq!(e.profiles[0].axis, Axis::DoseRateScale);
    assert!(table.contains("dose rate (base 1)"), "{table}");
    assert!(table.contains("dose rate [×]"), "{table}");
    assert!(e.sensitivity.iter().all(|x| x.axis != Axis::ScanSpeed));
    // A dose rate of twice the base one is a change of ln 2 when it reaches the target.
    if let Some(c) = e.cheapest.as_ref().filter(|c| c.index == Some(1)) {
        assert!(close(c.cost, 2f64.ln(), 1e-12), "{c:?}");
    }

    // The CSV: the scale in its column, no scanning speed, the split of the beam-on time.
    let table = csv(&rows);
    assert!(table.starts_with(&format!("{CSV_HEADER}\n")));
    assert_eq!(column(&table, "dose_rate_scale"), ["1", "2"]);
    assert_eq!(column(&table, "scan_speed_mm_per_s"), ["", ""]);
    assert_eq!(
        column(&table, "scanning_s"),
        [b1.scanning_s.to_string(), b2.scanning_s.to_string()]
    );
}

/// A sweep that leaves the beam alone writes the scale 1 (the machine's own dose rate) and no
/// scanning speed for a `per_mu` machine; a scanning-speed axis on it is a located error saying
/// why; out-of-range values are refused when the sweep is loaded.
#[test]
fn beam_axis_values_are_checked_at_the_boundary() {
    let dir = scenarios();
    for (axes, expected) in [
        (
            r#"{"scan_speed_mm_per_s": [5000]}"#,
            "test-sweep.json: axes.scan_speed_mm_per_s: machine \"atom\": its beam model has no scanning speed (kind per_mu)",
        ),
        (
            r#"{"dose_rate_scale": [0]}"#,
            "test-sweep.json: axes.dose_rate_scale[0]: expected a value finite and > 0, got 0",
        ),
        (
            r#"{"dose_rate_scale": [1, 2000]}"#,
            "test-sweep.json: axes.dose_rate_scale[1]: expected a dose-rate scale from 0.001 to 1000",
        ),
        (
            r#"{"dose_rate_scale": {"from": 0.0001, "to": 1, "steps": 3, "scale": "log"}}"#,
            "test-sweep.json: axes.dose_rate_scale.from: expected a dose-rate scale from 0.001 to 1000",
        ),
        (
            r#"{"dose_rate_scale": [1, 1]}"#,
            "test-sweep.json: axes.dose_rate_scale: value 1 appears twice",
        ),
    ] {
        let e = error_of(&atom_sweep(axes), &dir);
        assert!(e.starts_with(expected), "{axes}: expected «{expected}», got «{e}»");
    }
    // In a schedule entry's own axes, located there.
    let text = atom_sweep("{}").replace(
        "[\"scan\"]",
        "[{\"schedule\": \"scan\", \"axes\": {\"scan_speed_mm_per_s\": [1000, 2000]}}]",
    );
    let e = error_of(&text, &dir);
    assert!(
        e.starts_with("test-sweep.json: schedules[0].axes.scan_speed_mm_per_s: machine \"atom\": its beam model has no scanning speed (kind per_mu)"),
        "{e}"
    );
    // A scale whose s/MU a machine file would refuse (0.05 s/MU / 0.001 = 50 s/MU).
    let tmp = temp_dir();
    let atom = std::fs::read_to_string(dir.join("machine-atom.json")).expect("machine");
    let slow = atom.replacen("\"s_per_mu\": 0.005", "\"s_per_mu\": 0.05", 1);
    assert_ne!(slow, atom);
    std::fs::write(tmp.join("machine-slow.json"), slow).expect("write");
    let text = atom_sweep(r#"{"dose_rate_scale": [0.001, 1]}"#)
        .replace("../plans/", &format!("{}/", dir.join("../plans").display()))
        .replace("machine-atom.json", "machine-slow.json");
    let e = error_of(&text, &tmp);
    assert!(
        e.starts_with("test-sweep.json: axes.dose_rate_scale[0]: ")
            && e.contains("`beam.s_per_mu`"),
        "{e}"
    );
    assert!(from_text_in(&text.replace("0.001", "0.01"), &tmp).is_ok());
}

/// A `scanning` machine (5 m/s, no settling or layer overhead) and a generated prostate plan with
/// spot positions, in `dir`; returns the sweep text over `axes`.
fn scanning_setup(dir: &Path, axes: &str) -> String {
    std::fs::create_dir_all(dir).expect("temp dir");
    let mut machine =
        arcsim_plan::load_machine(scenarios().join("machine-atom.json")).expect("machine");
    machine.name = "scanning".into();
    machine.beam = BeamModel::Scanning(ScanningBeam {
        s_per_mu_by_energy: vec![[70.0, 0.004], [230.0, 0.008]],
        scan_speed_mm_per_s: Some(5000.0),
        scan_speed_x_mm_per_s: None,
        scan_speed_y_mm_per_s: None,
        scan_distance: Default::default(),
        min_spot_time_s: 0.0,
        settling_time_s: 0.0,
        max_mu_per_spot: None,
        layer_overhead_s: 0.0,
        burst_switching_time_s: 0.0,
        spill: None,
    });
    std::fs::write(
        dir.join("machine-scanning.json"),
        serde_json::to_string_pretty(&machine).expect("machine json"),
    )
    .expect("write machine");
    let mut plan = arcsim_plan::generate(PlanKind::Prostate, 1);
    // Positions on a 5 mm grid where the generator gives none.
    for spots in plan
        .arcs
        .iter_mut()
        .flat_map(|a| &mut a.control_points)
        .flat_map(|cp| &mut cp.layers)
        .filter_map(|l| l.spots.as_mut())
    {
        if spots.positions_mm.is_none() {
            spots.positions_mm = Some(
                (0..spots.count)
                    .map(|i| [5.0 * f64::from(i % 7), 5.0 * f64::from(i / 7)])
                    .collect(),
            );
        }
    }
    std::fs::write(dir.join("prostate-1.json"), arcsim_plan::to_json(&plan)).expect("write plan");
    format!(
        r#"{{"format": "arcsim-sweep/1", "name": "scanning", "plans": ["prostate-1.json"],
            "machine": "machine-scanning.json", "axes": {axes}, "schedules": ["scan"]}}"#
    )
}

/// On a scanning machine without settling or layer overhead the time between spots is distance
/// over speed: ten times the speed, a tenth of it; the dose rate halves the irradiation only.
/// Both axes are in the variant: each combination resolves its own. The table reads back and
/// merges byte for byte.
#[test]
fn scan_speed_and_dose_rate_on_a_scanning_machine() {
    let dir = temp_dir();
    let text = scanning_setup(
        &dir,
        r#"{"scan_speed_mm_per_s": [2000, 20000], "dose_rate_scale": [1, 2]}"#,
    );
    let ev = Evaluator::new(from_text_in(&text, &dir).expect("sweep")).expect("prepare");
    assert_eq!(ev.len(), 4);
    let rows = all_rows(&ev);
    // The scanning speed varies faster than the dose-rate scale.
    assert_eq!(
        rows.iter()
            .map(|r| (r.setting.scan_speed_mm_per_s, r.setting.dose_rate_scale))
            .collect::<Vec<_>>(),
        [
            (Some(2000.0), Some(1.0)),
            (Some(20000.0), Some(1.0)),
            (Some(2000.0), Some(2.0)),
            (Some(20000.0), Some(2.0)),
        ]
    );
    let b: Vec<_> = rows.iter().map(|r| ok(r).breakdown).collect();
    for x in &b {
        assert!(
            close(x.beam_on_s, x.spot_irradiation_s + x.scanning_s, 1e-12),
            "{x:?}"
        );
        assert!(x.scanning_s > 0.0, "{x:?}");
    }
    for (slow, fast) in [(0, 1), (2, 3)] {
        assert!(
            close(b[slow].scanning_s, 10.0 * b[fast].scanning_s, 1e-9),
            "{b:?}"
        );
        assert!(close(
            b[slow].spot_irradiation_s,
            b[fast].spot_irradiation_s,
            1e-12
        ));
    }
    for (one, two) in [(0, 2), (1, 3)] {
        assert!(
            close(
                b[two].spot_irradiation_s,
                b[one].spot_irradiation_s / 2.0,
                1e-9
            ),
            "{b:?}"
        );
        assert!(close(b[two].scanning_s, b[one].scanning_s, 1e-12), "{b:?}");
    }
    let fastest_beam = b.iter().map(|x| x.beam_on_s).fold(f64::INFINITY, f64::min);
    assert_eq!(fastest_beam, b[3].beam_on_s);
    assert!(b[3].beam_on_s < b[0].beam_on_s);

    // The summary has both axes, at the machine's 5000 mm/s and scale 1, with their units.
    let s = ev.summarize(&rows);
    let table = s.to_table();
    print!("{table}");
    let e = &s.entries[0];
    let base = |a: Axis| {
        e.sensitivity
            .iter()
            .find(|x| x.axis == a)
            .map(|x| x.base_value)
    };
    assert_eq!(base(Axis::ScanSpeed), Some(5000.0));
    assert_eq!(base(Axis::DoseRateScale), Some(1.0));
    assert!(table.contains("scan speed (base 5000)"), "{table}");
    assert!(table.contains("scan speed [mm/s]"), "{table}");
    assert!(table.contains("dose rate [×]"), "{table}");
    let f = e.fastest.expect("fastest");
    assert_eq!(f.index, Some(3), "{f:?}");

    // CSV: the values in their columns; read back and written again, byte for byte; shards merge.
    let single = csv(&rows);
    assert_eq!(
        column(&single, "scan_speed_mm_per_s"),
        ["2000", "20000", "2000", "20000"]
    );
    assert_eq!(column(&single, "dose_rate_scale"), ["1", "1", "2", "2"]);
    let spot: Vec<String> = b.iter().map(|x| x.spot_irradiation_s.to_string()).collect();
    assert_eq!(column(&single, "spot_irradiation_s"), spot);
    let back = ev.rows_from_csv("back.csv", &single).expect("read back");
    assert_eq!(back.len(), 4);
    for (a, r) in back.iter().zip(&rows) {
        assert_eq!(a.setting, r.setting);
        assert_eq!(
            a.outcome.map(|o| o.breakdown),
            r.outcome.map(|o| o.breakdown)
        );
    }
    assert_eq!(csv(&back), single);
    let shards: Vec<(String, String)> = (1..=2)
        .map(|k| {
            let shard = Shard::new(k, 2).expect("shard");
            (
                format!("s{k}.csv"),
                csv(&ev.run_collect(&shard.indices(ev.len()))),
            )
        })
        .collect();
    assert_eq!(merge_csv(&shards, Some(4)).expect("merge"), single);
    // A table whose scanning speed is another: located.
    let other = single.replacen(",20000,1,0,,,,ok,", ",30000,1,0,,,,ok,", 1);
    assert_ne!(other, single);
    let err = ev
        .rows_from_csv("other.csv", &other)
        .expect_err("another combination")
        .to_string();
    assert!(
        err.contains("other.csv: line 3: row 1 is prostate-1.json scan")
            && err.contains("scan speed 20000 dose rate 1"),
        "{err}"
    );

    // Not swept: the machine's scanning speed and scale 1 in the columns, null in the setting.
    let text = scanning_setup(&dir, r#"{"jerk_deg_per_s3": [0.5, 1]}"#);
    let ev = Evaluator::new(from_text_in(&text, &dir).expect("sweep")).expect("prepare");
    let rows = all_rows(&ev);
    let table = csv(&rows);
    assert_eq!(column(&table, "scan_speed_mm_per_s"), ["5000", "5000"]);
    assert_eq!(column(&table, "dose_rate_scale"), ["1", "1"]);
    assert_eq!(rows[0].setting.scan_speed_mm_per_s, None);
    assert_eq!(
        ev.rows_from_csv("t.csv", &table).expect("read back").len(),
        2
    );
    // Scale 1 and the machine's own speed are the base machine: the same totals.
    let text = scanning_setup(
        &dir,
        r#"{"scan_speed_mm_per_s": [5000], "dose_rate_scale": [1]}"#,
    );
    let same = Evaluator::new(from_text_in(&text, &dir).expect("sweep")).expect("prepare");
    let same_rows = all_rows(&same);
    assert_eq!(ok(&same_rows[0]).total_s, ok(&rows[0]).total_s);
    assert_eq!(ok(&same_rows[0]).breakdown, ok(&rows[0]).breakdown);

    // Speeds beyond what a machine file accepts (0.001 to 1e6 mm/s) are refused, located.
    for (axes, at) in [
        (r#"{"scan_speed_mm_per_s": [5000, 1e7]}"#, "[1]"),
        (
            r#"{"scan_speed_mm_per_s": {"from": 0.0001, "to": 10, "steps": 3, "scale": "log"}}"#,
            ".from",
        ),
    ] {
        let e = error_of(&scanning_setup(&dir, axes), &dir);
        assert!(
            e.starts_with(&format!("test-sweep.json: axes.scan_speed_mm_per_s{at}: "))
                && e.contains("`beam.scan_speed_mm_per_s`"),
            "{axes}: {e}"
        );
    }
}

/// The burst switching axis on `scenarios/machine-proteusone-like.json`: only the burst switching
/// term of the beam-on time changes, linearly in the pause (each layer pauses once per burst after its first); the
/// column holds the swept value, or the machine's 0.15 s when not swept; the table reads back;
/// a `per_mu` machine refuses the axis, naming the field and the model.
#[test]
fn burst_switching_time_is_swept_on_a_scanning_machine() {
    let dir = scenarios();
    let text = |axes: &str| {
        format!(
            r#"{{"format": "arcsim-sweep/1", "name": "bursts", "plans": ["../plans/lung.json"],
                "machine": "machine-proteusone-like.json", "axes": {axes}, "schedules": ["scan"]}}"#
        )
    };
    let ev = Evaluator::new(
        from_text_in(&text(r#"{"burst_switching_time_s": [0, 0.15, 0.3]}"#), &dir).expect("sweep"),
    )
    .expect("prepare");
    let rows = all_rows(&ev);
    let b: Vec<_> = rows.iter().map(ok).map(|o| o.breakdown).collect();
    assert_eq!(b.len(), 3);
    for x in &b[1..] {
        assert_eq!(x.spot_irradiation_s, b[0].spot_irradiation_s);
        assert_eq!(x.energy_switching_s, b[0].energy_switching_s);
    }
    let (d1, d2) = (
        b[1].burst_switching_s - b[0].burst_switching_s,
        b[2].burst_switching_s - b[0].burst_switching_s,
    );
    assert_eq!(b[0].burst_switching_s, 0.0);
    assert!(b
        .iter()
        .all(|x| x.scanning_s == b[0].scanning_s && x.spill_waiting_s == 0.0));
    assert!(d1 > 1.0, "bursts add {d1} s");
    assert!(close(d2, 2.0 * d1, 1e-9), "{d1} {d2}");
    // A whole number of pauses of 0.15 s.
    let pauses = d1 / 0.15;
    assert!((pauses - pauses.round()).abs() < 1e-6, "{pauses}");
    let table = csv(&rows);
    assert_eq!(
        column(&table, "burst_switching_time_s"),
        ["0", "0.15", "0.3"]
    );
    let back = ev.rows_from_csv("b.csv", &table).expect("read back");
    assert_eq!(csv(&back), table);
    // Not swept: the machine's own.
    let ev = Evaluator::new(from_text_in(&text(r#"{}"#), &dir).expect("sweep")).expect("prepare");
    let base = csv(&all_rows(&ev));
    assert_eq!(column(&base, "burst_switching_time_s"), ["0.15"]);
    assert_eq!(
        column(&base, "total_s"),
        [column(&table, "total_s")[1]],
        "the machine's pause is the swept 0.15 s"
    );
    // A per_mu machine has no bursts.
    let e = error_of(&atom_sweep(r#"{"burst_switching_time_s": [0.1]}"#), &dir);
    assert!(
        e.contains("axes.burst_switching_time_s") && e.contains("per_mu"),
        "{e}"
    );
    let e = error_of(&text(r#"{"burst_switching_time_s": [-0.1]}"#), &dir);
    assert!(e.contains("burst_switching_time_s"), "{e}");
    // The bundled sweep of the README's question: 3 plans × (2·2·2·3 scan + 2·2·3 free) rows.
    let sweep = arcsim_evaluator::Sweep::load(&dir.join("sweep-proteusone.json")).expect("loads");
    assert_eq!(Evaluator::new(sweep).expect("prepare").len(), 108);
}

/// The spill axes on `scenarios/machine-probeat-v5-like-mee.json`: charge and refill time change
/// only the spill waiting and the energy switching (which layers continue a spill); a charge no
/// layer run exhausts never waits, whatever the refill; a shorter refill waits less; a swept row
/// is the row of a machine file with that value; one layer per spill is the machine without
/// multi-energy extraction; machines without spills refuse the axes.
#[test]
fn spill_charge_and_refill_are_swept_on_a_synchrotron() {
    let dir = scenarios();
    let text = |machine: &str, axes: &str| {
        format!(
            r#"{{"format": "arcsim-sweep/1", "name": "spills", "plans": ["{}"],
                "machine": "{machine}", "axes": {axes}, "schedules": ["scan"]}}"#,
            dir.join("../plans/lung.json").display()
        )
    };
    let mee = "machine-probeat-v5-like-mee.json";
    let axes = r#"{"spill_charge_mu": [20, 40, 1000], "spill_refill_time_s": [1.91, 0.5]}"#;
    let ev = Evaluator::new(from_text_in(&text(mee, axes), &dir).expect("sweep")).expect("prepare");
    let rows = all_rows(&ev);
    let b: Vec<_> = rows.iter().map(ok).map(|o| o.breakdown).collect();
    assert_eq!(b.len(), 6);
    for x in &b {
        assert!(close(x.spot_irradiation_s, b[0].spot_irradiation_s, 1e-12));
        assert_eq!(x.scanning_s, b[0].scanning_s);
        let parts = x.spot_irradiation_s + x.scanning_s + x.burst_switching_s + x.spill_waiting_s;
        assert!(close(parts, x.beam_on_s, 1e-12), "{x:?}");
    }
    // Charge fastest: rows 0-2 at refill 1.91 s, rows 3-5 at 0.5 s.
    assert_eq!(b[2].spill_waiting_s, 0.0);
    assert_eq!(b[5].spill_waiting_s, 0.0);
    assert_eq!(ok(&rows[2]).total_s, ok(&rows[5]).total_s);
    for k in 0..2 {
        assert!(b[k].spill_waiting_s > b[k + 3].spill_waiting_s, "{b:?}");
        assert!(b[k + 3].spill_waiting_s > 0.0);
    }
    let table = csv(&rows);
    assert_eq!(
        column(&table, "spill_charge_mu"),
        ["20", "40", "1000", "20", "40", "1000"]
    );
    assert_eq!(column(&table, "spill_refill_time_s")[3], "0.5");
    let back = ev.rows_from_csv("s.csv", &table).expect("read back");
    assert_eq!(csv(&back), table);
    // The swept 20 MU row is the row of a machine file that holds 20 MU.
    let tmp = temp_dir().join("spill-axes");
    std::fs::create_dir_all(&tmp).expect("dir");
    let mut machine: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join(mee)).expect("machine"))
            .expect("json");
    machine["beam"]["spill"]["charge_mu"] = serde_json::json!(20);
    std::fs::write(tmp.join("m20.json"), machine.to_string()).expect("write");
    let own = Evaluator::new(
        from_text_in(&text(&path_of(&tmp.join("m20.json")), "{}"), &dir).expect("sweep"),
    )
    .expect("prepare");
    assert_eq!(ok(&all_rows(&own)[0]).total_s, ok(&rows[0]).total_s);
    // Machines without spills refuse the axes; the values are checked.
    for (machine, kind) in [
        ("machine-atom.json", "per_mu"),
        ("machine-proteusone-like.json", "scanning"),
    ] {
        let e = error_of(&text(machine, r#"{"spill_charge_mu": [20]}"#), &dir);
        assert!(
            e.contains("axes.spill_charge_mu") && e.contains("no spills") && e.contains(kind),
            "{e}"
        );
    }
    // One layer per spill is the machine without multi-energy extraction.
    let layers = r#"{"spill_max_layers": [1, 5]}"#;
    let ev =
        Evaluator::new(from_text_in(&text(mee, layers), &dir).expect("sweep")).expect("prepare");
    let per = all_rows(&ev);
    let plain = text("machine-probeat-v5-like.json", "{}");
    let plain = Evaluator::new(from_text_in(&plain, &dir).expect("sweep")).expect("prepare");
    assert_eq!(ok(&per[0]).total_s, ok(&all_rows(&plain)[0]).total_s);
    assert!(ok(&per[0]).breakdown.energy_switching_s > ok(&per[1]).breakdown.energy_switching_s);
    assert_eq!(column(&csv(&per), "spill_max_layers"), ["1", "5"]);
    // The summary's finite difference of a whole-number axis is taken at L ± 1 (5 ± 10 % was
    // 4.5 and 5.5, applied as 4 and 5: half a step, and "no effect (1–5.5 layers)"), and agrees
    // with the totals simulated there.
    let summary = ev.summarize(&per);
    let layers = summary.entries[0]
        .sensitivity
        .iter()
        .find(|s| s.axis == Axis::SpillMaxLayers)
        .expect("layers per spill");
    assert_eq!((layers.evaluated_min, layers.evaluated_max), (1.0, 6.0));
    let at = |n: &str| {
        let axes = format!(r#"{{"spill_max_layers": [{n}]}}"#);
        let ev =
            Evaluator::new(from_text_in(&text(mee, &axes), &dir).expect("sweep")).expect("prepare");
        ok(&all_rows(&ev)[0]).total_s
    };
    let (t4, t6) = (at("4"), at("6"));
    let want = (t6 - t4) / (6f64 / 4.0).ln() * 1.1f64.ln();
    let got = layers.s_per_10_percent.expect("finite difference");
    assert!((got - want).abs() <= 1e-9 * t4, "{got} vs {want}");
    for (machine, axes, want) in [
        (
            "machine-probeat-v5-like.json",
            r#"{"spill_max_layers": [2]}"#,
            "multi-energy extraction",
        ),
        (
            mee,
            r#"{"spill_max_layers": [0, 2]}"#,
            "spill_max_layers[0]",
        ),
        (mee, r#"{"spill_max_layers": [2.5]}"#, "whole number"),
        (
            mee,
            r#"{"spill_max_layers": {"from": 1, "to": 5, "steps": 5}}"#,
            "not a range",
        ),
    ] {
        let e = error_of(&text(machine, axes), &dir);
        assert!(e.contains("spill_max_layers") && e.contains(want), "{e}");
    }
    let e = error_of(&text(mee, r#"{"spill_charge_mu": [0]}"#), &dir);
    assert!(e.contains("spill_charge_mu"), "{e}");
    let e = error_of(&text(mee, r#"{"spill_refill_time_s": [-1]}"#), &dir);
    assert!(e.contains("spill_refill_time_s"), "{e}");
    // The bundled sweep of the README's question: 3 plans × 2 schedules × 2 × 4 settings.
    let sweep = arcsim_evaluator::Sweep::load(&dir.join("sweep-probeat.json")).expect("loads");
    assert_eq!(Evaluator::new(sweep).expect("prepare").len(), 48);
}

fn path_of(p: &Path) -> String {
    p.to_str().expect("utf-8 path").to_string()
}
