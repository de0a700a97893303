//! Which point a summary picks: the fastest row, the cheapest change reaching the target, and
//! the tie-break between them (the setting closest to the base machine); see the summary's doc.

use std::cmp::Ordering;

use super::{Change, Point, Step};
use crate::run::Evaluator;
use crate::sweep::{Axis, Setting};

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
pub(super) fn total_slack(min: f64) -> f64 {
    TIE_TOLERANCE * min.abs()
}

impl Evaluator {
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

    /// The cheapest change reaching `target` among `candidates` (see the module doc), or none
    /// when the base machine reaches it already; `None` when no candidate reaches it.
    pub(super) fn cheapest(
        &self,
        candidates: &[Point],
        target: f64,
        base_total: f64,
    ) -> Option<Change> {
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
                burst_switching_time_s: None,
                spill_charge_mu: None,
                spill_refill_time_s: None,
                spill_max_layers: None,
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
