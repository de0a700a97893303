//! A log's beam-on segments matched to a plan's layers.
//!
//! A segment is a run of beam-on samples; its edges are put halfway between the last sample of
//! one state and the first of the other (unbiased for a beam switched at a random instant),
//! except across a sampling gap longer than [`LONG_GAP_PERIODS`] typical periods: halfway would
//! add up to half the gap to the beam-on time (an idle sample a minute before the delivery would
//! give its first layer 30 s), so the edge is put at the beam-on sample itself and counted as
//! uncertain ([`BeamSegment::start_uncertain`], [`LoggedLayer::uncertain_edges`]).
//! Consecutive segments of one energy form a run; the plan's consecutive layers of one energy
//! form one too. The runs must agree in number and energy (with the log's energies). Inside a
//! run of `r` layers the segments are split into `r` consecutive groups by time and MU
//! ([`layer_cuts`]): each group's MU against its layer's planned MU where the log has a `mu`
//! column and the plan spots (else its beam-on time against the planned one, which leans on the
//! base's beam model), after one common scale (the run's logged over planned amount), the
//! angles against the layers' windows, and, between equally good splits, the longer gaps. So a gating pause inside a layer, however long,
//! stays inside it. Without energies the whole log is one run.
//!
//! Inside a layer with pauses of its own (burst switching, waits for a spill:
//! [`arcsim_plan::ResolvedLayer`]'s `burst_switching_s` and `spill_waiting_s`), the shortest
//! beam-off gaps that last alike and together no longer than twice those are the machine's pauses
//! ([`LoggedLayer::pauses`]) and count as beam-on, as in the simulation; the other gaps are
//! interruptions.
//!
//! A log whose layers' beam-on times are a factor of about 1000 from the plan's
//! ([`UNIT_SLIP_BAND`]) is refused: its clock is in milliseconds (or the plan's times are), and
//! every time fitted or compared would be off by that factor.

use arcsim_plan::ResolvedArc;

use crate::LogSample;
use serde::Serialize;
use thiserror::Error;

use crate::{DeliveryLog, LONG_GAP_PERIODS};

mod cuts;

use cuts::*;

/// Energies closer than this (MeV) are the same energy in a log (logs round energies).
pub const LOG_ENERGY_TOLERANCE_MEV: f64 = 0.1;

/// How far (degrees) beyond the edge of its window a layer may be irradiated in a log before the
/// log is taken for another plan's.
pub const ANGLE_TOLERANCE_DEG: f64 = 2.0;

/// Median ratios of the logged to the plan's beam-on times that are a unit slip of 1000 (a
/// factor of 3 either way, for a machine's beam model off by as much), and their inverses.
pub const UNIT_SLIP_BAND: [f64; 2] = [1000.0 / 3.0, 3000.0];

/// One beam-on stretch of a log.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BeamSegment {
    /// Beam-on, s (log time), halfway between the last beam-off sample and the first beam-on one
    /// (at the beam-on one across a sampling gap).
    pub start_s: f64,
    /// Beam-off, s (log time), halfway between the last beam-on sample and the first beam-off
    /// one (at the beam-on one across a sampling gap).
    pub end_s: f64,
    /// Gantry angle at the first beam-on sample, degrees.
    pub angle_start_deg: f64,
    /// Gantry angle at the last beam-on sample, degrees.
    pub angle_end_deg: f64,
    /// The energy the log gives for the segment (at its first sample that has one), MeV.
    pub energy_mev: Option<f64>,
    /// Whether the beam-on follows a sampling gap longer than [`LONG_GAP_PERIODS`] typical
    /// periods (the beam came on somewhere in the gap; `start_s` is the first beam-on sample).
    pub start_uncertain: bool,
    /// Whether the beam-off precedes such a gap (`end_s` is the last beam-on sample).
    pub end_uncertain: bool,
    /// The MU the log's `mu` column gives the segment ([`attribute_mu`]); `None` without the
    /// column.
    pub mu: Option<f64>,
}

