//! A virtual log: a simulated delivery sampled as the log a machine would write.
//!
//! Every `period_s` from 0 (and at the end): the gantry angle from the timeline (plus seeded
//! Gaussian encoder noise when asked), the beam on from a layer's beam-on start to its end except
//! in pauses between two of its spots longer than the period (burst switching, a wait for a
//! spill), the layer's energy while on, the spot being irradiated, and the MU delivered since the
//! previous sample (each spot's MU spread evenly over its irradiation).

use arcsim_sequencer::{Delivery, SpotRow};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use thiserror::Error;

use crate::LogSample;

/// Most samples a virtual log may have.
pub const MAX_LOG_SAMPLES: f64 = 5e7;

/// The largest angle noise a virtual log takes (deg, one standard deviation): encoders are good
/// to hundredths of a degree, and a noise of 1e308 wrote infinite angles that `compare` refuses.
pub const MAX_ANGLE_NOISE_DEG: f64 = 10.0;

/// How a delivery is sampled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VirtualLogOptions {
    /// Time between samples, s (> 0).
    pub period_s: f64,
    /// Standard deviation of the Gaussian noise added to each angle, degrees (0: none).
    pub angle_noise_deg: f64,
    /// Seed of the noise.
    pub seed: u64,
}

impl Default for VirtualLogOptions {
    /// 10 ms, no noise, seed 0.
    fn default() -> Self {
        VirtualLogOptions {
            period_s: 0.01,
            angle_noise_deg: 0.0,
            seed: 0,
        }
    }
}

/// Why a delivery cannot be sampled.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum VirtualLogError {
    /// The delivery was simulated without its timeline.
    #[error("the delivery has no timeline to sample")]
    NoTimeline,
    /// The period is not a finite number > 0.
    #[error("log period {} s; expected a finite number > 0", arcsim_plan::fmt_num(*.0))]
    Period(f64),
    /// The noise is not a finite number from 0 to [`MAX_ANGLE_NOISE_DEG`].
    #[error("angle noise {} deg; expected a number from 0 to {MAX_ANGLE_NOISE_DEG} deg", arcsim_plan::fmt_num(*.0))]
    Noise(f64),
    /// The period would give too many samples.
    #[error("a {} s log period gives {} samples of a {} s delivery; expected at most {MAX_LOG_SAMPLES:.0}", arcsim_plan::fmt_num(*.period_s), arcsim_plan::fmt_num(*.count), arcsim_plan::fmt_num(*.duration_s))]
    TooManySamples {
        /// The period asked for.
        period_s: f64,
        /// The delivery's duration.
        duration_s: f64,
        /// The samples it would give.
        count: f64,
    },
}

/// A beam-on stretch of one layer.
#[derive(Debug, Clone, Copy)]
struct Segment {
    start: f64,
    end: f64,
    energy_mev: f64,
}

/// Samples `delivery` (which must carry its timeline) as a log; `spots` are its spot rows
/// ([`arcsim_sequencer::spot_timeline`]; empty when the plan has no spots).
pub fn virtual_log(
    delivery: &Delivery,
    spots: &[SpotRow],
    opts: &VirtualLogOptions,
) -> Result<Vec<LogSample>, VirtualLogError> {
    let timeline = delivery
        .timeline
        .as_ref()
        .ok_or(VirtualLogError::NoTimeline)?;
    let duration = timeline.duration_s();
    let count = check_options(duration, opts)?;
    let period = opts.period_s;
    let segments = segments(delivery, spots, period);
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let mut noise = || match opts.angle_noise_deg {
        0.0 => 0.0,
        sd => sd * rng.sample::<f64, _>(StandardNormal),
    };
    let mut out = Vec::with_capacity(count);
    let (mut seg, mut spot, mut mu_from) = (0, 0, 0);
    let mut prev_t = 0.0;
    for t in times(duration, period) {
        while seg < segments.len() && segments[seg].end < t {
            seg += 1;
        }
        let on = segments.get(seg).filter(|s| s.start <= t && t <= s.end);
        while spot < spots.len() && spots[spot].t_end_s < t {
            spot += 1;
        }
        let current = spots
            .get(spot)
            .filter(|r| r.t_start_s <= t && t <= r.t_end_s && on.is_some());
        let (mu, next) = mu_between(spots, mu_from, (prev_t, t), out.is_empty());
        mu_from = next;
        out.push(LogSample {
            t_s: t,
            gantry_angle_deg: timeline.state_at(t).angle_deg + noise(),
            beam_on: on.is_some(),
            energy_mev: on.map(|s| s.energy_mev),
            spot: current.map(|r| r.spot as u32),
            mu: (!spots.is_empty()).then_some(mu),
        });
        prev_t = t;
    }
    Ok(out)
}

