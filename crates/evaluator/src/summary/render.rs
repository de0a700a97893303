//! The summary as aligned text tables (what `arcsim sweep` and `sweep-merge` print), and the
//! number and setting formats the report and viewer share with them.

use super::{Entry, Sensitivity, Step, Summary, TIE_TOLERANCE};
use crate::sweep::{Axis, Setting};
use crate::sweep_file::Target;

/// A number with at most 4 decimals, trailing zeros dropped ("0.25", "1", "0.1468").
pub fn short(x: f64) -> String {
    let s = arcsim_plan::without_zero_sign(format!("{x:.4}"));
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// `x` with `decimals` decimals; "-" when there is none (e.g. an infeasible total).
fn opt(x: Option<f64>, decimals: usize) -> String {
    x.map_or_else(
        || "-".to_string(),
        |v| arcsim_plan::without_zero_sign(format!("{v:.decimals$}")),
    )
}

/// "J 0.5 -> 1 deg/s^3, A 0.5 -> 0.75 deg/s^2".
pub fn describe_steps(steps: &[Step]) -> String {
    if steps.is_empty() {
        return "none (the base machine reaches it)".into();
    }
    let parts: Vec<String> = steps
        .iter()
        .map(|s| {
            let (sym, unit) = s.axis.symbol();
            format!("{sym} {} -> {} {unit}", short(s.from), short(s.to))
        })
        .collect();
    parts.join(", ")
}

/// "J 2, A 1, V 6" plus any ELST / window the setting sets.
pub fn describe_setting(s: &Setting) -> String {
    let parts: Vec<String> = Axis::ALL
        .into_iter()
        .filter_map(|a| s.get(a).map(|v| format!("{} {}", a.symbol().0, short(v))))
        .collect();
    parts.join(", ")
}

/// An aligned text table: text columns left-aligned, the others right-aligned.
pub fn table(header: &[&str], left: &[bool], rows: &[Vec<String>]) -> String {
    let mut width: Vec<usize> = header.iter().map(|h| h.chars().count()).collect();
    for r in rows {
        for (w, c) in width.iter_mut().zip(r) {
            *w = (*w).max(c.chars().count());
        }
    }
    let line = |cells: Vec<&str>| {
        let parts: Vec<String> = cells
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let w = width[i];
                if left.get(i).copied().unwrap_or(false) {
                    format!("{c:<w$}")
                } else {
                    format!("{c:>w$}")
                }
            })
            .collect();
        parts.join("  ").trim_end().to_string() + "\n"
    };
    let mut out = line(header.to_vec());
    for r in rows {
        out += &line(r.iter().map(String::as_str).collect());
    }
    out
}

impl Summary {
    /// The summary as aligned text tables: the totals per plan and schedule, the sensitivities,
    /// the cheapest change reaching the target, then the one-limit profiles (when there are any).
    pub fn to_table(&self) -> String {
        let mut out = self.totals_table();
        out += &self.sensitivity_table();
        out += &self.cheapest_table();
        out += &self.profiles_table();
        out
    }

    /// The title, the base and fastest totals of each entry, and how ties are broken.
    fn totals_table(&self) -> String {
        let partial = if self.rows < self.combinations {
            format!(" ({} of {} combinations)", self.rows, self.combinations)
        } else {
            String::new()
        };
        let mut out = format!(
            "Sweep \"{}\"{partial}: delivery time per plan and schedule\n",
            self.sweep
        );
        let rows: Vec<Vec<String>> = self.entries.iter().map(totals_row).collect();
        out += &table(
            &[
                "plan",
                "schedule",
                "rows",
                "feasible",
                "base [s]",
                "fastest [s]",
                "speed-up",
                "fastest setting",
            ],
            &[true, true, false, false, false, false, false, true],
            &rows,
        );
        out += &format!(
            "(totals within {TIE_TOLERANCE:e} (relative) of the fastest tie; a tie goes to the setting closest to the base machine:\n \
             fewest limits changed, then smallest Σ |ln(new/base)|, then lower values in the order J, A, V, ELST up, ELST down, window,\n \
             scan speed, dose rate)\n"
        );
        out
    }