/// One plan layer as the log shows it delivered.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LoggedLayer {
    /// Index of the layer in delivery order (as the simulation's rows).
    pub index: usize,
    /// Beam-on of its first segment, s (log time).
    pub start_s: f64,
    /// Beam-off of its last segment, s (log time).
    pub end_s: f64,
    /// Beam-on time as the simulation counts it, s: the sum of its segments and of the machine's
    /// own pauses between them (bursts, spills), without its interruptions.
    pub beam_on_s: f64,
    /// How many beam-on segments it was delivered in (1: no pause, no interruption).
    pub segments: usize,
    /// Of the gaps between its segments, those that are the machine's own pauses (burst
    /// switching, a wait for a spill; see the module documentation), s, shortest first: part of
    /// `beam_on_s`.
    pub pause_gaps_s: Vec<f64>,
    /// Whether its end is early: fewer pauses between bursts logged than the machine has, a last
    /// burst too short to be sampled (set by calibration, which knows the bursts; `false` here).
    /// The gap after it is then long by a pause and more, so gap fits leave it out.
    pub ends_early: bool,
    /// The other gaps between its segments: interruptions (gating, a beam hold).
    pub interruptions: usize,
    /// Gantry angle at its first beam-on sample, degrees.
    pub angle_start_deg: f64,
    /// Gantry angle at its last beam-on sample, degrees.
    pub angle_end_deg: f64,
    /// Edges of its segments put at a sample across a sampling gap, not halfway
    /// ([`BeamSegment::start_uncertain`]): its beam-on time is a lower bound.
    pub uncertain_edges: usize,
}

/// A log that does not fit the plan, located.
#[derive(Debug, Error, Clone, PartialEq)]
#[error("{file}: {message}")]
pub struct MatchError {
    /// The log as named to the reader.
    pub file: String,
    /// What differs and where.
    pub message: String,
}

/// One plan layer, in delivery order, as matching needs it.
#[derive(Debug, Clone, Copy)]
struct Planned {
    arc: usize,
    control_point: usize,
    angle_deg: f64,
    window_deg: f64,
    energy_mev: f64,
    /// Planned beam-on time without the machine's pauses, s.
    on_s: f64,
    /// The machine's pauses inside the layer (burst switching, spill waits), s.
    pause_s: f64,
    /// Planned MU, 0 when the plan gives none.
    mu: f64,
}

fn planned(arcs: &[ResolvedArc]) -> Vec<Planned> {
    arcs.iter()
        .flat_map(|a| {
            a.layers.iter().map(move |l| Planned {
                arc: a.arc_index,
                control_point: l.control_point,
                angle_deg: l.angle_deg,
                window_deg: l.window_deg,
                energy_mev: l.energy_mev,
                on_s: (l.irradiation_s - l.burst_switching_s - l.spill_waiting_s).max(0.0),
                pause_s: l.burst_switching_s + l.spill_waiting_s,
                mu: l.mu,
            })
        })
        .collect()
}

/// The log's beam-on segments in time order (edges as the module documentation says).
pub fn beam_segments(log: &DeliveryLog) -> Vec<BeamSegment> {
    let s = &log.samples;
    let long_gap_s = LONG_GAP_PERIODS * log.typical_period_s();
    // The edge between samples `a` (earlier) and `b`: halfway, or at the beam-on one `on`
    // across a long gap (then uncertain).
    let edge = |a: usize, b: usize, on: usize| {
        if s[b].t_s - s[a].t_s > long_gap_s {
            (s[on].t_s, true)
        } else {
            (0.5 * (s[a].t_s + s[b].t_s), false)
        }
    };
    let mut out = Vec::new();
    let mut i = 0;
    // Each segment's first and last beam-on rows.
    let mut rows = Vec::new();
    while i < s.len() {
        if !s[i].beam_on {
            i += 1;
            continue;
        }
        let first = i;
        while i + 1 < s.len() && s[i + 1].beam_on {
            i += 1;
        }
        let last = i;
        let (start_s, start_uncertain) = match first {
            0 => (s[0].t_s, false),
            k => edge(k - 1, k, k),
        };
        let (end_s, end_uncertain) = if last + 1 < s.len() {
            edge(last, last + 1, last)
        } else {
            (s[last].t_s, false)
        };
        out.push(BeamSegment {
            start_s,
            end_s,
            angle_start_deg: s[first].gantry_angle_deg,
            angle_end_deg: s[last].gantry_angle_deg,
            energy_mev: s[first..=last].iter().find_map(|x| x.energy_mev),
            start_uncertain,
            end_uncertain,
            mu: None,
        });
        rows.push((first, last));
        i += 1;
    }
    if log.has_mu {
        attribute_mu(s, &rows, &mut out);
    }
    out
}

