//! Layers with their own share of the window (`window_share`): a share belongs to its layer, so a
//! reordered control point passes the dose check and a changed or swapped share fails it; what
//! `resequence` returns keeps every layer's share, and the estimate with equal shares is the
//! estimate without.

use arcsim_plan::{resolve, ArcPlan, EnergyLayer};
use arcsim_resequence::{check_same_dose, resequence, DoseChange, GantryCost, ResequenceOptions};
use arcsim_sequencer::machine_limits;
use arcsim_test_support::Rng;

use crate::util::{machine, small_plan};

/// `plan` with every layer given a share: 1, 2, 3, ... in each control point's order.
fn with_shares(mut plan: ArcPlan, share: impl Fn(usize) -> f64) -> ArcPlan {
    for cp in plan.arcs.iter_mut().flat_map(|a| &mut a.control_points) {
        for (l, layer) in cp.layers.iter_mut().enumerate() {
            layer.window_share = Some(share(l));
        }
    }
    plan
}

/// A layer's identity: its energy and MU, as text.
fn id(l: &EnergyLayer) -> String {
    format!(
        "{} {:?}",
        l.energy_mev,
        l.spots.as_ref().and_then(|s| s.total_mu)
    )
}

#[test]
fn a_share_travels_with_its_layer_through_the_dose_check() {
    let mut rng = Rng::new(48);
    let plan = with_shares(small_plan(&mut rng, 1, 4, &|_| 3), |l| 1.0 + l as f64);
    let mut reordered = plan.clone();
    for cp in &mut reordered.arcs[0].control_points {
        cp.layers.rotate_left(1);
    }
    assert_eq!(check_same_dose(&plan, &reordered), Ok(()));

    // A share changed: the layer is not the original's.
    let mut changed = plan.clone();
    changed.arcs[0].control_points[2].layers[1].window_share = Some(2.5);
    match check_same_dose(&plan, &changed) {
        Err(DoseChange::Arc { arc: 0, why }) => assert!(why.contains("control point 2 "), "{why}"),
        other => panic!("a changed share passed: {other:?}"),
    }
    // Two layers' shares swapped, the layers left in place: each layer's window changes.
    let mut swapped = plan.clone();
    let layers = &mut swapped.arcs[0].control_points[1].layers;
    let (a, b) = (layers[0].window_share, layers[2].window_share);
    (layers[0].window_share, layers[2].window_share) = (b, a);
    assert!(check_same_dose(&plan, &swapped).is_err());
    // Shares dropped (equal sub-windows): not the original's either.
    let mut dropped = plan.clone();
    for l in &mut dropped.arcs[0].control_points[3].layers {
        l.window_share = None;
    }
    assert!(check_same_dose(&plan, &dropped).is_err());
}

#[test]
fn resequencing_keeps_every_layers_share_and_width() {
    let m = machine("machine-atom.json");
    let mut rng = Rng::new(7);
    let plan = with_shares(small_plan(&mut rng, 1, 5, &|r| 2 + r.below(2)), |l| {
        [1.0, 3.0, 2.0][l]
    });
    let out = resequence(&plan, &m, &ResequenceOptions::default()).expect("resequenced");
    assert_eq!(check_same_dose(&plan, &out.plan), Ok(()));
    assert!(out.moved_layers > 0, "the case should move layers");
    let before = resolve(&plan, &m).expect("resolved");
    let after = resolve(&out.plan, &m).expect("resolved");
    for (c, (cp0, cp1)) in plan.arcs[0]
        .control_points
        .iter()
        .zip(&out.plan.arcs[0].control_points)
        .enumerate()
    {
        for (l1, layer) in cp1.layers.iter().enumerate() {
            let l0 = cp0
                .layers
                .iter()
                .position(|o| id(o) == id(layer))
                .expect("the same layer");
            assert_eq!(layer.window_share, cp0.layers[l0].window_share);
            let width = |arcs: &[arcsim_plan::ResolvedArc], l: usize| {
                arcs[0]
                    .layers
                    .iter()
                    .find(|r| r.control_point == c && r.layer == l)
                    .map(|r| r.window_deg)
                    .expect("resolved layer")
            };
            assert!((width(&before, l0) - width(&after, l1)).abs() < 1e-12);
        }
    }
}

#[test]
fn the_estimate_with_equal_shares_is_the_estimate_without() {
    let m = machine("machine-atom.json");
    let limits = machine_limits(&m).expect("limits");
    let mut rng = Rng::new(11);
    let plan = small_plan(&mut rng, 1, 4, &|_| 3);
    let equal = with_shares(plan.clone(), |_| 4.0);
    let fastest = |_: usize, _: usize| None;
    let a = GantryCost::new(&plan, &m, limits, &fastest).expect("estimate");
    let b = GantryCost::new(&equal, &m, limits, &fastest).expect("estimate");
    for g in 0..3 {
        for (la, pa, lb, pb) in [(0, 0, 1, 1), (2, 0, 0, 1), (1, 1, 2, 2), (0, 2, 1, 0)] {
            let (x, y) = (
                a.switch_s((g, la, pa), (g + 1, lb, pb)),
                b.switch_s((g, la, pa), (g + 1, lb, pb)),
            );
            assert!((x - y).abs() < 1e-9, "{g} {la} {pa} {lb} {pb}: {x} vs {y}");
            if pa + 1 < 3 {
                let (x, y) = (
                    a.switch_s((g, la, pa), (g, lb, pa + 1)),
                    b.switch_s((g, la, pa), (g, lb, pa + 1)),
                );
                assert!((x - y).abs() < 1e-9, "{x} vs {y}");
            }
        }
    }
}
