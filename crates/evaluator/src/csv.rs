//! The results table as CSV (one header line, then one line per combination in index order) and
//! the merge of shard outputs. Numbers are written in Rust's shortest round-trip form, so equal
//! results give equal bytes; there are no timing fields.
//!
//! The limit columns (`jerk_deg_per_s3` to `dose_rate_scale`) follow one rule: each holds the
//! value the combination uses, the swept one or else the base machine's ([`crate::Defaults`]).
//! Two columns hold the machine's value where the plan can override it: `elst_up_s` and
//! `elst_down_s` (layers with their own switching time keep it) and `window_deg` when the window
//! is not swept (it is then the machine's `default_window_deg`, used by the control points without
//! a window of their own; a swept window replaces every control point's). `dose_rate_scale` is 1
//! when not swept (the machine's own dose rate). A column is empty only where the machine has no
//! single value: `elst_up_s` for a polynomial ELST model, `scan_speed_mm_per_s` for a `per_mu`
//! beam model (no scanning speed) or a `scanning` one with separate x and y speeds.
//!
//! Tables of an older arcsim ([`CSV_HEADER_V1`]: without the two beam axes and the split of the
//! beam-on time) still merge (with each other) and read back.

use std::io::Write;

use arcsim_sequencer::{Breakdown, LimiterCounts};

use crate::run::{Evaluator, Outcome, Row, Status};
use crate::sweep::{Axis, Defaults, Setting};
use crate::EvalError;

/// The CSV header line (without the newline).
pub const CSV_HEADER: &str = "index,plan,schedule,jerk_deg_per_s3,accel_deg_per_s2,speed_deg_per_s,elst_up_s,elst_down_s,window_deg,\
scan_speed_mm_per_s,dose_rate_scale,\
status,total_s,beam_on_s,spot_irradiation_s,scanning_s,energy_switching_s,lost_s,speedup,\
limited_elst,limited_speed,limited_accel,limited_jerk,limited_none,\
violations,speed_use,accel_use,jerk_use,window_slack_deg,elst_slack_s,message";

/// The header of an older arcsim's tables: no `scan_speed_mm_per_s`, `dose_rate_scale`,
/// `spot_irradiation_s` or `scanning_s` columns. Such tables merge (with tables of the same
/// header; the merged table keeps it) and read back ([`Evaluator::rows_from_csv`]).
pub const CSV_HEADER_V1: &str = "index,plan,schedule,jerk_deg_per_s3,accel_deg_per_s2,speed_deg_per_s,elst_up_s,elst_down_s,window_deg,\
status,total_s,beam_on_s,energy_switching_s,lost_s,speedup,limited_elst,limited_speed,limited_accel,limited_jerk,limited_none,\
violations,speed_use,accel_use,jerk_use,window_slack_deg,elst_slack_s,message";

/// The headers a table may have, the current one first.
const HEADERS: [&str; 2] = [CSV_HEADER, CSV_HEADER_V1];

/// Writes the header line.
pub fn write_csv_header(out: &mut impl Write) -> std::io::Result<()> {
    writeln!(out, "{CSV_HEADER}")
}

