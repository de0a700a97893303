//! Rerun outputs of `simulate` (kept apart so the rest of the CLI does not touch the viewer crate).

use std::path::Path;

use arcsim_sequencer::Delivery;
use arcsim_viewer::ViewerOptions;

use crate::CliError;

/// Writes / spawns / connects as asked; does nothing when no flag is given.
pub fn output(
    d: &Delivery,
    spots: &[arcsim_sequencer::SpotRow],
    title: &str,
    dt: f64,
    rrd: Option<&Path>,
    spawn: bool,
    connect: Option<&str>,
) -> Result<(), CliError> {
    let opts = ViewerOptions { sample_dt_s: dt };
    if let Some(path) = rrd {
        crate::output::write_via_path(path, |tmp| {
            arcsim_viewer::save_delivery(tmp, title, d, spots, &opts)
                .map_err(|e| CliError::failed(format!("--rrd {}: {e}", path.display())))
        })?;
    }
    if spawn {
        arcsim_viewer::spawn_delivery(title, d, spots, &opts)
            .map_err(|e| CliError::failed(format!("--spawn: {e}")))?;
    }
    if let Some(url) = connect {
        arcsim_viewer::connect_delivery(url, title, d, spots, &opts)
            .map_err(|e| CliError::failed(format!("--connect: {e}")))?;
    }
    Ok(())
}
