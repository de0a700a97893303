//! Tables written as CSV (`profile`, `simulate`): each table's columns are defined once, as a
//! list of names with how to get each field from a row.

use std::borrow::Borrow;

/// One column of a table written as CSV: its name and its field of a row.
pub(crate) struct Column<R> {
    pub name: &'static str,
    pub get: fn(&R) -> String,
}

/// `rows` as CSV: the columns' names, then one line per row (fields quoted where needed; a number
/// field of -0 is written 0).
pub(crate) fn csv_table<R, T: Borrow<R>>(
    columns: &[Column<R>],
    rows: impl IntoIterator<Item = T>,
) -> Vec<u8> {
    let mut w = csv::Writer::from_writer(Vec::new());
    // Writing to memory does not fail.
    let _ = w.write_record(columns.iter().map(|c| c.name));
    for r in rows {
        let _ = w.write_record(
            columns
                .iter()
                .map(|c| arcsim_plan::without_zero_sign((c.get)(r.borrow()))),
        );
    }
    w.into_inner().unwrap_or_default()
}