/// Each segment's MU ([`BeamSegment::mu`]): its rows' and the first beam-off row's after it
/// (each row holds the MU since the previous), and of the beam-off rows between two segments
/// those nearer in time to it. A spot too short for any row to see the beam on still counts,
/// with the segment it was delivered next to.
fn attribute_mu(s: &[LogSample], rows: &[(usize, usize)], out: &mut [BeamSegment]) {
    let mu = |k: usize| s.get(k).and_then(|x| x.mu).unwrap_or(0.0);
    for (j, &(first, last)) in rows.iter().enumerate() {
        let own: f64 = (first..=last + 1).map(mu).sum();
        out[j].mu = Some(own);
    }
    // The rows between segment j's first beam-off row and segment j + 1's first row.
    for j in 0..rows.len() {
        let from = rows[j].1 + 2;
        let to = rows.get(j + 1).map_or(s.len(), |r| r.0);
        let (end_s, next_start_s) = (out[j].end_s, out.get(j + 1).map(|n| n.start_s));
        for row in s.get(from..to).unwrap_or(&[]) {
            let t = row.t_s;
            let nearer_next = next_start_s.is_some_and(|n| n - t < t - end_s);
            let target = if nearer_next { j + 1 } else { j };
            if let Some(m) = &mut out[target].mu {
                *m += row.mu.unwrap_or(0.0);
            }
        }
    }
}

/// Consecutive items of one energy: `(first index, count, energy)`.
fn runs(energies: impl Iterator<Item = Option<f64>>) -> Vec<(usize, usize, Option<f64>)> {
    let mut out: Vec<(usize, usize, Option<f64>)> = Vec::new();
    for (i, e) in energies.enumerate() {
        match out.last_mut() {
            Some((_, n, last)) if same_energy(*last, e) => *n += 1,
            _ => out.push((i, 1, e)),
        }
    }
    out
}

fn same_energy(a: Option<f64>, b: Option<f64>) -> bool {
    match (a, b) {
        (Some(x), Some(y)) => (x - y).abs() <= LOG_ENERGY_TOLERANCE_MEV,
        (None, None) => true,
        _ => false,
    }
}

fn mev(e: Option<f64>) -> String {
    e.map_or_else(|| "no energy".to_string(), |e| format!("{e} MeV"))
}

/// Matches the log's beam-on segments to the layers of `arcs` (delivery order); see the module
/// documentation for the rule and [`MatchError`] for a log that does not fit.
pub fn match_layers(
    log: &DeliveryLog,
    arcs: &[ResolvedArc],
) -> Result<Vec<LoggedLayer>, MatchError> {
    let plan = planned(arcs);
    let segs = beam_segments(log);
    let fail = |message: String| MatchError {
        file: log.source.clone(),
        message,
    };
    if segs.is_empty() {
        return Err(fail("the log has no beam-on sample".into()));
    }
    let use_energy = log.has_energy && segs.iter().all(|s| s.energy_mev.is_some());
    let seg_runs = runs(segs.iter().map(|s| s.energy_mev.filter(|_| use_energy)));
    let plan_runs = runs(plan.iter().map(|p| use_energy.then_some(p.energy_mev)));
    let head = format!(
        "log has {} beam-on segments, the plan {} layers",
        segs.len(),
        plan.len()
    );
    for k in 0..seg_runs.len().max(plan_runs.len()) {
        let (s, p) = (seg_runs.get(k), plan_runs.get(k));
        let differs = match (s, p) {
            (Some(s), Some(p)) => !same_energy(s.2, p.2) || s.1 < p.1,
            _ => true,
        };
        if differs {
            let at = s.map_or(segs[segs.len() - 1].end_s, |s| segs[s.0].start_s);
            let what = match (s, p) {
                (Some(s), Some(p)) if same_energy(s.2, p.2) => format!(
                    "{} beam-on segments of {} in the log, {} layers in the plan",
                    s.1,
                    mev(s.2),
                    p.1
                ),
                (Some(s), Some(p)) => format!("{} in the log, {} in the plan", mev(s.2), mev(p.2)),
                (Some(s), None) => format!("{} in the log, the plan has ended", mev(s.2)),
                (None, Some(p)) => format!("the log has ended, {} in the plan", mev(p.2)),
                (None, None) => unreachable!("k < max of the two lengths"),
            };
            return Err(fail(format!(
                "{head}; the first that differs is at t = {at:.3} s: {what}"
            )));
        }
    }
    let period_s = log.typical_period_s();
    let mut out = Vec::with_capacity(plan.len());
    for (s, p) in seg_runs.iter().zip(&plan_runs) {
        let run = merge_short_gaps(&segs[s.0..s.0 + s.1]);
        let run = run.as_slice();
        let layers = &plan[p.0..p.0 + p.1];
        let cuts = layer_cuts(run, layers, period_s);
        let mut from = 0;
        for (j, &to) in cuts.iter().enumerate() {
            let parts = &run[from..to];
            out.push(logged_layer(p.0 + j, parts, layers[j].pause_s, period_s));
            from = to;
        }
    }
    check_time_unit(&out, &plan).map_err(fail)?;
    check_angles(&out, &plan).map_err(fail)?;
    Ok(out)
}

