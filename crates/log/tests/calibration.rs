//! Calibration recovers a machine hidden in the test from logs it generates: ELST jittered per
//! switch, angles with encoder noise, 10 ms sampling; the fitted machine then predicts a plan it
//! never saw.

use std::path::PathBuf;

use arcsim_log::{
    calibrate, parse_log, to_csv, virtual_log, ColumnMap, DeliveryLog, ElstFit, LoggedRun,
    VirtualLogOptions,
};
use arcsim_plan::{
    generate, load_plan, parse_machine, resolve, ArcPlan, BeamModel, ElstModel, Machine, PlanKind,
    TimingSpread,
};
use arcsim_sequencer::{
    machine_limits, simulate, simulate_resolved, spot_timeline, Motion, Options, Schedule,
};
use arcsim_test_support::HIDDEN_MACHINE_JSON;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The machine the logs come from, unlike every bundled one.
fn hidden() -> Machine {
    parse_machine(HIDDEN_MACHINE_JSON, "hidden").expect("hidden machine")
}

fn free() -> Options {
    Options {
        motion: Motion::Free,
        ..Options::new(Schedule::Optimal)
    }
}

/// A log of `plan` on `machine` with each switch's ELST drawn at 3 % (seeded), sampled every
/// 10 ms with 0.01 deg of angle noise, written and read back as a file would be.
pub fn jittered_log(plan: &ArcPlan, machine: &Machine, seed: u64, name: &str) -> DeliveryLog {
    let arcs = resolve(plan, machine).expect("resolves");
    let (up, down) = match machine.elst {
        ElstModel::Constant { up_s, down_s, .. } => (up_s, down_s),
        _ => unreachable!("the hidden machine's ELST is constant"),
    };
    let jitter = TimingSpread {
        elst_up_sd_s: 0.03 * up,
        elst_down_sd_s: 0.03 * down,
        elst_same_sd_s: 0.0,
        beam_time_sd_fraction: 0.0,
    };
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut normal = || rng.sample::<f64, _>(StandardNormal);
    let drawn = jitter.draw(&arcs, &mut normal);
    let limits = machine_limits(machine).expect("limits");
    let d = simulate_resolved(&drawn, &limits, &free()).expect("simulated");
    let spots = spot_timeline(plan, machine, &d).expect("spots");
    let opts = VirtualLogOptions {
        period_s: 0.01,
        angle_noise_deg: 0.01,
        seed,
    };
    let samples = virtual_log(&d, &spots, &opts).expect("log");
    parse_log(to_csv(&samples).as_bytes(), name, &ColumnMap::default()).expect("reads back")
}

fn bundled(name: &str) -> ArcPlan {
    load_plan(repo().join(format!("plans/{name}.json"))).expect("plan")
}

#[test]
fn calibration_recovers_a_hidden_machine_and_predicts_a_held_out_plan() {
    let machine = hidden();
    let runs: Vec<LoggedRun> = ["lung", "prostate", "two-arc"]
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let plan = bundled(name);
            let log = jittered_log(&plan, &machine, 100 + k as u64, &format!("{name}.log"));
            LoggedRun {
                plan_name: name.to_string(),
                plan,
                log,
            }
        })
        .collect();
    let base = arcsim_plan::load_machine(repo().join("scenarios/machine-atom.json")).expect("atom");
    let cal = calibrate(&base, &runs, ElstFit::Constant, &free()).expect("calibrated");
    for v in &cal.report.values {
        eprintln!(
            "{} {:?} -> {} {:?} det {} n {} : {}",
            v.field, v.base, v.value, v.interval, v.determined, v.observations, v.note
        );
    }
    for r in &cal.report.residuals {
        eprintln!("{r:?}");
    }
    eprintln!("{:?}", cal.report.spread);
    let fitted = &cal.machine;
    let within = |x: f64, truth: f64, tol: f64, what: &str| {
        assert!(
            (x / truth - 1.0).abs() <= tol,
            "{what}: fitted {x}, hidden {truth}"
        );
    };
    let ElstModel::Constant { up_s, down_s, .. } = fitted.elst else {
        panic!("constant ELST expected")
    };
    within(up_s, 3.2, 0.02, "ELST up");
    within(down_s, 0.8, 0.02, "ELST down");
    let BeamModel::PerMu(b) = &fitted.beam else {
        panic!("per_mu expected")
    };
    within(b.s_per_mu, 0.004, 0.02, "s per MU");
    let g = &fitted.gantry;
    within(g.max_accel_deg_per_s2, 0.3, 0.05, "A");
    let value = |field: &str| cal.report.value(field).expect(field);
    // Two-arc holds V for seconds, and the acceleration reversals (1.5 s) are long enough for
    // the fits to resolve J: all three are identifiable in these logs.
    for field in [
        "gantry.max_speed_deg_per_s",
        "gantry.max_accel_deg_per_s2",
        "gantry.max_jerk_deg_per_s3",
    ] {
        assert!(value(field).determined, "{field}: {}", value(field).note);
    }
    within(g.max_speed_deg_per_s, 4.0, 0.05, "V");
    within(g.max_jerk_deg_per_s3, 0.4, 0.10, "J");
    // Every interval holds its value; the spreads are measured (the jitter is 3 %).
    for v in cal.report.values.iter().filter(|v| v.determined) {
        let [lo, hi] = v.interval.expect("an interval");
        assert!(
            lo <= v.value && v.value <= hi,
            "{}: {lo} {} {hi}",
            v.field,
            v.value
        );
    }
    let spread = fitted.spread.expect("spreads");
    assert!(
        spread.elst_up_sd_s > 0.3 * 0.096 && spread.elst_up_sd_s < 2.0 * 0.096,
        "{spread:?}"
    );
    assert!(
        spread.elst_down_sd_s > 0.3 * 0.024 && spread.elst_down_sd_s < 2.0 * 0.024,
        "{spread:?}"
    );
    // The fitted machine reads back from its JSON, and is nearer every log than the base.
    let text = serde_json::to_string(fitted).expect("serialises");
    assert_eq!(&parse_machine(&text, "fitted").expect("reads back"), fitted);
    for r in &cal.report.residuals {
        assert!(
            r.fitted_error_pct.abs() < 1.0 && r.fitted_error_pct.abs() < r.base_error_pct.abs(),
            "{r:?}"
        );
    }
    // A plan none of the logs came from.
    let held_out = generate(PlanKind::Lung, 7);
    let logged = jittered_log(&held_out, &machine, 7, "held-out.log");
    let logged_total =
        arcsim_log::match_layers(&logged, &resolve(&held_out, fitted).expect("resolves"))
            .map(|l| l[l.len() - 1].end_s - l[0].start_s)
            .expect("matches");
    let predicted = simulate(&held_out, fitted, &free())
        .expect("simulated")
        .total_s;
    within(predicted, logged_total, 0.01, "held-out total");
}
