//! Sequencer benchmarks on the 180-layer ATOM article cases (the bundled `plans/atom/*.json`):
//! `scan` and `optimal` schedules, totals only (as sweeps run them) and with the full verified
//! timeline; `optimal` on head-and-neck; free motion (seeded by `optimal`) with both arc-end
//! options on prostate, rest ends on head-and-neck, on the bundled 722-layer `plans/head-neck.json`
//! and on an 888-layer two-arc plan (`generate-plan --kind two-arc --spacing 2.2 --layers 2-4
//! --energy 70-230`, 2–4 layers per control point: issue 45's real-size case).
//! `cargo bench --bench sequencer`

#![allow(
    clippy::too_many_lines,
    reason = "the 100-line rule is for the crates' code; a test or benchmark reads top to bottom"
)]

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
    let load = |name: &str| {
        let path = arcsim_suite::repo_root().join(format!("plans/atom/{name}.json"));
        resolve(&load_plan(path).expect("plan"), &machine).expect("resolve")
    };
    let arcs = load("prostate");
    // The 180-layer ATOM head-and-neck case: `optimal` on another plan (totals, as sweeps run it).
    let hn = load("head-and-neck");
    c.bench_function("optimal head-and-neck 180 layers (totals)", |b| {
        let opts = Options {
            schedule: Schedule::Optimal,
            build_timeline: false,
            ..Options::default()
        };
        b.iter(|| {
            black_box(
                simulate_resolved(black_box(&hn), &limits, &opts)
                    .expect("simulate")
                    .total_s,
            )
        })
    });
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
    let rest = Options {
        motion: Motion::Free,
        ..Options::new(Schedule::Optimal)
    };
    let long = {
        let path = arcsim_suite::repo_root().join("plans/head-neck.json");
        resolve(&load_plan(path).expect("plan"), &machine).expect("resolve")
    };
    let shape = arcsim_plan::Shape {
        spacing_deg: Some(2.2),
        layers_per_cp: Some((2, 4)),
        energy_mev: Some((70.0, 230.0)),
        spot_spacing_mm: None,
    };
    let two_arc =
        arcsim_plan::generate_shaped(arcsim_plan::PlanKind::TwoArc, 1, &shape).expect("shape");
    let large = resolve(&two_arc, &machine).expect("resolve");
    for (name, plan) in [
        ("head-and-neck 180 layers, arc ends rest", &hn),
        ("bundled head-neck 722 layers, arc ends rest", &long),
        ("two-arc 888 layers, arc ends rest", &large),
    ] {
        group.bench_function(name, |b| {
            b.iter(|| {
                black_box(
                    simulate_resolved(black_box(plan), &limits, &rest)
                        .expect("simulate")
                        .total_s,
                )
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
