//! `compare`, `calibrate` and `simulate --monte-carlo` end to end, as a user runs them: logs
//! written by `simulate --log` on a machine the test makes up, compared, fitted and drawn; bad
//! inputs refused with nothing written.

use std::path::{Path, PathBuf};

use arcsim_test_support::{temp_dir, HIDDEN_MACHINE_JSON};
use serde_json::Value;

use crate::util::{arcsim, path_str, text};

fn dir(name: &str) -> PathBuf {
    let d = temp_dir().join(name);
    std::fs::create_dir_all(&d).expect("dir");
    d
}

/// `plans/PLAN.json` simulated on the hidden machine (free motion) and logged into `dir`.
fn log_of(dir: &Path, plan: &str) -> PathBuf {
    let machine = dir.join("hidden.json");
    std::fs::write(&machine, HIDDEN_MACHINE_JSON).expect("machine");
    let log = dir.join(format!("{plan}.log.csv"));
    let out = arcsim(&[
        "simulate",
        &format!("plans/{plan}.json"),
        "--machine",
        path_str(&machine),
        "--log",
        path_str(&log),
        "--angle-noise-deg",
        "0.01",
        "--seed",
        "4",
    ]);
    assert!(out.status.success(), "{}", text(&out).1);
    log
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("written")).expect("JSON")
}

#[test]
fn compare_sets_a_log_beside_its_simulation() {
    let d = dir("compare-cli");
    let log = log_of(&d, "lung");
    let (out_json, out_rrd) = (d.join("cmp.json"), d.join("cmp.rrd"));
    let out = arcsim(&[
        "compare",
        "plans/lung.json",
        path_str(&log),
        "--machine",
        path_str(&d.join("hidden.json")),
        "--json",
        path_str(&out_json),
        "--rrd",
        path_str(&out_rrd),
    ]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stderr}");
    for line in [
        "88 layers matched; 0 interrupted (0 interruptions); 0 machine pauses",
        "the log fits free motion better",
        "downward switch",
        "gantry observed (local polynomial fits over 2 s",
    ] {
        assert!(stdout.contains(line), "{line:?} in\n{stdout}");
    }
    let doc = json(&out_json);
    assert_eq!(doc["format"], "arcsim-compare/1");
    let layers = doc["layers"].as_array().expect("layers");
    assert_eq!(layers.len(), 88);
    for l in layers {
        let d = l["logged_start_s"].as_f64().expect("start")
            - l["simulated_start_s"].as_f64().expect("start");
        assert!(d.abs() <= 0.01 + 1e-9, "{l}");
    }
    assert!(doc["difference_s"].as_f64().expect("difference").abs() <= 0.01 + 1e-9);
    assert!(std::fs::metadata(&out_rrd).expect("rrd").len() > 1000);
    // The same log under a vendor's column names reads through --columns.
    let original = std::fs::read_to_string(&log).expect("log");
    let renamed = d.join("vendor.csv");
    let body = original.replacen(
        "t_s,gantry_angle_deg,beam_on,energy_mev",
        "TIME,GantryAngle,Beam,Energy",
        1,
    );
    std::fs::write(&renamed, body).expect("renamed");
    let out = arcsim(&[
        "compare",
        "plans/lung.json",
        path_str(&renamed),
        "--machine",
        path_str(&d.join("hidden.json")),
        "--columns",
        "t_s=TIME,gantry_angle_deg=GantryAngle,beam_on=Beam,energy_mev=Energy",
    ]);
    let (again, stderr) = text(&out);
    assert!(out.status.success(), "{stderr}");
    let totals = |s: &str| {
        s.lines()
            .find(|l| l.starts_with("difference of the totals"))
            .map(str::to_string)
    };
    assert!(
        totals(&again).is_some() && totals(&again) == totals(&stdout),
        "{again}"
    );
}

