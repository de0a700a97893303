//! Answers a physicist can read: where the lost time goes (by cause and place), plausibility
//! warnings for likely unit slips, one message per kind of problem, and results that say what
//! produced them. Run on the bundled plans and a DICOM fixture, as a user would.

use crate::util;

use std::collections::HashMap;
use std::path::Path;

use arcsim_test_support::{dicom, temp_dir, temp_file};
use serde_json::Value;

use crate::util::{arcsim, path_str as s, repo, text as out};

fn json_of(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("result")).expect("json")
}

/// Regroups the result's transitions independently (limit, energy direction, control points
/// apart) and checks the `lost_time` block against it: counts, seconds, costliest order.
fn check_lost_time(v: &Value) {
    let layers = v["layers"].as_array().expect("layers");
    let mut expect: HashMap<(String, String, String), (usize, f64)> = HashMap::new();
    let mut lost: Vec<f64> = Vec::new();
    for t in v["transitions"].as_array().expect("transitions") {
        let l = t["lost_s"].as_f64().expect("lost");
        if l <= 1e-9 {
            continue;
        }
        lost.push(l);
        let (a, b) = (
            &layers[t["from_layer"].as_u64().expect("from") as usize],
            &layers[t["to_layer"].as_u64().expect("to") as usize],
        );
        let (ea, eb) = (
            a["energy_mev"].as_f64().unwrap(),
            b["energy_mev"].as_f64().unwrap(),
        );
        let switch = if a["arc"] != b["arc"] {
            "arc_change"
        } else if eb > ea + 1e-6 {
            "up"
        } else if eb < ea - 1e-6 {
            "down"
        } else {
            "same"
        };
        let (ca, cb) = (
            a["control_point"].as_u64().unwrap(),
            b["control_point"].as_u64().unwrap(),
        );
        let gap = if a["arc"] != b["arc"] || cb > ca + 1 {
            "further"
        } else if ca == cb {
            "same_control_point"
        } else {
            "next_control_point"
        };
        let key = (
            t["limited_by"].as_str().unwrap().to_string(),
            switch.to_string(),
            gap.to_string(),
        );
        let e = expect.entry(key).or_default();
        e.0 += 1;
        e.1 += l;
    }
    let lt = &v["lost_time"];
    assert_eq!(lt["count"].as_u64().unwrap() as usize, lost.len());
    let total = v["breakdown"]["lost_s"].as_f64().unwrap();
    assert!((lt["total_s"].as_f64().unwrap() - total).abs() < 1e-6 * (1.0 + total));
    let groups = lt["groups"].as_array().expect("groups");
    assert_eq!(groups.len(), expect.len());
    let mut previous = f64::INFINITY;
    for g in groups {
        let key = (
            g["limited_by"].as_str().unwrap().to_string(),
            g["switch"].as_str().unwrap().to_string(),
            g["gap"].as_str().unwrap().to_string(),
        );
        let (count, seconds) = expect[&key];
        assert_eq!(g["count"].as_u64().unwrap() as usize, count, "{key:?}");
        let got = g["lost_s"].as_f64().unwrap();
        assert!((got - seconds).abs() < 1e-9 * (1.0 + seconds), "{key:?}");
        assert!(got <= previous, "groups sorted by lost time");
        previous = got;
        assert!(!g["angle_ranges_deg"].as_array().unwrap().is_empty());
    }
    lost.sort_by(|a, b| b.total_cmp(a));
    let costliest = lt["costliest"].as_array().expect("costliest");
    assert_eq!(costliest.len(), lost.len().min(5));
    for (c, want) in costliest.iter().zip(&lost) {
        assert_eq!(c["lost_s"].as_f64().unwrap(), *want);
        let t = &v["transitions"][c["transition"].as_u64().unwrap() as usize];
        let from = &layers[t["from_layer"].as_u64().unwrap() as usize];
        assert_eq!(c["from_control_point"], from["control_point"]);
        assert_eq!(c["from_angle_deg"], from["angle_deg"]);
    }
}

