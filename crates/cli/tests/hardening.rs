//! The CLI under hostile or careless use: closed pipes, standard input and FIFOs, outputs that
//! alias inputs or cannot be written, interrupted sweeps, absurd arguments and names. Each test
//! reproduces a failure an adversarial probe found (a panic, a hang, a lost or overwritten file).

use crate::util;

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use arcsim_test_support::temp_dir;

use crate::util::{arcsim, bin, path_str, repo, stderr, stdout};

/// A sweep file of the prostate plan with `scan` over the given jerks (× accelerations).
fn small_sweep(dir: &Path, name: &str, jerks: &[f64]) -> PathBuf {
    sweep_file(dir, name, jerks, &[0.5])
}

fn sweep_file(dir: &Path, name: &str, jerks: &[f64], accels: &[f64]) -> PathBuf {
    util::prostate_sweep(dir, name, jerks, accels)
}

#[test]
fn closed_stdout_ends_quietly() {
    // head-neck's JSON is far larger than a pipe's buffer: the writer meets the closed pipe.
    let mut child = bin()
        .args(["generate-plan", "--kind", "head-neck", "--seed", "1"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    let mut out = child.stdout.take().expect("stdout");
    let mut first = [0u8; 16];
    out.read_exact(&mut first).expect("some output");
    drop(out);
    let o = child.wait_with_output().expect("wait");
    let err = stderr(&o);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(o.status.code(), Some(0), "{err}");
}

#[test]
fn plans_read_once_from_stdin_and_fifos() {
    let plan = std::fs::read(repo().join("plans/prostate.json")).expect("plan");
    for arg in ["-", "/dev/stdin"] {
        let mut child = bin()
            .args([
                "simulate",
                arg,
                "--schedule",
                "scan",
                "--motion",
                "constant",
            ])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn");
        child
            .stdin
            .take()
            .expect("stdin")
            .write_all(&plan)
            .expect("feed plan");
        let o = child.wait_with_output().expect("wait");
        assert!(o.status.success(), "{arg}: {}", stderr(&o));
        assert!(stdout(&o).contains("plan prostate on atom"), "{arg}");
    }

    let dir = temp_dir();
    let fifo = dir.join("plan.fifo");
    let made = Command::new("mkfifo").arg(&fifo).status().expect("mkfifo");
    assert!(made.success());
    let fifo_w = fifo.clone();
    let writer = std::thread::spawn(move || {
        std::fs::write(&fifo_w, plan).expect("write into the FIFO");
    });
    let mut child = bin()
        .args(["validate", path_str(&fifo)])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    let started = Instant::now();
    while child.try_wait().expect("poll").is_none() {
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "validate hangs on a FIFO"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let o = child.wait_with_output().expect("wait");
    writer.join().expect("writer");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("valid (prostate)"), "{}", stdout(&o));
}

#[test]
fn outputs_never_overwrite_inputs_or_appear_half_done() {
    let dir = temp_dir();
    let input = dir.join("in.json");
    std::fs::copy(repo().join("plans/prostate.json"), &input).expect("copy");
    let before = std::fs::read(&input).expect("read");

    let o = arcsim(&[
        "simulate",
        path_str(&input),
        "--json",
        path_str(&input),
        "--csv",
        "nodir/x.csv",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("is also an input of this command"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(&input).expect("read"), before, "plan changed");

    // A bad path among good ones: refused before the work, nothing written.
    let json = dir.join("out.json");
    let o = arcsim(&[
        "simulate",
        path_str(&input),
        "--json",
        path_str(&json),
        "--csv",
        path_str(&dir.join("nodir/x.csv")),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("does not exist"), "{}", stderr(&o));
    assert!(!json.exists(), "an output was written before the failure");
    // Two outputs on one file.
    let o = arcsim(&[
        "simulate",
        path_str(&input),
        "--json",
        path_str(&json),
        "--csv",
        path_str(&json),
    ]);
    assert!(
        stderr(&o).contains("the same file as --json"),
        "{}",
        stderr(&o)
    );

    // Success leaves exactly the outputs, no `.partial` files.
    let o = arcsim(&[
        "simulate",
        path_str(&input),
        "--schedule",
        "scan",
        "--motion",
        "constant",
        "--json",
        path_str(&json),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let names: Vec<String> = std::fs::read_dir(&dir)
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|n| !n.ends_with(".partial")), "{names:?}");
    assert!(json.exists());
}

#[test]
fn sweep_checks_outputs_and_threads_before_the_work() {
    let dir = temp_dir();
    let sweep = small_sweep(&dir, "small", &[0.5, 1.0]);
    let started = Instant::now();
    let o = arcsim(&[
        "sweep",
        path_str(&sweep),
        "--json",
        path_str(&dir.join("nodir/x.json")),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--json"), "{}", stderr(&o));
    assert!(
        !stderr(&o).contains("evaluated"),
        "the sweep ran first: {}",
        stderr(&o)
    );
    let o = arcsim(&["sweep", path_str(&sweep), "--threads", "20000"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--threads 20000: expected 1 to 256"));
    assert!(started.elapsed() < Duration::from_secs(30));
}

/// Runs shard `shard` (K/N) of `sweep` into `out`.
fn run_shard(sweep: &Path, shard: &str, out: &Path) {
    let o = arcsim(&[
        "sweep",
        path_str(sweep),
        "--shard",
        shard,
        "--out",
        path_str(out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn sweep_merge_leaves_no_bad_output() {
    let dir = temp_dir();
    let a = small_sweep(&dir, "a", &[0.5, 1.0]);
    let b = small_sweep(&dir, "b", &[2.0, 4.0]);
    let (s1, s2) = (dir.join("s1.csv"), dir.join("s2.csv"));
    run_shard(&a, "1/2", &s1);
    run_shard(&b, "2/2", &s2);
    let merged = dir.join("merged.csv");
    let o = arcsim(&[
        "sweep-merge",
        path_str(&s1),
        path_str(&s2),
        "--sweep",
        path_str(&a),
        "--out",
        path_str(&merged),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(!merged.exists(), "a mixed merge was written");
    // The shard of the other sweep is named, not the output.
    assert!(
        stderr(&o).contains(&format!("{}: line 2:", path_str(&s2))),
        "{}",
        stderr(&o)
    );
    // An output that is one of the inputs is refused.
    let o = arcsim(&["sweep-merge", path_str(&s1), "--out", path_str(&s1)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));

    // Without the sweep file: a shard that lost its last row is found from the rows' own count.
    let (t1, t2) = (dir.join("t1.csv"), dir.join("t2.csv"));
    run_shard(&a, "1/2", &t1);
    run_shard(&a, "2/2", &t2);
    let whole = dir.join("whole.csv");
    let o = arcsim(&[
        "sweep-merge",
        path_str(&t1),
        path_str(&t2),
        "--out",
        path_str(&whole),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&t2).expect("shard 2");
    let lines: Vec<&str> = text.lines().collect();
    std::fs::write(&t2, format!("{}\n", lines[..lines.len() - 1].join("\n"))).expect("cut");
    let o = arcsim(&[
        "sweep-merge",
        path_str(&t1),
        path_str(&t2),
        "--out",
        path_str(&merged),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("row 1 of 2 is missing"),
        "{}",
        stderr(&o)
    );
    assert!(!merged.exists(), "an incomplete merge was written");

    // A shard row with a result that is not a delivery time, or an unknown status, is refused
    // by shard, line and column, with or without the sweep file (NaN and -5 s were merged,
    // and -5 s became the sweep's fastest delivery).
    run_shard(&a, "2/2", &t2);
    let good = std::fs::read_to_string(&t2).expect("shard 2");
    let header: Vec<&str> = good.lines().next().expect("header").split(',').collect();
    for (column, value, want) in [
        (
            "total_s",
            "NaN",
            "column total_s: expected a finite number ≥ 0, found \"NaN\"",
        ),
        (
            "total_s",
            "-5",
            "column total_s: expected a finite number ≥ 0, found \"-5\"",
        ),
        (
            "status",
            "bogus",
            "column status: expected ok, infeasible, invalid or error",
        ),
    ] {
        let at = header.iter().position(|c| *c == column).expect("column");
        let lines: Vec<String> = good
            .lines()
            .enumerate()
            .map(|(i, l)| {
                let mut f: Vec<&str> = l.split(',').collect();
                if i == 1 {
                    f[at] = value;
                }
                f.join(",")
            })
            .collect();
        std::fs::write(&t2, lines.join("\n") + "\n").expect("write");
        for with_sweep in [false, true] {
            let mut args = vec![
                "sweep-merge",
                path_str(&t1),
                path_str(&t2),
                "--out",
                path_str(&merged),
            ];
            if with_sweep {
                args.extend(["--sweep", path_str(&a)]);
            }
            let o = arcsim(&args);
            assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
            let err = stderr(&o);
            assert!(
                err.contains(&format!("{}: line 2: {want}", path_str(&t2))),
                "{err}"
            );
            assert!(!merged.exists(), "a bad merge was written");
        }
    }
}

#[cfg(unix)]
#[test]
fn sighup_saves_a_sweep_like_ctrl_c() {
    let dir = temp_dir();
    // About 20 s of work on one thread: the signal arrives in the middle.
    let jerks: Vec<f64> = (1..=400).map(|i| 0.1 + 0.01 * f64::from(i)).collect();
    let accels: Vec<f64> = (1..=50).map(|i| 0.1 + 0.02 * f64::from(i)).collect();
    let sweep = sweep_file(&dir, "long", &jerks, &accels);
    let json = dir.join("partial.json");
    let child = bin()
        .args([
            "sweep",
            path_str(&sweep),
            "--threads",
            "1",
            "--json",
            path_str(&json),
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    std::thread::sleep(Duration::from_millis(1500));
    let killed = Command::new("kill")
        .args(["-HUP", &child.id().to_string()])
        .status()
        .expect("kill");
    assert!(killed.success());
    let o = child.wait_with_output().expect("wait");
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json saved")).expect("json");
    assert_eq!(v["complete"], serde_json::json!(false));
}

#[test]
fn long_deliveries_need_no_sampling_without_sampled_outputs() {
    let o = arcsim(&[
        "simulate",
        "plans/prostate.json",
        "--schedule",
        "scan",
        "--motion",
        "constant",
        "--dt",
        "1e-6",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let dir = temp_dir();
    let csv = dir.join("t.csv");
    let o = arcsim(&[
        "simulate",
        "plans/prostate.json",
        "--schedule",
        "scan",
        "--motion",
        "constant",
        "--dt",
        "1e-6",
        "--csv",
        path_str(&csv),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("more than 5e7 samples"));
}

#[test]
fn clearer_errors_for_careless_input() {
    let dir = temp_dir();
    // A byte-order mark is skipped.
    let mut bom = b"\xef\xbb\xbf".to_vec();
    bom.extend(std::fs::read(repo().join("plans/prostate.json")).expect("plan"));
    let plan = dir.join("bom.json");
    std::fs::write(&plan, bom).expect("write");
    let o = arcsim(&["validate", path_str(&plan)]);
    assert!(o.status.success(), "{}", stderr(&o));

    // A negative limit is a value, not an unknown flag.
    let o = arcsim(&[
        "profile",
        "--distance",
        "10",
        "--v-start",
        "0",
        "--v-end",
        "0",
        "--jerk",
        "1",
        "--accel",
        "-1",
        "--vel",
        "2",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("max_accel = -1: expected a finite number > 0"),
        "{}",
        stderr(&o)
    );

    // Terminal escapes in a name are shown, not obeyed; huge numbers stay short.
    let mut v = util::repo_json("plans/prostate.json");
    v["name"] = serde_json::json!("evil\u{1b}[2J\u{1b}[31mred");
    let named = dir.join("named.json");
    std::fs::write(&named, v.to_string()).expect("write");
    let o = arcsim(&["validate", path_str(&named)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stdout(&o).contains('\u{1b}'), "{}", stdout(&o));
    assert!(stdout(&o).contains("evil\\u{1b}[2J"), "{}", stdout(&o));
    v["arcs"][0]["control_points"][0]["angle_deg"] = serde_json::json!(1e308);
    std::fs::write(&named, v.to_string()).expect("write");
    let o = arcsim(&["validate", path_str(&named)]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(!err.contains('\u{1b}'), "{err}");
    assert!(err.contains("1e308 deg is beyond ±10000 deg"), "{err}");
    assert!(err.len() < 2000, "{err}");
}

#[test]
fn extreme_limits_are_refused_with_the_range() {
    let dir = temp_dir();
    let mut m = util::repo_json("scenarios/machine-atom.json");
    m["gantry"]["max_jerk_deg_per_s3"] = serde_json::json!(1e7);
    let path = dir.join("m.json");
    std::fs::write(&path, m.to_string()).expect("write");
    let o = arcsim(&[
        "simulate",
        "plans/head-neck.json",
        "--machine",
        path_str(&path),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("expected a value from 0.001 to 10000 deg/s^3, got 10000000"),
        "{}",
        stderr(&o)
    );
    let o = arcsim(&["simulate", "plans/prostate.json", "--period", "1e300"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--period 1e300"), "{}", stderr(&o));
}

/// The files of `dir` whose names start with `prefix`.
fn names_starting(dir: &Path, prefix: &str) -> Vec<String> {
    std::fs::read_dir(dir)
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(prefix))
        .collect()
}

#[cfg(unix)]
#[test]
fn outputs_go_through_symlinks_and_to_standard_output() {
    let dir = temp_dir();
    std::fs::create_dir(dir.join("real")).expect("dir");
    let link = dir.join("link.json");
    std::os::unix::fs::symlink("real/out.json", &link).expect("symlink");
    let run = |json: &str| {
        arcsim(&[
            "simulate",
            "plans/prostate.json",
            "--schedule",
            "scan",
            "--motion",
            "constant",
            "--json",
            json,
        ])
    };
    let o = run(path_str(&link));
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::symlink_metadata(&link)
        .expect("link")
        .file_type()
        .is_symlink());
    let written = std::fs::read_to_string(dir.join("real/out.json")).expect("target written");
    let doc: serde_json::Value = serde_json::from_str(&written).expect("json");
    // `-`: the document on standard output, the report on standard error. (`/dev/stdout` is
    // checked without writing, in the output module's unit tests: a regression must not replace
    // a system file.)
    let o = run("-");
    assert!(o.status.success(), "{}", stderr(&o));
    let out: serde_json::Value = serde_json::from_str(&stdout(&o)).expect("stdout is JSON");
    assert_eq!(out["total_s"], doc["total_s"]);
    assert!(stderr(&o).contains("total delivery time"), "{}", stderr(&o));
    // A binary output cannot go to standard output.
    let o = arcsim(&["simulate", "plans/prostate.json", "--rrd", "-"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("binary"), "{}", stderr(&o));
}

#[cfg(unix)]
#[test]
fn concurrent_writers_of_one_output_each_leave_a_whole_file() {
    let dir = temp_dir();
    let a = small_sweep(&dir, "a", &[0.5, 1.0, 2.0, 4.0]);
    let b = small_sweep(&dir, "b", &[0.25, 0.75, 1.5, 3.0]);
    let out = dir.join("rows.csv");
    let start = |sweep: &Path| {
        bin()
            .args([
                "sweep",
                path_str(sweep),
                "--threads",
                "1",
                "--out",
                path_str(&out),
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn")
    };
    let (ca, cb) = (start(&a), start(&b));
    let (oa, ob) = (
        ca.wait_with_output().expect("a"),
        cb.wait_with_output().expect("b"),
    );
    assert!(oa.status.success(), "{}", stderr(&oa));
    assert!(ob.status.success(), "{}", stderr(&ob));
    let merged = std::fs::read_to_string(&out).expect("output");
    // Each run alone, for what a whole file of each holds.
    let whole = |sweep: &Path, name: &str| {
        let p = dir.join(name);
        let o = arcsim(&["sweep", path_str(sweep), "--out", path_str(&p)]);
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read_to_string(p).expect("alone")
    };
    let (alone_a, alone_b) = (whole(&a, "a.csv"), whole(&b, "b.csv"));
    assert!(
        merged == alone_a || merged == alone_b,
        "the output is neither run's whole table:\n{merged}"
    );
    assert!(
        names_starting(&dir, "rows.csv.").is_empty(),
        "temporary files left"
    );
}

#[cfg(unix)]
#[test]
fn a_killed_sweep_keeps_its_rows_where_it_said() {
    let dir = temp_dir();
    let jerks: Vec<f64> = (1..=400).map(|i| 0.1 + 0.01 * f64::from(i)).collect();
    let sweep = sweep_file(&dir, "long", &jerks, &[0.5]);
    let out = dir.join("rows.csv");
    let mut child = bin()
        .args([
            "sweep",
            path_str(&sweep),
            "--threads",
            "1",
            "--out",
            path_str(&out),
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    // Wait for some rows in the temporary file, then SIGKILL.
    let started = Instant::now();
    let temp = loop {
        let temps = names_starting(&dir, "rows.csv.partial.");
        if let Some(t) = temps.first() {
            let p = dir.join(t);
            if std::fs::read_to_string(&p).is_ok_and(|s| s.lines().count() > 3) {
                break p;
            }
        }
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "no rows written"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    child.kill().expect("kill");
    let o = child.wait_with_output().expect("wait");
    assert!(
        stderr(&o).contains(path_str(&temp)),
        "the run did not say where its rows go: {}",
        stderr(&o)
    );
    let rows = std::fs::read_to_string(&temp).expect("rows kept");
    // A later command naming the same output, which fails on a malformed input, keeps them.
    let bad = dir.join("bad.json");
    std::fs::write(&bad, "{").expect("bad");
    let o = arcsim(&["sweep", path_str(&bad), "--out", path_str(&out)]);
    assert_ne!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&temp).expect("still kept"), rows);
    assert!(!out.exists());
}

#[test]
fn sweep_outputs_may_not_overwrite_the_files_the_sweep_names() {
    let dir = temp_dir();
    let plan = dir.join("plan.json");
    let machine = dir.join("machine.json");
    std::fs::copy(repo().join("plans/prostate.json"), &plan).expect("plan");
    std::fs::copy(repo().join("scenarios/machine-atom.json"), &machine).expect("machine");
    let sweep = dir.join("s.json");
    let text = serde_json::json!({
        "format": "arcsim-sweep/1",
        "name": "s",
        "plans": ["plan.json"],
        "machine": "machine.json",
        "axes": { "jerk_deg_per_s3": [0.5, 1.0] },
        "schedules": ["scan"]
    });
    std::fs::write(&sweep, text.to_string()).expect("sweep");
    let before = (
        std::fs::read(&plan).expect("plan"),
        std::fs::read(&machine).expect("machine"),
    );
    for (flag, target) in [
        ("--out", &plan),
        ("--json", &machine),
        ("--report", &plan),
        ("--rrd", &machine),
    ] {
        let o = arcsim(&["sweep", path_str(&sweep), flag, path_str(target)]);
        assert_eq!(o.status.code(), Some(2), "{flag}: {}", stderr(&o));
        assert!(stderr(&o).contains("is also an input"), "{}", stderr(&o));
    }
    // sweep-merge reads the sweep's files too.
    let shard = dir.join("all.csv");
    let o = arcsim(&["sweep", path_str(&sweep), "--out", path_str(&shard)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = arcsim(&[
        "sweep-merge",
        path_str(&shard),
        "--sweep",
        path_str(&sweep),
        "--out",
        path_str(&dir.join("m.csv")),
        "--report",
        path_str(&machine),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let after = (
        std::fs::read(&plan).expect("plan"),
        std::fs::read(&machine).expect("machine"),
    );
    assert!(before == after, "a file the sweep names was overwritten");
}

/// Moves far below the limits' scale (1e-11 deg under a 5 s ELST, 10 deg in 2e12 s) are solved:
/// what `validate` accepts, `simulate` delivers with either motion, and `profile` plans them.
#[test]
fn validate_and_simulate_agree_on_tiny_moves() {
    let layer = |e: f64, elst: Option<f64>| {
        let mut l = serde_json::json!({ "energy_mev": e, "irradiation_time_s": 1.0 });
        if let Some(s) = elst {
            l["switching_time_s"] = serde_json::json!(s);
        }
        l
    };
    let plan = serde_json::json!({
        "format": "arcsim-plan/1",
        "name": "tiny",
        "arcs": [{ "direction": "CW", "control_points": [
            { "angle_deg": 10.0, "window_deg": 0.0, "layers": [layer(150.0, None)] },
            { "angle_deg": 10.00000000001, "window_deg": 0.0, "layers": [layer(140.0, Some(5.0))] }
        ]}]
    });
    let path = temp_dir().join("tiny.json");
    std::fs::write(&path, plan.to_string()).expect("plan");
    let o = arcsim(&["validate", path_str(&path)]);
    assert!(o.status.success(), "{}", stderr(&o));
    for motion in ["constant", "free"] {
        let o = arcsim(&["simulate", path_str(&path), "--motion", motion]);
        assert!(o.status.success(), "{motion}: {}", stderr(&o));
        assert!(stdout(&o).contains("total delivery time"), "{}", stdout(&o));
    }
    let limits = [
        "--v-start",
        "0",
        "--v-end",
        "0",
        "--jerk",
        "0.5",
        "--accel",
        "0.5",
        "--vel",
        "6",
    ];
    for (d, t) in [("1e-10", "60"), ("10", "2e12")] {
        let mut args = vec!["profile", "--distance", d, "--min-duration", t];
        args.extend(limits);
        let o = arcsim(&args);
        assert!(o.status.success(), "{d} in {t} s: {}", stderr(&o));
    }
}
