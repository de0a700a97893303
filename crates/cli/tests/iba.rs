//! IBA-style logs end to end: `simulate --iba-log` writes the beam folders a scanning nozzle's
//! recorder would leave of a delivery on a machine hidden here (6,000 mm/s where the base has
//! 8,000, 2 ms settling where it has none, every time per MU 10 % longer), rows every 0.25 ms
//! stamped to the millisecond, the chamber's positions and charge in its own frame; the plans
//! are generated with spot spacings of 3–8 mm by energy (`generate-plan --spot-spacing 3-8`),
//! since moves of one length cannot tell a scanning speed from a settling time. `calibrate-spots` on those folders finds each value
//! within 3 % with intervals that hold it; `compare` times every layer to the sampling period;
//! a malformed folder is refused by file and line.

use std::path::{Path, PathBuf};

use arcsim_test_support::temp_dir;
use serde_json::Value;

use crate::util::{arcsim, path_str, text};

const BASE: &str = "scenarios/machine-opentps-pbs.json";

fn hidden_machine(dir: &Path) -> PathBuf {
    crate::util::hidden_scanning_machine(dir, BASE, &[])
}

/// The generated plan of `kind` with spot spacings of 3–8 mm (by energy), as docs/records.md's
/// walk-through makes it.
fn spaced_plan(dir: &Path, kind: &str) -> PathBuf {
    let path = dir.join(format!("{kind}-spaced.json"));
    let out = arcsim(&[
        "generate-plan",
        "--kind",
        kind,
        "--spot-spacing",
        "3-8",
        "-o",
        path_str(&path),
    ]);
    assert!(out.status.success(), "{:?}", text(&out));
    path
}

fn iba_log(dir: &Path, plan: &Path, machine: &Path, start: &str) -> PathBuf {
    iba_log_in(dir, plan, machine, start, "rows")
}

/// `simulate --iba-log` of `plan` on `machine` in the recorder's `layout`.
fn iba_log_in(dir: &Path, plan: &Path, machine: &Path, start: &str, layout: &str) -> PathBuf {
    let stem = plan.file_stem().expect("stem").to_string_lossy();
    let out_dir = dir.join(format!("{stem}-iba-{layout}"));
    let out = arcsim(&[
        "simulate",
        path_str(plan),
        "--machine",
        path_str(machine),
        "--iba-log",
        path_str(&out_dir),
        "--iba-layout",
        layout,
        "--record-start",
        start,
    ]);
    assert!(out.status.success(), "{:?}", text(&out));
    out_dir
}

#[test]
fn calibrate_spots_recovers_a_hidden_scanning_machine_from_iba_logs() {
    let dir = temp_dir();
    let hidden = hidden_machine(&dir);
    // One delivery crosses midnight and the new year; the lung's recorder writes the element
    // layout (`SPOT_ID`, `FPGA_COUNT`), the others a row per 0.25 ms.
    let logs: Vec<(PathBuf, PathBuf)> = [
        ("prostate", "20261231235950", "rows"),
        ("lung", "20260102080000", "elements"),
        ("two-arc", "20260103080000", "rows"),
    ]
    .into_iter()
    .map(|(plan, start, layout)| {
        let plan = spaced_plan(&dir, plan);
        let log = iba_log_in(&dir, &plan, &hidden, start, layout);
        (plan, log)
    })
    .collect();
    recovered(
        &dir,
        BASE,
        &logs,
        0.00025,
        &[
            ("beam.s_per_mu_scale", 1.1),
            ("beam.scan_speed_mm_per_s", 6000.0),
            ("beam.settling_time_s", 0.002),
        ],
    );
}

/// `calibrate-spots` from `base` on `logs` (plan and log folder pairs): it reads the clock as
/// `clock_s`, finds each of `truth` within 3 % with an interval that holds it, and times every
/// logged layer within 0.1 %.
fn recovered(
    dir: &Path,
    base: &str,
    logs: &[(PathBuf, PathBuf)],
    clock_s: f64,
    truth: &[(&str, f64)],
) {
    let (fitted, json) = (dir.join("fitted.json"), dir.join("report.json"));
    let mut args: Vec<&str> = vec!["calibrate-spots", "--machine", base];
    for (plan, log) in logs {
        args.extend([path_str(plan), path_str(log)]);
    }
    args.extend(["-o", path_str(&fitted), "--json", path_str(&json)]);
    let out = arcsim(&args);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}{stderr}");
    assert!(
        stdout.contains(&format!("clock resolution {clock_s} s")),
        "{stdout}"
    );
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("report")).expect("json");
    crate::util::assert_recovered(&report, truth, 0.03, &stdout);
    for r in report["residuals"].as_array().expect("residuals") {
        let pct = r["fitted_error_pct"].as_f64().expect("pct");
        assert!(pct.abs() < 0.1, "{r}");
    }
}

