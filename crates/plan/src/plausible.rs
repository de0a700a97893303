//! Plausibility: values that are valid but far outside what real machines and plans use, most
//! often a unit slip (ELST in ms, gantry limits in rad/s, keV for MeV). They are warnings, not
//! errors, because a what-if machine may be extreme on purpose; the CLI's `--strict` refuses them.
//!
//! | field | plausible range | likely slip outside it |
//! |---|---|---|
//! | ELST `up_s`, `down_s`, `same_s`, `switching_time_s` | ≤ 60 s | ms (≥ 100) |
//! | gantry V `max_speed_deg_per_s` | 0.1–30 °/s | rad/s (below 0.2) |
//! | gantry A/D `max_accel_deg_per_s2`, `max_decel_deg_per_s2` | 0.01–30 °/s² | rad/s² (below 0.02) |
//! | gantry J `max_jerk_deg_per_s3` | 0.01–100 °/s³ | rad/s³ (below 0.02) |
//! | servo period `servo_period_s` | 0.1 ms–0.1 s | ms (≥ 0.1) |
//! | beam `s_per_mu` | ≤ 1 s/MU | ms/MU |
//! | beam `spot_switch_time_s`, `min_spot_time_s` | ≤ 0.1 s | ms |
//! | window `default_window_deg`, `window_deg` | ≤ 30° | |
//! | energy `energy_mev` | 30–300 MeV (protons) | |
//! | MU of one spot `spots.mu` | ≤ 100 MU | |
//! | irradiation time of a layer `irradiation_time_s` | ≤ 120 s | ms |

use serde::{Deserialize, Serialize};

use crate::error::fmt_num;
use crate::model::{ArcPlan, BeamModel, ElstModel, Machine};

/// A value outside the plausible range of its field.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Warning {
    /// Where: the file (or plan/machine name) and the field, e.g. `machine.json: elst.up_s`.
    pub field: String,
    /// The value found.
    pub value: f64,
    /// What is plausible and the likely slip.
    pub message: String,
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.field, self.message)
    }
}

struct Collector<'a> {
    source: &'a str,
    out: Vec<Warning>,
}

impl Collector<'_> {
    /// Warns when `x` is outside `[lo, hi]`; `slip` says what a value below (`low`) or above
    /// (`high`) most likely means.
    fn range(
        &mut self,
        field: &str,
        x: f64,
        (lo, hi): (f64, f64),
        unit: &str,
        low: Option<&str>,
        high: Option<&str>,
    ) {
        if !x.is_finite() || (lo..=hi).contains(&x) {
            return;
        }
        let slip = if x < lo { low } else { high };
        let hint = slip.map(|s| format!("; {s}")).unwrap_or_default();
        self.out.push(Warning {
            field: format!("{}: {field}", self.source),
            value: x,
            message: format!(
                "{} {unit} is outside the plausible {}–{} {unit}{hint}",
                fmt_num(x),
                fmt_num(lo),
                fmt_num(hi)
            ),
        });
    }
}

const MS: &str = "given in milliseconds? the field is in seconds";

/// Implausible values of a machine (`source` names it in the messages).
pub fn machine_warnings(m: &Machine, source: &str) -> Vec<Warning> {
    let mut c = Collector {
        source,
        out: Vec::new(),
    };
    let g = &m.gantry;
    let rad = "given in rad? the field is in degrees";
    c.range(
        "gantry.max_speed_deg_per_s",
        g.max_speed_deg_per_s,
        (0.1, 30.0),
        "deg/s",
        Some(rad),
        None,
    );
    for (field, x) in [
        ("gantry.max_accel_deg_per_s2", Some(g.max_accel_deg_per_s2)),
        ("gantry.max_decel_deg_per_s2", g.max_decel_deg_per_s2),
    ] {
        if let Some(x) = x {
            c.range(field, x, (0.01, 30.0), "deg/s^2", Some(rad), None);
        }
    }
    c.range(
        "gantry.max_jerk_deg_per_s3",
        g.max_jerk_deg_per_s3,
        (0.01, 100.0),
        "deg/s^3",
        Some(rad),
        None,
    );
    for (field, x) in elst_values(&m.elst) {
        c.range(&field, x, (0.0, 60.0), "s", None, Some(MS));
    }
    if let Some(ts) = m.servo_period_s {
        c.range("servo_period_s", ts, (1e-4, 0.1), "s", None, Some(MS));
    }
    // (field, s per MU) and (field, time in s) of the beam model.
    type Fields<'a> = (Vec<(String, f64)>, Vec<(&'a str, f64)>);
    let (rates, times): Fields = match &m.beam {
        BeamModel::PerMu(b) => (
            vec![("beam.s_per_mu".to_string(), b.s_per_mu)],
            vec![
                ("beam.spot_switch_time_s", b.spot_switch_time_s),
                ("beam.min_spot_time_s", b.min_spot_time_s),
            ],
        ),
        BeamModel::Scanning(b) => (
            b.s_per_mu_by_energy
                .iter()
                .enumerate()
                .map(|(i, r)| (format!("beam.s_per_mu_by_energy[{i}][1]"), r[1]))
                .collect(),
            vec![
                ("beam.min_spot_time_s", b.min_spot_time_s),
                ("beam.settling_time_s", b.settling_time_s),
            ],
        ),
    };
    if let BeamModel::Scanning(b) = &m.beam {
        c.range(
            "beam.layer_overhead_s",
            b.layer_overhead_s,
            (0.0, 5.0),
            "s",
            None,
            None,
        );
    }
    for (field, x) in &rates {
        c.range(field, *x, (0.0, 1.0), "s/MU", None, Some(MS));
    }
    for (field, x) in times {
        c.range(field, x, (0.0, 0.1), "s", None, Some(MS));
    }
    c.range(
        "default_window_deg",
        m.default_window_deg,
        (0.0, 30.0),
        "deg",
        None,
        None,
    );
    c.out
}

