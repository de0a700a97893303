//! Edges an adversarial probe found (issue 47), each a test that failed before its fix: values
//! outside the ranges a move is solved in, numbers printed hundreds of digits long, angles
//! printed past 360°, a help line, sweeps beyond memory, long runs that said nothing of their
//! length.

use std::process::Stdio;
use std::time::{Duration, Instant};

use arcsim_test_support::temp_dir;

use crate::util::{self, arcsim, bin, path_str, stderr, stdout};

/// `profile` solves moves only inside its documented ranges: a jerk of 1e-300 was "planner
/// self-check failed (a bug)" and a distance of 1e300 printed 300-digit durations; both exit 2
/// naming the option and the range, in a short message. A batch row out of range is an error
/// row, the other rows are solved.
#[test]
fn profile_refuses_values_outside_its_ranges() {
    let base = [
        "--v-start",
        "0",
        "--v-end",
        "0",
        "--accel",
        "1",
        "--vel",
        "5",
    ];
    for (option, value, expected) in [
        ("--jerk", "1e-300", "jerk 1e-300 deg/s³ is outside the range a move is solved in (0.001 to 10000 deg/s³)"),
        ("--jerk", "1e300", "jerk 1e300 deg/s³ is outside"),
        ("--distance", "1e300", "distance 1e300 deg is outside the range a move is solved in (0 to 100000 deg), in magnitude"),
        ("--period", "1e-7", "period 1e-7 s is outside"),
        ("--min-duration", "1e14", "min-duration 1e14 s is outside"),
    ] {
        let mut args = vec!["profile", "--distance", "10", "--jerk", "1"];
        args.extend(base);
        match args.iter().position(|a| *a == option) {
            Some(i) => args[i + 1] = value,
            None => args.extend([option, value]),
        }
        let o = arcsim(&args);
        assert_eq!(o.status.code(), Some(2), "{option} {value}: {}", stderr(&o));
        let err = stderr(&o);
        assert!(err.contains(expected), "{option} {value}: {err}");
        assert!(err.len() < 200 && !err.contains("a bug"), "{err}");
        assert!(stdout(&o).is_empty(), "{}", stdout(&o));
    }
    let dir = temp_dir();
    let batch = dir.join("moves.csv");
    std::fs::write(
        &batch,
        "distance,v_start,v_end,jerk,accel,vel\n10,0,0,1,1,5\n10,0,0,1e-300,1,5\n",
    )
    .expect("write");
    let o = arcsim(&["profile", "--batch", path_str(&batch)]);
    let out = stdout(&o);
    let rows: Vec<&str> = out.lines().collect();
    assert_eq!(rows.len(), 3, "{out}");
    assert!(rows[1].contains(",ok,"), "{out}");
    assert!(
        rows[2].contains("error") && rows[2].contains("jerk 1e-300"),
        "{out}"
    );
}

