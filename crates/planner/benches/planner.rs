//! Planner benchmarks: one minimum-time move on random inputs (with rsruckig's 1-DoF
//! calculation on the same inputs for comparison), a move with a minimum duration, one with
//! reversal allowed and a minimum duration, the duration analysis, and `state_at`.
//! `cargo bench -p arcsim-planner --bench planner`

#![allow(
    clippy::too_many_lines,
    reason = "the 100-line rule is for the crates' code; a test or benchmark reads top to bottom"
)]

use std::hint::black_box;

use arcsim_planner::{plan, Limits, Move, MoveAnalysis, MoveOptions, Reversal};
use criterion::{criterion_group, criterion_main, Criterion};
use rsruckig::prelude::*;

struct Rng(u64);
impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Gantry-scale random moves: J 0.1–10, A 0.1–2, V 1–10, speeds in [0, V], gaps 0.01–20 deg.
fn inputs(n: usize) -> Vec<(Move, Limits)> {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    (0..n)
        .map(|_| {
            let j = 10f64.powf(rng.unit() * 2.0 - 1.0);
            let a = 10f64.powf(rng.unit() * 1.3 - 1.0);
            let v = 10f64.powf(rng.unit());
            let lim = Limits::new(j, a, v).expect("limits");
            let mv = Move {
                distance: 10f64.powf(rng.unit() * 3.3 - 2.0),
                v_start: rng.unit() * v,
                v_end: rng.unit() * v,
            };
            (mv, lim)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let data = inputs(1024);
    let mut i = 0;
    let allow = MoveOptions {
        reversal: Reversal::Allow,
        ..MoveOptions::default()
    };
    c.bench_function(
        "plan: minimum time (random gantry moves, reversal allowed)",
        |b| {
            b.iter(|| {
                i = (i + 1) & 1023;
                let (mv, lim) = &data[i];
                black_box(
                    plan(black_box(mv), lim, &allow)
                        .map(|p| p.duration())
                        .unwrap_or(0.0),
                )
            })
        },
    );
    let mut otg = Ruckig::<1, ThrowErrorHandler>::new(None, 0.001);
    let mut traj = Trajectory::new(None);
    let ruckig_inputs: Vec<InputParameter<1>> = data
        .iter()
        .map(|(mv, lim)| {
            let mut input = InputParameter::new(None);
            input.current_velocity[0] = mv.v_start;
            input.target_position[0] = mv.distance;
            input.target_velocity[0] = mv.v_end;
            input.max_velocity[0] = lim.max_vel;
            input.max_acceleration[0] = lim.max_accel;
            input.max_jerk[0] = lim.max_jerk;
            input
        })
        .collect();
    let mut k = 0;
    c.bench_function("rsruckig 1-DoF calculate (same inputs)", |b| {
        b.iter(|| {
            k = (k + 1) & 1023;
            let _ = otg.calculate(black_box(&ruckig_inputs[k]), &mut traj);
            black_box(traj.get_duration())
        })
    });
    for (name, reversal) in [
        ("plan: 5 s minimum (random gantry moves)", Reversal::Forbid),
        (
            "plan: 5 s minimum, reversal allowed (random gantry moves)",
            Reversal::Allow,
        ),
    ] {
        let options = MoveOptions {
            min_duration_s: 5.0,
            reversal,
            ..MoveOptions::default()
        };
        let mut m = 0;
        c.bench_function(name, |b| {
            b.iter(|| {
                m = (m + 1) & 1023;
                let (mv, lim) = &data[m];
                black_box(
                    plan(black_box(mv), lim, &options)
                        .map(|p| p.duration())
                        .unwrap_or(0.0),
                )
            })
        });
    }
    let mut m = 0;
    c.bench_function("MoveAnalysis: can last 5 s (random gantry moves)", |b| {
        b.iter(|| {
            m = (m + 1) & 1023;
            let (mv, lim) = &data[m];
            black_box(
                MoveAnalysis::new(black_box(mv), lim, Reversal::Forbid)
                    .map(|a| a.can_last_at_least(5.0))
                    .unwrap_or(false),
            )
        })
    });
    let lim = Limits::new(0.5, 0.5, 5.0).expect("limits");
    let p = plan(
        &Move {
            distance: 4.0,
            v_start: 1.0,
            v_end: 1.5,
        },
        &lim,
        &MoveOptions::default(),
    )
    .expect("profile");
    let total = p.duration();
    let mut t = 0.0;
    c.bench_function("Profile::state_at", |b| {
        b.iter(|| {
            t += 0.0137;
            if t > total {
                t -= total;
            }
            black_box(p.state_at(black_box(t)))
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
