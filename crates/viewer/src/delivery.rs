//! Logging one simulated delivery.
//!
//! Temporal data goes through `send_columns` with explicit `time` / `angle_cdeg` columns, so the
//! caller's stream keeps its own time cursor and gets no `log_tick`/`log_time` columns from us.

use arcsim_sequencer::{Delivery, GantryState, Limiter, PieceKind, SpeedBound, Timeline};
use rerun::components::{InterpolationMode, TextLogLevel};
use rerun::{Color, RecordingStream, TimeColumn};

use crate::timelines::{ANGLE_CDEG, TIME};
use crate::{paths, ViewerError, ViewerOptions};

/// Upper bound on logged gantry samples (a too-small interval would exhaust memory).
const MAX_SAMPLES: usize = 2_000_000;

/// Radius of the ring of control points in the 2D gantry view; the beam starts a bit outside it.
const RING_R: f32 = 1.0;
const HEAD_R: f32 = 1.25;

const BLUE: Color = rgb(31, 119, 180);
const RED: Color = rgb(214, 39, 40);
const ORANGE: Color = rgb(255, 127, 14);
const GREEN: Color = rgb(44, 160, 44);
const PURPLE: Color = rgb(148, 103, 189);
const GREY: Color = rgb(140, 140, 140);
const LIMIT: Color = rgb(200, 60, 60);
const LIMIT_DECEL: Color = rgb(230, 150, 60);

/// The phases logged on [`paths::PHASE`].
pub(crate) const PHASE_BEAM: &str = "beam on";
pub(crate) const PHASE_SWITCH: &str = "energy switch";
pub(crate) const PHASE_GANTRY: &str = "gantry";

pub(crate) const fn rgb(r: u8, g: u8, b: u8) -> Color {
    Color(rerun::datatypes::Rgba32::from_rgb(r, g, b))
}

/// Logs `delivery` into `rec`: gantry time series with their limits, energy steps, phases,
/// a text entry per layer and the 2D gantry view (see [`crate::paths`]).
pub fn log_delivery(
    rec: &RecordingStream,
    delivery: &Delivery,
    opts: &ViewerOptions,
) -> Result<(), ViewerError> {
    let timeline = delivery.timeline.as_ref().ok_or(ViewerError::NoTimeline)?;
    let samples = sample(timeline, opts.sample_dt_s)?;
    log_styles(rec)?;
    log_motion(rec, delivery, &samples)?;
    log_energy(rec, delivery, timeline)?;
    log_lost(rec, delivery, timeline)?;
    log_phases(rec, delivery, timeline)?;
    log_layer_text(rec, delivery, timeline)?;
    log_gantry_2d(rec, delivery, &samples)?;
    Ok(())
}

/// The delivery's timeline, if it has one and `opts` can sample it.
pub(crate) fn check<'a>(
    delivery: &'a Delivery,
    opts: &ViewerOptions,
) -> Result<&'a Timeline, ViewerError> {
    let timeline = delivery.timeline.as_ref().ok_or(ViewerError::NoTimeline)?;
    let dt = opts.sample_dt_s;
    if !(dt.is_finite() && dt > 0.0) {
        return Err(ViewerError::InvalidSampleDt(dt));
    }
    let total = timeline.duration_s();
    let count = total / dt + 2.0 * timeline.pieces.len() as f64;
    if count > MAX_SAMPLES as f64 {
        return Err(ViewerError::TooManySamples {
            dt_s: dt,
            total_s: total,
            samples: count.ceil(),
            max: MAX_SAMPLES,
        });
    }
    Ok(timeline)
}

/// One logged gantry state; `beam` is the layer being irradiated, if any.
struct Sample {
    t: f64,
    state: GantryState,
    beam: Option<usize>,
}

