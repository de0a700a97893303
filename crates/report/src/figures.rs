//! The report's figures as SVG documents, drawn with `plotters`.
//!
//! Categories (the values of J and A in a heatmap, the limits of the sensitivity bars, the
//! settings of the breakdown) sit at integer positions of an `f64` axis from -0.5 to n - 0.5,
//! so each cell or bar is centred on its tick; tick labels are printed only at those integers.

use arcsim_evaluator::{short, Outcome};
use plotters::prelude::*;
use plotters::style::colors::colormaps::{ColorMap, ViridisRGB};
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Colours of the breakdown, the same as in the Rerun recordings (red: beam on).
const BEAM_ON: RGBColor = RGBColor(230, 60, 60);
const SWITCHING: RGBColor = RGBColor(80, 160, 255);
const GANTRY: RGBColor = RGBColor(255, 170, 40);
/// The outline of the cheapest change reaching the target.
const TARGET: RGBColor = RGBColor(255, 0, 220);
const SAVES: RGBColor = RGBColor(40, 150, 90);
const COSTS: RGBColor = RGBColor(200, 70, 60);
const FONT: &str = "sans-serif";

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

/// The drawing area of a figure.
type Area<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;

/// An SVG document of `size` (px): white, `title` on top, the rest drawn by `draw`.
fn svg_figure(
    size: (u32, u32),
    title: &str,
    draw: impl FnOnce(&Area<'_>) -> Result<(), String>,
) -> Result<String, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let area = root.titled(title, (FONT, 15)).map_err(err)?;
        draw(&area)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// The category at tick `x` of a category axis, if `x` is one.
fn category(x: f64, n: usize) -> Option<usize> {
    let i = x.round();
    ((x - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < n).then_some(i as usize)
}

fn centred(size: u32, color: &RGBColor) -> TextStyle<'static> {
    (FONT, size)
        .into_font()
        .color(color)
        .pos(Pos::new(HPos::Center, VPos::Center))
}

/// One cell of a heatmap.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Cell {
    Total(f64),
    Infeasible,
    /// Not among the rows (e.g. in another shard).
    NotRun,
}

/// Delivery time over J (x) × A (y) at one V.
pub(crate) struct Heatmap {
    pub title: String,
    pub jerks: Vec<f64>,
    pub accels: Vec<f64>,
    /// `totals[j][a]`.
    pub totals: Vec<Vec<Cell>>,
    /// The colour scale's range (s), shared by a section's heatmaps.
    pub range: (f64, f64),
    /// Cells (j, a) of the base machine and of the cheapest change reaching the target.
    pub base: Option<(usize, usize)>,
    pub target: Option<(usize, usize)>,
}

/// The colour scale's range, widened when it is a single value.
fn scale(range: (f64, f64)) -> (f64, f64) {
    let (lo, hi) = range;
    if !lo.is_finite() || !hi.is_finite() {
        (0.0, 1.0)
    } else if hi - lo < 1e-9 * hi.abs().max(1.0) {
        (lo - 0.5, hi + 0.5)
    } else {
        (lo, hi)
    }
}

