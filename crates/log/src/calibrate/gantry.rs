//! The gantry fits: V, A, D and J from the trace's plateaus and reversals, by the model where
//! the controller says so, and "not determined" where the logs do not show a limit binding.

use arcsim_plan::Machine;
use arcsim_sequencer::{simulate, Options};
use rayon::prelude::*;

use crate::kinematics::{ObservedKinematics, Plateau};
use crate::matching::LoggedLayer;

use super::gaps::*;
use super::stats::*;
use super::types::*;

/// How a gantry limit fitted to the gaps of a log without an angle trace begins its note (and
/// how [`decel_follows_accel`] recognises one).
const BY_MODEL_WITHOUT_TRACE: &str = "by the model, from a log without an angle trace";

pub(super) fn gantry_value(
    field: &str,
    unit: &str,
    base: Option<f64>,
    p: Option<&Plateau>,
    what: &str,
) -> FittedValue {
    match p {
        Some(p) if p.reached => FittedValue {
            field: field.into(),
            unit: unit.into(),
            base,
            value: p.level,
            interval: Some(p.interval),
            observations: 1,
            determined: true,
            note: format!("plateau of the observed {what}, held {:.1} s (local fits over 2 s)", p.held_s),
        },
        Some(p) if base.is_some_and(|b| p.level > b) => FittedValue {
            value: p.level,
            ..kept(field, unit, base, 1, &format!("the observed {what} is not held as a limit (plateau {:.4} held {:.2} s) but exceeds the base value: raised to it, a lower bound of the limit", p.level, p.held_s))
        },
        Some(p) => kept(field, unit, base, 1, &format!("the observed {what} peaks at {:.4} (held {:.2} s): the limit is not resolved, the base value is kept", p.peak, p.held_s)),
        None => kept(field, unit, base, 0, &format!("no {what} in the logs: the base value is kept")),
    }
}

/// Below this fraction of the base machine's speed limit the gantry is not moving at a
/// meaningful speed: creeping through narrow windows (or standing still, its trace pure encoder
/// noise) it approaches none of its limits, and a plateau of such motion is the plan's pace or
/// noise, not the machine's limit (a still gantry's noise gave a "jerk limit" of 1e9 deg/s³).
pub(super) const MOVING_FRACTION_OF_BASE_SPEED: f64 = 0.2;

/// Whether the logs show the gantry moving at a meaningful speed (see
/// [`MOVING_FRACTION_OF_BASE_SPEED`]).
pub(super) fn moving(base: &Machine, obs: &ObservedKinematics) -> bool {
    obs.speed.map_or(0.0, |p| p.peak)
        >= MOVING_FRACTION_OF_BASE_SPEED * base.gantry.max_speed_deg_per_s
}

/// A fitted V that changes the plans' simulated totals by less than this fraction, when raised
/// tenfold from the logged peak speed, does not bind in those plans.
pub(super) const V_BINDS_FRACTION: f64 = 1e-3;

/// Under a constant-speed controller a speed plateau in the logs is a layer's constant speed
/// (its window and beam-on set it), not V, unless V is what held it there. The logged plans are
/// simulated with V at the logged peak speed and at ten times it: when the totals differ by less
/// than [`V_BINDS_FRACTION`], V does not bind in these logs and is not determined (the base value
/// kept, never below the logged peak).
pub(super) fn question_speed_plateau(
    base: &Machine,
    machine: &mut Machine,
    runs: &[LoggedRun],
    options: &Options,
    observed: &ObservedKinematics,
    values: &mut [FittedValue],
) {
    let Some(row) = values
        .iter_mut()
        .find(|v| v.field == "gantry.max_speed_deg_per_s" && v.determined)
    else {
        return;
    };
    let plateau = row.value;
    let logged_peak = observed.speed.map_or(plateau, |s| s.peak.max(plateau));
    let opts = Options {
        build_timeline: false,
        ..options.clone()
    };
    let total_at = |v: f64| -> Option<f64> {
        let mut m = machine.clone();
        m.gantry.max_speed_deg_per_s = v;
        runs.par_iter()
            .map(|r| simulate(&r.plan, &m, &opts).ok().map(|d| d.total_s))
            .sum()
    };
    let (Some(at_peak), Some(unbound)) =
        rayon::join(|| total_at(logged_peak), || total_at(10.0 * logged_peak))
    else {
        return;
    };
    let saved = (at_peak - unbound) / at_peak.max(f64::MIN_POSITIVE);
    if saved >= V_BINDS_FRACTION {
        row.note.push_str(&format!(
            "; V binds: the plans (constant speed per layer) take {:.2} % less time with V ten times the logged peak",
            100.0 * saved
        ));
        return;
    }
    let value = base.gantry.max_speed_deg_per_s.max(logged_peak);
    row.note = format!(
        "not determined: under constant speed per layer the plateau {plateau:.4} deg/s is a layer's speed, not V (the plans simulated with V at the logged peak {logged_peak:.4} and at ten times it last alike: {:+.3} %); the base value is kept, never below the logged peak",
        -100.0 * saved
    );
    row.value = value;
    row.interval = None;
    row.determined = false;
    machine.gantry.max_speed_deg_per_s = value;
}

