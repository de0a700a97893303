//! `calibrate-spots` end to end: `simulate --spots` writes the per-spot log of a delivery on a
//! scanning machine hidden here (6,000 mm/s, 2 ms settling, bursts of 0.12 s, every time per MU
//! 10 % longer than the ProteusONE-like base), its times read here by a 0.25 ms clock with a
//! random phase per layer (as IBA's per-spot records are); `calibrate-spots` finds each value
//! within 3 % with intervals that hold it, writes a machine `simulate` reads, and refuses bad
//! input by file, line and column.

use std::path::{Path, PathBuf};

use arcsim_test_support::{temp_dir, Rng};
use serde_json::Value;

use crate::util::{arcsim, path_str, repo_json, text};

const BASE: &str = "scenarios/machine-proteusone-like.json";

fn hidden_machine(dir: &Path) -> PathBuf {
    crate::util::hidden_scanning_machine(dir, BASE, &[("burst_switching_time_s", 0.12)])
}

/// `simulate --spots` of `plan` on `machine`, every time then read by a 0.25 ms clock whose
/// phase is random per layer.
fn spot_log(dir: &Path, plan: &str, machine: &Path, rng: &mut Rng) -> PathBuf {
    let plan_file = match plan.contains('/') {
        true => plan.to_string(),
        false => format!("plans/{plan}.json"),
    };
    let plan = Path::new(plan)
        .file_stem()
        .expect("stem")
        .to_string_lossy()
        .into_owned();
    let exact = dir.join(format!("{plan}-exact.csv"));
    let out = arcsim(&[
        "simulate",
        &plan_file,
        "--machine",
        path_str(machine),
        "--spots",
        path_str(&exact),
    ]);
    assert!(out.status.success(), "{:?}", text(&out));
    let csv = std::fs::read_to_string(&exact).expect("spots");
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let (layer, start, end) = (col("layer_index"), col("t_start_s"), col("t_end_s"));
    let mut phase = (usize::MAX, 0.0);
    let mut text_out = format!("{}\n", header.join(","));
    for line in lines {
        let mut f: Vec<String> = line.split(',').map(str::to_string).collect();
        let k: usize = f[layer].parse().expect("layer");
        if phase.0 != k {
            phase = (k, 0.00025 * rng.unit());
        }
        for c in [start, end] {
            let t: f64 = f[c].parse().expect("time");
            f[c] = format!("{}", ((t + phase.1) / 0.00025).round() * 0.00025);
        }
        text_out.push_str(&f.join(","));
        text_out.push('\n');
    }
    let path = dir.join(format!("{plan}.csv"));
    std::fs::write(&path, text_out).expect("log written");
    path
}

#[test]
fn calibrate_spots_recovers_a_hidden_scanning_machine() {
    let dir = temp_dir();
    let hidden = hidden_machine(&dir);
    let mut rng = Rng::new(7);
    let mut args: Vec<String> = vec!["calibrate-spots".into(), "--machine".into(), BASE.into()];
    for plan in ["prostate", "lung", "two-arc"] {
        args.push(format!("plans/{plan}.json"));
        args.push(path_str(&spot_log(&dir, plan, &hidden, &mut rng)).to_string());
    }
    let (fitted, json) = (dir.join("fitted.json"), dir.join("report.json"));
    args.extend([
        "-o".into(),
        path_str(&fitted).into(),
        "--json".into(),
        path_str(&json).into(),
    ]);
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = arcsim(&refs);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}{stderr}");
    assert!(stdout.contains("clock resolution 0.00025 s"), "{stdout}");
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("report")).expect("json");
    assert_eq!(report["format"], "arcsim-spot-calibration/1");
    crate::util::assert_recovered(
        &report,
        &[
            ("beam.s_per_mu_scale", 1.1),
            ("beam.scan_speed_mm_per_s", 6000.0),
            ("beam.settling_time_s", 0.002),
            ("beam.burst_switching_time_s", 0.12),
        ],
        0.03,
        &stdout,
    );
    for r in report["residuals"].as_array().expect("residuals") {
        let pct = r["fitted_error_pct"].as_f64().expect("pct");
        assert!(pct.abs() < 0.1, "{r}");
    }
    // The fitted machine is a machine file: the hidden machine's prostate, simulated with it,
    // lasts as on the hidden machine (the spot timing is all that differs from the base).
    let total = |machine: &Path| {
        let out = arcsim(&[
            "simulate",
            "plans/prostate.json",
            "--machine",
            path_str(machine),
        ]);
        let (stdout, stderr) = text(&out);
        assert!(out.status.success(), "{stdout}{stderr}");
        let line = stdout
            .lines()
            .find(|l| l.trim_start().starts_with("total"))
            .unwrap_or_else(|| panic!("{stdout}"))
            .to_string();
        line.split_whitespace()
            .find_map(|w| w.parse::<f64>().ok())
            .expect("a total")
    };
    let (on_hidden, on_fitted) = (total(&hidden), total(&fitted));
    assert!(
        (on_fitted / on_hidden - 1.0).abs() < 0.002,
        "{on_fitted} against {on_hidden}"
    );
}

