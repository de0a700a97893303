//! The DICOM plan bundled for the walk-through (`plans/dicom/arc180.dcm`) is exactly what the test
//! fixtures write, and imports as the arc they describe.

use std::path::Path;

use arcsim_dicom::read_rt_ion_plan;
use arcsim_test_support::dicom;

fn bundled() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../plans/dicom/arc180.dcm")
}

#[test]
fn the_bundled_dicom_plan_is_the_fixture() {
    let committed = std::fs::read(bundled()).expect("plans/dicom/arc180.dcm is readable");
    assert!(
        committed == dicom::dynamic_arc_plan().to_bytes(),
        "plans/dicom/arc180.dcm differs from dicom::dynamic_arc_plan(); regenerate it by writing \
         that fixture's to_bytes() to the file"
    );
}

#[test]
fn the_bundled_dicom_plan_imports_as_one_arc_of_180_layers() {
    let plan = read_rt_ion_plan(bundled()).expect("the bundled plan imports");
    assert_eq!(plan.arcs.len(), 1);
    let layers: usize = plan.arcs[0]
        .control_points
        .iter()
        .map(|cp| cp.layers.len())
        .sum();
    assert_eq!(layers, 180);
}

/// `plans/dicom/multi.dcm`, the plan the re-sequencing walk-through writes back, is the fixture
/// `dicom::multi_layer_arc_plan()`.
#[test]
fn the_bundled_multi_layer_plan_is_the_fixture() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../plans/dicom/multi.dcm");
    if std::env::var_os("ARCSIM_WRITE_BUNDLED").is_some() {
        std::fs::write(&path, dicom::multi_layer_arc_plan().to_bytes()).expect("written");
    }
    let committed = std::fs::read(&path).expect("plans/dicom/multi.dcm is readable");
    assert!(
        committed == dicom::multi_layer_arc_plan().to_bytes(),
        "plans/dicom/multi.dcm differs from dicom::multi_layer_arc_plan(); regenerate it with \
         ARCSIM_WRITE_BUNDLED=1 cargo test -p arcsim-dicom bundled"
    );
}
