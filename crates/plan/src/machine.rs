//! Machine-model validation: limits must be positive and finite, times non-negative, so that the
//! sequencer never divides by zero or turns a bad file into NaN.

use crate::error::{fmt_num, At, PlanIssue};
use crate::model::{poly, BeamModel, ElstModel, GantryLimitsSpec, Machine, MACHINE_FORMAT};
use crate::validate::ENERGY_RANGE_MEV;
use crate::ScanDistance;

/// Gantry limits arcsim accepts. They span every real gantry (V 1–10 deg/s, A 0.1–5 deg/s²,
/// J 0.1–10 deg/s³) by orders of magnitude for what-if studies; beyond them a move's durations
/// and distances differ by so many orders that the planner's exact checks lose their precision.
pub const SPEED_RANGE_DEG_PER_S: (f64, f64) = (1e-3, 1e3);
/// See [`SPEED_RANGE_DEG_PER_S`].
pub const ACCEL_RANGE_DEG_PER_S2: (f64, f64) = (1e-3, 1e3);
/// See [`SPEED_RANGE_DEG_PER_S`].
pub const JERK_RANGE_DEG_PER_S3: (f64, f64) = (1e-3, 1e4);
/// Accepted servo periods, seconds: from a 1 µs control loop to a 1 s step.
pub const SERVO_PERIOD_RANGE_S: (f64, f64) = (1e-6, 1.0);
/// Largest accepted energy-switching time, seconds (over a day).
pub const MAX_SWITCH_TIME_S: f64 = 1e5;
/// Largest accepted per-spot and per-MU beam time, seconds.
pub const MAX_BEAM_TIME_S: f64 = 10.0;
/// Most coefficients of an ELST polynomial (degree 15).
pub const MAX_ELST_COEFFS: usize = 16;

/// Checks every rule of the machine format and returns all problems found (empty when valid).
pub fn validate_machine(machine: &Machine, source: &str) -> Vec<PlanIssue> {
    let mut m = Checker {
        source,
        issues: Vec::new(),
    };
    if machine.format != MACHINE_FORMAT {
        m.push(
            "format",
            format!("expected \"{MACHINE_FORMAT}\", got \"{}\"", machine.format),
        );
    }
    gantry(&mut m, &machine.gantry);
    beam(&mut m, &machine.beam);
    elst(&mut m, &machine.elst);
    m.check(
        "default_window_deg",
        machine.default_window_deg,
        true,
        "deg",
    );
    m.at_most(
        "default_window_deg",
        machine.default_window_deg,
        360.0,
        "deg",
    );
    if let Some(p) = machine.servo_period_s {
        m.range("servo_period_s", p, SERVO_PERIOD_RANGE_S, "s");
    }
    if let Some(c) = &machine.controller {
        if c.source.trim().is_empty() {
            m.push(
                "controller.source",
                "empty; expected where the controller comes from (a publication, logs, or \"assumed: <why>\")".into(),
            );
        }
    }
    if let Some(u) = &machine.uncertainty {
        for (name, x) in u.fields() {
            m.check(&format!("uncertainty.{name}"), x, false, "");
            m.at_most(&format!("uncertainty.{name}"), x, MAX_SWITCH_TIME_S, "");
        }
    }
    if let Some(spread) = &machine.spread {
        for (name, x) in spread.fields() {
            m.check(&format!("spread.{name}"), x, false, "");
            m.at_most(&format!("spread.{name}"), x, MAX_SWITCH_TIME_S, "");
        }
    }
    m.issues
}

/// The rules of the gantry limits.
fn gantry(m: &mut Checker, g: &GantryLimitsSpec) {
    m.range(
        "gantry.max_speed_deg_per_s",
        g.max_speed_deg_per_s,
        SPEED_RANGE_DEG_PER_S,
        "deg/s",
    );
    m.range(
        "gantry.max_accel_deg_per_s2",
        g.max_accel_deg_per_s2,
        ACCEL_RANGE_DEG_PER_S2,
        "deg/s^2",
    );
    if let Some(d) = g.max_decel_deg_per_s2 {
        m.range(
            "gantry.max_decel_deg_per_s2",
            d,
            ACCEL_RANGE_DEG_PER_S2,
            "deg/s^2",
        );
    }
    m.range(
        "gantry.max_jerk_deg_per_s3",
        g.max_jerk_deg_per_s3,
        JERK_RANGE_DEG_PER_S3,
        "deg/s^3",
    );
}

