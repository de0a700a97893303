//! Unit tests of the scan, and random arcs and limits shared with other modules' tests.

use super::*;
use arcsim_plan::ResolvedArc;
use arcsim_plan::{ResolvedLayer, RotationDirection};
use arcsim_test_support::Rng;

/// Random limits of the unit tests: J 0.1–4, A and D 0.1–2, V 1–8.
pub(crate) fn random_limits(rng: &mut Rng) -> Limits {
    Limits::with_decel(
        rng.range(0.1, 4.0),
        rng.range(0.1, 2.0),
        rng.range(0.1, 2.0),
        rng.range(1.0, 8.0),
    )
    .expect("limits")
}

/// A random arc of `n` layers: spacing, irradiation time and window drawn uniformly from
/// the given ranges (deg, s, deg), the ELST of each switch one of `elsts_s`.
pub(crate) fn random_arc_of(
    rng: &mut Rng,
    n: usize,
    spacing_deg: (f64, f64),
    irradiation_s: (f64, f64),
    window_deg: (f64, f64),
    elsts_s: &[f64],
) -> ResolvedArc {
    let mut angle = 0.0;
    let layers = (0..n)
        .map(|k| {
            if k > 0 {
                angle += rng.range(spacing_deg.0, spacing_deg.1);
            }
            let t = rng.range(irradiation_s.0, irradiation_s.1);
            ResolvedLayer {
                control_point: k,
                layer: 0,
                angle_deg: angle,
                window_deg: rng.range(window_deg.0, window_deg.1),
                energy_mev: 100.0,
                irradiation_s: t,
                spot_irradiation_s: t,
                scanning_s: 0.0,
                required_speed_deg_per_s: None,
                switch_in_s: elsts_s[rng.below(elsts_s.len())],
            }
        })
        .collect();
    ResolvedArc {
        arc_index: 0,
        direction: RotationDirection::Cw,
        layers,
    }
}

/// A random arc of closely spaced layers with short irradiation times and ELSTs of
/// 0–2 s: the setting where transitions barely exceed their ELSTs.
fn random_arc(rng: &mut Rng) -> ResolvedArc {
    let n = 4 + rng.below(12);
    random_arc_of(
        rng,
        n,
        (0.2, 3.0),
        (0.05, 1.0),
        (0.2, 3.0),
        &[0.0, 0.3, 0.5, 1.0, 2.0],
    )
}

/// The polish keeps only moves that shorten the arc: on random arcs and limits its schedule
/// is never longer than the scan it starts from, every transition has a move, and every
/// speed stays within its cap; it shortens some.
#[test]
fn polish_never_lengthens_the_scan_and_keeps_it_feasible() {
    let mut rng = Rng::new(0x9011_5800);
    let (mut shorter, mut cases) = (0, 0);
    for _ in 0..300 {
        let lim = random_limits(&mut rng);
        let p = ArcProblem::new(&random_arc(&mut rng), &lim);
        let settled = scan(&p, &lim, &p.speed_cap, &p.cap_bound, true, None);
        let (start, _) = stop_avoiding_scan(&p, &lim, settled.clone());
        let before = moving_time(&p, &lim, &start);
        assert!(before.is_finite(), "the scan is feasible");
        let (v, bounds) = polished_scan(&p, &lim, settled);
        let after = moving_time(&p, &lim, &v);
        cases += 1;
        assert!(
            after <= before,
            "polish lengthened {p:?} on {lim:?}: {before} -> {after} s"
        );
        for k in 0..p.len() {
            assert!(
                (0.0..=p.speed_cap[k]).contains(&v[k]),
                "speed {} of layer {k} outside [0, {}]",
                v[k],
                p.speed_cap[k]
            );
            if v[k] != start[k] {
                assert_eq!(bounds[k], SpeedBound::Optimised);
            }
            if k + 1 < p.len() {
                assert!(
                    p.cost(k, v[k], v[k + 1], &lim).is_some(),
                    "transition {k} infeasible"
                );
            }
        }
        if after < before * (1.0 - 1e-9) {
            shorter += 1;
        }
    }
    assert!(
        shorter >= cases / 4,
        "polish shortened only {shorter} of {cases} random arcs"
    );
    println!("polish shortened {shorter} of {cases} random arcs");
}
