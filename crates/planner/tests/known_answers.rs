//! Known answers: the paper's Table 3 and the true optima under its stated limits.

use crate::util::{min_time, new_ruckig, ruckig_duration};
use arcsim_planner::{Limits, Move, PlannerError, Reversal};

fn peak(j: f64, a: f64, v: f64, d: f64, vs: f64, ve: f64) -> (f64, f64) {
    let lim = Limits::new(j, a, v).expect("limits");
    let p = min_time(
        &Move {
            distance: d,
            v_start: vs,
            v_end: ve,
        },
        &lim,
        Reversal::Allow,
    )
    .expect("profile");
    (p.seven_phases().expect("seven-phase").v_peak, p.duration())
}

/// Table 3, case 1 (A = 20, V = 1.2) reproduces with an effective jerk of J/2 = 1000: the paper's
/// jerk periods evidently use J/2. Ex3's printed distance 0.000 is 0.00033 before rounding.
#[test]
fn paper_table3_case1_with_half_jerk() {
    let rows = [
        ("Ex1", 0.033, 0.0, 0.0, 0.6367),
        ("Ex2", 0.033, 0.0, 0.03, 0.6333),
        ("Ex3", 0.00033, 0.0, 0.4, -0.2425),
    ];
    for (name, d, vs, ve, printed) in rows {
        let (vm, _) = peak(1000.0, 20.0, 1.2, d, vs, ve);
        assert!(
            (vm - printed).abs() < 0.5e-4,
            "{name}: v_m = {vm:.6}, paper {printed}"
        );
    }
    // Ex4: the paper prints -0.3821; the exact optimum under the same convention is -0.3831.
    let (vm, _) = peak(1000.0, 20.0, 1.2, 0.033, 0.0, 1.2);
    assert!((vm - (-0.3831)).abs() < 0.5e-4, "Ex4: {vm}");
    assert!(
        (vm - (-0.3821)).abs() > 5e-4,
        "Ex4 should differ from the misprint: {vm}"
    );
}

