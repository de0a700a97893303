//! How a machine's gantry moves: its controller. A property of the machine (its file says which,
//! with a source), because the same limits give different delivery times under different
//! controllers, and a calibration fitted under the wrong one is wrong everywhere.
//!
//! A controller is a [`Motion`] (the law of motion during and between layers) and a [`Schedule`]
//! (how the constant layer speeds are chosen; free motion starts from them). Adding a controller
//! is a new [`Motion`] variant with its facts here (name, description, what it accepts) and its
//! solver file in the sequencer, dispatched from one `match` there; every command lists, parses,
//! checks and reports controllers through [`Motion::ALL`] and these facts, never by variant.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// A name that is none of a choice's names (schedule, motion, arc ends).
#[derive(Debug, Error)]
#[error("unknown {what} '{name}' (expected {expected})")]
pub struct UnknownName {
    /// What was named ("schedule", "motion", "arc ends").
    pub what: &'static str,
    /// The name given.
    pub name: String,
    /// The names it may be.
    pub expected: String,
}

/// How layer speeds are chosen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Schedule {
    /// The plan's required speeds, checked; infeasible ones are reported and corrected minimally.
    Prescribed,
    /// Bidirectional scan: window/V caps, then backward and forward passes until feasible, then
    /// lower speeds where a transition would stop and dwell to last its ELST, then a local search
    /// over single speeds and neighbour pairs.
    Scan,
    /// The least total delivery time found over the layer speeds (dynamic programming over
    /// refined speed grids; a local search, never worse than `Scan`).
    #[default]
    Optimal,
    /// The gantry stops at every layer (the classic baseline).
    StepAndShoot,
}

impl Schedule {
    /// Every schedule, in the order the CLI lists them.
    pub const ALL: [Schedule; 4] = [
        Schedule::Prescribed,
        Schedule::Scan,
        Schedule::Optimal,
        Schedule::StepAndShoot,
    ];

    /// The name the CLI and the files use.
    pub fn name(self) -> &'static str {
        match self {
            Schedule::Prescribed => "prescribed",
            Schedule::Scan => "scan",
            Schedule::Optimal => "optimal",
            Schedule::StepAndShoot => "step-and-shoot",
        }
    }
}

impl std::str::FromStr for Schedule {
    type Err = UnknownName;
    fn from_str(s: &str) -> Result<Self, UnknownName> {
        Schedule::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| UnknownName {
                what: "schedule",
                name: s.to_string(),
                expected: "prescribed, scan, optimal or step-and-shoot".into(),
            })
    }
}

/// How the gantry moves while a layer is irradiated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Motion {
    /// ATOM's rule: one constant speed per layer, its sweep centred on the layer's angle, zero
    /// acceleration at every beam-on and beam-off.
    #[default]
    Constant,
    /// The machine's own limits only: the gantry may speed up or slow down while the beam is on,
    /// anywhere inside the layer's window.
    Free,
    /// One constant gantry speed for the whole arc (the AAPM 2026 one-speed workflow: the beam's
    /// intensity is adapted so each layer fits its window at that speed): the first and last
    /// layers at rest, every other layer and every move between them at the arc's one speed.
    OneSpeed,
}

impl Motion {
    /// Every motion model, in the order the CLI lists them.
    pub const ALL: [Motion; 3] = [Motion::Constant, Motion::Free, Motion::OneSpeed];

