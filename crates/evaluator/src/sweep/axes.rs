//! The schedule grids of a sweep file's axes, and the checks of the axes' values.

use std::collections::HashMap;

use arcsim_plan::{BeamModel, ElstModel, Machine};
use arcsim_sequencer::{ArcEnds, Motion};

use super::*;
use crate::sweep_file::{Axes, AxisSpec, Scale, SweepFile};
use crate::{EvalError, RunMode};

/// Refuses a sweep whose combinations (`plans` × the grids' points; per plan when `plans` is not
/// known yet) overflow `usize` or exceed [`MAX_COMBINATIONS`], naming the count.
pub(crate) fn check_combinations<'a>(
    file: &str,
    plans: Option<usize>,
    grids: impl IntoIterator<Item = &'a Grid>,
) -> Result<(), EvalError> {
    let per_plan = grids
        .into_iter()
        .try_fold(0usize, |n, g| n.checked_add(g.checked_len()?));
    let total = per_plan.and_then(|n| n.checked_mul(plans.unwrap_or(1)));
    if total.is_some_and(|n| n <= MAX_COMBINATIONS) {
        return Ok(());
    }
    let count = |n: Option<usize>| match n {
        Some(n) => n.to_string(),
        None => format!("2^{} or more", usize::BITS),
    };
    let what = match plans {
        None => format!(
            "{} combinations per plan (grid points summed over the schedule entries)",
            count(per_plan)
        ),
        Some(p) => format!(
            "{} combinations ({p} plan{} × {} grid points summed over the schedule entries)",
            count(total),
            if p == 1 { "" } else { "s" },
            count(per_plan)
        ),
    };
    Err(EvalError::sweep(
        file,
        "",
        format!("{what}; expected at most {MAX_COMBINATIONS} (the most combinations a sweep may have): use fewer steps, values, schedules or plans"),
    ))
}

pub(super) fn expand_runs(
    spec: &SweepFile,
    machine: &Machine,
    file: &str,
) -> Result<Vec<ScheduleGrid>, EvalError> {
    if spec.schedules.is_empty() {
        return Err(EvalError::sweep(
            file,
            "schedules",
            "expected at least one schedule; an empty sweep has nothing to run",
        ));
    }
    let g = &machine.gantry;
    // Ranges whose values are checked distinct once the size of the sweep is known to be sane
    // (that check walks the range).
    let mut ranges: Vec<(String, AxisSpec)> = Vec::new();
    let runs = spec
        .schedules
        .iter()
        .enumerate()
        .map(|(i, entry)| {
            let own = entry.axes.as_ref();
            let pick = |f: fn(&Axes) -> &Option<AxisSpec>| -> (Option<&AxisSpec>, String) {
                match own.and_then(|a| f(a).as_ref()) {
                    Some(a) => (Some(a), format!("schedules[{i}].axes")),
                    None => (f(&spec.axes).as_ref(), "axes".to_string()),
                }
            };
            let mut checked = |f: fn(&Axes) -> &Option<AxisSpec>,
                               axis: Axis|
             -> Result<Option<AxisSpec>, EvalError> {
                let (a, at) = pick(f);
                let field = format!("{at}.{}", axis.field());
                let Some(a) = a else { return Ok(None) };
                if let Some(why) = refusal(axis, machine) {
                    return Err(EvalError::sweep(file, field, why));
                }
                check_values(a, axis, &field, file, machine)?;
                if matches!(a, AxisSpec::Range { .. }) && !ranges.iter().any(|(f, _)| *f == field) {
                    ranges.push((field, a.clone()));
                }
                Ok(Some(a.clone()))
            };
            let jerk = checked(|a| &a.jerk_deg_per_s3, Axis::Jerk)?;
            let accel = checked(|a| &a.accel_deg_per_s2, Axis::Accel)?;
            let speed = checked(|a| &a.speed_deg_per_s, Axis::Speed)?;
            let elst_up = checked(|a| &a.elst_up_s, Axis::ElstUp)?;
            let elst_down = checked(|a| &a.elst_down_s, Axis::ElstDown)?;
            let window = checked(|a| &a.window_deg, Axis::Window)?;
            let scan_speed = checked(|a| &a.scan_speed_mm_per_s, Axis::ScanSpeed)?;
            let dose_rate_scale = checked(|a| &a.dose_rate_scale, Axis::DoseRateScale)?;
            let burst_switching = checked(|a| &a.burst_switching_time_s, Axis::BurstSwitching)?;
            let spill_charge = checked(|a| &a.spill_charge_mu, Axis::SpillCharge)?;
            let spill_refill = checked(|a| &a.spill_refill_time_s, Axis::SpillRefill)?;
            let spill_max_layers = checked(|a| &a.spill_max_layers, Axis::SpillMaxLayers)?;
            let limit = |a: Option<AxisSpec>, base: f64| a.unwrap_or(AxisSpec::Values(vec![base]));
            let grid = Grid {
                jerk: limit(jerk, g.max_jerk_deg_per_s3),
                accel: limit(accel, g.max_accel_deg_per_s2),
                speed: limit(speed, g.max_speed_deg_per_s),
                elst_up,
                elst_down,
                window,
                scan_speed,
                dose_rate_scale,
                burst_switching,
                spill_charge,
                spill_refill,
                spill_max_layers,
            };
            Ok(ScheduleGrid {
                schedule: RunMode {
                    schedule: entry.schedule,
                    motion: entry_motion(entry, machine, file, &format!("schedules[{i}]"))?,
                    arc_ends: entry.arc_ends,
                },
                grid,
            })
        })
        .collect::<Result<Vec<ScheduleGrid>, EvalError>>()?;
    // At least one plan: refuse an absurd grid before walking its ranges or loading any plan.
    check_combinations(file, None, runs.iter().map(|r| &r.grid))?;
    for (field, range) in &ranges {
        check_range_distinct(range, field, file)?;
    }
    Ok(runs)
}

