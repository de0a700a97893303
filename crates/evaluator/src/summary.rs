//! Summaries of a sweep, per plan and schedule entry:
//!
//! - **time at each setting of one limit**: the total with one axis at each of its swept values
//!   and every other limit at the base machine's value, with the speed-up (base total / total);
//!   an axis of more than [`PROFILE_MAX_POINTS`] values is profiled at that many of them, evenly
//!   spread by position, both ends included (so a shard of a huge axis is not summarised by
//!   simulating every value of it);
//! - **fastest row** of the grid, with its speed-up against the base machine. Totals within
//!   [`TIE_TOLERANCE`] (relative) of the fastest tie, and ties go to the setting closest to the
//!   base machine ([`Evaluator::closest_to_base`]): fewest limits changed, then smallest
//!   `Σ |ln(value / base value)|`, then the lower values in axis order (J, A, V, ELST up, ELST
//!   down, window, scanning speed, dose-rate scale), then a grid row before a computed setting,
//!   the lower index first. The pick depends only on the set of rows, not on their order (so a
//!   shard and the merged table agree whenever they hold the same tied rows);
//! - **sensitivity** of the total to each limit L at the base machine, by central finite
//!   differences: `s_per_10_percent = (T(1.1 L) - T(L / 1.1)) / 2`, the change in total time for a
//!   +10 % change of L (≈ ln(1.1) · dT/d ln L; negative: raising L saves time), and
//!   `s_per_ln = dT/d ln L` itself. A limit has **no effect** (`no_effect`) when every value of it
//!   the summary evaluated with the other limits at the base machine (L / 1.1, L, 1.1 L and the
//!   profile's values; from `evaluated_min` to `evaluated_max`) is feasible and gives the same
//!   total within [`TIE_TOLERANCE`] (relative);
//! - **cheapest change reaching the target**: among the grid rows and the one-limit settings
//!   whose total reaches the target time, the one whose limits differ least from the base
//!   machine, where the cost of a setting is `Σ |ln(value / base value)|` over the limits it
//!   changes (doubling or halving one limit costs ln 2 ≈ 0.69; doubling two costs 1.39). Costs
//!   within [`TIE_TOLERANCE`] tie; ties go to the shorter total (within [`TIE_TOLERANCE`],
//!   relative), then as the fastest row's. Changes from or to a zero value (e.g. an ELST of 0 s)
//!   are not ranked.

use std::cmp::Ordering;

use crate::RunMode;
use rayon::prelude::*;
use serde::Serialize;

use crate::run::{Evaluator, Row, Status};
use crate::sweep::{Axis, Setting};
use crate::sweep_file::Target;

/// A sweep's summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    pub sweep: String,
    /// Combinations in the whole sweep.
    pub combinations: usize,
    /// Rows summarised (fewer for a shard or an interrupted run).
    pub rows: usize,
    pub target: Target,
    pub entries: Vec<Entry>,
}

/// The summary of one plan under one schedule entry.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Entry {
    pub plan: String,
    pub schedule: RunMode,
    pub rows: usize,
    pub feasible: usize,
    /// Total on the base machine.
    pub base_total_s: Option<f64>,
    /// The fastest row; of rows tied within [`TIE_TOLERANCE`], the one closest to the base
    /// machine ([`Evaluator::fastest`]).
    pub fastest: Option<Point>,
    /// Time at each value of one axis, the others at the base machine.
    pub profiles: Vec<Profile>,
    pub sensitivity: Vec<Sensitivity>,
    /// The target total (from the sweep's `target` and the base total).
    pub target_total_s: Option<f64>,
    /// The cheapest change reaching the target; `None` when no evaluated setting reaches it.
    pub cheapest: Option<Change>,
}

/// A setting and its total.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Point {
    /// Row index when the point is a grid row.
    pub index: Option<usize>,
    pub setting: Setting,
    pub total_s: f64,
    pub speedup: Option<f64>,
}

