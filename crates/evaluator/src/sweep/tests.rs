//! Unit tests of loading a sweep and decoding its grids.

use super::*;
use crate::sweep_file::Scale;

/// The values of a range computed eagerly, one by one.
fn eager(spec: &AxisSpec) -> Vec<f64> {
    match *spec {
        AxisSpec::Values(ref v) => v.clone(),
        AxisSpec::Range { from, steps: 1, .. } => vec![from],
        AxisSpec::Range {
            from,
            to,
            steps,
            scale,
        } => (0..steps)
            .map(|i| {
                let f = i as f64 / (steps - 1) as f64;
                if i + 1 == steps {
                    to
                } else {
                    match scale {
                        Scale::Linear => from + f * (to - from),
                        Scale::Log => from * (to / from).powf(f),
                    }
                }
            })
            .collect(),
    }
}

fn range(from: f64, to: f64, steps: usize, scale: Scale) -> AxisSpec {
    AxisSpec::Range {
        from,
        to,
        steps,
        scale,
    }
}

#[test]
fn lazy_axis_values_are_bit_identical_to_the_eager_ones() {
    for spec in [
        range(0.125, 4.0, 1001, Scale::Log),
        range(0.1, 4.0, 997, Scale::Linear),
        range(8.0, 2.0, 10, Scale::Log),
        range(3.0, 0.0, 7, Scale::Linear),
        range(2.5, 2.5, 1, Scale::Linear),
        AxisSpec::Values(vec![3.0, 1.0, 2.0]),
    ] {
        let want = eager(&spec);
        assert_eq!(spec.len(), want.len());
        let got: Vec<u64> = (0..spec.len()).map(|i| spec.value(i).to_bits()).collect();
        let want: Vec<u64> = want.iter().map(|x| x.to_bits()).collect();
        assert_eq!(got, want, "{spec:?}");
    }
}

/// Grid points decode by mixed radix in the eager nesting: spill refill slowest, then spill
/// charge, burst switching, dose-rate scale, scanning speed, window, ELST up, ELST down, V, A, and
/// J fastest.
#[test]
fn grid_settings_decode_like_the_nested_expansion() {
    let grid = Grid {
        jerk: range(0.25, 4.0, 5, Scale::Log),
        accel: AxisSpec::Values(vec![0.5, 0.25]),
        speed: range(6.0, 3.0, 3, Scale::Linear),
        elst_up: None,
        elst_down: Some(range(0.0, 1.0, 2, Scale::Linear)),
        window: Some(AxisSpec::Values(vec![1.0, 0.5])),
        scan_speed: None,
        dose_rate_scale: Some(AxisSpec::Values(vec![1.0, 2.0])),
        burst_switching: Some(AxisSpec::Values(vec![0.15, 0.0])),
        spill_charge: Some(AxisSpec::Values(vec![40.0, 20.0])),
        spill_refill: None,
        spill_max_layers: None,
    };
    let mut nested = Vec::new();
    // No ELST up, scanning speed or spill refill axis: one point, `None`.
    for &q in &eager(grid.spill_charge.as_ref().expect("spill charge")) {
        for &b in &eager(grid.burst_switching.as_ref().expect("bursts")) {
            for &r in &eager(grid.dose_rate_scale.as_ref().expect("dose rate")) {
                for &w in &eager(grid.window.as_ref().expect("window")) {
                    for &d in &eager(grid.elst_down.as_ref().expect("down")) {
                        for &v in &eager(&grid.speed) {
                            for &a in &eager(&grid.accel) {
                                for &j in &eager(&grid.jerk) {
                                    nested.push(Setting {
                                        jerk_deg_per_s3: j,
                                        accel_deg_per_s2: a,
                                        speed_deg_per_s: v,
                                        elst_up_s: None,
                                        elst_down_s: Some(d),
                                        window_deg: Some(w),
                                        scan_speed_mm_per_s: None,
                                        dose_rate_scale: Some(r),
                                        burst_switching_time_s: Some(b),
                                        spill_charge_mu: Some(q),
                                        spill_refill_time_s: None,
                                        spill_max_layers: None,
                                    });
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    assert_eq!(grid.len(), nested.len());
    assert_eq!(grid.checked_len(), Some(960));
    for (i, s) in nested.iter().enumerate() {
        assert_eq!(grid.setting(i), *s, "grid point {i}");
    }
    assert_eq!(grid.values(Axis::ElstUp), vec![None]);
    assert_eq!(grid.values(Axis::ScanSpeed), vec![None]);
    assert_eq!(grid.value(Axis::DoseRateScale, 1), Some(2.0));
    assert_eq!(grid.value(Axis::BurstSwitching, 1), Some(0.0));
    assert_eq!(grid.value(Axis::SpillCharge, 1), Some(20.0));
    assert_eq!(grid.values(Axis::SpillRefill), vec![None]);
    assert_eq!(grid.axis_len(Axis::Jerk), 5);
    assert_eq!(grid.value(Axis::Speed, 2), Some(3.0));
}

#[test]
fn grid_sizes_overflow_into_a_refusal_not_a_wrap() {
    let huge = range(1.0, 2.0, MAX_COMBINATIONS, Scale::Linear);
    let grid = Grid {
        jerk: huge.clone(),
        accel: huge.clone(),
        speed: huge,
        elst_up: None,
        elst_down: None,
        window: None,
        scan_speed: None,
        dose_rate_scale: None,
        burst_switching: None,
        spill_charge: None,
        spill_refill: None,
        spill_max_layers: None,
    };
    assert_eq!(grid.checked_len(), None);
    assert_eq!(grid.len(), usize::MAX);
    let e = check_combinations("s.json", Some(3), [&grid])
        .expect_err("too many")
        .to_string();
    assert!(
        e.starts_with("s.json: 2^64 or more combinations (3 plans × 2^64 or more grid points"),
        "{e}"
    );
    let small = Grid {
        jerk: range(1.0, 2.0, 10_000, Scale::Linear),
        accel: range(1.0, 2.0, 10_000, Scale::Linear),
        speed: AxisSpec::Values(vec![1.0]),
        elst_up: None,
        elst_down: None,
        window: None,
        scan_speed: None,
        dose_rate_scale: None,
        burst_switching: None,
        spill_charge: None,
        spill_refill: None,
        spill_max_layers: None,
    };
    assert!(check_combinations("s.json", Some(1), [&small]).is_ok());
    let e = check_combinations("s.json", Some(2), [&small])
        .expect_err("too many")
        .to_string();
    assert!(
        e.starts_with("s.json: 200000000 combinations (2 plans × 100000000 grid points"),
        "{e}"
    );
    assert!(e.contains("expected at most 100000000"), "{e}");
}