/// An entry's motion: its own, else the base machine's controller's (constant speed where the
/// schedule is `prescribed` or `step-and-shoot`, as `simulate` does); free arc ends need free
/// motion.
fn entry_motion(
    entry: &crate::sweep_file::ScheduleEntry,
    machine: &Machine,
    file: &str,
    at: &str,
) -> Result<Motion, EvalError> {
    let motion = entry.motion.unwrap_or_else(|| {
        let own = machine.controller_or_assumed().motion;
        if own.accepts_schedule(entry.schedule) {
            own
        } else {
            Motion::Constant
        }
    });
    // A schedule the motion does not take (step-and-shoot or prescribed with free motion) would
    // fail on every row of the sweep: refused here, at the entry.
    if !motion.accepts_schedule(entry.schedule) {
        return Err(EvalError::sweep(
            file,
            format!("{at}.motion"),
            format!(
                "{} chooses its own speeds: expected the optimal or scan schedule with it, not {}",
                motion.describe(),
                entry.schedule.name()
            ),
        ));
    }
    if !motion.speed_changes_during_beam() && entry.arc_ends == ArcEnds::Free {
        return Err(EvalError::sweep(
            file,
            format!("{at}.arc_ends"),
            format!("\"free\" needs free motion (a {} arc starts and ends at rest); the entry's motion is {}: give \"motion\": \"free\"", motion.adjective(), motion.describe()),
        ));
    }
    Ok(motion)
}

/// Why `machine` cannot have `axis` swept: an ELST model without the single value, or a beam
/// model without the scanning speed, bursts or spills the axis sets.
fn refusal(axis: Axis, machine: &Machine) -> Option<String> {
    if let Some(why) = elst_not_sweepable(axis, machine) {
        return Some(why);
    }
    if let (Some((lacks, sweeps)), BeamModel::PerMu(_)) = (axis.scanning_only(), &machine.beam) {
        return Some(format!("machine \"{}\": its beam model has no {lacks} (kind per_mu); expected a beam model of kind scanning to sweep {sweeps}", machine.name));
    }
    if let (Some(sweeps), None) = (axis.spill_only(), machine.beam.spill()) {
        return Some(format!("machine \"{}\": its beam model has no spills (kind {}, no `spill`); expected a `scanning` beam model with a `spill` to sweep {sweeps}", machine.name, machine.beam.kind()));
    }
    None
}