/// Most points of a one-limit profile ([`Profile`]): a longer axis is profiled at this many of its
/// values, evenly spread by position, both ends included.
pub const PROFILE_MAX_POINTS: usize = 1000;

/// The positions of an axis of `n` values that its profile evaluates: all of them, or
/// [`PROFILE_MAX_POINTS`] evenly spread, both ends included.
fn profile_positions(n: usize) -> impl Iterator<Item = usize> {
    let m = n.min(PROFILE_MAX_POINTS);
    (0..m).map(move |k| {
        if m == n {
            k
        } else {
            // m >= 2 here; the widening keeps k·(n − 1) from overflowing.
            (k as u128 * (n - 1) as u128 / (m - 1) as u128) as usize
        }
    })
}

/// Totals along one axis (at most [`PROFILE_MAX_POINTS`] of its values).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Profile {
    pub axis: Axis,
    pub points: Vec<ProfilePoint>,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ProfilePoint {
    pub value: f64,
    /// `None` when the setting is not feasible.
    pub total_s: Option<f64>,
    pub speedup: Option<f64>,
}

/// Sensitivity of the total to one limit at the base machine.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Sensitivity {
    pub axis: Axis,
    pub base_value: f64,
    /// dT / d ln L (s).
    pub s_per_ln: Option<f64>,
    /// Change of the total for +10 % of the limit (s).
    pub s_per_10_percent: Option<f64>,
    /// The limit has no effect: every value of it evaluated with the other limits at the base
    /// machine (`evaluated_min` to `evaluated_max`) is feasible and gives the same total, within
    /// [`TIE_TOLERANCE`] (relative).
    pub no_effect: bool,
    /// The lowest value of the limit evaluated with the others at the base machine (L / 1.1 or
    /// the lowest profiled value).
    pub evaluated_min: f64,
    /// The highest such value (1.1 L or the highest profiled value).
    pub evaluated_max: f64,
}

/// One limit changed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Step {
    pub axis: Axis,
    pub from: f64,
    pub to: f64,
}

/// A change of the base machine and what it saves.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Change {
    /// The changed limits (empty: the base machine already reaches the target).
    pub steps: Vec<Step>,
    /// Σ |ln(to / from)|.
    pub cost: f64,
    pub total_s: f64,
    pub saving_s: f64,
    /// Row index when the setting is a grid row.
    pub index: Option<usize>,
}

/// Relative tolerance under which two totals are the same (`|a − b| <= TIE_TOLERANCE · min(a, b)`,
/// 0.3 µs on a 300 s delivery), and absolute tolerance under which two costs `Σ |ln(value / base
/// value)|` are the same (a ratio within 1e-9): far above rounding noise (about 1e-16 relative),
/// far below any difference a delivery cares about.
pub const TIE_TOLERANCE: f64 = 1e-9;

/// The items whose `key` is at most `slack(min)` above the smallest key, in their order.
fn near_min<T>(items: Vec<T>, key: impl Fn(&T) -> f64, slack: impl Fn(f64) -> f64) -> Vec<T> {
    let Some(min) = items.iter().map(&key).min_by(f64::total_cmp) else {
        return items;
    };
    let limit = min + slack(min);
    items.into_iter().filter(|t| key(t) <= limit).collect()
}

/// Slack of a total: [`TIE_TOLERANCE`], relative.
fn total_slack(min: f64) -> f64 {
    TIE_TOLERANCE * min.abs()
}

/// Factor of the finite differences (±10 %).
const FD_FACTOR: f64 = 1.1;

enum Task {
    Profile { axis: Axis, value: f64 },
    Sens { axis: Axis, up: bool },
}