#[test]
fn compare_refuses_a_log_of_another_plan_and_writes_nothing() {
    let d = dir("compare-cli-other");
    let log = log_of(&d, "lung");
    let out_json = d.join("never.json");
    let out = arcsim(&[
        "compare",
        "plans/prostate.json",
        path_str(&log),
        "--json",
        path_str(&out_json),
    ]);
    let stderr = text(&out).1;
    assert!(!out.status.success());
    assert!(
        stderr.contains("log has 88 beam-on segments, the plan 180 layers; the first that differs is at t = 0.000 s: 195.7 MeV in the log, 170.6 MeV in the plan"),
        "{stderr}"
    );
    assert!(!out_json.exists());
    // Bad logs are located and refused the same way.
    for (name, body, says) in [
        (
            "unsorted",
            "t_s,gantry_angle_deg,beam_on\n0,150,1\n0.2,150,1\n0.1,150,1\n",
            "line 4",
        ),
        (
            "repeated",
            "t_s,gantry_angle_deg,beam_on\n0,150,1\n0,150,1\n",
            "line 3",
        ),
        ("nan", "t_s,gantry_angle_deg,beam_on\n0,NaN,1\n", "line 2"),
        ("missing", "t_s,beam_on\n0,1\n", "gantry_angle_deg"),
        ("empty", "", "empty"),
    ] {
        let bad = d.join(format!("{name}.csv"));
        std::fs::write(&bad, body).expect("bad log");
        let out = arcsim(&[
            "compare",
            "plans/lung.json",
            path_str(&bad),
            "--json",
            path_str(&out_json),
        ]);
        let stderr = text(&out).1;
        assert!(
            !out.status.success() && stderr.contains(says) && stderr.contains(name),
            "{name}: {stderr}"
        );
        assert!(!out_json.exists(), "{name}");
    }
    // A 1 GiB log (sparse) is refused with its size before it is read.
    let huge = d.join("huge.csv");
    std::fs::File::create(&huge)
        .and_then(|f| f.set_len(1 << 30))
        .expect("sparse file");
    let out = arcsim(&[
        "compare",
        "plans/lung.json",
        path_str(&huge),
        "--json",
        path_str(&out_json),
    ]);
    let stderr = text(&out).1;
    assert!(
        !out.status.success() && stderr.contains("1073741824"),
        "{stderr}"
    );
    assert!(!out_json.exists());
    let _ = std::fs::remove_file(&huge);
}

#[test]
fn calibrate_fits_a_machine_that_simulate_reads_and_draws() {
    let d = dir("calibrate-cli");
    let logs: Vec<PathBuf> = ["lung", "two-arc"].iter().map(|p| log_of(&d, p)).collect();
    let (fitted, report) = (d.join("fitted.json"), d.join("report.json"));
    let out = arcsim(&[
        "calibrate",
        "--machine",
        "scenarios/machine-atom.json",
        "plans/lung.json",
        path_str(&logs[0]),
        "plans/two-arc.json",
        path_str(&logs[1]),
        "-o",
        path_str(&fitted),
        "--json",
        path_str(&report),
    ]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stdout.contains("elst.up_s") && stdout.contains("residuals"),
        "{stdout}"
    );
    let m = json(&fitted);
    // The logs are of a free-motion machine; the ATOM base is constant speed per layer: the
    // calibration learns the controller and writes it with its evidence.
    assert_eq!(m["controller"]["motion"], "free", "{}", m["controller"]);
    assert_eq!(m["controller"]["evidence"]["decision"], "chosen");
    assert!(stdout.contains("controller: free motion"), "{stdout}");
    let within = |x: &Value, truth: f64, tol: f64| {
        let x = x.as_f64().expect("number");
        assert!((x / truth - 1.0).abs() <= tol, "{x} vs {truth}");
    };
    within(&m["elst"]["up_s"], 3.2, 0.02);
    within(&m["elst"]["down_s"], 0.8, 0.02);
    within(&m["beam"]["s_per_mu"], 0.004, 0.02);
    within(&m["gantry"]["max_accel_deg_per_s2"], 0.3, 0.05);
    let sources = m["sources"].as_array().expect("sources");
    assert!(sources
        .iter()
        .any(|s| s.as_str().is_some_and(|s| s.contains("lung.log.csv"))));
    assert!(m["description"]
        .as_str()
        .expect("description")
        .contains("Fitted: "));
    let r = json(&report);
    assert_eq!(r["format"], "arcsim-calibration/1");
    for res in r["residuals"].as_array().expect("residuals") {
        let (b, f) = (
            res["base_error_pct"].as_f64().expect("b"),
            res["fitted_error_pct"].as_f64().expect("f"),
        );
        assert!(f.abs() < 1.0 && f.abs() < b.abs(), "{res}");
    }
    // These logs have no jitter: the spreads measured are (close to) none. With spreads set, a
    // Monte Carlo of a plan draws them.
    let spread = &m["spread"];
    assert!(
        spread["elst_down_sd_s"].as_f64().expect("sd") < 0.01,
        "{spread}"
    );
    let mut jittery = m.clone();
    jittery["spread"] = serde_json::json!({
        "elst_up_sd_s": 0.1, "elst_down_sd_s": 0.03, "beam_time_sd_fraction": 0.02
    });
    let fitted = d.join("jittery.json");
    std::fs::write(&fitted, jittery.to_string()).expect("machine");
    let mc = d.join("mc.json");
    let out = arcsim(&[
        "simulate",
        "plans/lung.json",
        "--machine",
        path_str(&fitted),
        "--monte-carlo",
        "8",
        "--seed",
        "2",
        "--json",
        path_str(&mc),
    ]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stderr}");
    assert!(stdout.contains("Monte Carlo, 8 draws (seed 2"), "{stdout}");
    let doc = json(&mc);
    let p = |k: &str| doc["monte_carlo"][k].as_f64().expect(k);
    assert!(
        p("p5_s") <= p("p50_s") && p("p50_s") <= p("p95_s"),
        "{}",
        doc["monte_carlo"]
    );
    assert!(p("sd_s") > 0.0);
    assert_eq!(
        doc["monte_carlo"]["totals_s"]
            .as_array()
            .expect("totals")
            .len(),
        8
    );
}

