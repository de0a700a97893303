//! One row of a delivery log, a whole log, and the cleaning every log read goes through.
//!
//! Before any analysis the angle trace is made continuous and freed of encoder glitches
//! ([`DeliveryLog::clean`], called by [`crate::parse_log`]):
//!
//! 1. **Unwrapping.** Encoders report angles modulo 360°; on an arc through 0° the trace jumps by
//!    a turn, which the kinematics would read as a speed of 36 000 deg/s at 10 ms. A step of more
//!    than 180° between consecutive samples is a wrap (no gantry turns half a circle between two
//!    samples), undone by whole turns. The trace keeps the first good sample's logged value, so a
//!    log without wraps is left exactly as it is.
//! 2. **Glitch rejection** (a Hampel filter on the unwrapped trace, so that a wrap is never taken
//!    for a glitch): each sample is compared with the [`GLITCH_NEIGHBOURS`] samples on either side
//!    (the window slid inward at an end of the log or at a sampling gap), the gantry's motion
//!    through them removed (the median of their pairwise slopes, which a glitch among them cannot
//!    move); a sample further than max([`GLITCH_MAD_FACTOR`] × 1.4826 × MAD, [`GLITCH_FLOOR_DEG`])
//!    from the window's median is a glitch, replaced by linear interpolation (in time) between the
//!    nearest good samples, and counted. The floor keeps encoder noise (0.01° typical) from ever
//!    being rejected; a sample with fewer than 3 neighbours (isolated by sampling gaps) is not
//!    judged.

use serde::Serialize;

/// One sample of a delivery: where the gantry was and what the beam did at `t_s`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LogSample {
    /// Time, s, from any origin (strictly increasing along a log).
    pub t_s: f64,
    /// Gantry angle, degrees: as the plan gives angles, or modulo 360° as an encoder reports
    /// them; continuous in a log read ([`DeliveryLog::clean`]).
    pub gantry_angle_deg: f64,
    /// Whether the beam is on.
    pub beam_on: bool,
    /// The layer's nominal energy while the beam is on, MeV, when the log has it.
    pub energy_mev: Option<f64>,
    /// Index of the spot being delivered in its layer, when known.
    pub spot: Option<u32>,
    /// MU delivered since the previous sample, when the log has it.
    pub mu: Option<f64>,
}

/// A delivery log read from a file: its samples in time order and which optional columns it
/// had.
#[derive(Debug, Clone, PartialEq)]
pub struct DeliveryLog {
    /// The file as named to the reader.
    pub source: String,
    /// The samples, times strictly increasing.
    pub samples: Vec<LogSample>,
    /// Whether the log has an `energy_mev` column.
    pub has_energy: bool,
    /// Whether the log has a `spot` column.
    pub has_spot: bool,
    /// Whether the log has an `mu` column.
    pub has_mu: bool,
    /// Whole turns the angle trace was unwrapped by ([`DeliveryLog::clean`]): one per crossing
    /// of 0° in a log of angles modulo 360°.
    pub wraps_unwrapped: usize,
    /// Angle samples rejected as encoder glitches and replaced by their neighbours'
    /// interpolation ([`DeliveryLog::clean`]).
    pub glitches_rejected: usize,
    /// For a log of beam-on intervals ([`DeliveryLog::from_intervals`], e.g. a DICOM treatment
    /// record): the resolution its edge times were written at, s. Such a log has no angle trace
    /// between its edges, so the kinematics see none ([`crate::kinematics::trace`]), and its
    /// typical period is this resolution. `None` for a sampled log.
    pub edge_resolution_s: Option<f64>,
}

/// A layer's beam on between two recorded instants: what a log of intervals holds (a DICOM
/// treatment record's pair of control points).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamInterval {
    /// Beam on and off, s (any origin).
    pub start_s: f64,
    /// See `start_s`.
    pub end_s: f64,
    /// Gantry angle at beam on and beam off, degrees (modulo 360 allowed).
    pub angle_start_deg: f64,
    /// See `angle_start_deg`.
    pub angle_end_deg: f64,
    /// The layer's nominal energy, MeV.
    pub energy_mev: f64,
    /// MU delivered in it.
    pub mu: f64,
}

/// Neighbours on either side a sample's angle is judged against.
pub const GLITCH_NEIGHBOURS: usize = 3;

/// Robust standard deviations (1.4826 × MAD) from the window's median beyond which a sample is a
/// glitch (when that is above [`GLITCH_FLOOR_DEG`]).
pub const GLITCH_MAD_FACTOR: f64 = 3.0;

/// The least deviation, degrees, that counts as a glitch: 50 standard deviations of a typical
/// encoder's noise (0.01°), a tenth of the smallest glitch that misleads the kinematics (5°).
pub const GLITCH_FLOOR_DEG: f64 = 0.5;

/// A step between samples longer than this many typical (median) periods is a sampling gap: a
/// beam edge across it is not put halfway ([`crate::beam_segments`]) and glitch rejection does
/// not judge a sample by neighbours across it.
pub const LONG_GAP_PERIODS: f64 = 5.0;

