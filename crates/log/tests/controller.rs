//! Calibration learns a machine's controller from its logs. Machines hidden here, one per
//! controller: free motion, constant speed per layer (optimal schedule), and a constant-speed
//! machine whose gantry is a servo loop written in this file (a second-order lag with overshoot
//! tracking the planned constant-speed trajectory), so the logs do not come from the sequencer's
//! own motion. Each fit uses 3 plans, 10 ms samples, 0.01° noise, 3 % ELST jitter; the base is
//! the ATOM machine (constant speed per layer); a held-out plan is predicted by the fitted
//! machine under the controller it wrote, with no option given.

use std::path::PathBuf;

use arcsim_log::{
    calibrate_controller, parse_log, to_csv, virtual_log, Calibration, ColumnMap, DeliveryLog,
    ElstFit, LogSample, LoggedRun, VirtualLogOptions,
};
use arcsim_plan::{
    generate, load_plan, parse_machine, resolve, ArcPlan, BeamModel, ElstModel, Machine, Motion,
    PlanKind, TimingSpread,
};
use arcsim_sequencer::{
    machine_limits, simulate, simulate_resolved, spot_timeline, Options, Schedule,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn bundled(name: &str) -> ArcPlan {
    load_plan(repo().join(format!("plans/{name}.json"))).expect("plan")
}

/// A constant-speed machine unlike the bundled ones: V 3.5 °/s (not reached on these plans),
/// A 0.4, J 0.6, ELST 4.0 s up and 0.7 s down, 0.0045 s/MU.
const HIDDEN_CONSTANT: &str = r#"{
  "format": "arcsim-machine/1", "name": "hidden-constant",
  "gantry": {"max_speed_deg_per_s": 3.5, "max_accel_deg_per_s2": 0.4, "max_jerk_deg_per_s3": 0.6},
  "beam": {"s_per_mu": 0.0045, "spot_switch_time_s": 0.002, "min_spot_time_s": 0.0},
  "elst": {"kind": "constant", "up_s": 4.0, "down_s": 0.7, "same_s": 0.0},
  "default_window_deg": 1.0
}"#;

/// A constant-speed synchrocyclotron unlike the bundled ProteusONE-like one (its base here):
/// every time per MU 0.8 of that machine's (a higher dose rate), 0.22 s between bursts (not
/// 0.15), ELST 4.0 s up and 0.7 s down or same (not 6.0 and 0.6), V 3.5, A 0.4, J 0.6.
const HIDDEN_BURST: &str = r#"{
  "format": "arcsim-machine/1", "name": "hidden-burst",
  "gantry": {"max_speed_deg_per_s": 3.5, "max_accel_deg_per_s2": 0.4, "max_jerk_deg_per_s3": 0.6},
  "beam": {
    "kind": "scanning",
    "s_per_mu_by_energy": [[60, 0.0304], [70, 0.0184], [80, 0.0136], [90, 0.0104], [100, 0.008], [110, 0.0064], [120, 0.0048], [130, 0.0056], [140, 0.0056], [150, 0.0048], [227, 0.0048]],
    "scan_speed_mm_per_s": 8000.0, "scan_distance": "euclidean", "min_spot_time_s": 0.00025,
    "max_mu_per_spot": 1.0, "burst_switching_time_s": 0.22
  },
  "elst": {"kind": "constant", "up_s": 4.0, "down_s": 0.7, "same_s": 0.7},
  "default_window_deg": 1.0
}"#;

/// How the hidden machine's gantry really moves.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Truth {
    Free,
    Constant,
    /// Constant speed per layer as planned, followed by a servo loop with lag and overshoot.
    Servo,
    /// Constant speed per layer, the beam in bursts (a synchrocyclotron).
    Burst,
}

impl Truth {
    fn motion(self) -> Motion {
        match self {
            Truth::Free => Motion::Free,
            Truth::Constant | Truth::Servo | Truth::Burst => Motion::Constant,
        }
    }

    /// The machine calibration starts from: ATOM's, or for a beam in bursts the bundled
    /// ProteusONE-like one (a beam model with bursts to fit).
    fn base(self) -> Machine {
        let name = match self {
            Truth::Burst => "machine-proteusone-like.json",
            _ => "machine-atom.json",
        };
        arcsim_plan::load_machine(repo().join("scenarios").join(name)).expect("base")
    }
}

