//! The `scanning` beam model fitted to per-spot logs: each spot's irradiation time on its MU
//! (the time per MU and the minimum spot time), each move between two spots of one pass on its
//! distance (the scanning speed and the settling time), each pause between two passes (the
//! burst switching time).

use arcsim_plan::{ArcPlan, BeamModel, Machine, ScanningBeam};
use serde::Serialize;
use thiserror::Error;

use super::moves::{fit_moves, fit_passes, residual, warn_of_residuals};
use super::read::{LoggedSpot, SpotLog};
use crate::calibrate::{mad_sd, median, FittedValue};

/// The median of `v` (not reordered).
pub(super) fn med(v: &[f64]) -> f64 {
    median(&mut v.to_vec())
}

/// The robust standard deviation of `v` about its median (1.4826 × the median absolute
/// deviation).
pub(super) fn spread(v: &[f64]) -> f64 {
    mad_sd(v, med(v))
}
use crate::transitions::student_t95;

/// Why a spot-level calibration cannot be made.
#[derive(Debug, Error)]
pub enum SpotCalibrateError {
    /// The base machine's beam is not the `scanning` model.
    #[error("the base machine's beam is `{kind}`; the spot-level fit is of the `scanning` model (its time per MU and between spots come from `calibrate`'s fit of each layer's beam-on time)")]
    NotScanning {
        /// The base's beam kind.
        kind: String,
    },
    /// A logged spot names no layer of its plan.
    #[error("{log}: line {line}: arc {arc}, control point {control_point}, layer {layer} is not a layer of the plan {plan}")]
    NoSuchLayer {
        /// The log.
        log: String,
        /// The plan.
        plan: String,
        /// The log's line.
        line: u64,
        /// The indices the spot names.
        arc: usize,
        /// The control point.
        control_point: usize,
        /// The layer.
        layer: usize,
    },
    /// Too few spots or moves to fit anything.
    #[error("{0}")]
    TooFew(String),
}

/// One plan and its per-spot log.
#[derive(Debug, Clone)]
pub struct SpotRun {
    /// The plan's name, as the user gave it.
    pub plan_name: String,
    /// The plan (for each layer's energy).
    pub plan: ArcPlan,
    /// Its per-spot log.
    pub log: SpotLog,
}

/// How well the fitted model times one log's layers.
#[derive(Debug, Clone, Serialize)]
pub struct SpotResidual {
    /// The log.
    pub log: String,
    /// Layers in the log.
    pub layers: usize,
    /// Sum over the layers of (first spot start to last spot end), as logged, s.
    pub logged_s: f64,
    /// The same under the base machine's model, each layer's logged spots in their logged order.
    pub base_s: f64,
    /// The same under the fitted model.
    pub fitted_s: f64,
    /// (fitted − logged) / logged, percent.
    pub fitted_error_pct: f64,
    /// (base − logged) / logged, percent.
    pub base_error_pct: f64,
}

/// A machine with its `scanning` beam fitted to per-spot logs.
#[derive(Debug, Clone, Serialize)]
pub struct SpotCalibration {
    /// The base machine with the fitted values in its beam model.
    #[serde(skip)]
    pub machine: Machine,
    /// Every value considered: fitted (with a 95 % interval) or kept, and how.
    pub values: Vec<FittedValue>,
    /// The time resolution read from the logs' clocks, s (0 when finer than 1 µs).
    pub clock_resolution_s: f64,
    /// Moves (and pauses) left out as outliers: further from the fit than 6 robust standard
    /// deviations plus the clock's resolution.
    pub outliers_rejected: usize,
    /// Each log's layers timed under the base and the fitted model.
    pub residuals: Vec<SpotResidual>,
    /// What the user should know (a residual above the noise, a distance rule the gaps
    /// contradict).
    pub warnings: Vec<String>,
}

/// One move between two consecutive spot deliveries of a layer.
#[derive(Clone, Copy, Debug)]
pub(super) struct Move {
    pub gap_s: f64,
    pub dx: f64,
    pub dy: f64,
    /// The two spots are of different passes (a new burst on a beam in bursts).
    pub new_pass: bool,
}

/// One spot delivery with its base-predicted irradiation time.
#[derive(Clone, Copy, Debug)]
struct Spot {
    duration_s: f64,
    /// MU × the base's time per MU at the layer's energy, s.
    base_irradiation_s: f64,
}

/// The logged spots of one layer, in order.
pub(crate) struct Layer<'a> {
    pub spots: &'a [LoggedSpot],
    pub energy_mev: f64,
}

