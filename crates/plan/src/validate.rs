//! Plan validation: every rule of the format checked on a parsed plan, with ALL problems collected so
//! a user fixes a file in one pass instead of one error per run.

use crate::error::{fmt_num, At, PlanIssue};
use crate::model::{ArcPlan, ControlPoint, EnergyLayer, Spots, PLAN_FORMAT};

/// Lowest and highest nominal beam energy accepted, MeV.
pub const ENERGY_RANGE_MEV: (f64, f64) = (1.0, 400.0);

/// Largest accepted magnitude of a control-point angle, degrees: far beyond any gantry's travel
/// (a few turns at most), small enough that angle differences keep their precision.
pub const MAX_ANGLE_DEG: f64 = 1e4;
/// Largest accepted time of a layer (irradiation, switching), seconds: over a day.
pub const MAX_LAYER_TIME_S: f64 = 1e5;
/// Largest accepted speed, deg/s (as for the gantry's V).
pub const MAX_SPEED_DEG_PER_S: f64 = crate::machine::SPEED_RANGE_DEG_PER_S.1;
/// Largest accepted MU of one spot and of one layer's `total_mu`.
pub const MAX_SPOT_MU: f64 = 1e6;
/// Largest accepted spot count of one layer: real layers have hundreds to a few thousand.
pub const MAX_SPOTS_PER_LAYER: u32 = 1_000_000;

/// Most paintings of one layer (DICOM NumberOfPaintings).
pub const MAX_PAINTINGS: u32 = 1000;
/// Largest accepted spot coordinate, mm: far beyond any field size (about ±200 mm).
pub const MAX_SPOT_POSITION_MM: f64 = 1e4;
/// Largest accepted `window_share` of a layer: shares are relative weights, and a million to one
/// is far beyond any useful split (it keeps the sum of a control point's shares finite).
pub const MAX_WINDOW_SHARE: f64 = 1e6;
use crate::beam::MAX_SPOT_DELIVERIES;

/// Slack when comparing a window with the control-point spacing, so 1.0 vs 0.9999999999 is not an error.
const SPACING_TOLERANCE_DEG: f64 = 1e-9;

/// Checks every rule of the plan format and returns all problems found (empty when the plan is valid).
/// `source` names the file in the messages.
pub fn validate_plan(plan: &ArcPlan, source: &str) -> Vec<PlanIssue> {
    let mut v = Validator {
        source,
        issues: Vec::new(),
    };
    if plan.format != PLAN_FORMAT {
        v.push(
            At::top(),
            "format",
            format!("expected \"{PLAN_FORMAT}\", got \"{}\"", plan.format),
        );
    }
    if plan.arcs.is_empty() {
        v.push(
            At::top(),
            "arcs",
            "the plan has no arcs; expected at least one",
        );
    }
    let mut first_layer_seen = false;
    for (a, arc) in plan.arcs.iter().enumerate() {
        if arc.control_points.is_empty() {
            v.push(
                At::arc(a),
                "control_points",
                "the arc has no control points; expected at least one",
            );
        }
        let sign = arc.direction.sign();
        let dir = arc.direction.as_str();
        // Spacing to the previous control point, when both angles are usable and progress correctly.
        let spacing: Vec<Option<f64>> = (0..arc.control_points.len())
            .map(|c| {
                let prev = arc.control_points.get(c.checked_sub(1)?)?.angle_deg;
                let this = arc.control_points[c].angle_deg;
                let d = sign * (this - prev);
                (d.is_finite() && d > 0.0).then_some(d)
            })
            .collect();
        for (c, cp) in arc.control_points.iter().enumerate() {
            let at = At::cp(a, c);
            if !cp.angle_deg.is_finite() {
                v.push(
                    at,
                    "angle_deg",
                    format!(
                        "expected a finite angle in degrees, got {}",
                        fmt_num(cp.angle_deg)
                    ),
                );
            } else if cp.angle_deg.abs() > MAX_ANGLE_DEG {
                v.push(
                    at,
                    "angle_deg",
                    format!(
                        "{} deg is beyond ±{} deg; expected a gantry angle in degrees",
                        fmt_num(cp.angle_deg),
                        fmt_num(MAX_ANGLE_DEG)
                    ),
                );
            } else if c > 0 {
                let prev = arc.control_points[c - 1].angle_deg;
                if prev.is_finite() {
                    let d = sign * (cp.angle_deg - prev);
                    if d == 0.0 {
                        v.push(
                            at,
                            "angle_deg",
                            format!(
                                "duplicate angle {} deg: control point {} has the same angle; expected each angle once per arc",
                                fmt_num(cp.angle_deg),
                                c - 1
                            ),
                        );
                    } else if d < 0.0 {
                        let want = if sign > 0.0 { "greater" } else { "less" };
                        v.push(
                            at,
                            "angle_deg",
                            format!(
                                "angle {} deg goes against the arc's {dir} direction after control point {} at {} deg; expected {want} than {}",
                                fmt_num(cp.angle_deg),
                                c - 1,
                                fmt_num(prev),
                                fmt_num(prev)
                            ),
                        );
                    }
                }
            }
            v.control_point(a, c, cp, spacing[c], spacing.get(c + 1).copied().flatten());
            v.window_shares(a, c, cp);
            for (l, layer) in cp.layers.iter().enumerate() {
                v.layer(At::layer(a, c, l), layer, !first_layer_seen);
                first_layer_seen = true;
            }
        }
    }
    v.issues
}