impl DeliveryLog {
    /// A log of an angle trace as sampled: no optional column, nothing cleaned (a simulated
    /// trace, read again by the kinematics).
    pub fn of_angles(source: impl Into<String>, samples: Vec<LogSample>) -> DeliveryLog {
        DeliveryLog {
            source: source.into(),
            samples,
            has_energy: false,
            has_spot: false,
            has_mu: false,
            wraps_unwrapped: 0,
            glitches_rejected: 0,
            edge_resolution_s: None,
        }
    }

    /// A log of beam-on intervals whose edges were written at `resolution_s` (seconds; 1 for
    /// whole seconds). Each interval becomes two beam-on samples (its edges, the second holding
    /// its MU) between two beam-off samples a thousandth of the resolution outside them, so that
    /// every edge found halfway between samples ([`crate::beam_segments`]) is within that of the
    /// recorded time. Intervals that touch (recorded in one tick) are kept apart by that much
    /// each. The angles are unwrapped as in [`DeliveryLog::clean`]; no glitch is looked for (a
    /// record's angles are the system's own, not an encoder stream). `None` for an empty list,
    /// a resolution that is not a positive finite number, or intervals not in order of their
    /// starts.
    pub fn from_intervals(
        source: impl Into<String>,
        intervals: &[BeamInterval],
        resolution_s: f64,
    ) -> Option<DeliveryLog> {
        if intervals.is_empty() || !(resolution_s.is_finite() && resolution_s > 0.0) {
            return None;
        }
        let delta = 1e-3 * resolution_s;
        let mut samples: Vec<LogSample> = Vec::with_capacity(4 * intervals.len());
        let off = |t_s: f64, angle: f64| LogSample {
            t_s,
            gantry_angle_deg: angle,
            beam_on: false,
            energy_mev: None,
            spot: None,
            mu: Some(0.0),
        };
        let mut prev_start = f64::NEG_INFINITY;
        for iv in intervals {
            if !(iv.end_s >= iv.start_s && iv.start_s >= prev_start) {
                return None;
            }
            prev_start = iv.start_s;
            let last = samples.last().map(|x| x.t_s);
            let earliest = last.map_or(f64::NEG_INFINITY, |t| t + delta);
            let before = (iv.start_s - delta).max(earliest);
            let on_s = iv.start_s.max(before + delta);
            let off_s = iv.end_s.max(on_s + delta);
            samples.push(off(before, iv.angle_start_deg));
            samples.push(LogSample {
                t_s: on_s,
                gantry_angle_deg: iv.angle_start_deg,
                beam_on: true,
                energy_mev: Some(iv.energy_mev),
                spot: None,
                mu: Some(0.0),
            });
            samples.push(LogSample {
                t_s: off_s,
                gantry_angle_deg: iv.angle_end_deg,
                beam_on: true,
                energy_mev: Some(iv.energy_mev),
                spot: None,
                mu: Some(iv.mu),
            });
            samples.push(off(off_s + delta, iv.angle_end_deg));
        }
        let mut turns = 0_i64;
        let mut wraps = 0;
        let mut prev = samples[0].gantry_angle_deg;
        for x in &mut samples {
            let step = x.gantry_angle_deg - prev;
            prev = x.gantry_angle_deg;
            if step.abs() > 180.0 {
                turns -= (step / 360.0).round() as i64;
                wraps += 1;
            }
            x.gantry_angle_deg += 360.0 * turns as f64;
        }
        Some(DeliveryLog {
            source: source.into(),
            samples,
            has_energy: true,
            has_spot: false,
            has_mu: true,
            wraps_unwrapped: wraps,
            glitches_rejected: 0,
            edge_resolution_s: Some(resolution_s),
        })
    }

    /// Time from the first sample to the last, s.
    pub fn duration_s(&self) -> f64 {
        match (self.samples.first(), self.samples.last()) {
            (Some(a), Some(b)) => b.t_s - a.t_s,
            _ => 0.0,
        }
    }

    /// The log's typical time between samples: the median step, s (0 with fewer than two
    /// samples); for a log of intervals, the resolution of its edges.
    pub fn typical_period_s(&self) -> f64 {
        if let Some(r) = self.edge_resolution_s {
            return r;
        }
        let times: Vec<f64> = self.samples.iter().map(|x| x.t_s).collect();
        median_step_s(&times)
    }