/// The median ratio of the logged to the planned beam-on times is not a unit slip
/// ([`UNIT_SLIP_BAND`]); layers without a planned or a logged beam-on time are left out.
fn check_time_unit(logged: &[LoggedLayer], plan: &[Planned]) -> Result<(), String> {
    let mut ratios: Vec<f64> = logged
        .iter()
        .filter_map(|l| {
            let planned_s = plan[l.index].on_s + plan[l.index].pause_s;
            (planned_s > 0.0 && l.beam_on_s > 0.0).then(|| l.beam_on_s / planned_s)
        })
        .collect();
    if ratios.is_empty() {
        return Ok(());
    }
    let mid = ratios.len() / 2;
    let ratio = *ratios.select_nth_unstable_by(mid, f64::total_cmp).1;
    let [lo, hi] = UNIT_SLIP_BAND;
    let n = ratios.len();
    if (lo..=hi).contains(&ratio) {
        return Err(format!(
            "the layers' logged beam-on times are a median {ratio:.0} times the plan's ({n} layers): times in milliseconds? the t_s column is in seconds"
        ));
    }
    if (1.0 / hi..=1.0 / lo).contains(&ratio) {
        return Err(format!(
            "the layers' logged beam-on times are a median 1/{:.0} of the plan's ({n} layers): times in kiloseconds, or the plan's irradiation times in milliseconds? the t_s column is in seconds",
            1.0 / ratio
        ));
    }
    Ok(())
}

/// Beam-off gaps shorter than this (s) are moves between spots, never a layer change (no
/// machine switches energy, or even layer within a spill, this fast): a per-spot record's
/// segments are merged across them before matching, their time counted as beam-on (scanning,
/// as the model counts it).
pub const MIN_LAYER_CHANGE_S: f64 = 0.02;

/// Of a layer's gaps (ascending), how many of the shortest are the machine's own pauses, and
/// their time: each at most 3 times the median of the shorter half plus two periods (pauses of
/// one kind last alike; a gating pause stands out), together at most twice the layer's planned
/// pauses plus two periods a gap (so a base machine's pause time off by a factor of up to 2 still
/// finds them, for calibration to fit).
fn machine_pauses(gaps: &[f64], pause_s: f64, period_s: f64) -> (usize, f64) {
    if pause_s <= 0.0 || gaps.is_empty() {
        return (0, 0.0);
    }
    let shorter = &gaps[..gaps.len().div_ceil(2)];
    let typical = shorter[shorter.len() / 2];
    let cap = 3.0 * typical + 2.0 * period_s;
    let budget = 2.0 * pause_s + 2.0 * period_s * gaps.len() as f64;
    let (mut n, mut total) = (0, 0.0);
    for &g in gaps {
        if g > cap || total + g > budget {
            break;
        }
        n += 1;
        total += g;
    }
    (n, total)
}

/// A layer from its segments; `pause_s` is the machine's own pauses the plan gives it.
fn logged_layer(index: usize, parts: &[BeamSegment], pause_s: f64, period_s: f64) -> LoggedLayer {
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    let mut gaps: Vec<f64> = parts
        .windows(2)
        .map(|w| (w[1].start_s - w[0].end_s).max(0.0))
        .collect();
    gaps.sort_by(f64::total_cmp);
    let (pauses, paused_s) = machine_pauses(&gaps, pause_s, period_s);
    LoggedLayer {
        index,
        start_s: first.start_s,
        end_s: last.end_s,
        beam_on_s: parts.iter().map(|p| p.end_s - p.start_s).sum::<f64>() + paused_s,
        segments: parts.len(),
        pause_gaps_s: gaps[..pauses].to_vec(),
        interruptions: gaps.len() - pauses,
        angle_start_deg: first.angle_start_deg,
        angle_end_deg: last.angle_end_deg,
        uncertain_edges: parts
            .iter()
            .map(|p| usize::from(p.start_uncertain) + usize::from(p.end_uncertain))
            .sum(),
        ends_early: false,
    }
}