fn hidden(truth: Truth) -> Machine {
    match truth {
        Truth::Free => parse_machine(arcsim_test_support::HIDDEN_MACHINE_JSON, "hidden"),
        Truth::Constant | Truth::Servo => parse_machine(HIDDEN_CONSTANT, "hidden-constant"),
        Truth::Burst => parse_machine(HIDDEN_BURST, "hidden-burst"),
    }
    .expect("hidden machine")
}

/// A second-order servo (natural frequency 12 rad/s, damping 0.5: about 16 % overshoot, 0.1 s
/// lag) tracking `reference`, integrated with the log's own period. Written here, independent of
/// the sequencer's moves.
fn servo(samples: &mut [LogSample]) {
    let (wn, zeta) = (12.0_f64, 0.5_f64);
    let Some(first) = samples.first() else { return };
    let (mut x, mut v) = (first.gantry_angle_deg, 0.0);
    let mut prev_t = first.t_s;
    for s in samples.iter_mut() {
        let dt = s.t_s - prev_t;
        prev_t = s.t_s;
        // Sub-steps keep the explicit integration stable and accurate.
        let n = (dt / 1e-3).ceil().max(1.0) as usize;
        let h = dt / n as f64;
        for _ in 0..n {
            let a = wn * wn * (s.gantry_angle_deg - x) - 2.0 * zeta * wn * v;
            v += h * a;
            x += h * v;
        }
        s.gantry_angle_deg = x;
    }
}

/// A log of `plan` delivered by the hidden machine of `truth`: each switch's ELST drawn at 3 %
/// (seeded), sampled every 10 ms, 0.01° of angle noise, written and read back as a file.
fn log_of(plan: &ArcPlan, truth: Truth, seed: u64, name: &str) -> DeliveryLog {
    noisy_log_of(plan, truth, seed, name, 0.01)
}

/// [`log_of`] with `noise_deg` of angle noise.
fn noisy_log_of(
    plan: &ArcPlan,
    truth: Truth,
    seed: u64,
    name: &str,
    noise_deg: f64,
) -> DeliveryLog {
    let machine = hidden(truth);
    let arcs = resolve(plan, &machine).expect("resolves");
    let ElstModel::Constant { up_s, down_s, .. } = machine.elst else {
        unreachable!("hidden machines have a constant ELST")
    };
    let jitter = TimingSpread {
        elst_up_sd_s: 0.03 * up_s,
        elst_down_sd_s: 0.03 * down_s,
        elst_same_sd_s: 0.0,
        beam_time_sd_fraction: 0.0,
    };
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut normal = move || rng.sample::<f64, _>(StandardNormal);
    let drawn = jitter.draw(&arcs, &mut normal);
    let limits = machine_limits(&machine).expect("limits");
    let opts = Options {
        motion: truth.motion(),
        build_timeline: true,
        ..Options::new(Schedule::Optimal)
    };
    let d = simulate_resolved(&drawn, &limits, &opts).expect("simulated");
    let spots = spot_timeline(plan, &machine, &d).expect("spots");
    let clean = VirtualLogOptions {
        period_s: 0.01,
        angle_noise_deg: 0.0,
        seed,
    };
    let mut samples = virtual_log(&d, &spots, &clean).expect("log");
    if truth == Truth::Servo {
        servo(&mut samples);
    }
    for s in &mut samples {
        s.gantry_angle_deg += noise_deg * normal();
    }
    // Every other log has an encoder glitch: one sample 5° off.
    if seed % 2 == 1 {
        let k = samples.len() / 3;
        samples[k].gantry_angle_deg += 5.0;
    }
    parse_log(to_csv(&samples).as_bytes(), name, &ColumnMap::default()).expect("reads back")
}

fn runs(truth: Truth, seed: u64) -> Vec<LoggedRun> {
    ["lung", "prostate", "two-arc"]
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let plan = bundled(name);
            let log = log_of(&plan, truth, seed * 10 + k as u64, &format!("{name}.log"));
            LoggedRun {
                plan_name: name.to_string(),
                plan,
                log,
            }
        })
        .collect()
}

