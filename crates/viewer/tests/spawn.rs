//! Without a `rerun` executable, spawning a viewer is a clear error (run in its own process: it
//! needs a PATH without `rerun`).

use std::net::TcpStream;
use std::path::Path;

use arcsim_sequencer::{simulate, Options, Schedule};
use arcsim_test_support::{cannot_run, in_own_process};
use arcsim_viewer::{spawn_delivery, ViewerError, ViewerOptions};

#[test]
fn spawn_without_viewer_is_a_clear_error() {
    // The viewer's port is fixed: a viewer listening there would be reused, not spawned.
    if TcpStream::connect("127.0.0.1:9876").is_ok() {
        cannot_run(
            "the spawn test",
            "something listens on 127.0.0.1:9876, where spawning would reuse a running viewer",
        );
    }
    let no_rerun = Path::new(env!("CARGO_TARGET_TMPDIR")).join("no-rerun-here");
    if !in_own_process(
        module_path!(),
        "spawn_without_viewer_is_a_clear_error",
        &[("PATH", no_rerun.as_os_str())],
    ) {
        return;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let plan = arcsim_plan::load_plan(root.join("plans/lung.json")).expect("plan");
    let machine =
        arcsim_plan::load_machine(root.join("scenarios/machine-atom.json")).expect("machine");
    let d = simulate(&plan, &machine, &Options::new(Schedule::Scan)).expect("simulation");
    let err = spawn_delivery("lung", &d, &[], &ViewerOptions::default());
    assert!(matches!(err, Err(ViewerError::Spawn(_))), "{err:?}");
    let message = err.map_err(|e| e.to_string()).expect_err("error");
    assert!(
        message.contains("pip install rerun-sdk==0.36.3"),
        "{message}"
    );
}
