//! Without a `rerun` executable, spawning a viewer is a clear error (own test binary: it
//! changes PATH for the whole process).

use std::net::TcpStream;
use std::path::Path;

use arcsim_sequencer::{simulate, Options, Schedule};
use arcsim_viewer::{spawn_delivery, ViewerError, ViewerOptions};

#[test]
fn spawn_without_viewer_is_a_clear_error() {
    if TcpStream::connect("127.0.0.1:9876").is_ok() {
        eprintln!("skipped: something listens on 9876, spawn would reuse it");
        return;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let plan = arcsim_plan::load_plan(root.join("plans/lung.json")).expect("plan");
    let machine =
        arcsim_plan::load_machine(root.join("scenarios/machine-atom.json")).expect("machine");
    let d = simulate(&plan, &machine, &Options::new(Schedule::Scan)).expect("simulation");
    std::env::set_var(
        "PATH",
        Path::new(env!("CARGO_TARGET_TMPDIR")).join("no-rerun-here"),
    );
    let err = spawn_delivery("lung", &d, &ViewerOptions::default());
    assert!(matches!(err, Err(ViewerError::Spawn(_))), "{err:?}");
    let message = err.map_err(|e| e.to_string()).expect_err("error");
    assert!(
        message.contains("pip install rerun-sdk==0.36.3"),
        "{message}"
    );
}