fn atom() -> Machine {
    arcsim_plan::load_machine(repo().join("scenarios/machine-atom.json")).expect("atom")
}

fn fit(truth: Truth, seed: u64) -> Calibration {
    let opts = Options::new(Schedule::Optimal);
    calibrate_controller(
        &truth.base(),
        &runs(truth, seed),
        ElstFit::Constant,
        &opts,
        None,
    )
    .expect("calibrated")
}

fn within(x: f64, truth: f64, tol: f64, what: &str) {
    assert!(
        (x / truth - 1.0).abs() <= tol,
        "{what}: fitted {x}, hidden {truth} (tolerance {} %)",
        100.0 * tol
    );
}

/// What issue 44 asks of every seed: the controller right, ELST and s/MU within 2 %, a held-out
/// plan within 1 % of its log under the controller the fitted machine names.
fn check(truth: Truth, seed: u64) {
    let cal = fit(truth, seed);
    for v in &cal.report.values {
        eprintln!("{} = {} {:?} ({})", v.field, v.value, v.interval, v.note);
    }
    let controller = cal
        .machine
        .controller
        .clone()
        .expect("a controller written");
    let evidence = controller.evidence.clone().expect("its evidence");
    assert_eq!(
        (controller.motion, evidence.decision.as_str()),
        (truth.motion(), "chosen"),
        "seed {seed}, {truth:?}: {}",
        controller.source
    );
    let hidden = hidden(truth);
    let (
        ElstModel::Constant { up_s, down_s, .. },
        ElstModel::Constant {
            up_s: u, down_s: d, ..
        },
    ) = (&cal.machine.elst, &hidden.elst)
    else {
        panic!("constant ELST expected")
    };
    within(*up_s, *u, 0.02, "ELST up");
    within(*down_s, *d, 0.02, "ELST down");
    match (&cal.machine.beam, &hidden.beam) {
        (BeamModel::PerMu(b), BeamModel::PerMu(t)) => {
            within(b.s_per_mu, t.s_per_mu, 0.02, "s per MU")
        }
        (BeamModel::Scanning(b), BeamModel::Scanning(t)) => {
            for (row, truth_row) in b.s_per_mu_by_energy.iter().zip(&t.s_per_mu_by_energy) {
                within(
                    row[1],
                    truth_row[1],
                    0.02,
                    &format!("s per MU at {} MeV", row[0]),
                );
            }
            within(
                b.burst_switching_time_s,
                t.burst_switching_time_s,
                0.02,
                "burst switching time",
            );
        }
        other => panic!("the beam model's kind changed: {other:?}"),
    }
    // A and J where the logs reach them (the servo loop's are its own, not the machine's).
    if truth != Truth::Servo {
        let value = |field: &str| cal.report.value(field).expect(field).clone();
        let (a, j) = (
            value("gantry.max_accel_deg_per_s2"),
            value("gantry.max_jerk_deg_per_s3"),
        );
        if a.determined {
            within(a.value, hidden.gantry.max_accel_deg_per_s2, 0.05, "A");
        }
        if j.determined {
            within(j.value, hidden.gantry.max_jerk_deg_per_s3, 0.10, "J");
        }
    }
    // V is never below what the logs show of it.
    let v = cal.report.value("gantry.max_speed_deg_per_s").expect("V");
    if let Some(peak) = cal.report.observed.speed.as_ref() {
        assert!(
            v.value >= 0.98 * peak.peak,
            "V {} below the logged peak {}",
            v.value,
            peak.peak
        );
    }
    // A speed read as V is V: under constant speed per layer a layer's plateau is not
    // (these plans never reach the hidden V of the constant-speed machines).
    if v.determined {
        within(
            v.value,
            hidden.gantry.max_speed_deg_per_s,
            0.05,
            "V (determined)",
        );
    }
    // The fitted machine alone (its controller, no option) predicts a plan it never saw.
    let held_out = generate(PlanKind::Lung, 7);
    let logged = log_of(&held_out, truth, seed + 1000, "held-out.log");
    let layers = arcsim_log::match_layers(
        &logged,
        &resolve(&held_out, &cal.machine).expect("resolves"),
    )
    .expect("matches");
    let logged_total = layers[layers.len() - 1].end_s - layers[0].start_s;
    let opts = Options {
        motion: controller.motion,
        ..Options::new(controller.schedule)
    };
    let predicted = simulate(&held_out, &cal.machine, &opts)
        .expect("simulated")
        .total_s;
    within(predicted, logged_total, 0.01, "held-out total");
}

