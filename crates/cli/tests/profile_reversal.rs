//! `arcsim profile` with a minimum duration and reversal allowed: `--min-duration 0` means no
//! minimum, and a minimum duration with `--reverse allow` is solved (the shortest duration of at
//! least that long), while `--reverse forbid` keeps reporting a duration the move cannot last.

use crate::util::{arcsim, text};
use arcsim_test_support::temp_dir;

/// `arcsim profile --json` on the ATOM gantry (J = A = 0.5, V = 5) with extra options.
fn profile_json(distance: &str, v: &str, extra: &[&str]) -> Result<serde_json::Value, String> {
    profile_json_to(distance, v, v, extra)
}

/// [`profile_json`] with different start and end speeds.
fn profile_json_to(
    distance: &str,
    v_start: &str,
    v_end: &str,
    extra: &[&str],
) -> Result<serde_json::Value, String> {
    let mut args = vec![
        "profile",
        "--distance",
        distance,
        "--v-start",
        v_start,
        "--v-end",
        v_end,
        "--jerk",
        "0.5",
        "--accel",
        "0.5",
        "--vel",
        "5",
        "--json",
    ];
    args.extend_from_slice(extra);
    let o = arcsim(&args);
    let (out, err) = text(&o);
    if !o.status.success() {
        return Err(err);
    }
    serde_json::from_str(&out).map_err(|e| format!("{e}: {out}"))
}

fn duration(v: &serde_json::Value) -> f64 {
    v["duration_s"].as_f64().expect("duration_s")
}

fn lowest_phase_speed(v: &serde_json::Value) -> f64 {
    v["phases"]
        .as_array()
        .expect("phases")
        .iter()
        .map(|p| p["speed_at_start_deg_per_s"].as_f64().expect("speed"))
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn zero_minimum_duration_with_reversal_is_the_minimum_time() {
    // Too short to brake from 2 to 0.5 deg/s in 0.5 deg without backing up.
    let fastest =
        profile_json_to("0.5", "2", "0.5", &["--reverse", "allow"]).expect("minimum time");
    let zero = profile_json_to(
        "0.5",
        "2",
        "0.5",
        &["--reverse", "allow", "--min-duration", "0"],
    )
    .expect("--min-duration 0 is no minimum");
    assert!(profile_json_to("0.5", "2", "0.5", &["--min-duration", "0"]).is_err());
    assert!(
        (duration(&zero) - duration(&fastest)).abs() <= 1e-9,
        "{zero} vs {fastest}"
    );
    assert!(zero["extreme_speed_deg_per_s"].as_f64().expect("v_m") < 0.0);
}

#[test]
fn minimum_duration_with_reversal_is_solved() {
    // Slow enough to stop and dwell: exactly the minimum.
    let slow = profile_json("1.6", "0.3", &["--reverse", "allow", "--min-duration", "5"])
        .expect("slow move");
    assert!((duration(&slow) - 5.0).abs() <= 1e-9, "{slow}");
    // At 1.5 deg/s the 1.6 deg gap can neither last 5 s going forward nor brake to rest (4 s to
    // stop, 4 s to start again): without reversal it is infeasible ...
    let err = profile_json("1.6", "1.5", &["--min-duration", "5"]).unwrap_err();
    assert!(
        err.contains("infeasible") && err.contains("feasible durations"),
        "{err}"
    );
    // ... with reversal the gantry backs up: the shortest duration of at least 5 s is longer
    // than stopping and starting again.
    let back = profile_json("1.6", "1.5", &["--reverse", "allow", "--min-duration", "5"])
        .expect("reversal makes it");
    assert!(duration(&back) > 8.0, "{back}");
    assert!(lowest_phase_speed(&back) < 0.0, "{back}");
    // A longer minimum than that is met exactly.
    let t = format!("{}", duration(&back) + 2.0);
    let longer =
        profile_json("1.6", "1.5", &["--reverse", "allow", "--min-duration", &t]).expect("longer");
    assert!(
        (duration(&longer) - duration(&back) - 2.0).abs() <= 1e-9,
        "{longer}"
    );
}

#[test]
fn batch_rows_with_reversal_and_a_minimum_duration() {
    let dir = temp_dir();
    let input = dir.join("moves.csv");
    let output = dir.join("out.csv");
    std::fs::write(
        &input,
        "distance,v_start,v_end,jerk,accel,vel,min_duration,reverse\n\
         1.6,1.5,1.5,0.5,0.5,5,5,forbid\n\
         1.6,1.5,1.5,0.5,0.5,5,5,allow\n\
         0.5,2,0.5,0.5,0.5,5,0,allow\n\
         1,0,0,1,1,1,-1,allow\n",
    )
    .expect("write");
    let o = arcsim(&[
        "profile",
        "--batch",
        input.to_str().expect("utf-8"),
        "--out",
        output.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    let rows: Vec<String> = std::fs::read_to_string(&output)
        .expect("out")
        .lines()
        .map(String::from)
        .collect();
    assert_eq!(rows.len(), 5, "{rows:?}");
    assert!(rows[1].starts_with("2,infeasible,"), "{}", rows[1]);
    assert!(rows[2].starts_with("3,ok,"), "{}", rows[2]);
    let d: f64 = rows[2]
        .split(',')
        .nth(2)
        .expect("duration")
        .parse()
        .expect("number");
    assert!(d > 8.0, "{}", rows[2]);
    assert!(rows[3].starts_with("4,ok,"), "{}", rows[3]);
    assert!(
        rows[4].starts_with("5,error,") && rows[4].contains("min_duration"),
        "{}",
        rows[4]
    );
}
