//! Per-layer shares of a control point's window (`window_share`): the format, its validation, the
//! resolved sub-windows against hand-computed figures (those of `docs/plan-format.md`), and the
//! default (no shares) resolving bit for bit as the equal split always did.

use arcsim_plan::{
    generate, layer_windows, parse_machine, parse_plan, resolve, validate_plan, ArcPlan, Machine,
    PlanError, PlanIssue, PlanKind, RotationDirection,
};
use serde_json::{json, Value};

fn machine() -> Machine {
    let m = crate::machine_resolve::machine_json();
    parse_machine(&m.to_string(), "m.json").expect("test machine")
}

fn layer(e: f64, share: Option<f64>) -> Value {
    let mut l = json!({ "energy_mev": e, "irradiation_time_s": 0.2 });
    if let Some(s) = share {
        l["window_share"] = json!(s);
    }
    l
}

/// One arc in `direction` with control points at 8, 10 and 12 deg; the one at 10 deg has a 1 deg
/// window and `middle` as its layers.
fn plan(direction: &str, middle: Vec<Value>) -> Value {
    let mut cps = vec![
        json!({ "angle_deg": 8.0, "layers": [layer(160.0, None)] }),
        json!({ "angle_deg": 10.0, "window_deg": 1.0, "layers": middle }),
        json!({ "angle_deg": 12.0, "layers": [layer(120.0, None)] }),
    ];
    if direction == "CC" {
        cps.reverse();
    }
    json!({
        "format": "arcsim-plan/1",
        "name": "shares",
        "arcs": [{ "direction": direction, "control_points": cps }]
    })
}

fn parse(v: &Value) -> Result<ArcPlan, PlanError> {
    parse_plan(&v.to_string(), "shares.json")
}

/// (centre, width) of each layer of the control point at 10 deg, in delivery order.
fn middle_windows(v: &Value) -> Vec<(f64, f64)> {
    let arcs = resolve(&parse(v).expect("valid plan"), &machine()).expect("resolved");
    // The middle control point is the second in either direction.
    arcs[0]
        .layers
        .iter()
        .filter(|l| l.control_point == 1)
        .map(|l| (l.angle_deg, l.window_deg))
        .collect()
}

fn issues(v: &Value) -> Vec<PlanIssue> {
    match parse(v) {
        Err(PlanError::Invalid { issues, .. }) => issues,
        other => panic!("expected validation issues, got {other:?}"),
    }
}

fn shares(s: [f64; 3]) -> Vec<Value> {
    vec![
        layer(150.0, Some(s[0])),
        layer(140.0, Some(s[1])),
        layer(130.0, Some(s[2])),
    ]
}

#[test]
fn window_share_round_trips_and_is_omitted_when_absent() {
    let v = plan("CW", shares([1.0, 2.5, 1.0]));
    let p = parse(&v).expect("valid plan");
    assert_eq!(
        p.arcs[0].control_points[1].layers[1].window_share,
        Some(2.5)
    );
    assert_eq!(p.arcs[0].control_points[0].layers[0].window_share, None);
    let text = serde_json::to_string(&p).expect("serialised");
    assert_eq!(parse_plan(&text, "again.json").expect("parsed again"), p);
    let without = serde_json::to_string(&parse(&plan("CW", vec![layer(150.0, None)])).unwrap())
        .expect("serialised");
    assert!(!without.contains("window_share"), "{without}");
}

#[test]
fn shares_given_by_some_layers_only_are_refused_at_the_layer_without() {
    let v = plan(
        "CW",
        vec![
            layer(150.0, Some(1.0)),
            layer(140.0, None),
            layer(130.0, Some(2.0)),
        ],
    );
    let found = issues(&v);
    assert_eq!(found.len(), 1, "{found:#?}");
    let i = &found[0];
    assert_eq!(
        (i.arc, i.control_point, i.layer),
        (Some(0), Some(1), Some(1)),
        "{i}"
    );
    assert_eq!(i.field, "window_share");
    assert!(
        i.message
            .contains("layer 0 of this control point gives a window_share"),
        "{i}"
    );
    assert!(
        i.message.contains("on every layer of the control point"),
        "{i}"
    );
    assert!(i.to_string().contains("shares.json"), "{i}");
}

#[test]
fn a_share_must_be_positive_and_not_huge() {
    for (bad, needle) in [
        (0.0, "expected a share of the window (a weight) > 0, got 0"),
        (-1.0, "(negative)"),
        (2e6, "above the largest accepted share"),
    ] {
        let found = issues(&plan("CW", shares([1.0, bad, 1.0])));
        assert_eq!(found.len(), 1, "{bad}: {found:#?}");
        let i = &found[0];
        assert_eq!(
            (i.arc, i.control_point, i.layer),
            (Some(0), Some(1), Some(1)),
            "{i}"
        );
        assert_eq!(i.field, "window_share", "{i}");
        assert!(i.message.contains(needle), "{bad}: {i}");
    }
    // JSON has no NaN or infinity; a plan built in code can.
    for bad in [f64::NAN, f64::INFINITY] {
        let mut p = parse(&plan("CW", shares([1.0, 1.0, 1.0]))).expect("valid plan");
        p.arcs[0].control_points[1].layers[2].window_share = Some(bad);
        let found = validate_plan(&p, "code");
        assert_eq!(found.len(), 1, "{bad}: {found:#?}");
        assert_eq!(found[0].layer, Some(2));
        assert_eq!(found[0].field, "window_share");
    }
}