// CI checks four fits, one per machine: two seeds whose logs hold an encoder glitch (odd) and two
// whose logs do not. A fit costs about 2.5 CPU-minutes, most of it free-motion simulations
// (issue 45); the twenty seeds of each machine issue 44 asks for run in `controller_twenty_seeds`
// below.
#[test]
fn calibration_learns_a_constant_speed_controller() {
    check(Truth::Constant, 0);
}

#[test]
fn calibration_learns_a_free_motion_controller() {
    check(Truth::Free, 1);
}

#[test]
fn calibration_learns_a_constant_speed_machine_with_a_beam_in_bursts() {
    check(Truth::Burst, 1);
}

#[test]
fn calibration_learns_a_servo_loop_as_constant_speed() {
    check(Truth::Servo, 2);
}

/// `--motion` forces the model: the fit is made under it and says so.
#[test]
fn a_forced_motion_is_written_as_forced() {
    let opts = Options::new(Schedule::Optimal);
    let cal = calibrate_controller(
        &atom(),
        &runs(Truth::Constant, 3),
        ElstFit::Constant,
        &opts,
        Some(Motion::Free),
    )
    .expect("calibrated");
    let c = cal.machine.controller.expect("controller");
    assert_eq!(c.motion, Motion::Free);
    assert_eq!(c.evidence.expect("evidence").decision, "forced");
    // Fitted under the wrong model, the residuals say so.
    assert!(
        !cal.report.warnings.is_empty(),
        "{:?}",
        cal.report.residuals
    );
}

/// The long run issue 44 asks for: 20 seeds per machine (CI runs four fits, above). `cargo test -p arcsim-log --release
/// -- --ignored controller_twenty_seeds --nocapture`.
#[test]
#[ignore = "about 20 minutes: run by hand, figures in the closing note"]
fn controller_twenty_seeds() {
    let mut failed = Vec::new();
    for truth in [Truth::Constant, Truth::Free, Truth::Servo, Truth::Burst] {
        for seed in 0..20 {
            // Every seed is run and the failures listed together (one alone says little).
            match std::panic::catch_unwind(|| check(truth, seed)) {
                Ok(()) => eprintln!("{truth:?} seed {seed}: ok"),
                Err(_) => failed.push(format!("{truth:?} seed {seed}")),
            }
        }
    }
    assert!(failed.is_empty(), "failed: {failed:?}");
}

/// Issue 44, finding 10: logs of two different machines pooled for one fit leave residuals no
/// single machine explains, and the report says so instead of exiting quietly.
#[test]
fn logs_of_two_machines_pooled_are_flagged() {
    let mut runs = runs(Truth::Constant, 4);
    // The third log comes from a machine whose upward switches take 5.5 s, not 4.0 s.
    let mut other = hidden(Truth::Constant);
    other.elst = ElstModel::Constant {
        up_s: 5.5,
        down_s: 1.2,
        same_s: 0.0,
    };
    let text = serde_json::to_string(&other).expect("json");
    let plan = bundled("two-arc");
    let machine = parse_machine(&text, "other").expect("machine");
    let arcs = resolve(&plan, &machine).expect("resolves");
    let limits = machine_limits(&machine).expect("limits");
    let d = simulate_resolved(&arcs, &limits, &Options::new(Schedule::Optimal)).expect("sim");
    let spots = spot_timeline(&plan, &machine, &d).expect("spots");
    let samples = virtual_log(
        &d,
        &spots,
        &VirtualLogOptions {
            period_s: 0.01,
            angle_noise_deg: 0.01,
            seed: 9,
        },
    )
    .expect("log");
    runs[2].log = parse_log(
        to_csv(&samples).as_bytes(),
        "other.log",
        &ColumnMap::default(),
    )
    .expect("reads");
    // Under the controller all three machines share (the choice between models is tested above;
    // here it would double the cost for nothing).
    let cal = calibrate_controller(
        &atom(),
        &runs,
        ElstFit::Constant,
        &Options::new(Schedule::Optimal),
        Some(Motion::Constant),
    )
    .expect("calibrated");
    assert!(
        cal.report
            .warnings
            .iter()
            .any(|w| w.contains("the logs disagree")),
        "{:?} {:?}",
        cal.report.warnings,
        cal.report.residuals
    );
}

