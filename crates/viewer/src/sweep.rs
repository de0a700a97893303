//! Logging sweep results (plan × machine variant × schedule) from `arcsim-evaluator`.

use std::path::Path;

use arcsim_evaluator::{describe_setting, Row, Status};
use rerun::components::TextLogLevel;
use rerun::{RecordingStreamBuilder, TimeColumn};

use crate::layout::send_sweep_blueprint;
use crate::ViewerError;

/// Application id of sweep recordings.
pub const SWEEP_APP_ID: &str = "arcsim-sweep";

/// Sequence timeline of a sweep: the combination index of each row.
pub const COMBINATION: &str = "combination";

/// Sequence timelines of a sweep with the setting's limits in thousandths (Rerun timelines are
/// integers): choosing one in the viewer plots delivery time against that limit.
pub const SWEEP_JERK: &str = "jerk_mdeg_per_s3";
/// See [`SWEEP_JERK`].
pub const SWEEP_ACCEL: &str = "accel_mdeg_per_s2";
/// See [`SWEEP_JERK`].
pub const SWEEP_SPEED: &str = "speed_mdeg_per_s";

fn milli(x: f64) -> i64 {
    (x * 1000.0).round() as i64
}

/// The four sequence timelines of `rows`: combination index and J, A, V in thousandths.
fn time_columns(rows: &[&Row]) -> [TimeColumn; 4] {
    let limit = |name: &'static str, f: fn(&Row) -> f64| {
        TimeColumn::new_sequence(name, rows.iter().map(|r| milli(f(r))))
    };
    [
        TimeColumn::new_sequence(COMBINATION, rows.iter().map(|r| r.index as i64)),
        limit(SWEEP_JERK, |r| r.setting.jerk_deg_per_s3),
        limit(SWEEP_ACCEL, |r| r.setting.accel_deg_per_s2),
        limit(SWEEP_SPEED, |r| r.setting.speed_deg_per_s),
    ]
}

/// The limit swept over the most values (J first on ties), else the combination index: the
/// timeline the file opens on.
fn default_timeline(rows: &[Row]) -> &'static str {
    let distinct = |f: fn(&Row) -> f64| {
        let mut v: Vec<i64> = rows.iter().map(|r| milli(f(r))).collect();
        v.sort_unstable();
        v.dedup();
        v.len()
    };
    let axes: [(&'static str, usize); 3] = [
        (SWEEP_JERK, distinct(|r| r.setting.jerk_deg_per_s3)),
        (SWEEP_ACCEL, distinct(|r| r.setting.accel_deg_per_s2)),
        (SWEEP_SPEED, distinct(|r| r.setting.speed_deg_per_s)),
    ];
    let best = axes
        .iter()
        .fold(axes[0], |b, a| if a.1 > b.1 { *a } else { b });
    if best.1 > 1 {
        best.0
    } else {
        COMBINATION
    }
}

/// Entity path of the per-row text log of a sweep.
pub const SWEEP_ROWS: &str = "rows";

/// One entity-path part from a plan label such as `plans/prostate.json` or `atom:liver`.
fn slug(label: &str) -> String {
    let s: String = label
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect();
    s.trim_matches('_').to_owned()
}

/// Writes sweep `rows` to the `.rrd` file `path` on the `combination` timeline and on one
/// timeline per limit ([`SWEEP_JERK`], [`SWEEP_ACCEL`], [`SWEEP_SPEED`]):
/// per (plan, schedule) `sweep/<plan>/<schedule>/times` = Scalars [total, beam on, energy
/// switching, gantry] (s) and `sweep/<plan>/<schedule>/limits` = Scalars [J, A, V] of the
/// setting; feasible rows only. `rows` (a text log) has one entry per row, with its status.
/// The layout plots the times of each (plan, schedule) in a grid above the row log, against the
/// most swept limit.
pub fn save_sweep(path: &Path, title: &str, rows: &[Row]) -> Result<(), ViewerError> {
    let rec = RecordingStreamBuilder::new(SWEEP_APP_ID)
        .enabled(true)
        .recording_name(title)
        .save(path)
        .map_err(|source| ViewerError::Save {
            path: path.to_owned(),
            source,
        })?;

    // Groups in first-seen order.
    let mut groups: Vec<(String, Vec<&Row>)> = vec![];
    for r in rows {
        let origin = format!("sweep/{}/{}", slug(&r.plan), r.schedule.name());
        match groups.iter_mut().find(|g| g.0 == origin) {
            Some(g) => g.1.push(r),
            None => groups.push((origin, vec![r])),
        }
    }
    let plots: Vec<(String, String)> = groups
        .iter()
        .map(|(origin, g)| {
            (
                format!("{} · {} (s)", g[0].plan, g[0].schedule.name()),
                format!("{origin}/times"),
            )
        })
        .collect();
    send_sweep_blueprint(&rec, &plots, SWEEP_ROWS, default_timeline(rows))?;

    for (origin, group) in &groups {
        let ok: Vec<(&Row, &arcsim_evaluator::Outcome)> = group
            .iter()
            .filter_map(|r| r.outcome.as_ref().map(|o| (*r, o)))
            .collect();
        let ok_rows: Vec<&Row> = ok.iter().map(|(r, _)| *r).collect();
        let index = || time_columns(&ok_rows);
        rec.log_static(
            format!("{origin}/times"),
            &rerun::SeriesPoints::new()
                .with_names(["total", "beam on", "energy switching", "gantry"])
                // The same colours in every plot (red: beam on, as in delivery recordings).
                .with_colors([
                    [235, 235, 235],
                    [230, 60, 60],
                    [80, 160, 255],
                    [255, 170, 40],
                ]),
        )?;
        let times = ok.iter().flat_map(|(_, o)| {
            [
                o.total_s,
                o.breakdown.beam_on_s,
                o.breakdown.energy_switching_s,
                o.breakdown.lost_s,
            ]
        });
        let columns = rerun::Scalars::new(times).columns(std::iter::repeat_n(4, ok.len()))?;
        rec.send_columns(format!("{origin}/times"), index(), columns)?;

        rec.log_static(
            format!("{origin}/limits"),
            &rerun::SeriesPoints::new().with_names(["J", "A", "V"]),
        )?;
        let limits = ok.iter().flat_map(|(r, _)| {
            [
                r.setting.jerk_deg_per_s3,
                r.setting.accel_deg_per_s2,
                r.setting.speed_deg_per_s,
            ]
        });
        let columns = rerun::Scalars::new(limits).columns(std::iter::repeat_n(3, ok.len()))?;
        rec.send_columns(format!("{origin}/limits"), index(), columns)?;
    }

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
    let all: Vec<&Row> = rows.iter().collect();
    rec.send_columns(SWEEP_ROWS, time_columns(&all), columns)?;

    let target = path.display().to_string();
    rec.flush_blocking()
        .map_err(|source| ViewerError::Flush { target, source })?;
    Ok(())
}