/// Fits the base machine's `scanning` beam to the per-spot logs of `runs` (see the module
/// documentation); everything else is the base's.
pub fn calibrate_spots(
    base: &Machine,
    runs: &[SpotRun],
) -> Result<SpotCalibration, SpotCalibrateError> {
    let beam = match &base.beam {
        BeamModel::Scanning(b) => b,
        other => {
            return Err(SpotCalibrateError::NotScanning {
                kind: other.kind().to_string(),
            })
        }
    };
    let mut layers_of_runs = Vec::new();
    for run in runs {
        layers_of_runs.push(layers(run)?);
    }
    let all: Vec<&Layer> = layers_of_runs.iter().flatten().collect();
    let (spots, moves) = observations(beam, &all);
    let clock = clock_resolution(runs);
    let mut values = Vec::new();
    let mut fitted = beam.clone();
    fit_irradiation(beam, &spots, clock, &mut fitted, &mut values)?;
    let mut outliers = 0;
    let mut warnings = Vec::new();
    fit_moves(
        beam,
        &moves,
        clock,
        &mut fitted,
        &mut values,
        (&mut outliers, &mut warnings),
    )?;
    fit_passes(beam, &moves, clock, &mut fitted, &mut values, &mut outliers);
    super::spills::fit_spills(beam, &all, clock, &mut fitted, &mut values, &mut outliers);
    values.push(kept_value(
        "beam.layer_overhead_s",
        "s",
        beam.layer_overhead_s,
        "not determined: a per-spot log holds no layer beam-on edge before its first spot; the base value is kept",
    ));
    let residuals: Vec<SpotResidual> = runs
        .iter()
        .zip(&layers_of_runs)
        .map(|(run, ls)| residual(&run.log.source, ls, beam, &fitted))
        .collect();
    warn_of_residuals(&residuals, clock, &mut warnings);
    let mut machine = base.clone();
    machine.beam = BeamModel::Scanning(fitted);
    machine.name = format!("{}-spot-calibrated", base.name);
    Ok(SpotCalibration {
        machine,
        values,
        clock_resolution_s: clock,
        outliers_rejected: outliers,
        residuals,
        warnings,
    })
}

/// The run's spots cut into layers (consecutive spots naming one plan layer), with energies.
fn layers(run: &SpotRun) -> Result<Vec<Layer<'_>>, SpotCalibrateError> {
    let spots = &run.log.spots;
    let mut out = Vec::new();
    let mut start = 0;
    for i in 1..=spots.len() {
        let same = |a: &LoggedSpot, b: &LoggedSpot| {
            (a.arc, a.control_point, a.layer) == (b.arc, b.control_point, b.layer)
        };
        if i < spots.len() && same(&spots[i], &spots[start]) {
            continue;
        }
        let s = &spots[start];
        let energy_mev = run
            .plan
            .arcs
            .get(s.arc)
            .and_then(|a| a.control_points.get(s.control_point))
            .and_then(|c| c.layers.get(s.layer))
            .map(|l| l.energy_mev)
            .ok_or_else(|| SpotCalibrateError::NoSuchLayer {
                log: run.log.source.clone(),
                plan: run.plan_name.clone(),
                line: s.line,
                arc: s.arc,
                control_point: s.control_point,
                layer: s.layer,
            })?;
        out.push(Layer {
            spots: &spots[start..i],
            energy_mev,
        });
        start = i;
    }
    Ok(out)
}

/// Every spot's irradiation and every move between two consecutive spots of a layer.
fn observations(beam: &ScanningBeam, layers: &[&Layer]) -> (Vec<Spot>, Vec<Move>) {
    let mut spots = Vec::new();
    let mut moves = Vec::new();
    for layer in layers {
        let rate = beam.s_per_mu_at(layer.energy_mev);
        for (k, s) in layer.spots.iter().enumerate() {
            spots.push(Spot {
                duration_s: s.t_end_s - s.t_start_s,
                base_irradiation_s: s.mu * rate,
            });
            // A refill is no move (fitted apart, [`super::spills`]).
            let prev = k.checked_sub(1).map(|j| &layer.spots[j]);
            if let Some(p) = prev.filter(|p| !super::spills::is_refill(beam, p, s)) {
                moves.push(Move {
                    gap_s: s.t_start_s - p.t_end_s,
                    dx: (s.x_mm - p.x_mm).abs(),
                    dy: (s.y_mm - p.y_mm).abs(),
                    new_pass: s.painting != p.painting,
                });
            }
        }
    }
    (spots, moves)
}