/// The rules of the energy-switching (ELST) model of either kind.
fn elst(m: &mut Checker, elst: &ElstModel) {
    match elst {
        ElstModel::Constant {
            up_s,
            down_s,
            same_s,
        } => {
            for (field, x) in [
                ("elst.up_s", *up_s),
                ("elst.down_s", *down_s),
                ("elst.same_s", *same_s),
            ] {
                m.check(field, x, false, "s");
                m.at_most(field, x, MAX_SWITCH_TIME_S, "s");
            }
        }
        ElstModel::Polynomial {
            down_s,
            same_s,
            up_coeffs_s,
        } => {
            for (field, x) in [("elst.down_s", *down_s), ("elst.same_s", *same_s)] {
                m.check(field, x, false, "s");
                m.at_most(field, x, MAX_SWITCH_TIME_S, "s");
            }
            let mut coeffs_ok = (1..=MAX_ELST_COEFFS).contains(&up_coeffs_s.len());
            if up_coeffs_s.is_empty() {
                m.push(
                    "elst.up_coeffs_s",
                    "no coefficients; expected at least one (the constant term)".into(),
                );
            } else if up_coeffs_s.len() > MAX_ELST_COEFFS {
                m.push(
                    "elst.up_coeffs_s",
                    format!(
                        "{} coefficients; expected at most {MAX_ELST_COEFFS} (degree {})",
                        up_coeffs_s.len(),
                        MAX_ELST_COEFFS - 1
                    ),
                );
            }
            for (i, c) in up_coeffs_s.iter().enumerate() {
                if !c.is_finite() {
                    coeffs_ok = false;
                    m.push(
                        &format!("elst.up_coeffs_s[{i}]"),
                        format!("expected a finite coefficient, got {}", fmt_num(*c)),
                    );
                }
            }
            if coeffs_ok {
                // Every possible upward step must get a usable time: the polynomial's extremes
                // on the whole range of steps, found exactly (at the ends and where it turns).
                let span = ENERGY_RANGE_MEV.1 - ENERGY_RANGE_MEV.0;
                let ((min_at, min), (max_at, max)) = poly_min_max(up_coeffs_s, 0.0, span);
                if !(min.is_finite() && min >= 0.0) {
                    m.push(
                        "elst.up_coeffs_s",
                        format!("upward switching time is {} s for an energy step of {} MeV; expected a time >= 0 s for every step up to {span} MeV", fmt_num(min), fmt_num(min_at)),
                    );
                } else if !(max.is_finite() && max <= MAX_SWITCH_TIME_S) {
                    m.push(
                        "elst.up_coeffs_s",
                        format!("upward switching time is {} s for an energy step of {} MeV; expected at most {} s for every step up to {span} MeV", fmt_num(max), fmt_num(max_at), fmt_num(MAX_SWITCH_TIME_S)),
                    );
                }
            }
        }
        ElstModel::ByEnergy {
            up_s_by_energy,
            down_s_by_energy,
            same_s,
        } => elst_by_energy(m, up_s_by_energy, down_s_by_energy, *same_s),
        ElstModel::ByEnergyPair {
            energies_mev,
            switch_s,
            same_s,
        } => elst_by_energy_pair(m, energies_mev, switch_s, *same_s),
    }
}

/// The rules of a `by_energy` ELST model.
fn elst_by_energy(m: &mut Checker, up: &[[f64; 2]], down: &[[f64; 2]], same_s: f64) {
    switch_time(m, "elst.same_s", same_s);
    for (name, rows) in [("elst.up_s_by_energy", up), ("elst.down_s_by_energy", down)] {
        if rows.is_empty() || rows.len() > MAX_ELST_TABLE_ROWS {
            m.push(
                name,
                format!("{} rows; expected 1 to {MAX_ELST_TABLE_ROWS} rows of [energy MeV, switching time s]", rows.len()),
            );
        }
        let energies: Vec<f64> = rows.iter().map(|r| r[0]).collect();
        increasing_energies(m, name, "][0]", &energies);
        for (i, row) in rows.iter().enumerate() {
            switch_time(m, &format!("{name}[{i}][1]"), row[1]);
        }
    }
}

