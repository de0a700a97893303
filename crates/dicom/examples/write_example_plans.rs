//! Writes the test fixtures as DICOM files to try `arcsim import` / `arcsim validate` by hand:
//! `cargo run -p arcsim-dicom --example write_example_plans -- DIR`.

#[path = "../tests/fixtures/mod.rs"]
mod fixtures;

use std::path::PathBuf;

fn main() -> std::io::Result<()> {
    let dir = std::env::args_os()
        .nth(1)
        .map_or_else(|| PathBuf::from("."), PathBuf::from);
    std::fs::create_dir_all(&dir)?;
    let plans = [
        ("arc180.dcm", fixtures::dynamic_arc_plan()),
        ("static-arc.dcm", fixtures::static_arc_plan()),
        ("two-arc.dcm", fixtures::two_arc_plan()),
        ("photon-rt-plan.dcm", fixtures::photon_plan()),
    ];
    for (name, spec) in plans {
        let path = dir.join(name);
        std::fs::write(&path, spec.to_bytes())?;
        println!("{}", path.display());
    }
    Ok(())
}
