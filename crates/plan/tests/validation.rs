//! Every validation rule of the plan format, each checked to name the file, the place and the field.

use arcsim_plan::{parse_plan, validate_plan, ArcPlan, PlanError, PlanIssue};
use serde_json::{json, Value};

const FILE: &str = "case.json";

/// (arc, control point, layer) of an issue.
type Place = (Option<usize>, Option<usize>, Option<usize>);

fn layer(e: f64, t: f64) -> Value {
    json!({ "energy_mev": e, "irradiation_time_s": t })
}

/// A valid plan: one CW arc at 10, 12, 14, 16 deg, one layer each (spots on the second).
fn base() -> Value {
    json!({
        "format": "arcsim-plan/1",
        "name": "base",
        "arcs": [{
            "direction": "CW",
            "control_points": [
                { "angle_deg": 10.0, "layers": [layer(150.0, 0.2)] },
                { "angle_deg": 12.0, "window_deg": 1.0, "layers": [
                    { "energy_mev": 140.0, "spots": { "count": 3, "mu": [1.0, 2.0, 3.0] } }
                ] },
                { "angle_deg": 14.0, "required_speed_deg_per_s": 2.0, "layers": [layer(130.0, 0.2), layer(120.0, 0.1)] },
                { "angle_deg": 16.0, "layers": [
                    { "energy_mev": 160.0, "spots": { "count": 4, "total_mu": 10.0 }, "switching_time_s": 4.0 }
                ] }
            ]
        }]
    })
}

fn parse(v: &Value) -> Result<ArcPlan, PlanError> {
    parse_plan(&serde_json::to_string_pretty(v).unwrap(), FILE)
}

fn issues(v: &Value) -> Vec<PlanIssue> {
    match parse(v) {
        Err(PlanError::Invalid {
            source_name,
            issues,
        }) => {
            assert_eq!(source_name, FILE);
            issues
        }
        other => panic!("expected validation issues, got {other:?}"),
    }
}

/// Asserts exactly one issue, at this place and field, whose message contains `needle`; returns its text.
fn single(v: &Value, place: Place, field: &str, needle: &str) -> String {
    let found = issues(v);
    assert_eq!(found.len(), 1, "expected one issue, got {found:#?}");
    let i = &found[0];
    assert_eq!((i.arc, i.control_point, i.layer), place, "{i}");
    assert_eq!(i.field, field, "{i}");
    assert!(
        i.message.contains(needle),
        "message {:?} lacks {needle:?}",
        i.message
    );
    let text = i.to_string();
    assert!(text.starts_with("case.json: "), "{text}");
    assert!(text.contains(&format!("field `{field}`")), "{text}");
    if let Some(a) = place.0 {
        assert!(text.contains(&format!("arc {a}")), "{text}");
    }
    if let Some(c) = place.1 {
        assert!(text.contains(&format!("control point {c}")), "{text}");
    }
    if let Some(l) = place.2 {
        assert!(text.contains(&format!("layer {l}")), "{text}");
    }
    text
}

fn at(a: usize, c: usize, l: usize) -> Place {
    (Some(a), Some(c), Some(l))
}

fn at_cp(a: usize, c: usize) -> Place {
    (Some(a), Some(c), None)
}

fn lay(v: &mut Value, c: usize, l: usize) -> &mut Value {
    &mut v["arcs"][0]["control_points"][c]["layers"][l]
}

fn cp(v: &mut Value, c: usize) -> &mut Value {
    &mut v["arcs"][0]["control_points"][c]
}

fn json_error(text: &str) -> (usize, usize, String, String) {
    match parse_plan(text, FILE) {
        Err(e @ PlanError::Json { .. }) => {
            let shown = e.to_string();
            let PlanError::Json {
                line,
                column,
                location,
                ..
            } = e
            else {
                unreachable!()
            };
            (line, column, location, shown)
        }
        other => panic!("expected a JSON error, got {other:?}"),
    }
}

#[test]
fn base_plan_is_valid() {
    let plan = parse(&base()).expect("base plan");
    assert_eq!(plan.arcs[0].control_points.len(), 4);
    assert!(validate_plan(&plan, FILE).is_empty());
}

#[test]
fn malformed_json_reports_line_and_column() {
    let text = "{\n  \"format\": \"arcsim-plan/1\",\n  \"name\": \"x\"\n  \"arcs\": []\n}";
    let (line, column, _, shown) = json_error(text);
    assert_eq!(line, 4);
    assert!(column >= 1);
    assert!(
        shown.starts_with(&format!("case.json:4:{column}: ")),
        "{shown}"
    );
    assert!(shown.contains("malformed JSON"), "{shown}");
}

