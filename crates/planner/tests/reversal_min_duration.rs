//! A minimum duration with reversal allowed (the speed may go down to -V): random moves and
//! random minimum durations, checked by integration, against the limits, against a fine
//! numerical search over the profile family, and against Ruckig's `minimum_duration`.

use crate::util::*;
use arcsim_planner::{plan, Limits, Move, MoveAnalysis, MoveOptions, Profile, Reversal};
use rsruckig::prelude::*;

fn allow(min_duration_s: f64) -> MoveOptions {
    MoveOptions {
        min_duration_s,
        servo_period_s: None,
        reversal: Reversal::Allow,
    }
}

/// Ruckig's duration for the move with a minimum duration (speeds in [-V, V], A along the
/// direction of travel and D against it, zero boundary accelerations).
fn ruckig_at_least(
    mv: &Move,
    lim: &Limits,
    t_min: f64,
    otg: &mut Ruckig<1, ThrowErrorHandler>,
) -> Option<f64> {
    let (a_max, a_min) = if mv.direction() > 0.0 {
        (lim.max_accel, -lim.max_decel)
    } else {
        (lim.max_decel, -lim.max_accel)
    };
    let mut input = InputParameter::new(None);
    input.current_velocity[0] = mv.v_start;
    input.target_position[0] = mv.distance;
    input.target_velocity[0] = mv.v_end;
    input.max_velocity[0] = lim.max_vel;
    input.max_acceleration[0] = a_max;
    input.min_acceleration = Some(daov_stack![a_min]);
    input.max_jerk[0] = lim.max_jerk;
    input.minimum_duration = Some(t_min);
    let mut traj = Trajectory::new(None);
    otg.calculate(&input, &mut traj).ok()?;
    Some(traj.get_duration())
}

/// End state by integration (independent of the stored boundary states), limits on the exact
/// extrema and on samples, and the duration against the minimum.
fn check_profile(p: &Profile, mv: &Move, lim: &Limits, t_min: f64, ctx: &str) {
    let (pos, vel, acc) = brute_force_end(p, 16);
    let scale = move_scale(mv, lim, p.duration());
    assert!(
        (pos - mv.distance).abs() <= 1e-9 * scale,
        "{ctx}: end {pos}"
    );
    assert!(
        (vel - mv.v_end).abs() <= 1e-9 * lim.max_vel,
        "{ctx}: end speed {vel}"
    );
    assert!(
        acc.abs() <= 1e-9 * lim.max_accel.max(lim.max_decel),
        "{ctx}: end acc {acc}"
    );
    assert!(p.duration() >= t_min * (1.0 - 1e-12), "{ctx}: too short");
    let rel = 1e-12;
    let e = p.extrema();
    assert!(e.max_abs_jerk <= lim.max_jerk * (1.0 + rel), "{ctx}: {e:?}");
    if let Err(why) = check_accel(&e, mv, lim, rel) {
        panic!("{ctx}: {why}");
    }
    assert!(
        e.max_velocity.max(-e.min_velocity) <= lim.max_vel * (1.0 + rel),
        "{ctx}: {e:?}"
    );
    let dir = mv.direction();
    for (_, st) in p.samples(p.duration() / 53.0) {
        let along = dir * st.acceleration;
        assert!(
            st.velocity.abs() <= lim.max_vel * (1.0 + rel)
                && along <= lim.max_accel * (1.0 + rel)
                && -along <= lim.max_decel * (1.0 + rel),
            "{ctx}: sample {st:?}"
        );
    }
}

/// Stop-and-dwell time of a move whose boundary speeds point along the travel: braking to rest
/// and starting again (eq. 3–4), and whether that fits in the distance. `None` otherwise.
fn stop_and_dwell(mv: &Move, lim: &Limits) -> Option<(f64, bool)> {
    let dir = mv.direction();
    let (d, vs, ve) = (dir * mv.distance, dir * mv.v_start, dir * mv.v_end);
    if vs < 0.0 || ve < 0.0 {
        return None;
    }
    let t = lim.speed_change_duration(vs, 0.0) + lim.speed_change_duration(0.0, ve);
    let dist = lim.speed_change_distance(vs, 0.0) + lim.speed_change_distance(0.0, ve);
    Some((t, dist <= d))
}

