//! `simulate`'s options as a user gives them, and the defaults that fill the rest.

use arcsim_plan::{ArcPlan, Machine, Warning};
use arcsim_sequencer::{ArcEnds, Motion, Options, Schedule};

use serde::Serialize;

use crate::AppError;

/// What a user asks `simulate` for; `None` fields take the machine's controller, else the
/// documented assumption ([`arcsim_plan::Controller::assumed`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimulateRequest {
    /// Speed schedule of each layer (`None`: the machine's controller's).
    pub schedule: Option<Schedule>,
    /// Motion model (`None`: the machine's controller's, constant speed where a servo period
    /// applies or the schedule is `prescribed` or `step-and-shoot`).
    pub motion: Option<Motion>,
    /// Arcs starting and ending at rest, or free.
    pub arc_ends: ArcEnds,
    /// Servo period (s) overriding the machine's.
    pub period_s: Option<f64>,
}

/// The controller a result was computed under, and where each part of it came from: what every
/// output says beside its number.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ControllerUsed {
    /// Motion model (written by its name: `constant`, `free`).
    pub motion: Motion,
    /// Speed schedule (written by its name).
    pub schedule: Schedule,
    /// Where the motion came from: `option` (`--motion`), `machine` (its file's controller),
    /// `assumed` (the file names none), or `rule` (forced by a servo period or the schedule).
    pub motion_from: &'static str,
    /// The machine file's controller source, or the assumption's text.
    pub source: String,
}

impl ControllerUsed {
    /// One line for text summaries, e.g. `controller: constant speed per layer, optimal schedule (machine: Wase …)`.
    pub fn line(&self) -> String {
        let motion = self.motion.describe();
        let from = match self.motion_from {
            "option" => "from --motion".to_string(),
            "rule" => "forced by the servo period or the schedule".to_string(),
            "machine" => format!("machine file: {}", short_source(&self.source)),
            _ => short_source(&self.source).to_string(),
        };
        format!(
            "controller: {motion}, {} schedule ({from})",
            self.schedule.name()
        )
    }
}

/// The head of a controller's source for a one-line summary: up to its first `;`, and for a
/// source that is not an assumption, up to its first `: ` (the full text is in the JSON).
fn short_source(source: &str) -> &str {
    let head = source.split(';').next().unwrap_or(source).trim();
    if head.to_ascii_lowercase().starts_with("assumed") {
        head
    } else {
        head.split(": ").next().unwrap_or(head).trim()
    }
}

impl SimulateRequest {
    /// The request with every choice left to the machine.
    pub fn machine_default() -> Self {
        SimulateRequest {
            schedule: None,
            motion: None,
            arc_ends: ArcEnds::Rest,
            period_s: None,
        }
    }

    /// The sequencer options for `plan` on `machine`, and notes on how the defaults applied.
    pub fn options(&self, plan: &ArcPlan, machine: &Machine) -> (Options, Vec<String>) {
        let (opts, notes, _) = self.resolve(plan, machine);
        (opts, notes)
    }

    /// As [`SimulateRequest::options`], with the controller used and where it came from.
    pub fn resolve(
        &self,
        plan: &ArcPlan,
        machine: &Machine,
    ) -> (Options, Vec<String>, ControllerUsed) {
        let mut notes = Vec::new();
        let controller = machine.controller_or_assumed();
        let schedule = self.schedule.unwrap_or(controller.schedule);
        let prescribes = plan
            .arcs
            .iter()
            .flat_map(|a| &a.control_points)
            .any(|cp| cp.required_speed_deg_per_s.is_some());
        if schedule == Schedule::Prescribed && !prescribes {
            notes.push("the plan prescribes no speeds (no required_speed_deg_per_s), so `prescribed` gives the same speeds as `scan`".to_string());
        }
        let period = self.period_s.or(machine.servo_period_s);
        let from_machine = if machine.controller.is_some() {
            "machine"
        } else {
            notes.push(format!("controller {}", controller.source));
            "assumed"
        };
        let (motion, motion_from) = match self.motion {
            Some(m) => (m, "option"),
            None if controller.motion.continuous_time_only().is_some() && period.is_some() => {
                notes.push(format!(
                    "a servo period applies, so the motion is constant speed per layer ({} is continuous-time only)",
                    controller.motion.describe()
                ));
                (Motion::Constant, "rule")
            }
            None if !controller.motion.accepts_schedule(schedule) => (Motion::Constant, "rule"),
            None => (controller.motion, from_machine),
        };
        let opts = Options {
            servo_period_s: self.period_s,
            motion,
            arc_ends: self.arc_ends,
            ..Options::new(schedule)
        };
        let used = ControllerUsed {
            motion,
            schedule,
            motion_from,
            source: controller.source,
        };
        (opts, notes, used)
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