/// The logs' clock resolution: the longest time step a log's format states (an IBA-style log's
/// rows or elements), else the step every difference between two distinct logged times is a
/// whole multiple of (to 1 % of it), found as the mean of the differences within 1 % of the
/// smallest; 0 when there is none (a clock finer than the spots) or it is under 1 µs.
fn clock_resolution(runs: &[SpotRun]) -> f64 {
    if let Some(step) = runs
        .iter()
        .filter_map(|r| r.log.time_step_s)
        .reduce(f64::max)
    {
        return step;
    }
    let mut times: Vec<f64> = runs
        .iter()
        .flat_map(|r| r.log.spots.iter().flat_map(|s| [s.t_start_s, s.t_end_s]))
        .collect();
    times.sort_by(f64::total_cmp);
    let diffs: Vec<f64> = times
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 1e-9)
        .collect();
    let smallest = diffs.iter().copied().fold(f64::INFINITY, f64::min);
    if !smallest.is_finite() || smallest < 1e-6 {
        return 0.0;
    }
    let near: Vec<f64> = diffs
        .iter()
        .copied()
        .filter(|d| (d / smallest - 1.0).abs() < 0.01)
        .collect();
    let step = near.iter().sum::<f64>() / near.len() as f64;
    let whole = diffs.iter().all(|d| {
        let k = d / step;
        (k - k.round()).abs() < 0.01
    });
    if whole {
        // The step as the clock has it, not as the differences of rounded times average it.
        let digits = 10f64.powi(9 - step.log10().ceil() as i32);
        (step * digits).round() / digits
    } else {
        0.0
    }
}

/// A value kept from the base, with why.
pub(super) fn kept_value(field: &str, unit: &str, base: f64, note: &str) -> FittedValue {
    FittedValue {
        field: field.into(),
        unit: unit.into(),
        base: Some(base),
        value: base,
        interval: None,
        observations: 0,
        determined: false,
        note: note.into(),
    }
}

/// A fitted value.
pub(super) fn fitted_value(
    (field, unit, base): (&str, &str, f64),
    value: f64,
    interval: [f64; 2],
    n: usize,
    note: String,
) -> FittedValue {
    FittedValue {
        field: field.into(),
        unit: unit.into(),
        base: Some(base),
        value,
        interval: Some(interval),
        observations: n,
        determined: true,
        note,
    }
}

/// The time per MU (one factor on the base's table) and the minimum spot time. A spot is held
/// at the minimum when it lasts longer than its MU at the fitted rate by more than the noise
/// allows; the minimum is their median. The factor: least squares through the origin of the
/// other spots' durations on their MU at the base's rates.
fn fit_irradiation(
    base: &ScanningBeam,
    spots: &[Spot],
    clock: f64,
    fitted: &mut ScanningBeam,
    values: &mut Vec<FittedValue>,
) -> Result<(), SpotCalibrateError> {
    let heavy: Vec<f64> = {
        let mut x: Vec<f64> = spots.iter().map(|s| s.base_irradiation_s).collect();
        x.sort_by(f64::total_cmp);
        let cut = x.get(x.len() / 2).copied().unwrap_or(0.0);
        spots
            .iter()
            .filter(|s| s.base_irradiation_s >= cut && s.base_irradiation_s > 0.0)
            .map(|s| s.duration_s / s.base_irradiation_s)
            .collect()
    };
    if heavy.len() < 3 {
        return Err(SpotCalibrateError::TooFew(format!(
            "{} spots with MU in the logs; expected at least 6 to fit the time per MU",
            spots.len()
        )));
    }
    let k0 = med(&heavy);
    // Each duration is read to within one clock step; the spread of the heavy spots' ratios
    // bounds the rest of the noise.
    // (And a microsecond: a time printed to its last digit is still rounded.)
    let heavy_sd = spread(&heavy);
    let noise = |s: &Spot| 3.0 * heavy_sd * s.base_irradiation_s * k0 + 2.0 * clock + 1e-6;
    let floor: Vec<f64> = spots
        .iter()
        .filter(|s| s.duration_s > k0 * s.base_irradiation_s + noise(s))
        .map(|s| s.duration_s)
        .collect();
    // A spot that the minimum may hold (its MU at the rate not clearly above the minimum) says
    // nothing certain of the rate: only those clearly above it are fitted.
    let at_least = if floor.len() >= 3 { med(&floor) } else { 0.0 };
    let free: Vec<&Spot> = spots
        .iter()
        .filter(|s| s.duration_s <= k0 * s.base_irradiation_s + noise(s))
        .filter(|s| k0 * s.base_irradiation_s > at_least + noise(s))
        .collect();
    let (sxx, sxy) = free.iter().fold((0.0, 0.0), |(a, b), s| {
        (
            a + s.base_irradiation_s * s.base_irradiation_s,
            b + s.base_irradiation_s * s.duration_s,
        )
    });
    let k = sxy / sxx.max(f64::MIN_POSITIVE);
    let n = free.len();
    let rss: f64 = free
        .iter()
        .map(|s| (s.duration_s - k * s.base_irradiation_s).powi(2))
        .sum();
    let se = (rss / (n.saturating_sub(1).max(1)) as f64).sqrt() / sxx.sqrt();
    let t = student_t95(n.saturating_sub(1).max(1) as f64);
    for row in &mut fitted.s_per_mu_by_energy {
        row[1] *= k;
    }
    values.push(fitted_value(
        ("beam.s_per_mu_scale", "", 1.0),
        k,
        [k - t * se, k + t * se],
        n,
        format!("the factor on every time per MU of the base's table: least squares through the origin of the {n} spots' irradiation times on their MU at the base's rates (spots held at the minimum spot time left out)"),
    ));
    fit_floor(base, &floor, clock, fitted, values);
    Ok(())
}