    /// The name the CLI and the files use.
    pub fn name(self) -> &'static str {
        match self {
            Motion::Constant => "constant",
            Motion::Free => "free",
            Motion::OneSpeed => "one-speed",
        }
    }

    /// What the model is, in a few words, for summaries.
    pub fn describe(self) -> &'static str {
        match self {
            Motion::Constant => "constant speed per layer",
            Motion::Free => "free motion (speed may change during beam-on)",
            Motion::OneSpeed => "one constant speed per arc (AAPM 2026 one-speed workflow)",
        }
    }

    /// The model's name in a sentence, without [`Motion::describe`]'s parenthesis ("free motion
    /// saves …").
    pub fn short(self) -> &'static str {
        match self {
            Motion::Constant => "constant speed per layer",
            Motion::Free => "free motion",
            Motion::OneSpeed => "one constant speed per arc",
        }
    }

    /// The model as an adjective, for tables and what-if lines ("free-motion total").
    pub fn adjective(self) -> &'static str {
        match self {
            Motion::Constant => "constant-speed",
            Motion::Free => "free-motion",
            Motion::OneSpeed => "one-speed",
        }
    }

    /// Whether the gantry's speed may change while a layer is irradiated; only such a model may
    /// leave an arc's ends free (a run-up through the first layer, braking after the last).
    pub fn speed_changes_during_beam(self) -> bool {
        matches!(self, Motion::Free)
    }

    /// Why the model cannot run on a servo period, if it cannot (its moves are not built of whole
    /// periods); `None` where it can.
    pub fn continuous_time_only(self) -> Option<&'static str> {
        match self {
            Motion::Constant => None,
            Motion::Free => Some("its solver switches jerk at any instant; a version whose jerk holds over whole servo periods is not built"),
            Motion::OneSpeed => Some("its cruises between layers last gap / speed, not whole servo periods"),
        }
    }

    /// Whether the model takes its layer speeds from `schedule`: constant speed per layer takes
    /// every schedule; free motion starts from a searched one (`scan` or `optimal`); one speed
    /// per arc sets its own and accepts those two as the sweep's default, not the others, which
    /// fix the speeds.
    pub fn accepts_schedule(self, schedule: Schedule) -> bool {
        match self {
            Motion::Constant => true,
            Motion::Free | Motion::OneSpeed => {
                matches!(schedule, Schedule::Scan | Schedule::Optimal)
            }
        }
    }

    /// Whether a calibration can fit a machine's timings under this model from logs (and so
    /// whether `calibrate` weighs it when it learns the controller).
    pub fn calibrates_from_logs(self) -> bool {
        matches!(self, Motion::Constant | Motion::Free)
    }

    /// The names of every model, for errors ("constant, free or one-speed").
    pub fn names() -> String {
        Motion::names_where(|_| true)
    }

    /// The names of the models `keep` keeps, for errors ("constant or free").
    pub fn names_where(keep: impl Fn(Motion) -> bool) -> String {
        let names: Vec<&str> = Motion::ALL
            .into_iter()
            .filter(|&m| keep(m))
            .map(Motion::name)
            .collect();
        match names.split_last() {
            Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
            _ => names.join(""),
        }
    }
}

impl std::str::FromStr for Motion {
    type Err = UnknownName;
    fn from_str(s: &str) -> Result<Self, UnknownName> {
        Motion::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| UnknownName {
                what: "motion",
                name: s.to_string(),
                expected: Motion::names(),
            })
    }
}

/// A machine's controller as its file states it: the motion model, the schedule of the constant
/// layer speeds, and where that knowledge comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Controller {
    /// How the gantry moves during and between layers.
    pub motion: Motion,
    /// How the constant layer speeds are chosen (free motion starts from them).
    #[serde(default)]
    pub schedule: Schedule,
    /// Where this comes from: a publication, a calibration from logs, or `assumed: <why>`.
    pub source: String,
    /// How a calibration decided it from logs (written by `arcsim calibrate`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub evidence: Option<ControllerEvidence>,
}

/// What logs showed of a machine's controller: each model simulated, its timing error against
/// the logged layers, and the decision with its rule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerEvidence {
    /// The logs the decision was made from.
    pub logs: Vec<String>,
    /// Per motion model, the rms of (logged − simulated) layer beam-on start times, s, over every
    /// layer of every log (each log's offset removed).
    pub rms_beam_on_start_s: BTreeMap<String, f64>,
    /// `chosen` (the best model's error is at least [`CONTROLLER_DECISION_RATIO`] times smaller
    /// than every other's), `not determined` (the base's kept) or `forced` (`--motion`).
    pub decision: String,
}

/// How many times smaller a model's timing error must be than every other's to be chosen from
/// logs (issue 44's rule: a factor 3 separates the models well above timing noise).
pub const CONTROLLER_DECISION_RATIO: f64 = 3.0;

/// The source written for a machine file that names no controller.
pub const ASSUMED_CONTROLLER_SOURCE: &str = "assumed: the machine file names no controller; arcsim assumes ATOM's published model (one constant speed per layer, Wase et al., Phys. Med. Biol. 2024) with the optimal schedule";

impl Controller {
    /// The controller of a machine file that names none ([`ASSUMED_CONTROLLER_SOURCE`]).
    pub fn assumed() -> Controller {
        Controller {
            motion: Motion::Constant,
            schedule: Schedule::Optimal,
            source: ASSUMED_CONTROLLER_SOURCE.into(),
            evidence: None,
        }
    }

    /// Whether the source says the controller is an assumption.
    pub fn is_assumed(&self) -> bool {
        self.source
            .trim_start()
            .to_ascii_lowercase()
            .starts_with("assumed")
    }
}
