//! Raising a gantry limit only admits more schedules, so the constant-speed `optimal` total must
//! never grow when J, A, D or V grows. One-axis sweeps (10 values each, the others at the ATOM
//! machine's) on the three ATOM cases (`plans/atom/`, committed: no reference file is needed) and
//! the bundled plans (`plans/*.json`), on the ATOM machine, `--motion constant`: along each sweep
//! no total may exceed the least total of a lower setting by more than 1e-6 relative. `scan` (the
//! seed of `optimal`) is held to the same. Grids and seeds scaled by each setting's own V fail
//! here (30 of the 280 `optimal` settings, worst bundled head-neck V 1.3 → 1.93: +0.014 s).
//! About 20 s in the test profile on 2 cores.

use arcsim_plan::{load_machine, load_plan, resolve, Machine, ResolvedArc};
use arcsim_planner::Limits;
use arcsim_sequencer::{simulate_resolved, Motion, Options, Schedule};
use rayon::prelude::*;

/// The plans swept: the ATOM article's cases and the bundled plans.
const PLANS: [&str; 7] = [
    "atom/prostate",
    "atom/head-and-neck",
    "atom/liver",
    "prostate",
    "lung",
    "two-arc",
    "head-neck",
];

/// Relative tolerance of the monotonicity check.
const REL: f64 = 1e-6;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Axis {
    J,
    A,
    D,
    V,
}

/// Ten values of each axis: low settings where the limit binds often, up past the ATOM
/// machine's (J 0.5, A 0.5, D = A, V 5); irregular steps so no value is a round multiple of
/// another.
fn values(axis: Axis) -> [f64; 10] {
    match axis {
        Axis::J => [0.12, 0.169, 0.23, 0.287, 0.36, 0.45, 0.58, 0.75, 1.0, 1.6],
        Axis::A | Axis::D => [0.15, 0.21, 0.28, 0.35, 0.43, 0.52, 0.698, 0.85, 1.1, 1.6],
        Axis::V => [1.3, 1.93, 2.2, 2.68, 3.1, 3.7, 4.4, 5.0, 6.2, 8.0],
    }
}

fn limits(m: &Machine, axis: Axis, x: f64) -> Limits {
    let g = &m.gantry;
    let (mut j, mut a, mut d, mut v) = (
        g.max_jerk_deg_per_s3,
        g.max_accel_deg_per_s2,
        g.max_decel_deg_per_s2.unwrap_or(g.max_accel_deg_per_s2),
        g.max_speed_deg_per_s,
    );
    match axis {
        Axis::J => j = x,
        Axis::A => a = x,
        Axis::D => d = x,
        Axis::V => v = x,
    }
    Limits::with_decel(j, a, d, v).expect("limits")
}

fn total(arcs: &[ResolvedArc], lim: &Limits, schedule: Schedule) -> f64 {
    let opts = Options {
        motion: Motion::Constant,
        build_timeline: false,
        ..Options::new(schedule)
    };
    simulate_resolved(arcs, lim, &opts)
        .expect("simulate")
        .total_s
}

/// The steps of one sweep where a total exceeds the least total of a lower setting by more than
/// `rel` relative, as text, and the largest excess (s) with its description.
fn violations(name: &str, axis: Axis, totals: &[f64], rel: f64) -> (Vec<String>, (f64, String)) {
    let mut found = Vec::new();
    let mut worst = (0.0f64, String::new());
    let mut best = (f64::INFINITY, 0.0);
    for (&x, &t) in values(axis).iter().zip(totals) {
        if t > best.0 {
            let excess = t - best.0;
            let what = format!(
                "{name} {axis:?} {} -> {x}: {:.6} s -> {t:.6} s (+{excess:.6} s)",
                best.1, best.0
            );
            if excess > worst.0 {
                worst = (excess, what.clone());
            }
            if t > best.0 * (1.0 + rel) {
                found.push(what);
            }
        }
        if t < best.0 {
            best = (t, x);
        }
    }
    (found, worst)
}

/// Sweeps every plan along every axis with `schedule`; returns the violations beyond [`REL`]
/// and the worst step, and prints a summary.
fn sweep(machine: &Machine, schedule: Schedule) -> (Vec<String>, usize) {
    let root = arcsim_suite::repo_root();
    let start = std::time::Instant::now();
    let jobs: Vec<(&str, Axis)> = PLANS
        .iter()
        .flat_map(|&p| [Axis::J, Axis::A, Axis::D, Axis::V].map(|a| (p, a)))
        .collect();
    let sweeps: Vec<(&str, Axis, Vec<f64>)> = jobs
        .par_iter()
        .map(|&(name, axis)| {
            let plan = load_plan(root.join(format!("plans/{name}.json"))).expect("plan");
            let arcs = resolve(&plan, machine).expect("resolve");
            let totals = values(axis)
                .iter()
                .map(|&x| total(&arcs, &limits(machine, axis, x), schedule))
                .collect();
            (name, axis, totals)
        })
        .collect();
    let mut failures = Vec::new();
    let mut worst = (0.0f64, String::new());
    for (name, axis, totals) in &sweeps {
        let (found, w) = violations(name, *axis, totals, REL);
        failures.extend(found);
        if w.0 > worst.0 {
            worst = w;
        }
    }
    let settings = sweeps.len() * 10;
    println!(
        "{}: {} sweeps, {settings} settings in {:.1} s, {} beyond {REL:e} relative; worst increase: {}",
        schedule.name(),
        sweeps.len(),
        start.elapsed().as_secs_f64(),
        failures.len(),
        if worst.1.is_empty() {
            "none".to_string()
        } else {
            worst.1
        }
    );
    (failures, settings)
}

#[test]
fn constant_speed_optimal_and_scan_are_monotone_in_every_limit() {
    let root = arcsim_suite::repo_root();
    let machine = load_machine(root.join("scenarios/machine-atom.json")).expect("machine");
    let mut report = Vec::new();
    for schedule in [Schedule::Optimal, Schedule::Scan] {
        let (failures, settings) = sweep(&machine, schedule);
        if !failures.is_empty() {
            report.push(format!(
                "{}: {} of {settings} settings exceed a lower setting's total by more than {REL:e} relative:\n{}",
                schedule.name(),
                failures.len(),
                failures.join("\n")
            ));
        }
    }
    assert!(report.is_empty(), "{}", report.join("\n"));
}