/// A synchrotron hidden here (ProBeat-like: refill 1.5 s where the base has 1.91, spills of
/// 30 MU where it has 40, 2.5 ms settling): its refill time and spill charge found from the
/// pauses where a spill ran out, within 3 % with intervals that hold them, on plans whose spot
/// spacing varies by energy (`generate-plan --spot-spacing 3-8`).
#[test]
fn calibrate_spots_finds_a_synchrotrons_refill_time_and_spill_charge() {
    // A spot takes what is left of a spill (`split`), or waits whole for the next.
    for across in ["split", "next_spill"] {
        synchrotron_fit(across);
    }
}

fn synchrotron_fit(across: &str) {
    let dir = temp_dir();
    let mut base = repo_json("scenarios/machine-probeat-v5-like.json");
    base["beam"]["spill"]["spot_across_spills"] = across.into();
    let base_file = dir.join("base-sync.json");
    std::fs::write(&base_file, base.to_string()).expect("base written");
    let mut m = base.clone();
    m["name"] = "hidden".into();
    m["beam"]["spill"]["refill_time_s"] = 1.5.into();
    m["beam"]["spill"]["charge_mu"] = 30.0.into();
    m["beam"]["settling_time_s"] = 0.0025.into();
    let hidden = dir.join("hidden-sync.json");
    std::fs::write(&hidden, m.to_string()).expect("machine written");
    let mut rng = Rng::new(11);
    let mut args: Vec<String> = vec![
        "calibrate-spots".into(),
        "--machine".into(),
        path_str(&base_file).into(),
    ];
    for kind in ["prostate", "lung", "two-arc"] {
        let plan = dir.join(format!("{kind}-spaced.json"));
        let out = arcsim(&[
            "generate-plan",
            "--kind",
            kind,
            "--spot-spacing",
            "3-8",
            "-o",
            path_str(&plan),
        ]);
        assert!(out.status.success(), "{:?}", text(&out));
        args.push(path_str(&plan).into());
        args.push(path_str(&spot_log(&dir, path_str(&plan), &hidden, &mut rng)).into());
    }
    let json = dir.join("report.json");
    args.extend([
        "-o".into(),
        path_str(&dir.join("fitted.json")).into(),
        "--json".into(),
        path_str(&json).into(),
    ]);
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = arcsim(&refs);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}{stderr}");
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("report")).expect("json");
    crate::util::assert_recovered(
        &report,
        &[
            ("beam.spill.refill_time_s", 1.5),
            ("beam.spill.charge_mu", 30.0),
            ("beam.settling_time_s", 0.0025),
        ],
        0.03,
        &format!("{across}\n{stdout}"),
    );
    for r in report["residuals"].as_array().expect("residuals") {
        let pct = r["fitted_error_pct"].as_f64().expect("pct");
        assert!(pct.abs() < 0.1, "{r}");
    }
}

#[test]
fn calibrate_spots_refuses_bad_logs_by_line_and_column() {
    let dir = temp_dir();
    let bad = dir.join("bad.csv");
    std::fs::write(
        &bad,
        "arc,control_point,layer,painting,x_mm,y_mm,mu,t_start_s,t_end_s\n0,0,0,0,1,2,0.5,0.0,0.001\n0,0,0,0,6,2,0.5,0.004,NaN\n",
    )
    .expect("written");
    let out = dir.join("out.json");
    let run = |log: &Path| {
        arcsim(&[
            "calibrate-spots",
            "--machine",
            BASE,
            "plans/prostate.json",
            path_str(log),
            "-o",
            path_str(&out),
        ])
    };
    let o = run(&bad);
    let (_, stderr) = text(&o);
    assert!(!o.status.success());
    assert!(
        stderr.contains("bad.csv: line 3: column t_end_s: `NaN`; expected a number"),
        "{stderr}"
    );
    std::fs::write(&bad, "t_s,gantry_angle_deg,beam_on\n0,10,0\n").expect("written");
    let (_, stderr) = text(&run(&bad));
    assert!(
        stderr.contains("bad.csv: line 1: no column `arc`"),
        "{stderr}"
    );
    // A per_mu machine has no scanning model to fit.
    let o = arcsim(&[
        "calibrate-spots",
        "--machine",
        "scenarios/machine-atom.json",
        "plans/prostate.json",
        path_str(&bad),
        "-o",
        path_str(&out),
    ]);
    let (_, stderr) = text(&o);
    assert!(
        !o.status.success() && stderr.contains("bad.csv"),
        "{stderr}"
    );
    assert!(!out.exists(), "nothing is written on an error");
}