/// Uniform samples every `dt` plus both sides of every piece boundary, in time order. At a
/// boundary the end of the earlier piece comes first, so jerk steps are drawn as vertical edges.
fn sample(timeline: &Timeline, dt: f64) -> Result<Vec<Sample>, ViewerError> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(ViewerError::InvalidSampleDt(dt));
    }
    let total = timeline.duration_s();
    let count = total / dt + 2.0 * timeline.pieces.len() as f64;
    if count > MAX_SAMPLES as f64 {
        return Err(ViewerError::TooManySamples {
            dt_s: dt,
            total_s: total,
            samples: count.ceil(),
            max: MAX_SAMPLES,
        });
    }
    let beam_of = |kind: PieceKind| match kind {
        PieceKind::Beam { layer } => Some(layer),
        PieceKind::Move { .. } | PieceKind::RunUp { .. } => None,
    };
    // (t, order at equal t: 0 = end of a piece, 1 = grid, 2 = start of a piece, sample)
    let mut keyed: Vec<(f64, u8, Sample)> = Vec::with_capacity(count as usize + 2);
    for (t, state) in timeline.samples(dt) {
        keyed.push((
            t,
            1,
            Sample {
                t,
                state,
                beam: timeline.beam_layer_at(t),
            },
        ));
    }
    for p in &timeline.pieces {
        let beam = beam_of(p.kind);
        let t0 = p.t_start_s;
        let t1 = p.t_start_s + p.duration_s;
        keyed.push((
            t0,
            2,
            Sample {
                t: t0,
                state: p.state_after(0.0),
                beam,
            },
        ));
        keyed.push((
            t1,
            0,
            Sample {
                t: t1,
                state: p.state_after(p.duration_s),
                beam,
            },
        ));
    }
    keyed.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut out: Vec<Sample> = Vec::with_capacity(keyed.len());
    for (_, _, s) in keyed {
        if out.last().is_some_and(|l| l.t == s.t && l.state == s.state) {
            continue;
        }
        out.push(s);
    }
    Ok(out)
}

/// The angle timeline's value for a gantry angle (hundredths of a degree).
pub(crate) fn angle_cdeg(angle_deg: f64) -> i64 {
    (angle_deg * 100.0).round() as i64
}

/// The two index columns of rows at `times` with gantry angles `angles`.
pub(crate) fn index_columns(
    times: &[f64],
    angles: impl IntoIterator<Item = f64>,
) -> [TimeColumn; 2] {
    [
        TimeColumn::new_duration_secs(TIME, times.iter().copied()),
        TimeColumn::new_sequence(ANGLE_CDEG, angles.into_iter().map(angle_cdeg)),
    ]
}