#[test]
fn random_moves_with_reversal_and_a_minimum_duration() {
    let mut rng = Rng::new(31);
    let mut otg = new_ruckig();
    let (mut exact, mut lengthened, mut compared, mut reversing) = (0, 0, 0, 0);
    for case in 0..20_000 {
        let lim = random_limits(&mut rng);
        let forward_only = rng.chance(0.5);
        let mv = random_move(&mut rng, &lim, forward_only);
        let analysis = MoveAnalysis::new(&mv, &lim, Reversal::Allow)
            .unwrap_or_else(|e| panic!("case {case}: {e} {mv:?} {lim:?}"));
        let t_opt = analysis.min_time();
        let stop = stop_and_dwell(&mv, &lim);
        // Minimum durations: zero, below the minimum time, up to 30x it, and around the stop time.
        let t_min = match rng.unit() {
            r if r < 0.05 => 0.0,
            r if r < 0.15 => t_opt * rng.uniform(0.0, 1.0),
            r if r < 0.4 && stop.is_some() => {
                stop.map_or(0.0, |s| s.0) * (1.0 + rng.uniform(-0.3, 0.3))
            }
            _ => t_opt * (1.0 + rng.log_uniform(-6.0, 1.5)),
        };
        let ctx = format!("case {case}: {mv:?} {lim:?} t_min {t_min}");
        let p = plan(&mv, &lim, &allow(t_min)).unwrap_or_else(|e| panic!("{ctx}: {e}"));
        check_profile(&p, &mv, &lim, t_min, &ctx);
        let t = p.duration();
        if p.extrema().min_velocity * mv.direction() < -1e-9 * lim.max_vel
            || p.extrema().max_velocity * mv.direction() < -1e-9 * lim.max_vel
        {
            reversing += 1;
        }
        // The answer is the shortest feasible duration >= max(t_min, T_min).
        let want = analysis
            .shortest_duration_at_least(t_min)
            .unwrap_or_else(|| panic!("{ctx}: reversal always has a longer duration"));
        assert!(
            (t - want).abs() <= 1e-9 * want.max(1.0),
            "{ctx}: {t} vs {want}"
        );
        assert!(analysis.can_last_at_least(t_min), "{ctx}");
        assert!(analysis.durations().max().is_infinite(), "{ctx}");
        let target = t_min.max(t_opt);
        if (t - target).abs() <= 1e-9 * target.max(1.0) {
            exact += 1;
        } else {
            lengthened += 1;
            assert!(t > target, "{ctx}: {t} below {target}");
        }
        // Exactly the minimum once it reaches the stop-and-dwell time (stopping fits), or when
        // one end is at or against rest (no hump in the shortest coverable distance).
        match stop {
            Some((t_stop, true)) if t_min >= t_stop => assert!(
                (t - target).abs() <= 1e-9 * target.max(1.0),
                "{ctx}: {t} instead of {target} (stop {t_stop})"
            ),
            None => assert!(
                (t - target).abs() <= 1e-9 * target.max(1.0),
                "{ctx}: {t} instead of {target}"
            ),
            _ => {}
        }
        // Ruckig as an independent oracle, where its ~1e-8 position precision resolves the move.
        if t_min > 0.0 && move_scale(&mv, &lim, t) > 1e-5 {
            if let Some(tr) = ruckig_at_least(&mv, &lim, t_min, &mut otg) {
                compared += 1;
                assert!(
                    (t - tr).abs() <= 1e-6 * tr.max(1.0),
                    "{ctx}: {t} vs ruckig {tr}"
                );
            }
        }
    }
    println!(
        "exact {exact}, lengthened {lengthened}, reversing {reversing}, ruckig compared {compared}"
    );
    assert!(
        exact > 10_000 && lengthened > 100 && reversing > 1000 && compared > 10_000,
        "exact {exact}, lengthened {lengthened}, reversing {reversing}, compared {compared}"
    );
}

/// Distances covered in exactly `t` by the family `v_s → c`, cruise at `c`, `c → v_e` on a fine
/// grid of `c` in [-V, V] (eq. 3–4 for each change): the lowest and the highest found. Every grid
/// profile exists, so `lo <= d <= hi` proves `t` feasible.
fn grid_distances(vs: f64, ve: f64, t: f64, lim: &Limits) -> (f64, f64) {
    let n = 4000;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..=n {
        let c = -lim.max_vel + 2.0 * lim.max_vel * i as f64 / n as f64;
        let (t1, t2) = (
            lim.speed_change_duration(vs, c),
            lim.speed_change_duration(c, ve),
        );
        if t1 + t2 > t {
            continue;
        }
        let d = lim.speed_change_distance(vs, c) + lim.speed_change_distance(c, ve);
        let d = d + c * (t - t1 - t2);
        lo = lo.min(d);
        hi = hi.max(d);
    }
    (lo, hi)
}

