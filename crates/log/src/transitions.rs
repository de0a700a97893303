//! Machine values from the transitions themselves, by the model: the value whose simulated
//! beam-off gaps last as long as the logged ones. Under a constant-speed controller every move
//! starts and ends at zero acceleration and the beam-on dwells sit between the acceleration's
//! turns, so the trace's reversals (the free-motion estimate) read the dwell as a slow jerk; and
//! its schedule stretches most moves to their switch's ELST, so few gaps show the ELST alone.
//! The planner's own moves and schedule, simulated at each candidate value, share neither blind
//! spot: the jerk limit from every gap, each ELST from the gaps of its kind.

use arcsim_plan::Machine;
use arcsim_sequencer::{simulate, Delivery, Options};
use rayon::prelude::*;

use crate::calibrate::LoggedRun;
use crate::compare::switch_class;
use crate::matching::LoggedLayer;

/// A gap differing from its simulation by more than this counts as this much (s): a gating
/// pause or an interruption must not pull the fit.
pub(crate) const ROBUST_CAP_S: f64 = 0.3;

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

/// The (logged, simulated) beam-off gaps (s) over the transitions of `which` of every run,
/// `machine` changed by `set(value)`, in a fixed order; `None` if a simulation fails.
pub(crate) fn gap_pairs(
    machine: &Machine,
    set: &dyn Fn(&mut Machine, f64),
    value: f64,
    (runs, logged): (&[LoggedRun], &[&[LoggedLayer]]),
    which: Switches,
    opts: &Options,
) -> Option<Vec<(f64, f64)>> {
    let mut m = machine.clone();
    set(&mut m, value);
    Some(pairs_of_runs(
        &simulate_runs(&m, runs, opts)?,
        logged,
        which,
    ))
}

/// `machine`'s simulation of every run under `opts` (`None` if one fails).
pub(crate) fn simulate_runs(
    machine: &Machine,
    runs: &[LoggedRun],
    opts: &Options,
) -> Option<Vec<Delivery>> {
    runs.par_iter()
        .map(|r| simulate(&r.plan, machine, opts).ok())
        .collect()
}

/// The (logged, simulated) gaps of `which` of every run, its simulation `simulated`, in order.
fn pairs_of_runs(
    simulated: &[Delivery],
    logged: &[&[LoggedLayer]],
    which: Switches,
) -> Vec<(f64, f64)> {
    simulated
        .iter()
        .zip(logged)
        .flat_map(|(d, layers)| pairs_of(d, layers, which))
        .collect()
}

/// The (logged, simulated) gaps of `which` between a run's logged layers and a simulation of
/// its plan, in order (switches between arcs and after a layer the log ends early left out).
pub(crate) fn pairs_of(d: &Delivery, layers: &[LoggedLayer], which: Switches) -> Vec<(f64, f64)> {
    let mut pairs = Vec::new();
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
        pairs.push((pair[1].start_s - pair[0].end_s, b.t_start_s - a.t_end_s));
    }
    pairs
}

/// Robust sum of squares of (logged − simulated) gaps, and how many.
pub(crate) fn misfit_of(pairs: &[(f64, f64)]) -> (f64, usize) {
    let ss = pairs
        .iter()
        .map(|(l, s)| (l - s).abs().min(ROBUST_CAP_S).powi(2))
        .sum();
    (ss, pairs.len())
}

/// The robust rms (s) of (logged − simulated) beam-off gaps of `which` between each run's logged
/// layers and its simulation `simulated`, and how many gaps.
pub(crate) fn rms_of(
    simulated: &[Delivery],
    logged: &[&[LoggedLayer]],
    which: Switches,
) -> (f64, usize) {
    rms_of_pairs(&pairs_of_runs(simulated, logged, which))
}

