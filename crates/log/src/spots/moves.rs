//! The moves between spots: the scanning speed(s) and settling time from the moves inside a
//! pass, the burst switching time from the pauses between passes, and how well the fitted
//! model times each log's layers.

use arcsim_plan::{ScanDistance, ScanningBeam};

use super::fit::{kept_value, least_squares, Layer, Move, SpotCalibrateError, SpotResidual};
use super::fit::{med, spread};
use crate::calibrate::FittedValue;
use crate::transitions::student_t95;

/// A move or pause further from the fit than this many robust standard deviations (plus the
/// clock's resolution) is an outlier (a gating pause, an interlock, a glitch of the clock).
const OUTLIER_SDS: f64 = 6.0;

/// The robust standard deviation of `v`, at least what the clock alone gives a gap (two edges
/// each read to within half a step: `clock / √6`) and a microsecond (a time printed to its last
/// digit is still rounded): where most gaps are read alike, the median absolute deviation is 0.
fn robust_sd(v: &[f64], clock: f64) -> f64 {
    spread(v).max(clock / 6f64.sqrt()).max(1e-6)
}

/// The scanning distance of a move under a rule: per axis (both columns) or along the line.
fn features(m: &Move, rule: ScanDistance, one_speed: bool, speeds: (f64, f64)) -> Vec<f64> {
    match (rule, one_speed) {
        (ScanDistance::Euclidean, _) => vec![1.0, m.dx.hypot(m.dy)],
        (ScanDistance::PerAxis, true) => vec![1.0, m.dx.max(m.dy)],
        (ScanDistance::PerAxis, false) => {
            // The axis that takes longer at the current speeds sets the move.
            if m.dx / speeds.0 >= m.dy / speeds.1 {
                vec![1.0, m.dx, 0.0]
            } else {
                vec![1.0, 0.0, m.dy]
            }
        }
    }
}

/// One least-squares fit of the gaps on the moves' features at the current per-axis speeds:
/// coefficients, standard errors, residual sd and the residuals.
type Fit = (Vec<f64>, Vec<f64>, f64, Vec<f64>);

fn fit_once(
    moves: &[&Move],
    rule: ScanDistance,
    one_speed: bool,
    speeds: (f64, f64),
) -> Option<Fit> {
    let x: Vec<Vec<f64>> = moves
        .iter()
        .map(|m| features(m, rule, one_speed, speeds))
        .collect();
    let y: Vec<f64> = moves.iter().map(|m| m.gap_s).collect();
    let (coef, se, sigma) = least_squares(&x, &y)?;
    let resid = x
        .iter()
        .zip(&y)
        .map(|(r, yi)| yi - r.iter().zip(&coef).map(|(a, c)| a * c).sum::<f64>())
        .collect();
    Some((coef, se, sigma, resid))
}

/// A distance rule fitted to the moves.
struct RuleFit {
    /// Settling, then the inverse speed(s).
    coef: Vec<f64>,
    /// Their standard errors.
    se: Vec<f64>,
    /// The residual standard deviation, s.
    sigma: f64,
    /// Moves fitted.
    used: usize,
    /// Moves left out as outliers.
    outliers: usize,
}

/// Least squares of the gaps on the moves' features: outliers left out after a first fit, and
/// with one speed per axis the slower axis of each move re-chosen at the fitted speeds until
/// the speeds hold.
fn fit_rule(moves: &[&Move], rule: ScanDistance, one_speed: bool, clock: f64) -> Option<RuleFit> {
    let per_axis = !one_speed && rule == ScanDistance::PerAxis;
    let mut speeds = (1.0, 1.0);
    if per_axis {
        let (c, ..) = fit_once(moves, rule, true, speeds)?;
        let v = 1.0 / c[1].max(1e-12);
        speeds = (v, v);
    }
    let (coef, _, _, resid) = fit_once(moves, rule, one_speed, speeds)?;
    let cut = OUTLIER_SDS * robust_sd(&resid, clock);
    let kept: Vec<&Move> = moves
        .iter()
        .zip(&resid)
        .filter(|(_, r)| r.abs() <= cut)
        .map(|(m, _)| *m)
        .collect();
    let outliers = moves.len() - kept.len();
    if per_axis {
        speeds = (1.0 / coef[1].max(1e-12), 1.0 / coef[2].max(1e-12));
    }
    let mut fit = fit_once(&kept, rule, one_speed, speeds)?;
    for _ in 0..20 {
        if !per_axis {
            break;
        }
        let next = (1.0 / fit.0[1].max(1e-12), 1.0 / fit.0[2].max(1e-12));
        let held = (next.0 / speeds.0 - 1.0).abs() < 1e-9 && (next.1 / speeds.1 - 1.0).abs() < 1e-9;
        speeds = next;
        if held {
            break;
        }
        fit = fit_once(&kept, rule, one_speed, speeds)?;
    }
    let (coef, se, sigma, _) = fit;
    Some(RuleFit {
        coef,
        se,
        sigma,
        used: kept.len(),
        outliers,
    })
}

