//! Where a delivery goes: an `.rrd` file, a spawned viewer, or a running viewer over gRPC.

use std::path::Path;
use std::time::Duration;

use arcsim_sequencer::{Delivery, SpotRow};
use rerun::{RecordingStream, RecordingStreamBuilder, RecordingStreamError};

use crate::delivery::check;
use crate::{log_delivery, log_spots, send_delivery_blueprint, ViewerError, ViewerOptions};

/// Application id of delivery recordings (the viewer keeps one layout per application).
pub const DELIVERY_APP_ID: &str = "arcsim-delivery";

/// How long to wait for a viewer to take the data before giving up.
const SEND_TIMEOUT: Duration = Duration::from_secs(20);

fn builder(title: &str) -> RecordingStreamBuilder {
    builder_of(DELIVERY_APP_ID, title)
}

fn builder_of(app_id: &'static str, title: &str) -> RecordingStreamBuilder {
    // `enabled(true)`: an explicit request for output ignores the `RERUN` environment variable.
    RecordingStreamBuilder::new(app_id)
        .enabled(true)
        .recording_name(title)
}

/// A recording of application `app_id` named `title`, saved to the `.rrd` file `path`.
pub(crate) fn save_recording(
    app_id: &'static str,
    title: &str,
    path: &Path,
) -> Result<RecordingStream, ViewerError> {
    builder_of(app_id, title)
        .save(path)
        .map_err(|source| ViewerError::Save {
            path: path.to_owned(),
            source,
        })
}

/// Logs, waits until everything reached the sink, then closes the stream (which finishes a file).
/// The beam's-eye view is laid out and logged when some spot has a position.
fn finish(
    rec: RecordingStream,
    delivery: &Delivery,
    spots: &[SpotRow],
    opts: &ViewerOptions,
    target: &str,
) -> Result<(), ViewerError> {
    let with_spots = spots.iter().any(|r| r.x_mm.is_some() && r.y_mm.is_some());
    send_delivery_blueprint(&rec, with_spots)?;
    log_delivery(&rec, delivery, opts)?;
    if with_spots {
        log_spots(&rec, spots, &layer_energies(delivery))?;
    }
    rec.flush_with_timeout(SEND_TIMEOUT)
        .map_err(|source| ViewerError::Flush {
            target: target.to_owned(),
            source,
        })?;
    drop(rec);
    Ok(())
}

/// Nominal energy of each layer by its delivery index (NaN where a row is missing).
fn layer_energies(delivery: &Delivery) -> Vec<f64> {
    let len = delivery
        .layers
        .iter()
        .map(|l| l.index + 1)
        .max()
        .unwrap_or(0);
    let mut energies = vec![f64::NAN; len];
    for l in &delivery.layers {
        energies[l.index] = l.energy_mev;
    }
    energies
}

/// Writes `delivery` to the `.rrd` file `path` (replaced if it exists), with the default layout.
/// With `spots` (the rows of `arcsim_sequencer::spot_timeline` for this delivery) that have a
/// position, it adds their beam's-eye view ([`crate::log_spots`], energies taken from the
/// delivery); pass `&[]` for none.
pub fn save_delivery(
    path: &Path,
    title: &str,
    delivery: &Delivery,
    spots: &[SpotRow],
    opts: &ViewerOptions,
) -> Result<(), ViewerError> {
    check(delivery, opts)?;
    let rec = save_recording(DELIVERY_APP_ID, title, path)?;
    finish(rec, delivery, spots, opts, &path.display().to_string())
}

/// Starts a Rerun viewer (the `rerun` executable on `PATH`; an already running one on the
/// default port 9876 is reused) and streams `delivery` to it, with `spots` as in
/// [`save_delivery`].
pub fn spawn_delivery(
    title: &str,
    delivery: &Delivery,
    spots: &[SpotRow],
    opts: &ViewerOptions,
) -> Result<(), ViewerError> {
    check(delivery, opts)?;
    let rec = builder(title).spawn().map_err(|e| match e {
        RecordingStreamError::SpawnViewer(e) => ViewerError::Spawn(e),
        e => ViewerError::Log(e),
    })?;
    finish(rec, delivery, spots, opts, "the spawned Rerun viewer")
}

/// Streams `delivery` to a running viewer at a gRPC proxy URL such as
/// `rerun+http://127.0.0.1:9876/proxy` (what `rerun` prints when it starts), with `spots` as in
/// [`save_delivery`].
pub fn connect_delivery(
    url: &str,
    title: &str,
    delivery: &Delivery,
    spots: &[SpotRow],
    opts: &ViewerOptions,
) -> Result<(), ViewerError> {
    check(delivery, opts)?;
    let rec = builder(title)
        .connect_grpc_opts(url)
        .map_err(|source| ViewerError::Url {
            url: url.to_owned(),
            source,
        })?;
    finish(rec, delivery, spots, opts, url)
}
