//! Machine values from the transitions themselves, by the model: the value whose simulated
//! beam-off gaps last as long as the logged ones. Under a constant-speed controller every move
//! starts and ends at zero acceleration and the beam-on dwells sit between the acceleration's
//! turns, so the trace's reversals (the free-motion estimate) read the dwell as a slow jerk; and
//! its schedule stretches most moves to their switch's ELST, so few gaps show the ELST alone.
//! The planner's own moves and schedule, simulated at each candidate value, share neither blind
//! spot: the jerk limit from every gap, each ELST from the gaps of its kind.

use arcsim_plan::Machine;
use arcsim_sequencer::{simulate, Options};
use rayon::prelude::*;

use crate::calibrate::LoggedRun;
use crate::compare::switch_class;
use crate::matching::LoggedLayer;

/// A gap differing from its simulation by more than this counts as this much (s): a gating
/// pause or an interruption must not pull the fit.
const ROBUST_CAP_S: f64 = 0.3;

/// The golden section stops when its bracket over the logarithm is this narrow (the value known
/// to 1e-4 relative, far below any interval it is given with).
pub(crate) const LOG_TOLERANCE: f64 = 2e-4;

/// A value fitted by the model: its value, 95 % interval and the transitions behind it.
pub(crate) struct GapFit {
    pub value: f64,
    pub interval: [f64; 2],
    pub transitions: usize,
}

/// Which switches a fit compares: all, or one kind by the energy step.
#[derive(Clone, Copy, PartialEq)]
pub(crate) enum Switches {
    All,
    Kind(&'static str),
}

/// Robust sum of squares of (logged − simulated) beam-off gaps over the transitions of `which`
/// of every run, `machine` changed by `set(value)`; `None` if a simulation fails.
fn misfit(
    machine: &Machine,
    set: &dyn Fn(&mut Machine, f64),
    value: f64,
    (runs, logged): (&[LoggedRun], &[&[LoggedLayer]]),
    which: Switches,
    opts: &Options,
) -> Option<(f64, usize)> {
    let mut m = machine.clone();
    set(&mut m, value);
    let parts = runs
        .par_iter()
        .zip(logged)
        .map(|(r, layers)| {
            let d = simulate(&r.plan, &m, opts).ok()?;
            let mut ss = 0.0;
            let mut n = 0;
            for (k, pair) in layers.windows(2).enumerate() {
                let (Some(a), Some(b)) = (d.layers.get(k), d.layers.get(k + 1)) else {
                    continue;
                };
                if a.arc != b.arc || pair[0].ends_early {
                    continue;
                }
                if let Switches::Kind(kind) = which {
                    if switch_class(a.energy_mev, b.energy_mev) != kind {
                        continue;
                    }
                }
                let gap_logged = pair[1].start_s - pair[0].end_s;
                let gap_sim = b.t_start_s - a.t_end_s;
                let r = (gap_logged - gap_sim).abs().min(ROBUST_CAP_S);
                ss += r * r;
                n += 1;
            }
            Some((ss, n))
        })
        .collect::<Option<Vec<_>>>()?;
    Some(parts.iter().fold((0.0, 0), |(a, b), (x, y)| (a + x, b + y)))
}

/// The robust rms (s) of (logged − simulated) beam-off gaps of `which` with `machine` changed by
/// `set(value)`, and how many gaps; `None` if a simulation fails.
pub(crate) fn gap_rms(
    machine: &Machine,
    set: &dyn Fn(&mut Machine, f64),
    value: f64,
    data: (&[LoggedRun], &[&[LoggedLayer]]),
    which: Switches,
    options: &Options,
) -> Option<(f64, usize)> {
    let opts = Options {
        build_timeline: false,
        ..options.clone()
    };
    let (ss, n) = misfit(machine, set, value, data, which, &opts)?;
    Some(((ss / n.max(1) as f64).sqrt(), n))
}

/// The value in [`start` / `span`, `span` × `start`] (clamped to `range`) that makes the
/// simulated gaps of `which` last as logged (golden section over its logarithm, to a bracket of
/// `log_tolerance`), with a 95 % interval from the misfit's curvature; `None` with fewer than 3
/// such gaps or when the misfit does not depend on the value (no gap of `which` is bound by it).
pub(crate) fn fit_by_gaps(
    machine: &Machine,
    set: &dyn Fn(&mut Machine, f64),
    (start, span, range, log_tolerance): (f64, f64, (f64, f64), f64),
    data: (&[LoggedRun], &[&[LoggedLayer]]),
    which: Switches,
    options: &Options,
) -> Option<GapFit> {
    let opts = Options {
        build_timeline: false,
        ..options.clone()
    };
    let f = |x: f64| {
        misfit(
            machine,
            set,
            x.exp().clamp(range.0, range.1),
            data,
            which,
            &opts,
        )
    };
    let phi = 0.5 * (5f64.sqrt() - 1.0);
    let (mut a, mut b) = ((start / span).ln(), (start * span).ln());
    let mut c = b - phi * (b - a);
    let mut d = a + phi * (b - a);
    let (mut fc, mut fd) = (f(c)?.0, f(d)?.0);
    let steps = ((log_tolerance / (b - a)).ln() / phi.ln()).ceil().max(1.0) as usize;
    for _ in 0..steps {
        if fc <= fd {
            (b, d, fd) = (d, c, fc);
            c = b - phi * (b - a);
            fc = f(c)?.0;
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + phi * (b - a);
            fd = f(d)?.0;
        }
    }
    let x = 0.5 * (a + b);
    let (f0, n) = f(x)?;
    if n < 3 {
        return None;
    }
    let h = 0.02_f64;
    let (fp, fm) = (f(x + h)?.0, f(x - h)?.0);
    let curvature = (fp + fm - 2.0 * f0) / (h * h);
    if curvature <= 0.0 || (fp - f0).abs() + (fm - f0).abs() < 1e-12 {
        return None;
    }
    // f ≈ f0 + curvature/2 (ln x − x0)², residual variance f0 / (n − 1): one standard deviation
    // of ln x where f has risen by that variance (twice, for the 1/2).
    let var = (f0 / (n as f64 - 1.0)).max(1e-12);
    let sd = (2.0 * var / curvature).sqrt();
    Some(GapFit {
        value: x.exp().clamp(range.0, range.1),
        interval: [(x - 1.96 * sd).exp(), (x + 1.96 * sd).exp()],
        transitions: n,
    })
}