#[test]
fn compare_times_every_layer_of_an_iba_log_to_its_sampling_period() {
    let dir = temp_dir();
    let hidden = hidden_machine(&dir);
    let plan = spaced_plan(&dir, "two-arc");
    // The element layout places each layer by its millisecond START_IRRADIATION stamp.
    for (layout, step) in [("rows", 0.00025), ("elements", 0.001)] {
        let log = iba_log_in(&dir, &plan, &hidden, "20261231235930", layout);
        compare_within(&plan, &log, &hidden, step);
    }
}

/// `compare` of `log` with `plan` on `machine`: every planned layer matched, each beam edge
/// within `step` s of the simulation, each angle within the events' 0.001°.
fn compare_within(plan: &Path, log: &Path, machine: &Path, step: f64) {
    let json = log.with_extension("compare.json");
    let out = arcsim(&[
        "compare",
        path_str(plan),
        path_str(log),
        "--machine",
        path_str(machine),
        "--json",
        path_str(&json),
    ]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}{stderr}");
    let c: Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("json");
    let layers = c["layers"].as_array().expect("layers");
    let planned = serde_json::from_str::<Value>(&std::fs::read_to_string(plan).expect("plan"))
        .expect("json")["arcs"]
        .as_array()
        .expect("arcs")
        .iter()
        .flat_map(|a| a["control_points"].as_array().expect("cps").iter())
        .map(|cp| cp["layers"].as_array().expect("layers").len())
        .sum::<usize>();
    assert_eq!(layers.len(), planned, "{stdout}");
    for l in layers {
        for (a, b) in [
            ("logged_start_s", "simulated_start_s"),
            ("logged_end_s", "simulated_end_s"),
        ] {
            let d = l[a].as_f64().expect("t") - l[b].as_f64().expect("t");
            assert!(d.abs() <= step, "layer {}: {a} off by {d} s", l["index"]);
        }
        // The events file's actual angles (written to 0.001°, modulo 360).
        let d = (l["logged_angle_start_deg"].as_f64().expect("deg")
            - l["simulated_angle_start_deg"].as_f64().expect("deg"))
        .rem_euclid(360.0);
        assert!(
            d.min(360.0 - d) < 0.002,
            "layer {}: angle off by {d}",
            l["index"]
        );
    }
    assert_eq!(c["edge_resolution_s"], step);
}

/// Runs `compare` on the prostate's IBA-style log after `edit` changed it; standard error.
fn refused(edit: impl Fn(&Path)) -> String {
    let dir = temp_dir();
    let hidden = hidden_machine(&dir);
    let plan = spaced_plan(&dir, "prostate");
    let log = iba_log(&dir, &plan, &hidden, "20260101080000");
    edit(&log.join("beam_01"));
    let out = arcsim(&["compare", path_str(&plan), path_str(&log)]);
    let (stdout, stderr) = text(&out);
    assert!(!out.status.success(), "{stdout}");
    stderr
}

fn file_starting(dir: &Path, prefix: &str) -> PathBuf {
    let mut names: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("dir")
        .map(|e| e.expect("entry").path())
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with(prefix))
        })
        .collect();
    names.sort();
    names.into_iter().next().expect(prefix)
}

fn edit_line(path: &Path, line: usize, f: impl Fn(&str) -> String) {
    let text = std::fs::read_to_string(path).expect("read");
    let lines: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| if i + 1 == line { f(l) } else { l.to_string() })
        .collect();
    std::fs::write(path, lines.join("\n") + "\n").expect("write");
}