impl Evaluator {
    /// Summarises `rows` (any subset of the sweep's, e.g. a shard's), evaluating on the current
    /// rayon pool the extra settings the summary needs (one-limit profiles, finite differences).
    pub fn summarize(&self, rows: &[Row]) -> Summary {
        let sweep = self.sweep();
        let base = sweep.base_setting();
        let mut entries = Vec::new();
        for plan in 0..sweep.plans.len() {
            for (run, r) in sweep.runs.iter().enumerate() {
                let base_total = self.base_total_s(plan, run);
                let g = &r.grid;
                let swept: Vec<Axis> = Axis::ALL
                    .into_iter()
                    .filter(|&a| !(g.axis_len(a) == 1 && g.value(a, 0) == base.get(a)))
                    .collect();
                let mut tasks = Vec::new();
                for &axis in &swept {
                    for v in profile_positions(g.axis_len(axis)).filter_map(|i| g.value(axis, i)) {
                        tasks.push(Task::Profile { axis, value: v });
                    }
                }
                let sens_axes: Vec<Axis> = Axis::ALL
                    .into_iter()
                    .filter(|&a| {
                        matches!(a, Axis::Jerk | Axis::Accel | Axis::Speed) || swept.contains(&a)
                    })
                    .filter(|&a| sweep.base_value(a).is_some_and(|b| b > 0.0))
                    .collect();
                for &axis in &sens_axes {
                    tasks.extend([
                        Task::Sens { axis, up: true },
                        Task::Sens { axis, up: false },
                    ]);
                }
                let setting_of = |t: &Task| match *t {
                    Task::Profile { axis, value } => base.with(axis, value),
                    Task::Sens { axis, up } => {
                        let b = sweep.base_value(axis).unwrap_or(1.0);
                        base.with(axis, if up { b * FD_FACTOR } else { b / FD_FACTOR })
                    }
                };
                let totals: Vec<Option<f64>> = tasks
                    .par_iter()
                    .map(|t| {
                        self.simulate(plan, r.schedule, &setting_of(t), base_total)
                            .1
                            .map(|o| o.total_s)
                    })
                    .collect();
                let speedup = |t: Option<f64>| base_total.zip(t).map(|(b, t)| b / t);
                let profiles: Vec<Profile> = swept
                    .iter()
                    .map(|&axis| Profile {
                        axis,
                        points: tasks
                            .iter()
                            .zip(&totals)
                            .filter_map(|(t, &total)| match *t {
                                Task::Profile { axis: a, value } if a == axis => {
                                    Some(ProfilePoint {
                                        value,
                                        total_s: total,
                                        speedup: speedup(total),
                                    })
                                }
                                _ => None,
                            })
                            .collect(),
                    })
                    .collect();
                let fd = |axis: Axis, up: bool| {
                    tasks.iter().zip(&totals).find_map(|(t, &total)| match *t {
                        Task::Sens { axis: a, up: u } if a == axis && u == up => total,
                        _ => None,
                    })
                };
                let sensitivity = sens_axes
                    .iter()
                    .map(|&axis| {
                        let diff = fd(axis, true).zip(fd(axis, false)).map(|(p, m)| p - m);
                        let b = sweep.base_value(axis).unwrap_or(f64::NAN);
                        // Every value of this limit evaluated with the others at the base machine.
                        let mut evaluated = vec![
                            (b / FD_FACTOR, fd(axis, false)),
                            (b, base_total),
                            (b * FD_FACTOR, fd(axis, true)),
                        ];
                        evaluated.extend(tasks.iter().zip(&totals).filter_map(
                            |(t, &total)| match *t {
                                Task::Profile { axis: a, value } if a == axis => {
                                    Some((value, total))
                                }
                                _ => None,
                            },
                        ));
                        let values = evaluated.iter().map(|e| e.0);
                        let all: Option<Vec<f64>> = evaluated.iter().map(|e| e.1).collect();
                        let no_effect = all.is_some_and(|t| {
                            let lo = t.iter().copied().fold(f64::INFINITY, f64::min);
                            let hi = t.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                            hi - lo <= total_slack(lo)
                        });
                        Sensitivity {
                            axis,
                            base_value: b,
                            s_per_ln: diff.map(|d| d / (2.0 * FD_FACTOR.ln())),
                            s_per_10_percent: diff.map(|d| d / 2.0),
                            no_effect,
                            evaluated_min: values.clone().fold(f64::INFINITY, f64::min),
                            evaluated_max: values.fold(f64::NEG_INFINITY, f64::max),
                        }
                    })
                    .collect();

                // Grid rows of this entry, then the profile points, as candidates.
                let mine: Vec<&Row> = rows
                    .iter()
                    .filter(|row| {
                        let (p, rr, _) = self.combination(row.index);
                        p == plan && rr == run
                    })
                    .collect();
                let feasible: Vec<Point> = mine
                    .iter()
                    .filter(|row| row.status == Status::Ok)
                    .filter_map(|row| {
                        row.outcome.map(|o| Point {
                            index: Some(row.index),
                            setting: row.setting,
                            total_s: o.total_s,
                            speedup: o.speedup,
                        })
                    })
                    .collect();
                let fastest = self.fastest(&feasible);
                let mut candidates = feasible.clone();
                for (t, &total) in tasks.iter().zip(&totals) {
                    if let (Task::Profile { .. }, Some(total_s)) = (t, total) {
                        candidates.push(Point {
                            index: None,
                            setting: setting_of(t),
                            total_s,
                            speedup: speedup(Some(total_s)),
                        });
                    }
                }
                let target_total_s = base_total.map(|b| sweep.target.total_s(b));
                let cheapest = target_total_s
                    .zip(base_total)
                    .and_then(|(target, b)| self.cheapest(&candidates, target, b));
                entries.push(Entry {
                    plan: sweep.plans[plan].label.clone(),
                    schedule: r.schedule,
                    rows: mine.len(),
                    feasible: feasible.len(),
                    base_total_s: base_total,
                    fastest,
                    profiles,
                    sensitivity,
                    target_total_s,
                    cheapest,
                });
            }
        }
        Summary {
            sweep: sweep.name.clone(),
            combinations: self.len(),
            rows: rows.len(),
            target: sweep.target,
            entries,
        }
    }