/// The true optimum under the stated limits for all eight examples (peak speed, duration),
/// each duration confirmed by Ruckig.
#[test]
fn table3_true_optimum_under_stated_limits() {
    // (name, J, A, V, d, vs, ve, v_peak, duration)
    type Row = (&'static str, f64, f64, f64, f64, f64, f64, f64, f64);
    let rows: [Row; 7] = [
        ("Ex1", 2000.0, 20.0, 1.2, 0.033, 0.0, 0.0, 0.7185, 0.091854),
        ("Ex2", 2000.0, 20.0, 1.2, 0.033, 0.0, 0.03, 0.7170, 0.090198),
        (
            "Ex3", 2000.0, 20.0, 1.2, 0.00033, 0.0, 0.4, -0.2513, 0.065128,
        ),
        ("Ex4", 2000.0, 20.0, 1.2, 0.033, 0.0, 1.2, -0.3359, 0.113589),
        ("Ex5", 1.2e4, 40.0, 0.8, 0.033, 0.0, 0.0, 0.8, 0.064583),
        ("Ex6", 1.2e4, 40.0, 0.8, 0.033, 0.0, 0.03, 0.8, 0.063785),
        ("Ex7", 1.2e4, 40.0, 0.8, 0.0, 0.0, 0.4, -0.2667, 0.030000),
    ];
    let mut otg = new_ruckig();
    for (name, j, a, v, d, vs, ve, vm_want, t_want) in rows {
        let (vm, t) = peak(j, a, v, d, vs, ve);
        assert!(
            (vm - vm_want).abs() < 0.5e-4,
            "{name}: v_m {vm:.6} vs {vm_want}"
        );
        assert!((t - t_want).abs() < 0.5e-6, "{name}: T {t:.7} vs {t_want}");
        let lim = Limits::new(j, a, v).expect("limits");
        let tr = ruckig_duration(
            &Move {
                distance: d,
                v_start: vs,
                v_end: ve,
            },
            &lim,
            &mut otg,
        )
        .expect("ruckig");
        assert!((t - tr).abs() <= 1e-9 * tr, "{name}: {t} vs ruckig {tr}");
    }
    // Ex8: v_e = 1.2 exceeds V = 0.8: a typed error, not a profile.
    let lim = Limits::new(1.2e4, 40.0, 0.8).expect("limits");
    let err = min_time(
        &Move {
            distance: 0.033,
            v_start: 0.0,
            v_end: 1.2,
        },
        &lim,
        Reversal::Allow,
    )
    .unwrap_err();
    assert!(
        matches!(err, PlannerError::SpeedAboveLimit { name: "v_end", .. }),
        "{err:?}"
    );
}

/// Speed change alone (eq. 3–4): trapezoid and triangle durations and distances, and the
/// minimum-time profile of a move that is exactly one speed change.
#[test]
fn basic_profile_equations() {
    let lim = Limits::with_decel(0.5, 0.5, 0.25, 5.0).expect("limits");
    // Trapezoid: Δv = 2 >= A²/J = 0.5 → t1 = A/J = 1, t2 = Δv/A - A/J = 3, duration 5.
    assert!((lim.speed_change_duration(0.5, 2.5) - 5.0).abs() < 1e-15);
    assert!((lim.speed_change_distance(0.5, 2.5) - 1.5 * 5.0).abs() < 1e-12);
    // Triangle: Δv = 0.125 < A²/J = 0.5 → t1 = sqrt(Δv/J) = 0.5, t2 = 0, duration 1.
    assert!((lim.speed_change_duration(0.5, 0.625) - 1.0).abs() < 1e-15);
    // Falling under D = 0.25: Δv = 1 >= D²/J = 0.125 → Δv/D + D/J = 4.5.
    assert!((lim.speed_change_duration(2.0, 1.0) - 4.5).abs() < 1e-15);
    assert_eq!(lim.accel_bound(1.0, 2.0), 0.5);
    assert_eq!(lim.accel_bound(2.0, 1.0), 0.25);
    // A move whose distance is exactly that of the speed change is the speed change.
    let mv = Move {
        distance: lim.speed_change_distance(0.5, 2.5),
        v_start: 0.5,
        v_end: 2.5,
    };
    let p = min_time(&mv, &lim, Reversal::Forbid).expect("profile");
    assert!((p.duration() - 5.0).abs() < 1e-12, "{}", p.duration());
    let phases = p.seven_phases().expect("seven phases");
    assert!((phases.t1 - 1.0).abs() < 1e-12 && (phases.t2 - 3.0).abs() < 1e-12);
}

/// Invalid limits and inputs are typed errors, never panics or NaN.
#[test]
fn bad_inputs_are_typed_errors() {
    for (j, a, v) in [
        (0.0, 1.0, 1.0),
        (1.0, -1.0, 1.0),
        (1.0, 1.0, f64::NAN),
        (f64::INFINITY, 1.0, 1.0),
    ] {
        assert!(matches!(
            Limits::new(j, a, v),
            Err(PlannerError::InvalidLimit { .. })
        ));
    }
    let lim = Limits::new(1.0, 1.0, 1.0).expect("limits");
    let nan = Move {
        distance: f64::NAN,
        v_start: 0.0,
        v_end: 0.0,
    };
    assert!(matches!(
        min_time(&nan, &lim, Reversal::Allow),
        Err(PlannerError::InvalidInput {
            name: "distance",
            ..
        })
    ));
    let back = Move {
        distance: 1.0,
        v_start: -0.5,
        v_end: 0.0,
    };
    assert!(matches!(
        min_time(&back, &lim, Reversal::Forbid),
        Err(PlannerError::SpeedAgainstTravel { .. })
    ));
    assert!(min_time(&back, &lim, Reversal::Allow).is_ok());
}

/// Inside an arc (reversal forbidden) a gap too short to brake is a typed result whose bounds
/// are exact: the reported start speed still reaches v_e, anything faster does not.
#[test]
fn gap_too_short_reports_exact_bounds() {
    let lim = Limits::new(0.5, 0.5, 5.0).expect("limits");
    let mv = Move {
        distance: 0.5,
        v_start: 2.0,
        v_end: 0.5,
    };
    let err = min_time(&mv, &lim, Reversal::Forbid).unwrap_err();
    let PlannerError::Unreachable {
        max_start_speed, ..
    } = err
    else {
        panic!("{err:?}")
    };
    assert!(max_start_speed < 2.0 && max_start_speed > 0.5);
    let ok = Move {
        v_start: max_start_speed,
        ..mv
    };
    assert!(min_time(&ok, &lim, Reversal::Forbid).is_ok());
    let too_fast = Move {
        v_start: max_start_speed * (1.0 + 1e-9),
        ..mv
    };
    assert!(min_time(&too_fast, &lim, Reversal::Forbid).is_err());
}

/// An analytic optimum: from speed v back to the same point at rest (d = 0, v_e = 0) with only a
/// jerk limit, the valley speed is -v/φ (φ the golden ratio) and T = 2·sqrt(v/J)·(sqrt(φ) + sqrt(1/φ)).
/// Checked at a scale where rsruckig's position precision (~1e-8) no longer resolves the move.
#[test]
fn golden_ratio_return_to_start() {
    let phi = 0.5 * (1.0 + 5f64.sqrt());
    for (v, j) in [
        (1.0, 1.0),
        (8.037834236398688e-8, 3022.9005540918),
        (0.3, 0.5),
    ] {
        let lim = Limits::new(j, 1e6, 10.0).expect("limits");
        let p = min_time(
            &Move {
                distance: 0.0,
                v_start: v,
                v_end: 0.0,
            },
            &lim,
            Reversal::Allow,
        )
        .expect("profile");
        let t = 2.0 * (v / j).sqrt() * (phi.sqrt() + (1.0 / phi).sqrt());
        assert!(
            (p.duration() - t).abs() <= 1e-12 * t,
            "v={v}: {} vs {t}",
            p.duration()
        );
        let vm = p.seven_phases().expect("seven-phase").v_peak;
        assert!((vm + v / phi).abs() <= 1e-9 * v, "v={v}: valley {vm}");
    }
}