#[test]
fn truncated_and_trailing_json_are_errors() {
    let (_, _, _, shown) = json_error("{\"format\": \"arcsim-plan/1\", \"name\": ");
    assert!(shown.contains("malformed JSON"), "{shown}");
    let (line, _, _, shown) =
        json_error("{\"format\": \"arcsim-plan/1\", \"name\": \"x\", \"arcs\": []}\n]");
    assert_eq!(line, 2, "{shown}");
    assert!(shown.contains("trailing"), "{shown}");
}

#[test]
fn missing_field_names_the_layer() {
    let mut v = base();
    lay(&mut v, 1, 0)
        .as_object_mut()
        .unwrap()
        .remove("energy_mev");
    let (_, _, location, shown) = json_error(&serde_json::to_string_pretty(&v).unwrap());
    assert_eq!(location, "arc 0, control point 1, layer 0");
    assert!(shown.contains("missing field `energy_mev`"), "{shown}");
}

#[test]
fn unknown_field_names_the_place_and_field() {
    let mut v = base();
    cp(&mut v, 2)["window"] = json!(1.0);
    let (_, _, location, shown) = json_error(&serde_json::to_string_pretty(&v).unwrap());
    assert_eq!(location, "arc 0, control point 2, field `window`");
    assert!(shown.contains("unknown field `window`"), "{shown}");

    let mut v = base();
    lay(&mut v, 1, 0)["spots"]["weights"] = json!([1.0]);
    let (_, _, location, _) = json_error(&serde_json::to_string_pretty(&v).unwrap());
    assert_eq!(
        location,
        "arc 0, control point 1, layer 0, field `spots.weights`"
    );
}

#[test]
fn wrong_type_and_unknown_direction_are_located() {
    let mut v = base();
    lay(&mut v, 1, 0)["spots"]["mu"][2] = json!("3");
    let (_, _, location, _) = json_error(&serde_json::to_string_pretty(&v).unwrap());
    assert_eq!(
        location,
        "arc 0, control point 1, layer 0, field `spots.mu[2]`"
    );

    let mut v = base();
    v["arcs"][0]["direction"] = json!("CCW");
    let (_, _, location, shown) = json_error(&serde_json::to_string_pretty(&v).unwrap());
    assert_eq!(location, "arc 0, field `direction`");
    assert!(shown.contains("`CW` or `CC`"), "{shown}");
}

#[test]
fn wrong_or_missing_format_string() {
    let mut v = base();
    v["format"] = json!("arcsim-plan/2");
    single(
        &v,
        (None, None, None),
        "format",
        "expected \"arcsim-plan/1\"",
    );
    v.as_object_mut().unwrap().remove("format");
    single(&v, (None, None, None), "format", "no `format` field");
    // A file of another format fails on its own fields; the format is what to report.
    let other = json!({ "format": "arcsim-machine/1", "name": "m", "gantry": {} });
    single(
        &other,
        (None, None, None),
        "format",
        "not in the arcsim-plan/1 format",
    );
}

#[test]
fn overflowing_number_is_reported() {
    let text = serde_json::to_string_pretty(&base())
        .unwrap()
        .replace("150.0", "1e400");
    let (_, _, location, shown) = json_error(&text);
    assert_eq!(
        location,
        "arc 0, control point 0, layer 0, field `energy_mev`"
    );
    assert!(shown.contains("expected a finite number"), "{shown}");
}

#[test]
fn non_finite_values_are_caught_by_validation() {
    let mut plan = parse(&base()).unwrap();
    plan.arcs[0].control_points[0].layers[0].energy_mev = f64::NAN;
    plan.arcs[0].control_points[0].layers[0].irradiation_time_s = Some(f64::INFINITY);
    plan.arcs[0].control_points[1].layers[0]
        .spots
        .as_mut()
        .unwrap()
        .mu
        .as_mut()
        .unwrap()[1] = f64::NAN;
    plan.arcs[0].control_points[2].window_deg = Some(f64::INFINITY);
    plan.arcs[0].control_points[3].angle_deg = f64::NAN;
    let found = validate_plan(&plan, FILE);
    let text: Vec<String> = found.iter().map(|i| i.to_string()).collect();
    let has = |s: &str| text.iter().any(|t| t.contains(s));
    assert!(has("arc 0, control point 0, layer 0, field `energy_mev`: expected an energy in 1..=400 MeV, got NaN"), "{text:#?}");
    assert!(has("arc 0, control point 0, layer 0, field `irradiation_time_s`: expected an irradiation time in seconds > 0, got inf"), "{text:#?}");
    assert!(
        has("arc 0, control point 1, layer 0, field `spots.mu[1]`"),
        "{text:#?}"
    );
    assert!(
        has("arc 0, control point 2, field `window_deg`"),
        "{text:#?}"
    );
    assert!(
        has("arc 0, control point 3, field `angle_deg`: expected a finite angle"),
        "{text:#?}"
    );
    assert_eq!(found.len(), 5, "{text:#?}");
}

