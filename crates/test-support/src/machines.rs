//! Machines that only tests and benchmarks use.

/// A machine unlike every bundled one (V 4 °/s, A 0.3 °/s², J 0.4 °/s³, 0.004 s/MU, ELST up
/// 3.2 s and down 0.8 s; free motion): the "real" machine whose simulated deliveries stand in for delivery
/// logs, so that a calibration from the ATOM machine has something to find.
pub const HIDDEN_MACHINE_JSON: &str = r#"{
  "format": "arcsim-machine/1", "name": "hidden",
  "gantry": {"max_speed_deg_per_s": 4.0, "max_accel_deg_per_s2": 0.3, "max_jerk_deg_per_s3": 0.4},
  "controller": {"motion": "free", "schedule": "optimal", "source": "assumed: a test machine whose gantry may change speed during beam-on"},
  "beam": {"s_per_mu": 0.004, "spot_switch_time_s": 0.002, "min_spot_time_s": 0.0},
  "elst": {"kind": "constant", "up_s": 3.2, "down_s": 0.8, "same_s": 0.0},
  "default_window_deg": 1.0
}"#;
