//! Joining shard outputs into the table a single run writes.

use super::read::{check_results, records};
use super::schema::{column_index, COLUMNS};
use super::write::write_records;
use crate::EvalError;

/// Joins shard outputs (`(name, text)` pairs, in any order) into the table a single run writes.
/// Every input must have the columns of [`CSV_HEADER`](super::CSV_HEADER) (in any order; the
/// merged table has them in the header's); indices must not repeat and must be exactly `0..n`,
/// where `n` is the sweep's combination count: `expected` when given (from the sweep file), and
/// the `combinations` column of every row (which must agree with each other and with
/// `expected`). Every row's status must be one a table writes and, for a row that is ok, every
/// result a finite number not below 0 (the certificate's gap may be).
pub fn merge_csv(
    inputs: &[(String, String)],
    expected: Option<usize>,
) -> Result<String, EvalError> {
    let mut merge = Merge {
        rows: Vec::new(),
        size: expected.map(|n| (n, "the sweep file".to_string())),
    };
    for (name, text) in inputs {
        merge.add(name, text)?;
    }
    let Merge { mut rows, size } = merge;
    rows.sort_by_key(|r| r.0);
    check_complete(&rows, size.as_ref().map(|s| s.0), expected)?;
    let header: Vec<&str> = COLUMNS.iter().map(|c| c.name).collect();
    let lines = rows
        .iter()
        .map(|r| r.1.iter().map(String::as_str).collect::<Vec<_>>());
    let mut out = Vec::with_capacity(inputs.iter().map(|(_, t)| t.len()).sum());
    write_records(&mut out, std::iter::once(header).chain(lines))?;
    String::from_utf8(out).map_err(|e| EvalError::Merge {
        file: "merged shards".into(),
        message: format!("not UTF-8 text ({e})"),
    })
}

/// The shard rows read so far, and what the inputs must agree on.
struct Merge<'a> {
    /// (index, fields in the header's order, input name)
    rows: Vec<(usize, Vec<String>, &'a str)>,
    /// The sweep's size as the first row that says it does, and where.
    size: Option<(usize, String)>,
}

impl<'a> Merge<'a> {
    /// Reads one input's rows: its header must be the sweep table's, its last line complete, and
    /// each row's index within the sweep's size that every row agrees on.
    fn add(&mut self, name: &'a str, text: &str) -> Result<(), EvalError> {
        let merr = |message: String| EvalError::Merge {
            file: name.to_string(),
            message,
        };
        let (header, records) = records(text).map_err(merr)?;
        if !text.ends_with('\n') {
            return Err(merr(
                "the last line is incomplete (no newline): was the run killed while writing?"
                    .into(),
            ));
        }
        let index_column = column_index("index");
        let size_column = column_index("combinations");
        for (line, record) in records {
            let count = |column: usize, what: &str| -> Result<usize, EvalError> {
                let field = header.get(&record, column);
                field.trim().parse::<usize>().map_err(|_| {
                    merr(format!(
                        "line {line}: column {}: expected {what}, found {field:?}",
                        COLUMNS[column].name
                    ))
                })
            };
            let index = count(index_column, "a row index (a count)")?;
            check_results(&header, &record, line).map_err(merr)?;
            let n = count(size_column, "the sweep's number of combinations")?;
            self.check_size(n, index, name, line).map_err(merr)?;
            let fields = header.in_order(&record).map(str::to_string).collect();
            self.rows.push((index, fields, name));
        }
        Ok(())
    }

    /// Checks a row's sweep size `n` against the one seen first, and its index against `n`.
    fn check_size(
        &mut self,
        n: usize,
        index: usize,
        name: &str,
        line: usize,
    ) -> Result<(), String> {
        match &self.size {
            None => self.size = Some((n, format!("{name} line {line}"))),
            Some((m, from)) if *m != n => {
                return Err(format!(
                    "line {line}: a sweep of {n} combinations, but {from} says {m}; expected the tables of one sweep"
                ));
            }
            Some(_) => {}
        }
        if index >= n {
            return Err(format!(
                "line {line}: row {index} of a sweep of {n} combinations"
            ));
        }
        Ok(())
    }
}

/// Checks that the sorted `rows` hold each index once and every index of `0..total` (or, with
/// no size known, of `0..rows.len()`), and as many rows as the sweep file's `expected`.
fn check_complete(
    rows: &[(usize, Vec<String>, &str)],
    total: Option<usize>,
    expected: Option<usize>,
) -> Result<(), EvalError> {
    for pair in rows.windows(2) {
        if pair[0].0 == pair[1].0 {
            return Err(EvalError::Merge {
                file: pair[1].2.to_string(),
                message: format!(
                    "row {} also appears in {}; expected each combination once",
                    pair[1].0, pair[0].2
                ),
            });
        }
    }
    let present = rows.len();
    let missing = rows
        .iter()
        .enumerate()
        .find(|(i, r)| r.0 != *i)
        .map(|(i, _)| i)
        .or_else(|| total.filter(|&n| present < n).map(|_| present));
    if let Some(i) = missing {
        let of = total.map_or(String::new(), |n| format!(" of {n}"));
        return Err(EvalError::Merge {
            file: "merged shards".into(),
            message: format!(
                "row {i}{of} is missing; {present} rows present (is a shard missing or interrupted?)"
            ),
        });
    }
    if let Some(n) = expected {
        if present != n {
            return Err(EvalError::Merge {
                file: "merged shards".into(),
                message: format!("{present} rows; the sweep has {n} combinations (is a shard missing or interrupted?)"),
            });
        }
    }
    Ok(())
}
