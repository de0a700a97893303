//! What reading a delivery log costs: `compare` (matching, differences, the angle trace's local
//! fits) on a 180-layer plan's 10 ms log, with and without the two simulations the command runs,
//! and `calibrate` (the fits, bootstrap intervals and the residual simulations) on that log.
//! The log is the plan's free-motion delivery on the tests' hidden machine with 0.01 deg angle noise.
//! And at scale: a 4 kHz per-spot record of a 274 s arc (1.1M rows) read and compared, and
//! calibrated, under the ATOM machine's own controller (issue 44's goal: ≤ 3 s on 2 cores).
//! `cargo bench --bench logs`

use std::hint::black_box;
use std::time::Duration;

use arcsim_log::{
    calibrate, compare, parse_log, to_csv, virtual_log, ColumnMap, DeliveryLog, ElstFit, LoggedRun,
    VirtualLogOptions,
};
use arcsim_plan::{load_machine, load_plan, parse_machine, resolve};
use arcsim_sequencer::{
    machine_limits, simulate_resolved, spot_timeline, Motion, Options, Schedule,
};
use arcsim_test_support::HIDDEN_MACHINE_JSON;
use criterion::{criterion_group, criterion_main, Criterion};

fn bench(c: &mut Criterion) {
    let root = arcsim_suite::repo_root();
    let plan = load_plan(root.join("plans/prostate.json")).expect("plan");
    let machine = parse_machine(HIDDEN_MACHINE_JSON, "hidden").expect("machine");
    let atom = load_machine(root.join("scenarios/machine-atom.json")).expect("atom");
    let free = Options {
        motion: Motion::Free,
        ..Options::new(Schedule::Optimal)
    };
    let constant = Options::new(Schedule::Optimal);
    let arcs = resolve(&plan, &machine).expect("resolves");
    let limits = machine_limits(&machine).expect("limits");
    let delivered = simulate_resolved(&arcs, &limits, &free).expect("simulated");
    let spots = spot_timeline(&plan, &machine, &delivered).expect("spots");
    let opts = VirtualLogOptions {
        period_s: 0.01,
        angle_noise_deg: 0.01,
        seed: 1,
    };
    let log = DeliveryLog {
        source: "prostate.csv".into(),
        samples: virtual_log(&delivered, &spots, &opts).expect("log"),
        has_energy: true,
        has_spot: true,
        has_mu: true,
        wraps_unwrapped: 0,
        glitches_rejected: 0,
        edge_resolution_s: None,
    };
    let other = simulate_resolved(&arcs, &limits, &constant).expect("simulated");
    let mut group = c.benchmark_group("logs");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(20));
    group.bench_function(
        "compare prostate (180 layers, 10 ms), simulations given",
        |b| {
            b.iter(|| {
                black_box(
                    compare(&arcs, &delivered, &[&other], black_box(&log))
                        .expect("compare")
                        .difference_s,
                )
            })
        },
    );
    group.bench_function(
        "compare prostate (180 layers, 10 ms), with both simulations",
        |b| {
            b.iter(|| {
                let (main, alt) = rayon::join(
                    || simulate_resolved(&arcs, &limits, &free).expect("free"),
                    || simulate_resolved(&arcs, &limits, &constant).expect("constant"),
                );
                black_box(
                    compare(&arcs, &main, &[&alt], black_box(&log))
                        .expect("compare")
                        .difference_s,
                )
            })
        },
    );
    let runs = [LoggedRun {
        plan_name: "prostate".into(),
        plan: plan.clone(),
        log: log.clone(),
    }];
    group.bench_function("calibrate from the ATOM machine on prostate's log", |b| {
        b.iter(|| {
            black_box(
                calibrate(&atom, &runs, ElstFit::Constant, &free)
                    .expect("calibrate")
                    .report
                    .values
                    .len(),
            )
        })
    });
    group.finish();
}

/// Issue 44's scale: a per-spot record at 4 kHz of a 274 s arc (the bundled prostate on the
/// ATOM machine under its own controller, constant speed per layer): 1.1M rows, read from its
/// CSV bytes and compared (the simulation included), and calibrated under that controller.
fn bench_4khz(c: &mut Criterion) {
    let root = arcsim_suite::repo_root();
    let plan = load_plan(root.join("plans/prostate.json")).expect("plan");
    let atom = load_machine(root.join("scenarios/machine-atom.json")).expect("atom");
    let constant = Options::new(Schedule::Optimal);
    let arcs = resolve(&plan, &atom).expect("resolves");
    let limits = machine_limits(&atom).expect("limits");
    let delivered = simulate_resolved(&arcs, &limits, &constant).expect("simulated");
    let spots = spot_timeline(&plan, &atom, &delivered).expect("spots");
    let opts = VirtualLogOptions {
        period_s: 0.00025,
        angle_noise_deg: 0.01,
        seed: 1,
    };
    let csv = to_csv(&virtual_log(&delivered, &spots, &opts).expect("log"));
    let map = ColumnMap::default();
    let log = parse_log(csv.as_bytes(), "prostate-4khz.csv", &map).expect("reads");
    let mut group = c.benchmark_group("logs at 4 kHz");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(30));
    let rows = log.samples.len();
    group.bench_function(
        format!("read and compare prostate ({rows} rows), the simulation included"),
        |b| {
            b.iter(|| {
                let log = parse_log(black_box(csv.as_bytes()), "p.csv", &map).expect("reads");
                let sim = simulate_resolved(&arcs, &limits, &constant).expect("simulated");
                black_box(
                    compare(&arcs, &sim, &[], &log)
                        .expect("compare")
                        .difference_s,
                )
            })
        },
    );
    let runs = [LoggedRun {
        plan_name: "prostate".into(),
        plan: plan.clone(),
        log,
    }];
    group.bench_function(
        format!("calibrate from the ATOM machine under its controller ({rows} rows)"),
        |b| {
            b.iter(|| {
                black_box(
                    calibrate(&atom, &runs, ElstFit::Constant, &constant)
                        .expect("calibrate")
                        .report
                        .values
                        .len(),
                )
            })
        },
    );
    group.finish();
}

criterion_group!(benches, bench, bench_4khz);
criterion_main!(benches);
