//! Machine-model validation, the ELST models, and resolution of plans into sequencer layers.

use arcsim_plan::{
    parse_machine, parse_plan, resolve, validate_machine, BeamModel, ElstModel, Machine, PerMuBeam,
    PlanError, ResolvedArc,
};
use serde_json::{json, Value};

pub(crate) fn machine_json() -> Value {
    json!({
        "format": "arcsim-machine/1",
        "name": "test",
        "gantry": { "max_speed_deg_per_s": 5.0, "max_accel_deg_per_s2": 0.5, "max_jerk_deg_per_s3": 0.5 },
        "beam": { "s_per_mu": 0.005, "spot_switch_time_s": 0.002 },
        "elst": { "kind": "constant", "up_s": 5.0, "down_s": 0.5, "same_s": 0.0 },
        "default_window_deg": 1.0
    })
}

/// The machine's `per_mu` beam model, to change in a test.
fn per_mu(m: &mut Machine) -> &mut PerMuBeam {
    match &mut m.beam {
        BeamModel::PerMu(b) => b,
        BeamModel::Scanning(_) => panic!("the test machine has a per_mu beam model"),
    }
}

fn machine() -> Machine {
    parse_machine(&machine_json().to_string(), "m.json").expect("test machine")
}

fn machine_issues(v: &Value) -> Vec<String> {
    match parse_machine(&v.to_string(), "m.json") {
        Err(PlanError::Invalid { issues, .. }) => issues.iter().map(|i| i.to_string()).collect(),
        other => panic!("expected machine issues, got {other:?}"),
    }
}

#[test]
fn machine_defaults_and_optional_fields() {
    let m = machine();
    let mut m = m;
    assert_eq!(per_mu(&mut m).min_spot_time_s, 0.0);
    assert!(m.sources.is_empty());
    assert_eq!(m.gantry.max_decel_deg_per_s2, None);
    assert_eq!(m.servo_period_s, None);
}

#[test]
fn machine_limits_must_be_positive_and_finite() {
    let mut v = machine_json();
    v["gantry"]["max_speed_deg_per_s"] = json!(0.0);
    v["gantry"]["max_jerk_deg_per_s3"] = json!(-1.0);
    v["gantry"]["max_decel_deg_per_s2"] = json!(0.0);
    v["beam"]["spot_switch_time_s"] = json!(-0.002);
    v["elst"]["down_s"] = json!(-0.5);
    v["default_window_deg"] = json!(0.0);
    v["servo_period_s"] = json!(0.0);
    v["format"] = json!("arcsim-machine/9");
    let text = machine_issues(&v);
    for needle in [
        "m.json: field `format`: expected \"arcsim-machine/1\"",
        "m.json: field `gantry.max_speed_deg_per_s`: expected a value from 0.001 to 1000 deg/s, got 0",
        "m.json: field `gantry.max_jerk_deg_per_s3`: expected a value from 0.001 to 10000 deg/s^3, got -1",
        "m.json: field `gantry.max_decel_deg_per_s2`",
        "m.json: field `beam.spot_switch_time_s`: expected a finite value >= 0 s",
        "m.json: field `elst.down_s`",
        "m.json: field `default_window_deg`",
        "m.json: field `servo_period_s`",
    ] {
        assert!(
            text.iter().any(|t| t.contains(needle)),
            "{needle:?} not in {text:#?}"
        );
    }
    assert_eq!(text.len(), 8, "{text:#?}");
}

#[test]
fn machine_non_finite_values_are_caught() {
    let mut m = machine();
    m.gantry.max_accel_deg_per_s2 = f64::NAN;
    per_mu(&mut m).s_per_mu = f64::INFINITY;
    let text: Vec<String> = validate_machine(&m, "m.json")
        .iter()
        .map(|i| i.to_string())
        .collect();
    assert_eq!(text.len(), 2, "{text:#?}");
    assert!(
        text[0].contains("gantry.max_accel_deg_per_s2") && text[0].contains("NaN"),
        "{text:#?}"
    );
    assert!(
        text[1].contains("beam.s_per_mu") && text[1].contains("inf"),
        "{text:#?}"
    );
}

