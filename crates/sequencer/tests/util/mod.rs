//! What the sequencer's test files share: the bundled machines, and the limits checked at one
//! instant of a timeline, independently of the sequencer's own verification.

use arcsim_plan::{
    parse_machine, GantryLimitsSpec, Machine, ResolvedArc, ResolvedLayer, RotationDirection,
};
use arcsim_sequencer::Timeline;
use arcsim_test_support::Rng;

/// A machine file of `scenarios/`.
pub fn machine(name: &str) -> Machine {
    let path = format!("{}/../../scenarios/{name}", env!("CARGO_MANIFEST_DIR"));
    parse_machine(
        &std::fs::read_to_string(&path).expect("machine file"),
        &path,
    )
    .expect("machine")
}

/// The direction of travel at `t`: the sign of its piece's displacement (no piece reverses, so a
/// A machine file of `scenarios/` with `edit` applied to its JSON.
pub fn edited_machine(name: &str, edit: impl Fn(&mut serde_json::Value)) -> Machine {
    let path = format!("{}/../../scenarios/{name}", env!("CARGO_MANIFEST_DIR"));
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).expect("machine file")).expect("json");
    edit(&mut v);
    parse_machine(&v.to_string(), &path).expect("edited machine")
}

/// piece that moves at all moves one way); 0 for a piece that does not move.
pub fn direction_at(tl: &Timeline, t: f64) -> f64 {
    tl.piece_at(t).map_or(0.0, |i| {
        let p = &tl.pieces[i];
        let moved = p.state_after(p.duration_s).angle_deg - p.angle_deg;
        if moved > 0.0 {
            1.0
        } else if moved < 0.0 {
            -1.0
        } else {
            0.0
        }
    })
}

/// Speed within V, jerk within J, and the acceleration within A along the direction of travel
/// and within D against it, at `t`; returns the direction ([`direction_at`]). Where the piece does
/// not move (a zero-length piece, or the turning point between two arcs of free motion, where the
/// gantry may reverse with the acceleration it has) only max(A, D) is held here.
pub fn check_limits_at(tl: &Timeline, g: &GantryLimitsSpec, t: f64, what: &str) -> f64 {
    let s = tl.state_at(t);
    let (a_along, a_against) = (
        g.max_accel_deg_per_s2,
        g.max_decel_deg_per_s2.unwrap_or(g.max_accel_deg_per_s2),
    );
    assert!(
        s.speed_deg_per_s.abs() <= g.max_speed_deg_per_s * (1.0 + 1e-9),
        "{what}: speed {} at {t}",
        s.speed_deg_per_s
    );
    let dir = direction_at(tl, t);
    let a = s.accel_deg_per_s2;
    let within = |x: f64, limit: f64| x <= limit * (1.0 + 1e-9) + 1e-12;
    let ok = if dir == 0.0 {
        within(a.abs(), a_along.max(a_against))
    } else {
        within(dir * a, a_along) && within(-dir * a, a_against)
    };
    assert!(
        ok,
        "{what}: acceleration {a} at {t} (travel {dir}; A {a_along}, D {a_against})"
    );
    assert!(
        s.jerk_deg_per_s3.abs() <= g.max_jerk_deg_per_s3 * (1.0 + 1e-9),
        "{what}: jerk at {t}"
    );
    dir
}

/// Ranges of a random arc's layers ([`random_arc`]).
pub struct ArcRanges {
    /// Angle between neighbouring layers (deg).
    pub spacing_deg: (f64, f64),
    pub irradiation_s: (f64, f64),
    pub window_deg: (f64, f64),
    /// ELSTs to draw from (s).
    pub elst_s: &'static [f64],
}

/// A clockwise arc of `n` layers, one per control point, drawn from `r` (per layer: the spacing,
/// the irradiation time, the window, the ELST, in that order).
pub fn random_arc(rng: &mut Rng, n: usize, r: &ArcRanges) -> ResolvedArc {
    let mut angle = 0.0;
    let layers = (0..n)
        .map(|k| {
            if k > 0 {
                angle += rng.range(r.spacing_deg.0, r.spacing_deg.1);
            }
            let t = rng.range(r.irradiation_s.0, r.irradiation_s.1);
            let window_deg = rng.range(r.window_deg.0, r.window_deg.1);
            ResolvedLayer {
                control_point: k,
                layer: 0,
                angle_deg: angle,
                window_deg,
                energy_mev: 100.0,
                irradiation_s: t,
                spot_irradiation_s: t,
                scanning_s: 0.0,
                burst_switching_s: 0.0,
                spill_waiting_s: 0.0,
                required_speed_deg_per_s: None,
                switch_in_s: if k == 0 {
                    0.0
                } else {
                    r.elst_s[rng.below(r.elst_s.len())]
                },
                mu: 0.0,
            }
        })
        .collect();
    ResolvedArc {
        arc_index: 0,
        direction: RotationDirection::Cw,
        layers,
    }
}
