//! The plans a sweep file names: paths and globs, named paths, ATOM article cases.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use arcsim_plan::ArcPlan;

use super::*;
use crate::sweep_file::{PlanSource, SweepFile};
use crate::EvalError;

/// The plans of a sweep file, in its order (a glob's matches sorted); `inputs` gets every file
/// read, for the run's input list.
pub(super) fn load_plans(
    spec: &SweepFile,
    base_dir: &Path,
    file: &str,
    load_plan: &dyn Fn(&Path) -> Result<ArcPlan, String>,
    inputs: &mut Vec<PathBuf>,
) -> Result<Vec<SweepPlan>, EvalError> {
    if spec.plans.is_empty() {
        return Err(EvalError::sweep(
            file,
            "plans",
            "expected at least one plan; an empty sweep has nothing to run",
        ));
    }
    let mut plans = Vec::new();
    let mut references: HashMap<PathBuf, String> = HashMap::new();
    for (i, source) in spec.plans.iter().enumerate() {
        let field = format!("plans[{i}]");
        let at = At {
            base_dir,
            file,
            field: &field,
        };
        match source {
            PlanSource::Path(pattern) => {
                for (p, plan) in at.glob_plans(pattern, load_plan)? {
                    let label = p
                        .strip_prefix(base_dir)
                        .unwrap_or(&p)
                        .to_string_lossy()
                        .replace('\\', "/");
                    plans.push(SweepPlan { label, plan });
                    inputs.push(p);
                }
            }
            PlanSource::Named { path, name } => {
                if name.trim().is_empty() || plans.iter().any(|p: &SweepPlan| &p.label == name) {
                    return Err(EvalError::sweep(
                        file,
                        format!("{field}.name"),
                        format!(
                            "\"{name}\": expected a name for the plan's rows that no earlier plan has"
                        ),
                    ));
                }
                let full = base_dir.join(path);
                let plan = load_plan(&full).map_err(|message| EvalError::Input {
                    file: file.to_string(),
                    field: format!("{field}.path"),
                    message,
                })?;
                plans.push(SweepPlan {
                    label: name.clone(),
                    plan,
                });
                inputs.push(full);
            }
            PlanSource::AtomCase {
                atom_case,
                reference,
            } => {
                let plan = at.atom_case(atom_case, reference, &mut references, inputs)?;
                plans.push(SweepPlan {
                    label: format!("atom:{atom_case}"),
                    plan,
                });
            }
        }
    }
    Ok(plans)
}

/// The label suffix of a re-sequenced plan's rows.
pub const RESEQUENCED_SUFFIX: &str = " (re-sequenced)";

/// `plans` as the sweep file's `resequence` asks: (as given, re-sequenced) say which to keep;
/// each re-sequenced twin is found on `machine` under its controller (in parallel) and follows
/// its plan.
pub(super) fn with_resequenced(
    plans: Vec<SweepPlan>,
    machine: &arcsim_plan::Machine,
    (as_given, resequenced): (bool, bool),
    file: &str,
) -> Result<(Vec<SweepPlan>, Vec<super::ResequencedPlan>), EvalError> {
    if !as_given && !resequenced {
        return Err(EvalError::sweep(
            file,
            "resequence",
            "expected true, false or a list holding at least one of them",
        ));
    }
    if !resequenced {
        return Ok((plans, Vec::new()));
    }
    let controller = machine.controller_or_assumed();
    let mut simulation = arcsim_sequencer::Options {
        motion: controller.motion,
        schedule: controller.schedule,
        servo_period_s: machine.servo_period_s,
        ..arcsim_sequencer::Options::default()
    };
    if simulation.servo_period_s.is_some() && controller.motion.continuous_time_only().is_some() {
        simulation.motion = arcsim_sequencer::Motion::Constant;
    }
    let opts = arcsim_resequence::ResequenceOptions {
        simulation,
        ..arcsim_resequence::ResequenceOptions::default()
    };
    use rayon::prelude::*;
    let found: Vec<Result<arcsim_resequence::Outcome, String>> = plans
        .par_iter()
        .map(|p| arcsim_resequence::resequence(&p.plan, machine, &opts).map_err(|e| e.to_string()))
        .collect();
    let mut out = Vec::new();
    let mut report = Vec::new();
    for (i, (p, f)) in plans.into_iter().zip(found).enumerate() {
        let f = f.map_err(|message| {
            EvalError::sweep(
                file,
                "resequence",
                format!(
                    "plan {i} (\"{}\"): cannot be re-sequenced: {message}",
                    p.label
                ),
            )
        })?;
        let twin = format!("{}{RESEQUENCED_SUFFIX}", p.label);
        report.push(super::ResequencedPlan {
            label: p.label.clone(),
            twin: twin.clone(),
            before_s: f.before.total_s,
            after_s: f.after.total_s,
            moved_layers: f.moved_layers,
        });
        if as_given {
            out.push(p);
        }
        out.push(SweepPlan {
            label: twin,
            plan: f.plan,
        });
    }
    Ok((out, report))
}