#[test]
fn simulate_says_where_the_time_is_lost() {
    let dir = temp_dir();
    let json = dir.join("r.json");
    let o = arcsim(&[
        "simulate",
        "plans/prostate.json",
        "--schedule",
        "scan",
        "--motion",
        "constant",
        "--json",
        s(&json),
    ]);
    let (stdout, stderr) = out(&o);
    assert!(o.status.success(), "{stderr}");
    assert!(stdout.contains("where the time is lost:"), "{stdout}");
    assert!(
        stdout.contains("limit  switch      layers apart"),
        "{stdout}"
    );
    assert!(stdout.contains("next control point"), "{stdout}");
    assert!(stdout.contains("most costly transitions:"), "{stdout}");
    assert!(
        stdout.contains("arc  control point   angle (deg)"),
        "{stdout}"
    );
    let v = json_of(&json);
    check_lost_time(&v);

    // The same on a DICOM arc (free motion, the default).
    let dcm = temp_file("arc.dcm", &dicom::dynamic_arc_plan().to_bytes());
    let json = dir.join("d.json");
    let o = arcsim(&["simulate", s(&dcm), "--json", s(&json)]);
    let (stdout, stderr) = out(&o);
    assert!(o.status.success(), "{stderr}");
    assert!(stdout.contains("where the time is lost") || stdout.contains("no time lost"));
    check_lost_time(&json_of(&json));
}

#[test]
fn results_say_what_produced_them() {
    let dir = temp_dir();
    let json = dir.join("r.json");
    let o = arcsim(&[
        "simulate",
        "plans/prostate.json",
        "--schedule",
        "prescribed",
        "--json",
        s(&json),
    ]);
    let (_, stderr) = out(&o);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains("note: the plan prescribes no speeds"),
        "{stderr}"
    );
    let v = json_of(&json);
    assert!(v["notes"][0]
        .as_str()
        .unwrap()
        .contains("prescribes no speeds"));
    assert_eq!(v["arcsim_version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(v["options"]["schedule"], "prescribed");
    assert_eq!(v["options"]["motion"], "constant");
    assert_eq!(v["machine_model"]["gantry"]["max_jerk_deg_per_s3"], 0.5);
    assert_eq!(v["machine_file"], "built-in scenarios/machine-atom.json");
    // Hashes tell differently edited files apart.
    let plan_hash = v["plan_sha256"].as_str().unwrap().to_string();
    assert_eq!(plan_hash.len(), 64);
    let mut machine: Value = serde_json::from_str(
        &std::fs::read_to_string(repo().join("scenarios/machine-atom.json")).unwrap(),
    )
    .unwrap();
    let built_in = v["machine_sha256"].as_str().unwrap().to_string();
    machine["gantry"]["max_jerk_deg_per_s3"] = serde_json::json!(0.6);
    let m = dir.join("atom-edited.json");
    std::fs::write(&m, machine.to_string()).unwrap();
    let o = arcsim(&[
        "simulate",
        "plans/prostate.json",
        "--machine",
        s(&m),
        "--schedule",
        "scan",
        "--json",
        s(&json),
    ]);
    assert!(o.status.success());
    let w = json_of(&json);
    assert_eq!(w["machine"], "atom");
    assert_ne!(w["machine_sha256"].as_str().unwrap(), built_in);
    assert_eq!(w["plan_sha256"].as_str().unwrap(), plan_hash);
}

#[test]
fn unit_slips_warn_and_strict_refuses() {
    let dir = temp_dir();
    let mut machine: Value = serde_json::from_str(
        &std::fs::read_to_string(repo().join("scenarios/machine-atom.json")).unwrap(),
    )
    .unwrap();
    machine["elst"]["up_s"] = serde_json::json!(5000.0);
    machine["elst"]["down_s"] = serde_json::json!(500.0);
    machine["gantry"]["max_speed_deg_per_s"] = serde_json::json!(0.087);
    let m = dir.join("ms.json");
    std::fs::write(&m, machine.to_string()).unwrap();
    let json = dir.join("r.json");
    let o = arcsim(&[
        "simulate",
        "plans/prostate.json",
        "--machine",
        s(&m),
        "--schedule",
        "scan",
        "--motion",
        "constant",
        "--json",
        s(&json),
    ]);
    let (_, stderr) = out(&o);
    assert!(o.status.success(), "{stderr}");
    for needle in [
        "warning: ",
        "elst.up_s: 5000 s is outside the plausible 0–60 s; given in milliseconds?",
        "elst.down_s: 500 s",
        "gantry.max_speed_deg_per_s: 0.087 deg/s is outside the plausible 0.1–30 deg/s; given in rad?",
    ] {
        assert!(stderr.contains(needle), "{needle:?} not in {stderr}");
    }
    assert_eq!(json_of(&json)["warnings"].as_array().unwrap().len(), 3);
    let o = arcsim(&[
        "simulate",
        "plans/prostate.json",
        "--machine",
        s(&m),
        "--strict",
    ]);
    let (_, stderr) = out(&o);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("--strict: 3 implausible values"),
        "{stderr}"
    );
    // `validate` warns the same way, and refuses with --strict.
    let o = arcsim(&["validate", "plans/prostate.json", "--machine", s(&m)]);
    assert!(o.status.success());
    assert!(out(&o).1.contains("elst.up_s: 5000 s"), "{}", out(&o).1);
    let o = arcsim(&[
        "validate",
        "plans/prostate.json",
        "--machine",
        s(&m),
        "--strict",
    ]);
    assert_eq!(o.status.code(), Some(1));
    // A servo period meant as ms.
    let o = arcsim(&["simulate", "plans/prostate.json", "--period", "0.5"]);
    let (_, stderr) = out(&o);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains("--period: 0.5 s is outside the plausible 0.0001–0.1 s"),
        "{stderr}"
    );
    // A plausible machine gives no warning.
    let o = arcsim(&["simulate", "plans/prostate.json", "--schedule", "scan"]);
    assert!(!out(&o).1.contains("warning"), "{}", out(&o).1);
}

