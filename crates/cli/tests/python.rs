//! The Python package end to end: builds the wheel with maturin into a fresh virtual environment
//! (maturin, numpy, pandas, pytest, dask and pydicom from the package index), then runs the pytest suite
//! `python/tests` against this build of the `arcsim` command. Without Python or the package
//! index the test says so and passes, except under CI (`CI` set), where that is a failure.

use crate::util;

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::util::run;
use arcsim_test_support::{dicom, temp_file};

/// What the environment installs: the versions the package is built and tested with.
// pydicom reads the DICOM plans arcsim writes back, as a reader independent of dicom-rs.
const PACKAGES: &[&str] = &[
    "maturin==1.16.0",
    "numpy",
    "pandas",
    "pytest",
    "dask[bag]",
    "pydicom",
];

fn cannot_run(why: &str) -> ! {
    arcsim_test_support::cannot_run("the Python tests", why)
}

fn wheel_in(dir: &Path) -> Option<PathBuf> {
    std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| p.extension().is_some_and(|e| e == "whl"))
}

#[test]
fn python_package_passes_its_pytest_suite() {
    let _turn = crate::util::one_heavy_test_at_a_time();
    let repo = util::repo();
    let python = match util::python() {
        Ok(python) => python,
        Err(e) => cannot_run(&e),
    };
    let work = Path::new(env!("CARGO_TARGET_TMPDIR")).join("python");
    let venv = work.join("venv");
    let dist = work.join("dist");
    let _ = std::fs::remove_dir_all(&dist);
    let _ = std::fs::remove_dir_all(&venv);
    std::fs::create_dir_all(&work).expect("work dir");
    if let Err(e) = run(Command::new(&python).args(["-m", "venv"]).arg(&venv)) {
        cannot_run(&e);
    }
    let bin = venv.join("bin");
    let pip = |args: &[&str]| util::pip_install(&bin.join("python"), args);
    if let Err(e) = pip(PACKAGES) {
        cannot_run(&e);
    }
    // The wheel, built from this checkout with the dev profile (so it shares its dependencies'
    // build with `cargo build`; maturin's `cargo rustc` would build a test harness with the
    // `test` profile), stripped of debug information (else it is over 600 MB).
    let mut maturin = Command::new(bin.join("maturin"));
    util::without_test_environment(&mut maturin);
    run(maturin
        .current_dir(&repo)
        .args([
            "build",
            "--profile",
            "dev",
            "--strip",
            "-m",
            "crates/python/Cargo.toml",
            "-o",
        ])
        .arg(&dist)
        .arg("-i")
        .arg(bin.join("python")))
    .map(|log| {
        // A second build of rerun costs CI ~8 minutes and ~3 GB of disk: the features resolved
        // for the Python crate alone must match the workspace's (crates/python/Cargo.toml).
        assert!(
            !log.contains("Compiling rerun v"),
            "the wheel build compiled rerun again: its dependency features differ from the \
             workspace's; compare `cargo tree -e features` for -p arcsim-python and --workspace\n{log}"
        );
    })
    .unwrap_or_else(|e| panic!("{e}"));
    let wheel = wheel_in(&dist).expect("maturin wrote a wheel");
    pip(&["--no-deps", wheel.to_str().expect("utf-8 path")]).unwrap_or_else(|e| panic!("{e}"));

    let dcm = temp_file("python-arc.dcm", &dicom::dynamic_arc_plan().to_bytes());
    // Static beams at 350, 360 and 10 deg: the import warns that 360 is read as 0.
    let beams = [350.0, 360.0, 10.0]
        .iter()
        .enumerate()
        .map(|(i, &angle)| {
            let layer = dicom::Layer {
                angle,
                energy: 100.0 + i as f64,
                weights: dicom::weights_of(i),
            };
            dicom::BeamSpec::from_layers(i as i64 + 1, "STATIC", "NONE", 50.0, &[layer])
        })
        .collect();
    let warned = temp_file(
        "python-warned.dcm",
        &dicom::PlanSpec::ion("STATIC", beams).to_bytes(),
    );
    let out = Command::new(bin.join("python"))
        .current_dir(&repo)
        .args(["-m", "pytest", "-q", "-rs", "python/tests"])
        .env("ARCSIM_BIN", env!("CARGO_BIN_EXE_arcsim"))
        .env("ARCSIM_TEST_DICOM", &dcm)
        .env("ARCSIM_TEST_DICOM_WARNED", &warned)
        .output()
        .expect("run pytest");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    println!("{text}");
    assert!(out.status.success(), "pytest failed:\n{text}");
    // Every test ran except the ones that need data this machine may lack.
    assert!(!text.contains("dask is not installed"), "{text}");
}