/// Under a constant-speed controller, J by the model ([`crate::transitions::fit_by_gaps`]): the
/// reversals of the trace read the beam-on dwells between a move's turns as a slow jerk. The
/// search spans a factor 4 each way: wider, the constant-speed model takes a free-motion
/// gantry's logs for a jerk of 21 deg/s³ (the README's fast machine, J 3) and fits them almost
/// as well as free motion does, and the controller is no longer told apart. The joint
/// refinement reaches up to a third beyond the bracket's end (three steps of at most 10 %): the
/// tests' constant-speed machine, whose J the trace reads 4.2 times low.
pub(super) fn refine_jerk(
    machine: &mut Machine,
    (runs, matched): (&[LoggedRun], &[Matched]),
    options: &Options,
    values: &mut [FittedValue],
) {
    let logged: Vec<&[LoggedLayer]> = matched.iter().map(|m| m.layers.as_slice()).collect();
    let start = machine.gantry.max_jerk_deg_per_s3;
    let set = |m: &mut Machine, j: f64| m.gantry.max_jerk_deg_per_s3 = j;
    let Some(fit) = crate::transitions::fit_by_gaps(
        machine,
        &set,
        (
            start,
            4.0,
            arcsim_plan::JERK_RANGE_DEG_PER_S3,
            SEED_TOLERANCE,
        ),
        (runs, &logged),
        crate::transitions::Switches::All,
        options,
    ) else {
        return;
    };
    machine.gantry.max_jerk_deg_per_s3 = fit.value;
    if let Some(v) = values
        .iter_mut()
        .find(|v| v.field == "gantry.max_jerk_deg_per_s3")
    {
        let note = format!(
            "by the model: the J whose simulated moves (constant speed per layer) last as the logged beam-off gaps (golden section over ln J from the trace's {:.4}; a gap off by more than 0.3 s counts as 0.3 s); interval: the sandwich over the {} gaps it moves, Student's t",
            start, fit.transitions
        );
        record_gap_fit(v, &fit, note);
    }
}

