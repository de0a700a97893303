//! The results table as CSV (one header line, then one line per combination in index order) and
//! the merge of shard outputs. Numbers are written in Rust's shortest round-trip form, so equal
//! results give equal bytes; there are no timing fields.
//!
//! The limit columns (`jerk_deg_per_s3` to `burst_switching_time_s`) follow one rule: each holds the
//! value the combination uses, the swept one or else the base machine's ([`crate::Defaults`]).
//! Two columns hold the machine's value where the plan can override it: `elst_up_s` and
//! `elst_down_s` (layers with their own switching time keep it) and `window_deg` when the window
//! is not swept (it is then the machine's `default_window_deg`, used by the control points without
//! a window of their own; a swept window replaces every control point's). `dose_rate_scale` is 1
//! when not swept (the machine's own dose rate). A column is empty only where the machine has no
//! single value: `elst_up_s` for a polynomial ELST model, both ELST columns for an ELST table
//! (`by_energy`, `by_energy_pair`), `scan_speed_mm_per_s` for a `per_mu`
//! beam model (no scanning speed) or a `scanning` one with separate x and y speeds,
//! `burst_switching_time_s` for a `per_mu` beam model (no bursts).
//!
//! A table is read and merged only with [`CSV_HEADER`]'s columns: one with other columns (an
//! earlier arcsim's) is refused, naming the file and the header expected.
//!
//! Every column is defined once, in `COLUMNS`: its name and how a row writes it and reads back
//! into one. The writer, the reader and the merge all go through that list and the `csv` crate,
//! so a table read back may have its columns in any order (found by their header name), and
//! quoted fields, a UTF-8 byte-order mark and CRLF line ends read as well.
//!
//! The files: `schema` (the columns and the header), `write` (a row as a line), `merge` (shard
//! outputs into one table), `read` (a table back into rows) and `lines` (line numbers of records,
//! for located errors).

mod lines;
mod merge;
mod read;
mod schema;
mod write;

pub use lines::CsvLineNumbers;
pub use merge::merge_csv;
pub use schema::CSV_HEADER;
pub use write::{write_csv_header, write_csv_row};

#[cfg(test)]
mod tests;