/// The robust rms (s) of (logged − simulated) gaps, and how many.
fn rms_of_pairs(pairs: &[(f64, f64)]) -> (f64, usize) {
    let (ss, n) = misfit_of(pairs);
    ((ss / n.max(1) as f64).sqrt(), n)
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
    gap_pairs(machine, set, value, data, which, &opts).map(|p| rms_of_pairs(&p))
}

/// The value in [`start` / `span`, `span` × `start`] (clamped to `range`) that makes the
/// simulated gaps of `which` last as logged (golden section over its logarithm, to a bracket of
/// `log_tolerance`), with a 95 % interval from the sandwich over the gaps it moves
/// ([`sandwich_sd`]); `None` when fewer than 3 gaps of `which` move with it, or when the misfit
/// does not curve up on both sides of it (no gap of `which` bound by it, or the value pinned at
/// the end of its bracket).
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
    let at = |x: f64| {
        gap_pairs(
            machine,
            set,
            x.exp().clamp(range.0, range.1),
            data,
            which,
            &opts,
        )
    };
    let f = |x: f64| at(x).map(|p| misfit_of(&p));
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
    // One simulation of each run at a time, its runs in parallel (`set` need not be `Sync`).
    let (centre, plus, minus) = (at(x)?, at(x + H)?, at(x - H)?);
    // A value the gaps do not bind, or one pinned at the bracket's end, is no minimum: the
    // misfit must curve up on both sides.
    let (f0, fp, fm) = (
        misfit_of(&centre).0,
        misfit_of(&plus).0,
        misfit_of(&minus).0,
    );
    if fp + fm - 2.0 * f0 <= 0.0 || (fp - f0).abs() + (fm - f0).abs() < 1e-12 {
        return None;
    }
    let sd = sandwich_sd(&centre, &plus, &minus)?;
    Some(GapFit {
        value: x.exp().clamp(range.0, range.1),
        interval: [
            (x - sd.t95 * sd.sd).exp().clamp(range.0, range.1),
            (x + sd.t95 * sd.sd).exp().clamp(range.0, range.1),
        ],
        transitions: sd.moved,
    })
}

/// The step (in the logarithm) of the central differences behind each gap's sensitivity.
pub(crate) const H: f64 = 0.02;

/// The spread of a fitted logarithm: its standard deviation, the 95 % two-sided Student
/// quantile for its degrees of freedom, and how many gaps the value moves.
struct Spread {
    sd: f64,
    t95: f64,
    moved: usize,
}

/// The standard deviation of a fitted logarithm θ from each gap's residual rᵢ at θ and its
/// sensitivity gᵢ = ∂simᵢ/∂θ (central difference over ±[`H`]): the sandwich
/// √(Σ gᵢ² rᵢ²) / Σ gᵢ², scaled by n/(n−1) for the n gaps θ moves. Unlike a misfit's curvature
/// with one residual variance over all gaps, it weighs only the gaps the value binds (the
/// others, gantry-bound, have rᵢ near the log's resolution and would shrink the variance) and
/// lets their noise differ. `None` when fewer than 3 gaps move with θ. Gaps beyond the robust
/// cap do not pull the fit and are left out.
fn sandwich_sd(centre: &[(f64, f64)], plus: &[(f64, f64)], minus: &[(f64, f64)]) -> Option<Spread> {
    if centre.len() != plus.len() || centre.len() != minus.len() {
        return None;
    }
    let terms: Vec<(f64, f64)> = centre
        .iter()
        .zip(plus.iter().zip(minus))
        .map(|((l, s), ((_, sp), (_, sm)))| (l - s, (sp - sm) / (2.0 * H)))
        .filter(|(r, _)| r.abs() < ROBUST_CAP_S)
        .collect();
    let g_max = terms.iter().map(|(_, g)| g.abs()).fold(0.0, f64::max);
    if g_max.is_nan() || g_max <= 1e-9 {
        return None;
    }
    let (s_gg, s_ggrr, n) = weighted_sums(
        terms
            .iter()
            .copied()
            .filter(|(_, g)| g.abs() > 1e-3 * g_max),
    );
    if n < 3 {
        return None;
    }
    let dof = n as f64 - 1.0;
    let sd = (s_ggrr * n as f64 / dof).sqrt() / s_gg;
    Some(Spread {
        sd: sd.max(1e-9),
        t95: student_t95(dof),
        moved: n,
    })
}

