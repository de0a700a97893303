//! Step 2 (minimum durations) and the servo-period discretisation, on seeded random moves.

use crate::util;

use crate::util::*;
use arcsim_planner::{plan, LinearGap, Move, MoveAnalysis, MoveOptions, PlannerError, Reversal};

/// `plan` with a minimum duration, reversal forbidden, continuous time.
fn at_least(
    mv: Move,
    lim: &arcsim_planner::Limits,
    t: f64,
) -> Result<arcsim_planner::Profile, PlannerError> {
    let options = MoveOptions {
        min_duration_s: t,
        ..MoveOptions::default()
    };
    plan(&mv, lim, &options)
}

/// `plan` on a servo period, no minimum duration.
fn on_servo(
    mv: Move,
    lim: &arcsim_planner::Limits,
    period: f64,
    reversal: Reversal,
) -> Result<arcsim_planner::Profile, PlannerError> {
    let options = MoveOptions {
        servo_period_s: Some(period),
        reversal,
        ..MoveOptions::default()
    };
    plan(&mv, lim, &options)
}

#[test]
fn minimum_durations_on_random_moves() {
    let mut rng = Rng::new(99);
    let (mut solved, mut lengthened, mut infeasible, mut reversing) = (0, 0, 0, 0);
    for case in 0..30_000 {
        let lim = random_limits(&mut rng);
        let mv = random_move(&mut rng, &lim, true);
        let set = match MoveAnalysis::new(&mv, &lim, Reversal::Forbid) {
            Ok(a) => a.durations(),
            Err(PlannerError::Unreachable { .. }) => {
                reversing += 1;
                assert!(
                    min_time(&mv, &lim, Reversal::Forbid).is_err(),
                    "case {case}"
                );
                continue;
            }
            Err(e) => panic!("case {case}: {e}"),
        };
        let t_opt = min_time(&mv, &lim, Reversal::Forbid)
            .expect("forbid ok")
            .duration();
        assert!(
            (set.min() - t_opt).abs() <= 1e-12 * t_opt.max(1.0),
            "case {case}: {set:?} vs {t_opt}"
        );
        // A requested duration: up to 20x the minimum time, or a little beyond the longest.
        let t_req = if rng.chance(0.2) && set.max().is_finite() {
            set.max() * (1.0 + rng.uniform(1e-6, 0.5))
        } else {
            t_opt * (1.0 + rng.log_uniform(-6.0, 1.3))
        };
        match at_least(mv, &lim, t_req) {
            Ok(p) => {
                solved += 1;
                // The requested duration when feasible, else the next feasible one.
                let want = if set.contains(t_req) {
                    t_req
                } else {
                    lengthened += 1;
                    set.at_least(t_req).expect("a longer feasible duration")
                };
                assert!(
                    (p.duration() - want).abs() <= 1e-9 * want.max(1.0),
                    "case {case}: {} vs {want} (asked {t_req}, {set:?})",
                    p.duration()
                );
                let end = p.end_state();
                let scale = move_scale(&mv, &lim, p.duration());
                assert!(
                    (end.position - mv.distance).abs() <= 1e-9 * scale,
                    "case {case}: end {end:?}"
                );
                assert!(
                    (end.velocity - mv.v_end).abs() <= 1e-9 * lim.max_vel,
                    "case {case}: end {end:?}"
                );
                let e = p.extrema();
                assert!(
                    e.min_velocity >= -1e-12 * lim.max_vel,
                    "case {case}: reverses {e:?}"
                );
                assert!(
                    e.max_velocity <= lim.max_vel * (1.0 + 1e-12),
                    "case {case}: {e:?}"
                );
                assert!(
                    e.max_abs_jerk <= lim.max_jerk * (1.0 + 1e-12),
                    "case {case}"
                );
            }
            Err(PlannerError::DurationInfeasible { feasible, .. }) => {
                infeasible += 1;
                assert!(
                    set.at_least(t_req).is_none(),
                    "case {case}: {t_req} below the end of {set:?} but refused {mv:?} {lim:?}"
                );
                assert_eq!(feasible, set.intervals());
            }
            Err(e) => panic!("case {case}: {e}"),
        }
    }
    println!(
        "solved {solved} ({lengthened} lengthened), infeasible {infeasible}, reversing {reversing}"
    );
    assert!(
        solved > 10_000 && infeasible > 100 && lengthened > 0,
        "solved {solved}, lengthened {lengthened}, infeasible {infeasible}"
    );
}

