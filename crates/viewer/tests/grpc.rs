//! Streaming to a viewer over gRPC: a bad URL and an unreachable viewer are errors; a real
//! viewer (set ARCSIM_RERUN_URL, e.g. rerun+http://127.0.0.1:9876/proxy) gets the delivery.

use std::path::Path;
use std::time::{Duration, Instant};

use arcsim_sequencer::{simulate, Delivery, Options, Schedule};
use arcsim_viewer::{connect_delivery, ViewerError, ViewerOptions};

fn lung() -> Delivery {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let plan = arcsim_plan::load_plan(root.join("plans/lung.json")).expect("plan");
    let machine =
        arcsim_plan::load_machine(root.join("scenarios/machine-atom.json")).expect("machine");
    simulate(&plan, &machine, &Options::new(Schedule::Scan)).expect("simulation")
}

#[test]
fn bad_url_is_an_error() {
    for url in [
        "http://127.0.0.1:9876",
        "not a url",
        "rerun+http://127.0.0.1:9876/catalog",
    ] {
        let err = connect_delivery(url, "lung", &lung(), &[], &ViewerOptions::default());
        assert!(
            matches!(err, Err(ViewerError::Url { .. })),
            "{url}: {err:?}"
        );
    }
}

#[test]
fn unreachable_viewer_is_an_error() {
    let start = Instant::now();
    // Port 9 (discard) is assumed closed on the test machine.
    let err = connect_delivery(
        "rerun+http://127.0.0.1:9/proxy",
        "lung",
        &lung(),
        &[],
        &ViewerOptions::default(),
    );
    assert!(matches!(err, Err(ViewerError::Flush { .. })), "{err:?}");
    assert!(
        start.elapsed() < Duration::from_secs(30),
        "gave up after {:?}",
        start.elapsed()
    );
}

#[test]
#[ignore = "needs a running viewer: ARCSIM_RERUN_URL=rerun+http://127.0.0.1:9876/proxy"]
fn running_viewer_gets_the_delivery() {
    let url = std::env::var("ARCSIM_RERUN_URL").expect("ARCSIM_RERUN_URL");
    connect_delivery(&url, "lung (scan)", &lung(), &[], &ViewerOptions::default()).expect("sent");
}