pub(super) fn fit_gantry(
    base: &Machine,
    (obs, traced): (&ObservedKinematics, bool),
    machine: &mut Machine,
    values: &mut Vec<FittedValue>,
) {
    let g = &base.gantry;
    let base_d = g.max_decel_deg_per_s2.unwrap_or(g.max_accel_deg_per_s2);
    let top_speed = obs.speed.map_or(0.0, |p| p.peak);
    let meaningful = MOVING_FRACTION_OF_BASE_SPEED * g.max_speed_deg_per_s;
    if !traced || top_speed < meaningful {
        let why = if traced {
            format!(
                "the gantry never moves faster than {top_speed:.4} deg/s in the logs, under {:.0} % of the base machine's speed limit {} deg/s: no limit is approached, the base value is kept",
                100.0 * MOVING_FRACTION_OF_BASE_SPEED,
                g.max_speed_deg_per_s
            )
        } else {
            "not determined: the logs hold no angle trace (a treatment record or an IBA-style log holds each layer's beam-on and beam-off, not the gantry's motion between them), the base value is kept".to_string()
        };
        let n = usize::from(obs.speed.is_some());
        for (field, unit, kept_value) in [
            ("gantry.max_speed_deg_per_s", "deg/s", g.max_speed_deg_per_s),
            (
                "gantry.max_accel_deg_per_s2",
                "deg/s^2",
                g.max_accel_deg_per_s2,
            ),
            ("gantry.max_decel_deg_per_s2", "deg/s^2", base_d),
            (
                "gantry.max_jerk_deg_per_s3",
                "deg/s^3",
                g.max_jerk_deg_per_s3,
            ),
        ] {
            values.push(kept(field, unit, Some(kept_value), n, &why));
        }
        let out = &mut machine.gantry;
        out.max_speed_deg_per_s = g.max_speed_deg_per_s;
        out.max_accel_deg_per_s2 = g.max_accel_deg_per_s2;
        out.max_decel_deg_per_s2 = g.max_decel_deg_per_s2;
        out.max_jerk_deg_per_s3 = g.max_jerk_deg_per_s3;
        return;
    }
    let v = gantry_value(
        "gantry.max_speed_deg_per_s",
        "deg/s",
        Some(g.max_speed_deg_per_s),
        obs.speed.as_ref(),
        "speed",
    );
    let a = gantry_value(
        "gantry.max_accel_deg_per_s2",
        "deg/s^2",
        Some(g.max_accel_deg_per_s2),
        obs.accel.as_ref(),
        "acceleration",
    );
    let mut d = gantry_value(
        "gantry.max_decel_deg_per_s2",
        "deg/s^2",
        Some(base_d),
        obs.decel.as_ref(),
        "deceleration",
    );
    let j = match obs.jerk_reversals.filter(|r| r.reached) {
        Some(r) => FittedValue {
            field: "gantry.max_jerk_deg_per_s3".into(),
            unit: "deg/s^3".into(),
            base: Some(g.max_jerk_deg_per_s3),
            value: r.level,
            interval: Some(r.interval),
            observations: (r.held_s * r.level / (2.0 * obs.accel.map_or(1.0, |a| a.level))).round() as usize,
            determined: true,
            note: "median over the acceleration's reversals between its plateaus: the slope between the half-way points, the 2 s fits' averaging undone".into(),
        },
        None => gantry_value(
            "gantry.max_jerk_deg_per_s3",
            "deg/s^3",
            Some(g.max_jerk_deg_per_s3),
            obs.jerk.as_ref(),
            "jerk (fewer than 3 reversals of the acceleration between its plateaus)",
        ),
    };
    let out = &mut machine.gantry;
    out.max_speed_deg_per_s = v.value;
    out.max_jerk_deg_per_s3 = j.value;
    // One limit A unless the deceleration differs from it by more than 5 %.
    out.max_accel_deg_per_s2 = a.value;
    let same = (a.value - d.value).abs() <= 0.05 * a.value.max(d.value);
    out.max_decel_deg_per_s2 = match (a.determined || d.determined, same) {
        (true, true) => {
            d.note
                .push_str("; within 5 % of the acceleration: the machine keeps one limit, A");
            None
        }
        (_, false) => Some(d.value),
        (false, true) => g.max_decel_deg_per_s2.filter(|_| d.value != a.value),
    };
    values.extend([v, a, d, j]);
}

/// Sets A, moving a separate deceleration limit D by as much (their difference kept).
pub(super) fn set_accel(m: &mut Machine, a: f64) {
    let shift = a - m.gantry.max_accel_deg_per_s2;
    m.gantry.max_accel_deg_per_s2 = a;
    if let Some(d) = &mut m.gantry.max_decel_deg_per_s2 {
        *d += shift;
    }
}