/// The ELST situation on the ATOM gantry: a 2° step that must last 5 s. At 1.5°/s the gantry can
/// neither brake to rest in the gap nor stretch the move to 5 s; at 0.3°/s it can.
#[test]
fn energy_switch_on_atom_gantry() {
    let lim = arcsim_planner::Limits::new(0.5, 0.5, 5.0).expect("limits");
    let fast = Move {
        distance: 1.6,
        v_start: 1.5,
        v_end: 1.5,
    };
    let analysis = |mv: &Move| MoveAnalysis::new(mv, &lim, Reversal::Forbid).expect("feasible");
    let t_max = analysis(&fast).durations().max();
    assert!(t_max.is_finite() && t_max < 5.0, "{t_max}");
    assert!(!analysis(&fast).can_last_at_least(5.0));
    let err = at_least(fast, &lim, 5.0).unwrap_err();
    assert!(err.to_string().contains("feasible durations"), "{err}");
    let slow = Move {
        distance: 1.6,
        v_start: 0.3,
        v_end: 0.3,
    };
    let p = at_least(slow, &lim, 5.0).expect("slow enough");
    assert!((p.duration() - 5.0).abs() < 1e-9);
    assert!(analysis(&slow).durations().max().is_infinite());
    assert!(analysis(&slow).can_last_at_least(5.0));
}

#[test]
fn servo_discretisation_keeps_limits_and_end_state() {
    let mut rng = Rng::new(4242);
    let (mut ok, mut coarse) = (0, 0);
    for case in 0..30_000 {
        let lim = random_limits(&mut rng);
        let forward = rng.chance(0.5);
        let mv = random_move(&mut rng, &lim, forward);
        let reversal = if forward {
            Reversal::Forbid
        } else {
            Reversal::Allow
        };
        let Ok(p) = min_time(&mv, &lim, reversal) else {
            continue;
        };
        // Periods from 1e-4 to 1e-1 of the move's duration (and an absolute servo-like 1 ms).
        let period = if rng.chance(0.3) {
            1e-3
        } else {
            p.duration().max(1e-9) * rng.log_uniform(-4.0, -1.0)
        };
        match on_servo(mv, &lim, period, reversal) {
            Ok(dz) => {
                ok += 1;
                let added = dz.servo_added_time().expect("on a servo period");
                assert!(
                    added >= -1e-12 * p.duration().max(1.0)
                        && (dz.duration() - p.duration() - added).abs()
                            <= 1e-12 * p.duration().max(1.0),
                    "case {case}: {added}"
                );
                for s in dz.segments() {
                    let n = s.duration / period;
                    assert!(
                        (n - n.round()).abs() <= 1e-9 * n.max(1.0),
                        "case {case}: phase {} not a multiple of {period}",
                        s.duration
                    );
                }
                let (e0, e1) = (p.end_state(), dz.end_state());
                let scale = move_scale(&mv, &lim, dz.duration());
                assert!(
                    (e1.position - e0.position).abs() <= 1e-9 * scale,
                    "case {case}: {e1:?} vs {e0:?}"
                );
                assert!(
                    (e1.velocity - e0.velocity).abs() <= 1e-9 * lim.max_vel,
                    "case {case}"
                );
                let e = dz.extrema();
                assert!(
                    e.max_abs_jerk <= lim.max_jerk * (1.0 + 1e-12),
                    "case {case}: jerk {}",
                    e.max_abs_jerk
                );
                if let Err(why) = util::check_accel(&e, &mv, &lim, 1e-12) {
                    panic!("case {case}: {why}");
                }
                assert!(
                    e.max_velocity.max(-e.min_velocity) <= lim.max_vel * (1.0 + 1e-12),
                    "case {case}"
                );
            }
            Err(PlannerError::PeriodTooCoarse { .. }) => coarse += 1,
            Err(e) => panic!(
                "case {case}: {e} {mv:?} {lim:?} period {period} {:?}",
                p.seven_phases()
            ),
        }
    }
    println!("discretised {ok}, too coarse {coarse}");
    // Rounding every phase up alone re-times 20,225 of these; searching neighbouring whole
    // counts 20,917.
    assert!(ok > 20_800, "ok {ok}, coarse {coarse}");
}

/// Rounding phases down would need more jerk than J; rounding up on a 1 ms servo adds less than
/// 1 ms per phase and keeps the jerk.
#[test]
fn servo_rounding_up_adds_bounded_time() {
    let lim = arcsim_planner::Limits::new(0.5, 0.5, 5.0).expect("limits");
    let mv = Move {
        distance: 2.0,
        v_start: 1.0,
        v_end: 0.4,
    };
    let p = min_time(&mv, &lim, Reversal::Forbid).expect("ok");
    let dz = on_servo(mv, &lim, 1e-3, Reversal::Forbid).expect("fine period");
    let added = dz.servo_added_time().expect("on a servo period");
    assert!((0.0..7.0 * 1e-3).contains(&added), "{added}");
    assert!((dz.duration() - p.duration() - added).abs() < 1e-12);
    assert!(dz.extrema().max_abs_jerk <= 0.5 * (1.0 + 1e-12));
    assert!(p.servo_added_time().is_none());
}

