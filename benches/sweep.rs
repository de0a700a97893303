//! Evaluator benchmark: evaluations per second of 180-layer plans with the `scan` and the
//! `optimal` schedule (every 10th combination of the 1000-setting sweep
//! `scenarios/sweep-atom-1000.json` over the three ATOM article cases; the same settings with
//! `optimal` in place of `scan`), on 1 and on 2 threads; the ratio of the two throughputs is the
//! parallel speed-up. Then free motion (`optimal+free`, every 100th combination) on 2 threads.
//! `cargo bench --bench sweep` (Criterion reports "thrpt" in evaluations/s).

use std::hint::black_box;
use std::time::Instant;

use arcsim_evaluator::{Evaluator, Sweep};
use arcsim_plan::load_plan;
use criterion::{criterion_group, criterion_main, Criterion, Throughput};

/// `sweep-atom-1000.json` with `schedule` (a schedule entry of a sweep file) as its one schedule.
fn sweep(schedule: &str) -> Sweep {
    let scenarios = arcsim_suite::repo_root().join("scenarios");
    let path = scenarios.join("sweep-atom-1000.json");
    let text = std::fs::read_to_string(&path)
        .expect("sweep-atom-1000.json")
        .replace(
            r#""schedules": ["scan"]"#,
            &format!(r#""schedules": [{schedule}]"#),
        );
    assert!(text.contains(schedule), "the sweep names its schedule");
    Sweep::from_text(
        &text,
        "sweep-atom-1000.json",
        &scenarios,
        &|p: &std::path::Path| load_plan(p).map_err(|e| e.to_string()),
    )
    .expect("sweep")
}

fn bench(c: &mut Criterion) {
    for schedule in ["scan", "optimal"] {
        let ev = Evaluator::new(sweep(&format!("\"{schedule}\""))).expect("prepare");
        // Every 10th combination: a representative mix of settings and plans, 300 evaluations.
        let all: Vec<usize> = (0..ev.len()).step_by(10).collect();
        let mut group = c.benchmark_group(format!("sweep {schedule} 180 layers"));
        group.throughput(Throughput::Elements(all.len() as u64));
        group.sample_size(10);
        let mut rates = Vec::new();
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool");
            group.bench_function(
                format!("{threads} thread(s), {} evaluations", all.len()),
                |b| b.iter(|| black_box(pool.install(|| ev.run_collect(black_box(&all))).len())),
            );
            // A plain measurement too, so the speed-up is printed as one number.
            let started = Instant::now();
            let n = pool.install(|| ev.run_collect(&all)).len();
            rates.push(n as f64 / started.elapsed().as_secs_f64());
        }
        group.finish();
        println!(
            "{schedule}: evaluations/s: 1 thread {:.0}, 2 threads {:.0}; speed-up {:.2}x",
            rates[0],
            rates[1],
            rates[1] / rates[0]
        );
    }
}

/// Free motion: every 100th combination (30 evaluations) on 2 threads.
fn bench_free(c: &mut Criterion) {
    let ev =
        Evaluator::new(sweep(r#"{"schedule": "optimal", "motion": "free"}"#)).expect("prepare");
    let some: Vec<usize> = (0..ev.len()).step_by(100).collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("pool");
    let mut group = c.benchmark_group("sweep optimal+free 180 layers");
    group.throughput(Throughput::Elements(some.len() as u64));
    group.sample_size(10);
    group.bench_function(format!("2 threads, {} evaluations", some.len()), |b| {
        b.iter(|| black_box(pool.install(|| ev.run_collect(black_box(&some))).len()))
    });
    group.finish();
}

criterion_group!(benches, bench, bench_free);
criterion_main!(benches);