impl LoggedLayer {
    /// How many of the gaps between its segments are the machine's own pauses.
    pub fn pauses(&self) -> usize {
        self.pause_gaps_s.len()
    }
}

/// Signed difference `a - b` of two angles, in (-180, 180].
pub fn angle_diff_deg(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    if d > 180.0 {
        d - 360.0
    } else {
        d
    }
}

/// Every logged layer irradiated within its window (plus [`ANGLE_TOLERANCE_DEG`]).
fn check_angles(logged: &[LoggedLayer], plan: &[Planned]) -> Result<(), String> {
    for l in logged {
        let p = plan[l.index];
        let reach = p.window_deg / 2.0 + ANGLE_TOLERANCE_DEG;
        for a in [l.angle_start_deg, l.angle_end_deg] {
            if angle_diff_deg(a, p.angle_deg).abs() > reach {
                return Err(format!(
                    "layer {} (arc {}, control point {}, {} MeV) is irradiated at {a:.2} deg \
                     in the log (t = {:.3} s), the plan's window is {} ± {} deg: a log of \
                     another plan?",
                    l.index,
                    p.arc,
                    p.control_point,
                    p.energy_mev,
                    l.start_s,
                    p.angle_deg,
                    p.window_deg / 2.0
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn segment(start_s: f64, on_s: f64, mu: Option<f64>) -> BeamSegment {
        BeamSegment {
            start_s,
            end_s: start_s + on_s,
            angle_start_deg: 0.0,
            angle_end_deg: 0.0,
            energy_mev: None,
            start_uncertain: false,
            end_uncertain: false,
            mu,
        }
    }

    fn layer(on_s: f64, mu: f64) -> Planned {
        Planned {
            arc: 0,
            control_point: 0,
            angle_deg: 0.0,
            window_deg: 1.0,
            energy_mev: 100.0,
            on_s,
            pause_s: 0.0,
            mu,
        }
    }

    /// Three layers in one window, the middle one's beam-on cut by a 3 s pause, its beam twice
    /// as slow as the base's model says. By time, cutting at the pause fits as well as cutting
    /// at the switch, and the longer gap wins; the MU (10, 30, 10) say where the layers are.
    #[test]
    fn the_mu_column_decides_where_the_beam_on_times_cannot() {
        let layers = [layer(1.0, 10.0), layer(1.0, 30.0), layer(1.0, 10.0)];
        let times = [
            (0.0, 1.0, 10.0),
            (1.5, 1.0, 15.0),
            (5.5, 1.0, 15.0),
            (7.0, 1.0, 10.0),
        ];
        let with_mu: Vec<BeamSegment> = times
            .iter()
            .map(|&(t, on, mu)| segment(t, on, Some(mu)))
            .collect();
        let without: Vec<BeamSegment> = times
            .iter()
            .map(|&(t, on, _)| segment(t, on, None))
            .collect();
        assert_eq!(layer_cuts(&with_mu, &layers, 0.01), vec![1, 3, 4]);
        // Without it, the time alone is fooled (the pause is the longer gap).
        assert_eq!(layer_cuts(&without, &layers, 0.01), vec![2, 3, 4]);
    }

    /// MU seen only on beam-off rows (a spot shorter than the sampling) goes with the segment
    /// nearer in time; each segment's own rows and the first row after it are its.
    #[test]
    fn mu_between_segments_goes_to_the_nearer() {
        let row = |t_s: f64, beam_on: bool, mu: f64| LogSample {
            t_s,
            gantry_angle_deg: 0.0,
            beam_on,
            energy_mev: None,
            spot: None,
            mu: Some(mu),
        };
        let samples = vec![
            row(0.0, true, 1.0),
            row(0.1, true, 1.0),
            row(0.2, false, 1.0),
            row(0.3, false, 0.5),
            row(1.0, false, 0.25),
            row(1.1, true, 2.0),
            row(1.2, false, 0.0),
        ];
        let log = DeliveryLog {
            source: "rows".into(),
            samples,
            has_energy: false,
            has_spot: false,
            has_mu: true,
            wraps_unwrapped: 0,
            glitches_rejected: 0,
            edge_resolution_s: None,
        };
        let mu: Vec<f64> = beam_segments(&log)
            .iter()
            .map(|g| g.mu.expect("mu"))
            .collect();
        assert_eq!(mu, vec![3.5, 2.25]);
    }
}