/// Writes one row as one line. The limit columns hold the values used (see the module
/// documentation); empty fields: a result the row does not have (and the upward ELST of a
/// polynomial ELST model).
pub fn write_csv_row(out: &mut impl Write, r: &Row) -> std::io::Result<()> {
    let opt = |x: Option<f64>| x.map(|v| v.to_string()).unwrap_or_default();
    let mut f: Vec<String> = vec![
        r.index.to_string(),
        text(&r.plan),
        r.schedule.name().to_string(),
    ];
    f.extend(limit_fields(&r.setting, &r.defaults));
    f.push(r.status.name().to_string());
    match &r.outcome {
        Some(o) => {
            let c = &o.limiter_counts;
            f.extend([
                o.total_s.to_string(),
                o.breakdown.beam_on_s.to_string(),
                o.breakdown.spot_irradiation_s.to_string(),
                o.breakdown.scanning_s.to_string(),
                o.breakdown.energy_switching_s.to_string(),
                o.breakdown.lost_s.to_string(),
                opt(o.speedup),
            ]);
            f.extend(
                [c.elst, c.speed, c.accel, c.jerk, c.none, o.violations].map(|n| n.to_string()),
            );
            match &o.margins {
                Some(m) => f.extend(
                    [
                        m.speed_use,
                        m.accel_use,
                        m.jerk_use,
                        m.window_slack_deg,
                        m.elst_slack_s,
                    ]
                    .map(|x| x.value.to_string()),
                ),
                None => f.extend(std::iter::repeat_n(String::new(), 5)),
            }
        }
        None => f.extend(std::iter::repeat_n(String::new(), 18)),
    }
    f.push(text(&r.message));
    writeln!(out, "{}", f.join(","))
}

/// The limit columns of a setting, in the order of [`Axis::ALL`], each the value used.
fn limit_fields(s: &Setting, defaults: &Defaults) -> [String; Axis::ALL.len()] {
    Axis::ALL.map(|a| {
        s.get_or(a, defaults)
            .map(|v| v.to_string())
            .unwrap_or_default()
    })
}

/// A text field on one line, quoted when it holds a comma or a quote.
fn text(s: &str) -> String {
    let one_line: String = s
        .chars()
        .map(|c| if c == '\n' || c == '\r' { ' ' } else { c })
        .collect();
    if one_line.contains([',', '"']) {
        format!("\"{}\"", one_line.replace('"', "\"\""))
    } else {
        one_line
    }
}

/// Joins shard outputs (`(name, text)` pairs, in any order) into the table a single run writes.
/// Every input must have the sweep header, all the same one ([`CSV_HEADER`], or all an older
/// arcsim's [`CSV_HEADER_V1`], which the merged table then keeps); indices must not repeat and
/// must cover `0..n` without gaps, and be exactly `0..expected` when `expected` is given (the
/// sweep's combination count).
pub fn merge_csv(
    inputs: &[(String, String)],
    expected: Option<usize>,
) -> Result<String, EvalError> {
    let mut rows: Vec<(usize, &str, &str)> = Vec::new();
    // The header of the first input, and its name.
    let mut header: Option<(&str, &str)> = None;
    for (name, text) in inputs {
        let merr = |message: String| EvalError::Merge {
            file: name.clone(),
            message,
        };
        let mut lines = text.lines();
        match lines.next() {
            Some(h) if HEADERS.contains(&h) => match header {
                None => header = Some((h, name)),
                Some((first, first_name)) if first != h => {
                    let which = |h: &str| {
                        if h == CSV_HEADER {
                            "the current arcsim sweep CSV header"
                        } else {
                            "an older arcsim's header (without the scan_speed_mm_per_s, dose_rate_scale, spot_irradiation_s and scanning_s columns)"
                        }
                    };
                    return Err(merr(format!(
                        "line 1: {}, but {first_name} has {}; expected the tables of one run",
                        which(h),
                        which(first)
                    )));
                }
                Some(_) => {}
            },
            Some(_) => return Err(merr("line 1: expected the arcsim sweep CSV header".into())),
            None => {
                return Err(merr(
                    "empty file; expected the arcsim sweep CSV header".into(),
                ))
            }
        }
        if !text.ends_with('\n') {
            return Err(merr(
                "the last line is incomplete (no newline): was the run killed while writing?"
                    .into(),
            ));
        }
        for (n, line) in lines.enumerate() {
            let index = line.split(',').next().and_then(|i| i.parse::<usize>().ok());
            let index = index.ok_or_else(|| {
                merr(format!(
                    "line {}: expected a row starting with its index",
                    n + 2
                ))
            })?;
            rows.push((index, line, name));
        }
    }
    rows.sort_by_key(|r| r.0);
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
    if let Some((i, _)) = rows.iter().enumerate().find(|(i, r)| r.0 != *i) {
        return Err(EvalError::Merge {
            file: "merged shards".into(),
            message: format!("row {i} is missing; expected every combination from 0 (is a shard missing or interrupted?)"),
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
    let mut out = String::with_capacity(inputs.iter().map(|(_, t)| t.len()).sum());
    out.push_str(header.map_or(CSV_HEADER, |h| h.0));
    out.push('\n');
    for (_, line, _) in rows {
        out.push_str(line);
        out.push('\n');
    }
    Ok(out)
}

/// The fields of one CSV line as [`write_csv_row`] writes them (quoted text fields unquoted).
fn split_line(line: &str) -> Vec<String> {
    let mut fields = vec![String::new()];
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        let field = fields.last_mut().expect("one field at least");
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                chars.next();
                field.push('"');
            }
            ('"', true) => quoted = false,
            ('"', false) if field.is_empty() => quoted = true,
            (',', false) => fields.push(String::new()),
            (c, _) => field.push(c),
        }
    }
    fields
}

