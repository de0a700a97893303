//! What the CLI test files share: running the binary from the repository root as a user would,
//! its output as text, and small sweep files.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The `arcsim` binary, to run in the repository root.
pub fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_arcsim"));
    c.current_dir(repo());
    c
}

pub fn arcsim(args: &[&str]) -> Output {
    bin().args(args).output().expect("run arcsim")
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// (standard output, standard error)
pub fn text(o: &Output) -> (String, String) {
    (stdout(o), stderr(o))
}

pub fn path_str(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// Writes `DIR/NAME.json`: a `scan` sweep of one bundled plan (`plan`, relative to the
/// repository) on the ATOM machine over `axes`.
pub fn sweep_file(dir: &Path, name: &str, plan: &str, axes: serde_json::Value) -> PathBuf {
    let text = serde_json::json!({
        "format": "arcsim-sweep/1",
        "name": name,
        "plans": [path_str(&repo().join(plan))],
        "machine": path_str(&repo().join("scenarios/machine-atom.json")),
        "axes": axes,
        "schedules": ["scan"]
    });
    let path = dir.join(format!("{name}.json"));
    std::fs::write(&path, text.to_string()).expect("write sweep");
    path
}

/// A sweep file of the bundled prostate plan with `scan` over the given jerks × accelerations.
pub fn prostate_sweep(dir: &Path, name: &str, jerks: &[f64], accels: &[f64]) -> PathBuf {
    sweep_file(
        dir,
        name,
        "plans/prostate.json",
        serde_json::json!({ "jerk_deg_per_s3": jerks, "accel_deg_per_s2": accels }),
    )
}

/// A JSON file of the repository (`plans/…`, `scenarios/…`), parsed, to edit in a test.
pub fn repo_json(rel: &str) -> serde_json::Value {
    let text = std::fs::read_to_string(repo().join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

/// Runs `cmd` to its end: its standard output and error as text, or (when it cannot start or
/// fails) the command and that text as the error.
pub fn run(cmd: &mut Command) -> Result<String, String> {
    let shown = format!("{cmd:?}");
    let out = cmd
        .output()
        .map_err(|e| format!("{shown}: cannot start: {e}"))?;
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    if out.status.success() {
        Ok(text)
    } else {
        Err(format!("{shown} failed:\n{text}"))
    }
}

/// The Python interpreter to use (`ARCSIM_PYTHON`, else `python3`), once it answers `--version`.
pub fn python() -> Result<String, String> {
    let python = std::env::var("ARCSIM_PYTHON").unwrap_or_else(|_| "python3".into());
    run(Command::new(&python).arg("--version")).map(|_| python)
}

/// `pip install`s `packages` quietly into the environment of the interpreter `python`.
pub fn pip_install(python: &Path, packages: &[&str]) -> Result<String, String> {
    run(Command::new(python)
        .args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
        ])
        .args(packages))
}

/// Removes from `cmd` what Cargo sets for this test process. Passed on to a nested cargo (a
/// build, maturin), they change the fingerprints of build scripts that watch them (ring's
/// watches `CARGO_MANIFEST_DIR`), and rerun with everything above it would compile again.
pub fn without_test_environment(cmd: &mut Command) -> &mut Command {
    for (key, _) in std::env::vars_os() {
        let key = key.to_string_lossy();
        let set_for_tests = [
            "CARGO_MANIFEST_DIR",
            "CARGO_MANIFEST_PATH",
            "CARGO_CRATE_NAME",
            "CARGO_PRIMARY_PACKAGE",
            "CARGO_TARGET_TMPDIR",
            "CARGO_BIN_NAME",
        ]
        .contains(&key.as_ref())
            || key.starts_with("CARGO_PKG_")
            || key.starts_with("CARGO_BIN_EXE_");
        if set_for_tests {
            cmd.env_remove(key.as_ref());
        }
    }
    cmd
}

/// Held by each test that loads the machine for minutes (sweeps, the probes, the independent
/// optimiser, the wheel build, nested cargo): they take turns, so the ones with a time limit
/// per run are not starved by the others on a 2-core machine. A test that failed while holding
/// it does not block the rest.
pub fn one_heavy_test_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    static HEAVY: std::sync::Mutex<()> = std::sync::Mutex::new(());
    HEAVY
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Asserts that each `(field, truth)` of a calibration report's `values` is determined, within
/// `rel` of the truth, with a 95 % interval that holds it; `context` (e.g. the printed report)
/// is shown on failure.
pub fn assert_recovered(
    report: &serde_json::Value,
    truths: &[(&str, f64)],
    rel: f64,
    context: &str,
) {
    for &(field, truth) in truths {
        let v = report["values"]
            .as_array()
            .expect("values")
            .iter()
            .find(|v| v["field"] == field)
            .unwrap_or_else(|| panic!("{field}\n{context}"));
        let got = v["value"].as_f64().expect("value");
        assert!(
            v["determined"] == true && (got / truth - 1.0).abs() < rel,
            "{field}: {got} (truth {truth})\n{context}"
        );
        let iv = v["interval"].as_array().expect("interval");
        let (lo, hi) = (iv[0].as_f64().expect("lo"), iv[1].as_f64().expect("hi"));
        assert!(
            lo <= truth && truth <= hi,
            "{field}: {truth} outside {lo}–{hi}\n{context}"
        );
    }
}

/// The scanning machine `calibrate-spots` tests hide: `base` (a machine file of the repository)
/// scanning at 6,000 mm/s with 2 ms of settling and every time per MU 10 % longer, then `extra`
/// beam fields set; written as `dir/hidden.json`.
pub fn hidden_scanning_machine(dir: &Path, base: &str, extra: &[(&str, f64)]) -> PathBuf {
    let mut m = repo_json(base);
    m["name"] = "hidden".into();
    let b = &mut m["beam"];
    b["scan_speed_mm_per_s"] = 6000.0.into();
    b["settling_time_s"] = 0.002.into();
    for (field, value) in extra {
        b[*field] = (*value).into();
    }
    for row in b["s_per_mu_by_energy"].as_array_mut().expect("table") {
        let r = row[1].as_f64().expect("rate");
        row[1] = (1.1 * r).into();
    }
    let path = dir.join("hidden.json");
    std::fs::write(&path, m.to_string()).expect("machine written");
    path
}