/// A series line: legend name, colour, width.
type Style = (&'static str, Color, f32);

/// A limit line: its style and constant value.
type Limit = (Style, f64);

/// Static styling of the energy and phase entities (the motion series style themselves).
fn log_styles(rec: &RecordingStream) -> Result<(), ViewerError> {
    rec.log_static(
        paths::ENERGY,
        &series_lines(&[("nominal energy (MeV)", BLUE, 2.0)])
            .with_interpolation_mode(InterpolationMode::StepAfter),
    )?;
    rec.log_static(
        paths::LOST,
        &series_lines(&[("lost time per transition (s)", GREY, 2.0)])
            .with_interpolation_mode(InterpolationMode::StepAfter),
    )?;
    rec.log_static(
        paths::PHASE,
        &rerun::StateConfiguration::new()
            .with_values([PHASE_BEAM, PHASE_SWITCH, PHASE_GANTRY])
            .with_labels(["beam on", "energy switch (ELST)", "gantry (beyond ELST)"])
            .with_colors([RED, BLUE, GREY]),
    )?;
    Ok(())
}

fn series_lines(styles: &[Style]) -> rerun::SeriesLines {
    rerun::SeriesLines::new()
        .with_names(styles.iter().map(|s| s.0))
        .with_colors(styles.iter().map(|s| s.1))
        .with_widths(styles.iter().map(|s| s.2))
}

/// The limit lines of speed and acceleration for the directions the gantry actually turns
/// (CW positive): moving CW the bounds are +V, +A (speeding up) and −D (braking); CCW mirrors them.
fn speed_accel_limits(d: &Delivery, samples: &[Sample]) -> (Vec<Limit>, Vec<Limit>) {
    let l = &d.limits;
    let (v, a, dec) = (
        l.max_speed_deg_per_s,
        l.max_accel_deg_per_s2,
        l.max_decel_deg_per_s2,
    );
    let ccw = samples.iter().any(|s| s.state.speed_deg_per_s < -1e-9);
    let cw = !ccw || samples.iter().any(|s| s.state.speed_deg_per_s > 1e-9);
    let mut speed = vec![];
    let mut accel: Vec<Limit> = vec![];
    if cw {
        speed.push((("+V", LIMIT, 1.0), v));
        accel.push((("+A", LIMIT, 1.0), a));
        accel.push((("−D", LIMIT_DECEL, 1.0), -dec));
    }
    if ccw {
        speed.push((("−V", LIMIT, 1.0), -v));
        accel.push((("−A", LIMIT, 1.0), -a));
        accel.push((("+D", LIMIT_DECEL, 1.0), dec));
    }
    if a == dec {
        // One pair of lines, named ±A.
        accel.retain(|(style, _)| !style.0.ends_with('D'));
        if cw && !ccw {
            accel.push((("−A", LIMIT, 1.0), -a));
        } else if ccw && !cw {
            accel.push((("+A", LIMIT, 1.0), a));
        }
    }
    (speed, accel)
}

/// Angle, speed, acceleration and jerk, each with its limits as extra series of the same entity.
fn log_motion(rec: &RecordingStream, d: &Delivery, samples: &[Sample]) -> Result<(), ViewerError> {
    let times: Vec<f64> = samples.iter().map(|s| s.t).collect();
    let angles = || samples.iter().map(|s| s.state.angle_deg);
    let j = d.limits.max_jerk_deg_per_s3;
    let (speed_limits, accel_limits) = speed_accel_limits(d, samples);
    let jerk_limits = vec![(("+J", LIMIT, 1.0), j), (("−J", LIMIT, 1.0), -j)];
    type Value = fn(&GantryState) -> f64;
    let series: [(&str, Style, Value, Vec<Limit>); 4] = [
        (
            paths::ANGLE,
            ("gantry angle (°)", PURPLE, 2.0),
            |s| s.angle_deg,
            vec![],
        ),
        (
            paths::SPEED,
            ("speed (°/s)", BLUE, 2.0),
            |s| s.speed_deg_per_s,
            speed_limits,
        ),
        (
            paths::ACCEL,
            ("acceleration (°/s²)", ORANGE, 2.0),
            |s| s.accel_deg_per_s2,
            accel_limits,
        ),
        (
            paths::JERK,
            ("jerk (°/s³)", GREEN, 1.5),
            |s| s.jerk_deg_per_s3,
            jerk_limits,
        ),
    ];
    for (path, style, value, limits) in series {
        let mut styles = vec![style];
        styles.extend(limits.iter().map(|l| l.0));
        rec.log_static(path, &series_lines(&styles))?;
        let limits: Vec<f64> = limits.iter().map(|l| l.1).collect();
        let width = 1 + limits.len();
        let mut flat = Vec::with_capacity(samples.len() * width);
        for s in samples {
            flat.push(value(&s.state));
            flat.extend_from_slice(&limits);
        }
        let columns =
            rerun::Scalars::new(flat).columns(std::iter::repeat_n(width, samples.len()))?;
        rec.send_columns(path, index_columns(&times, angles()), columns)?;
    }
    Ok(())
}

/// Nominal energy of each layer from its beam-on start, held until the next layer starts.
fn log_energy(rec: &RecordingStream, d: &Delivery, timeline: &Timeline) -> Result<(), ViewerError> {
    let mut times: Vec<f64> = d.layers.iter().map(|l| l.t_start_s).collect();
    let mut energies: Vec<f64> = d.layers.iter().map(|l| l.energy_mev).collect();
    if let Some(last) = d.layers.last() {
        times.push(timeline.duration_s().max(last.t_start_s));
        energies.push(last.energy_mev);
    }
    let angles: Vec<f64> = times
        .iter()
        .map(|&t| timeline.state_at(t).angle_deg)
        .collect();
    let columns = rerun::Scalars::new(energies).columns_of_unit_batches()?;
    rec.send_columns(paths::ENERGY, index_columns(&times, angles), columns)?;
    Ok(())
}

/// Each transition's lost time, held from its start to its end (0 in between).
fn log_lost(rec: &RecordingStream, d: &Delivery, timeline: &Timeline) -> Result<(), ViewerError> {
    let mut times = Vec::with_capacity(2 * d.transitions.len());
    let mut lost = Vec::with_capacity(2 * d.transitions.len());
    for t in &d.transitions {
        times.extend([t.t_start_s, t.t_start_s + t.duration_s]);
        lost.extend([t.lost_s.max(0.0), 0.0]);
    }
    if times.is_empty() {
        return Ok(());
    }
    let angles: Vec<f64> = times
        .iter()
        .map(|&t| timeline.state_at(t).angle_deg)
        .collect();
    let columns = rerun::Scalars::new(lost).columns_of_unit_batches()?;
    rec.send_columns(paths::LOST, index_columns(&times, angles), columns)?;
    Ok(())
}

/// Beam on / energy switch / gantry phases; an empty state ends the last phase.
fn log_phases(rec: &RecordingStream, d: &Delivery, timeline: &Timeline) -> Result<(), ViewerError> {
    let mut rows: Vec<(f64, &str)> = d.layers.iter().map(|l| (l.t_start_s, PHASE_BEAM)).collect();
    for tr in &d.transitions {
        let elst = tr.elst_s.min(tr.duration_s).max(0.0);
        if elst > 0.0 {
            rows.push((tr.t_start_s, PHASE_SWITCH));
        }
        if tr.duration_s > elst {
            rows.push((tr.t_start_s + elst, PHASE_GANTRY));
        }
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    rows.push((timeline.duration_s(), ""));
    let times: Vec<f64> = rows.iter().map(|r| r.0).collect();
    let angles = times.iter().map(|&t| timeline.state_at(t).angle_deg);
    let columns = rerun::StateChange::new()
        .with_state(rows.iter().map(|r| r.1))
        .columns_of_unit_batches()?;
    rec.send_columns(paths::PHASE, index_columns(&times, angles), columns)?;
    Ok(())
}

fn bound_name(b: SpeedBound) -> &'static str {
    match b {
        SpeedBound::Rest => "at rest (arc end)",
        SpeedBound::Window => "window",
        SpeedBound::MaxSpeed => "max speed V",
        SpeedBound::Gap => "gap (A/J)",
        SpeedBound::Elst => "ELST",
        SpeedBound::Prescribed => "prescribed",
        SpeedBound::StepAndShoot => "step-and-shoot",
        SpeedBound::Optimised => "optimised",
        SpeedBound::Servo => "servo period",
        SpeedBound::Free => "free motion (mean speed)",
        SpeedBound::OneSpeed => "the arc's one speed",
    }
}

fn limiter_name(l: Limiter) -> &'static str {
    match l {
        Limiter::Elst => "ELST",
        Limiter::Speed => "speed V",
        Limiter::Accel => "acceleration A",
        Limiter::Jerk => "jerk J",
        Limiter::None => "nothing",
    }
}