    /// The changed limits of a setting and its cost, `None` when a change involves a zero value.
    pub fn change_of(&self, s: &Setting) -> Option<(Vec<Step>, f64)> {
        let mut steps = Vec::new();
        let mut cost = 0.0;
        for axis in Axis::ALL {
            let Some(to) = s.get(axis) else { continue };
            let from = self.sweep().base_value(axis)?;
            if to == from {
                continue;
            }
            if !(to > 0.0 && from > 0.0) {
                return None;
            }
            cost += (to / from).ln().abs();
            steps.push(Step { axis, from, to });
        }
        Some((steps, cost))
    }

    /// The fastest of `points`: among those whose total is within [`TIE_TOLERANCE`] (relative)
    /// of the smallest, the one closest to the base machine ([`Evaluator::closest_to_base`]).
    pub fn fastest(&self, points: &[Point]) -> Option<Point> {
        let tied = near_min(points.to_vec(), |p| p.total_s, total_slack);
        self.closest_to_base(tied.into_iter().map(|p| (p, ())).collect())
            .map(|(p, ())| p)
    }

    fn cheapest(&self, candidates: &[Point], target: f64, base_total: f64) -> Option<Change> {
        if base_total <= target {
            return Some(Change {
                steps: Vec::new(),
                cost: 0.0,
                total_s: base_total,
                saving_s: 0.0,
                index: None,
            });
        }
        let reaching: Vec<(Point, (Vec<Step>, f64))> = candidates
            .iter()
            .filter(|p| p.total_s <= target)
            .filter_map(|p| self.change_of(&p.setting).map(|change| (*p, change)))
            .collect();
        let cheapest = near_min(reaching, |c| c.1 .1, |_| TIE_TOLERANCE);
        let shortest = near_min(cheapest, |c| c.0.total_s, total_slack);
        self.closest_to_base(shortest)
            .map(|(p, (steps, cost))| Change {
                steps,
                cost,
                total_s: p.total_s,
                saving_s: base_total - p.total_s,
                index: p.index,
            })
    }