/// The one-root test `can_last_at_least` agrees with the full duration analysis: whenever it says
/// yes, a duration >= t exists and is built; it says no only where none exists or t is within
/// 1e-8 of the longest duration.
#[test]
fn can_last_at_least_agrees_with_the_duration_set() {
    let mut rng = Rng::new(2024);
    let (mut yes, mut no) = (0, 0);
    for case in 0..30_000 {
        let lim = random_limits(&mut rng);
        let mv = random_move(&mut rng, &lim, true);
        let Ok(analysis) = MoveAnalysis::new(&mv, &lim, Reversal::Forbid) else {
            assert!(
                !LinearGap::plain(mv.distance).fits(mv.v_start, mv.v_end, &lim),
                "case {case}"
            );
            continue;
        };
        let set = analysis.durations();
        let t = if rng.chance(0.5) && set.max().is_finite() {
            set.max() * (1.0 + rng.uniform(-0.5, 0.5))
        } else {
            set.min() * (1.0 + rng.log_uniform(-6.0, 1.3))
        };
        let fast = analysis.can_last_at_least(t);
        let full = analysis.shortest_duration_at_least(t);
        if fast {
            yes += 1;
            let d = full.unwrap_or_else(|| panic!("case {case}: {set:?} t {t}"));
            let p = analysis.profile(d).expect("a profile that long");
            assert!(p.duration() >= t * (1.0 - 1e-9), "case {case}");
            assert!((p.duration() - d).abs() <= 1e-9 * d.max(1.0), "case {case}");
        } else {
            no += 1;
            assert!(
                full.is_none() || (set.max() - t).abs() <= 1e-8 * t,
                "case {case}: {set:?} t {t}"
            );
        }
    }
    println!("can last: {yes}, cannot: {no}");
    assert!(yes > 1000 && no > 1000, "yes {yes}, no {no}");
}

/// `shortest_duration_at_least` (one root solve in most cases) gives what the whole duration set
/// gives, near both ends of each interval and far from them.
#[test]
fn shortest_duration_at_least_agrees_with_the_duration_set() {
    let mut rng = Rng::new(2026);
    let (mut inside, mut later, mut none) = (0, 0, 0);
    for case in 0..40_000 {
        let lim = random_limits(&mut rng);
        let mv = random_move(&mut rng, &lim, true);
        let Ok(analysis) = MoveAnalysis::new(&mv, &lim, Reversal::Forbid) else {
            continue;
        };
        let set = analysis.durations();
        let ends: Vec<f64> = set
            .intervals()
            .iter()
            .flat_map(|&(a, b)| [a, b])
            .filter(|x| x.is_finite())
            .collect();
        let t = match rng.next_u64() % 3 {
            0 => {
                ends[(rng.next_u64() % ends.len() as u64) as usize]
                    * (1.0 + rng.uniform(-1e-6, 1e-6))
            }
            1 if set.max().is_finite() => set.max() * (1.0 + rng.uniform(-0.5, 0.5)),
            _ => set.min() * (1.0 + rng.log_uniform(-6.0, 1.3)),
        };
        let fast = analysis.shortest_duration_at_least(t);
        let full = set.at_least(t);
        match (fast, full) {
            (Some(a), Some(b)) => {
                assert!(
                    (a - b).abs() <= 1e-9 * b,
                    "case {case}: {a} vs {b}, {set:?} t {t}"
                );
                if b > t * (1.0 + 1e-12) {
                    later += 1;
                } else {
                    inside += 1;
                }
            }
            (None, None) => none += 1,
            _ => panic!("case {case}: {fast:?} vs {full:?}, {set:?} t {t}"),
        }
    }
    println!("inside {inside}, later {later}, none {none}");
    assert!(
        inside > 1000 && later > 100 && none > 1000,
        "inside {inside}, later {later}, none {none}"
    );
}

/// Tiny moves stretched over long durations (1e-11 deg in 5 s, 10 deg in 2e12 s): the cruise
/// speed is far below the speed limit's rounding, and the profile must still cover the distance
/// (a tolerance scaled by V·T once accepted standing still).
#[test]
fn tiny_moves_over_long_durations_reach_their_end() {
    let lim = arcsim_planner::Limits {
        max_jerk: 0.5,
        max_accel: 0.5,
        max_decel: 0.5,
        max_vel: 6.0,
    };
    for d in [1e-11, 1e-10, 1e-6, 1e-3, 1.0, 10.0, 360.0] {
        for t in [5.0, 60.0, 1e5, 1e9, 2e12] {
            let mv = Move {
                distance: d,
                v_start: 0.0,
                v_end: 0.0,
            };
            let p = at_least(mv, &lim, t).unwrap_or_else(|e| panic!("d {d} T {t}: {e}"));
            assert!(
                p.duration() >= t * (1.0 - 1e-9),
                "d {d} T {t}: {}",
                p.duration()
            );
            let end = p.state_at(p.duration());
            assert!(
                (end.position - d).abs() <= 1e-9 * d,
                "d {d} T {t}: ends at {} ",
                end.position
            );
            assert!(
                end.velocity.abs() <= 1e-9 * d / t,
                "d {d} T {t}: {}",
                end.velocity
            );
        }
    }
}
