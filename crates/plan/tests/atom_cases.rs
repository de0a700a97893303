//! The ATOM article cases (the repository's `reference/atom-article-cases.json`), converted to
//! plans.

use arcsim_plan::{atom_case_plan, load_machine, resolve, PlanError};
use serde_json::Value;

fn reference() -> String {
    arcsim_test_support::atom_reference("the conversion of the ATOM article cases")
}

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

#[test]
fn atom_cases_become_plans_with_their_timings() {
    let text = reference();
    let data: Value = serde_json::from_str(&text).unwrap();
    let atom = load_machine(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/machine-atom.json"
    ))
    .unwrap();
    let cases = data["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 3);
    for case in cases {
        let name = case["name"].as_str().unwrap();
        let irradiation = numbers(&case["irradiation_times_s"]);
        let switching = numbers(&case["energy_switch_times_s"]);
        let plan = atom_case_plan(&text, name).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(plan.arcs.len(), 1);
        let cps = &plan.arcs[0].control_points;
        assert_eq!(cps.len(), 180);
        assert_eq!((cps[0].angle_deg, cps[179].angle_deg), (0.5, 358.5));
        assert!(cps
            .iter()
            .all(|c| c.window_deg == Some(1.0) && c.layers.len() == 1));

        let layers = &resolve(&plan, &atom).unwrap()[0].layers;
        assert_eq!(
            layers.iter().map(|l| l.irradiation_s).collect::<Vec<_>>(),
            irradiation
        );
        assert_eq!(layers[0].switch_in_s, 0.0);
        assert_eq!(
            layers[1..]
                .iter()
                .map(|l| l.switch_in_s)
                .collect::<Vec<_>>(),
            switching
        );

        // The placeholder energies follow the switches: without the explicit times the ATOM
        // machine's ELST gives the same switching times.
        let mut bare = plan.clone();
        for l in bare.arcs[0]
            .control_points
            .iter_mut()
            .flat_map(|c| &mut c.layers)
        {
            l.switching_time_s = None;
        }
        let from_elst: Vec<f64> = resolve(&bare, &atom).unwrap()[0].layers[1..]
            .iter()
            .map(|l| l.switch_in_s)
            .collect();
        assert_eq!(from_elst, switching, "{name}");
    }
}

#[test]
fn unknown_case_and_bad_text_are_errors() {
    let text = reference();
    let err = atom_case_plan(&text, "brain").unwrap_err().to_string();
    assert!(
        err.contains("no case named \"brain\"") && err.contains("prostate"),
        "{err}"
    );
    assert!(matches!(
        atom_case_plan("{", "prostate"),
        Err(PlanError::Json { .. })
    ));
}
