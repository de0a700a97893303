//! The report as one self-contained HTML file (inline SVG and CSS, nothing fetched), and its
//! figures as separate SVG files.

use std::path::{Path, PathBuf};

use crate::{FigureKind, Report};

/// Text for HTML content and attribute values.
fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// The SVG document without its XML declaration, to inline in HTML.
fn inline_svg(svg: &str) -> &str {
    match svg.find("<svg") {
        Some(i) => &svg[i..],
        None => svg,
    }
}

const STYLE: &str =
    "body{font-family:sans-serif;max-width:1560px;margin:2em auto;padding:0 1em;color:#222}\
h1{font-size:1.5em}h2{font-size:1.2em;margin-top:2em;border-bottom:1px solid #ccc}\
figure{display:inline-block;margin:0.5em 1em 1em 0;vertical-align:top}\
figcaption{font-size:0.85em;color:#444;max-width:740px}\
table{border-collapse:collapse;font-size:0.9em}td,th{padding:2px 10px;text-align:left}\
th{border-bottom:1px solid #999}svg{max-width:100%;height:auto}";

impl Report {
    /// The whole report as one HTML document.
    pub fn to_html(&self) -> String {
        let mut h = String::new();
        h += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
        h += &format!(
            "<title>arcsim sweep {}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n",
            escape(&self.sweep)
        );
        h += &format!("<h1>Sweep “{}”</h1>\n", escape(&self.sweep));
        if let Some(d) = &self.description {
            h += &format!("<p>{}</p>\n", escape(d));
        }
        let partial = if self.rows < self.combinations {
            format!(" ({} of {} combinations)", self.rows, self.combinations)
        } else {
            format!(" ({} combinations)", self.combinations)
        };
        h += &format!(
            "<p>Delivery time per plan and schedule{partial}; target: {}. Each section shows \
             the delivery time over J × A at each V (the base machine outlined in black, the \
             cheapest change reaching the target in magenta), the sensitivity of the total to \
             each limit, and where the time goes.</p>\n",
            escape(&self.target)
        );
        h += "<table>\n<tr><th>plan</th><th>schedule</th><th>rows</th><th>feasible</th>\
              <th>base [s]</th><th>target [s]</th><th>fastest</th><th>cheapest change reaching the target</th></tr>\n";
        let opt = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.1}"));
        for s in &self.sections {
            h += &format!(
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                escape(&s.plan),
                escape(&s.schedule),
                s.rows,
                s.feasible,
                opt(s.base_total_s),
                opt(s.target_total_s),
                escape(s.fastest.as_deref().unwrap_or("-")),
                escape(s.cheapest.as_deref().unwrap_or("not reached by any evaluated setting")),
            );
        }
        h += "</table>\n";
        for s in &self.sections {
            h += &format!(
                "<section class=\"entry\" data-plan=\"{}\" data-schedule=\"{}\">\n<h2>{} · {}</h2>\n",
                escape(&s.plan),
                escape(&s.schedule),
                escape(&s.plan),
                escape(&s.schedule)
            );
            for f in &s.figures {
                let extra = match &f.kind {
                    FigureKind::Heatmap {
                        speed_deg_per_s,
                        others,
                    } => format!(
                        " data-speed-deg-per-s=\"{speed_deg_per_s}\" data-others=\"{}\"",
                        escape(others)
                    ),
                    _ => String::new(),
                };
                h += &format!(
                    "<figure class=\"{}\" id=\"{}\"{extra}>\n{}\n<figcaption>{}</figcaption>\n</figure>\n",
                    f.kind.name(),
                    escape(&f.file_stem),
                    inline_svg(&f.svg).trim_end(),
                    escape(&f.caption)
                );
            }
            h += "</section>\n";
        }
        h += "</body>\n</html>\n";
        h
    }

    /// Every figure's SVG document as `DIR/FILE_STEM.svg`, with the paths in report order.
    pub fn svg_files(&self, dir: &Path) -> Vec<(PathBuf, &str)> {
        self.sections
            .iter()
            .flat_map(|s| &s.figures)
            .map(|f| (dir.join(format!("{}.svg", f.file_stem)), f.svg.as_str()))
            .collect()
    }
}