/// Issue 44, finding 4: an upward ELST line fitted only to small energy steps warns that larger
/// steps are an extrapolation, with what the line gives there.
#[test]
fn an_elst_line_from_small_steps_warns_of_extrapolation() {
    // Lung with every energy set to alternate by 0.5 MeV: each upward step is 0.5 MeV.
    let mut plan = bundled("lung");
    for (k, layer) in plan
        .arcs
        .iter_mut()
        .flat_map(|a| {
            a.control_points
                .iter_mut()
                .flat_map(|cp| cp.layers.iter_mut())
        })
        .enumerate()
    {
        layer.energy_mev = 150.0 + if k % 2 == 1 { 0.5 } else { 0.0 };
    }
    let log = log_of(&plan, Truth::Constant, 5, "small-steps.log");
    let runs = [LoggedRun {
        plan_name: "small steps".into(),
        plan,
        log,
    }];
    let cal = calibrate_controller(
        &atom(),
        &runs,
        ElstFit::Polynomial,
        &Options::new(Schedule::Optimal),
        Some(Motion::Constant),
    )
    .expect("calibrated");
    assert!(
        cal.report
            .warnings
            .iter()
            .any(|w| w.contains("upward steps of 0.50–0.50 MeV") && w.contains("extrapolation")),
        "{:?}",
        cal.report.warnings
    );
}

/// The hidden value behind a report row, where the hidden machine has one.
fn hidden_value(truth: Truth, field: &str) -> Option<f64> {
    let m = hidden(truth);
    let ElstModel::Constant {
        up_s,
        down_s,
        same_s,
    } = m.elst
    else {
        return None;
    };
    match (field, &m.beam) {
        // The servo's acceleration and jerk are its own loop's, not a limit of the machine.
        ("gantry.max_accel_deg_per_s2" | "gantry.max_jerk_deg_per_s3", _)
            if truth == Truth::Servo =>
        {
            None
        }
        ("gantry.max_speed_deg_per_s", _) => Some(m.gantry.max_speed_deg_per_s),
        ("gantry.max_accel_deg_per_s2", _) => Some(m.gantry.max_accel_deg_per_s2),
        ("gantry.max_jerk_deg_per_s3", _) => Some(m.gantry.max_jerk_deg_per_s3),
        ("elst.up_s", _) => Some(up_s),
        ("elst.down_s", _) => Some(down_s),
        ("elst.same_s", _) => Some(same_s),
        ("beam.s_per_mu", BeamModel::PerMu(b)) => Some(b.s_per_mu),
        // HIDDEN_BURST's times per MU are 0.8 of its base's.
        ("beam.s_per_mu_scale", BeamModel::Scanning(_)) => Some(0.8),
        ("beam.burst_switching_time_s", BeamModel::Scanning(b)) => Some(b.burst_switching_time_s),
        _ => None,
    }
}

