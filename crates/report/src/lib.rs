//! # arcsim-report
//!
//! A sweep's static report, for papers and for readers without the Rerun viewer: per plan and
//! schedule entry, heatmaps of the delivery time over J × A at each V (base machine and cheapest
//! change reaching the target marked), the sensitivity of the total to each limit as bars, and the
//! breakdown (beam on / energy switching / gantry) of the base, cheapest and fastest settings.
//!
//! Figures are SVG drawn with `plotters` ([`figures`]); [`Report::to_html`] puts them in one
//! self-contained HTML file and [`Report::svg_files`] names them as separate files.

#![warn(missing_docs)]

mod figures;
mod html;
mod model;

pub use model::{build, Figure, FigureKind, Report, Section};

/// What can go wrong while drawing a report.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// `plotters` failed to draw a figure (a bug, or a value it cannot place).
    #[error("drawing {figure}: {message}")]
    Draw {
        /// The figure's caption.
        figure: String,
        /// What `plotters` reported.
        message: String,
    },
}