/// A summary at t = 0, one entry per layer at its beam-on start, warnings for violations.
fn log_layer_text(
    rec: &RecordingStream,
    d: &Delivery,
    timeline: &Timeline,
) -> Result<(), ViewerError> {
    let b = &d.breakdown;
    let mut rows: Vec<(f64, String, &str)> = vec![(
        0.0,
        format!(
            "{} schedule, {} motion{}: total {:.1} s = beam on {:.1} s + energy switching {:.1} s + gantry {:.1} s; {} layers{}",
            d.schedule.name(),
            d.motion.name(),
            if d.motion.speed_changes_during_beam() {
                format!(" (arc ends {})", d.arc_ends.name())
            } else {
                String::new()
            },
            d.total_s,
            b.beam_on_s,
            b.energy_switching_s,
            b.lost_s,
            d.layers.len(),
            d.constant_speed_total_s
                .map(|c| format!("; constant speed per layer would take {c:.1} s"))
                .unwrap_or_default()
        ),
        TextLogLevel::INFO,
    )];
    for l in &d.layers {
        let transition = if l.index == 0 {
            String::new()
        } else {
            format!(
                "; transition in {:.2} s, limited by {} (the limit whose raise shortens it most)",
                l.transition_in_s,
                limiter_name(l.transition_limited_by)
            )
        };
        rows.push((
            l.t_start_s,
            format!(
                "layer {} (arc {}, cp {}, layer {}) at {:.1}°: {:.1} MeV, {:.2} s at {:.2} °/s (speed set by {}){}",
                l.index,
                l.arc,
                l.control_point,
                l.layer,
                l.angle_deg,
                l.energy_mev,
                l.irradiation_s,
                l.speed_deg_per_s,
                bound_name(l.speed_bound),
                transition
            ),
            TextLogLevel::INFO,
        ));
    }
    for v in &d.violations {
        let t = d.layers.get(v.layer).map_or(0.0, |l| l.t_start_s);
        rows.push((
            t,
            format!(
                "layer {} (arc {}, cp {}): prescribed {:.2} °/s infeasible, delivered {:.2} °/s: {}",
                v.layer, v.arc, v.control_point, v.prescribed_deg_per_s, v.corrected_deg_per_s, v.reason
            ),
            TextLogLevel::WARN,
        ));
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    let times: Vec<f64> = rows.iter().map(|r| r.0).collect();
    let angles = times.iter().map(|&t| timeline.state_at(t).angle_deg);
    let columns = rerun::TextLog::update_fields()
        .with_many_text(rows.iter().map(|r| r.1.as_str()))
        .with_many_level(rows.iter().map(|r| r.2))
        .columns_of_unit_batches()?;
    rec.send_columns(paths::LAYERS, index_columns(&times, angles), columns)?;
    Ok(())
}

/// Screen position of a gantry angle at radius `r`: 0° at the top, clockwise on screen
/// (Rerun's 2D views have y pointing down).
fn polar(angle_deg: f64, r: f32) -> [f32; 2] {
    let (s, c) = angle_deg.to_radians().sin_cos();
    [r * s as f32, -r * c as f32]
}

/// Viridis colour ramp, `x` in [0, 1].
pub(crate) fn viridis(x: f64) -> Color {
    const STOPS: [[f64; 3]; 5] = [
        [68.0, 1.0, 84.0],
        [59.0, 82.0, 139.0],
        [33.0, 145.0, 140.0],
        [94.0, 201.0, 98.0],
        [253.0, 231.0, 37.0],
    ];
    let x = if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        0.0
    } * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f64;
    let c = |k: usize| (STOPS[i][k] + f * (STOPS[i + 1][k] - STOPS[i][k])).round() as u8;
    rgb(c(0), c(1), c(2))
}