/// Checks `opts` for a delivery of `duration_s` and returns at most how many samples its log has
/// (every period from 0, and the end).
pub fn check_options(duration_s: f64, opts: &VirtualLogOptions) -> Result<usize, VirtualLogError> {
    let period = opts.period_s;
    if !(period.is_finite() && period > 0.0) {
        return Err(VirtualLogError::Period(period));
    }
    if !(0.0..=MAX_ANGLE_NOISE_DEG).contains(&opts.angle_noise_deg) {
        return Err(VirtualLogError::Noise(opts.angle_noise_deg));
    }
    let count = (duration_s / period).floor() + 2.0;
    if count > MAX_LOG_SAMPLES {
        return Err(VirtualLogError::TooManySamples {
            period_s: period,
            duration_s,
            count,
        });
    }
    Ok(count as usize)
}

/// 0, `period`, 2·`period`, … up to `duration`, and `duration` itself.
fn times(duration: f64, period: f64) -> impl Iterator<Item = f64> {
    let n = (duration / period).floor() as u64;
    let grid = (0..=n).map(move |k| k as f64 * period);
    let last = (n as f64 * period < duration).then_some(duration);
    grid.chain(last)
}

/// Every layer's beam-on window, split where two of its spots are more than `gap_s` apart.
fn segments(delivery: &Delivery, spots: &[SpotRow], gap_s: f64) -> Vec<Segment> {
    let mut out = Vec::new();
    let mut k = 0;
    for layer in &delivery.layers {
        let mut start = layer.t_start_s;
        let mut last_end: Option<f64> = None;
        while k < spots.len() && spots[k].layer_index < layer.index {
            k += 1;
        }
        while k < spots.len() && spots[k].layer_index == layer.index {
            let r = &spots[k];
            if let Some(end) = last_end.filter(|end| r.t_start_s - end > gap_s) {
                out.push(Segment {
                    start,
                    end,
                    energy_mev: layer.energy_mev,
                });
                start = r.t_start_s;
            }
            last_end = Some(r.t_end_s);
            k += 1;
        }
        out.push(Segment {
            start,
            end: layer.t_end_s,
            energy_mev: layer.energy_mev,
        });
    }
    out
}

/// MU the spots deliver in (`from`, `to`] (`[from, to]` for the first sample), each spread evenly
/// over its irradiation (a spot of no duration counts at its start), looking from spot `first`
/// on; also the first spot that may still deliver after `to`.
fn mu_between(
    spots: &[SpotRow],
    first: usize,
    (from, to): (f64, f64),
    closed: bool,
) -> (f64, usize) {
    let mut mu = 0.0;
    let mut next = first;
    for (i, r) in spots.iter().enumerate().skip(first) {
        if r.t_start_s > to {
            break;
        }
        let d = r.t_end_s - r.t_start_s;
        if d > 0.0 {
            let overlap = (r.t_end_s.min(to) - r.t_start_s.max(from)).max(0.0);
            mu += r.mu * overlap / d;
        } else if r.t_start_s > from || (closed && r.t_start_s == from) {
            mu += r.mu;
        }
        if r.t_end_s <= to {
            next = i + 1;
        }
    }
    (mu, next)
}
