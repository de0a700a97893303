//! What the sequencer's test files share: the bundled machines, and the limits checked at one
//! instant of a timeline, independently of the sequencer's own verification.
#![allow(dead_code)] // each test file uses its own part

use arcsim_plan::{parse_machine, GantryLimitsSpec, Machine};
use arcsim_sequencer::Timeline;

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
