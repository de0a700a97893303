//! The trace's speed, acceleration and deceleration plateaus corrected by replaying the fitted
//! machine.
//!
//! A plateau level is the median of the local fits within four noise deviations of the largest
//! ([`crate::kinematics::plateau`]). With an encoder's noise that band takes in windows over a
//! plateau's edge, which average in the ramp and read low: on plateaus shorter than the fits'
//! window (most of a constant-speed machine's) A reads about 0.3 % low, and the band's count of
//! "independent" windows misjudges its spread (the interval it gave was twice the error's). A
//! free-motion gantry's V reads 0.2–0.3 % low the same way, with an interval a fifth of that
//! wide (it missed V on 12 seeds of 12).
//! Both are measured here rather than modelled: the fitted machine delivers every logged plan
//! again, sampled as its log was and with the logs' own angle noise, [`REPLAYS`] times; the same
//! estimator on those logs shows its bias (their median level less the machine's value) and its
//! spread, which give the corrected value and its interval (a parametric bootstrap).

use arcsim_plan::Machine;
use arcsim_sequencer::{simulate, Delivery, Options};
use rayon::prelude::*;

use crate::calibrate::{FittedValue, LoggedRun};
use crate::kinematics::{observe, trace, ObservedKinematics, BIN_BELOW_S, BIN_S};
use crate::transitions::student_t95;
use crate::virtual_log::{virtual_log, VirtualLogOptions};
use crate::DeliveryLog;

/// How many noisy logs of the fitted machine are read again.
pub(crate) const REPLAYS: usize = 32;

/// The least standard deviation an interval is given, as a fraction of the value: a noiseless
/// log replays identically, and its estimate is still only as fine as the plateau's band.
const SD_FLOOR_FRACTION: f64 = 1e-3;

const SPEED: &str = "gantry.max_speed_deg_per_s";
const ACCEL: &str = "gantry.max_accel_deg_per_s2";
const DECEL: &str = "gantry.max_decel_deg_per_s2";
/// The rows a replay corrects, in the order [`replayed_levels`] gives their levels.
const FIELDS: [&str; 3] = [SPEED, ACCEL, DECEL];

/// The speed, acceleration and deceleration rows read from plateaus corrected by the replay,
/// `machine` set to the corrected values. One replay, at the values read: the bias hardly depends on them
/// (on the tests' constant-speed machine at 0.03° of noise a second replay at the corrected
/// values moved A by a twentieth of the first's correction, 0.0003 deg/s²). Nothing changes when the replay cannot be
/// simulated or fewer than half its logs show the plateau.
pub(crate) fn correct_plateaus(
    machine: &mut Machine,
    runs: &[LoggedRun],
    options: &Options,
    observed: &ObservedKinematics,
    values: &mut [FittedValue],
) {
    let read = FIELDS.map(|field| {
        values
            .iter()
            .find(|v| v.field == field && v.determined && v.note.starts_with("plateau"))
            .map(|v| v.value)
    });
    if read.iter().all(Option::is_none) {
        return;
    }
    let Some(levels) = replayed_levels(machine, runs, options, observed.angle_noise_deg) else {
        return;
    };
    let g = &machine.gantry;
    let simulated = [
        g.max_speed_deg_per_s,
        g.max_accel_deg_per_s2,
        g.max_decel_deg_per_s2.unwrap_or(g.max_accel_deg_per_s2),
    ];
    let mut corrected: [Option<Correction>; 3] = [None, None, None];
    for (k, drawn) in levels.into_iter().enumerate() {
        if let Some(read) = read[k].filter(|_| drawn.len() >= REPLAYS / 2) {
            corrected[k] = Some(Correction::of(read, simulated[k], &drawn));
        }
    }
    let g = &mut machine.gantry;
    if let Some(v) = &corrected[0] {
        g.max_speed_deg_per_s = v.value;
    }
    if let Some(a) = &corrected[1] {
        g.max_accel_deg_per_s2 = a.value;
    }
    if let (Some(d), Some(_)) = (&corrected[2], g.max_decel_deg_per_s2) {
        g.max_decel_deg_per_s2 = Some(d.value);
    }
    for (field, c) in FIELDS.into_iter().zip(corrected) {
        let (Some(c), Some(row)) = (c, values.iter_mut().find(|v| v.field == field)) else {
            continue;
        };
        row.note = format!(
            "{}; corrected by replay: the fitted machine's logs read again {} times with the logs' angle noise ({:.4} deg) put the plateau {:+.4} off its value, the interval from their spread (Student's t)",
            row.note, c.draws, observed.angle_noise_deg, c.bias
        );
        row.value = c.value;
        row.interval = Some(c.interval);
    }
}

