//! Helpers shared by the evaluator's test modules: loading a sweep from text, and a table of
//! rows as the CSV a sweep writes.

use std::path::{Path, PathBuf};

use arcsim_evaluator::{write_csv_header, write_csv_row, EvalError, Row, Sweep};

/// The repository's `scenarios/`, where the bundled sweep files resolve their paths.
pub fn scenarios() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios")
}

/// A sweep file's text named `test-sweep.json`, its paths relative to `dir`.
pub fn from_text_in(text: &str, dir: &Path) -> Result<Sweep, EvalError> {
    Sweep::from_text(text, "test-sweep.json", dir, &|p: &Path| {
        arcsim_plan::load_plan(p).map_err(|e| e.to_string())
    })
}

/// [`from_text_in`] with paths relative to `scenarios/`.
pub fn from_text(text: &str) -> Result<Sweep, EvalError> {
    from_text_in(text, &scenarios())
}

/// `rows` as the CSV table a sweep writes: the header, then one line per row.
pub fn csv(rows: &[Row]) -> String {
    let mut out = Vec::new();
    write_csv_header(&mut out).expect("write");
    for r in rows {
        write_csv_row(&mut out, r).expect("write");
    }
    String::from_utf8(out).expect("utf-8")
}