struct Validator<'a> {
    source: &'a str,
    issues: Vec<PlanIssue>,
}

/// Why a number breaks a rule, or None when it is fine.
fn bad_number(x: f64, min: f64, min_inclusive: bool) -> Option<&'static str> {
    if x.is_nan() {
        Some("not a number")
    } else if x.is_infinite() {
        Some("infinite (too large for a double?)")
    } else if x < min || (!min_inclusive && x == min) {
        Some(if x < 0.0 { "negative" } else { "too small" })
    } else {
        None
    }
}

impl Validator<'_> {
    fn push(&mut self, at: At, field: &str, message: impl Into<String>) {
        self.issues
            .push(PlanIssue::new(self.source, at, field, message));
    }

    /// Checks `x >= 0` (or `> 0` when `positive`) and finite; `what` says what was expected.
    fn number(&mut self, at: At, field: &str, x: f64, positive: bool, what: &str) {
        if let Some(why) = bad_number(x, 0.0, !positive) {
            let bound = if positive { "> 0" } else { ">= 0" };
            self.push(
                at,
                field,
                format!("expected {what} {bound}, got {} ({why})", fmt_num(x)),
            );
        }
    }

    /// Adds an issue when `x` (already known finite and in range below) is above `max`.
    fn at_most(&mut self, at: At, field: &str, x: f64, max: f64, unit: &str, why: &str) {
        if x.is_finite() && x > max {
            self.push(
                at,
                field,
                format!(
                    "{} {unit} is above the largest accepted value, {} {unit} ({why})",
                    fmt_num(x),
                    fmt_num(max)
                ),
            );
        }
    }

    fn control_point(
        &mut self,
        a: usize,
        c: usize,
        cp: &ControlPoint,
        before: Option<f64>,
        after: Option<f64>,
    ) {
        let at = At::cp(a, c);
        if let Some(s) = cp.required_speed_deg_per_s {
            self.number(
                at,
                "required_speed_deg_per_s",
                s,
                false,
                "a speed magnitude in deg/s",
            );
            self.at_most(
                at,
                "required_speed_deg_per_s",
                s,
                MAX_SPEED_DEG_PER_S,
                "deg/s",
                "the fastest gantry speed arcsim models",
            );
        }
        if let Some(w) = cp.window_deg {
            // 0 is a static control point: the gantry stands at the angle for all its layers.
            if bad_number(w, 0.0, true).is_some() {
                self.number(at, "window_deg", w, false, "a window width in degrees");
            } else if w > 360.0 {
                self.at_most(at, "window_deg", w, 360.0, "deg", "a full turn");
            } else {
                let neighbours = [(before, c.wrapping_sub(1)), (after, c + 1)];
                let tightest = neighbours
                    .iter()
                    .filter_map(|(s, n)| s.map(|s| (s, *n)))
                    .min_by(|x, y| x.0.total_cmp(&y.0));
                if let Some((s, n)) = tightest {
                    if w > s + SPACING_TOLERANCE_DEG {
                        self.push(
                            at,
                            "window_deg",
                            format!(
                                "window {} deg is wider than the {} deg spacing to control point {n}; expected at most {} deg", fmt_num(w), fmt_num(s), fmt_num(s)
                            ),
                        );
                    }
                }
            }
        }
        if cp.layers.is_empty() {
            self.push(
                at,
                "layers",
                "the control point has no layers; expected at least one",
            );
        }
    }

    /// Every layer of `cp` gives a `window_share` or none does; each one given is a positive
    /// weight of at most [`MAX_WINDOW_SHARE`].
    fn window_shares(&mut self, a: usize, c: usize, cp: &ControlPoint) {
        let given: Vec<usize> = (0..cp.layers.len())
            .filter(|&l| cp.layers[l].window_share.is_some())
            .collect();
        if let (Some(&with), Some(without)) = (
            given.first(),
            (0..cp.layers.len()).find(|l| !given.contains(l)),
        ) {
            self.push(
                At::layer(a, c, without),
                "window_share",
                format!(
                    "layer {with} of this control point gives a window_share and this layer does not; expected a share on every layer of the control point (its window is split in proportion to them) or on none (equal sub-windows)"
                ),
            );
        }
        let shares = cp.layers.iter().enumerate();
        for (l, x) in shares.filter_map(|(l, layer)| Some((l, layer.window_share?))) {
            let at = At::layer(a, c, l);
            let what = "a share of the window (a weight)";
            self.number(at, "window_share", x, true, what);
            if x.is_finite() && x > MAX_WINDOW_SHARE {
                self.push(
                    at,
                    "window_share",
                    format!(
                        "{} is above the largest accepted share, {} (shares are relative weights: scale them down together)",
                        fmt_num(x),
                        fmt_num(MAX_WINDOW_SHARE)
                    ),
                );
            }
        }
    }

    fn layer(&mut self, at: At, layer: &EnergyLayer, first_of_plan: bool) {
        let (lo, hi) = ENERGY_RANGE_MEV;
        let e = layer.energy_mev;
        if !e.is_finite() || !(lo..=hi).contains(&e) {
            self.push(
                at,
                "energy_mev",
                format!(
                    "expected an energy in {lo}..={hi} MeV, got {}{}",
                    fmt_num(e),
                    if e > hi && (lo..=hi).contains(&(e / 1000.0)) {
                        " — given in keV? the field is in MeV"
                    } else {
                        ""
                    }
                ),
            );
        }
        match (&layer.spots, layer.irradiation_time_s) {
            (Some(_), Some(_)) => self.push(
                at,
                "spots",
                "both `spots` and `irradiation_time_s` are given; expected exactly one of them",
            ),
            (None, None) => self.push(
                at,
                "spots",
                "neither `spots` nor `irradiation_time_s` is given; expected exactly one of them",
            ),
            _ => {}
        }
        if let Some(t) = layer.irradiation_time_s {
            self.number(
                at,
                "irradiation_time_s",
                t,
                true,
                "an irradiation time in seconds",
            );
            self.at_most(
                at,
                "irradiation_time_s",
                t,
                MAX_LAYER_TIME_S,
                "s",
                "over a day",
            );
        }
        if let Some(spots) = &layer.spots {
            self.spots(at, spots);
        }
        if let Some(t) = layer.switching_time_s {
            self.number(
                at,
                "switching_time_s",
                t,
                false,
                "a switching time in seconds",
            );
            self.at_most(
                at,
                "switching_time_s",
                t,
                MAX_LAYER_TIME_S,
                "s",
                "over a day",
            );
            if first_of_plan {
                self.push(
                    at,
                    "switching_time_s",
                    "the first layer of the plan has no switch into it; expected no switching_time_s here",
                );
            }
        }
    }

    fn spots(&mut self, at: At, spots: &Spots) {
        if spots.count == 0 {
            self.push(at, "spots.count", "expected at least 1 spot, got 0");
        } else if spots.count > MAX_SPOTS_PER_LAYER {
            self.push(
                at,
                "spots.count",
                format!(
                    "{} spots in one layer is above the largest accepted count, {MAX_SPOTS_PER_LAYER}",
                    spots.count
                ),
            );
        }
        match (&spots.mu, spots.total_mu) {
            (Some(_), Some(_)) => self.push(
                at,
                "spots",
                "both `mu` and `total_mu` are given; expected exactly one of them",
            ),
            (None, None) => self.push(
                at,
                "spots",
                "neither `mu` nor `total_mu` is given; expected exactly one of them",
            ),
            _ => {}
        }
        self.spot_mu(at, spots);
        self.spot_paintings(at, spots);
        self.spot_positions(at, spots);
        if let Some(t) = spots.total_mu {
            self.number(at, "spots.total_mu", t, true, "a total weight in MU");
            self.at_most(
                at,
                "spots.total_mu",
                t,
                MAX_SPOT_MU * f64::from(MAX_SPOTS_PER_LAYER),
                "MU",
                "no layer delivers that much",
            );
        }
    }

    /// Checks the per-spot MU values: one per spot, each a finite weight within range, and a
    /// positive finite sum.
    fn spot_mu(&mut self, at: At, spots: &Spots) {
        if let Some(mu) = &spots.mu {
            if mu.len() != spots.count as usize {
                self.push(
                    at,
                    "spots.mu",
                    format!("{} MU values for a count of {} spots; expected exactly one MU value per spot", mu.len(), spots.count),
                );
            }
            let mut all_good = true;
            for (i, &m) in mu.iter().enumerate() {
                if bad_number(m, 0.0, true).is_some() {
                    all_good = false;
                    self.number(
                        at,
                        &format!("spots.mu[{i}]"),
                        m,
                        false,
                        "a spot weight in MU",
                    );
                } else if m > MAX_SPOT_MU {
                    all_good = false;
                    self.at_most(
                        at,
                        &format!("spots.mu[{i}]"),
                        m,
                        MAX_SPOT_MU,
                        "MU",
                        "no spot delivers that much",
                    );
                }
            }
            let sum: f64 = mu.iter().sum();
            if all_good && !mu.is_empty() && sum <= 0.0 {
                self.push(
                    at,
                    "spots.mu",
                    "every spot has 0 MU; expected a layer that delivers some dose",
                );
            } else if all_good && !sum.is_finite() {
                self.push(
                    at,
                    "spots.mu",
                    format!("the MU values sum to {sum}; expected a finite total"),
                );
            }
        }
    }

    /// Checks the painting count and the spot deliveries it makes.
    fn spot_paintings(&mut self, at: At, spots: &Spots) {
        if let Some(p) = spots.paintings {
            if !(1..=MAX_PAINTINGS).contains(&p) {
                self.push(
                    at,
                    "spots.paintings",
                    format!("{p} paintings; expected 1 to {MAX_PAINTINGS}"),
                );
            } else if u64::from(p) * u64::from(spots.count) > MAX_SPOT_DELIVERIES as u64 {
                self.push(
                    at,
                    "spots.paintings",
                    format!(
                        "{p} paintings of {} spots are {} spot deliveries; expected at most {MAX_SPOT_DELIVERIES}",
                        spots.count,
                        u64::from(p) * u64::from(spots.count)
                    ),
                );
            }
        }
    }

    /// Checks the spot positions: one per spot, each with finite coordinates within range.
    fn spot_positions(&mut self, at: At, spots: &Spots) {
        if let Some(positions) = &spots.positions_mm {
            if positions.len() != spots.count as usize {
                self.push(
                    at,
                    "spots.positions_mm",
                    format!(
                        "{} positions for a count of {} spots; expected exactly one [x, y] per spot",
                        positions.len(),
                        spots.count
                    ),
                );
            }
            if let Some((i, p)) = positions.iter().enumerate().find(|(_, p)| {
                !p.iter()
                    .all(|c| c.is_finite() && c.abs() <= MAX_SPOT_POSITION_MM)
            }) {
                self.push(
                    at,
                    &format!("spots.positions_mm[{i}]"),
                    format!(
                        "[{}, {}] mm; expected finite coordinates within ±{} mm",
                        fmt_num(p[0]),
                        fmt_num(p[1]),
                        fmt_num(MAX_SPOT_POSITION_MM)
                    ),
                );
            }
        }
    }
}