/// Issue 44's long run: over `seeds` seeds of the machine `truth` (its controller forced, as
/// the decision is the twenty-seed run's), how often each 95 % interval holds the hidden value,
/// and the intervals' median relative width. Asserts coverage in [90 %, 99 %] for every value
/// with at least 50 intervals; prints the table.
fn coverage(truth: Truth, seeds: std::ops::Range<u64>) {
    use std::collections::BTreeMap;
    let mut seen: BTreeMap<String, (usize, usize, Vec<f64>)> = BTreeMap::new();
    let total = seeds.end - seeds.start;
    for seed in seeds {
        let cal = calibrate_controller(
            &truth.base(),
            &runs(truth, seed),
            ElstFit::Constant,
            &Options::new(Schedule::Optimal),
            Some(truth.motion()),
        )
        .expect("calibrated");
        for v in &cal.report.values {
            let (Some([lo, hi]), Some(t), true) =
                (v.interval, hidden_value(truth, &v.field), v.determined)
            else {
                continue;
            };
            let e = seen.entry(v.field.clone()).or_default();
            e.0 += 1;
            if (lo..=hi).contains(&t) {
                e.1 += 1;
            } else {
                eprintln!(
                    "{truth:?} seed {seed}: {} {} [{lo}, {hi}] misses {t}",
                    v.field, v.value
                );
            }
            e.2.push((hi - lo) / t);
        }
    }
    eprintln!(
        "{truth:?}, {total} seeds: value | intervals | coverage | median width (of the truth)"
    );
    let mut failures = Vec::new();
    for (field, (n, hits, mut widths)) in seen {
        widths.sort_by(f64::total_cmp);
        let cover = hits as f64 / n as f64;
        eprintln!(
            "| {field} | {n} | {:.1} % | {:.2} % |",
            100.0 * cover,
            100.0 * widths[widths.len() / 2]
        );
        if n >= 50 && !(0.90..=0.99).contains(&cover) {
            failures.push(format!("{field}: {:.1} % of {n}", 100.0 * cover));
        }
    }
    assert!(
        failures.is_empty(),
        "coverage outside [90 %, 99 %]: {failures:?}"
    );
}

/// 200 seeds, or `ARCSIM_COVERAGE_SEEDS` (a shorter look; values with fewer than 50
/// intervals are printed, not asserted).
fn coverage_seeds() -> u64 {
    std::env::var("ARCSIM_COVERAGE_SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(200)
}

#[test]
#[ignore = "about 40 minutes per machine: run by hand, figures in the closing note"]
fn interval_coverage_constant_speed() {
    coverage(Truth::Constant, 0..coverage_seeds());
}

#[test]
#[ignore = "about an hour per machine: run by hand, figures in the closing note"]
fn interval_coverage_free_motion() {
    coverage(Truth::Free, 0..coverage_seeds());
}

#[test]
#[ignore = "about an hour per machine: run by hand, figures in the closing note"]
fn interval_coverage_beam_in_bursts() {
    coverage(Truth::Burst, 0..coverage_seeds());
}

/// The trace's acceleration plateau, corrected by replaying the fitted machine: with 0.03° of
/// noise (three times the other tests') the plateau's band takes in more windows over its edges
/// and A reads low (1.6 % on average here); the replay measures that bias and the estimator's
/// spread. The correction raises A and its interval holds the truth (on seed 3 the trace's own,
/// [0.377, 0.398], does not).
#[test]
fn the_acceleration_plateau_is_corrected_by_replay() {
    let truth = Truth::Constant;
    let hidden_a = hidden(truth).gantry.max_accel_deg_per_s2;
    for seed in [3, 4] {
        let runs: Vec<LoggedRun> = ["lung", "prostate", "two-arc"]
            .iter()
            .enumerate()
            .map(|(k, name)| {
                let plan = bundled(name);
                let log = noisy_log_of(&plan, truth, seed * 10 + k as u64, name, 0.03);
                LoggedRun {
                    plan_name: name.to_string(),
                    plan,
                    log,
                }
            })
            .collect();
        let traces: Vec<_> = runs
            .iter()
            .map(|r| arcsim_log::kinematics::trace(&r.log))
            .collect();
        let read = arcsim_log::kinematics::observe(&traces)
            .accel
            .expect("a plateau");
        let cal = calibrate_controller(
            &truth.base(),
            &runs,
            ElstFit::Constant,
            &Options::new(Schedule::Optimal),
            Some(Motion::Constant),
        )
        .expect("calibrated");
        let a = cal
            .report
            .value("gantry.max_accel_deg_per_s2")
            .expect("A")
            .clone();
        let [lo, hi] = a.interval.expect("an interval");
        eprintln!(
            "seed {seed}: trace {} {:?}, corrected {} [{lo}, {hi}]",
            read.level, read.interval, a.value
        );
        assert!(a.note.contains("corrected by replay"), "{}", a.note);
        assert!(
            a.value >= 1.005 * read.level,
            "seed {seed}: the correction ({} from {}) does not raise A by 0.5 %",
            a.value,
            read.level
        );
        assert!((lo..=hi).contains(&hidden_a), "seed {seed}: [{lo}, {hi}]");
    }
}
