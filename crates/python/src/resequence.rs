//! `resequence`: the same dose delivered faster, as `arcsim resequence` finds it.

use std::panic::{catch_unwind, AssertUnwindSafe};

use arcsim_app::{sha256_hex, SimulateRequest, Source};
use arcsim_resequence::{check_same_dose, resequence as find, ArcFreedom, ResequenceOptions};
use pyo3::prelude::*;
use pyo3::types::PyAny;

use crate::convert::serde_to_py;
use crate::inputs::{Machine, Plan};
use crate::simulate::{motion_of, schedule_opt};
use crate::{PlanError, SimulationError};

/// The plan with each control point's layers in the order the machine delivers fastest (every
/// spot, MU, energy and control point kept, checked), and the report `arcsim resequence --json`
/// writes (dict: total_before_s, total_after_s, resequenced, moved_layers, breakdowns and
/// switching before and after, candidates). `turn_arcs` also tries arcs turned and reordered;
/// `search_layers` is the search's budget in layers simulated (None: the CLI's default). The
/// plan as given is returned where no order is faster. The GIL is released while it runs.
#[pyfunction]
#[pyo3(signature = (plan, machine=None, schedule=None, motion=None, turn_arcs=false, search_layers=None))]
pub fn resequence<'py>(
    py: Python<'py>,
    plan: &Bound<'py, Plan>,
    machine: Option<&Bound<'py, Machine>>,
    schedule: Option<&str>,
    motion: Option<&str>,
    turn_arcs: bool,
    search_layers: Option<usize>,
) -> PyResult<(Plan, Bound<'py, PyAny>)> {
    let plan = plan.get();
    let builtin;
    let machine = match machine {
        Some(m) => m.get(),
        None => {
            builtin = Machine::builtin();
            &builtin
        }
    };
    let request = SimulateRequest {
        schedule: schedule_opt(schedule)?,
        motion: motion_of(motion)?,
        arc_ends: arcsim_sequencer::ArcEnds::Rest,
        period_s: None,
    };
    let (simulation, _, controller) = request.resolve(&plan.plan, &machine.machine);
    let opts = ResequenceOptions {
        simulation,
        arcs: if turn_arcs {
            ArcFreedom::Turn
        } else {
            ArcFreedom::Keep
        },
        search_layer_budget: search_layers.unwrap_or(arcsim_resequence::SEARCH_LAYER_BUDGET),
        exhaustive: true,
    };
    let result = py.detach(|| {
        catch_unwind(AssertUnwindSafe(|| {
            find(&plan.plan, &machine.machine, &opts)
        }))
    });
    let out = match result {
        Ok(Ok(out)) => out,
        Ok(Err(arcsim_resequence::ResequenceError::Original(
            e @ arcsim_sequencer::SequenceError::Plan(_),
        ))) => return Err(PlanError::new_err(e.to_string())),
        Ok(Err(e)) => return Err(SimulationError::new_err(e.to_string())),
        Err(_) => {
            return Err(SimulationError::new_err(
                "re-sequencing panicked (a bug in arcsim)",
            ))
        }
    };
    check_same_dose(&plan.plan, &out.plan)
        .map_err(|e| SimulationError::new_err(format!("a bug: {e}")))?;
    let report = arcsim_app::resequence_report(&plan.plan, &machine.machine, &controller, &out);
    let json = arcsim_plan::to_json(&out.plan);
    let resequenced = Plan {
        plan: out.plan,
        source: Source {
            file: format!("resequence({})", plan.source.file),
            sha256: sha256_hex(json.as_bytes()),
        },
    };
    Ok((resequenced, serde_to_py(py, &report)?))
}

/// Writes `plan`, re-sequenced from the DICOM RT Ion Plan file `original` (its layers reordered
/// inside their control points, as `resequence` without `turn_arcs` returns it), back as a DICOM
/// RT Ion Plan at `path`, as `arcsim resequence ORIGINAL -o PATH.dcm` does: the original with its
/// layers' control points in the new order, a new SOPInstanceUID referencing the original,
/// ApprovalStatus UNAPPROVED. The file is read back before it is written. Returns the new
/// SOPInstanceUID. Raises PlanError when `plan` is not `original`'s layers reordered, OSError when
/// a file cannot be read or written.
#[pyfunction]
pub fn write_resequenced_dicom(
    plan: &Bound<'_, Plan>,
    original: std::path::PathBuf,
    path: std::path::PathBuf,
) -> PyResult<String> {
    let os = |p: &std::path::Path, e: std::io::Error| {
        pyo3::exceptions::PyOSError::new_err(format!("{}: {e}", p.display()))
    };
    let bytes = std::fs::read(&original).map_err(|e| os(&original, e))?;
    let written = arcsim_dicom::write_resequenced(&bytes, &plan.get().plan)
        .map_err(|e| PlanError::new_err(format!("{}: {e}", original.display())))?;
    std::fs::write(&path, &written.bytes).map_err(|e| os(&path, e))?;
    Ok(written.sop_instance_uid)
}