/// Checks an axis' values: the rules of every axis, those of its own quantity, and that the
/// machine accepts its extremes.
fn check_values(
    a: &AxisSpec,
    axis: Axis,
    field: &str,
    file: &str,
    machine: &Machine,
) -> Result<(), EvalError> {
    let zero_ok = matches!(
        axis,
        Axis::ElstUp | Axis::ElstDown | Axis::BurstSwitching | Axis::SpillRefill
    );
    check_axis(a, field, file, zero_ok)?;
    if axis == Axis::DoseRateScale {
        check_dose_rate_scales(a, field, file)?;
    }
    if axis == Axis::SpillMaxLayers {
        check_layer_counts(a, field, file, machine)?;
    }
    check_machine_values(a, axis, field, file, machine)
}

/// Checks one axis without walking a range: at least one value and at most
/// [`MAX_COMBINATIONS`], each finite and > 0 (>= 0 when `zero_ok`), no value of a list twice; a
/// range's ends likewise (> 0 on a log scale), and one step only when `from` equals `to`.
/// Whether a range's values are distinct is [`check_range_distinct`]'s.
pub(super) fn check_axis(
    spec: &AxisSpec,
    field: &str,
    file: &str,
    zero_ok: bool,
) -> Result<(), EvalError> {
    let bad = |sub: &str, msg: String| EvalError::sweep(file, format!("{field}{sub}"), msg);
    let lower = if zero_ok {
        "finite and >= 0"
    } else {
        "finite and > 0"
    };
    let ok = |x: f64| x.is_finite() && (x > 0.0 || (zero_ok && x == 0.0));
    match *spec {
        AxisSpec::Values(ref v) if v.is_empty() => Err(bad(
            "",
            "expected at least one value; an axis with no values makes an empty sweep".into(),
        )),
        AxisSpec::Values(ref v) => {
            if v.len() > MAX_COMBINATIONS {
                return Err(bad(
                    "",
                    format!("{} values; expected at most {MAX_COMBINATIONS}", v.len()),
                ));
            }
            if let Some((i, x)) = v.iter().enumerate().find(|(_, &x)| !ok(x)) {
                return Err(bad(
                    &format!("[{i}]"),
                    format!("expected a value {lower}, got {x}"),
                ));
            }
            let mut seen = HashMap::new();
            for (i, x) in v.iter().enumerate() {
                if let Some(j) = seen.insert(x.to_bits(), i) {
                    return Err(bad("", twice(*x, j, i)));
                }
            }
            Ok(())
        }
        AxisSpec::Range { steps: 0, .. } => Err(bad(
            ".steps",
            "expected at least 1 step; an axis with no values makes an empty sweep".into(),
        )),
        AxisSpec::Range { steps, .. } if steps > MAX_COMBINATIONS => Err(bad(
            ".steps",
            format!("{steps} steps; expected at most {MAX_COMBINATIONS} (the most combinations a sweep may have)"),
        )),
        AxisSpec::Range {
            from,
            to,
            steps,
            scale,
        } => {
            for (name, x) in [("from", from), ("to", to)] {
                let positive = x.is_finite() && x > 0.0;
                if !ok(x) || (scale == Scale::Log && !positive) {
                    let need = if scale == Scale::Log {
                        "finite and > 0 (log scale)"
                    } else {
                        lower
                    };
                    return Err(bad(
                        &format!(".{name}"),
                        format!("expected a value {need}, got {x}"),
                    ));
                }
            }
            if steps == 1 && from != to {
                return Err(bad(
                    ".steps",
                    format!("1 step gives only `from` ({from}), not `to` ({to}); expected at least 2 steps, or `to` equal to `from`"),
                ));
            }
            Ok(())
        }
    }
}

/// Accepted dose-rate scales (from a thousandth to a thousand times the base machine's dose rate).
pub const DOSE_RATE_SCALE_RANGE: (f64, f64) = (1e-3, 1e3);