/// A record (no angle trace) under a constant-speed controller: the gantry's limits by the
/// model, from the transitions the record shows. Each layer's beam edges are in the record;
/// between them the switch lasts its ELST or the planner's move from one layer's constant speed
/// to the next's, whichever is longer. A, then J, then A and J again (a move's duration
/// depends on both: short moves on J, long ones on A), then V: the value whose simulated
/// beam-off gaps last as the recorded ones ([`crate::transitions::fit_by_gaps`], every
/// candidate's schedule re-simulated). A limit no gap binds (the misfit flat around it) stays
/// not determined, the base value kept; so does every limit when the clock (`clock_s`) reads a
/// gap to no better than the robust cap of such fits (whole seconds: V and J were "fitted" at
/// 3.7 and 2.1 where the truth was 5 and 0.7).
pub(super) fn gantry_by_gaps(
    machine: &mut Machine,
    (runs, matched): (&[LoggedRun], &[Matched]),
    clock_s: f64,
    options: &Options,
    values: &mut [FittedValue],
) {
    if clock_s >= crate::transitions::ROBUST_CAP_S {
        for v in values.iter_mut().filter(|v| v.field.starts_with("gantry.")) {
            v.note.push_str(&format!("; nor by the model: the log's clock (times to {clock_s} s) reads a switch's duration to within {clock_s} s, at or beyond the {} s beyond which a gap stops pulling a fit by the model", crate::transitions::ROBUST_CAP_S));
        }
        return;
    }
    let logged: Vec<&[LoggedLayer]> = matched.iter().map(|m| m.layers.as_slice()).collect();
    let set_jerk = |m: &mut Machine, j: f64| m.gantry.max_jerk_deg_per_s3 = j;
    let set_speed = |m: &mut Machine, v: f64| m.gantry.max_speed_deg_per_s = v;
    type Setter<'a> = &'a dyn Fn(&mut Machine, f64);
    let limits: [(&str, Setter, (f64, f64)); 3] = [
        (
            "gantry.max_accel_deg_per_s2",
            &set_accel,
            arcsim_plan::ACCEL_RANGE_DEG_PER_S2,
        ),
        (
            "gantry.max_jerk_deg_per_s3",
            &set_jerk,
            arcsim_plan::JERK_RANGE_DEG_PER_S3,
        ),
        (
            "gantry.max_speed_deg_per_s",
            &set_speed,
            arcsim_plan::SPEED_RANGE_DEG_PER_S,
        ),
    ];
    let current = |m: &Machine, field: &str| match field {
        "gantry.max_accel_deg_per_s2" => m.gantry.max_accel_deg_per_s2,
        "gantry.max_jerk_deg_per_s3" => m.gantry.max_jerk_deg_per_s3,
        _ => m.gantry.max_speed_deg_per_s,
    };
    // (limit, bracket span): A and J twice, the second pass in a narrower bracket; V once.
    let passes = [(0, 4.0), (1, 4.0), (0, 1.5), (1, 1.5), (2, 4.0)];
    let mut fits: [Option<crate::transitions::GapFit>; 3] = [None, None, None];
    let mut starts = [0.0; 3];
    for (i, span) in passes {
        let (field, set, range) = limits[i];
        let start = current(machine, field);
        starts[i] = start;
        let fit = crate::transitions::fit_by_gaps(
            machine,
            set,
            (start, span, range, SEED_TOLERANCE),
            (runs, &logged),
            crate::transitions::Switches::All,
            options,
        );
        if let Some(f) = &fit {
            set(machine, f.value);
        }
        fits[i] = fit;
    }
    for (i, (field, _, _)) in limits.iter().enumerate() {
        let Some(row) = values.iter_mut().find(|v| v.field == *field) else {
            continue;
        };
        match &fits[i] {
            Some(fit) => {
                let note = format!(
                    "{BY_MODEL_WITHOUT_TRACE} (a treatment record or an IBA-style log): the value whose simulated switches (constant speed per layer, the schedule re-simulated at each candidate) last as the recorded beam-off gaps (golden section over its logarithm from {:.4}, A and J in turn; a gap off by more than 0.3 s counts as 0.3 s); interval: the sandwich over the {} gaps it moves, Student's t",
                    starts[i], fit.transitions
                );
                record_gap_fit(row, fit, note);
            }
            None => {
                row.note = format!(
                    "not determined: the log holds no angle trace (a treatment record or an IBA-style log holds each layer's beam-on and beam-off, not the gantry's motion between them), and fitted by the model the recorded gaps do not bind it (fewer than 3 gaps move with it, or their misfit is flat around it); the base value {} is kept",
                    row.base.unwrap_or(row.value)
                );
                if let Some(b) = row.base {
                    (limits[i].1)(machine, b);
                }
            }
        }
    }
}

/// After the gantry's fit by the model on a record ([`gantry_by_gaps`], then the joint
/// refinement): a record cannot tell deceleration from acceleration, so D's row says it moved
/// with A and shows the machine's value.
pub(super) fn decel_follows_accel(machine: &Machine, values: &mut [FittedValue]) {
    let accel_from_record = values.iter().any(|v| {
        v.field == "gantry.max_accel_deg_per_s2"
            && v.determined
            && v.note.starts_with(BY_MODEL_WITHOUT_TRACE)
    });
    let Some(row) = values
        .iter_mut()
        .find(|v| v.field == "gantry.max_decel_deg_per_s2")
    else {
        return;
    };
    if !accel_from_record {
        return;
    }
    let (value, how) = match machine.gantry.max_decel_deg_per_s2 {
        Some(d) => (
            d,
            "moved with A by as much (the base's difference from A kept)",
        ),
        None => (
            machine.gantry.max_accel_deg_per_s2,
            "the base machine has one limit A, kept so",
        ),
    };
    row.value = value;
    row.note = format!("not determined on its own: the recorded gaps cannot tell deceleration from acceleration; {how}");
}