/// Σ gᵢ², Σ gᵢ² rᵢ² and n over the (rᵢ, gᵢ) given: the sums behind the sandwich of a value
/// that moves those gaps by gᵢ, √(Σ gᵢ² rᵢ²) / Σ gᵢ² (a weighted mean's).
fn weighted_sums(terms: impl Iterator<Item = (f64, f64)>) -> (f64, f64, usize) {
    terms.fold((0.0, 0.0, 0), |(s_gg, s_ggrr, n), (r, g)| {
        (s_gg + g * g, s_ggrr + g * g * r * r, n + 1)
    })
}

/// The 97.5 % quantile of Student's t with `dof` degrees of freedom (Cornish–Fisher expansion
/// about the normal's 1.96; within 1 % of the tables from 4 degrees of freedom, and on the wide
/// side below).
pub(crate) fn student_t95(dof: f64) -> f64 {
    const Z: f64 = 1.959_963_984_540_054;
    let nu = dof.max(1.0);
    let z3 = Z.powi(3);
    let z5 = Z.powi(5);
    let z7 = Z.powi(7);
    Z + (z3 + Z) / (4.0 * nu)
        + (5.0 * z5 + 16.0 * z3 + 3.0 * Z) / (96.0 * nu * nu)
        + (3.0 * z7 + 19.0 * z5 + 17.0 * z3 - 15.0 * Z) / (384.0 * nu.powi(3))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Student's t quantiles against the published table (e.g. NIST/SEMATECH e-Handbook,
    /// 1.3.6.7.2): 2.776 at 4, 2.228 at 10, 2.042 at 30, 1.984 at 100 degrees of freedom.
    #[test]
    fn student_quantiles_match_the_table() {
        for (dof, table) in [(4.0, 2.776), (10.0, 2.228), (30.0, 2.042), (100.0, 1.984)] {
            let t = student_t95(dof);
            assert!((t / table - 1.0).abs() < 0.01, "{dof}: {t} against {table}");
        }
        // Below 4 degrees of freedom the expansion errs on the wide side or close to it.
        assert!(student_t95(2.0) > 0.9 * 4.303);
    }

    /// The sandwich on a linear model with known noise: gaps g·θ + noise, the spread of θ is
    /// σ/√(Σg²) for equal noise, and gaps that θ does not move change nothing.
    #[test]
    fn the_sandwich_weighs_only_the_gaps_the_value_moves() {
        let sigma = 0.02;
        // Deterministic residuals of rms sigma (±sigma alternately).
        let bound: Vec<(f64, f64)> = (0..40)
            .map(|k| (if k % 2 == 0 { sigma } else { -sigma }, 0.7))
            .collect();
        let mk = |extra: usize| {
            let mut c = Vec::new();
            let mut p = Vec::new();
            let mut m = Vec::new();
            for &(r, g) in &bound {
                c.push((1.0 + r, 1.0));
                p.push((0.0, 1.0 + g * H));
                m.push((0.0, 1.0 - g * H));
            }
            for _ in 0..extra {
                c.push((2.0, 2.0));
                p.push((0.0, 2.0));
                m.push((0.0, 2.0));
            }
            sandwich_sd(&c, &p, &m).expect("spread")
        };
        let expected = sigma / (40.0_f64 * 0.49).sqrt() * (40.0_f64 / 39.0).sqrt();
        for extra in [0, 200] {
            let s = mk(extra);
            assert_eq!(s.moved, 40);
            assert!(
                (s.sd / expected - 1.0).abs() < 1e-9,
                "{} {}",
                s.sd,
                expected
            );
        }
    }
}
