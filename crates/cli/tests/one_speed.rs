//! One speed per arc through every command that takes a controller: the figures docs/model.md
//! quotes, a machine file that names it, a sweep entry, and the refusals (a servo period, a
//! calibration under it) with their reasons.

use arcsim_test_support::temp_dir;

use crate::util::{arcsim, path_str, repo, text};

fn model_doc() -> String {
    std::fs::read_to_string(repo().join("docs/model.md")).expect("docs/model.md")
}

/// docs/model.md's prostate figures: 936.07 s at 0.38 °/s against 273.85 s, the speed set by the
/// cruises that must last a 5 s upward switch (their ELST slack 0).
#[test]
fn the_model_doc_s_one_speed_figures_are_what_simulate_prints() {
    let dir = temp_dir().join("one-speed-doc");
    std::fs::create_dir_all(&dir).expect("dir");
    let json = dir.join("prostate.json");
    let out = arcsim(&[
        "simulate",
        "plans/prostate.json",
        "--motion",
        "one-speed",
        "--json",
        path_str(&json),
    ]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stderr}");
    for line in [
        "motion one-speed",
        "total delivery time     936.07 s",
        "against constant speed per layer (273.85 s)",
        "ELST slack     0.0000 s",
        "what-if: free motion (speed may change during beam-on) with --motion free",
    ] {
        assert!(stdout.contains(line), "{line:?} not in\n{stdout}");
    }
    let d: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("parses");
    assert_eq!(d["motion"], "one-speed");
    let layers = d["layers"].as_array().expect("layers");
    let omega = layers[1]["speed_deg_per_s"].as_f64().expect("speed");
    assert!((omega - 0.38).abs() < 0.005, "{omega}");
    // Ten upward switches of 5 s, each 2° after the layer before.
    let ups = d["transitions"]
        .as_array()
        .expect("transitions")
        .iter()
        .filter(|t| t["elst_s"].as_f64() == Some(5.0))
        .count();
    assert_eq!(ups, 10);
    let doc = model_doc();
    for figure in [
        "0.38 °/s and takes 936.07 s, against 273.85 s",
        "10 upward switches of 5 s",
    ] {
        assert!(doc.contains(figure), "docs/model.md lacks {figure:?}");
    }
}

/// A machine whose file names one speed per arc is simulated under it with no option, and the
/// summary says where the controller came from; a sweep entry runs it and names it.
#[test]
fn a_machine_and_a_sweep_entry_can_name_one_speed() {
    let dir = temp_dir().join("one-speed-machine");
    std::fs::create_dir_all(&dir).expect("dir");
    let text_of = std::fs::read_to_string(repo().join("scenarios/machine-atom.json")).expect("m");
    let mut m: serde_json::Value = serde_json::from_str(&text_of).expect("machine json");
    m["name"] = "atom-one-speed".into();
    m["controller"] = serde_json::json!({
        "motion": "one-speed",
        "schedule": "optimal",
        "source": "assumed: a test of the one-speed controller"
    });
    let machine = dir.join("machine.json");
    std::fs::write(&machine, serde_json::to_string_pretty(&m).expect("json")).expect("write");
    let out = arcsim(&[
        "simulate",
        "plans/prostate.json",
        "--machine",
        path_str(&machine),
    ]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stdout.contains("motion one-speed") && stdout.contains("total delivery time     936.07 s"),
        "{stdout}"
    );
    assert!(
        stdout.contains("a test of the one-speed controller"),
        "{stdout}"
    );
    // A sweep: the machine's controller by default, and named explicitly.
    let sweep = dir.join("sweep.json");
    let plan = repo().join("plans/prostate.json");
    let spec = serde_json::json!({
        "format": "arcsim-sweep/1",
        "name": "one-speed",
        "plans": [path_str(&plan)],
        "machine": path_str(&machine),
        "axes": {"speed_deg_per_s": [5, 6]},
        "schedules": ["optimal", {"schedule": "optimal", "motion": "constant"}]
    });
    std::fs::write(&sweep, spec.to_string()).expect("write sweep");
    let csv = dir.join("sweep.csv");
    let out = arcsim(&["sweep", path_str(&sweep), "--out", path_str(&csv)]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    let table = std::fs::read_to_string(&csv).expect("csv");
    let mut lines = table.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let (schedule, total) = (col("schedule"), col("total_s"));
    let mut seen = Vec::new();
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        let t: f64 = cells[total].parse().expect("total");
        seen.push((cells[schedule].to_string(), (100.0 * t).round() / 100.0));
    }
    // V 5 and 6 alike: the arc's speed (0.38 °/s) is set by the cruises, not by V.
    for name_total in [("optimal+one-speed", 936.07), ("optimal", 273.85)] {
        let n = seen
            .iter()
            .filter(|(s, t)| s == name_total.0 && *t == name_total.1)
            .count();
        assert_eq!(n, 2, "{name_total:?} in {seen:?}");
    }
}

/// What one speed per arc cannot do is refused with the reason and a way out, and writes nothing.
#[test]
fn one_speed_refuses_a_servo_period_and_a_calibration() {
    let out = arcsim(&[
        "simulate",
        "plans/prostate.json",
        "--motion",
        "one-speed",
        "--period",
        "0.004",
    ]);
    let (_, stderr) = text(&out);
    assert!(!out.status.success());
    assert!(
        stderr.contains("continuous-time only") && stderr.contains("--motion constant"),
        "{stderr}"
    );
    let dir = temp_dir().join("one-speed-calibrate");
    std::fs::create_dir_all(&dir).expect("dir");
    let log = dir.join("log.csv");
    let out = arcsim(&["simulate", "plans/lung.json", "--log", path_str(&log)]);
    assert!(out.status.success(), "{}", text(&out).1);
    let fitted = dir.join("fitted.json");
    let out = arcsim(&[
        "calibrate",
        "--machine",
        "scenarios/machine-atom.json",
        "--motion",
        "one-speed",
        "plans/lung.json",
        path_str(&log),
        "-o",
        path_str(&fitted),
    ]);
    let (_, stderr) = text(&out);
    assert!(!out.status.success());
    assert!(
        stderr.contains("calibration under one constant speed per arc")
            && stderr.contains("constant or free"),
        "{stderr}"
    );
    assert!(!fitted.exists());
    // An unknown motion names every model.
    let out = arcsim(&["simulate", "plans/prostate.json", "--motion", "fast"]);
    let (_, stderr) = text(&out);
    assert!(stderr.contains("constant, free or one-speed"), "{stderr}");
}
