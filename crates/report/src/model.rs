//! What the report shows, taken from a sweep's rows and summary: one [`Section`] per plan and
//! schedule entry, each with its figures.

use std::collections::BTreeMap;

use arcsim_evaluator::{
    describe_setting, short, Axis, Entry, Evaluator, Outcome, Row, Setting, Summary,
};

use crate::figures::{self, Bar, Heatmap, SensitivityBar};
use crate::ReportError;

/// Most values of J or A a heatmap shows (a longer axis is shown at this many values, evenly
/// spread, both ends included), and most heatmaps (values of V) per section.
pub const MAX_CELLS_PER_AXIS: usize = 40;
/// See [`MAX_CELLS_PER_AXIS`].
pub const MAX_HEATMAPS: usize = 12;

/// What a figure shows.
#[derive(Debug, Clone, PartialEq)]
pub enum FigureKind {
    /// Delivery time over J × A at one V (and one value of any other swept limit).
    Heatmap {
        /// The V of every cell (deg/s).
        speed_deg_per_s: f64,
        /// The other swept limits of every cell, e.g. "ELST down 0.6" (empty when none).
        others: String,
    },
    /// Change of the total for +10 % of each limit.
    Sensitivity,
    /// Beam on, energy switching and gantry time of the base, cheapest and fastest settings.
    Breakdown,
}

impl FigureKind {
    /// Short name, as in file names and the HTML's `class`.
    pub fn name(&self) -> &'static str {
        match self {
            FigureKind::Heatmap { .. } => "heatmap",
            FigureKind::Sensitivity => "sensitivity",
            FigureKind::Breakdown => "breakdown",
        }
    }
}

/// One drawn figure.
#[derive(Debug, Clone)]
pub struct Figure {
    /// What the figure shows.
    pub kind: FigureKind,
    /// What the figure shows, in a sentence (the HTML caption).
    pub caption: String,
    /// File name without extension, unique within the report.
    pub file_stem: String,
    /// The SVG document.
    pub svg: String,
}

/// One plan under one schedule entry.
#[derive(Debug, Clone)]
pub struct Section {
    /// The plan, as the sweep names it.
    pub plan: String,
    /// The schedule entry's name.
    pub schedule: String,
    /// Rows of this plan and schedule entry in the report.
    pub rows: usize,
    /// How many of those rows are feasible.
    pub feasible: usize,
    /// Total on the base machine (s); `None` when it is not known.
    pub base_total_s: Option<f64>,
    /// The total the target asks for (s); `None` when it is not known.
    pub target_total_s: Option<f64>,
    /// The fastest setting and its total, in words.
    pub fastest: Option<String>,
    /// The cheapest change reaching the target, in words.
    pub cheapest: Option<String>,
    /// The section's figures, in the order shown.
    pub figures: Vec<Figure>,
}

/// A sweep's report.
#[derive(Debug, Clone)]
pub struct Report {
    /// The sweep's name.
    pub sweep: String,
    /// The sweep's description, when it has one.
    pub description: Option<String>,
    /// Combinations of the whole sweep.
    pub combinations: usize,
    /// Rows in the report (fewer than the combinations for a shard).
    pub rows: usize,
    /// The target as the summary states it, e.g. "10 % saving".
    pub target: String,
    /// One per plan and schedule entry.
    pub sections: Vec<Section>,
}