#[test]
fn machine_unknown_fields_and_kinds_are_errors() {
    let mut v = machine_json();
    v["gantry"]["max_sped"] = json!(1.0);
    let err = parse_machine(&v.to_string(), "m.json")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("m.json:1:") && err.contains("unknown field `max_sped`"),
        "{err}"
    );

    let mut v = machine_json();
    v["elst"]["kind"] = json!("cubic");
    let err = parse_machine(&v.to_string(), "m.json")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("field `elst.kind`") && err.contains("unknown variant `cubic`"),
        "{err}"
    );
}

#[test]
fn polynomial_elst_is_validated() {
    let mut v = machine_json();
    v["elst"] =
        json!({ "kind": "polynomial", "down_s": 0.3, "same_s": 0.0, "up_coeffs_s": [1.0, -0.05] });
    let text = machine_issues(&v);
    assert_eq!(text.len(), 1, "{text:#?}");
    assert!(
        text[0].contains("field `elst.up_coeffs_s`: upward switching time is")
            && text[0].contains("expected a time >= 0 s"),
        "{text:#?}"
    );

    v["elst"]["up_coeffs_s"] = json!([]);
    assert!(machine_issues(&v)[0].contains("no coefficients"));
    v["elst"]["up_coeffs_s"] = json!(vec![0.0; 17]);
    assert!(machine_issues(&v)[0].contains("17 coefficients; expected at most 16"));
}

/// A polynomial positive at every one of 400 sampled steps but negative between two of them
/// (a narrow dip of depth 0.2 s around 100.5 MeV) is found by the exact minimum.
#[test]
fn polynomial_elst_dip_between_samples_is_refused() {
    // t(x) = 1.2·(x − 100.5)² − 0.2 ≥ 0 except for |x − 100.5| < 0.408; a check that samples the
    // 400 steps x = i·399/399 = i (and 1e-3) misses the dip: at 100 and 101 it is +0.1.
    let (c, r) = (1.2, 100.5);
    let coeffs = [c * r * r - 0.2, -2.0 * c * r, c];
    for x in [100.0, 101.0] {
        let t: f64 = coeffs.iter().rev().fold(0.0, |acc, k| acc * x + k);
        assert!(t > 0.0, "the sampled step {x} MeV must look fine: {t}");
    }
    let mut v = machine_json();
    v["elst"] =
        json!({ "kind": "polynomial", "down_s": 0.3, "same_s": 0.0, "up_coeffs_s": coeffs });
    let text = machine_issues(&v);
    assert_eq!(text.len(), 1, "{text:#?}");
    assert!(
        text[0].contains("upward switching time is -0.2 s for an energy step of 100.5 MeV"),
        "{text:#?}"
    );
    // Far too slow a switch is refused too (and a sane one accepted).
    v["elst"]["up_coeffs_s"] = json!([1.0, 0.0, 10.0]);
    assert!(machine_issues(&v)[0].contains("expected at most 100000 s"));
    v["elst"]["up_coeffs_s"] = json!([1.0, 0.03, 0.0001]);
    assert!(parse_machine(&v.to_string(), "m.json").is_ok());
}

/// Limits outside the ranges where the planner keeps its precision are refused with the range.
#[test]
fn extreme_machine_values_are_refused_with_the_range() {
    let mut v = machine_json();
    v["gantry"]["max_jerk_deg_per_s3"] = json!(1e7);
    v["gantry"]["max_speed_deg_per_s"] = json!(1e5);
    v["gantry"]["max_accel_deg_per_s2"] = json!(1e-5);
    v["servo_period_s"] = json!(1e300);
    v["elst"]["up_s"] = json!(1e308);
    v["beam"]["s_per_mu"] = json!(100.0);
    let text = machine_issues(&v);
    for needle in [
        "`gantry.max_jerk_deg_per_s3`: expected a value from 0.001 to 10000 deg/s^3, got 10000000",
        "`gantry.max_speed_deg_per_s`: expected a value from 0.001 to 1000 deg/s, got 100000",
        "`gantry.max_accel_deg_per_s2`: expected a value from 0.001 to 1000 deg/s^2, got 1e-5",
        "`servo_period_s`: expected a value from 1e-6 to 1 s, got 1e300",
        "`elst.up_s`: 1e308 s is above the largest accepted value, 100000 s",
        "`beam.s_per_mu`: 100 s is above the largest accepted value, 10 s",
    ] {
        assert!(
            text.iter().any(|t| t.contains(needle)),
            "{needle:?} not in {text:#?}"
        );
    }
    assert_eq!(text.len(), 6, "{text:#?}");
}