#[test]
fn negative_values() {
    let mut v = base();
    lay(&mut v, 0, 0)["irradiation_time_s"] = json!(-0.1);
    single(&v, at(0, 0, 0), "irradiation_time_s", "got -0.1 (negative)");

    let mut v = base();
    lay(&mut v, 3, 0)["switching_time_s"] = json!(-1.0);
    single(
        &v,
        at(0, 3, 0),
        "switching_time_s",
        "expected a switching time in seconds >= 0",
    );

    let mut v = base();
    lay(&mut v, 1, 0)["spots"]["mu"][0] = json!(-2.0);
    single(
        &v,
        at(0, 1, 0),
        "spots.mu[0]",
        "spot weight in MU >= 0, got -2",
    );

    let mut v = base();
    lay(&mut v, 3, 0)["spots"]["total_mu"] = json!(-10.0);
    single(&v, at(0, 3, 0), "spots.total_mu", "> 0");

    let mut v = base();
    cp(&mut v, 1)["window_deg"] = json!(-1.0);
    single(
        &v,
        at_cp(0, 1),
        "window_deg",
        "window width in degrees >= 0",
    );
    // 0 is a static control point (the gantry at rest for all its layers).
    let mut v = base();
    cp(&mut v, 1)["window_deg"] = json!(0.0);
    assert!(parse(&v).is_ok());

    let mut v = base();
    cp(&mut v, 2)["required_speed_deg_per_s"] = json!(-2.0);
    single(
        &v,
        at_cp(0, 2),
        "required_speed_deg_per_s",
        "speed magnitude in deg/s >= 0, got -2",
    );
}

#[test]
fn zero_speed_and_zero_switching_are_allowed() {
    let mut v = base();
    cp(&mut v, 2)["required_speed_deg_per_s"] = json!(0.0);
    lay(&mut v, 3, 0)["switching_time_s"] = json!(0.0);
    parse(&v).expect("zero is a valid speed and switching time");
}

#[test]
fn energy_outside_range() {
    for e in [0.5, 400.5, -100.0] {
        let mut v = base();
        lay(&mut v, 2, 1)["energy_mev"] = json!(e);
        single(
            &v,
            at(0, 2, 1),
            "energy_mev",
            "expected an energy in 1..=400 MeV",
        );
    }
    for e in [1.0, 400.0] {
        let mut v = base();
        lay(&mut v, 2, 1)["energy_mev"] = json!(e);
        parse(&v).expect("range ends are valid");
    }
}

#[test]
fn angles_must_progress_in_the_arc_direction() {
    let mut v = base();
    cp(&mut v, 2)["angle_deg"] = json!(11.0);
    let text = issues(&v)
        .iter()
        .map(|i| i.to_string())
        .collect::<Vec<_>>()
        .join("\n");
    assert!(
        text.contains("arc 0, control point 2, field `angle_deg`: angle 11 deg goes against the arc's CW direction after control point 1 at 12 deg; expected greater than 12"),
        "{text}"
    );

    // The same angles in a CC arc all go the wrong way.
    let mut v = base();
    v["arcs"][0]["direction"] = json!("CC");
    let found = issues(&v);
    assert_eq!(found.len(), 3, "{found:#?}");
    assert!(found
        .iter()
        .all(|i| i.field == "angle_deg" && i.message.contains("expected less than")));

    // Reversed angles make a valid CC arc, and an arc may pass 360.
    let mut v = base();
    v["arcs"][0]["direction"] = json!("CC");
    for (c, a) in [370.0, 368.0, 366.0, 364.0].into_iter().enumerate() {
        cp(&mut v, c)["angle_deg"] = json!(a);
    }
    parse(&v).expect("CC arc with decreasing angles");
}

#[test]
fn duplicate_angles_have_their_own_message() {
    let mut v = base();
    cp(&mut v, 2)["angle_deg"] = json!(12.0);
    let text = single(
        &v,
        at_cp(0, 2),
        "angle_deg",
        "duplicate angle 12 deg: control point 1 has the same angle",
    );
    assert!(!text.contains("direction"), "{text}");
}

#[test]
fn empty_plan_arc_and_control_point() {
    let mut v = base();
    v["arcs"] = json!([]);
    single(&v, (None, None, None), "arcs", "no arcs");

    let mut v = base();
    v["arcs"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "direction": "CC", "control_points": [] }));
    single(
        &v,
        (Some(1), None, None),
        "control_points",
        "no control points",
    );

    let mut v = base();
    cp(&mut v, 1)["layers"] = json!([]);
    single(&v, at_cp(0, 1), "layers", "no layers");
}