    /// How far a setting is from the base machine: the number of limits it changes and
    /// `Σ |ln(value / base value)|` over them (+∞ for a change from or to 0).
    pub fn distance_from_base(&self, s: &Setting) -> (usize, f64) {
        let sweep = self.sweep();
        let mut changed = 0;
        let mut cost = 0.0;
        for axis in Axis::ALL {
            let Some(to) = s.get(axis) else { continue };
            let from = sweep.base_value(axis);
            if from == Some(to) {
                continue;
            }
            changed += 1;
            cost += match from {
                Some(from) if from > 0.0 && to > 0.0 => (to / from).ln().abs(),
                _ => f64::INFINITY,
            };
        }
        (changed, cost)
    }

    /// Of tied points (each with its payload), the one closest to the base machine: the fewest
    /// limits changed, then the smallest `Σ |ln(value / base value)|` (within
    /// [`TIE_TOLERANCE`]), then the lower values in axis order (J, A, V, ELST up, ELST down,
    /// window, scanning speed, dose-rate scale; a value the setting keeps counts as the base
    /// machine's), then a grid row before a computed setting and the lower row index first.
    /// Depends on the set of points only, not on their order. `None` when there are none.
    pub fn closest_to_base<T>(&self, points: Vec<(Point, T)>) -> Option<(Point, T)> {
        let keyed: Vec<((usize, f64), (Point, T))> = points
            .into_iter()
            .map(|p| (self.distance_from_base(&p.0.setting), p))
            .collect();
        let fewest = keyed.iter().map(|k| k.0 .0).min()?;
        let keyed: Vec<_> = keyed.into_iter().filter(|k| k.0 .0 == fewest).collect();
        let keyed = near_min(keyed, |k| k.0 .1, |_| TIE_TOLERANCE);
        let defaults = self.sweep().defaults();
        let values = |s: &Setting| Axis::ALL.map(|a| s.get_or(a, &defaults));
        keyed.into_iter().map(|k| k.1).min_by(|(a, _), (b, _)| {
            let by_value = values(&a.setting)
                .iter()
                .zip(values(&b.setting).iter())
                .map(|(x, y)| match (x, y) {
                    (Some(x), Some(y)) => x.total_cmp(y),
                    _ => x.is_some().cmp(&y.is_some()),
                })
                .find(|o| o.is_ne())
                .unwrap_or(Ordering::Equal);
            let by_index = match (a.index, b.index) {
                (Some(i), Some(j)) => i.cmp(&j),
                (i, j) => j.is_some().cmp(&i.is_some()),
            };
            by_value.then(by_index)
        })
    }
}

// ---- the printed table ----

