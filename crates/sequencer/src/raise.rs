//! What limits a transition: the gantry limit whose raise shortens it most.
//!
//! The question behind the label is "what would a faster gantry buy". Each transition is re-planned
//! exactly (same gap, boundary speeds and ELST floor) with one limit at a time raised by
//! [`LIMIT_RAISE_FACTOR`]: J alone, A and D together, or V alone. The label is the limit whose raise
//! shortens the move most. A transition that no raise shortens lasts its ELST ([`Limiter::Elst`]),
//! or does not move at all ([`Limiter::None`]). A saving counts from 1e-9 s; equal savings go to J,
//! then A, then V.

use arcsim_planner::{Limits, Move, MoveAnalysis, Reversal};

use crate::types::Limiter;

/// The factor each limit is raised by, one at a time, to find what limits a transition.
pub const LIMIT_RAISE_FACTOR: f64 = 2.0;

/// Savings below this (s) count as none.
const SAVING_TOL_S: f64 = 1e-9;

/// `lim` with one gantry limit raised by `factor`: [`Limiter::Jerk`] raises J,
/// [`Limiter::Accel`] raises A and D together, [`Limiter::Speed`] raises V; any other label gives
/// `lim` unchanged.
pub fn raised_limits(lim: &Limits, which: Limiter, factor: f64) -> Limits {
    let mut out = *lim;
    match which {
        Limiter::Jerk => out.max_jerk *= factor,
        Limiter::Accel => {
            out.max_accel *= factor;
            out.max_decel *= factor;
        }
        Limiter::Speed => out.max_vel *= factor,
        Limiter::Elst | Limiter::None => {}
    }
    out
}

/// The gantry limits in the order ties are broken.
pub(crate) const GANTRY_LIMITS: [Limiter; 3] = [Limiter::Jerk, Limiter::Accel, Limiter::Speed];

/// Duration of the shortest move `mv` (no reversal) lasting at least `elst` under `lim`, as the
/// constant-speed sequencer times it (before any servo rounding); `None` if it has none.
pub fn move_duration(mv: &Move, elst: f64, lim: &Limits) -> Option<f64> {
    let analysis = MoveAnalysis::new(mv, lim, Reversal::Forbid).ok()?;
    timed(&analysis).at_least(elst)
}

/// An analysed move's minimum time, to be floored by an ELST.
pub(crate) struct Timed<'a> {
    analysis: &'a MoveAnalysis,
    /// The duration of the time-optimal move (s).
    pub min_time: f64,
}

/// The minimum time of an analysed move.
pub(crate) fn timed(analysis: &MoveAnalysis) -> Timed<'_> {
    Timed {
        analysis,
        min_time: analysis.min_time_phases().duration(),
    }
}

impl Timed<'_> {
    /// The shortest duration lasting at least `elst`: the minimum time when it already does;
    /// `None` when no duration of the move lasts it.
    pub(crate) fn at_least(&self, elst: f64) -> Option<f64> {
        if elst > self.min_time {
            self.analysis.shortest_duration_at_least(elst)
        } else {
            Some(self.min_time)
        }
    }
}