/// "J 0.5 → 1 °/s³, A 0.5 → 0.75 °/s²" (`describe_steps` with the figures' units).
fn describe_change(steps: &[arcsim_evaluator::Step]) -> String {
    if steps.is_empty() {
        return "none (the base machine reaches it)".into();
    }
    steps
        .iter()
        .map(|s| {
            format!(
                "{} {} → {} {}",
                s.axis.symbol().0,
                short(s.from),
                short(s.to),
                s.axis.unit()
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Whether two limit values are the same (as written in a sweep file and decoded again).
fn same(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-300)
}

fn same_opt(a: Option<f64>, b: Option<f64>) -> bool {
    match (a, b) {
        (Some(a), Some(b)) => same(a, b),
        (None, None) => true,
        _ => false,
    }
}

/// Sorted distinct values, at most `max` of them (evenly spread by position, ends included).
fn distinct(mut v: Vec<f64>, max: usize) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v.dedup_by(|a, b| same(*a, *b));
    if v.len() <= max {
        return v;
    }
    (0..max).map(|k| v[k * (v.len() - 1) / (max - 1)]).collect()
}

/// The axes other than J, A, V (each value of them gets heatmaps of its own), and the key of a
/// setting's values on them.
const OTHER_AXES: [Axis; 9] = [
    Axis::ElstUp,
    Axis::ElstDown,
    Axis::Window,
    Axis::ScanSpeed,
    Axis::DoseRateScale,
    Axis::BurstSwitching,
    Axis::SpillCharge,
    Axis::SpillRefill,
    Axis::SpillMaxLayers,
];

type OthersKey = [Option<f64>; OTHER_AXES.len()];

fn others_key(s: &Setting) -> OthersKey {
    OTHER_AXES.map(|a| s.get(a))
}

fn describe_others(key: &OthersKey) -> String {
    OTHER_AXES
        .iter()
        .zip(key)
        .filter_map(|(a, v)| v.map(|v| format!("{} {} {}", a.symbol().0, short(v), a.unit())))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The file-name part of a plan label (`../plans/lung.json` → `lung`, `atom:liver` → `atom-liver`).
fn slug(label: &str) -> String {
    let stem = label
        .rsplit(['/', '\\'])
        .next()
        .unwrap_or(label)
        .trim_end_matches(".json")
        .trim_end_matches(".dcm");
    let s: String = stem
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect();
    let s = s.trim_matches('-').to_string();
    if s.is_empty() {
        "plan".into()
    } else {
        s
    }
}

/// The setting a change of the base machine leads to.
fn changed(base: &Setting, steps: &[arcsim_evaluator::Step]) -> Setting {
    steps.iter().fold(*base, |s, st| s.with(st.axis, st.to))
}

fn same_setting(a: &Setting, b: &Setting) -> bool {
    [Axis::Jerk, Axis::Accel, Axis::Speed]
        .iter()
        .all(|&x| same_opt(a.get(x), b.get(x)))
        && others_key(a) == others_key(b)
}

/// Builds the report of `rows` (all of a sweep's, or a shard's) and their `summary`. Settings
/// the figures need that are not among the rows (the base machine, a one-limit change) are
/// simulated with `ev`.
pub fn build(ev: &Evaluator, rows: &[Row], summary: &Summary) -> Result<Report, ReportError> {
    let sweep = ev.sweep();
    let runs = sweep.schedule_grids.len();
    let mut sections = Vec::with_capacity(summary.entries.len());
    let mut stems: Vec<String> = Vec::new();
    for (i, entry) in summary.entries.iter().enumerate() {
        let (plan, run) = (i / runs.max(1), i % runs.max(1));
        let block: Vec<&Row> = rows
            .iter()
            .filter(|r| {
                let (p, q, _) = ev.combination(r.index);
                p == plan && q == run
            })
            .collect();
        let mut stem = format!("{}-{}", slug(&entry.plan), entry.schedule.name());
        stem = stem.replace('+', "-");
        // Two plans with the same file name in different folders.
        let mut unique = stem.clone();
        let mut n = 2;
        while stems.contains(&unique) {
            unique = format!("{stem}-{n}");
            n += 1;
        }
        stems.push(unique.clone());
        sections.push(section(ev, plan, entry, &block, &unique)?);
    }
    Ok(Report {
        sweep: summary.sweep.clone(),
        description: sweep.description.clone(),
        combinations: summary.combinations,
        rows: summary.rows,
        target: match summary.target {
            arcsim_evaluator::Target::SavingPercent(p) => format!("{} % saving", short(p)),
            arcsim_evaluator::Target::TotalS(t) => format!("{} s total", short(t)),
        },
        sections,
    })
}

fn section(
    ev: &Evaluator,
    plan: usize,
    entry: &Entry,
    block: &[&Row],
    stem: &str,
) -> Result<Section, ReportError> {
    let base = ev.sweep().base_setting();
    let title = format!("{} · {}", entry.plan, entry.schedule.name());
    let mut figures = heatmaps(entry, block, &base, &title, stem)?;

    let bars: Vec<SensitivityBar> = entry
        .sensitivity
        .iter()
        .map(|s| SensitivityBar {
            label: format!(
                "{} (base {} {})",
                s.axis.symbol().0,
                short(s.base_value),
                s.axis.unit()
            ),
            s_per_10_percent: s.s_per_10_percent,
            no_effect: s.no_effect,
        })
        .collect();
    if !bars.is_empty() {
        let caption = format!(
            "{title}: change of the delivery time for +10 % of one limit at the base machine \
             (negative: raising the limit saves time)"
        );
        figures.push(Figure {
            kind: FigureKind::Sensitivity,
            svg: figures::sensitivity(&title, &bars).map_err(draw_err(&caption))?,
            caption,
            file_stem: format!("{stem}-sensitivity"),
        });
    }

    let breakdown = breakdown_bars(ev, plan, entry, block, &base);
    if !breakdown.is_empty() {
        let caption = format!(
            "{title}: where the time goes at the base machine, the cheapest change reaching the \
             target and the fastest setting (s)"
        );
        figures.push(Figure {
            kind: FigureKind::Breakdown,
            svg: figures::breakdown(&title, &breakdown).map_err(draw_err(&caption))?,
            caption,
            file_stem: format!("{stem}-breakdown"),
        });
    }

    Ok(Section {
        plan: entry.plan.clone(),
        schedule: entry.schedule.name(),
        rows: entry.rows,
        feasible: entry.feasible,
        base_total_s: entry.base_total_s,
        target_total_s: entry.target_total_s,
        fastest: entry.fastest.map(|p| {
            format!(
                "{:.1} s at {}{}",
                p.total_s,
                describe_setting(&p.setting),
                p.speedup
                    .map_or(String::new(), |s| format!(" (speed-up {s:.3})"))
            )
        }),
        cheapest: entry.cheapest.as_ref().map(|c| {
            format!(
                "{}: {:.1} s, saving {:.1} s",
                describe_change(&c.steps),
                c.total_s,
                c.saving_s
            )
        }),
        figures,
    })
}

/// The time breakdown's bars: the base machine, the cheapest change reaching the target and the
/// fastest setting, each when known.
fn breakdown_bars(
    ev: &Evaluator,
    plan: usize,
    entry: &Entry,
    block: &[&Row],
    base: &Setting,
) -> Vec<Bar> {
    // Base, cheapest and fastest: from the rows when they are there, else simulated.
    let outcome = |s: &Setting, index: Option<usize>| -> Option<Outcome> {
        block
            .iter()
            .find(|r| Some(r.index) == index || (index.is_none() && same_setting(&r.setting, s)))
            .and_then(|r| r.outcome)
            .or_else(|| ev.simulate(plan, entry.schedule, s, entry.base_total_s).1)
    };
    let mut breakdown: Vec<Bar> = Vec::new();
    if let Some(o) = outcome(base, None) {
        breakdown.push(Bar::new(format!("base ({})", describe_setting(base)), &o));
    }
    if let Some(c) = entry.cheapest.as_ref().filter(|c| !c.steps.is_empty()) {
        if let Some(o) = outcome(&changed(base, &c.steps), c.index) {
            breakdown.push(Bar::new(
                format!("cheapest: {}", describe_change(&c.steps)),
                &o,
            ));
        }
    }
    if let Some(f) = entry.fastest {
        if !same_setting(&f.setting, base) {
            if let Some(o) = outcome(&f.setting, f.index) {
                breakdown.push(Bar::new(
                    format!("fastest ({})", describe_setting(&f.setting)),
                    &o,
                ));
            }
        }
    }
    breakdown
}

fn draw_err(figure: &str) -> impl Fn(String) -> ReportError + '_ {
    move |message| ReportError::Draw {
        figure: figure.to_owned(),
        message,
    }
}

/// One heatmap per value of V (and of the other swept limits) among `block`'s rows.
fn heatmaps(
    entry: &Entry,
    block: &[&Row],
    base: &Setting,
    title: &str,
    stem: &str,
) -> Result<Vec<Figure>, ReportError> {
    type GroupKey = (u64, [Option<u64>; OTHER_AXES.len()]);
    let mut groups: BTreeMap<GroupKey, Vec<&Row>> = BTreeMap::new();
    for r in block {
        let key = (
            r.setting.speed_deg_per_s.to_bits(),
            others_key(&r.setting).map(|v| v.map(f64::to_bits)),
        );
        groups.entry(key).or_default().push(r);
    }
    // Groups in the order of V, then of the other limits.
    let mut keys: Vec<GroupKey> = groups.keys().copied().collect();
    keys.sort_by(|a, b| {
        f64::from_bits(a.0)
            .total_cmp(&f64::from_bits(b.0))
            .then_with(|| a.1.cmp(&b.1))
    });
    if keys.len() > MAX_HEATMAPS {
        keys = (0..MAX_HEATMAPS)
            .map(|k| keys[k * (keys.len() - 1) / (MAX_HEATMAPS - 1)])
            .collect();
    }
    let (lo, hi) = block
        .iter()
        .filter_map(|r| r.outcome.map(|o| o.total_s))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| {
            (lo.min(t), hi.max(t))
        });
    let cheapest = entry.cheapest.as_ref().map(|c| changed(base, &c.steps));
    let mut out = Vec::with_capacity(keys.len());
    for key in keys {
        let rows = &groups[&key];
        let speed = f64::from_bits(key.0);
        let others = describe_others(&key.1.map(|v| v.map(f64::from_bits)));
        let jerks = distinct(
            rows.iter().map(|r| r.setting.jerk_deg_per_s3).collect(),
            MAX_CELLS_PER_AXIS,
        );
        let accels = distinct(
            rows.iter().map(|r| r.setting.accel_deg_per_s2).collect(),
            MAX_CELLS_PER_AXIS,
        );
        let cell = |s: &Setting| {
            let j = jerks.iter().position(|&v| same(v, s.jerk_deg_per_s3))?;
            let a = accels.iter().position(|&v| same(v, s.accel_deg_per_s2))?;
            (same(s.speed_deg_per_s, speed) && others_key(s).map(|v| v.map(f64::to_bits)) == key.1)
                .then_some((j, a))
        };
        let mut totals: Vec<Vec<figures::Cell>> =
            vec![vec![figures::Cell::NotRun; accels.len()]; jerks.len()];
        for r in rows {
            if let Some((j, a)) = cell(&r.setting) {
                totals[j][a] = match r.outcome {
                    Some(o) => figures::Cell::Total(o.total_s),
                    None => figures::Cell::Infeasible,
                };
            }
        }
        let at = if others.is_empty() {
            format!("V = {} °/s", short(speed))
        } else {
            format!("V = {} °/s, {others}", short(speed))
        };
        let map = Heatmap {
            title: format!("{title}: delivery time (s) at {at}"),
            jerks: jerks.clone(),
            accels: accels.clone(),
            totals,
            range: (lo, hi),
            base: cell(base),
            target: cheapest.as_ref().and_then(cell),
        };
        let caption = format!(
            "{title}: delivery time (s) over J × A at {at}; base machine outlined in black, \
             cheapest change reaching the target in magenta"
        );
        let mut file_stem = format!("{stem}-heatmap-v{}", short(speed));
        if !others.is_empty() {
            file_stem += &format!("-{}", slug(&others));
        }
        out.push(Figure {
            kind: FigureKind::Heatmap {
                speed_deg_per_s: speed,
                others,
            },
            svg: figures::heatmap(&map).map_err(draw_err(&caption))?,
            caption,
            file_stem,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_axes_are_shown_at_spread_values_ends_included() {
        let v: Vec<f64> = (0..100).rev().map(|i| i as f64 * 0.1).collect();
        let d = distinct(v, MAX_CELLS_PER_AXIS);
        assert_eq!(d.len(), MAX_CELLS_PER_AXIS);
        assert_eq!((d[0], d[d.len() - 1]), (0.0, 9.9));
        assert!(d.windows(2).all(|w| w[0] < w[1]));
        // Repeated values (as decoded from a range) count once.
        assert_eq!(distinct(vec![0.5, 0.1 + 0.4, 1.0], 40), vec![0.5, 1.0]);
    }

    #[test]
    fn file_names_from_plan_labels() {
        assert_eq!(slug("../plans/head-neck.json"), "head-neck");
        assert_eq!(slug("atom:liver"), "atom-liver");
        assert_eq!(slug("C:\\plans\\x y.dcm"), "x-y");
        assert_eq!(slug("///"), "plan");
    }
}