/// An axis' values as written, located: each value of a list, or a range's ends.
fn listed(spec: &AxisSpec, field: &str) -> Vec<(String, f64)> {
    match spec {
        AxisSpec::Values(v) => v
            .iter()
            .enumerate()
            .map(|(i, &x)| (format!("{field}[{i}]"), x))
            .collect(),
        AxisSpec::Range { from, to, .. } => vec![
            (format!("{field}.from"), *from),
            (format!("{field}.to"), *to),
        ],
    }
}

/// Layers per spill: a list of whole numbers from 1 (a range would give fractions), on a machine
/// with multi-energy extraction (without it every layer has its own spill already).
fn check_layer_counts(
    spec: &AxisSpec,
    field: &str,
    file: &str,
    machine: &Machine,
) -> Result<(), EvalError> {
    if !machine
        .beam
        .spill()
        .is_some_and(|s| s.multi_energy_extraction)
    {
        return Err(EvalError::sweep(
            file,
            field,
            format!("machine \"{}\": its spills serve one layer each (no `multi_energy_extraction`); expected a machine with multi-energy extraction to sweep the layers per spill", machine.name),
        ));
    }
    if matches!(spec, AxisSpec::Range { .. }) {
        return Err(EvalError::sweep(
            file,
            field,
            "expected a list of whole numbers of layers (e.g. [1, 2, 5]), not a range",
        ));
    }
    match listed(spec, field)
        .into_iter()
        .find(|(_, x)| !(x.fract() == 0.0 && (1.0..=1e6).contains(x)))
    {
        Some((at, x)) => Err(EvalError::sweep(
            file,
            at,
            format!("expected a whole number of layers from 1 to 1000000 (1: every layer its own spill), got {x}"),
        )),
        None => Ok(()),
    }
}

/// Checks a dose-rate scale axis's values (a list's each, a range's ends) against
/// [`DOSE_RATE_SCALE_RANGE`]; the scaled beam model is then checked as a machine's
/// ([`check_machine_values`]).
pub(super) fn check_dose_rate_scales(
    spec: &AxisSpec,
    field: &str,
    file: &str,
) -> Result<(), EvalError> {
    let (lo, hi) = DOSE_RATE_SCALE_RANGE;
    match listed(spec, field)
        .into_iter()
        .find(|(_, x)| !(lo..=hi).contains(x))
    {
        Some((at, x)) => Err(EvalError::sweep(
            file,
            at,
            format!("expected a dose-rate scale from {lo} to {hi} (a factor on the base machine's dose rate), got {x}"),
        )),
        None => Ok(()),
    }
}

pub(super) fn twice(x: f64, j: usize, i: usize) -> String {
    format!("value {x} appears twice (positions {j} and {i}); expected distinct values")
}

/// Checks that a range's values are distinct without storing them: consecutive values must move
/// strictly from `from` towards `to` (a range finer than the floating-point resolution does not).
pub(super) fn check_range_distinct(
    spec: &AxisSpec,
    field: &str,
    file: &str,
) -> Result<(), EvalError> {
    let AxisSpec::Range { from, to, .. } = *spec else {
        return Ok(());
    };
    let n = spec.len();
    let mut prev = spec.value(0);
    for i in 1..n {
        let x = spec.value(i);
        if x == prev {
            return Err(EvalError::sweep(file, field, twice(x, i - 1, i)));
        }
        if (x > prev) != (to > from) {
            return Err(EvalError::sweep(
                file,
                format!("{field}.steps"),
                format!("{n} steps from {from} to {to} are finer than floating-point resolution (value {i}, {x}, does not move on from value {}, {prev}); expected fewer steps", i - 1),
            ));
        }
        prev = x;
    }
    Ok(())
}

