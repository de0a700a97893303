//! `simulate`'s options as a user gives them, and the defaults that fill the rest.

use arcsim_plan::{ArcPlan, Machine, Warning};
use arcsim_sequencer::{ArcEnds, Motion, Options, Schedule};

use crate::AppError;

/// What a user asks `simulate` for; `None` fields take the defaults of [`SimulateRequest::options`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimulateRequest {
    /// Speed schedule of each layer.
    pub schedule: Schedule,
    /// `None`: free motion, unless a servo period applies or the schedule is `prescribed` or
    /// `step-and-shoot` (constant speed then).
    pub motion: Option<Motion>,
    /// Arcs starting and ending at rest, or free.
    pub arc_ends: ArcEnds,
    /// Servo period (s) overriding the machine's.
    pub period_s: Option<f64>,
}

impl SimulateRequest {
    /// The sequencer options for `plan` on `machine`, and notes on how the defaults applied.
    pub fn options(&self, plan: &ArcPlan, machine: &Machine) -> (Options, Vec<String>) {
        let mut notes = Vec::new();
        let prescribes = plan
            .arcs
            .iter()
            .flat_map(|a| &a.control_points)
            .any(|cp| cp.required_speed_deg_per_s.is_some());
        if self.schedule == Schedule::Prescribed && !prescribes {
            notes.push("the plan prescribes no speeds (no required_speed_deg_per_s), so `prescribed` gives the same speeds as `scan`".to_string());
        }
        let period = self.period_s.or(machine.servo_period_s);
        let motion = match self.motion {
            Some(m) => m,
            None if period.is_some() => {
                notes.push("a servo period applies, so the motion is constant speed per layer (free motion is continuous-time only)".to_string());
                Motion::Constant
            }
            None if matches!(self.schedule, Schedule::Prescribed | Schedule::StepAndShoot) => {
                Motion::Constant
            }
            None => Motion::Free,
        };
        let opts = Options {
            servo_period_s: self.period_s,
            motion,
            arc_ends: self.arc_ends,
            ..Options::new(self.schedule)
        };
        (opts, notes)
    }
}

/// Checks a servo period given as option `field` (e.g. `--period`): an error outside the range a
/// machine file accepts, a plausibility warning outside 0.1 ms–100 ms (a value in milliseconds?).
pub fn check_period(ts: f64, field: &str) -> Result<Option<Warning>, AppError> {
    let (lo, hi) = arcsim_plan::SERVO_PERIOD_RANGE_S;
    if !(ts.is_finite() && (lo..=hi).contains(&ts)) {
        return Err(AppError::Option(format!(
            "{field} {}: expected a servo period from {} to {} s",
            arcsim_plan::fmt_num(ts),
            arcsim_plan::fmt_num(lo),
            arcsim_plan::fmt_num(hi)
        )));
    }
    if (1e-4..=0.1).contains(&ts) {
        return Ok(None);
    }
    Ok(Some(Warning {
        field: field.into(),
        value: ts,
        message: format!(
            "{} s is outside the plausible 0.0001–0.1 s of a servo period{}",
            arcsim_plan::fmt_num(ts),
            if ts > 0.1 {
                "; given in milliseconds? the option is in seconds"
            } else {
                ""
            }
        ),
    }))
}

/// The plausibility warnings (likely unit slips) of a plan and a machine, named as given.
pub fn plausibility(
    plan: &ArcPlan,
    plan_name: &str,
    machine: &Machine,
    machine_name: &str,
) -> Vec<Warning> {
    let mut warnings = arcsim_plan::plan_warnings(plan, plan_name);
    warnings.extend(arcsim_plan::machine_warnings(machine, machine_name));
    warnings
}

/// With `option` (e.g. `--strict`) given, implausible values are refused: an error listing every
/// warning; `Ok` when there are none.
pub fn refuse_implausible(warnings: &[Warning], option: &str) -> Result<(), AppError> {
    if warnings.is_empty() {
        return Ok(());
    }
    let lines: Vec<String> = warnings.iter().map(|w| format!("  {w}")).collect();
    Err(AppError::Option(format!(
        "{option}: {} implausible value{} (a unit slip?):\n{}",
        warnings.len(),
        if warnings.len() == 1 { "" } else { "s" },
        lines.join("\n")
    )))
}