/// The gantry seen along its axis: ring, isocentre, layers coloured by energy, and the beam.
fn log_gantry_2d(
    rec: &RecordingStream,
    d: &Delivery,
    samples: &[Sample],
) -> Result<(), ViewerError> {
    let ring: Vec<[f32; 2]> = (0..=360).map(|a| polar(f64::from(a), RING_R)).collect();
    rec.log_static(
        paths::GANTRY_RING,
        &rerun::LineStrips2D::new([ring])
            .with_colors([rgb(90, 90, 90)])
            .with_radii([0.004]),
    )?;
    rec.log_static(
        paths::GANTRY_ISOCENTRE,
        &rerun::Points2D::new([[0.0_f32, 0.0]])
            .with_radii([0.03])
            .with_colors([rgb(230, 230, 230)])
            .with_labels(["isocentre"]),
    )?;

    let (e_min, e_max) = d
        .layers
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), l| {
            (lo.min(l.energy_mev), hi.max(l.energy_mev))
        });
    let span = if e_max > e_min { e_max - e_min } else { 1.0 };
    // Several layers at one control point sit on slightly larger radii.
    let positions = d
        .layers
        .iter()
        .map(|l| polar(l.angle_deg, RING_R + 0.035 * l.layer as f32));
    let colors = d
        .layers
        .iter()
        .map(|l| viridis((l.energy_mev - e_min) / span));
    let labels = d.layers.iter().map(|l| format!("{:.1} MeV", l.energy_mev));
    rec.log_static(
        paths::GANTRY_CONTROL_POINTS,
        &rerun::Points2D::new(positions)
            .with_colors(colors)
            .with_radii([0.018])
            .with_labels(labels)
            .with_show_labels(false),
    )?;

    let times: Vec<f64> = samples.iter().map(|s| s.t).collect();
    let origins: Vec<[f32; 2]> = samples
        .iter()
        .map(|s| polar(s.state.angle_deg, HEAD_R))
        .collect();
    let vectors = origins.iter().map(|o| [-o[0], -o[1]]);
    let colors = samples
        .iter()
        .map(|s| if s.beam.is_some() { RED } else { GREY });
    let labels = samples.iter().map(|s| match s.beam {
        Some(layer) => format!("beam on, layer {layer}: {:.1}°", s.state.angle_deg),
        None => format!("beam off: {:.1}°", s.state.angle_deg),
    });
    let columns = rerun::Arrows2D::from_vectors(vectors)
        .with_origins(origins.iter().copied())
        .with_colors(colors)
        .with_labels(labels)
        .with_radii(std::iter::repeat_n(0.02_f32, samples.len()))
        .columns_of_unit_batches()?;
    rec.send_columns(
        paths::GANTRY_BEAM,
        index_columns(&times, samples.iter().map(|s| s.state.angle_deg)),
        columns,
    )?;
    Ok(())
}