/// The minimum spot time from the spots held at it.
fn fit_floor(
    base: &ScanningBeam,
    floor: &[f64],
    clock: f64,
    fitted: &mut ScanningBeam,
    values: &mut Vec<FittedValue>,
) {
    const FIELD: (&str, &str) = ("beam.min_spot_time_s", "s");
    if floor.len() < 3 {
        values.push(kept_value(FIELD.0, FIELD.1, base.min_spot_time_s, &format!("not determined: {} spots last longer than their MU at the fitted time per MU allows (fewer than 3 held at a minimum); the base value is kept", floor.len())));
        return;
    }
    let m = med(floor);
    let n = floor.len();
    let half = student_t95((n - 1) as f64) * 1.2533 * spread(floor) / (n as f64).sqrt() + clock;
    fitted.min_spot_time_s = m;
    values.push(fitted_value(
        (FIELD.0, FIELD.1, base.min_spot_time_s),
        m,
        [(m - half).max(0.0), m + half],
        n,
        format!("the median of the {n} spots that last longer than their MU at the fitted time per MU allows (held at the minimum); interval: the median's, widened by the clock's resolution {clock} s"),
    ));
}

/// Least squares of `y` on the columns of `x` (rows of equal length ≤ 3): the coefficients, their
/// standard errors and the residual standard deviation; `None` when singular or too few rows.
pub(super) fn least_squares(x: &[Vec<f64>], y: &[f64]) -> Option<(Vec<f64>, Vec<f64>, f64)> {
    let p = x.first()?.len();
    let n = y.len();
    if n <= p {
        return None;
    }
    let mut a = vec![vec![0.0; p]; p];
    let mut b = vec![0.0; p];
    for (row, &yi) in x.iter().zip(y) {
        for i in 0..p {
            b[i] += row[i] * yi;
            for j in 0..p {
                a[i][j] += row[i] * row[j];
            }
        }
    }
    let inv = crate::joint::invert(&a)?;
    let coef: Vec<f64> = (0..p)
        .map(|i| (0..p).map(|j| inv[i][j] * b[j]).sum())
        .collect();
    let rss: f64 = x
        .iter()
        .zip(y)
        .map(|(row, yi)| {
            let f: f64 = row.iter().zip(&coef).map(|(r, c)| r * c).sum();
            (yi - f).powi(2)
        })
        .sum();
    let sigma = (rss / (n - p) as f64).sqrt();
    let se = (0..p).map(|i| sigma * inv[i][i].max(0.0).sqrt()).collect();
    Some((coef, se, sigma))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A line through known points: y = 2 + 3x, exact.
    #[test]
    fn least_squares_finds_a_line() {
        let x: Vec<Vec<f64>> = (0..10).map(|i| vec![1.0, f64::from(i)]).collect();
        let y: Vec<f64> = (0..10).map(|i| 2.0 + 3.0 * f64::from(i)).collect();
        let (c, se, sigma) = least_squares(&x, &y).expect("fit");
        assert!(
            (c[0] - 2.0).abs() < 1e-12 && (c[1] - 3.0).abs() < 1e-12,
            "{c:?}"
        );
        assert!(sigma < 1e-12 && se[1] < 1e-12);
        let big: Vec<Vec<f64>> = (0..1000)
            .map(|i| vec![1.0, 5.0 + f64::from(i % 7)])
            .collect();
        let yb: Vec<f64> = big.iter().map(|r| 0.002 + r[1] / 6000.0).collect();
        let (c, ..) = least_squares(&big, &yb).expect("fit");
        assert!((1.0 / c[1] - 6000.0).abs() < 1e-6, "{c:?}");
    }
}
