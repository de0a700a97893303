//! Logging sweep results (plan × machine variant × schedule) from `arcsim-evaluator`.
//!
//! The question a sweep answers is *which limit buys how much, and where does it stop paying*,
//! so the recording plots, per plan and schedule, the delivery time against each swept limit
//! (J, A, V) as lines, one line per setting of the other limits ("A 0.5, V 5"). Rerun plots
//! against integer timelines only, so every such plot uses one sequence timeline,
//! [`SWEEP_X`], holding the plotted limit's value in a unit chosen per plot (°/s³, 0.1 °/s³,
//! 0.01 °/s³ or 0.001 °/s³: the coarsest that writes every swept value exactly), named in the
//! plot's title. A plot shows at most [`MAX_LINES`] lines (the legend must fit beside the data):
//! beyond that, the lines of an evenly spread subset of the other limits' values, ends included,
//! and the title says how many of how many.

use std::path::Path;

use arcsim_evaluator::{describe_setting, short, Axis, Row, Status};
use rerun::components::TextLogLevel;
use rerun::{RecordingStream, TimeColumn};

use crate::layout::{send_sweep_blueprint, SweepPlot, SweepTab};
use crate::ViewerError;

/// Application id of sweep recordings.
pub const SWEEP_APP_ID: &str = "arcsim-sweep";

/// Sequence timeline of a sweep: the combination index of each row.
pub const COMBINATION: &str = "combination";

/// Sequence timeline of a sweep's plots: the plotted limit's value in the plot's unit (see the
/// module documentation); the row log holds the combination index on it.
pub const SWEEP_X: &str = "swept_limit";

/// Entity path of the per-row text log of a sweep.
pub const SWEEP_ROWS: &str = "rows";

/// Entity path of the sweep's summary (a markdown `TextDocument`, when given).
pub const SWEEP_SUMMARY: &str = "summary";

/// Where the summary is logged on [`SWEEP_X`] and [`COMBINATION`]: below and above every
/// plotted value and combination index.
const BEFORE_ALL: i64 = -1;
/// See [`BEFORE_ALL`].
const AFTER_ALL: i64 = 1 << 50;

/// One entity-path part from a label such as `plans/prostate.json`, `atom:liver` or `A 0.5, V 5`.
fn slug(label: &str) -> String {
    let s: String = label
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect();
    s.trim_matches('_').to_owned()
}

/// The fewest decimals (0 to 3) that write every value of `values` exactly (to 1e-6 of a step).
fn decimals(values: &[f64]) -> u32 {
    (0..3)
        .find(|&d| {
            let scale = 10f64.powi(d as i32);
            values
                .iter()
                .all(|v| ((v * scale) - (v * scale).round()).abs() < 1e-6)
        })
        .unwrap_or(3)
}

/// The limits a plot may have on its x axis.
const PLOTTED: [Axis; 3] = [Axis::Jerk, Axis::Accel, Axis::Speed];

/// A value of a row's setting on `axis` (the base machine's when the setting keeps it).
fn value(r: &Row, axis: Axis) -> Option<f64> {
    r.setting.get_or(axis, &r.defaults)
}

/// The line a row belongs to in the plot against `axis`: the row's other limits (J, A, V and
/// whatever ELST, window, scanning speed or dose-rate scale the row sets).
fn line_key(r: &Row, axis: Axis) -> Vec<(Axis, f64)> {
    Axis::ALL
        .into_iter()
        .filter(|&a| a != axis && (PLOTTED.contains(&a) || r.setting.get(a).is_some()))
        .filter_map(|a| value(r, a).map(|v| (a, v)))
        .collect()
}

