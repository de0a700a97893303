//! Sequencer benchmarks on the 180-layer ATOM article cases (the bundled `plans/atom/*.json`):
//! `scan` and `optimal` schedules, totals only (as sweeps run them) and with the full verified
//! timeline; free motion (seeded by `optimal`) with both arc-end options.
//! `cargo bench --bench sequencer`

use std::hint::black_box;

use arcsim_plan::{load_plan, parse_machine, resolve};
use arcsim_sequencer::{machine_limits, simulate_resolved, ArcEnds, Motion, Options, Schedule};
use criterion::{criterion_group, criterion_main, Criterion};

fn bench(c: &mut Criterion) {
    let m_text =
        std::fs::read_to_string(arcsim_suite::repo_root().join("scenarios/machine-atom.json"))
            .expect("machine");
    let machine = parse_machine(&m_text, "machine-atom.json").expect("machine");
    let limits = machine_limits(&machine).expect("limits");
    let plan = load_plan(arcsim_suite::repo_root().join("plans/atom/prostate.json")).expect("plan");
    let arcs = resolve(&plan, &machine).expect("resolve");
    for (schedule, timeline) in [
        (Schedule::Scan, false),
        (Schedule::Scan, true),
        (Schedule::Optimal, false),
        (Schedule::Optimal, true),
    ] {
        let opts = Options {
            schedule,
            build_timeline: timeline,
            ..Options::default()
        };
        let name = format!(
            "{} prostate 180 layers ({})",
            schedule.name(),
            if timeline {
                "verified timeline"
            } else {
                "totals"
            }
        );
        c.bench_function(&name, |b| {
            b.iter(|| {
                black_box(
                    simulate_resolved(black_box(&arcs), &limits, &opts)
                        .expect("simulate")
                        .total_s,
                )
            })
        });
    }
    let mut group = c.benchmark_group("free motion");
    group.sample_size(10);
    for ends in ArcEnds::ALL {
        let opts = Options {
            motion: Motion::Free,
            arc_ends: ends,
            ..Options::new(Schedule::Optimal)
        };
        group.bench_function(
            format!("prostate 180 layers, arc ends {}", ends.name()),
            |b| {
                b.iter(|| {
                    black_box(
                        simulate_resolved(black_box(&arcs), &limits, &opts)
                            .expect("simulate")
                            .total_s,
                    )
                })
            },
        );
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