impl Evaluator {
    /// Reads back the rows of a results table of this sweep (e.g. merged shards) to summarise
    /// them. Each line must match the combination its index names (plan, schedule, and the limit
    /// columns as [`write_csv_row`] writes them); margins are not read back (summaries do not use
    /// them).
    ///
    /// Columns are found by their name in the header, which must be [`CSV_HEADER`] or an older
    /// arcsim's [`CSV_HEADER_V1`]. Such an older table has no beam axes (its rows must be
    /// combinations that do not sweep them) and no split of the beam-on time: its rows read back
    /// with `spot_irradiation_s` and `scanning_s` NaN (unknown).
    pub fn rows_from_csv(&self, name: &str, text: &str) -> Result<Vec<Row>, EvalError> {
        let merr = |line: usize, message: String| EvalError::Merge {
            file: name.to_string(),
            message: format!("line {line}: {message}"),
        };
        let mut lines = text.lines();
        let header = match lines.next() {
            Some(h) if HEADERS.contains(&h) => h,
            _ => return Err(merr(1, "expected the arcsim sweep CSV header".into())),
        };
        let names: Vec<&str> = header.split(',').collect();
        let columns = names.len();
        let column = |name: &str| names.iter().position(|n| *n == name);
        // Every header in HEADERS has these.
        let at = |name: &str| column(name).unwrap_or_else(|| panic!("column {name}"));
        let defaults = self.sweep().defaults();
        let mut rows = Vec::new();
        for (n, line) in lines.enumerate() {
            let ln = n + 2;
            let f = split_line(line);
            if f.len() != columns {
                return Err(merr(ln, format!("{} fields; expected {columns}", f.len())));
            }
            let num = |i: usize| -> Result<f64, EvalError> {
                f[i].parse::<f64>().map_err(|_| {
                    merr(
                        ln,
                        format!(
                            "column {} ({}): expected a number, found {:?}",
                            i + 1,
                            names[i],
                            f[i]
                        ),
                    )
                })
            };
            let opt = |i: usize| -> Result<Option<f64>, EvalError> {
                if f[i].is_empty() {
                    Ok(None)
                } else {
                    num(i).map(Some)
                }
            };
            let count = |i: usize| -> Result<usize, EvalError> {
                f[i].parse::<usize>().map_err(|_| {
                    merr(
                        ln,
                        format!(
                            "column {} ({}): expected a count, found {:?}",
                            i + 1,
                            names[i],
                            f[i]
                        ),
                    )
                })
            };
            let index = count(at("index"))?;
            if index >= self.len() {
                return Err(merr(
                    ln,
                    format!("row {index}: the sweep has {} combinations", self.len()),
                ));
            }
            let (plan, run, setting) = self.combination(index);
            let schedule = self.sweep().runs[run].schedule;
            let label = &self.sweep().plans[plan].label;
            let mut same = f[at("plan")] == *label && f[at("schedule")] == schedule.name();
            for axis in Axis::ALL {
                same &= match column(axis.field()) {
                    Some(i) => opt(i)? == setting.get_or(axis, &defaults),
                    // An older table's combinations leave the axis to the base machine.
                    None => setting.get(axis).is_none(),
                };
            }
            if !same {
                let limits: Vec<String> = Axis::ALL
                    .into_iter()
                    .zip(limit_fields(&setting, &defaults))
                    .filter(|(_, v)| !v.is_empty())
                    .map(|(a, v)| format!("{} {v}", a.symbol().0))
                    .collect();
                return Err(merr(
                    ln,
                    format!(
                        "row {index} is {label} {} {} in this sweep; the file has another \
                         combination (a different sweep file, or an older arcsim's table, which \
                         left the ELST and window columns empty when they were not swept?)",
                        schedule.name(),
                        limits.join(" ")
                    ),
                ));
            }
            let status = [
                Status::Ok,
                Status::Infeasible,
                Status::Invalid,
                Status::Error,
            ]
            .into_iter()
            .find(|s| s.name() == f[at("status")])
            .ok_or_else(|| merr(ln, format!("unknown status {:?}", f[at("status")])))?;
            let unknown = |name: &str| column(name).map_or(Ok(f64::NAN), num);
            let outcome = if status == Status::Ok {
                Some(Outcome {
                    total_s: num(at("total_s"))?,
                    breakdown: Breakdown {
                        beam_on_s: num(at("beam_on_s"))?,
                        spot_irradiation_s: unknown("spot_irradiation_s")?,
                        scanning_s: unknown("scanning_s")?,
                        energy_switching_s: num(at("energy_switching_s"))?,
                        lost_s: num(at("lost_s"))?,
                    },
                    speedup: opt(at("speedup"))?,
                    limiter_counts: LimiterCounts {
                        elst: count(at("limited_elst"))?,
                        speed: count(at("limited_speed"))?,
                        accel: count(at("limited_accel"))?,
                        jerk: count(at("limited_jerk"))?,
                        none: count(at("limited_none"))?,
                    },
                    violations: count(at("violations"))?,
                    margins: None,
                })
            } else {
                None
            };
            rows.push(Row {
                index,
                plan: label.clone(),
                schedule,
                setting,
                defaults,
                status,
                outcome,
                message: f[at("message")].clone(),
            });
        }
        Ok(rows)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(rows: &[usize]) -> String {
        let mut s = format!("{CSV_HEADER}\n");
        for r in rows {
            s.push_str(&format!("{r},p,scan\n"));
        }
        s
    }

    #[test]
    fn merge_sorts_and_checks() {
        let a = ("a".to_string(), file(&[0, 2, 4]));
        let b = ("b".to_string(), file(&[1, 3]));
        let merged = merge_csv(&[b.clone(), a.clone()], Some(5)).expect("merge");
        assert_eq!(merged, file(&[0, 1, 2, 3, 4]));
        assert!(merge_csv(&[a.clone(), b.clone()], Some(6)).is_err());
        assert!(merge_csv(std::slice::from_ref(&a), None)
            .expect_err("gap")
            .to_string()
            .contains("row 1 is missing"));
        assert!(merge_csv(&[a.clone(), a.clone()], None)
            .expect_err("dup")
            .to_string()
            .contains("also appears"));
        assert!(merge_csv(&[("c".into(), "x\n".into())], None)
            .expect_err("header")
            .to_string()
            .contains("header"));
    }

    #[test]
    fn text_fields_stay_on_one_line() {
        assert_eq!(text("a,b \"c\"\nd"), "\"a,b \"\"c\"\" d\"");
        assert_eq!(text("plain"), "plain");
    }
}