/// The rules of a `by_energy_pair` ELST model.
fn elst_by_energy_pair(m: &mut Checker, energies_mev: &[f64], switch_s: &[Vec<f64>], same_s: f64) {
    switch_time(m, "elst.same_s", same_s);
    let n = energies_mev.len();
    if n == 0 || n > MAX_ELST_TABLE_ROWS {
        m.push(
            "elst.energies_mev",
            format!("{n} energies; expected 1 to {MAX_ELST_TABLE_ROWS}"),
        );
    }
    increasing_energies(m, "elst.energies_mev", "]", energies_mev);
    if switch_s.len() != n {
        m.push(
            "elst.switch_s",
            format!(
                "{} rows; expected one per energy of `energies_mev` ({n})",
                switch_s.len()
            ),
        );
    }
    for (i, row) in switch_s.iter().enumerate() {
        if row.len() != n {
            m.push(
                &format!("elst.switch_s[{i}]"),
                format!(
                    "{} columns; expected one per energy of `energies_mev` ({n})",
                    row.len()
                ),
            );
        }
        for (j, x) in row.iter().enumerate() {
            switch_time(m, &format!("elst.switch_s[{i}][{j}]"), *x);
        }
    }
}

/// Most rows of an ELST table (and energies of a pair table's grid).
pub const MAX_ELST_TABLE_ROWS: usize = 1000;

/// A switching time: finite, >= 0 and at most [`MAX_SWITCH_TIME_S`].
fn switch_time(m: &mut Checker, field: &str, x: f64) {
    m.check(field, x, false, "s");
    m.at_most(field, x, MAX_SWITCH_TIME_S, "s");
}

/// A table's energies: each in the accepted range and above the one before. `field` and `tail`
/// name entry `i` as `{field}[{i}{tail}`.
fn increasing_energies(m: &mut Checker, field: &str, tail: &str, energies: &[f64]) {
    for (i, e) in energies.iter().enumerate() {
        let at = format!("{field}[{i}{tail}");
        m.range(&at, *e, ENERGY_RANGE_MEV, "MeV");
        if i > 0 && (e.is_nan() || *e <= energies[i - 1]) {
            m.push(
                &at,
                format!(
                    "energy {} MeV does not rise above the previous {} MeV; expected strictly increasing energies",
                    fmt_num(*e),
                    fmt_num(energies[i - 1])
                ),
            );
        }
    }
}

/// Largest accepted scanning speed, mm/s (real systems: 2–20 m/s).
pub const MAX_SCAN_SPEED_MM_PER_S: f64 = 1e6;
/// Most rows of a `s_per_mu_by_energy` table.
pub const MAX_BEAM_TABLE_ROWS: usize = 1000;