/// The scanning speed(s) and the settling time, in the form the base machine has (one speed or
/// one per axis, its distance rule); a warning when the other distance rule fits the moves at
/// least 3× better.
pub(super) fn fit_moves(
    base: &ScanningBeam,
    moves: &[Move],
    clock: f64,
    fitted: &mut ScanningBeam,
    values: &mut Vec<FittedValue>,
    (outliers, warnings): (&mut usize, &mut Vec<String>),
) -> Result<(), SpotCalibrateError> {
    let inside: Vec<&Move> = moves.iter().filter(|m| !m.new_pass).collect();
    let one_speed = base.scan_speed_mm_per_s.is_some();
    let rule = base.scan_distance;
    let Some(RuleFit {
        coef,
        se,
        sigma,
        used: n,
        outliers: out,
    }) = fit_rule(&inside, rule, one_speed, clock)
    else {
        return Err(SpotCalibrateError::TooFew(format!(
            "{} moves between spots of one pass in the logs, or all of one length; expected at least 4 of different lengths to fit the scanning speed and the settling time",
            inside.len()
        )));
    };
    *outliers += out;
    let t = student_t95((n - coef.len()) as f64);
    let (vx, vy) = base.speeds_mm_per_s();
    let speed_rows: Vec<(&str, f64, usize)> = if one_speed {
        vec![("beam.scan_speed_mm_per_s", vx, 1)]
    } else {
        vec![
            ("beam.scan_speed_x_mm_per_s", vx, 1),
            ("beam.scan_speed_y_mm_per_s", vy, 2),
        ]
    };
    let how = format!(
        "least squares of the {n} moves between spots of one pass on their {} distance (the gap = settling + distance / speed), {out} outliers left out; residual sd {:.3} ms",
        match (rule, one_speed) {
            (ScanDistance::Euclidean, _) => "straight-line",
            (ScanDistance::PerAxis, true) => "longer axis's",
            (ScanDistance::PerAxis, false) => "per-axis (the slower axis's)",
        },
        1e3 * sigma
    );
    for (field, base_v, k) in speed_rows {
        let a = coef[k];
        if a <= t * se[k] {
            values.push(kept_value(field, "mm/s", base_v, &format!("not determined: the moves' time does not grow with their distance beyond the noise ({how}); the base value is kept")));
            continue;
        }
        let v = 1.0 / a;
        let interval = [1.0 / (a + t * se[k]), 1.0 / (a - t * se[k])];
        match (one_speed, k) {
            (true, _) => fitted.scan_speed_mm_per_s = Some(v),
            (false, 1) => fitted.scan_speed_x_mm_per_s = Some(v),
            _ => fitted.scan_speed_y_mm_per_s = Some(v),
        }
        values.push(super::fit::fitted_value(
            (field, "mm/s", base_v),
            v,
            interval,
            n,
            how.clone(),
        ));
    }
    let settle = coef[0].max(0.0);
    fitted.settling_time_s = settle;
    values.push(super::fit::fitted_value(
        ("beam.settling_time_s", "s", base.settling_time_s),
        settle,
        [
            (coef[0] - t * se[0]).max(0.0),
            (coef[0] + t * se[0]).max(0.0),
        ],
        n,
        format!("{how}; the intercept (0 where it came out negative)"),
    ));
    let other = match rule {
        ScanDistance::Euclidean => ScanDistance::PerAxis,
        ScanDistance::PerAxis => ScanDistance::Euclidean,
    };
    // What each rule leaves beyond the clock's own reading error (`clock / √6` a gap).
    let excess = |s: f64| (s * s - clock * clock / 6.0).max(0.0).sqrt();
    if let Some(RuleFit {
        sigma: s_other,
        outliers: out_other,
        ..
    }) = fit_rule(&inside, other, true, clock)
    {
        // Moves the rule cannot explain are either left out (counted) or left in (the excess).
        let more_outliers = out_other * 3 < out && out as f64 >= 0.01 * inside.len() as f64;
        let more_excess = excess(s_other) * 3.0 <= excess(sigma)
            && excess(sigma) > 0.5 * clock / 6f64.sqrt() + 1e-6;
        if more_outliers || more_excess {
            warnings.push(format!("the moves fit the other distance rule ({}) at least 3× better ({out_other} outliers against {out}, residual sd {:.3} ms against {:.3} ms): the base machine's `scan_distance` may be wrong, and the speed fitted under it with it", match other { ScanDistance::Euclidean => "euclidean", ScanDistance::PerAxis => "per_axis" }, 1e3 * s_other, 1e3 * sigma));
        }
    }
    Ok(())
}

