//! The dose check: a re-sequenced plan passes, and every change that moves dose fails, naming
//! the arc and control point.

use arcsim_resequence::{
    arrange, check_same_dose, resequence, ArcFreedom, DoseChange, ResequenceOptions,
};

use crate::util::{bundled, machine};

#[test]
fn reordered_and_turned_plans_pass_and_moved_dose_fails() {
    let plan = bundled("two-arc.json");
    let m = machine("machine-atom.json");
    // Layers reordered inside control points, arcs turned and swapped: the same dose.
    let mut shuffled = arrange(&plan, &[1, 0], &[true, false]);
    for arc in &mut shuffled.arcs {
        for cp in &mut arc.control_points {
            cp.layers.reverse();
        }
    }
    assert_eq!(check_same_dose(&plan, &shuffled), Ok(()));

    let mut lung = bundled("lung.json");
    let ok = lung.clone();
    // One spot moved by 1 mm.
    let cp = lung.arcs[0]
        .control_points
        .iter()
        .position(|cp| cp.layers.len() == 2)
        .expect("a control point with two layers");
    let spots = lung.arcs[0].control_points[cp].layers[1]
        .spots
        .as_mut()
        .expect("spots");
    spots.positions_mm.as_mut().expect("positions")[0][0] += 1.0;
    match check_same_dose(&ok, &lung) {
        Err(DoseChange::Arc { arc: 0, why }) => {
            assert!(why.contains(&format!("control point {cp} ")), "{why}")
        }
        other => panic!("a moved spot passed: {other:?}"),
    }
    // A layer moved to the next control point.
    let mut moved = ok.clone();
    let layer = moved.arcs[0].control_points[cp]
        .layers
        .pop()
        .expect("layer");
    moved.arcs[0].control_points[cp + 1].layers.push(layer);
    assert!(check_same_dose(&ok, &moved).is_err());
    // MU changed.
    let mut mu = ok.clone();
    let s = mu.arcs[0].control_points[0].layers[0]
        .spots
        .as_mut()
        .expect("spots");
    s.total_mu = s.total_mu.map(|t| t * 1.0001);
    assert!(check_same_dose(&ok, &mu).is_err());
    // An arc reversed in order but not in direction (control points flown backwards).
    let mut backwards = ok.clone();
    backwards.arcs[0].control_points.reverse();
    assert!(check_same_dose(&ok, &backwards).is_err());
    // An arc dropped.
    let mut fewer = plan.clone();
    fewer.arcs.pop();
    assert!(matches!(
        check_same_dose(&plan, &fewer),
        Err(DoseChange::ArcCount { .. })
    ));

    // What resequence returns passes, with arcs free to turn.
    let out = resequence(
        &plan,
        &m,
        &ResequenceOptions {
            arcs: ArcFreedom::Turn,
            ..ResequenceOptions::default()
        },
    )
    .expect("resequenced");
    assert_eq!(check_same_dose(&plan, &out.plan), Ok(()));
    assert!(
        (8..=16).contains(&out.candidates.len()),
        "2 orders × 4 turns, 1 or 2 layer orders each"
    );
}
