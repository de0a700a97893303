//! The result document of a simulation (`arcsim-result/1`, `simulate --json`).

use arcsim_plan::{ArcPlan, Machine, Warning};
use arcsim_sequencer::{Certificate, Delivery, SpotRow};
use serde::Serialize;

/// Format tag of [`ResultDocument`].
pub const RESULT_FORMAT: &str = "arcsim-result/1";

/// The options a result was computed with, as given or defaulted.
#[derive(Debug, Clone, Serialize)]
pub struct OptionsOut {
    /// Speed schedule name (e.g. `optimal`).
    pub schedule: &'static str,
    /// Motion name: `constant` or `free`.
    pub motion: &'static str,
    /// Arc ends name: `rest` or `free`.
    pub arc_ends: &'static str,
    /// The servo period used (s): the option, else the machine's; `null`: continuous time.
    pub servo_period_s: Option<f64>,
    /// Whether implausible values were refused (`--strict`).
    pub strict: bool,
    /// The controller the result was computed under and where it came from.
    pub controller: crate::ControllerUsed,
}

/// A simulation's result with what produced it: the plan and machine (names, files, SHA-256 of
/// the bytes read), the options, warnings and notes, then the delivery itself.
#[derive(Debug, Serialize)]
pub struct ResultDocument<'a> {
    /// Always [`RESULT_FORMAT`].
    pub format: &'static str,
    /// Version of arcsim that computed the result.
    pub arcsim_version: &'static str,
    /// The plan's name.
    pub plan: String,
    /// The plan file as named on the command line.
    pub plan_file: String,
    /// SHA-256 of the plan file's bytes.
    pub plan_sha256: String,
    /// The machine's name.
    pub machine: String,
    /// The machine file, or the built-in one.
    pub machine_file: String,
    /// SHA-256 of the machine file's text (of the built-in JSON without a machine file).
    pub machine_sha256: String,
    /// The whole machine model used: every limit, the ELST and beam models.
    pub machine_model: &'a Machine,
    /// The options the result was computed with.
    pub options: OptionsOut,
    /// Values outside their field's plausible range (likely unit slips).
    pub warnings: &'a [Warning],
    /// Remarks on how the options applied (e.g. `prescribed` without prescribed speeds).
    pub notes: &'a [String],
    /// The delivery itself, its fields inlined in the document.
    #[serde(flatten)]
    pub delivery: &'a Delivery,
    /// Every spot delivery with its time and gantry angle (`simulate --spots`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spots: Option<&'a [SpotRow]>,
    /// A proven lower bound of every constant-speed schedule and the gap to it
    /// (`simulate --certify`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub certificate: Option<&'a Certificate>,
    /// Percentiles of the total over draws of the machine's timing spreads
    /// (`simulate --monte-carlo`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub monte_carlo: Option<serde_json::Value>,
    /// The plan's energy switches by class and step, with the small upward steps and their cost.
    pub switching: Option<arcsim_sequencer::Switching>,
}

/// Where a plan or machine came from: its name in messages (a path) and the SHA-256 of its bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Source {
    /// The input's name in messages (a path).
    pub file: String,
    /// SHA-256 of the bytes read.
    pub sha256: String,
}

/// What a result is computed from besides the plan: the machine, where both came from, and the
/// checks and notes of the run.
#[derive(Debug, Clone)]
pub struct Provenance<'a> {
    /// Where the plan came from.
    pub plan_source: Source,
    /// The machine model used.
    pub machine: &'a Machine,
    /// Where the machine came from (a file, or the built-in one).
    pub machine_source: Source,
    /// Values outside their field's plausible range (likely unit slips).
    pub warnings: &'a [Warning],
    /// Remarks on how the options applied.
    pub notes: &'a [String],
    /// Whether implausible values were refused (`--strict`).
    pub strict: bool,
    /// The controller the result is computed under and where it came from.
    pub controller: &'a crate::ControllerUsed,
}

impl<'a> ResultDocument<'a> {
    /// The document of `delivery`, computed for `plan` as `from` says.
    pub fn new(plan: &ArcPlan, from: &Provenance<'a>, delivery: &'a Delivery) -> Self {
        ResultDocument {
            format: RESULT_FORMAT,
            arcsim_version: env!("CARGO_PKG_VERSION"),
            plan: plan.name.clone(),
            plan_file: from.plan_source.file.clone(),
            plan_sha256: from.plan_source.sha256.clone(),
            machine: from.machine.name.clone(),
            machine_file: from.machine_source.file.clone(),
            machine_sha256: from.machine_source.sha256.clone(),
            machine_model: from.machine,
            options: OptionsOut {
                schedule: delivery.schedule.name(),
                motion: delivery.motion.name(),
                arc_ends: delivery.arc_ends.name(),
                servo_period_s: delivery.servo_period_s,
                strict: from.strict,
                controller: from.controller.clone(),
            },
            warnings: from.warnings,
            notes: from.notes,
            delivery,
            spots: None,
            certificate: None,
            monte_carlo: None,
            switching: switching_of(plan, from.machine, delivery),
        }
    }

    /// The document with the per-spot timeline.
    pub fn with_spots(mut self, spots: &'a [SpotRow]) -> Self {
        self.spots = Some(spots);
        self
    }

    /// The document with the delivery's certificate.
    pub fn with_certificate(mut self, certificate: &'a Certificate) -> Self {
        self.certificate = Some(certificate);
        self
    }

    /// The document with a Monte Carlo of its total (`arcsim_evaluator::MonteCarlo` as JSON).
    pub fn with_monte_carlo(mut self, monte_carlo: serde_json::Value) -> Self {
        self.monte_carlo = Some(monte_carlo);
        self
    }

    /// The document as pretty-printed JSON, as `simulate --json` writes it.
    pub fn to_json(&self) -> Result<String, serde_json::Error> {
        serde_json::to_string_pretty(self)
    }
}

/// The format of a re-sequencing report.
pub const RESEQUENCE_FORMAT: &str = "arcsim-resequence/1";

/// The switching of a delivery of `plan` on `machine` (`None` if the plan does not resolve,
/// which a simulated plan does).
pub fn switching_of(
    plan: &ArcPlan,
    machine: &Machine,
    delivery: &Delivery,
) -> Option<arcsim_sequencer::Switching> {
    arcsim_plan::resolve(plan, machine).ok().map(|arcs| {
        arcsim_sequencer::Switching::of(
            &arcs,
            Some(delivery),
            &machine.elst,
            arcsim_sequencer::SMALL_UPWARD_STEP_MEV,
        )
    })
}

/// The `arcsim-resequence/1` report of re-sequencing `plan` on `machine` under `controller`, as
/// `resequence --json` writes it and Python's `resequence` returns it (docs/results.md).
pub fn resequence_report(
    plan: &ArcPlan,
    machine: &Machine,
    controller: &crate::ControllerUsed,
    out: &arcsim_resequence::Outcome,
) -> serde_json::Value {
    serde_json::json!({
        "format": RESEQUENCE_FORMAT,
        "plan": plan.name,
        "machine": machine.name,
        "controller": controller,
        "total_before_s": out.before.total_s,
        "total_after_s": out.after.total_s,
        "resequenced": out.chosen.is_some(),
        "moved_layers": out.moved_layers,
        "switching_before_s": out.switching_before_s,
        "switching_after_s": out.switching_after_s,
        "breakdown_before": out.before.breakdown,
        "breakdown_after": out.after.breakdown,
        "switching_before": switching_of(plan, machine, &out.before),
        "switching_after": switching_of(&out.plan, machine, &out.after),
        "candidates": out.candidates,
    })
}
