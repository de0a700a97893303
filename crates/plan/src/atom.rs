//! The ATOM article cases (Wase et al., Phys. Med. Biol. 2024) as plans, so the sequencer can be
//! tested against real clinical timings without copying the data into this repository.

use serde::Deserialize;

use crate::error::{At, PlanError, PlanIssue};
use crate::load::invalid_if_any;
use crate::model::{Arc, ArcPlan, ControlPoint, EnergyLayer, RotationDirection, PLAN_FORMAT};
use crate::validate::validate_plan;

const SOURCE: &str = "ATOM article cases";

/// Lowest placeholder energy, MeV; see [`atom_case_plan`].
pub const ATOM_PLACEHOLDER_MIN_ENERGY_MEV: f64 = 70.0;

#[derive(Deserialize)]
struct AtomCases {
    max_window_deg: f64,
    control_point_spacing_deg: f64,
    first_angle_deg: f64,
    cases: Vec<AtomCase>,
}

#[derive(Deserialize)]
struct AtomCase {
    name: String,
    irradiation_times_s: Vec<f64>,
    energy_switch_times_s: Vec<f64>,
}

/// Converts one case (`"prostate"`, `"head-and-neck"`, `"liver"`) of the reference file
/// `atom-article-cases.json` into a plan: one CW arc, one layer per control point at
/// `first_angle_deg + i * control_point_spacing_deg`, window `max_window_deg`, each layer with the
/// case's `irradiation_time_s` and (from the second on) its `switching_time_s`.
///
/// The article gives no energies, so they are placeholders that agree with the switching times:
/// a switch of 1 s or more is taken as upward (+1 MeV), a shorter non-zero one as downward (-1 MeV),
/// zero as the same energy; the sequence is shifted so its lowest energy is 70 MeV. The explicit
/// switching times are what count; the energies only keep the up/down pattern recognisable.
pub fn atom_case_plan(json_text: &str, case_name: &str) -> Result<ArcPlan, PlanError> {
    let data: AtomCases = match serde_json::from_str(json_text) {
        Ok(d) => d,
        Err(e) => return Err(PlanError::from_serde(SOURCE, None, &e)),
    };
    let issue = |field: &str, message: String| PlanError::Invalid {
        source_name: SOURCE.to_string(),
        issues: vec![PlanIssue::new(SOURCE, At::top(), field, message)],
    };
    let Some(case) = data.cases.iter().find(|c| c.name == case_name) else {
        let names: Vec<&str> = data.cases.iter().map(|c| c.name.as_str()).collect();
        return Err(issue(
            "cases",
            format!("no case named \"{case_name}\"; expected one of {names:?}"),
        ));
    };
    let n = case.irradiation_times_s.len();
    if n == 0 || case.energy_switch_times_s.len() + 1 != n {
        return Err(issue(
            "energy_switch_times_s",
            format!(
                "case \"{case_name}\" has {} layers and {} switching times; expected one switch fewer than layers",
                n,
                case.energy_switch_times_s.len()
            ),
        ));
    }
    let mut energy = 0.0;
    let mut energies = vec![energy];
    for &s in &case.energy_switch_times_s {
        energy += if s >= 1.0 {
            1.0
        } else if s > 0.0 {
            -1.0
        } else {
            0.0
        };
        energies.push(energy);
    }
    let lowest = energies.iter().copied().fold(f64::INFINITY, f64::min);
    let control_points = (0..n)
        .map(|i| ControlPoint {
            angle_deg: data.first_angle_deg + i as f64 * data.control_point_spacing_deg,
            required_speed_deg_per_s: None,
            window_deg: Some(data.max_window_deg),
            layers: vec![EnergyLayer {
                energy_mev: energies[i] - lowest + ATOM_PLACEHOLDER_MIN_ENERGY_MEV,
                spots: None,
                irradiation_time_s: Some(case.irradiation_times_s[i]),
                switching_time_s: i.checked_sub(1).map(|k| case.energy_switch_times_s[k]),
                window_share: None,
            }],
        })
        .collect();
    let plan = ArcPlan {
        format: PLAN_FORMAT.to_string(),
        name: format!("ATOM article case {case_name}"),
        description: Some(format!(
            "Case \"{case_name}\" of the ATOM article data (Wase et al., Phys. Med. Biol. 2024): real irradiation and \
             switching times; energies are placeholders that only follow the up/down pattern of the switches."
        )),
        arcs: vec![Arc { direction: RotationDirection::Cw, control_points }],
    };
    invalid_if_any(SOURCE, validate_plan(&plan, SOURCE))?;
    Ok(plan)
}
