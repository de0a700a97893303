//! What `simulate` writes besides its summary: the spot and timeline CSVs, the virtual log and
//! the `--json` result document.

use std::path::Path;

use arcsim_sequencer::{Certificate, Delivery, GantryState, SpotRow};

use crate::table::{csv_table, Column};
use crate::CliError;

use super::Args;

/// The spot table: one row per spot delivery, columns named with their units (the burst and
/// spill indices last, so tables of machines without them keep their column positions).
const SPOT_COLUMNS: [Column<SpotRow>; 15] = [
    Column {
        name: "layer_index",
        get: |r| r.layer_index.to_string(),
    },
    Column {
        name: "arc",
        get: |r| r.arc.to_string(),
    },
    Column {
        name: "control_point",
        get: |r| r.control_point.to_string(),
    },
    Column {
        name: "layer",
        get: |r| r.layer.to_string(),
    },
    Column {
        name: "spot",
        get: |r| r.spot.to_string(),
    },
    Column {
        name: "painting",
        get: |r| r.painting.to_string(),
    },
    Column {
        name: "x_mm",
        get: |r| optional(r.x_mm),
    },
    Column {
        name: "y_mm",
        get: |r| optional(r.y_mm),
    },
    Column {
        name: "mu",
        get: |r| r.mu.to_string(),
    },
    Column {
        name: "t_start_s",
        get: |r| r.t_start_s.to_string(),
    },
    Column {
        name: "t_end_s",
        get: |r| r.t_end_s.to_string(),
    },
    Column {
        name: "angle_start_deg",
        get: |r| r.angle_start_deg.to_string(),
    },
    Column {
        name: "angle_end_deg",
        get: |r| r.angle_end_deg.to_string(),
    },
    Column {
        name: "burst",
        get: |r| r.burst.map(|b| b.to_string()).unwrap_or_default(),
    },
    Column {
        name: "spill",
        get: |r| r.spill.map(|b| b.to_string()).unwrap_or_default(),
    },
];

/// A number, or an empty field.
fn optional(x: Option<f64>) -> String {
    x.map(|v| v.to_string()).unwrap_or_default()
}

/// What `--log-period`, `--angle-noise-deg` and `--seed` ask of the virtual log.
pub(super) fn log_options(args: &Args) -> arcsim_log::VirtualLogOptions {
    arcsim_log::VirtualLogOptions {
        period_s: args.log_period,
        angle_noise_deg: args.angle_noise_deg,
        seed: args.seed,
    }
}

/// The virtual log of `--log`.
pub(super) fn write_log(
    path: &Path,
    delivery: &Delivery,
    spots: &[SpotRow],
    args: &Args,
) -> Result<(), CliError> {
    let samples = arcsim_log::virtual_log(delivery, spots, &log_options(args))
        .map_err(|e| CliError::usage(format!("--log: {e}")))?;
    crate::output::write_file(path, arcsim_log::to_csv(&samples).as_bytes())
}

/// `--record`: the delivery as a DICOM RT Ion Beams Treatment Record (one beam per arc, each
/// layer a pair of control points), referencing the plan when its file (`plan_bytes`, as read)
/// is a DICOM one.
pub(super) fn write_record(
    path: &Path,
    delivery: &Delivery,
    (plan, machine, plan_bytes): (&arcsim_plan::ArcPlan, &arcsim_plan::Machine, &[u8]),
    args: &Args,
) -> Result<(), CliError> {
    let failed = |e: String| CliError::failed(format!("--record: {e}"));
    let arcs = arcsim_plan::resolve(plan, machine).map_err(|e| failed(e.to_string()))?;
    let planned: Vec<&arcsim_plan::ResolvedLayer> =
        arcs.iter().flat_map(|a| a.layers.iter()).collect();
    let mut beams: Vec<arcsim_dicom::RecordedBeam> = Vec::new();
    for row in &delivery.layers {
        let mu = planned.get(row.index).map_or(0.0, |l| l.mu);
        if mu <= 0.0 {
            return Err(failed(format!(
                "layer {} (arc {}, control point {}) has no MU; a record holds each layer's delivered meterset, so the plan must give MU (spots' `mu`, or a layer's `mu`)",
                row.index, row.arc, row.control_point
            )));
        }
        // The gantry at beam on and off: the timeline's, else the layer's sweep centred on its
        // angle.
        let (on, off) = match &delivery.timeline {
            Some(tl) => (
                tl.state_at(row.t_start_s).angle_deg,
                tl.state_at(row.t_end_s).angle_deg,
            ),
            None => (row.angle_deg, row.angle_deg),
        };
        let interval = arcsim_dicom::BeamOnInterval {
            control_point: 0,
            interval: arcsim_log::BeamInterval {
                start_s: row.t_start_s,
                end_s: row.t_end_s,
                angle_start_deg: on,
                angle_end_deg: off,
                energy_mev: row.energy_mev,
                mu,
            },
        };
        let number = i64::try_from(row.arc).unwrap_or(i64::MAX).saturating_add(1);
        match beams.last_mut() {
            Some(b) if b.beam_number == Some(number) => b.intervals.push(interval),
            _ => beams.push(arcsim_dicom::RecordedBeam {
                beam_number: Some(number),
                termination: Some("NORMAL".into()),
                intervals: vec![interval],
            }),
        }
    }
    let start = arcsim_dicom::RecordStart::parse(&args.record_start)
        .map_err(|e| CliError::usage(format!("--record-start {e}")))?;
    let plan_uid = arcsim_dicom::sop_instance_uid_of(plan_bytes);
    let (bytes, _) = arcsim_dicom::treatment_record_bytes(
        &beams,
        start,
        args.record_time_digits,
        plan_uid.as_deref(),
    )
    .map_err(failed)?;
    crate::output::write_file(path, &bytes)
}

