//! Machine-model validation: limits must be positive and finite, times non-negative, so that the
//! sequencer never divides by zero or turns a bad file into NaN.

use crate::error::{At, PlanIssue};
use crate::model::{ElstModel, Machine, MACHINE_FORMAT};
use crate::validate::ENERGY_RANGE_MEV;

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
    let g = &machine.gantry;
    m.check(
        "gantry.max_speed_deg_per_s",
        g.max_speed_deg_per_s,
        true,
        "deg/s",
    );
    m.check(
        "gantry.max_accel_deg_per_s2",
        g.max_accel_deg_per_s2,
        true,
        "deg/s^2",
    );
    if let Some(d) = g.max_decel_deg_per_s2 {
        m.check("gantry.max_decel_deg_per_s2", d, true, "deg/s^2");
    }
    m.check(
        "gantry.max_jerk_deg_per_s3",
        g.max_jerk_deg_per_s3,
        true,
        "deg/s^3",
    );
    let b = &machine.beam;
    m.check("beam.s_per_mu", b.s_per_mu, true, "s/MU");
    m.check("beam.spot_switch_time_s", b.spot_switch_time_s, false, "s");
    m.check("beam.min_spot_time_s", b.min_spot_time_s, false, "s");
    match &machine.elst {
        ElstModel::Constant {
            up_s,
            down_s,
            same_s,
        } => {
            m.check("elst.up_s", *up_s, false, "s");
            m.check("elst.down_s", *down_s, false, "s");
            m.check("elst.same_s", *same_s, false, "s");
        }
        ElstModel::Polynomial {
            down_s,
            same_s,
            up_coeffs_s,
        } => {
            m.check("elst.down_s", *down_s, false, "s");
            m.check("elst.same_s", *same_s, false, "s");
            let mut coeffs_ok = !up_coeffs_s.is_empty();
            if up_coeffs_s.is_empty() {
                m.push(
                    "elst.up_coeffs_s",
                    "no coefficients; expected at least one (the constant term)".into(),
                );
            }
            for (i, c) in up_coeffs_s.iter().enumerate() {
                if !c.is_finite() {
                    coeffs_ok = false;
                    m.push(
                        &format!("elst.up_coeffs_s[{i}]"),
                        format!("expected a finite coefficient, got {c}"),
                    );
                }
            }
            if coeffs_ok {
                // The polynomial must give a usable time for every possible upward step.
                let span = ENERGY_RANGE_MEV.1 - ENERGY_RANGE_MEV.0;
                let steps = (0..=399).map(|i| {
                    if i == 0 {
                        1e-3
                    } else {
                        f64::from(i) * span / 399.0
                    }
                });
                if let Some((de, t)) = steps
                    .map(|de| (de, machine.elst.switch_time_s(0.0, de)))
                    .find(|(_, t)| !t.is_finite() || *t < 0.0)
                {
                    m.push(
                        "elst.up_coeffs_s",
                        format!("upward switching time is {t} s for an energy step of {de} MeV; expected a finite value >= 0 for every step up to {span} MeV"),
                    );
                }
            }
        }
    }
    m.check(
        "default_window_deg",
        machine.default_window_deg,
        true,
        "deg",
    );
    if let Some(p) = machine.servo_period_s {
        m.check("servo_period_s", p, true, "s");
    }
    m.issues
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

    /// Requires `x` finite and `> 0` (`positive`) or `>= 0`.
    fn check(&mut self, field: &str, x: f64, positive: bool, unit: &str) {
        let ok = x.is_finite() && if positive { x > 0.0 } else { x >= 0.0 };
        if !ok {
            let bound = if positive { "> 0" } else { ">= 0" };
            self.push(
                field,
                format!("expected a finite value {bound} {unit}, got {x}"),
            );
        }
    }
}
