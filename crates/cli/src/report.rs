//! `--report FILE.html` and `--plot DIR` of `sweep` and `sweep-merge`: the static report of a
//! sweep (heatmaps, sensitivities, breakdowns; `arcsim-report`).

use std::path::Path;

use arcsim_evaluator::{Evaluator, Row, Summary};

use crate::CliError;

/// Draws the report of `rows` and `summary` and writes it as one HTML file (`report`) and/or as
/// one SVG file per figure in `plot` (created if missing). Prints where each went.
pub fn write(
    ev: &Evaluator,
    rows: &[Row],
    summary: &Summary,
    report: Option<&Path>,
    plot: Option<&Path>,
) -> Result<(), CliError> {
    if report.is_none() && plot.is_none() {
        return Ok(());
    }
    let drawn = arcsim_report::build(ev, rows, summary)
        .map_err(|e| CliError::failed(format!("report: {e}")))?;
    if let Some(path) = report {
        crate::output::write_file(path, drawn.to_html().as_bytes())?;
        let figures: usize = drawn.sections.iter().map(|s| s.figures.len()).sum();
        eprintln!(
            "report: {} -> {}",
            crate::count(figures, "figure"),
            path.display()
        );
    }
    if let Some(dir) = plot {
        std::fs::create_dir_all(dir)
            .map_err(|e| CliError::failed(format!("--plot {}: {e}", dir.display())))?;
        let files = drawn.svg_files(dir);
        for (path, svg) in &files {
            crate::output::write_file(path, svg.as_bytes())?;
        }
        eprintln!(
            "plots: {} in {}",
            crate::count(files.len(), "SVG file"),
            dir.display()
        );
    }
    Ok(())
}
