//! Transitions on the machine's servo period.
//!
//! A trajectory generator sampled every Ts starts and ends each move on a servo tick, so a
//! transition lasts a whole number of periods: the shortest multiple of Ts, at least its
//! continuous duration, that the move can last (planner step 2, [`MoveAnalysis::durations`]). This
//! is Ruckig's discrete-duration mode; `arcsim profile --period` instead puts every phase on the
//! grid, which a move on a reachability bound cannot do at all. A transition with no
//! such duration (a move on a reachability bound has exactly one) makes the scan lower its
//! speeds a little ([`crate::SpeedBound::Servo`]).

use arcsim_planner::{DurationSet, Limits, Move, MoveAnalysis, Reversal};

/// The shortest whole multiple of `period` that is at least `duration` and that `mv` can last
/// with speed in [0, V]; `None` when there is none.
pub(crate) fn grid_duration(mv: Move, lim: &Limits, duration: f64, period: f64) -> Option<f64> {
    let analysis = MoveAnalysis::new(&mv, lim, Reversal::Forbid).ok()?;
    grid_duration_in(&analysis.durations(), duration, period)
}

/// [`grid_duration`] within an already computed set of feasible durations.
pub(crate) fn grid_duration_in(set: &DurationSet, duration: f64, period: f64) -> Option<f64> {
    set.intervals()
        .iter()
        .filter(|&&(_, hi)| hi * (1.0 + 1e-9) >= duration)
        .map(|&(lo, hi)| (ticks(lo.max(duration), period), hi))
        .find(|&(t, hi)| t <= hi * (1.0 + 1e-9))
        .map(|(t, _)| t)
}

/// `t` rounded up to a whole number of periods (an exact multiple, to 1e-9, stays).
pub(crate) fn ticks(t: f64, period: f64) -> f64 {
    (t / period - 1e-9).ceil().max(0.0) * period
}