/// The median of `v` with those beyond 6 robust sd of it (a gating pause, an interlock) left
/// out: the median, the half-width of its 95 % interval widened by the clock's resolution, and
/// how many were kept.
pub(super) fn robust_median(v: &[f64], clock: f64) -> (f64, f64, usize) {
    let m0 = med(v);
    let cut = OUTLIER_SDS * robust_sd(v, clock);
    let kept: Vec<f64> = v
        .iter()
        .copied()
        .filter(|p| (p - m0).abs() <= cut)
        .collect();
    let n = kept.len();
    let half =
        student_t95((n.max(2) - 1) as f64) * 1.2533 * spread(&kept) / (n as f64).sqrt() + clock;
    (med(&kept), half, n)
}

/// The burst switching time: the median of the pauses between passes, less each move's fitted
/// time.
pub(super) fn fit_passes(
    base: &ScanningBeam,
    moves: &[Move],
    clock: f64,
    fitted: &mut ScanningBeam,
    values: &mut Vec<FittedValue>,
    outliers: &mut usize,
) {
    const FIELD: &str = "beam.burst_switching_time_s";
    let pauses: Vec<f64> = moves
        .iter()
        .filter(|m| m.new_pass)
        .map(|m| m.gap_s - fitted.move_time_s([0.0, 0.0], [m.dx, m.dy]))
        .collect();
    if pauses.len() < 3 {
        values.push(kept_value(FIELD, "s", base.burst_switching_time_s, &format!("not determined: {} moves between two passes over a layer's spots in the logs (fewer than 3); the base value is kept", pauses.len())));
        return;
    }
    let (m, half, n) = robust_median(&pauses, clock);
    *outliers += pauses.len() - n;
    let m = m.max(0.0);
    fitted.burst_switching_time_s = m;
    values.push(super::fit::fitted_value(
        (FIELD, "s", base.burst_switching_time_s),
        m,
        [(m - half).max(0.0), m + half],
        n,
        format!("the median of the {n} pauses between two passes over a layer's spots, less each move's fitted scanning and settling; interval: the median's, widened by the clock's resolution {clock} s"),
    ));
}

/// A layer's logged spots timed under `beam`: each spot its MU at the rate (at least the
/// minimum spot time), each move its scanning and settling, each new pass the burst switching,
/// each refill (a pause `base_of_refills` calls one) the spill's refill.
fn layer_time(layer: &Layer, beam: &ScanningBeam, base_of_refills: &ScanningBeam) -> f64 {
    let rate = beam.s_per_mu_at(layer.energy_mev);
    let mut t = 0.0;
    for (k, s) in layer.spots.iter().enumerate() {
        t += (s.mu * rate).max(beam.min_spot_time_s);
        if let Some(p) = k.checked_sub(1).map(|j| &layer.spots[j]) {
            let m = beam.move_time_s([p.x_mm, p.y_mm], [s.x_mm, s.y_mm]);
            // Where the log shows a refill (judged at the base, as for every model timed), the
            // model's refill, the magnets moving meanwhile.
            t += match (&beam.spill, super::spills::is_refill(base_of_refills, p, s)) {
                (Some(spill), true) => m.max(spill.refill_time_s),
                _ => m,
            };
            if p.painting != s.painting {
                t += beam.burst_switching_time_s;
            }
        }
    }
    t
}

/// One log's layers timed under the base and the fitted model, against the log.
pub(super) fn residual(
    log: &str,
    layers: &[Layer],
    base: &ScanningBeam,
    fitted: &ScanningBeam,
) -> SpotResidual {
    let logged: f64 = layers
        .iter()
        .map(|l| match (l.spots.first(), l.spots.last()) {
            (Some(a), Some(b)) => b.t_end_s - a.t_start_s,
            _ => 0.0,
        })
        .sum();
    let base_s: f64 = layers.iter().map(|l| layer_time(l, base, base)).sum();
    let fitted_s: f64 = layers.iter().map(|l| layer_time(l, fitted, base)).sum();
    let pct = |x: f64| 100.0 * (x - logged) / logged.max(f64::MIN_POSITIVE);
    SpotResidual {
        log: log.to_string(),
        layers: layers.len(),
        logged_s: logged,
        base_s,
        fitted_s,
        fitted_error_pct: pct(fitted_s),
        base_error_pct: pct(base_s),
    }
}

/// A log whose layers the fitted model times off by more than 0.5 % (beyond what its clock
/// explains): said, with the likely causes.
pub(super) fn warn_of_residuals(
    residuals: &[SpotResidual],
    clock: f64,
    warnings: &mut Vec<String>,
) {
    for r in residuals {
        // Each layer's span is read to within one clock step.
        let clock_pct = 100.0 * clock * r.layers as f64 / r.logged_s.max(f64::MIN_POSITIVE);
        if r.fitted_error_pct.abs() > 0.5f64.max(3.0 * clock_pct) {
            warnings.push(format!(
                "{}: the fitted model times its layers {:+.2} % off the log (above 0.5 %): pauses the model lacks (gating, interlocks), a beam in spills, or a spot order other than the plan's",
                r.log, r.fitted_error_pct
            ));
        }
    }
}