    /// Unwraps the angle trace and replaces its glitches (see the module documentation), adding
    /// what it did to [`DeliveryLog::wraps_unwrapped`] and [`DeliveryLog::glitches_rejected`].
    /// A clean log is left unchanged, so cleaning twice changes nothing more.
    pub fn clean(&mut self) {
        let s = &mut self.samples;
        if s.len() < 2 {
            return;
        }
        // Whole turns added to each sample: a step beyond ±180° is a wrap. Counted in integers,
        // so that the samples keep their logged values exactly (the reader bounds angles to
        // ±1e9°, which keeps the counts exact; saturating, they cannot overflow on any log).
        let mut turns = vec![0_i64; s.len()];
        for i in 1..s.len() {
            let step_deg = s[i].gantry_angle_deg - s[i - 1].gantry_angle_deg;
            turns[i] = turns[i - 1];
            if step_deg.abs() > 180.0 {
                turns[i] = turns[i].saturating_sub((step_deg / 360.0).round() as i64);
            }
        }
        let unwrapped: Vec<f64> = s
            .iter()
            .zip(&turns)
            .map(|(x, k)| x.gantry_angle_deg + 360.0 * *k as f64)
            .collect();
        let times: Vec<f64> = s.iter().map(|x| x.t_s).collect();
        let long_gap_s = LONG_GAP_PERIODS * median_step_s(&times);
        let glitch = glitches(&times, &unwrapped, long_gap_s);
        let Some(first_good) = glitch.iter().position(|g| !g) else {
            return;
        };
        // Turns between consecutive good samples are the encoder's wraps (a glitch's own are
        // not).
        let good: Vec<usize> = (0..s.len()).filter(|&i| !glitch[i]).collect();
        let wraps = good.windows(2).fold(0_u64, |n, w| {
            n.saturating_add(turns[w[1]].saturating_sub(turns[w[0]]).unsigned_abs())
        });
        let base = turns[first_good];
        for &i in &good {
            let k = turns[i].saturating_sub(base);
            if k != 0 {
                s[i].gantry_angle_deg += 360.0 * k as f64;
            }
        }
        // A glitch takes the line between the nearest good samples (or the nearest one, at an
        // end of the log).
        for i in (0..s.len()).filter(|&i| glitch[i]) {
            let before = good.partition_point(|&g| g < i);
            let (a, b) = (
                before.checked_sub(1).map(|k| good[k]),
                good.get(before).copied(),
            );
            s[i].gantry_angle_deg = match (a, b) {
                (Some(a), Some(b)) => {
                    let f = (s[i].t_s - s[a].t_s) / (s[b].t_s - s[a].t_s);
                    s[a].gantry_angle_deg + f * (s[b].gantry_angle_deg - s[a].gantry_angle_deg)
                }
                (Some(a), None) => s[a].gantry_angle_deg,
                (None, Some(b)) => s[b].gantry_angle_deg,
                (None, None) => s[i].gantry_angle_deg,
            };
        }
        let wraps = usize::try_from(wraps).unwrap_or(usize::MAX);
        self.wraps_unwrapped = self.wraps_unwrapped.saturating_add(wraps);
        let rejected = glitch.iter().filter(|g| **g).count();
        self.glitches_rejected = self.glitches_rejected.saturating_add(rejected);
    }
}

/// The median step of `times`, s (0 with fewer than two).
fn median_step_s(times: &[f64]) -> f64 {
    let mut steps: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
    if steps.is_empty() {
        return 0.0;
    }
    let mid = steps.len() / 2;
    *steps.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// Which samples of the (unwrapped) trace `angles` at `times` are glitches: the Hampel filter of
/// the module documentation, windows not crossing a step longer than `long_gap_s`.
fn glitches(times: &[f64], angles: &[f64], long_gap_s: f64) -> Vec<bool> {
    let n = angles.len();
    // Runs of samples without a long gap: [start, end).
    let mut run_start = vec![0; n];
    let mut run_end = vec![n; n];
    for i in 1..n {
        run_start[i] = if times[i] - times[i - 1] > long_gap_s {
            i
        } else {
            run_start[i - 1]
        };
    }
    for i in (0..n - 1).rev() {
        run_end[i] = if times[i + 1] - times[i] > long_gap_s {
            i + 1
        } else {
            run_end[i + 1]
        };
    }
    let k = GLITCH_NEIGHBOURS;
    let mut out = vec![false; n];
    let (mut slopes, mut window, mut scratch) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..n {
        let (lo, hi) = (run_start[i], run_end[i]);
        if hi - lo < 4 {
            continue;
        }
        // 2k + 1 samples around i, slid inward at the run's ends.
        let from = i
            .saturating_sub(k)
            .max(lo)
            .min(hi.saturating_sub(2 * k + 1).max(lo));
        let to = (from + 2 * k + 1).min(hi);
        let neighbours = || (from..to).filter(|&j| j != i);
        slopes.clear();
        for a in neighbours() {
            for b in neighbours().filter(|&b| b > a) {
                slopes.push((angles[b] - angles[a]) / (times[b] - times[a]));
            }
        }
        let slope = crate::calibrate::median(&mut slopes);
        window.clear();
        window.extend((from..to).map(|j| angles[j] - slope * (times[j] - times[i])));
        scratch.clone_from(&window);
        let centre = crate::calibrate::median(&mut scratch);
        scratch.clear();
        scratch.extend(window.iter().map(|y| (y - centre).abs()));
        let mad = crate::calibrate::median(&mut scratch);
        let limit = (GLITCH_MAD_FACTOR * 1.4826 * mad).max(GLITCH_FLOOR_DEG);
        out[i] = (angles[i] - centre).abs() > limit;
    }
    out
}