#[test]
fn one_cause_one_message() {
    let dir = temp_dir();
    let mut plan: Value =
        serde_json::from_str(&std::fs::read_to_string(repo().join("plans/prostate.json")).unwrap())
            .unwrap();
    for cp in plan["arcs"][0]["control_points"].as_array_mut().unwrap() {
        for layer in cp["layers"].as_array_mut().unwrap() {
            let e = layer["energy_mev"].as_f64().unwrap();
            layer["energy_mev"] = serde_json::json!(e * 1000.0);
        }
    }
    let p = dir.join("kev.json");
    std::fs::write(&p, plan.to_string()).unwrap();
    let o = arcsim(&["validate", s(&p)]);
    let (_, stderr) = out(&o);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr.contains("180 problems"), "{stderr}");
    assert!(stderr.contains("given in keV?"), "{stderr}");
    assert!(stderr.contains("and 179 more like it:"), "{stderr}");
    assert!(stderr.lines().count() <= 4, "{stderr}");

    // 3-degree windows on a 2-degree arc: grouped, no float noise.
    let mut plan: Value =
        serde_json::from_str(&std::fs::read_to_string(repo().join("plans/prostate.json")).unwrap())
            .unwrap();
    for cp in plan["arcs"][0]["control_points"].as_array_mut().unwrap() {
        cp["window_deg"] = serde_json::json!(2.0100000000000002);
    }
    std::fs::write(&p, plan.to_string()).unwrap();
    let o = arcsim(&["validate", s(&p)]);
    let (_, stderr) = out(&o);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr.contains("window 2.01 deg is wider than the 2 deg spacing"),
        "{stderr}"
    );
    assert!(!stderr.contains("2.0100000000000002"), "{stderr}");
    assert!(stderr.lines().count() <= 4, "{stderr}");

    // A DICOM arc 0.5 deg apart: the machine's default window is blamed, by its field name.
    let beam = dicom::BeamSpec::from_layers(
        1,
        "DYNAMIC",
        "CW",
        100.0,
        &dicom::dynamic_arc_layers(10.0, 0.5, 12),
    );
    let dcm = temp_file(
        "narrow.dcm",
        &dicom::PlanSpec::ion("NARROW", vec![beam]).to_bytes(),
    );
    let o = arcsim(&["simulate", s(&dcm)]);
    let (_, stderr) = out(&o);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("machine field `default_window_deg`")
            && stderr.contains("lower the machine's default_window_deg to at most 0.5 deg"),
        "{stderr}"
    );
}

/// Sweeps: a limit without effect is said so, ties go to the base machine (lung: V 3, 5 and 6
/// give the same time, so the fastest setting keeps V 5), and every limit column of the CSV
/// holds the value used.
#[test]
fn sweep_ties_no_effect_and_limit_columns() {
    let dir = temp_dir();
    let path = util::sweep_file(
        &dir,
        "ties",
        "plans/lung.json",
        serde_json::json!({ "jerk_deg_per_s3": [0.5, 1], "speed_deg_per_s": [3, 5, 6] }),
    );
    let csv = dir.join("ties.csv");
    let o = arcsim(&["sweep", s(&path), "--out", s(&csv)]);
    let (stdout, stderr) = out(&o);
    assert!(o.status.success(), "{stderr}");
    assert!(stderr.contains("1 plan,"), "{stderr}");
    let fastest = stdout
        .lines()
        .find(|l| l.contains("lung.json") && l.contains("scan"))
        .expect("fastest row");
    assert!(fastest.ends_with("J 1, A 0.5, V 5"), "{fastest}");
    assert!(stdout.contains("no effect (3–6 deg/s)"), "{stdout}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let row: Vec<&str> = lines.next().unwrap().split(',').collect();
    for (col, want) in [
        ("elst_up_s", "5"),
        ("elst_down_s", "0.5"),
        ("window_deg", "1"),
    ] {
        let i = header.iter().position(|h| *h == col).expect(col);
        assert_eq!(row[i], want, "{col}");
    }
}