/// "A 0.5, V 5".
fn line_name(key: &[(Axis, f64)]) -> String {
    key.iter()
        .map(|(a, v)| format!("{} {}", a.symbol().0, short(*v)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Most lines in one plot: a longer legend would not fit beside the data.
pub const MAX_LINES: usize = 12;

/// `m` of the sorted `values`, evenly spread by position, both ends included.
fn spread(values: &[f64], m: usize) -> Vec<f64> {
    let n = values.len();
    if m >= n {
        return values.to_vec();
    }
    if m <= 1 {
        return values[..1].to_vec();
    }
    (0..m).map(|k| values[k * (n - 1) / (m - 1)]).collect()
}

/// At most [`MAX_LINES`] of `lines`: those whose other limits lie in a subset of each limit's
/// values, evenly spread (ends included), the limit with the most values thinned first.
fn thin(lines: Vec<Line>) -> Vec<Line> {
    if lines.len() <= MAX_LINES {
        return lines;
    }
    let axes = lines[0].key.len();
    let all: Vec<Vec<f64>> = (0..axes)
        .map(|i| {
            let mut v: Vec<f64> = lines.iter().map(|l| l.key[i].1).collect();
            v.sort_by(f64::total_cmp);
            v.dedup();
            v
        })
        .collect();
    let mut keep: Vec<usize> = all.iter().map(Vec::len).collect();
    while keep.iter().product::<usize>() > MAX_LINES {
        let Some((i, _)) = keep.iter().enumerate().max_by_key(|(_, &m)| m) else {
            break;
        };
        if keep[i] <= 1 {
            break;
        }
        keep[i] -= 1;
    }
    let kept: Vec<Vec<f64>> = all.iter().zip(&keep).map(|(v, &m)| spread(v, m)).collect();
    lines
        .into_iter()
        .filter(|l| l.key.iter().zip(&kept).all(|((_, v), k)| k.contains(v)))
        .collect()
}

/// Distinct line colours, cycled (a qualitative palette that reads on the viewer's dark theme).
const PALETTE: [[u8; 3]; 10] = [
    [90, 170, 255],
    [255, 150, 50],
    [90, 210, 110],
    [240, 80, 80],
    [190, 140, 255],
    [200, 150, 110],
    [255, 130, 210],
    [190, 190, 190],
    [220, 220, 60],
    [60, 220, 220],
];

/// One line of a plot: its other limits, name and points (x in the plot's unit, total in s,
/// combination index).
struct Line {
    key: Vec<(Axis, f64)>,
    name: String,
    points: Vec<(i64, f64, usize)>,
}

/// Writes sweep `rows` to the `.rrd` file `path`: per plan a tab, in it per schedule a row of
/// plots of the delivery time (s) against each limit swept over more than one value, one line
/// per setting of the other limits (feasible rows only; entity
/// `sweep/<plan>/<schedule>/vs_<J|A|V>/<line>`, `Scalars` [total] on [`SWEEP_X`] and
/// [`COMBINATION`]); a tab with `summary` (markdown, e.g. the printed summary tables) when given;
/// a tab with the row log ([`SWEEP_ROWS`], one entry per row with its status).
pub fn save_sweep(
    path: &Path,
    title: &str,
    rows: &[Row],
    summary: Option<&str>,
) -> Result<(), ViewerError> {
    let rec = crate::output::save_recording(SWEEP_APP_ID, title, path)?;

    // Plans, then (plan, schedule) groups, in first-seen order.
    let mut tabs: Vec<SweepTab> = vec![];
    for (origin, group) in &groups(rows) {
        let plan = &group[0].plan;
        let schedule = group[0].schedule.name();
        let ok: Vec<&Row> = group
            .iter()
            .copied()
            .filter(|r| r.outcome.is_some())
            .collect();
        let mut plots = vec![];
        for axis in PLOTTED {
            if let Some(plot) = log_plot(&rec, origin, &schedule, &ok, axis)? {
                plots.push(plot);
            }
        }
        match tabs.iter_mut().find(|t| &t.plan == plan) {
            Some(t) => t.rows.push(plots),
            None => tabs.push(SweepTab {
                plan: plan.clone(),
                rows: vec![plots],
            }),
        }
    }
    tabs.retain(|t| t.rows.iter().any(|r| !r.is_empty()));
    send_sweep_blueprint(&rec, &tabs, SWEEP_SUMMARY, SWEEP_ROWS)?;
    log_summary(&rec, summary)?;
    log_rows(&rec, rows)?;

    let target = path.display().to_string();
    rec.flush_blocking()
        .map_err(|source| ViewerError::Flush { target, source })?;
    Ok(())
}

/// The rows grouped by (plan, schedule), as `sweep/PLAN/SCHEDULE` origins, in first-seen order.
fn groups(rows: &[Row]) -> Vec<(String, Vec<&Row>)> {
    let mut groups: Vec<(String, Vec<&Row>)> = vec![];
    for r in rows {
        let origin = format!("sweep/{}/{}", slug(&r.plan), slug(&r.schedule.name()));
        match groups.iter_mut().find(|g| g.0 == origin) {
            Some(g) => g.1.push(r),
            None => groups.push((origin, vec![r])),
        }
    }
    groups
}

/// Logs one group's plot of the total time against `axis` (one line per setting of the other
/// limits); `None` when the group has fewer than two values of the axis.
fn log_plot(
    rec: &RecordingStream,
    origin: &str,
    schedule: &str,
    ok: &[&Row],
    axis: Axis,
) -> Result<Option<SweepPlot>, ViewerError> {
    let mut values: Vec<f64> = ok.iter().filter_map(|r| value(r, axis)).collect();
    values.sort_by(f64::total_cmp);
    values.dedup();
    if values.len() < 2 {
        return Ok(None);
    }
    let d = decimals(&values);
    let scale = 10f64.powi(d as i32);
    let x_of = |v: f64| (v * scale).round() as i64;
    let mut lines: Vec<Line> = vec![];
    let mut sorted = ok.to_vec();
    // Lines in the order of their other limits (as named: J, A, V, ...), points along x.
    sorted.sort_by(|a, b| {
        let key = |r: &Row| {
            let mut k: Vec<f64> = line_key(r, axis).iter().map(|p| p.1).collect();
            k.push(value(r, axis).unwrap_or(0.0));
            k
        };
        key(a)
            .iter()
            .zip(key(b).iter())
            .map(|(x, y)| x.total_cmp(y))
            .find(|o| o.is_ne())
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    for r in sorted {
        let (Some(v), Some(o)) = (value(r, axis), r.outcome) else {
            continue;
        };
        let key = line_key(r, axis);
        let point = (x_of(v), o.total_s, r.index);
        match lines.iter_mut().find(|l| l.key == key) {
            Some(l) => l.points.push(point),
            None => lines.push(Line {
                name: line_name(&key),
                key,
                points: vec![point],
            }),
        }
    }
    let all_lines = lines.len();
    let lines = thin(lines);
    let shown = if lines.len() < all_lines {
        format!("; {} of {all_lines} lines", lines.len())
    } else {
        String::new()
    };
    let sym = axis.symbol().0;
    let plot_origin = format!("{origin}/vs_{sym}");
    for (k, line) in lines.iter().enumerate() {
        log_line(rec, &plot_origin, k, line)?;
    }
    let x_unit = match d {
        0 => axis.unit().to_string(),
        _ => format!("{} {}", short(1.0 / scale), axis.unit()),
    };
    let (lo, hi) = (x_of(values[0]), x_of(values[values.len() - 1]));
    let span = (hi - lo).max(1);
    // From 0 when that costs at most half the plot (the ticks then fall on round values).
    let start = if lo <= span { 0 } else { lo - span / 20 - 1 };
    Ok(Some(SweepPlot {
        title: format!("{schedule}: total (s) vs {sym} (x: {sym} in {x_unit}{shown})"),
        origin: plot_origin,
        // A margin left and right so no point sits on the edge, and a wider one on
        // the right where the legend goes.
        x_range: (start, hi + span * 3 / 5 + 1),
        lines: lines.len(),
    }))
}

/// Logs one line of a plot (its series style, then its points) as the `k`th entity under
/// `plot_origin`.
fn log_line(
    rec: &RecordingStream,
    plot_origin: &str,
    k: usize,
    line: &Line,
) -> Result<(), ViewerError> {
    // The viewer lists a plot's lines in entity-path order: numbered, they keep ours.
    let entity = format!("{plot_origin}/{k:02}_{}", slug(&line.name));
    let color = PALETTE[k % PALETTE.len()];
    rec.log_static(
        entity.as_str(),
        &rerun::SeriesLines::new()
            .with_names([line.name.as_str()])
            .with_colors([color])
            .with_widths([2.0]),
    )?;
    rec.log_static(
        entity.as_str(),
        // The same name as the line: the legend shows one entry for both.
        &rerun::SeriesPoints::new()
            .with_names([line.name.as_str()])
            .with_colors([color])
            .with_marker_sizes([3.0]),
    )?;
    let times = [
        TimeColumn::new_sequence(SWEEP_X, line.points.iter().map(|p| p.0)),
        TimeColumn::new_sequence(COMBINATION, line.points.iter().map(|p| p.2 as i64)),
    ];
    let columns = rerun::Scalars::new(line.points.iter().map(|p| p.1))
        .columns(std::iter::repeat_n(1, line.points.len()))?;
    rec.send_columns(entity.as_str(), times, columns)?;
    Ok(())
}

/// Logs `summary` (or, without one, a note that the run did not complete) before and after
/// every plotted value.
fn log_summary(rec: &RecordingStream, summary: Option<&str>) -> Result<(), ViewerError> {
    // The summary sits before and after every plotted value on both timelines: shown wherever
    // the time cursor is, and the viewer (following the end) opens with the cursor outside every
    // plot's x range instead of on a plotted value.
    let text = summary.unwrap_or("The run did not complete: no summary.");
    for at in [BEFORE_ALL, AFTER_ALL] {
        rec.set_time_sequence(SWEEP_X, at);
        rec.set_time_sequence(COMBINATION, at);
        rec.log(
            SWEEP_SUMMARY,
            &rerun::TextDocument::new(text).with_media_type(rerun::MediaType::markdown()),
        )?;
    }
    rec.reset_time();
    Ok(())
}

/// Logs one line of text per row, warnings for the rows that are not `ok`.
fn log_rows(rec: &RecordingStream, rows: &[Row]) -> Result<(), ViewerError> {
    let text = rows.iter().map(|r| {
        let result = match &r.outcome {
            Some(o) => format!("{:.1} s", o.total_s),
            None => format!("{}: {}", r.status.name(), r.message),
        };
        format!(
            "#{} {} · {} · {}: {}",
            r.index,
            r.plan,
            r.schedule.name(),
            describe_setting(&r.setting),
            result
        )
    });
    let levels = rows.iter().map(|r| {
        if r.status == Status::Ok {
            TextLogLevel::INFO
        } else {
            TextLogLevel::WARN
        }
    });
    let columns = rerun::TextLog::update_fields()
        .with_many_text(text)
        .with_many_level(levels)
        .columns_of_unit_batches()?;
    let index = || rows.iter().map(|r| r.index as i64);
    let times = [
        TimeColumn::new_sequence(COMBINATION, index()),
        TimeColumn::new_sequence(SWEEP_X, index()),
    ];
    rec.send_columns(SWEEP_ROWS, times, columns)?;
    Ok(())
}