#[test]
fn window_wider_than_spacing() {
    let mut v = base();
    cp(&mut v, 1)["window_deg"] = json!(2.5);
    single(
        &v,
        at_cp(0, 1),
        "window_deg",
        "window 2.5 deg is wider than the 2 deg spacing",
    );

    // The tighter neighbour counts: 12 -> 13 is 1 deg.
    let mut v = base();
    cp(&mut v, 2)["angle_deg"] = json!(13.0);
    cp(&mut v, 3)["angle_deg"] = json!(17.0);
    cp(&mut v, 1)["window_deg"] = json!(1.5);
    single(
        &v,
        at_cp(0, 1),
        "window_deg",
        "than the 1 deg spacing to control point 2; expected at most 1 deg",
    );

    // Equal to the spacing is fine.
    let mut v = base();
    cp(&mut v, 1)["window_deg"] = json!(2.0);
    parse(&v).expect("window equal to the spacing");
}

#[test]
fn spots_need_exactly_one_of_mu_and_total_mu() {
    let mut v = base();
    lay(&mut v, 1, 0)["spots"]["total_mu"] = json!(6.0);
    single(&v, at(0, 1, 0), "spots", "both `mu` and `total_mu`");

    let mut v = base();
    lay(&mut v, 1, 0)["spots"]
        .as_object_mut()
        .unwrap()
        .remove("mu");
    single(&v, at(0, 1, 0), "spots", "neither `mu` nor `total_mu`");
}

#[test]
fn mu_count_must_match_spot_count() {
    let mut v = base();
    lay(&mut v, 1, 0)["spots"]["count"] = json!(4);
    single(
        &v,
        at(0, 1, 0),
        "spots.mu",
        "3 MU values for a count of 4 spots",
    );

    let mut v = base();
    lay(&mut v, 3, 0)["spots"]["count"] = json!(0);
    single(&v, at(0, 3, 0), "spots.count", "at least 1 spot");

    let mut v = base();
    lay(&mut v, 1, 0)["spots"]["mu"] = json!([0.0, 0.0, 0.0]);
    single(&v, at(0, 1, 0), "spots.mu", "every spot has 0 MU");
}

#[test]
fn layer_needs_exactly_one_of_spots_and_time() {
    let mut v = base();
    lay(&mut v, 0, 0)["spots"] = json!({ "count": 1, "total_mu": 1.0 });
    single(
        &v,
        at(0, 0, 0),
        "spots",
        "both `spots` and `irradiation_time_s`",
    );

    let mut v = base();
    lay(&mut v, 0, 0)
        .as_object_mut()
        .unwrap()
        .remove("irradiation_time_s");
    single(
        &v,
        at(0, 0, 0),
        "spots",
        "neither `spots` nor `irradiation_time_s`",
    );
}

#[test]
fn first_layer_of_plan_takes_no_switching_time() {
    let mut v = base();
    lay(&mut v, 0, 0)["switching_time_s"] = json!(1.0);
    single(
        &v,
        at(0, 0, 0),
        "switching_time_s",
        "first layer of the plan has no switch",
    );
}

#[test]
fn all_problems_are_reported_at_once() {
    let mut v = base();
    v["format"] = json!("arcsim-plan/0");
    lay(&mut v, 0, 0)["energy_mev"] = json!(500.0);
    cp(&mut v, 2)["angle_deg"] = json!(12.0);
    lay(&mut v, 2, 1)["irradiation_time_s"] = json!(-1.0);
    lay(&mut v, 3, 0)["spots"] = json!({ "count": 4, "mu": [1.0] });
    v["arcs"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "direction": "CC", "control_points": [
        { "angle_deg": 5.0, "layers": [] }
    ] }));
    let err = parse(&v).unwrap_err();
    let found = err.issues();
    let places: Vec<(&str, Place)> = found
        .iter()
        .map(|i| (i.field.as_str(), (i.arc, i.control_point, i.layer)))
        .collect();
    assert_eq!(
        places,
        vec![
            ("format", (None, None, None)),
            ("energy_mev", at(0, 0, 0)),
            ("angle_deg", at_cp(0, 2)),
            ("irradiation_time_s", at(0, 2, 1)),
            ("spots.mu", at(0, 3, 0)),
            ("layers", at_cp(1, 0)),
        ]
    );
    let shown = err.to_string();
    assert!(shown.starts_with("case.json: 6 problems:\n"), "{shown}");
    assert_eq!(shown.lines().count(), 7, "{shown}");
}
