//! Independent checks of the profile representation: brute-force integration of the sampled
//! jerk, continuity of `state_at`, and a fine numerical search over the extreme speed.

use crate::util::*;
use arcsim_planner::{Limits, Move, Reversal};

#[test]
fn brute_force_integration_matches_profile_end() {
    let mut rng = Rng::new(5);
    for case in 0..20_000 {
        let lim = random_limits(&mut rng);
        let mv = random_move(&mut rng, &lim, false);
        let p = min_time(&mv, &lim, Reversal::Allow).expect("profile");
        let (pos, vel, acc) = brute_force_end(&p, 16);
        let scale = move_scale(&mv, &lim, p.duration());
        assert!(
            (pos - mv.distance).abs() <= 1e-9 * scale,
            "case {case}: {pos} vs {} {mv:?} {lim:?} {:?} end {:?}",
            mv.distance,
            p.segments(),
            p.end_state()
        );
        assert!(
            (vel - mv.v_end).abs() <= 1e-9 * lim.max_vel,
            "case {case}: {vel} vs {} {mv:?} {lim:?} {:?} end {:?}",
            mv.v_end,
            p.segments(),
            p.end_state()
        );
        let a_scale = lim.max_accel.max(lim.max_decel);
        assert!(acc.abs() <= 1e-9 * a_scale, "case {case}: acc {acc}");
    }
}

#[test]
fn state_at_is_continuous_and_samples_cover_the_move() {
    let lim = Limits::new(0.5, 0.5, 5.0).expect("limits");
    let p = min_time(
        &Move {
            distance: 10.0,
            v_start: 0.5,
            v_end: 1.0,
        },
        &lim,
        Reversal::Forbid,
    )
    .expect("ok");
    let mut t = 0.0;
    for s in p.segments() {
        t += s.duration;
        let (a, b) = (p.state_at(t - 1e-9), p.state_at(t + 1e-9));
        assert!((a.position - b.position).abs() < 1e-8 && (a.velocity - b.velocity).abs() < 1e-8);
        assert!((a.acceleration - b.acceleration).abs() < 1e-8);
    }
    let samples = p.samples(0.01);
    assert_eq!(samples.first().map(|s| s.0), Some(0.0));
    assert!((samples.last().expect("samples").0 - p.duration()).abs() < 1e-15);
    assert!((samples.last().expect("samples").1.position - 10.0).abs() < 1e-9);
    // Beyond the end the axis moves on at the end speed.
    let after = p.state_at(p.duration() + 2.0);
    assert!((after.position - 12.0).abs() < 1e-9 && after.acceleration == 0.0);
}

/// Fine numerical search over the single-extremum family (v_s → c, cruise at c, c → v_e):
/// no feasible c on a fine grid beats the planner.
#[test]
fn no_grid_extreme_speed_beats_the_planner() {
    let mut rng = Rng::new(11);
    for case in 0..400 {
        let lim = random_limits(&mut rng);
        let mv = random_move(&mut rng, &lim, false);
        let p = min_time(&mv, &lim, Reversal::Allow).expect("profile");
        let dir = mv.direction();
        let (d, vs, ve) = (dir * mv.distance, dir * mv.v_start, dir * mv.v_end);
        let n = 20_000;
        let mut best = f64::INFINITY;
        for i in 0..=n {
            let c = -lim.max_vel + 2.0 * lim.max_vel * i as f64 / n as f64;
            let (t1, t2) = (
                lim.speed_change_duration(vs, c),
                lim.speed_change_duration(c, ve),
            );
            let dist = 0.5 * (vs + c) * t1 + 0.5 * (c + ve) * t2;
            let cruise = if c != 0.0 {
                (d - dist) / c
            } else if (d - dist).abs() < 1e-15 {
                0.0
            } else {
                -1.0
            };
            if cruise >= 0.0 {
                best = best.min(t1 + t2 + cruise);
            }
        }
        assert!(
            p.duration() <= best * (1.0 + 1e-12) + 1e-15,
            "case {case}: planner {} vs grid {best}",
            p.duration()
        );
    }
}