    /// The sensitivity of each entry's total to each limit that any entry reports.
    fn sensitivity_table(&self) -> String {
        let axes: Vec<Axis> = Axis::ALL
            .into_iter()
            .filter(|a| {
                self.entries
                    .iter()
                    .any(|e| e.sensitivity.iter().any(|s| s.axis == *a))
            })
            .collect();
        let mut out = format!(
            "\nSensitivity at the base machine: change of the total for +10 % of one limit, in s\n\
             (central difference (T(1.1 L) - T(L/1.1)) / 2; negative = raising the limit saves time;\n \
             \"no effect (LO–HI)\": every value of the limit evaluated from LO to HI, the others at the base machine,\n \
             gives the same total within {TIE_TOLERANCE:e} (relative))\n"
        );
        let mut header = vec!["plan".to_string(), "schedule".to_string()];
        header.extend(axes.iter().map(|&a| self.sensitivity_column(a)));
        let rows: Vec<Vec<String>> = self
            .entries
            .iter()
            .map(|e| {
                let mut r = vec![e.plan.clone(), e.schedule.name()];
                r.extend(
                    axes.iter()
                        .map(|a| sensitivity_cell(e.sensitivity.iter().find(|s| s.axis == *a))),
                );
                r
            })
            .collect();
        let header_refs: Vec<&str> = header.iter().map(String::as_str).collect();
        out += &table(&header_refs, &[true, true], &rows);
        out
    }

    /// The heading of a sensitivity column: the limit and its base value ("J (base 0.5)").
    fn sensitivity_column(&self, axis: Axis) -> String {
        let base = self
            .entries
            .iter()
            .flat_map(|e| &e.sensitivity)
            .find(|s| s.axis == axis)
            .map(|s| s.base_value);
        format!(
            "{} (base {})",
            axis.symbol().0,
            base.map_or("-".into(), short)
        )
    }

    /// The cheapest change reaching the target, per entry.
    fn cheapest_table(&self) -> String {
        let target = match self.target {
            Target::TotalS(t) => format!("total <= {} s", short(t)),
            Target::SavingPercent(p) => format!("{} % saving", short(p)),
        };
        let mut out = format!(
            "\nCheapest change reaching the target ({target}): smallest Σ |ln(new/base)| over the changed limits\n\
             (costs within {TIE_TOLERANCE:e} tie; a tie goes to the shorter total, then as the fastest setting's)\n"
        );
        let rows: Vec<Vec<String>> = self.entries.iter().map(cheapest_row).collect();
        out += &table(
            &[
                "plan",
                "schedule",
                "target [s]",
                "change",
                "total [s]",
                "saves [s]",
            ],
            &[true, true, false, true],
            &rows,
        );
        out
    }

    /// The total at each profiled value of each swept limit; empty when no entry has a profile.
    fn profiles_table(&self) -> String {
        if self.entries.iter().all(|e| e.profiles.is_empty()) {
            return String::new();
        }
        let mut out =
            "\nTime at each value of one limit, the others at the base machine\n".to_string();
        let mut rows = Vec::new();
        for e in &self.entries {
            for p in &e.profiles {
                let (sym, unit) = p.axis.symbol();
                for pt in &p.points {
                    rows.push(vec![
                        e.plan.clone(),
                        e.schedule.name(),
                        format!("{sym} [{unit}]"),
                        short(pt.value),
                        opt(pt.total_s, 1),
                        opt(pt.speedup, 3),
                    ]);
                }
            }
        }
        out += &table(
            &[
                "plan",
                "schedule",
                "limit",
                "value",
                "total [s]",
                "speed-up",
            ],
            &[true, true, true],
            &rows,
        );
        out
    }
}

/// An entry's row of the totals table.
fn totals_row(e: &Entry) -> Vec<String> {
    vec![
        e.plan.clone(),
        e.schedule.name(),
        e.rows.to_string(),
        e.feasible.to_string(),
        opt(e.base_total_s, 1),
        opt(e.fastest.map(|p| p.total_s), 1),
        opt(e.fastest.and_then(|p| p.speedup), 3),
        e.fastest
            .map_or("-".into(), |p| describe_setting(&p.setting)),
    ]
}

/// A sensitivity cell: the change for +10 %, "no effect (LO–HI UNIT)", or "-" when not reported.
fn sensitivity_cell(s: Option<&Sensitivity>) -> String {
    s.map_or("-".into(), |s| {
        if s.no_effect {
            format!(
                "no effect ({}–{} {})",
                short((s.evaluated_min * 100.0).round() / 100.0),
                short((s.evaluated_max * 100.0).round() / 100.0),
                s.axis.symbol().1
            )
        } else {
            opt(s.s_per_10_percent, 2)
        }
    })
}

/// An entry's row of the cheapest-change table.
fn cheapest_row(e: &Entry) -> Vec<String> {
    let mut row = vec![e.plan.clone(), e.schedule.name(), opt(e.target_total_s, 1)];
    row.extend(match &e.cheapest {
        Some(c) => [
            describe_steps(&c.steps),
            arcsim_plan::without_zero_sign(format!("{:.1}", c.total_s)),
            arcsim_plan::without_zero_sign(format!("{:.1}", c.saving_s)),
        ],
        None => [
            "not reached by any evaluated setting".into(),
            "-".into(),
            "-".into(),
        ],
    });
    row
}