/// `--iba-log`: the delivery as an IBA-style log folder (one beam folder per arc).
pub(super) fn write_iba_log(
    dir: &Path,
    delivery: &Delivery,
    spots: &[SpotRow],
    args: &Args,
) -> Result<(), CliError> {
    let start = arcsim_log::iba::start_seconds(&args.record_start)
        .map_err(|e| CliError::usage(format!("--record-start {e}")))?;
    if spots.iter().any(|s| s.x_mm.is_none()) {
        return Err(CliError::failed(
            "--iba-log: the plan gives no spot positions; an IBA-style log records each spot's position (spots' `positions_mm`)".to_string(),
        ));
    }
    let files = arcsim_log::iba::iba_log_files(
        delivery,
        spots,
        start,
        &arcsim_log::iba::IbaNozzle::default(),
        args.iba_layout,
    );
    for (rel, text) in files {
        let path = dir.join(rel);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(|e| {
                CliError::failed(format!(
                    "--iba-log: cannot create {}: {e}",
                    parent.display()
                ))
            })?;
        }
        crate::output::write_file(&path, text.as_bytes())?;
    }
    Ok(())
}

pub(super) fn write_spots_csv(path: &Path, spots: &[SpotRow]) -> Result<(), CliError> {
    crate::output::write_file(path, &csv_table(&SPOT_COLUMNS, spots))
}

/// One sample of the timeline: time, gantry state, and the layer being irradiated (its index
/// and energy).
struct Sample {
    t: f64,
    state: GantryState,
    beam: Option<(usize, f64)>,
}

/// The columns of the timeline CSV.
const SAMPLE_COLUMNS: [Column<Sample>; 7] = [
    Column {
        name: "t_s",
        get: |s| format!("{:.6}", s.t),
    },
    Column {
        name: "angle_deg",
        get: |s| s.state.angle_deg.to_string(),
    },
    Column {
        name: "speed_deg_per_s",
        get: |s| s.state.speed_deg_per_s.to_string(),
    },
    Column {
        name: "accel_deg_per_s2",
        get: |s| s.state.accel_deg_per_s2.to_string(),
    },
    Column {
        name: "jerk_deg_per_s3",
        get: |s| s.state.jerk_deg_per_s3.to_string(),
    },
    Column {
        name: "beam_layer",
        get: |s| s.beam.map(|(l, _)| l.to_string()).unwrap_or_default(),
    },
    Column {
        name: "energy_mev",
        get: |s| optional(s.beam.map(|(_, e)| e)),
    },
];

pub(super) fn write_csv(path: &Path, d: &Delivery, dt: f64) -> Result<(), CliError> {
    let tl = d
        .timeline
        .as_ref()
        .ok_or_else(|| CliError::failed("no timeline was built"))?;
    let samples = tl.samples(dt).into_iter().map(|(t, state)| Sample {
        t,
        state,
        beam: tl
            .beam_layer_at(t)
            .map(|l| (l, d.layers.get(l).map_or(f64::NAN, |x| x.energy_mev))),
    });
    crate::output::write_file(path, &csv_table(&SAMPLE_COLUMNS, samples))
}

/// What `--json` adds to the delivery, when asked for.
pub(super) struct Extras<'a> {
    pub(super) spots: Option<&'a [SpotRow]>,
    pub(super) certificate: Option<&'a Certificate>,
    pub(super) monte_carlo: Option<&'a arcsim_evaluator::MachineMonteCarlo>,
}

/// The `--json` result document.
pub(super) fn write_json(
    path: &Path,
    args: &Args,
    (plan, plan_sha256, machine, machine_sha256): (
        &arcsim_plan::ArcPlan,
        &str,
        &arcsim_plan::Machine,
        &str,
    ),
    delivery: &Delivery,
    (warnings, notes, controller): (
        &[arcsim_plan::Warning],
        &[String],
        &arcsim_app::ControllerUsed,
    ),
    extras: &Extras,
) -> Result<(), CliError> {
    let from = arcsim_app::Provenance {
        plan_source: arcsim_app::Source {
            file: crate::input::input_name(&args.plan),
            sha256: plan_sha256.to_string(),
        },
        machine,
        machine_source: arcsim_app::Source {
            file: crate::input::machine_name(args.machine.as_deref()),
            sha256: machine_sha256.to_string(),
        },
        warnings,
        notes,
        strict: args.strict,
        controller,
    };
    let mut doc = arcsim_app::ResultDocument::new(plan, &from, delivery);
    if let Some(spots) = extras.spots {
        doc = doc.with_spots(spots);
    }
    if let Some(c) = extras.certificate {
        doc = doc.with_certificate(c);
    }
    if let Some(mc) = extras.monte_carlo {
        let value = serde_json::to_value(mc).map_err(|e| CliError::failed(e.to_string()))?;
        doc = doc.with_monte_carlo(value);
    }
    let text = doc.to_json().map_err(|e| CliError::failed(e.to_string()))?;
    crate::output::write_file(path, text.as_bytes())
}
