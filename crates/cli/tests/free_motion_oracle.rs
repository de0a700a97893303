//! Free motion against an independent optimiser: `tests/oracle/free_motion_ipopt.py`
//! solves each case's free-motion problem on its own (direct multiple shooting, CasADi + IPOPT,
//! started from arcsim's timeline; the formulation is in the script's docstring), checks its answer
//! by dense re-integration against every limit, window, irradiation time and ELST, and the test
//! fails when that verified answer is shorter than arcsim's free-motion total by more than 0.05 %
//! (more on the two plans of [`KNOWN_GAPS`]), or a case has no verified answer. Cases: the three ATOM article cases on the ATOM machine with
//! rest and free arc ends, and the bundled prostate, lung and two-arc plans on their default
//! machine with rest ends; in ignored tests, the 722-layer bundled head-neck (five minutes, more
//! than the others together) and, for issue 45, three bundled plans on the faster machine.
//!
//! The script runs in a virtual environment under the target directory with CasADi (pinned) and
//! numpy from the package index, two cases at a time: about 2 minutes on 2 cores. Without Python
//! or the package index the test fails, saying why.

use crate::util;

use std::path::Path;
use std::process::Command;

use crate::util::run;

/// What the environment installs: CasADi at the version the oracle was written and measured with.
const PACKAGES: &[&str] = &["casadi==3.8.2", "numpy"];

/// Largest relative shortening of arcsim's total that the oracle may find (the script's `GAP`).
const GAP: f64 = 5e-4;

/// Known gaps, larger than [`GAP`] (an open issue): on these plans the refinement
/// stops in another local optimum, where most control points hold two layers and the long
/// upward switches between them leave the exact build (Ruckig's moves between the transcript's
/// states) failing for many steps. Measured: lung −0.12 % (−0.42 % before a change of rounding in
/// the interior point moved the refinement's path), head-neck −0.29 %.
const KNOWN_GAPS: &[(&str, f64)] = &[("lung", 6e-3), ("head-neck", 5e-3)];

fn cannot_run(why: &str) -> ! {
    arcsim_test_support::cannot_run("the free-motion oracle", why)
}

/// Runs the oracle on `only` (its names; empty: its default cases) and returns its cases (the
/// result JSON) and whether the script exited 0 or 1. Without Python or the package index the
/// test fails, saying so.
fn run_oracle(only: &[&str]) -> (Vec<serde_json::Value>, bool) {
    let _turn = crate::util::one_heavy_test_at_a_time();
    let repo = util::repo();
    let python = match util::python() {
        Ok(python) => python,
        Err(e) => cannot_run(&e),
    };
    let work = Path::new(env!("CARGO_TARGET_TMPDIR")).join("free-motion-oracle");
    let venv = work.join("venv");
    std::fs::create_dir_all(&work).expect("work dir");
    // The environment is kept between runs; pip leaves it as it is when the pins are met.
    if !venv.join("bin/python").exists() {
        if let Err(e) = run(Command::new(&python).args(["-m", "venv"]).arg(&venv)) {
            let _ = std::fs::remove_dir_all(&venv);
            cannot_run(&e);
        }
    }
    let py = venv.join("bin/python");
    if let Err(e) = util::pip_install(&py, PACKAGES) {
        cannot_run(&e);
    }

    let result = work.join(format!("result{}.json", only.join("+")));
    let _ = std::fs::remove_file(&result);
    let mut cmd = Command::new(&py);
    cmd.arg(repo.join("tests/oracle/free_motion_ipopt.py"))
        .arg("--arcsim")
        .arg(env!("CARGO_BIN_EXE_arcsim"))
        .arg("--repo")
        .arg(&repo)
        .arg("--out")
        .arg(&result)
        .args(["--jobs", "2"]);
    if !only.is_empty() {
        cmd.arg("--only").args(only);
    }
    let out = cmd.output().expect("run the oracle");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    println!("{text}");
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(&result)
            .unwrap_or_else(|e| panic!("the oracle wrote no result ({e}):\n{text}")),
    )
    .expect("oracle result JSON");
    let cases = json["cases"].as_array().expect("cases").clone();
    (cases, matches!(out.status.code(), Some(0 | 1)))
}

/// The cases where the oracle's verified answer is shorter than arcsim's by more than the gap
/// allowed (`known`, else [`GAP`]), or that have no verified answer.
fn beaten(cases: &[serde_json::Value], known: &[(&str, f64)]) -> Vec<String> {
    let mut failures = Vec::new();
    for c in cases {
        let name = format!(
            "{} ({} ends)",
            c["case"].as_str().unwrap_or("?"),
            c["ends"].as_str().unwrap_or("?")
        );
        let arcsim = c["arcsim_total_s"].as_f64().expect("arcsim total");
        let gap = known
            .iter()
            .find(|(plan, _)| c["case"].as_str() == Some(plan))
            .map_or(GAP, |&(_, g)| g);
        match c["oracle_total_s"].as_f64() {
            None => failures.push(format!(
                "{name}: no verified oracle solution: {}",
                c["failures"]
            )),
            Some(oracle) if arcsim > oracle * (1.0 + gap) => failures.push(format!(
                "{name}: the oracle delivers in {oracle:.4} s, arcsim in {arcsim:.4} s ({:+.3} %, allowed {:.3} %)",
                100.0 * (oracle - arcsim) / arcsim,
                100.0 * gap
            )),
            Some(_) => {}
        }
    }
    failures
}

/// Runs the oracle on `only` (empty: its default cases, `expected` of them) and fails unless every
/// case ran, none beats arcsim by more than its gap (`known`, else [`GAP`]) and the script itself
/// did not fail. The oracle's log and table are printed above the failure.
fn within_reach(only: &[&str], expected: usize, known: &[(&str, f64)]) {
    let (cases, script_ran) = run_oracle(only);
    assert_eq!(
        cases.len(),
        expected,
        "every case ran (the oracle's output is above)"
    );
    let failures = beaten(&cases, known);
    assert!(
        failures.is_empty(),
        "free motion is not within reach of the independent optimiser:\n{}",
        failures.join("\n")
    );
    // The script exits 1 when a case misses its own 0.05 % (the known gaps above); anything else
    // is a failure of the script itself.
    assert!(script_ran, "the oracle failed (its output is above)");
}

#[test]
fn no_independent_optimiser_beats_free_motion() {
    within_reach(&[], 9, KNOWN_GAPS);
}

/// The 722-layer bundled head-neck on its default machine with rest ends (measured 2026-12-07:
/// 320 s of the oracle's 327 s on 2 cores, arcsim 598.33 s, −0.29 %, its known gap).
#[test]
#[ignore = "about 5 minutes of IPOPT on 2 cores, more than every other case together: run with --ignored"]
fn no_independent_optimiser_beats_free_motion_on_the_largest_plan() {
    within_reach(&["head-neck"], 1, KNOWN_GAPS);
}

/// The bundled lung, prostate and two-arc plans on the faster machine
/// (`scenarios/machine-fast.json`), which the cases above do not cover. Measured 2026-12-06:
/// prostate −0.048 %, two-arc −0.024 %, but lung −6.23 % (the oracle verifies 84.82 s against
/// arcsim's 90.45 s): the refinement stops far from the optimum there.
#[test]
#[ignore = "issue 45: on machine-fast the bundled lung plan's free motion is 6.2 % longer than the independent optimiser's (90.45 s against 84.82 s); run with --ignored"]
fn no_independent_optimiser_beats_free_motion_on_a_faster_machine() {
    within_reach(&["lung-fast", "prostate-fast", "two-arc-fast"], 3, &[]);
}