#[test]
fn extreme_plan_values_are_refused() {
    let v = json!({ "format": "arcsim-plan/1", "name": "r", "arcs": [{ "direction": "CW", "control_points": [
        { "angle_deg": 1e308, "layers": [{ "energy_mev": 150.0, "spots": { "count": 2, "mu": [1e307, 1.0] } }] },
        { "angle_deg": 2.0, "layers": [{ "energy_mev": 150.0, "irradiation_time_s": 1e300, "switching_time_s": 1e308 }] }
    ] }] });
    let err = parse_plan(&v.to_string(), "r.json")
        .unwrap_err()
        .to_string();
    for needle in [
        "control point 0, field `angle_deg`: 1e308 deg is beyond ±10000 deg",
        "field `spots.mu[0]`: 1e307 MU is above the largest accepted value, 1000000 MU",
        "field `irradiation_time_s`: 1e300 s is above the largest accepted value, 100000 s",
        "field `switching_time_s`: 1e308 s is above the largest accepted value, 100000 s",
    ] {
        assert!(err.contains(needle), "{needle:?} not in {err}");
    }
}

#[test]
fn elst_switch_times() {
    let constant = ElstModel::Constant {
        up_s: 5.0,
        down_s: 0.5,
        same_s: 0.1,
    };
    assert_eq!(constant.switch_time_s(100.0, 120.0), 5.0);
    assert_eq!(constant.switch_time_s(120.0, 100.0), 0.5);
    assert_eq!(constant.switch_time_s(120.0, 120.0), 0.1);
    let poly = ElstModel::Polynomial {
        down_s: 0.3,
        same_s: 0.0,
        up_coeffs_s: vec![1.0, 0.03, 0.0001],
    };
    assert!((poly.switch_time_s(100.0, 110.0) - 1.31).abs() < 1e-12);
    assert!((poly.switch_time_s(100.0, 180.0) - 4.04).abs() < 1e-12);
    assert_eq!(poly.switch_time_s(180.0, 100.0), 0.3);
    assert_eq!(poly.switch_time_s(180.0, 180.0), 0.0);
}

fn plan(arcs: Value) -> arcsim_plan::ArcPlan {
    let v = json!({ "format": "arcsim-plan/1", "name": "r", "arcs": arcs });
    parse_plan(&v.to_string(), "r.json").expect("test plan")
}

fn resolved(arcs: Value) -> Vec<ResolvedArc> {
    resolve(&plan(arcs), &machine()).expect("resolves")
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-12
}

#[test]
fn irradiation_times_from_spots() {
    let arcs = json!([{ "direction": "CW", "control_points": [
        { "angle_deg": 0.0, "layers": [{ "energy_mev": 150.0, "spots": { "count": 3, "mu": [10.0, 20.0, 0.0] } }] },
        { "angle_deg": 2.0, "layers": [{ "energy_mev": 140.0, "spots": { "count": 4, "total_mu": 40.0 } }] },
        { "angle_deg": 4.0, "layers": [{ "energy_mev": 130.0, "irradiation_time_s": 0.25 }] }
    ] }]);
    let r = resolved(arcs.clone());
    let t: Vec<f64> = r[0].layers.iter().map(|l| l.irradiation_s).collect();
    assert!(close(t[0], 30.0 * 0.005 + 2.0 * 0.002), "{t:?}");
    assert!(close(t[1], 40.0 * 0.005 + 3.0 * 0.002), "{t:?}");
    assert_eq!(t[2], 0.25);

    // A minimum spot time lifts the short spots (here every spot to 0.08 s).
    let mut m = machine();
    per_mu(&mut m).min_spot_time_s = 0.08;
    let r = resolve(&plan(arcs), &m).unwrap();
    assert!(close(
        r[0].layers[0].irradiation_s,
        0.08 + 0.1 + 0.08 + 2.0 * 0.002
    ));
    assert!(close(
        r[0].layers[1].irradiation_s,
        4.0 * 0.08 + 3.0 * 0.002
    ));
}

