//! Writes the test fixtures as DICOM files to try `arcsim import` / `arcsim validate` by hand:
//! `cargo run -p arcsim-dicom --example write_example_plans -- DIR`.

use std::path::PathBuf;

use arcsim_test_support::dicom;

fn main() -> std::io::Result<()> {
    let dir = std::env::args_os()
        .nth(1)
        .map_or_else(|| PathBuf::from("."), PathBuf::from);
    std::fs::create_dir_all(&dir)?;
    let plans = [
        ("arc180.dcm", dicom::dynamic_arc_plan()),
        ("static-arc.dcm", dicom::static_arc_plan()),
        ("two-arc.dcm", dicom::two_arc_plan()),
        ("photon-rt-plan.dcm", dicom::photon_plan()),
    ];
    for (name, spec) in plans {
        let path = dir.join(name);
        std::fs::write(&path, spec.to_bytes())?;
        println!("{}", path.display());
    }
    Ok(())
}