pub(crate) fn heatmap(m: &Heatmap) -> Result<String, String> {
    let (nj, na) = (m.jerks.len(), m.accels.len());
    let w = (220 + 84 * nj).clamp(620, 1500) as u32;
    let h = (150 + 46 * na).clamp(320, 1000) as u32;
    let (lo, hi) = scale(m.range);
    svg_figure((w, h), &m.title, |root| {
        let (main, bar) = root.split_horizontally(w - 110);
        let mut chart = ChartBuilder::on(&main)
            .margin(12)
            .x_label_area_size(46)
            .y_label_area_size(70)
            .build_cartesian_2d(-0.5..nj as f64 - 0.5, -0.5..na as f64 - 0.5)
            .map_err(err)?;
        let j_label = |x: &f64| category(*x, nj).map_or(String::new(), |i| short(m.jerks[i]));
        let a_label = |y: &f64| category(*y, na).map_or(String::new(), |i| short(m.accels[i]));
        chart
            .configure_mesh()
            .disable_mesh()
            .x_labels(nj + 1)
            .y_labels(na + 1)
            .x_label_formatter(&j_label)
            .y_label_formatter(&a_label)
            .x_desc("J (°/s³)")
            .y_desc("A (°/s²)")
            .label_style((FONT, 13))
            .axis_desc_style((FONT, 14))
            .draw()
            .map_err(err)?;

        let norm = |t: f64| ((t - lo) / (hi - lo)).clamp(0.0, 1.0);
        for (j, column) in m.totals.iter().enumerate() {
            for (a, cell) in column.iter().enumerate() {
                let (x, y) = (j as f64, a as f64);
                let corners = [(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)];
                let (fill, text, ink) = match *cell {
                    Cell::Total(t) => {
                        let c: RGBColor = ViridisRGB.get_color(norm(t) as f32);
                        let ink = if norm(t) < 0.6 { WHITE } else { BLACK };
                        (c, format!("{t:.1}"), ink)
                    }
                    Cell::Infeasible => (RGBColor(200, 200, 200), "infeasible".into(), BLACK),
                    Cell::NotRun => (WHITE, "not run".into(), RGBColor(150, 150, 150)),
                };
                chart
                    .draw_series([Rectangle::new(corners, fill.filled())])
                    .map_err(err)?;
                chart
                    .draw_series([Text::new(text, (x, y), centred(13, &ink))])
                    .map_err(err)?;
            }
        }
        let outline = |(j, a): (usize, usize), inset: f64| {
            let (x, y) = (j as f64, a as f64);
            [
                (x - 0.5 + inset, y - 0.5 + inset),
                (x + 0.5 - inset, y + 0.5 - inset),
            ]
        };
        // Labels in the cell's ink, readable on any colour of the scale.
        let ink_at = |(j, a): (usize, usize)| match m.totals[j][a] {
            Cell::Total(t) if norm(t) < 0.6 => WHITE,
            _ => BLACK,
        };
        if let Some(c) = m.target {
            chart
                .draw_series([Rectangle::new(outline(c, 0.1), TARGET.stroke_width(4))])
                .map_err(err)?;
            let (x, y) = (c.0 as f64, c.1 as f64 - 0.28);
            chart
                .draw_series([Text::new("target", (x, y), centred(11, &ink_at(c)))])
                .map_err(err)?;
        }
        if let Some(c) = m.base {
            chart
                .draw_series([Rectangle::new(outline(c, 0.03), BLACK.stroke_width(3))])
                .map_err(err)?;
            let (x, y) = (c.0 as f64, c.1 as f64 + 0.28);
            chart
                .draw_series([Text::new("base", (x, y), centred(11, &ink_at(c)))])
                .map_err(err)?;
        }

        colour_bar(&bar, lo, hi)
    })
}

/// Draws the heatmap's colour bar: the scale from `lo` to `hi` seconds, labelled.
fn colour_bar(bar: &Area<'_>, lo: f64, hi: f64) -> Result<(), String> {
    let mut key = ChartBuilder::on(bar)
        .margin_top(12)
        .margin_bottom(58)
        .margin_right(8)
        .y_label_area_size(62)
        .build_cartesian_2d(0.0..1.0, lo..hi)
        .map_err(err)?;
    key.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(6)
        .y_label_formatter(&|y| short(*y))
        .y_desc("total (s)")
        .label_style((FONT, 12))
        .axis_desc_style((FONT, 13))
        .draw()
        .map_err(err)?;
    const STEPS: usize = 64;
    key.draw_series((0..STEPS).map(|k| {
        let (a, b) = (k as f64 / STEPS as f64, (k + 1) as f64 / STEPS as f64);
        let c: RGBColor = ViridisRGB.get_color(((a + b) / 2.0) as f32);
        Rectangle::new(
            [(0.0, lo + a * (hi - lo)), (1.0, lo + b * (hi - lo))],
            c.filled(),
        )
    }))
    .map_err(err)?;
    Ok(())
}

/// One limit's sensitivity.
pub(crate) struct SensitivityBar {
    pub label: String,
    pub s_per_10_percent: Option<f64>,
    pub no_effect: bool,
}

