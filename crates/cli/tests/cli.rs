//! End-to-end tests of the `arcsim` binary, run as a user would: exit codes, located messages,
//! outputs with units, and the DICOM round trip.

use crate::util;

use arcsim_test_support::{dicom, temp_dir};

use crate::util::{arcsim, repo, text};

fn total_of(stdout: &str) -> f64 {
    let line = stdout
        .lines()
        .find(|l| l.starts_with("total delivery time"))
        .expect("total line");
    line.split_whitespace()
        .nth(3)
        .expect("value")
        .parse()
        .expect("number")
}

#[test]
fn simulate_bundled_plan_prints_summary_and_writes_outputs() {
    let dir = temp_dir();
    let json = dir.join("r.json");
    let csv = dir.join("t.csv");
    let o = arcsim(&[
        "simulate",
        "plans/prostate.json",
        "--schedule",
        "scan",
        "--json",
        json.to_str().unwrap(),
        "--csv",
        csv.to_str().unwrap(),
        "--dt",
        "0.5",
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    for needle in [
        "total delivery time",
        "beam on",
        "energy switching",
        "lost (gantry)",
        "tightest margins",
        "5 most costly transitions",
    ] {
        assert!(out.contains(needle), "missing '{needle}' in:\n{out}");
    }
    let total = total_of(&out);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("valid json");
    assert!((v["total_s"].as_f64().expect("total_s") - total).abs() < 0.01);
    assert_eq!(v["layers"].as_array().expect("layers").len(), 180);
    assert!(v["transitions"][0]["elst_s"].is_number() && v["layers"][0]["angle_deg"].is_number());
    let csv_text = std::fs::read_to_string(&csv).expect("csv");
    assert!(csv_text.starts_with(
        "t_s,angle_deg,speed_deg_per_s,accel_deg_per_s2,jerk_deg_per_s3,beam_layer,energy_mev"
    ));
    let last_t: f64 = csv_text
        .lines()
        .last()
        .expect("rows")
        .split(',')
        .next()
        .expect("t")
        .parse()
        .expect("number");
    assert!((last_t - v["total_s"].as_f64().expect("total")).abs() < 1e-3);
}

#[test]
fn bad_plan_gets_located_errors_and_exit_1() {
    let dir = temp_dir();
    let bad = dir.join("bad.json");
    let mut plan: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(repo().join("plans/lung.json")).expect("plan"),
    )
    .expect("json");
    plan["arcs"][0]["control_points"][3]["layers"][0]["energy_mev"] = serde_json::json!(900.0);
    plan["arcs"][0]["control_points"][5]["angle_deg"] =
        plan["arcs"][0]["control_points"][4]["angle_deg"].clone();
    std::fs::write(&bad, serde_json::to_string(&plan).expect("json")).expect("write");
    for cmd in ["validate", "simulate"] {
        let o = arcsim(&[cmd, bad.to_str().unwrap()]);
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(1), "{cmd}: {err}");
        assert!(
            err.contains("control point 3") && err.contains("energy_mev"),
            "{cmd}: {err}"
        );
        assert!(
            err.contains("control point 5"),
            "{cmd}: all problems at once: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
    let malformed = dir.join("malformed.json");
    std::fs::write(&malformed, "{\"format\": \"arcsim-plan/1\",\n \"name\": }").expect("write");
    let o = arcsim(&["simulate", malformed.to_str().unwrap()]);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        err.contains("malformed.json:2:10") && err.contains("name"),
        "{err}"
    );
}

#[test]
fn bad_arguments_exit_2() {
    for args in [
        vec!["simulate", "plans/prostate.json", "--schedule", "fastest"],
        vec!["profile", "--distance", "x"],
        vec![
            "profile",
            "--distance",
            "1",
            "--v-start",
            "0",
            "--v-end",
            "0",
            "--jerk",
            "-1",
            "--accel",
            "1",
            "--vel",
            "1",
        ],
        vec!["simulate", "plans/prostate.json", "--dt", "0"],
        vec!["simulate", "plans/prostate.json", "--period", "0"],
        vec!["simulate", "plans/prostate.json", "--period", "NaN"],
    ] {
        let o = arcsim(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", text(&o).1);
    }
}

#[test]
fn profile_single_and_batch() {
    let o = arcsim(&[
        "profile",
        "--distance",
        "0.033",
        "--v-start",
        "0",
        "--v-end",
        "0.03",
        "--jerk",
        "1000",
        "--accel",
        "20",
        "--vel",
        "1.2",
        "--json",
    ]);
    assert!(o.status.success());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert!(
        (v["extreme_speed_deg_per_s"].as_f64().expect("v_m") - 0.6333).abs() < 5e-5,
        "{v}"
    );
    let dir = temp_dir();
    let input = dir.join("moves.csv");
    let output = dir.join("results.csv");
    std::fs::write(&input, "distance,v_start,v_end,jerk,accel,vel,min_duration,reverse\n2,1.5,1.5,0.5,0.5,5,5,\n1.6,0.3,0.3,0.5,0.5,5,5,\nabc,0,0,1,1,1,,\n0,0,0.4,2000,20,1.2,,allow\n").expect("write");
    let o = arcsim(&[
        "profile",
        "--batch",
        input.to_str().unwrap(),
        "--out",
        output.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    let rows: Vec<String> = std::fs::read_to_string(&output)
        .expect("out")
        .lines()
        .map(String::from)
        .collect();
    assert_eq!(rows[0], "line,status,duration_s,peak_speed,message");
    assert!(
        rows[1].starts_with("2,infeasible,") && rows[1].contains("feasible durations"),
        "{}",
        rows[1]
    );
    assert!(rows[2].starts_with("3,ok,5,"), "{}", rows[2]);
    assert!(
        rows[3].starts_with("4,error,") && rows[3].contains("distance"),
        "{}",
        rows[3]
    );
    assert!(rows[4].starts_with("5,ok,"), "{}", rows[4]);
}

/// DICOM → native JSON → simulate gives the same total as simulating the DICOM directly.
#[test]
fn dicom_round_trip_gives_the_same_total() {
    for (name, spec) in [
        ("arc180.dcm", dicom::dynamic_arc_plan()),
        ("two-arc.dcm", dicom::two_arc_plan()),
        ("static.dcm", dicom::static_arc_plan()),
    ] {
        let dcm = spec.write(name);
        let json = dcm.with_extension("json");
        let o = arcsim(&[
            "import",
            dcm.to_str().unwrap(),
            "-o",
            json.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{name}: {}", text(&o).1);
        let direct = arcsim(&["simulate", dcm.to_str().unwrap(), "--schedule", "optimal"]);
        let via_json = arcsim(&["simulate", json.to_str().unwrap(), "--schedule", "optimal"]);
        assert!(
            direct.status.success() && via_json.status.success(),
            "{name}: {} {}",
            text(&direct).1,
            text(&via_json).1
        );
        let (a, b) = (total_of(&text(&direct).0), total_of(&text(&via_json).0));
        assert!(a > 0.0 && a == b, "{name}: {a} vs {b}");
        // Detected by content: the same file under another extension.
        let renamed = dcm.with_extension("bin");
        std::fs::copy(&dcm, &renamed).expect("copy");
        let o = arcsim(&["validate", renamed.to_str().unwrap()]);
        assert!(o.status.success(), "{name}: {}", text(&o).1);
    }
    let photon = dicom::photon_plan().write("photon.dcm");
    let o = arcsim(&["simulate", photon.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        text(&o).1.to_lowercase().contains("photon") || text(&o).1.contains("RT Plan"),
        "{}",
        text(&o).1
    );
}

/// `--period` times every transition on the servo grid: said in the summary, recorded in the
/// JSON, every transition a whole number of periods, never faster than continuous time.
#[test]
fn simulate_on_a_servo_period() {
    let out = temp_dir().join("servo.json");
    let cont = arcsim(&["simulate", "plans/lung.json"]);
    let o = arcsim(&[
        "simulate",
        "plans/lung.json",
        "--period",
        "0.004",
        "--json",
        out.to_str().expect("path"),
    ]);
    let (stdout, stderr) = text(&o);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stdout.contains("whole numbers of a 4.000 ms servo period"),
        "{stdout}"
    );
    assert!(total_of(&stdout) >= total_of(&text(&cont).0));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).expect("json")).expect("valid json");
    assert_eq!(json["servo_period_s"].as_f64(), Some(0.004));
    let transitions = json["transitions"].as_array().expect("transitions");
    assert!(!transitions.is_empty());
    for t in transitions {
        let n = t["duration_s"].as_f64().expect("duration") / 0.004;
        assert!((n - n.round()).abs() <= 1e-6, "{t}");
    }
}

/// `simulate` runs free motion by default and says what it saved; `--motion constant` is ATOM's
/// model; the JSON names both; the CSV shows the speed changing while a layer is irradiated;
/// free arc ends without free motion are refused.
#[test]
fn simulate_free_and_constant_motion() {
    let dir = temp_dir();
    let json = dir.join("free.json");
    let csv = dir.join("free.csv");
    let o = arcsim(&[
        "simulate",
        "plans/prostate.json",
        "--motion",
        "free",
        "--arc-ends",
        "free",
        "--json",
        json.to_str().expect("path"),
        "--csv",
        csv.to_str().expect("path"),
        "--dt",
        "0.01",
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(out.contains("motion free (arc ends free)"), "{out}");
    assert!(out.contains("free motion saves"), "{out}");
    let free_total = total_of(&out);
    // The ATOM machine's own controller is constant speed per layer: free arc ends without
    // --motion free are refused with the way out.
    let refused = arcsim(&["simulate", "plans/prostate.json", "--arc-ends", "free"]);
    assert!(
        !refused.status.success() && text(&refused).1.contains("--motion free"),
        "{}",
        text(&refused).1
    );
    let c = arcsim(&["simulate", "plans/prostate.json"]);
    let (cout, cerr) = text(&c);
    assert!(c.status.success(), "{cerr}");
    assert!(
        cout.contains("motion constant") && !cout.contains("free motion saves"),
        "{cout}"
    );
    let constant_total = total_of(&cout);
    assert!(
        free_total <= constant_total,
        "{free_total} > {constant_total}"
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("valid json");
    assert_eq!(v["motion"], "free");
    assert_eq!(v["arc_ends"], "free");
    assert!(
        (v["constant_speed_total_s"]
            .as_f64()
            .expect("constant total")
            - constant_total)
            .abs()
            < 0.01
    );
    let layer = &v["layers"][5];
    assert!(layer["speed_on_deg_per_s"].is_number() && layer["speed_off_deg_per_s"].is_number());
    // Some layer is irradiated while the speed changes (CSV rows with the same beam layer).
    let text = std::fs::read_to_string(&csv).expect("csv");
    let mut speeds: std::collections::HashMap<String, (f64, f64)> = Default::default();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        if f[5].is_empty() {
            continue;
        }
        let v: f64 = f[2].parse().expect("speed");
        let e = speeds.entry(f[5].to_string()).or_insert((v, v));
        e.0 = e.0.min(v);
        e.1 = e.1.max(v);
    }
    assert!(
        speeds.values().any(|(lo, hi)| hi - lo > 1e-3),
        "no layer with a changing speed while irradiated"
    );
    let bad = arcsim(&[
        "simulate",
        "plans/prostate.json",
        "--motion",
        "constant",
        "--arc-ends",
        "free",
    ]);
    assert_eq!(bad.status.code(), Some(1));
    assert!(util::stderr(&bad).contains("free arc ends need free motion"));
}

/// `--help` explains the summaries' terms (issue "Answers a physicist can read").
#[test]
fn help_explains_the_summaries() {
    let o = arcsim(&["simulate", "--help"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    for needle in [
        "lost (gantry)",
        "beyond their ELST",
        "window slack",
        "ELST slack",
        "tightest margins",
    ] {
        assert!(
            out.contains(needle),
            "simulate --help lacks {needle:?}:\n{out}"
        );
    }
    let o = arcsim(&["sweep", "--help"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let lower = out.to_lowercase();
    for needle in [
        "base [s]",
        "fastest setting",
        "sensitivity",
        "cheapest change",
        "ln(new/base)",
    ] {
        assert!(
            lower.contains(needle),
            "sweep --help lacks {needle:?}:\n{out}"
        );
    }
    // The short help points to the long one.
    let o = arcsim(&["sweep", "-h"]);
    assert!(text(&o).0.contains("arcsim sweep --help"), "{}", text(&o).0);
}

#[test]
fn validate_help_says_it_reads_dicom_and_standard_input() {
    let o = arcsim(&["validate", "--help"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(out.contains("DICOM RT Ion Plan"), "{out}");
    assert!(out.contains("standard input"), "{out}");
}

#[test]
fn generate_plan_to_a_file_says_what_it_wrote() {
    let dir = temp_dir();
    let path = dir.join("prostate.json");
    let o = arcsim(&[
        "generate-plan",
        "--kind",
        "prostate",
        "--seed",
        "1",
        "-o",
        path.to_str().unwrap(),
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert_eq!(
        out.trim_end(),
        format!(
            "wrote prostate plan (seed 1): 1 arc, 180 control points, 180 layers -> {}",
            path.display()
        )
    );
    assert!(std::fs::read_to_string(&path)
        .expect("plan written")
        .contains("arcsim-plan/1"));
    let path = dir.join("two-arc.json");
    let o = arcsim(&[
        "generate-plan",
        "--kind",
        "two-arc",
        "-o",
        path.to_str().unwrap(),
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.starts_with("wrote two-arc plan (seed 1): 2 arcs, "),
        "{out}"
    );
}

#[test]
fn generate_plan_reshapes_a_kind_for_large_plans() {
    let dir = temp_dir();
    let path = dir.join("big.json");
    let o = arcsim(&[
        "generate-plan",
        "--kind",
        "two-arc",
        "--spacing",
        "2.2",
        "--layers",
        "2-4",
        "--energy",
        "70-230",
        "-o",
        path.to_str().unwrap(),
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    // 320 deg per arc every 2.2 deg: 146 control points each (docs/commands.md's figures).
    assert!(
        out.starts_with("wrote two-arc plan (seed 1): 2 arcs, 292 control points, 888 layers"),
        "{out}"
    );
    let plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).expect("plan written")).expect("json");
    let mut layers = 0;
    for arc in plan["arcs"].as_array().expect("arcs") {
        let cps = arc["control_points"].as_array().expect("control points");
        assert_eq!(cps.len(), 146);
        for w in cps.windows(2) {
            let step =
                (w[1]["angle_deg"].as_f64().unwrap() - w[0]["angle_deg"].as_f64().unwrap()).abs();
            assert!((step - 2.2).abs() < 1e-9, "step {step}");
        }
        for cp in cps {
            let ls = cp["layers"].as_array().expect("layers");
            assert!((2..=4).contains(&ls.len()), "{} layers", ls.len());
            layers += ls.len();
            for l in ls {
                let e = l["energy_mev"].as_f64().unwrap();
                assert!((70.0..=230.0).contains(&e), "energy {e}");
            }
        }
    }
    assert!(out.contains(&format!("{layers} layers")), "{out}");
    assert!(
        plan["description"]
            .as_str()
            .unwrap()
            .contains("--spacing 2.2 --layers 2-4 --energy 70-230"),
        "the description says how to make the plan again"
    );
    // The same options and seed make the same file.
    let again = arcsim(&[
        "generate-plan",
        "--kind",
        "two-arc",
        "--spacing",
        "2.2",
        "--layers",
        "2-4",
        "--energy",
        "70-230",
    ]);
    assert_eq!(
        String::from_utf8_lossy(&again.stdout),
        std::fs::read_to_string(&path).unwrap()
    );
    // Out of range: exit 2, the option named with what it takes.
    for (args, says) in [
        (["--spacing", "0"], "--spacing: 0 deg is not allowed"),
        (["--spacing", "400"], "--spacing: 400 deg is not allowed"),
        (["--layers", "4-2"], "--layers: 4-2 is not allowed"),
        (["--layers", "0-3"], "--layers: 0-3 is not allowed"),
        (
            ["--energy", "230-70"],
            "--energy: 230-70 MeV is not allowed",
        ),
        (["--energy", "70"], "is not LOW-HIGH in MeV"),
        (
            ["--layers", "two"],
            "is not MIN-MAX layers per control point",
        ),
    ] {
        let o = arcsim(&[&["generate-plan", "--kind", "two-arc"][..], &args[..]].concat());
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
}

#[test]
fn one_plan_sweep_banner_is_singular() {
    let dir = temp_dir();
    let sweep = util::sweep_file(
        &dir,
        "one",
        "plans/prostate.json",
        serde_json::json!({ "jerk_deg_per_s3": [0.5] }),
    );
    let o = arcsim(&["sweep", sweep.to_str().unwrap(), "--threads", "1"]);
    let (_, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("sweep \"one\": 1 plan, 1 combination, 1 thread\n"),
        "{err}"
    );
    assert!(err.contains("evaluated 1 combination in "), "{err}");
    for plural in ["1 plans", "1 combinations", "1 threads"] {
        assert!(!err.contains(plural), "{err}");
    }
}

/// A sweep with `"certify": true` writes the certificate's columns and names its largest gap.
#[test]
fn certified_sweep_writes_the_columns_and_the_largest_gap() {
    let dir = temp_dir();
    let sweep = util::sweep_file(
        &dir,
        "certified",
        "plans/lung.json",
        serde_json::json!({ "jerk_deg_per_s3": [1] }),
    );
    let mut file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&sweep).expect("read")).expect("json");
    file["certify"] = serde_json::Value::Bool(true);
    std::fs::write(&sweep, file.to_string()).expect("write");
    let out_csv = dir.join("certified.csv");
    let o = arcsim(&[
        "sweep",
        sweep.to_str().unwrap(),
        "--out",
        out_csv.to_str().unwrap(),
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("certificate: 1 constant-speed rows bounded; largest gap "),
        "{out}"
    );
    let table = std::fs::read_to_string(&out_csv).expect("csv");
    let mut lines = table.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let row: Vec<&str> = lines.next().expect("row").split(',').collect();
    let col = |name: &str| -> f64 {
        let i = header.iter().position(|h| *h == name).expect(name);
        row[i].parse().expect(name)
    };
    let (total, bound, gap) = (col("total_s"), col("lower_bound_s"), col("gap_s"));
    assert!(
        bound > 0.0 && bound <= total && gap >= 0.0,
        "{total} {bound} {gap}"
    );
    assert!((total - bound - gap).abs() <= 1e-9 * total);
}

/// `--certify` prints a lower bound of every constant-speed schedule and the gap to it, writes
/// both with --json, and holds on a servo period too; with free motion it bounds every free
/// motion, below the free total and above every beam and ELST in sequence.
#[test]
fn simulate_certify_prints_and_writes_the_bound() {
    let dir = temp_dir();
    let json = dir.join("c.json");
    let value = |out: &str, label: &str| -> f64 {
        let line = out
            .lines()
            .find(|l| l.starts_with(label))
            .unwrap_or_else(|| panic!("no '{label}' line in:\n{out}"));
        line.split_whitespace()
            .nth(label.split_whitespace().count())
            .expect("value")
            .parse()
            .expect("number")
    };
    for period in [None, Some("0.004")] {
        let mut args = vec![
            "simulate",
            "plans/lung.json",
            "--motion",
            "constant",
            "--certify",
            "--json",
            json.to_str().unwrap(),
        ];
        args.extend(period.iter().flat_map(|p| ["--period", *p]));
        let o = arcsim(&args);
        let (out, err) = text(&o);
        assert!(o.status.success(), "{err}");
        let (total, bound, gap) = (
            total_of(&out),
            value(&out, "lower bound"),
            value(&out, "gap"),
        );
        assert!(bound <= total && bound > 0.9 * total, "{out}");
        assert!((total - bound - gap).abs() < 0.011, "{out}");
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("json");
        let c = &v["certificate"];
        let (lb, g) = (
            c["lower_bound_s"].as_f64().expect("lower_bound_s"),
            c["gap_s"].as_f64().expect("gap_s"),
        );
        let t = v["total_s"].as_f64().expect("total_s");
        assert!(g >= 0.0 && (t - lb - g).abs() < 1e-9, "{c}");
    }
    let o = arcsim(&[
        "simulate",
        "plans/lung.json",
        "--motion",
        "free",
        "--certify",
        "--json",
        json.to_str().unwrap(),
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("(no free motion is faster; a loose bound)"),
        "{out}"
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("json");
    let (lb, g, t) = (
        v["certificate"]["lower_bound_s"].as_f64().expect("bound"),
        v["certificate"]["gap_s"].as_f64().expect("gap"),
        v["total_s"].as_f64().expect("total"),
    );
    let b = &v["breakdown"];
    let floor =
        b["beam_on_s"].as_f64().expect("beam") + b["energy_switching_s"].as_f64().expect("elst");
    assert!(lb <= t && lb >= floor * (1.0 - 1e-8), "{lb} {floor} {t}");
    assert!((t - lb - g).abs() < 1e-9 * t);
    assert_eq!(v["motion"], "free", "{v}");
}
