//! Rerun outputs of `simulate` (kept apart so the rest of the CLI does not touch rerun's API).

use std::path::Path;

use arcsim_sequencer::Delivery;

use crate::CliError;

/// Writes / spawns / connects as asked; does nothing when no flag is given.
pub fn output(
    d: &Delivery,
    title: &str,
    dt: f64,
    rrd: Option<&Path>,
    spawn: bool,
    connect: Option<&str>,
) -> Result<(), CliError> {
    let _ = (d, title, dt);
    if rrd.is_some() || spawn || connect.is_some() {
        return Err(CliError::failed(
            "Rerun output is not available in this build yet",
        ));
    }
    Ok(())
}