#[test]
fn switch_times_windows_and_speeds() {
    let r = resolved(json!([
        { "direction": "CW", "control_points": [
            { "angle_deg": 10.0, "required_speed_deg_per_s": 1.5, "layers": [
                { "energy_mev": 150.0, "irradiation_time_s": 0.1 },
                { "energy_mev": 140.0, "irradiation_time_s": 0.1 },
                { "energy_mev": 140.0, "irradiation_time_s": 0.1 }
            ] },
            { "angle_deg": 12.0, "window_deg": 2.0, "layers": [
                { "energy_mev": 160.0, "irradiation_time_s": 0.1, "switching_time_s": 3.0 }
            ] }
        ] },
        { "direction": "CC", "control_points": [
            { "angle_deg": 12.0, "window_deg": 1.0, "layers": [
                { "energy_mev": 170.0, "irradiation_time_s": 0.1 },
                { "energy_mev": 120.0, "irradiation_time_s": 0.1 }
            ] }
        ] }
    ]));
    assert_eq!(r.len(), 2);
    assert_eq!(
        (r[1].arc_index, r[1].direction),
        (1, arcsim_plan::RotationDirection::Cc)
    );
    let a = &r[0].layers;
    assert_eq!(
        a.iter().map(|l| l.switch_in_s).collect::<Vec<_>>(),
        vec![0.0, 0.5, 0.0, 3.0]
    );
    // Three layers share the default 1 deg window in CW order: centres 10 - 1/3, 10, 10 + 1/3.
    assert!(
        close(a[0].angle_deg, 10.0 - 1.0 / 3.0)
            && close(a[1].angle_deg, 10.0)
            && close(a[2].angle_deg, 10.0 + 1.0 / 3.0)
    );
    assert!(a[..3].iter().all(|l| close(l.window_deg, 1.0 / 3.0)));
    assert!(a[..3]
        .iter()
        .all(|l| l.required_speed_deg_per_s == Some(1.5)));
    assert_eq!(
        (
            a[3].control_point,
            a[3].layer,
            a[3].angle_deg,
            a[3].window_deg
        ),
        (1, 0, 12.0, 2.0)
    );
    assert_eq!(a[3].required_speed_deg_per_s, None);
    // The second arc continues from the first one's last energy (160 -> 170: up); CC order reverses.
    let b = &r[1].layers;
    assert_eq!(
        b.iter().map(|l| l.switch_in_s).collect::<Vec<_>>(),
        vec![5.0, 0.5]
    );
    assert!(
        close(b[0].angle_deg, 12.25) && close(b[1].angle_deg, 11.75),
        "{b:?}"
    );
    assert!(close(b[0].window_deg, 0.5));
}

#[test]
fn default_window_wider_than_spacing_fails_to_resolve() {
    let p = plan(json!([{ "direction": "CW", "control_points": [
        { "angle_deg": 0.0, "layers": [{ "energy_mev": 150.0, "irradiation_time_s": 0.1 }] },
        { "angle_deg": 0.5, "window_deg": 0.5, "layers": [{ "energy_mev": 140.0, "irradiation_time_s": 0.1 }] }
    ] }]));
    let err = resolve(&p, &machine()).unwrap_err();
    let issues = err.issues();
    assert_eq!(issues.len(), 1, "{err}");
    assert_eq!(
        (
            issues[0].arc,
            issues[0].control_point,
            issues[0].field.as_str()
        ),
        (Some(0), Some(0), "window_deg")
    );
    assert!(
        issues[0]
            .message
            .contains("default window 1 deg (machine field `default_window_deg`) is wider than the 0.5 deg spacing to control point 1; lower the machine's default_window_deg"),
        "{err}"
    );
    assert!(
        err.to_string().starts_with("plan \"r\": 1 problem:"),
        "{err}"
    );
}

