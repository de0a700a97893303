//! Re-sequencing benchmark (issue 48: ≤ 1 s for a 900-layer plan): an 888-layer two-arc plan
//! (`generate-plan --kind two-arc --spacing 2.2 --layers 2-4 --energy 70-230`) with each control
//! point's layers in ascending energy, on the ATOM machine (constant speed per layer, optimal
//! schedule): the orders found without simulating, each simulated, and the plan as given (docs/benchmarks.md).
//! `cargo bench --bench resequence`

use std::hint::black_box;

use arcsim_plan::{generate_shaped, parse_machine, PlanKind, Shape};
use arcsim_resequence::{best_orders, best_orders_by, resequence, GantryCost, ResequenceOptions};
use arcsim_sequencer::{machine_limits, simulate, Options, Schedule};
use criterion::{criterion_group, criterion_main, Criterion};

fn bench(c: &mut Criterion) {
    let m_text =
        std::fs::read_to_string(arcsim_suite::repo_root().join("scenarios/machine-atom.json"))
            .expect("machine");
    let machine = parse_machine(&m_text, "machine-atom.json").expect("machine");
    let shape = Shape {
        spacing_deg: Some(2.2),
        layers_per_cp: Some((2, 4)),
        energy_mev: Some((70.0, 230.0)),
        spot_spacing_mm: None,
    };
    let mut plan = generate_shaped(PlanKind::TwoArc, 1, &shape).expect("plan");
    for cp in plan.arcs.iter_mut().flat_map(|a| &mut a.control_points) {
        cp.layers
            .sort_by(|a, b| a.energy_mev.total_cmp(&b.energy_mev));
    }
    let opts = ResequenceOptions {
        simulation: Options {
            schedule: Schedule::Optimal,
            ..Options::default()
        },
        ..ResequenceOptions::default()
    };
    let mut group = c.benchmark_group("resequence");
    group.sample_size(10);
    group.bench_function("order of least switching time, 888 layers", |b| {
        b.iter(|| black_box(best_orders(black_box(&plan), &machine.elst)))
    });
    group.bench_function(
        "order of least estimated switch duration, 888 layers",
        |b| {
            b.iter(|| {
                let fastest = |_: usize, _: usize| None;
                let limits = machine_limits(&machine).expect("limits");
                let cost = GantryCost::new(&plan, &machine, limits, &fastest).expect("cost");
                black_box(best_orders_by(black_box(&plan), &|a, b| {
                    cost.switch_s(a, b)
                }))
            })
        },
    );
    group.bench_function("one simulation, 888 layers (constant, optimal)", |b| {
        b.iter(|| {
            black_box(simulate(black_box(&plan), &machine, &opts.simulation).map(|d| d.total_s))
        })
    });
    group.bench_function("resequence 888 layers (constant, optimal)", |b| {
        b.iter(|| {
            black_box(
                resequence(black_box(&plan), &machine, &opts)
                    .expect("resequence")
                    .after
                    .total_s,
            )
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