#[test]
fn malformed_iba_logs_are_refused_by_file_and_line() {
    // A row's time that is not a time stamp.
    let e = refused(|beam| {
        let rec = file_starting(beam, "map_record_0002");
        edit_line(&rec, 15, |l| l.replacen(":", "h", 1));
    });
    assert!(
        e.contains("map_record_0002_part_01")
            && e.contains("line 15: column TIME:")
            && e.contains("expected a time stamp dd/MM/yyyy HH:MM:SS.fff"),
        "{e}"
    );
    // Rows out of time order.
    let e = refused(|beam| {
        let rec = file_starting(beam, "map_record_0001");
        edit_line(&rec, 20, |l| {
            let f: Vec<&str> = l.split(',').collect();
            format!("{},01/01/2025 08:00:00.000,{}", f[0], f[2..].join(","))
        });
    });
    assert!(
        e.contains("line 20: column TIME: earlier than the row before"),
        "{e}"
    );
    // An arc irradiation that never ends.
    let e = refused(|beam| {
        let ev = file_starting(beam, "events");
        let text = std::fs::read_to_string(&ev).expect("events");
        let kept: Vec<&str> = text.lines().filter(|l| !l.contains("END_ARC")).collect();
        std::fs::write(&ev, kept.join("\n")).expect("write");
    });
    assert!(
        e.contains("events.")
            && e.contains(
                "line 2: a second START_ARC_ANGLE_IRRADIATION before the one of line 1 ended"
            ),
        "{e}"
    );
    // A layer's record gone: the events file has one irradiation too many.
    let e = refused(|beam| {
        std::fs::remove_file(file_starting(beam, "map_record_0005")).expect("removed");
    });
    assert!(
        e.contains("events.")
            && e.contains("arc irradiations for")
            && e.contains("expected one per layer"),
        "{e}"
    );
    // A charge per MU that is not a number.
    let e = refused(|beam| {
        let cfg = file_starting(beam, "beam_config");
        edit_line(&cfg, 4, |_| {
            "chargePerMUIC2;Charge per MU on IC2;three".into()
        });
    });
    assert!(
        e.contains("beam_config.")
            && e.contains("line 4: charge per MU `three`; expected a finite number"),
        "{e}"
    );
    // A folder with no record at all.
    let dir = temp_dir();
    let out = arcsim(&["compare", "plans/prostate.json", path_str(&dir)]);
    let (_, e) = text(&out);
    assert!(
        !out.status.success() && e.contains("no map_record_* file here or in a folder below"),
        "{e}"
    );
}

#[test]
fn calibrate_spots_refuses_an_iba_log_of_another_shape_of_plan() {
    let dir = temp_dir();
    let hidden = hidden_machine(&dir);
    let plan = spaced_plan(&dir, "two-arc");
    let log = iba_log(&dir, &plan, &hidden, "20260101080000");
    let out = dir.join("fitted.json");
    // Two beam folders for a one-arc plan.
    let o = arcsim(&[
        "calibrate-spots",
        "--machine",
        BASE,
        "plans/prostate.json",
        path_str(&log),
        "-o",
        path_str(&out),
    ]);
    let (_, e) = text(&o);
    assert!(
        !o.status.success() && e.contains("2 beam folder(s) for a plan of 1 arc(s)"),
        "{e}"
    );
    assert!(!out.exists());
}

/// A synchrocyclotron's recorder: `burst_record` files, one element per 1 ms beam pulse, of a
/// ProteusONE-like machine hidden here (6,000 mm/s, 2 ms settling, 0.12 s between bursts where
/// the base has 0.15, every time per MU 10 % longer, at least one pulse per spot). Each pass
/// over a layer's spots is one burst and passes differ in length (only spots with MU left are
/// revisited), so the passes are found by the plan's spot order. `calibrate-spots` finds every
/// value within 3 % with intervals that hold it, reading the 1 ms pulse as the clock; `compare`
/// times every layer to the pulse.
#[test]
fn calibrate_spots_recovers_a_hidden_burst_machine_from_burst_records() {
    const BURST_BASE: &str = "scenarios/machine-proteusone-like.json";
    let dir = temp_dir();
    let hidden = crate::util::hidden_scanning_machine(
        &dir,
        BURST_BASE,
        &[("burst_switching_time_s", 0.12), ("min_spot_time_s", 0.001)],
    );
    let logs: Vec<(PathBuf, PathBuf)> = [
        ("prostate", "20260105080000"),
        ("lung", "20260106235958"),
        ("two-arc", "20260107080000"),
    ]
    .into_iter()
    .map(|(plan, start)| {
        let plan = spaced_plan(&dir, plan);
        let log = iba_log_in(&dir, &plan, &hidden, start, "bursts");
        (plan, log)
    })
    .collect();
    recovered(
        &dir,
        BURST_BASE,
        &logs,
        0.001,
        &[
            ("beam.s_per_mu_scale", 1.1),
            ("beam.scan_speed_mm_per_s", 6000.0),
            ("beam.settling_time_s", 0.002),
            ("beam.burst_switching_time_s", 0.12),
        ],
    );
    let (plan, log) = &logs[1];
    compare_within(plan, log, &hidden, 0.001);
}