/// Tiny and huge numbers in errors print short: `--dt 1e-300` and `--spacing 1e-300` once
/// printed three hundred digits.
#[test]
fn tiny_and_huge_numbers_print_short_in_errors() {
    let dir = temp_dir();
    let csv = dir.join("t.csv");
    let plan = dir.join("p.json");
    for (args, want) in [
        (
            vec![
                "simulate",
                "plans/prostate.json",
                "--csv",
                path_str(&csv),
                "--dt",
                "1e-300",
            ],
            "--dt 1e-300 would write more than 5e7 samples",
        ),
        (
            vec![
                "generate-plan",
                "--kind",
                "lung",
                "--spacing",
                "1e-300",
                "-o",
                path_str(&plan),
            ],
            "--spacing: 1e-300 deg is not allowed",
        ),
        (
            vec![
                "generate-plan",
                "--kind",
                "lung",
                "--energy",
                "0.0000001-1e300",
                "-o",
                path_str(&plan),
            ],
            "1e-7-1e300 MeV",
        ),
    ] {
        let o = arcsim(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        let err = stderr(&o);
        assert!(err.contains(want) && err.len() < 300, "{args:?}: {err}");
    }
}

/// `calibrate --help` names a plan and its log (it showed `<PLAN LOG> <PLAN LOG>...`).
#[test]
fn calibrate_help_names_a_plan_and_its_log() {
    let o = arcsim(&["calibrate", "--help"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let help = stdout(&o);
    assert!(help.contains("<PLAN> <LOG>..."), "{help}");
    assert!(!help.contains("<PLAN LOG>"), "{help}");
}

/// An arc through 0° keeps increasing angles in the plan (181° … 539°); the summary prints them
/// as the gantry shows them (177°, not 537°).
#[test]
fn angles_print_as_the_gantry_shows_them() {
    let mut v = util::repo_json("plans/prostate.json");
    for cp in v["arcs"][0]["control_points"]
        .as_array_mut()
        .expect("control points")
    {
        let a = cp["angle_deg"].as_f64().expect("angle");
        cp["angle_deg"] = serde_json::json!(a + 180.0);
    }
    let plan = temp_dir().join("through-zero.json");
    std::fs::write(&plan, v.to_string()).expect("write");
    let o = arcsim(&["simulate", path_str(&plan)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains("177.00 → 179.00"), "{out}");
    assert!(!out.contains("537.00"), "{out}");
}

/// A sweep whose rows would not fit in memory is refused before any work, with what it would
/// take and the way out (shards): one of 1e8 rows once started towards 69 GB. The memory it may
/// take is the machine's available memory, or `ARCSIM_MEMORY_LIMIT_BYTES` (here 1 GB, so the
/// test does not depend on this machine's).
#[test]
fn a_sweep_beyond_memory_is_refused_before_the_work() {
    let dir = temp_dir();
    let range = serde_json::json!({ "from": 0.1, "to": 10.0, "steps": 10_000 });
    let sweep = util::sweep_file(
        &dir,
        "huge",
        "plans/prostate.json",
        serde_json::json!({ "jerk_deg_per_s3": range, "accel_deg_per_s2": range }),
    );
    let started = Instant::now();
    let o = bin()
        .args(["sweep", path_str(&sweep)])
        .env("ARCSIM_MEMORY_LIMIT_BYTES", "1000000000")
        .output()
        .expect("run");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("100000000 combinations would hold about")
            && err.contains("GB of rows in memory for the summary; this machine has 1.0 GB available: run it in shards (--shard K/N"),
        "{err}"
    );
    assert!(!err.contains("evaluated"), "{err}");
    assert!(started.elapsed() < Duration::from_secs(30));
    // About 700 bytes a row, as docs/commands.md says.
    let gb: f64 = err
        .split("would hold about ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .expect("GB figure");
    assert!((60.0..=80.0).contains(&gb), "{gb} GB for 1e8 rows");
}

/// The first line of standard error of `child` that contains `want`, within `limit`; the child
/// is killed either way.
fn stderr_line(mut child: std::process::Child, want: &str, limit: Duration) -> Option<String> {
    use std::io::BufRead;
    let err = child.stderr.take().expect("stderr piped");
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(err).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let deadline = Instant::now() + limit;
    let mut found = None;
    while let Some(left) = deadline.checked_duration_since(Instant::now()) {
        match rx.recv_timeout(left) {
            Ok(line) if line.contains(want) => {
                found = Some(line);
                break;
            }
            Ok(_) => {}
            Err(_) => break,
        }
    }
    let _ = child.kill();
    let _ = child.wait();
    found
}

/// A long sweep and a long Monte Carlo say how long they will take once a few seconds have run,
/// on standard error even without a terminal (a job's log): 1e5 draws of 36 h once started
/// without a word.
#[test]
fn long_runs_say_how_long_they_will_take() {
    let dir = temp_dir();
    let jerks: Vec<f64> = (1..=400).map(|i| 0.1 + 0.01 * f64::from(i)).collect();
    let accels: Vec<f64> = (1..=250).map(|i| 0.1 + 0.004 * f64::from(i)).collect();
    let sweep = util::prostate_sweep(&dir, "long", &jerks, &accels);
    let child = bin()
        .args(["sweep", path_str(&sweep), "--threads", "1"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    let line = stderr_line(
        child,
        "to go at the pace of the first",
        Duration::from_secs(30),
    );
    let line = line.expect("a sweep of 100000 rows says how long it will take");
    assert!(
        line.starts_with("about ") && line.ends_with("; Ctrl-C stops and keeps the rows done"),
        "{line}"
    );

    let mut v = util::repo_json("scenarios/machine-atom.json");
    v["spread"] = serde_json::json!({"elst_up_sd_s": 0.1, "elst_down_sd_s": 0.05, "beam_time_sd_fraction": 0.0});
    let machine = dir.join("spread.json");
    std::fs::write(&machine, v.to_string()).expect("write");
    let child = bin()
        .args([
            "simulate",
            "plans/prostate.json",
            "--machine",
            path_str(&machine),
            "--monte-carlo",
            "100000",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    let line = stderr_line(
        child,
        "--monte-carlo 100000: about",
        Duration::from_secs(30),
    );
    let line = line.expect("1e5 draws say how long they will take");
    assert!(line.contains("to go at the pace of the first"), "{line}");
}