/// The rules of the beam model of either kind.
fn beam(m: &mut Checker, beam: &BeamModel) {
    match beam {
        BeamModel::PerMu(b) => {
            m.check("beam.s_per_mu", b.s_per_mu, true, "s/MU");
            m.check("beam.spot_switch_time_s", b.spot_switch_time_s, false, "s");
            m.check("beam.min_spot_time_s", b.min_spot_time_s, false, "s");
            for (field, x) in [
                ("beam.s_per_mu", b.s_per_mu),
                ("beam.spot_switch_time_s", b.spot_switch_time_s),
                ("beam.min_spot_time_s", b.min_spot_time_s),
            ] {
                m.at_most(field, x, MAX_BEAM_TIME_S, "s");
            }
        }
        BeamModel::Scanning(b) => {
            let rows = &b.s_per_mu_by_energy;
            if rows.is_empty() || rows.len() > MAX_BEAM_TABLE_ROWS {
                m.push(
                    "beam.s_per_mu_by_energy",
                    format!("{} rows; expected 1 to {MAX_BEAM_TABLE_ROWS} rows of [energy MeV, s per MU]", rows.len()),
                );
            }
            let energies: Vec<f64> = rows.iter().map(|r| r[0]).collect();
            increasing_energies(m, "beam.s_per_mu_by_energy", "][0]", &energies);
            for (i, [_, r]) in rows.iter().enumerate() {
                m.check(
                    &format!("beam.s_per_mu_by_energy[{i}][1]"),
                    *r,
                    true,
                    "s/MU",
                );
                m.at_most(
                    &format!("beam.s_per_mu_by_energy[{i}][1]"),
                    *r,
                    MAX_BEAM_TIME_S,
                    "s/MU",
                );
            }
            let speeds = [
                ("beam.scan_speed_mm_per_s", b.scan_speed_mm_per_s),
                ("beam.scan_speed_x_mm_per_s", b.scan_speed_x_mm_per_s),
                ("beam.scan_speed_y_mm_per_s", b.scan_speed_y_mm_per_s),
            ];
            match (b.scan_speed_mm_per_s, b.scan_speed_x_mm_per_s, b.scan_speed_y_mm_per_s) {
                (Some(_), None, None) | (None, Some(_), Some(_)) => {}
                _ => m.push(
                    "beam.scan_speed_mm_per_s",
                    "expected either `scan_speed_mm_per_s` (both axes) or both `scan_speed_x_mm_per_s` and `scan_speed_y_mm_per_s`".into(),
                ),
            }
            if b.scan_distance == ScanDistance::Euclidean && b.scan_speed_mm_per_s.is_none() {
                m.push(
                    "beam.scan_distance",
                    "\"euclidean\" covers the straight-line distance at one speed: expected `scan_speed_mm_per_s`, not one speed per axis".into(),
                );
            }
            for (field, v) in speeds {
                if let Some(v) = v {
                    m.range(field, v, (1e-3, MAX_SCAN_SPEED_MM_PER_S), "mm/s");
                }
            }
            for (field, x) in [
                ("beam.min_spot_time_s", b.min_spot_time_s),
                ("beam.settling_time_s", b.settling_time_s),
                ("beam.layer_overhead_s", b.layer_overhead_s),
                ("beam.burst_switching_time_s", b.burst_switching_time_s),
            ] {
                m.check(field, x, false, "s");
                m.at_most(field, x, MAX_BEAM_TIME_S, "s");
            }
            if let Some(max) = b.max_mu_per_spot {
                m.check("beam.max_mu_per_spot", max, true, "MU");
                m.at_least("beam.max_mu_per_spot", max, MIN_MAX_MU_PER_SPOT, "MU");
            }
            if let Some(spill) = &b.spill {
                validate_spill(m, spill);
            }
        }
    }
}

/// Checks a spill model's numbers.
fn validate_spill(m: &mut Checker<'_>, spill: &crate::spill::SpillModel) {
    m.check("beam.spill.charge_mu", spill.charge_mu, true, "MU");
    m.at_least(
        "beam.spill.charge_mu",
        spill.charge_mu,
        MIN_MAX_MU_PER_SPOT,
        "MU",
    );
    for (field, x) in [
        ("beam.spill.refill_time_s", spill.refill_time_s),
        (
            "beam.spill.in_spill_switching_time_s",
            spill.in_spill_switching_time_s,
        ),
    ] {
        m.check(field, x, false, "s");
        m.at_most(field, x, MAX_SWITCH_TIME_S, "s");
    }
    if spill.max_layers_per_spill == Some(0) {
        m.push(
            "beam.spill.max_layers_per_spill",
            "0 layers per spill; expected at least 1".into(),
        );
    }
    if !spill.multi_energy_extraction
        && (spill.in_spill_switching_time_s != 0.0 || spill.max_layers_per_spill.is_some())
    {
        m.push(
            "beam.spill",
            "`in_spill_switching_time_s` and `max_layers_per_spill` apply only to multi-energy extraction; expected `multi_energy_extraction: true`, or neither field".into(),
        );
    }
}

/// Smallest accepted `max_mu_per_spot` (a plan whose spots it splits into too many parts is
/// refused when resolved: [`crate::beam::MAX_SPOT_DELIVERIES`]).
pub const MIN_MAX_MU_PER_SPOT: f64 = 1e-3;