#[test]
fn calibrate_and_monte_carlo_refuse_what_they_cannot_use_and_write_nothing() {
    let d = dir("calibrate-cli-bad");
    let fitted = d.join("never.json");
    let out = arcsim(&[
        "calibrate",
        "--machine",
        "scenarios/machine-atom.json",
        "plans/lung.json",
        "plans/lung.json",
        "plans/prostate.json",
        "-o",
        path_str(&fitted),
    ]);
    let stderr = text(&out).1;
    assert!(
        !out.status.success()
            && stderr.contains("expected pairs of a plan and its log, got 3 paths"),
        "{stderr}"
    );
    let log = log_of(&d, "lung");
    let out = arcsim(&[
        "calibrate",
        "--machine",
        "scenarios/machine-atom.json",
        "plans/prostate.json",
        path_str(&log),
        "-o",
        path_str(&fitted),
    ]);
    let stderr = text(&out).1;
    assert!(
        !out.status.success() && stderr.contains("the first that differs"),
        "{stderr}"
    );
    assert!(!fitted.exists());
    let mc = d.join("mc.json");
    let out = arcsim(&[
        "simulate",
        "plans/lung.json",
        "--monte-carlo",
        "5",
        "--json",
        path_str(&mc),
    ]);
    let stderr = text(&out).1;
    assert!(
        !out.status.success() && stderr.contains("has no timing spreads"),
        "{stderr}"
    );
    assert!(!mc.exists());
}

/// Issue 44, finding 12: every output of `compare` and `calibrate` is checked against every
/// input (through symlinks) and every other output before any work; `-` sends the JSON to
/// standard output and the readable report to standard error.
#[test]
fn compare_and_calibrate_never_overwrite_their_inputs() {
    let d = dir("log-outputs");
    let log = log_of(&d, "lung");
    let plan = d.join("lung.json");
    std::fs::copy(crate::util::repo().join("plans/lung.json"), &plan).expect("plan copied");
    let plan_before = std::fs::read(&plan).expect("plan");
    let log_before = std::fs::read(&log).expect("log");
    let refused = |args: &[&str], why: &str| {
        let out = arcsim(args);
        let stderr = text(&out).1;
        assert!(
            !out.status.success() && stderr.contains(why),
            "{args:?}: {stderr}"
        );
    };
    // compare --json PLAN.
    refused(
        &[
            "compare",
            path_str(&plan),
            path_str(&log),
            "--json",
            path_str(&plan),
        ],
        "is also an input",
    );
    // Through a symlink to the log.
    let link = d.join("link.json");
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink(&log, &link).expect("symlink");
    refused(
        &[
            "compare",
            path_str(&plan),
            path_str(&log),
            "--json",
            path_str(&link),
        ],
        "is also an input",
    );
    // calibrate -o LOG, and --json over the base machine.
    let machine = d.join("hidden.json");
    refused(
        &[
            "calibrate",
            "--machine",
            "scenarios/machine-atom.json",
            path_str(&plan),
            path_str(&log),
            "-o",
            path_str(&log),
        ],
        "is also an input",
    );
    let machine_before = std::fs::read(&machine).expect("machine");
    refused(
        &[
            "calibrate",
            "--machine",
            path_str(&machine),
            path_str(&plan),
            path_str(&log),
            "-o",
            path_str(&d.join("fitted.json")),
            "--json",
            path_str(&machine),
        ],
        "is also an input",
    );
    // -o X --json X.
    let same = d.join("same.json");
    refused(
        &[
            "calibrate",
            "--machine",
            "scenarios/machine-atom.json",
            path_str(&plan),
            path_str(&log),
            "-o",
            path_str(&same),
            "--json",
            path_str(&same),
        ],
        "the same file as",
    );
    assert!(!same.exists());
    // A missing directory is found before the work.
    refused(
        &[
            "compare",
            path_str(&plan),
            path_str(&log),
            "--json",
            path_str(&d.join("no-such-dir/c.json")),
        ],
        "does not exist",
    );
    assert_eq!(std::fs::read(&plan).expect("plan"), plan_before);
    assert_eq!(std::fs::read(&log).expect("log"), log_before);
    assert_eq!(std::fs::read(&machine).expect("machine"), machine_before);
    // --json -: the JSON alone on standard output, the report on standard error.
    let out = arcsim(&["compare", path_str(&plan), path_str(&log), "--json", "-"]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stderr}");
    let doc: Value = serde_json::from_str(&stdout).expect("only JSON on stdout");
    assert_eq!(doc["format"], "arcsim-compare/1");
    assert!(stderr.contains("the log fits"), "{stderr}");
}