/// One checked value of a plan.
struct Place {
    /// "arc 0, control point 3, layer 1"
    at: String,
    field: &'static str,
    value: f64,
    range: (f64, f64),
    unit: &'static str,
    slip: Option<&'static str>,
}

impl Place {
    fn implausible(&self) -> bool {
        !(self.range.0..=self.range.1).contains(&self.value)
    }
}

/// Implausible values of a plan, one warning per field (naming the first place and how many
/// there are).
pub fn plan_warnings(p: &ArcPlan, source: &str) -> Vec<Warning> {
    let mut places: Vec<Place> = Vec::new();
    for (a, arc) in p.arcs.iter().enumerate() {
        for (k, cp) in arc.control_points.iter().enumerate() {
            let at = format!("arc {a}, control point {k}");
            if let Some(w) = cp.window_deg {
                places.push(Place {
                    at: at.clone(),
                    field: "window_deg",
                    value: w,
                    range: (0.0, 30.0),
                    unit: "deg",
                    slip: None,
                });
            }
            for (l, layer) in cp.layers.iter().enumerate() {
                let at = format!("{at}, layer {l}");
                let mut add = |field, value, range, unit, slip| {
                    places.push(Place {
                        at: at.clone(),
                        field,
                        value,
                        range,
                        unit,
                        slip,
                    })
                };
                add("energy_mev", layer.energy_mev, (30.0, 300.0), "MeV", None);
                if let Some(t) = layer.irradiation_time_s {
                    add("irradiation_time_s", t, (0.0, 120.0), "s", Some(MS));
                }
                if let Some(t) = layer.switching_time_s {
                    add("switching_time_s", t, (0.0, 60.0), "s", Some(MS));
                }
                if let Some(mu) = layer.spots.as_ref().and_then(|s| s.mu.as_ref()) {
                    if let Some(&max) = mu.iter().max_by(|a, b| a.total_cmp(b)) {
                        add("spots.mu", max, (0.0, 100.0), "MU", None);
                    }
                }
            }
        }
    }
    let mut c = Collector {
        source,
        out: Vec::new(),
    };
    let mut fields: Vec<&str> = Vec::new();
    for p in places.iter().filter(|p| p.implausible()) {
        if fields.contains(&p.field) {
            continue;
        }
        fields.push(p.field);
        let count = places
            .iter()
            .filter(|q| q.field == p.field && q.implausible())
            .count();
        let name = if count == 1 {
            format!("{}: {}", p.at, p.field)
        } else {
            format!("{}: {} (and {} more places)", p.at, p.field, count - 1)
        };
        c.range(&name, p.value, p.range, p.unit, None, p.slip);
    }
    c.out
}

/// The switching times of an ELST table, each with its field.
fn elst_table_entries(elst: &ElstModel) -> Vec<(String, f64)> {
    match elst {
        ElstModel::ByEnergy {
            up_s_by_energy,
            down_s_by_energy,
            ..
        } => [
            ("elst.up_s_by_energy", up_s_by_energy),
            ("elst.down_s_by_energy", down_s_by_energy),
        ]
        .into_iter()
        .flat_map(|(name, rows)| {
            rows.iter()
                .enumerate()
                .map(move |(i, r)| (format!("{name}[{i}][1]"), r[1]))
        })
        .collect(),
        ElstModel::ByEnergyPair { switch_s, .. } => switch_s
            .iter()
            .enumerate()
            .flat_map(|(i, row)| {
                row.iter()
                    .enumerate()
                    .map(move |(j, x)| (format!("elst.switch_s[{i}][{j}]"), *x))
            })
            .collect(),
        ElstModel::Constant { .. } | ElstModel::Polynomial { .. } => Vec::new(),
    }
}

/// Every switching time of an ELST model, each with its field.
fn elst_values(elst: &ElstModel) -> Vec<(String, f64)> {
    let mut values: Vec<(String, f64)> = match elst {
        ElstModel::Constant { up_s, down_s, .. } => {
            vec![("elst.up_s".into(), *up_s), ("elst.down_s".into(), *down_s)]
        }
        ElstModel::Polynomial { down_s, .. } => vec![("elst.down_s".into(), *down_s)],
        ElstModel::ByEnergy { .. } | ElstModel::ByEnergyPair { .. } => Vec::new(),
    };
    values.push(("elst.same_s".into(), elst.same_s()));
    values.extend(elst_table_entries(elst));
    values
}