/// Checks an axis's extreme values as the base machine's own would be: the machine with the
/// value set must pass [`arcsim_plan::validate_machine`] (so a sweep accepts the gantry limits,
/// switching times and windows a machine file accepts, and no value far beyond physical sense).
/// The extremes decide, as every accepted set of values is an interval. A also sets the
/// deceleration limit D = D_base · (A / A_base) (D_base: the machine's explicit deceleration
/// limit, else its A), which must stay finite, > 0 and accepted.
pub(super) fn check_machine_values(
    spec: &AxisSpec,
    axis: Axis,
    field: &str,
    file: &str,
    machine: &Machine,
) -> Result<(), EvalError> {
    let extremes: [(String, f64); 2] = match spec {
        AxisSpec::Values(v) => {
            let pick = |better: fn(f64, f64) -> bool| {
                let (i, x) = v
                    .iter()
                    .copied()
                    .enumerate()
                    .reduce(|a, b| if better(b.1, a.1) { b } else { a })
                    .unwrap_or((0, f64::NAN));
                (format!("{field}[{i}]"), x)
            };
            [pick(|a, b| a < b), pick(|a, b| a > b)]
        }
        AxisSpec::Range { from, to, .. } => [
            (format!("{field}.from"), *from),
            (format!("{field}.to"), *to),
        ],
    };
    let g = &machine.gantry;
    for (at, x) in extremes {
        let mut m = machine.clone();
        let mut note = String::new();
        match axis {
            Axis::Jerk => m.gantry.max_jerk_deg_per_s3 = x,
            Axis::Speed => m.gantry.max_speed_deg_per_s = x,
            Axis::Accel => {
                m.gantry.max_accel_deg_per_s2 = x;
                let d = g.max_decel_deg_per_s2.unwrap_or(g.max_accel_deg_per_s2);
                let decel = d * (x / g.max_accel_deg_per_s2);
                if g.max_decel_deg_per_s2.is_some() || !(decel.is_finite() && decel > 0.0) {
                    m.gantry.max_decel_deg_per_s2 = Some(decel);
                    note = format!(
                        "A = {x} deg/s^2 scales the deceleration limit ({d} deg/s^2 at A = {} deg/s^2) to {decel} deg/s^2: ",
                        g.max_accel_deg_per_s2
                    );
                }
            }
            Axis::ElstUp | Axis::ElstDown => match &mut m.elst {
                ElstModel::Constant { up_s, down_s, .. } => {
                    *if axis == Axis::ElstUp { up_s } else { down_s } = x;
                }
                ElstModel::Polynomial { down_s, .. } => *down_s = x,
                // Refused when the sweep is loaded (no single up or down time to set).
                ElstModel::ByEnergy { .. } | ElstModel::ByEnergyPair { .. } => {}
            },
            Axis::Window => m.default_window_deg = x,
            // A model that lacks what the axis sets is refused before.
            Axis::ScanSpeed
            | Axis::DoseRateScale
            | Axis::BurstSwitching
            | Axis::SpillCharge
            | Axis::SpillRefill
            | Axis::SpillMaxLayers => {
                if let Some(b) = axis.set_beam(&m.beam, x) {
                    m.beam = b;
                }
            }
        }
        if let Some(issue) = arcsim_plan::validate_machine(&m, &machine.name).first() {
            return Err(EvalError::sweep(
                file,
                at,
                format!(
                    "{note}{} (the values a machine's `{}` accepts)",
                    issue.message, issue.field
                ),
            ));
        }
    }
    Ok(())
}

/// Why `axis` cannot be swept on `machine`'s ELST model (no single up or down time), if so.
fn elst_not_sweepable(axis: Axis, machine: &Machine) -> Option<String> {
    let swept = match axis {
        Axis::ElstUp => matches!(machine.elst, ElstModel::Constant { .. }),
        Axis::ElstDown => matches!(
            machine.elst,
            ElstModel::Constant { .. } | ElstModel::Polynomial { .. }
        ),
        _ => true,
    };
    if swept {
        return None;
    }
    let (direction, expected) = match axis {
        Axis::ElstUp => ("upward", "a constant one"),
        _ => ("downward", "a constant or polynomial one"),
    };
    Some(format!(
        "machine \"{}\" has a {} ELST model; expected {expected} to sweep the {direction} switching time",
        machine.name,
        machine.elst.kind().replace('_', " ")
    ))
}