/// Brute force: on a fine grid of durations between the minimum asked for and the planner's
/// answer, no profile of the family on a fine grid of extreme speeds covers the distance, so no
/// shorter duration was missed; and the planner's duration is one the family reaches.
#[test]
fn no_shorter_duration_on_a_fine_grid() {
    let mut rng = Rng::new(77);
    let mut lengthened = 0;
    for case in 0..300 {
        let lim = random_limits(&mut rng);
        let mv = random_move(&mut rng, &lim, true);
        let dir = mv.direction();
        let (d, vs, ve) = (dir * mv.distance, dir * mv.v_start, dir * mv.v_end);
        let t_opt = MoveAnalysis::new(&mv, &lim, Reversal::Allow)
            .expect("valid move")
            .min_time();
        if t_opt <= 0.0 {
            // Already there: nothing to search.
            continue;
        }
        let t_min = t_opt * (1.0 + rng.log_uniform(-3.0, 1.0));
        let t = plan(&mv, &lim, &allow(t_min)).expect("profile").duration();
        let scale = d.abs() + lim.max_vel * t;
        if t > t_min * (1.0 + 1e-6) {
            lengthened += 1;
            for k in 0..200 {
                let tk = t_min + (t - t_min) * k as f64 / 200.0;
                if tk > t * (1.0 - 1e-6) {
                    break;
                }
                let (lo, hi) = grid_distances(vs, ve, tk, &lim);
                assert!(
                    !(lo <= d - 1e-9 * scale && d + 1e-9 * scale <= hi),
                    "case {case}: {mv:?} {lim:?}: {tk} s feasible on the grid, planner {t} s"
                );
            }
        }
        // The grid's extremes bracket d at the planner's duration, to the grid's resolution.
        let (lo, hi) = grid_distances(vs, ve, t * (1.0 + 1e-6), &lim);
        let slack = 1e-3 * scale;
        assert!(
            lo <= d + slack && d - slack <= hi,
            "case {case}: {mv:?} {lim:?}: grid [{lo}, {hi}] misses {d} at {t} s"
        );
    }
    assert!(lengthened > 5, "lengthened {lengthened}");
}

/// `min_duration = 0` means no minimum, with or without reversal: the minimum-time profile.
#[test]
fn zero_minimum_is_the_minimum_time() {
    let lim = Limits::new(0.5, 0.5, 5.0).expect("limits");
    let mv = Move {
        distance: 0.5,
        v_start: 2.0,
        v_end: 0.5,
    };
    let t_opt = MoveAnalysis::new(&mv, &lim, Reversal::Allow)
        .expect("valid")
        .min_time();
    let p = plan(&mv, &lim, &allow(0.0)).expect("profile");
    assert!((p.duration() - t_opt).abs() <= 1e-12 * t_opt);
    // The gap is too short to brake without reversing: the valley goes below rest.
    assert!(p.seven_phases().expect("seven phases").v_peak < 0.0);
    assert!(plan(&mv, &lim, &MoveOptions::default()).is_err());
}

/// The ATOM gantry: at 1.5 deg/s a 1.6 deg gap can neither be stretched to 5 s nor braked to rest
/// without reversing. With reversal allowed 5 s still falls between the feasible durations, so
/// the move lasts the start of the next interval: backing up, longer than braking to rest and
/// starting again (4 + 4 s).
#[test]
fn energy_switch_with_reversal_on_atom_gantry() {
    let lim = Limits::new(0.5, 0.5, 5.0).expect("limits");
    let mv = Move {
        distance: 1.6,
        v_start: 1.5,
        v_end: 1.5,
    };
    let forbid = MoveOptions {
        min_duration_s: 5.0,
        ..MoveOptions::default()
    };
    assert!(plan(&mv, &lim, &forbid).is_err());
    let p = plan(&mv, &lim, &allow(5.0)).expect("reversal makes it");
    check_profile(&p, &mv, &lim, 5.0, "atom");
    assert!(p.extrema().min_velocity < 0.0);
    let set = MoveAnalysis::new(&mv, &lim, Reversal::Allow)
        .expect("valid")
        .durations();
    let [first, second] = set.intervals() else {
        panic!("{set:?}")
    };
    assert!(
        first.1 < 5.0 && second.0 > 8.0 && second.1.is_infinite(),
        "{set:?}"
    );
    assert!((p.duration() - second.0).abs() <= 1e-9 * second.0);
    // Asking for a duration in the second interval gives exactly that.
    let q = plan(&mv, &lim, &allow(second.0 + 1.0)).expect("profile");
    assert!((q.duration() - second.0 - 1.0).abs() <= 1e-9 * q.duration());
    // A bad servo period is a typed error.
    let bad_period = MoveOptions {
        servo_period_s: Some(-1.0),
        ..allow(0.0)
    };
    assert!(matches!(
        plan(&mv, &lim, &bad_period),
        Err(arcsim_planner::PlannerError::InvalidInput { name: "period", .. })
    ));
    // Bad minimum durations are typed errors.
    for bad in [f64::NAN, -1.0, f64::INFINITY] {
        assert!(matches!(
            plan(&mv, &lim, &allow(bad)),
            Err(arcsim_planner::PlannerError::InvalidInput {
                name: "min_duration",
                ..
            })
        ));
    }
}