/// Where a plan source is: the sweep file's directory, its name, and the source's field.
struct At<'a> {
    base_dir: &'a Path,
    file: &'a str,
    field: &'a str,
}

impl At<'_> {
    /// The plans of the files `pattern` matches (at least one), sorted by path.
    fn glob_plans(
        &self,
        pattern: &str,
        load_plan: &dyn Fn(&Path) -> Result<ArcPlan, String>,
    ) -> Result<Vec<(PathBuf, ArcPlan)>, EvalError> {
        let (file, field) = (self.file, self.field);
        let full = self.base_dir.join(pattern);
        let full_str = full
            .to_str()
            .ok_or_else(|| EvalError::sweep(file, field, "expected a UTF-8 path"))?;
        let paths = glob::glob(full_str)
            .map_err(|e| EvalError::sweep(file, field, format!("bad glob \"{pattern}\": {e}")))?;
        let mut paths: Vec<PathBuf> = paths.collect::<Result<_, _>>().map_err(|e| {
            EvalError::sweep(file, field, format!("cannot list \"{pattern}\": {e}"))
        })?;
        paths.sort();
        if paths.is_empty() {
            return Err(EvalError::sweep(
                file,
                field,
                format!(
                    "\"{pattern}\" matches no file (relative to {})",
                    dir_name(self.base_dir)
                ),
            ));
        }
        paths
            .into_iter()
            .map(|p| {
                let plan = load_plan(&p).map_err(|message| EvalError::Input {
                    file: file.to_string(),
                    field: field.to_string(),
                    message,
                })?;
                Ok((p, plan))
            })
            .collect()
    }

    /// The plan of an ATOM article case from its reference file, each reference file read once
    /// (`references`, and added to `inputs` when first read).
    fn atom_case(
        &self,
        atom_case: &str,
        reference: &str,
        references: &mut HashMap<PathBuf, String>,
        inputs: &mut Vec<PathBuf>,
    ) -> Result<ArcPlan, EvalError> {
        let (file, field) = (self.file, self.field);
        let path = self.base_dir.join(reference);
        let text = match references.get(&path) {
            Some(t) => t.clone(),
            None => {
                let t = std::fs::read_to_string(&path).map_err(|e| {
                    EvalError::sweep(
                        file,
                        format!("{field}.reference"),
                        format!("cannot read {}: {e}", path.display()),
                    )
                })?;
                references.insert(path.clone(), t.clone());
                inputs.push(path.clone());
                t
            }
        };
        // The reference file is named: a wrong one is found without guessing.
        arcsim_plan::atom_case_plan(&text, atom_case).map_err(|e| {
            EvalError::sweep(
                file,
                format!("{field}.atom_case"),
                format!("reference {}: {e}", path.display()),
            )
        })
    }
}

pub(super) fn dir_name(dir: &Path) -> String {
    if dir.as_os_str().is_empty() {
        ".".into()
    } else {
        dir.display().to_string()
    }
}