/// Coefficients of the derivative of the polynomial `Σ c[i] x^i`.
fn derivative(c: &[f64]) -> Vec<f64> {
    c.iter()
        .enumerate()
        .skip(1)
        .map(|(i, k)| i as f64 * k)
        .collect()
}

/// Real roots of the polynomial `c` in `[a, b]`, ascending: between consecutive turning points
/// (the roots of its derivative, found the same way) the polynomial is monotone, so each sign
/// change there holds exactly one root, found by bisection. Degree ≤ [`MAX_ELST_COEFFS`] bounds
/// the recursion.
fn poly_roots(c: &[f64], a: f64, b: f64) -> Vec<f64> {
    let c = match c.iter().rposition(|&k| k != 0.0) {
        Some(last) => &c[..=last],
        None => return Vec::new(),
    };
    if c.len() < 2 {
        return Vec::new();
    }
    let mut cuts = vec![a];
    cuts.extend(poly_roots(&derivative(c), a, b));
    cuts.push(b);
    let mut roots = Vec::new();
    for w in cuts.windows(2) {
        let (mut lo, mut hi) = (w[0], w[1]);
        let (flo, fhi) = (poly(c, lo), poly(c, hi));
        if flo == 0.0 {
            roots.push(lo);
            continue;
        }
        if flo.signum() == fhi.signum() {
            continue;
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            if poly(c, mid).signum() == flo.signum() {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        roots.push(0.5 * (lo + hi));
    }
    roots
}

/// The lowest and the highest value of the polynomial on `[a, b]`, each with where it is: at an
/// end or at a root of the derivative. A NaN anywhere is reported as both.
fn poly_min_max(c: &[f64], a: f64, b: f64) -> ((f64, f64), (f64, f64)) {
    let start = (a, poly(c, a));
    let (mut min, mut max) = (start, start);
    for x in poly_roots(&derivative(c), a, b).into_iter().chain([b]) {
        let y = poly(c, x);
        if y.is_nan() || y < min.1 {
            min = (x, y);
        }
        if y.is_nan() || y > max.1 {
            max = (x, y);
        }
    }
    (min, max)
}

struct Checker<'a> {
    source: &'a str,
    issues: Vec<PlanIssue>,
}

impl Checker<'_> {
    fn push(&mut self, field: &str, message: String) {
        self.issues
            .push(PlanIssue::new(self.source, At::top(), field, message));
    }

    /// Requires `x` finite and within `range` (both ends included).
    fn range(&mut self, field: &str, x: f64, range: (f64, f64), unit: &str) {
        if !(x.is_finite() && x >= range.0 && x <= range.1) {
            self.push(
                field,
                format!(
                    "expected a value from {} to {} {unit}, got {}",
                    fmt_num(range.0),
                    fmt_num(range.1),
                    fmt_num(x)
                ),
            );
        }
    }

    /// Adds an issue when the finite `x` is above `max`.
    fn at_most(&mut self, field: &str, x: f64, max: f64, unit: &str) {
        if x.is_finite() && x > max {
            self.push(
                field,
                format!(
                    "{} {unit} is above the largest accepted value, {} {unit}",
                    fmt_num(x),
                    fmt_num(max)
                ),
            );
        }
    }

    /// Adds an issue when the finite `x` is below `min`.
    fn at_least(&mut self, field: &str, x: f64, min: f64, unit: &str) {
        if x.is_finite() && x < min {
            self.push(
                field,
                format!(
                    "{} {unit} is below the smallest accepted value, {} {unit}",
                    fmt_num(x),
                    fmt_num(min)
                ),
            );
        }
    }

    /// Requires `x` finite and `> 0` (`positive`) or `>= 0`.
    fn check(&mut self, field: &str, x: f64, positive: bool, unit: &str) {
        let ok = x.is_finite() && if positive { x > 0.0 } else { x >= 0.0 };
        if !ok {
            let bound = if positive { "> 0" } else { ">= 0" };
            self.push(
                field,
                format!("expected a finite value {bound} {unit}, got {}", fmt_num(x)),
            );
        }
    }
}
