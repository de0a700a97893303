//! The jerk limit from the transitions themselves, by the model: the J whose simulated moves
//! between layers last as long as the logged beam-off gaps. Under a constant-speed controller
//! every move starts and ends at zero acceleration and the beam-on dwells sit between the
//! acceleration's turns, so the trace's reversals (the free-motion estimate) read the dwell as a
//! slow jerk; the planner's own moves do not share that blind spot.

use arcsim_plan::Machine;
use arcsim_sequencer::{simulate, Options};
use rayon::prelude::*;

use crate::calibrate::LoggedRun;
use crate::matching::LoggedLayer;

/// A gap differing from its simulation by more than this counts as this much (s): a gating
/// pause or an interruption must not pull the fit.
const ROBUST_CAP_S: f64 = 0.3;

/// Golden-section steps over ln J (a factor 16 narrowed to 1e-4 relative).
const STEPS: usize = 30;

/// The fitted jerk: its value, 95 % interval and the transitions behind it.
pub(crate) struct JerkFit {
    pub value: f64,
    pub interval: [f64; 2],
    pub transitions: usize,
}

/// Robust sum of squares of (logged − simulated) beam-off gaps over every transition of every
/// run, with `machine`'s jerk set to `jerk`; `None` if a simulation fails.
fn misfit(
    machine: &Machine,
    jerk: f64,
    runs: &[LoggedRun],
    logged: &[&[LoggedLayer]],
    opts: &Options,
) -> Option<(f64, usize)> {
    let mut m = machine.clone();
    m.gantry.max_jerk_deg_per_s3 = jerk;
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
                if a.arc != b.arc {
                    continue;
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

/// The J in [`start`/4, 4 `start`] that makes the simulated transitions last as logged (golden
/// section over ln J), with a 95 % interval from the misfit's curvature; `None` when there are
/// fewer than 3 transitions or the misfit does not depend on J (no transition is J-limited).
pub(crate) fn fit_jerk(
    machine: &Machine,
    start: f64,
    runs: &[LoggedRun],
    logged: &[&[LoggedLayer]],
    options: &Options,
) -> Option<JerkFit> {
    let opts = Options {
        build_timeline: false,
        ..options.clone()
    };
    let (lo_j, hi_j) = arcsim_plan::JERK_RANGE_DEG_PER_S3;
    let f = |x: f64| misfit(machine, x.exp().clamp(lo_j, hi_j), runs, logged, &opts);
    let phi = 0.5 * (5f64.sqrt() - 1.0);
    let (mut a, mut b) = ((start / 4.0).ln(), (start * 4.0).ln());
    let mut c = b - phi * (b - a);
    let mut d = a + phi * (b - a);
    let (mut fc, mut fd) = (f(c)?.0, f(d)?.0);
    for _ in 0..STEPS {
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
    // f ≈ f0 + curvature/2 (ln J − x)², residual variance f0 / (n − 1): one standard deviation
    // of ln J where f has risen by that variance (twice, for the 1/2).
    let var = (f0 / (n as f64 - 1.0)).max(1e-12);
    let sd = (2.0 * var / curvature).sqrt();
    Some(JerkFit {
        value: x.exp(),
        interval: [(x - 1.96 * sd).exp(), (x + 1.96 * sd).exp()],
        transitions: n,
    })
}