#[test]
fn resolve_validates_plans_built_in_code() {
    let mut p = plan(json!([{ "direction": "CW", "control_points": [
        { "angle_deg": 0.0, "layers": [{ "energy_mev": 150.0, "irradiation_time_s": 0.1 }] }
    ] }]));
    p.arcs[0].control_points[0].layers[0].irradiation_time_s = Some(f64::NAN);
    let mut m = machine();
    m.gantry.max_jerk_deg_per_s3 = 0.0;
    let err = resolve(&p, &m).unwrap_err();
    let text = err.to_string();
    assert_eq!(err.issues().len(), 2, "{text}");
    assert!(
        text.contains("plan \"r\": arc 0, control point 0, layer 0, field `irradiation_time_s`"),
        "{text}"
    );
    assert!(
        text.contains("machine \"test\": field `gantry.max_jerk_deg_per_s3`"),
        "{text}"
    );
}

#[test]
fn overflowing_irradiation_time_fails_to_resolve() {
    // Validation refuses such MU; resolving still guards a plan built without it.
    let p: arcsim_plan::ArcPlan = serde_json::from_value(json!({ "format": "arcsim-plan/1", "name": "r", "arcs": [{ "direction": "CW", "control_points": [
        { "angle_deg": 0.0, "layers": [{ "energy_mev": 150.0, "spots": { "count": 2, "mu": [1e307, 1e307] } }] }
    ] }] }))
    .expect("parses without validation");
    let mut m = machine();
    per_mu(&mut m).s_per_mu = 10.0;
    let err = resolve(&p, &m).unwrap_err().to_string();
    assert!(
        err.contains("layer 0, field `spots.mu[0]`: 1e307 MU is above the largest accepted value"),
        "{err}"
    );
}

/// The same problem in many places is one line, with the count and a few places; numbers keep
/// a sensible precision; energies in keV get a hint.
#[test]
fn repeated_problems_are_grouped() {
    let cps: Vec<Value> = (0..166)
        .map(|i| json!({ "angle_deg": 2.0 * f64::from(i), "layers": [{ "energy_mev": 150000.0 + f64::from(i), "irradiation_time_s": 0.1 }] }))
        .collect();
    let v = json!({ "format": "arcsim-plan/1", "name": "kev", "arcs": [{ "direction": "CW", "control_points": cps }] });
    let err = parse_plan(&v.to_string(), "kev.json").unwrap_err();
    assert_eq!(err.issues().len(), 166);
    let text = err.to_string();
    assert!(text.starts_with("kev.json: 166 problems:"), "{text}");
    assert!(
        text.contains(
            "field `energy_mev`: expected an energy in 1..=400 MeV, got 150000 — given in keV?"
        ),
        "{text}"
    );
    assert!(
        text.contains("and 165 more like it: arc 0, control point 1, layer 0, field `energy_mev`;"),
        "{text}"
    );
    assert_eq!(text.lines().count(), 3, "{text}");
}

/// Implausible plan values are warned about once per field, with the count of places.
#[test]
fn plan_warnings_name_the_field_and_count() {
    let p = plan(json!([{ "direction": "CW", "control_points": [
        { "angle_deg": 0.0, "window_deg": 1.0, "layers": [{ "energy_mev": 20.0, "irradiation_time_s": 500.0 }] },
        { "angle_deg": 2.0, "layers": [{ "energy_mev": 150.0, "irradiation_time_s": 900.0 }] },
        { "angle_deg": 4.0, "layers": [{ "energy_mev": 150.0, "irradiation_time_s": 0.5 }] }
    ] }]));
    let w: Vec<String> = arcsim_plan::plan_warnings(&p, "p.json")
        .iter()
        .map(ToString::to_string)
        .collect();
    assert_eq!(w.len(), 2, "{w:#?}");
    assert!(w[0].contains("arc 0, control point 0, layer 0: energy_mev: 20 MeV is outside the plausible 30–300 MeV"), "{w:#?}");
    assert!(w[1].contains("irradiation_time_s (and 1 more places): 500 s is outside the plausible 0–120 s; given in milliseconds?"), "{w:#?}");
    assert!(arcsim_plan::machine_warnings(&machine(), "m.json").is_empty());
}
