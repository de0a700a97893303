//! Writing the table: the header line and one line per row.

use std::io::Write;

use super::schema::{Field, COLUMNS, CSV_HEADER};
use crate::run::{Outcome, Row};

/// A text field on one line: a table row is one line (line breaks become spaces).
pub(super) fn one_line(s: &str) -> String {
    s.chars()
        .map(|c| if c == '\n' || c == '\r' { ' ' } else { c })
        .collect()
}

/// Writes `records` as CSV lines (quoted where a field needs it).
pub(super) fn write_records<'a, I, R>(out: &mut impl Write, records: I) -> std::io::Result<()>
where
    I: IntoIterator<Item = R>,
    R: IntoIterator<Item = &'a str>,
{
    let mut w = csv::WriterBuilder::new()
        .flexible(true)
        .buffer_capacity(4096)
        .from_writer(out);
    for r in records {
        w.write_record(r).map_err(csv_io)?;
    }
    w.flush()
}

fn csv_io(e: csv::Error) -> std::io::Error {
    match e.into_kind() {
        csv::ErrorKind::Io(e) => e,
        kind => std::io::Error::other(format!("{kind:?}")),
    }
}

/// Writes the header line.
pub fn write_csv_header(out: &mut impl Write) -> std::io::Result<()> {
    writeln!(out, "{CSV_HEADER}")
}

/// Writes one row as one line. The limit columns hold the values used (see the module
/// documentation); empty fields: a result the row does not have, and an ELST the machine's model
/// has no single value for.
pub fn write_csv_row(out: &mut impl Write, r: &Row) -> std::io::Result<()> {
    let fields: Vec<String> = COLUMNS.iter().map(|c| field_text(c.field, r)).collect();
    write_records(out, [fields.iter().map(String::as_str)])
}

/// The text of one field of `r`; numbers are written without the sign of a zero.
pub(super) fn field_text(field: Field, r: &Row) -> String {
    let outcome = |f: &dyn Fn(&Outcome) -> Option<String>| r.outcome.as_ref().and_then(f);
    let number = |x: f64| arcsim_plan::without_zero_sign(x.to_string());
    let text = match field {
        Field::Index => Some(r.index.to_string()),
        Field::Combinations => Some(r.combinations.to_string()),
        Field::Name(get) => Some(one_line(&get(r))),
        Field::Limit(axis) => r.setting.get_or(axis, &r.defaults).map(number),
        Field::Status => Some(r.status.name().to_string()),
        Field::Number(get, _) => outcome(&|o| Some(number(get(o)))),
        Field::Optional(get, _) => outcome(&|o| get(o).map(number)),
        Field::Count(get, _) => outcome(&|o| Some(get(o).to_string())),
        Field::Margin(get) => outcome(&|o| o.margins.as_ref().map(|m| number(get(m)))),
        Field::Message => Some(one_line(&r.message)),
    };
    text.unwrap_or_default()
}