/// A plateau level corrected by one replay.
struct Correction {
    value: f64,
    interval: [f64; 2],
    bias: f64,
    draws: usize,
}

impl Correction {
    /// The level `read` from the logs less the replay's bias (the median of the `drawn` levels
    /// less the `simulated` value), with Student's t on their spread. Median and MAD: a draw
    /// now and then reads a plateau 1 % off (the band's median jumping between the plateau's
    /// windows and its edges'), which a mean and a standard deviation would take as the spread.
    fn of(read: f64, simulated: f64, drawn: &[f64]) -> Correction {
        let n = drawn.len() as f64;
        let mut sorted = drawn.to_vec();
        let centre = crate::calibrate::median(&mut sorted);
        let bias = centre - simulated;
        let value = read - bias;
        // The log's own noise and that of the bias measured on `n` replays.
        let sd = (crate::calibrate::mad_sd(drawn, centre) * (1.0 + 1.0 / n).sqrt())
            .max(SD_FLOOR_FRACTION * value.abs());
        let half = student_t95(n - 1.0) * sd;
        Correction {
            value,
            interval: [value - half, value + half],
            bias,
            draws: drawn.len(),
        }
    }
}

/// The speed, acceleration and deceleration plateau levels ([`FIELDS`]) read from each of
/// [`REPLAYS`] noisy logs of `machine` delivering every run's plan (each sampled at its log's
/// period, or at the bins the fits average a fast log into), where the replay's trace reaches
/// them.
fn replayed_levels(
    machine: &Machine,
    runs: &[LoggedRun],
    options: &Options,
    noise_deg: f64,
) -> Option<[Vec<f64>; 3]> {
    let opts = Options {
        build_timeline: true,
        ..options.clone()
    };
    let deliveries: Vec<(Delivery, f64)> = runs
        .par_iter()
        .map(|r| {
            let period = r.log.typical_period_s();
            let period = if period < BIN_BELOW_S { BIN_S } else { period };
            Some((simulate(&r.plan, machine, &opts).ok()?, period))
        })
        .collect::<Option<_>>()?;
    let draws: Vec<[Option<f64>; 3]> = (0..REPLAYS)
        .into_par_iter()
        .map(|k| {
            let traces = deliveries
                .iter()
                .enumerate()
                .map(|(i, (d, period))| {
                    let opts = VirtualLogOptions {
                        period_s: *period,
                        angle_noise_deg: noise_deg,
                        seed: 0x9a7e_0000 + (k * 1000 + i) as u64,
                    };
                    let samples = virtual_log(d, &[], &opts).ok()?;
                    Some(trace(&DeliveryLog::of_angles("replay", samples)))
                })
                .collect::<Option<Vec<_>>>()?;
            let obs = observe(&traces);
            let level =
                |p: Option<crate::kinematics::Plateau>| p.filter(|p| p.reached).map(|p| p.level);
            Some([level(obs.speed), level(obs.accel), level(obs.decel)])
        })
        .collect::<Option<_>>()?;
    Some([0, 1, 2].map(|k| draws.iter().filter_map(|d| d[k]).collect()))
}