#[test]
fn shares_split_the_window_in_proportion_in_delivery_order() {
    // docs/plan-format.md: 1 deg window at 10 deg, shares 1, 2, 1 (exact in binary).
    let cw = middle_windows(&plan("CW", shares([1.0, 2.0, 1.0])));
    assert_eq!(cw, vec![(9.625, 0.25), (10.0, 0.5), (10.375, 0.25)]);
    // CC: delivery runs towards lower angles, so the first layer sits at the high edge.
    let cc = middle_windows(&plan("CC", shares([1.0, 2.0, 1.0])));
    assert_eq!(cc, vec![(10.375, 0.25), (10.0, 0.5), (9.625, 0.25)]);
    // Shares 3, 1 (and 6, 2: only the proportion counts): 0.75 and 0.25 wide.
    for s in [[3.0, 1.0], [6.0, 2.0]] {
        let two = vec![layer(150.0, Some(s[0])), layer(140.0, Some(s[1]))];
        assert_eq!(
            middle_windows(&plan("CW", two)),
            vec![(9.875, 0.75), (10.375, 0.25)]
        );
    }
}

#[test]
fn a_share_moves_with_its_layer() {
    // The wide layer first, then last: it keeps its 0.75 deg wherever it goes.
    let first = vec![layer(150.0, Some(3.0)), layer(140.0, Some(1.0))];
    let last = vec![layer(140.0, Some(1.0)), layer(150.0, Some(3.0))];
    assert_eq!(
        middle_windows(&plan("CW", first)),
        vec![(9.875, 0.75), (10.375, 0.25)]
    );
    assert_eq!(
        middle_windows(&plan("CW", last)),
        vec![(9.625, 0.25), (10.125, 0.75)]
    );
}

#[test]
fn equal_split_matches_the_documented_figures_both_ways() {
    let three = || vec![layer(150.0, None), layer(140.0, None), layer(130.0, None)];
    let near = |got: &[(f64, f64)], want: [f64; 3]| {
        for ((c, w), x) in got.iter().zip(want) {
            assert!((c - x).abs() < 5e-4, "centre {c}, documented {x}");
            assert!((w - 0.333).abs() < 5e-4, "width {w}, documented 0.333");
        }
        assert_eq!(got.len(), 3);
    };
    near(&middle_windows(&plan("CW", three())), [9.667, 10.0, 10.333]);
    near(&middle_windows(&plan("CC", three())), [10.333, 10.0, 9.667]);
    // Equal shares give the equal split (to rounding).
    let equal = middle_windows(&plan("CW", shares([2.0, 2.0, 2.0])));
    for (a, b) in equal.iter().zip(middle_windows(&plan("CW", three()))) {
        assert!((a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-12);
    }
}

/// The documented example's JSON block, read from the docs, resolves to the documented figures.
#[test]
fn the_documented_example_resolves_as_documented() {
    let path = format!("{}/../../docs/plan-format.md", env!("CARGO_MANIFEST_DIR"));
    let doc = std::fs::read_to_string(path).expect("docs/plan-format.md");
    let block = doc
        .split("```json")
        .skip(1)
        .filter_map(|b| b.split("```").next())
        .find(|b| b.contains("\"window_share\""))
        .expect("a JSON example with window_share");
    let cp: Value = serde_json::from_str(block).expect("the example is JSON");
    let mut v = plan("CW", vec![]);
    v["arcs"][0]["control_points"][1] = cp.clone();
    assert_eq!(
        middle_windows(&v),
        vec![(9.625, 0.25), (10.0, 0.5), (10.375, 0.25)]
    );
    let mut v = plan("CC", vec![]);
    v["arcs"][0]["control_points"][1] = cp;
    assert_eq!(
        middle_windows(&v),
        vec![(10.375, 0.25), (10.0, 0.5), (9.625, 0.25)]
    );
    for figure in [
        "9.625°, 10° and 10.375°",
        "0.25°, 0.5° and 0.25°",
        "10.375°, 10° and 9.625°",
    ] {
        assert!(
            doc.contains(figure),
            "docs/plan-format.md should state {figure}"
        );
    }
}

/// Without shares, every layer resolves bit for bit as the equal split's arithmetic always gave:
/// offset `-w/2 + (w/k)·(l + 1/2)` along the direction, width `w/k` (a multi-layer plan, CW and
/// turned CC).
#[test]
fn no_shares_resolves_exactly_as_the_equal_split() {
    let m = machine();
    let cw = generate(PlanKind::HeadNeck, 3);
    let mut cc = cw.clone();
    for arc in &mut cc.arcs {
        arc.control_points.reverse();
        arc.direction = RotationDirection::Cc;
    }
    for p in [cw, cc] {
        let arcs = resolve(&p, &m).expect("resolved");
        let mut multi = 0;
        for (arc, resolved) in p.arcs.iter().zip(&arcs) {
            let sign = arc.direction.sign();
            for r in &resolved.layers {
                let cp = &arc.control_points[r.control_point];
                let w = cp.window_deg.unwrap_or(m.default_window_deg);
                let sub = w / cp.layers.len() as f64;
                let offset = -w / 2.0 + sub * (r.layer as f64 + 0.5);
                assert_eq!(
                    r.angle_deg.to_bits(),
                    (cp.angle_deg + sign * offset).to_bits()
                );
                assert_eq!(r.window_deg.to_bits(), sub.to_bits());
                let lw = layer_windows(cp, w)[r.layer];
                assert_eq!(lw.width_deg.to_bits(), sub.to_bits());
                multi += usize::from(cp.layers.len() > 1);
            }
        }
        assert!(
            multi > 100,
            "the plan should have many multi-layer control points"
        );
    }
}
