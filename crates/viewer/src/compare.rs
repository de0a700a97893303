//! A delivery log beside its simulation: gantry angle and speed of both on one time axis.

use std::path::Path;

use rerun::TimeColumn;

use crate::timelines::TIME;
use crate::ViewerError;

/// Application id of comparison recordings.
pub const COMPARISON_APP_ID: &str = "arcsim-compare";

/// One series to plot: its name (`logged`, `simulated`), its angle samples and its speed
/// samples (each with their times).
#[derive(Debug, Clone, Copy)]
pub struct AngleSeries<'a> {
    /// Name of the series, the last part of its entity paths.
    pub name: &'a str,
    /// Times, s.
    pub t_s: &'a [f64],
    /// Gantry angle, degrees.
    pub angle_deg: &'a [f64],
    /// Times of the speeds, s.
    pub speed_t_s: &'a [f64],
    /// Gantry speed, deg/s.
    pub speed_deg_per_s: &'a [f64],
}

/// Writes the series to the `.rrd` file `path` (replaced if it exists): `angle/NAME` and
/// `speed/NAME` on the `time` timeline.
pub fn save_comparison(
    path: &Path,
    title: &str,
    series: &[AngleSeries],
) -> Result<(), ViewerError> {
    let rec = crate::output::save_recording(COMPARISON_APP_ID, title, path)?;
    for s in series {
        for (what, t, values) in [
            ("angle", s.t_s, s.angle_deg),
            ("speed", s.speed_t_s, s.speed_deg_per_s),
        ] {
            let time = TimeColumn::new_duration_secs(TIME, t.iter().copied());
            let columns = rerun::Scalars::new(values.iter().copied()).columns_of_unit_batches()?;
            rec.send_columns(format!("{what}/{}", s.name), [time], columns)?;
        }
    }
    rec.flush_with_timeout(std::time::Duration::from_secs(20))
        .map_err(|source| ViewerError::Flush {
            target: path.display().to_string(),
            source,
        })?;
    Ok(())
}
