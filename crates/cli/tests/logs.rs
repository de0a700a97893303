//! `simulate --log` end to end: the virtual log reads back as `arcsim-log/1`, its beam-on runs are
//! the JSON result's layers to within one log period, its MU are the spot table's; bad options
//! and a log over an input are refused before anything is written.

use arcsim_log::{read_log, ColumnMap};
use arcsim_test_support::temp_dir;
use serde_json::Value;

use crate::util::{arcsim, path_str, text};

fn f(v: &Value) -> f64 {
    v.as_f64().expect("number")
}

#[test]
fn a_virtual_log_matches_the_simulation_it_samples() {
    let dir = temp_dir().join("virtual-log");
    std::fs::create_dir_all(&dir).expect("dir");
    let (log, json, spots) = (
        dir.join("lung.log.csv"),
        dir.join("lung.json"),
        dir.join("spots.csv"),
    );
    let period = 0.02;
    let out = arcsim(&[
        "simulate",
        "plans/lung.json",
        "--machine",
        "scenarios/machine-opentps-pbs.json",
        "--motion",
        "constant",
        "--log",
        path_str(&log),
        "--log-period",
        "0.02",
        "--angle-noise-deg",
        "0.01",
        "--seed",
        "3",
        "--json",
        path_str(&json),
        "--spots",
        path_str(&spots),
    ]);
    assert!(out.status.success(), "{}", text(&out).1);
    let logged = read_log(&log, &ColumnMap::default()).expect("an arcsim-log/1 file");
    let result: Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("result");
    let layers = result["layers"].as_array().expect("layers");
    // Beam-on runs, one per layer, within a period of its start and end.
    let mut runs: Vec<(f64, f64)> = Vec::new();
    let mut was_on = false;
    for s in &logged.samples {
        match (s.beam_on, was_on) {
            (true, false) => runs.push((s.t_s, s.t_s)),
            (true, true) => runs.last_mut().expect("run").1 = s.t_s,
            _ => {}
        }
        was_on = s.beam_on;
    }
    assert_eq!(runs.len(), layers.len());
    for (r, l) in runs.iter().zip(layers) {
        let (t0, t1) = (f(&l["t_start_s"]), f(&l["t_end_s"]));
        assert!(
            r.0 >= t0 && r.0 - t0 <= period + 1e-9,
            "{r:?} vs {t0}..{t1}"
        );
        assert!(
            r.1 <= t1 && t1 - r.1 <= period + 1e-9,
            "{r:?} vs {t0}..{t1}"
        );
    }
    let total = f(&result["total_s"]);
    assert_eq!(logged.samples.last().map(|s| s.t_s), Some(total));
    // The MU are the spot table's.
    let table = std::fs::read_to_string(&spots).expect("spots");
    let mu_col = 8;
    let planned: f64 = table
        .lines()
        .skip(1)
        .map(|l| {
            l.split(',')
                .nth(mu_col)
                .expect("mu")
                .parse::<f64>()
                .expect("number")
        })
        .sum();
    let mu: f64 = logged.samples.iter().filter_map(|s| s.mu).sum();
    assert!((mu - planned).abs() <= 1e-9 * planned, "{mu} vs {planned}");
}

#[test]
fn bad_log_options_are_refused_before_anything_is_written() {
    let dir = temp_dir().join("virtual-log-bad");
    std::fs::create_dir_all(&dir).expect("dir");
    let log = dir.join("x.csv");
    for (flag, value, want) in [
        (
            "--log-period",
            "0",
            "--log-period 0: expected a finite number of seconds > 0",
        ),
        ("--log-period", "nan", "--log-period NaN"),
        ("--angle-noise-deg", "-1", "--angle-noise-deg -1: expected"),
        // Noise of 1e308 wrote infinite angles that `compare` then refused.
        (
            "--angle-noise-deg",
            "1e308",
            "--angle-noise-deg 1e308: expected a number of degrees from 0 to 10",
        ),
        (
            "--log-period",
            "1e-9",
            "--log-period 1e-9 would write more than 5e7 samples",
        ),
        // Tiny and huge values are printed short (once 300 digits).
        (
            "--log-period",
            "1e-300",
            "--log-period 1e-300 would write more than 5e7 samples",
        ),
    ] {
        let out = arcsim(&[
            "simulate",
            "plans/prostate.json",
            "--motion",
            "constant",
            "--log",
            path_str(&log),
            flag,
            value,
        ]);
        let err = text(&out).1;
        assert_eq!(out.status.code(), Some(2), "{flag} {value}: {err}");
        assert!(err.contains(want), "{flag} {value}: {err}");
        assert!(!log.exists(), "{flag} {value}: a log was written");
    }
    let out = arcsim(&[
        "simulate",
        "plans/prostate.json",
        "--log",
        "plans/prostate.json",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out).1.contains("--log"), "{}", text(&out).1);
}
