//! What the `scanning` beam model costs against `per_mu`, on the bundled plans: `simulate` (plan
//! resolution included; optimal schedule, constant motion, verified timeline) with the ATOM
//! machine as it is and with its beam model swapped for the scanning model of
//! `scenarios/machine-opentps-pbs.json`, its bursts (`machine-proteusone-like.json`) and its
//! spills (`machine-probeat-v5-like-mee.json`); resolution alone; and the per-spot timeline of
//! `simulate --spots`.
//! `cargo bench --bench beam`

use std::hint::black_box;
use std::time::Duration;

use arcsim_plan::{load_machine, load_plan, resolve, Machine};
use arcsim_sequencer::{simulate, spot_timeline, Motion, Options, Schedule};
use criterion::{criterion_group, criterion_main, Criterion};

fn machines() -> [(&'static str, Machine); 4] {
    let root = arcsim_suite::repo_root();
    let atom = load_machine(root.join("scenarios/machine-atom.json")).expect("atom machine");
    // The ATOM machine with another file's beam model.
    let beam_of = |file: &str| Machine {
        beam: load_machine(root.join("scenarios").join(file))
            .expect("machine")
            .beam,
        ..atom.clone()
    };
    [
        ("scanning", beam_of("machine-opentps-pbs.json")),
        ("bursts", beam_of("machine-proteusone-like.json")),
        ("spills", beam_of("machine-probeat-v5-like-mee.json")),
        ("per_mu", atom),
    ]
}

fn bench(c: &mut Criterion) {
    let root = arcsim_suite::repo_root();
    let opts = Options {
        motion: Motion::Constant,
        ..Options::new(Schedule::Optimal)
    };
    let mut group = c.benchmark_group("beam model");
    group.measurement_time(Duration::from_secs(4));
    for name in ["prostate", "lung", "two-arc", "head-neck"] {
        let plan = load_plan(root.join(format!("plans/{name}.json"))).expect("plan");
        for (kind, machine) in machines() {
            group.bench_function(format!("simulate {name} ({kind})"), |b| {
                b.iter(|| {
                    black_box(
                        simulate(black_box(&plan), &machine, &opts)
                            .expect("simulate")
                            .total_s,
                    )
                })
            });
            group.bench_function(format!("resolve {name} ({kind})"), |b| {
                b.iter(|| black_box(resolve(black_box(&plan), &machine).expect("resolve").len()))
            });
        }
        for (kind, machine) in machines().into_iter().take(3) {
            let delivery = simulate(&plan, &machine, &opts).expect("simulate");
            group.bench_function(format!("spot timeline {name} ({kind})"), |b| {
                b.iter(|| {
                    black_box(
                        spot_timeline(&plan, &machine, black_box(&delivery))
                            .expect("spots")
                            .len(),
                    )
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