/// The label of a transition from its duration under `lim` (`base`) and the duration `under`
/// gives with each gantry limit raised by [`LIMIT_RAISE_FACTOR`] (`None`: that re-plan failed,
/// counted as no saving).
pub(crate) fn label_by_raise(
    base: f64,
    elst: f64,
    lim: &Limits,
    mut under: impl FnMut(&Limits) -> Option<f64>,
) -> Limiter {
    let mut best = (Limiter::None, SAVING_TOL_S);
    for which in GANTRY_LIMITS {
        let raised = raised_limits(lim, which, LIMIT_RAISE_FACTOR);
        if let Some(d) = under(&raised) {
            let saving = base - d;
            if saving > best.1 {
                best = (which, saving);
            }
        }
    }
    match best.0 {
        Limiter::None if base > 0.0 && elst > 0.0 => Limiter::Elst,
        l => l,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What limits the move `mv` lasting at least `elst` under `lim`: the gantry limit whose raise
    /// shortens it most (see the module documentation).
    fn limiter_by_raise(mv: &Move, elst: f64, lim: &Limits) -> Limiter {
        match move_duration(mv, elst, lim) {
            Some(base) if base > 0.0 => {
                label_by_raise(base, elst, lim, |l| move_duration(mv, elst, l))
            }
            _ => Limiter::None,
        }
    }

    fn atom() -> Limits {
        Limits::new(0.5, 0.5, 5.0).unwrap()
    }

    fn saving(mv: &Move, elst: f64, lim: &Limits, which: Limiter) -> f64 {
        let base = move_duration(mv, elst, lim).unwrap();
        base - move_duration(mv, elst, &raised_limits(lim, which, LIMIT_RAISE_FACTOR)).unwrap()
    }

    /// For every move of a grid, the labelled limit's raise saves at least as much as any other.
    #[test]
    fn label_is_the_limit_whose_raise_saves_most() {
        let lim = atom();
        let mut labelled = std::collections::HashMap::new();
        for &distance in &[0.0, 0.05, 0.4, 1.0, 2.0, 5.0, 20.0, 60.0, 180.0] {
            for &(v_start, v_end) in &[(0.0, 0.0), (0.5, 0.5), (1.0, 0.2), (0.1, 2.0), (4.0, 4.0)] {
                for &elst in &[0.0, 0.5, 5.0] {
                    let mv = Move {
                        distance,
                        v_start,
                        v_end,
                    };
                    let Some(base) = move_duration(&mv, elst, &lim) else {
                        continue;
                    };
                    let label = limiter_by_raise(&mv, elst, &lim);
                    *labelled.entry(label).or_insert(0usize) += 1;
                    let savings: Vec<f64> = GANTRY_LIMITS
                        .iter()
                        .map(|&w| saving(&mv, elst, &lim, w))
                        .collect();
                    let best = savings.iter().copied().fold(0.0f64, f64::max);
                    match label {
                        Limiter::Jerk | Limiter::Accel | Limiter::Speed => {
                            let own = saving(&mv, elst, &lim, label);
                            assert!(own > 0.0, "{mv:?} elst {elst}: {label:?} saves {own}");
                            assert!(
                                own >= best - 1e-12,
                                "{mv:?} elst {elst}: {label:?} saves {own}, best {best}"
                            );
                        }
                        Limiter::Elst => {
                            assert!(best <= 1e-9, "{mv:?}: ELST-bound yet a raise saves {best}");
                            assert!(elst > 0.0 && base >= elst - 1e-9);
                        }
                        Limiter::None => assert!(base <= 0.0 || elst <= 0.0 && best <= 1e-9),
                    }
                }
            }
        }
        // The grid exercises every gantry label and the ELST.
        for l in [Limiter::Jerk, Limiter::Accel, Limiter::Speed, Limiter::Elst] {
            assert!(labelled.contains_key(&l), "no {l:?} in {labelled:?}");
        }
    }

    /// A move that reaches A but spends most of its time in jerk ramps is J-bound: rest to rest
    /// over 1.2° on the ATOM gantry reaches A = 0.5 °/s² (its peak acceleration) for a short
    /// plateau, and doubling J saves far more than doubling A.
    #[test]
    fn move_reaching_a_mostly_in_jerk_ramps_is_jerk_bound() {
        let lim = atom();
        let mv = Move {
            distance: 1.2,
            v_start: 0.0,
            v_end: 0.0,
        };
        let shape = MoveAnalysis::new(&mv, &lim, Reversal::Forbid)
            .unwrap()
            .min_time_phases();
        assert!(shape.t2 > 0.0, "the move reaches A: {shape:?}");
        let (j, a) = (
            saving(&mv, 0.0, &lim, Limiter::Jerk),
            saving(&mv, 0.0, &lim, Limiter::Accel),
        );
        assert!(j > a, "J saves {j}, A {a}");
        assert_eq!(limiter_by_raise(&mv, 0.0, &lim), Limiter::Jerk);
    }
}