pub(crate) fn sensitivity(title: &str, bars: &[SensitivityBar]) -> Result<String, String> {
    let n = bars.len();
    let values: Vec<f64> = bars
        .iter()
        .filter_map(|b| b.s_per_10_percent.filter(|_| !b.no_effect))
        .collect();
    let lo = values.iter().copied().fold(0.0, f64::min);
    let hi = values.iter().copied().fold(0.0, f64::max);
    let span = (hi - lo).max(1e-3);
    // Room on both sides for the value printed beside each bar.
    let (x0, x1) = (lo - 0.35 * span, hi + 0.35 * span);
    let (w, h) = (760u32, (110 + 56 * n).max(220) as u32);
    svg_figure((w, h), title, |root| {
        let mut chart = ChartBuilder::on(root)
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(170)
            .build_cartesian_2d(x0..x1, -0.5..n as f64 - 0.5)
            .map_err(err)?;
        let label = |y: &f64| category(*y, n).map_or(String::new(), |i| bars[i].label.clone());
        chart
            .configure_mesh()
            .disable_y_mesh()
            .y_labels(n + 1)
            .y_label_formatter(&label)
            .x_label_formatter(&|x| short(*x))
            .light_line_style(WHITE)
            .x_desc("change of the delivery time for +10 % of the limit (s)")
            .label_style((FONT, 13))
            .axis_desc_style((FONT, 14))
            .draw()
            .map_err(err)?;
        chart
            .draw_series(LineSeries::new(
                [(0.0, -0.5), (0.0, n as f64 - 0.5)],
                BLACK.stroke_width(1),
            ))
            .map_err(err)?;
        for (i, b) in bars.iter().enumerate() {
            let y = i as f64;
            let (text, at, anchor) = match b.s_per_10_percent {
                _ if b.no_effect => ("no effect".to_string(), 0.0, HPos::Left),
                Some(v) => {
                    let color = if v < 0.0 { SAVES } else { COSTS };
                    chart
                        .draw_series([Rectangle::new(
                            [(0.0, y - 0.3), (v, y + 0.3)],
                            color.filled(),
                        )])
                        .map_err(err)?;
                    let anchor = if v < 0.0 { HPos::Right } else { HPos::Left };
                    (format!("{v:+.2} s"), v, anchor)
                }
                None => ("infeasible nearby".to_string(), 0.0, HPos::Left),
            };
            let pad = 0.02
                * (x1 - x0)
                * if matches!(anchor, HPos::Right) {
                    -1.0
                } else {
                    1.0
                };
            let style = (FONT, 13)
                .into_font()
                .color(&BLACK)
                .pos(Pos::new(anchor, VPos::Center));
            chart
                .draw_series([Text::new(text, (at + pad, y), style)])
                .map_err(err)?;
        }
        Ok(())
    })
}

/// One setting's breakdown.
pub(crate) struct Bar {
    pub label: String,
    pub beam_on_s: f64,
    pub switching_s: f64,
    pub gantry_s: f64,
}

impl Bar {
    pub fn new(label: String, o: &Outcome) -> Bar {
        Bar {
            label,
            beam_on_s: o.breakdown.beam_on_s,
            switching_s: o.breakdown.energy_switching_s,
            gantry_s: o.breakdown.lost_s,
        }
    }

    fn total(&self) -> f64 {
        self.beam_on_s + self.switching_s + self.gantry_s
    }
}

/// One part of a breakdown bar: its name, colour and value.
type Part = (&'static str, RGBColor, fn(&Bar) -> f64);

pub(crate) fn breakdown(title: &str, bars: &[Bar]) -> Result<String, String> {
    let n = bars.len();
    let max = bars.iter().map(Bar::total).fold(0.0, f64::max).max(1e-3);
    let (w, h) = (760u32, (120 + 70 * n).max(240) as u32);
    svg_figure((w, h), title, |root| {
        // The x axis runs to 1.5 × the longest bar: the legend sits in that empty strip.
        let mut chart = ChartBuilder::on(root)
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(12)
            .build_cartesian_2d(0.0..1.5 * max, -0.5..n as f64 - 0.5)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_y_mesh()
            .disable_y_axis()
            .x_label_formatter(&|x| short(*x))
            .light_line_style(WHITE)
            .x_desc("time (s)")
            .label_style((FONT, 13))
            .axis_desc_style((FONT, 14))
            .draw()
            .map_err(err)?;
        let parts: [Part; 3] = [
            ("beam on", BEAM_ON, |b| b.beam_on_s),
            ("energy switching", SWITCHING, |b| b.switching_s),
            ("gantry", GANTRY, |b| b.gantry_s),
        ];
        // Top to bottom in the order given.
        let row = |i: usize| (n - 1 - i) as f64;
        let mut start = vec![0.0; n];
        for (name, color, part) in parts {
            let rects: Vec<Rectangle<(f64, f64)>> = bars
                .iter()
                .enumerate()
                .map(|(i, b)| {
                    let (a, z) = (start[i], start[i] + part(b));
                    start[i] = z;
                    Rectangle::new([(a, row(i) - 0.22), (z, row(i) + 0.18)], color.filled())
                })
                .collect();
            chart
                .draw_series(rects)
                .map_err(err)?
                .label(name)
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 6), (x + 14, y + 6)], color.filled())
                });
        }
        for (i, b) in bars.iter().enumerate() {
            let left = (FONT, 13)
                .into_font()
                .color(&BLACK)
                .pos(Pos::new(HPos::Left, VPos::Bottom));
            chart
                .draw_series([Text::new(
                    b.label.clone(),
                    (0.0, row(i) + 0.44),
                    left.clone(),
                )])
                .map_err(err)?;
            let end = (FONT, 13)
                .into_font()
                .color(&BLACK)
                .pos(Pos::new(HPos::Left, VPos::Center));
            chart
                .draw_series([Text::new(
                    format!("{:.1} s", b.total()),
                    (b.total() + 0.01 * max, row(i) - 0.02),
                    end,
                )])
                .map_err(err)?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK.mix(0.4))
            .label_font((FONT, 13))
            .draw()
            .map_err(err)?;
        Ok(())
    })
}