/// A number with at most 4 decimals, trailing zeros dropped ("0.25", "1", "0.1468").
pub fn short(x: f64) -> String {
    let s = format!("{x:.4}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

fn opt(x: Option<f64>, decimals: usize) -> String {
    x.map_or_else(|| "-".to_string(), |v| format!("{v:.decimals$}"))
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
    /// The summary as aligned text tables.
    pub fn to_table(&self) -> String {
        let mut out = String::new();
        let partial = if self.rows < self.combinations {
            format!(" ({} of {} combinations)", self.rows, self.combinations)
        } else {
            String::new()
        };
        out += &format!(
            "Sweep \"{}\"{partial}: delivery time per plan and schedule\n",
            self.sweep
        );
        let rows: Vec<Vec<String>> = self
            .entries
            .iter()
            .map(|e| {
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
            })
            .collect();
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

        let axes: Vec<Axis> = Axis::ALL
            .into_iter()
            .filter(|a| {
                self.entries
                    .iter()
                    .any(|e| e.sensitivity.iter().any(|s| s.axis == *a))
            })
            .collect();
        out += &format!(
            "\nSensitivity at the base machine: change of the total for +10 % of one limit, in s\n\
             (central difference (T(1.1 L) - T(L/1.1)) / 2; negative = raising the limit saves time;\n \
             \"no effect (LO–HI)\": every value of the limit evaluated from LO to HI, the others at the base machine,\n \
             gives the same total within {TIE_TOLERANCE:e} (relative))\n"
        );
        let mut header = vec!["plan".to_string(), "schedule".to_string()];
        header.extend(axes.iter().map(|a| {
            let base = self
                .entries
                .iter()
                .flat_map(|e| &e.sensitivity)
                .find(|s| s.axis == *a)
                .map(|s| s.base_value);
            format!("{} (base {})", a.symbol().0, base.map_or("-".into(), short))
        }));
        let rows: Vec<Vec<String>> = self
            .entries
            .iter()
            .map(|e| {
                let mut r = vec![e.plan.clone(), e.schedule.name()];
                r.extend(axes.iter().map(|a| {
                    e.sensitivity
                        .iter()
                        .find(|s| s.axis == *a)
                        .map_or("-".into(), |s| {
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
                }));
                r
            })
            .collect();
        let header_refs: Vec<&str> = header.iter().map(String::as_str).collect();
        out += &table(&header_refs, &[true, true], &rows);

        out += &format!(
            "\nCheapest change reaching the target ({}): smallest Σ |ln(new/base)| over the changed limits\n\
             (costs within {TIE_TOLERANCE:e} tie; a tie goes to the shorter total, then as the fastest setting's)\n",
            match self.target {
                Target::TotalS(t) => format!("total <= {} s", short(t)),
                Target::SavingPercent(p) => format!("{} % saving", short(p)),
            }
        );
        let rows: Vec<Vec<String>> = self
            .entries
            .iter()
            .map(|e| match &e.cheapest {
                Some(c) => vec![
                    e.plan.clone(),
                    e.schedule.name(),
                    opt(e.target_total_s, 1),
                    describe_steps(&c.steps),
                    format!("{:.1}", c.total_s),
                    format!("{:.1}", c.saving_s),
                ],
                None => vec![
                    e.plan.clone(),
                    e.schedule.name(),
                    opt(e.target_total_s, 1),
                    "not reached by any evaluated setting".into(),
                    "-".into(),
                    "-".into(),
                ],
            })
            .collect();
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

        if self.entries.iter().any(|e| !e.profiles.is_empty()) {
            out += "\nTime at each value of one limit, the others at the base machine\n";
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
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_axes_are_profiled_at_spread_positions() {
        assert_eq!(profile_positions(5).collect::<Vec<_>>(), [0, 1, 2, 3, 4]);
        let n = PROFILE_MAX_POINTS;
        assert!(profile_positions(n).eq(0..n));
        for n in [n + 1, 3 * n + 7, 10_000_000, usize::MAX] {
            let p: Vec<usize> = profile_positions(n).collect();
            assert_eq!(p.len(), PROFILE_MAX_POINTS);
            assert_eq!((p[0], p[p.len() - 1]), (0, n - 1));
            assert!(p.windows(2).all(|w| w[0] < w[1]), "{n}");
        }
    }
}

#[cfg(test)]
mod tie_tests {
    use std::path::Path;

    use super::*;
    use crate::Sweep;

    /// Prostate on the ATOM machine (J 0.5, A 0.5, V 5), V swept over 3, 5, 6.
    fn evaluator() -> Evaluator {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios");
        let text = r#"{"format": "arcsim-sweep/1", "name": "t",
            "plans": ["../plans/prostate.json"], "machine": "machine-atom.json",
            "axes": {"speed_deg_per_s": [3, 5, 6]}, "schedules": ["scan"]}"#;
        let sweep = Sweep::from_text(text, "t.json", &dir, &|p: &Path| {
            arcsim_plan::load_plan(p).map_err(|e| e.to_string())
        })
        .expect("sweep");
        Evaluator::new(sweep).expect("prepare")
    }

    fn point(index: Option<usize>, jav: [f64; 3], total_s: f64) -> Point {
        Point {
            index,
            setting: Setting {
                jerk_deg_per_s3: jav[0],
                accel_deg_per_s2: jav[1],
                speed_deg_per_s: jav[2],
                elst_up_s: None,
                elst_down_s: None,
                window_deg: None,
                scan_speed_mm_per_s: None,
                dose_rate_scale: None,
            },
            total_s,
            speedup: None,
        }
    }

    /// Every order of `points` (up to 4) picks the same point, `want`.
    fn same_in_every_order(
        points: &[Point],
        pick: impl Fn(&[Point]) -> Option<Point>,
        want: Point,
    ) {
        let n = points.len();
        let mut order: Vec<usize> = (0..n).collect();
        // Heap's algorithm, iteratively.
        let mut c = vec![0; n];
        let mut i = 0;
        let check = |order: &[usize]| {
            let p: Vec<Point> = order.iter().map(|&k| points[k]).collect();
            assert_eq!(pick(&p), Some(want), "{p:?}");
        };
        check(&order);
        while i < n {
            if c[i] < i {
                order.swap(if i % 2 == 0 { 0 } else { c[i] }, i);
                check(&order);
                c[i] += 1;
                i = 0;
            } else {
                c[i] = 0;
                i += 1;
            }
        }
    }

    #[test]
    fn ties_go_to_the_setting_closest_to_the_base_machine() {
        let ev = evaluator();
        let fastest = |p: &[Point]| ev.fastest(p);
        let (v3, v5, v6) = (
            point(Some(0), [0.5, 0.5, 3.0], 100.0),
            point(Some(1), [0.5, 0.5, 5.0], 100.0 * (1.0 + 1e-12)),
            point(Some(2), [0.5, 0.5, 6.0], 100.0),
        );
        // Equal to the tolerance: the base machine, whatever the order.
        same_in_every_order(&[v3, v5, v6], fastest, v5);
        // Without it: the smaller change, |ln(6/5)| < |ln(3/5)|.
        same_in_every_order(&[v3, v6], fastest, v6);
        // A real difference is not a tie: 2e-9 (relative) faster beats the base machine.
        let v3_faster = Point {
            total_s: 100.0 * (1.0 - 2e-9),
            ..v3
        };
        same_in_every_order(&[v3_faster, v5, v6], fastest, v3_faster);
        // One limit changed beats two, even by a smaller ratio.
        let j_and_a = point(Some(3), [0.55, 0.55, 5.0], 100.0);
        let j_only = point(Some(4), [4.0, 0.5, 5.0], 100.0);
        same_in_every_order(&[j_and_a, j_only], fastest, j_only);
        // The same change on two limits: the lower values in axis order (J kept at 0.5).
        let j1 = point(Some(5), [1.0, 0.5, 5.0], 100.0);
        let a1 = point(Some(6), [0.5, 1.0, 5.0], 100.0);
        same_in_every_order(&[j1, a1], fastest, a1);
        // The same setting as a grid row and as a computed point: the grid row.
        let computed = Point { index: None, ..v6 };
        same_in_every_order(&[computed, v6, v3], fastest, v6);

        // The cheapest change: equal costs and totals tie alike; a shorter total wins.
        let base = 120.0;
        let cheapest = |p: &[Point]| {
            ev.cheapest(p, 110.0, base)
                .map(|c| point(c.index, [0.0; 3], c.total_s))
        };
        let picked = |p: Point| point(p.index, [0.0; 3], p.total_s);
        same_in_every_order(&[j1, a1], cheapest, picked(a1));
        let a1_close = Point {
            total_s: 100.0 * (1.0 + 1e-12),
            ..a1
        };
        same_in_every_order(&[j1, a1_close], cheapest, picked(a1_close));
        let j1_shorter = Point {
            total_s: 99.0,
            ..j1
        };
        same_in_every_order(&[j1_shorter, a1], cheapest, picked(j1_shorter));
        let c = ev.cheapest(&[a1], 110.0, base).expect("reached");
        assert_eq!(c.steps.len(), 1);
        assert_eq!(
            (c.steps[0].axis, c.steps[0].from, c.steps[0].to),
            (Axis::Accel, 0.5, 1.0)
        );
    }
}
