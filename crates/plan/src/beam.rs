//! Beam models: how long a layer's spots take, spot by spot.
//!
//! Two kinds, chosen by the machine file's `beam.kind`:
//! - `per_mu` (the default when `kind` is absent, so older machine files read unchanged): every
//!   spot takes `max(MU × s_per_mu, min_spot_time_s)` and consecutive spots are a fixed
//!   `spot_switch_time_s` apart.
//! - `scanning`: the dose rate depends on the energy (`s_per_mu_by_energy`, interpolated), the
//!   scanning magnets move the beam between spots at a finite speed (`scan_distance`: the slower
//!   axis sets the time, or the straight-line distance at one speed), each move may add a
//!   settling time, a spot above `max_mu_per_spot` is split over extra
//!   paintings, a layer may carry a fixed overhead before its first spot, and a synchrocyclotron
//!   pauses between its bursts (`burst_switching_time_s`: each pass over the spots is a burst),
//!   and a synchrotron extracts its beam in spills of limited charge (`spill`, see [`crate::spill`]).
//!
//! Both kinds lay a layer's spots out as [`SpotEvent`]s (start and end relative to the layer's
//! beam-on); the layer's beam-on time is where the last one ends. A plan's `paintings` repeat the
//! spot list, each pass delivering `MU / paintings` per spot.

use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize};

use crate::model::{interpolate_clamped, EnergyLayer, Spots};
use crate::spill::{Spill, SpillModel};

/// How long a layer's spots take to deliver.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum BeamModel {
    /// A fixed time per MU and between spots.
    PerMu(PerMuBeam),
    /// Energy-dependent dose rate, scanning speed, settling, repainting.
    Scanning(ScanningBeam),
}

/// The `per_mu` beam model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PerMuBeam {
    /// Seconds of beam per monitor unit.
    pub s_per_mu: f64,
    /// Seconds between two spots of one layer.
    pub spot_switch_time_s: f64,
    /// Shortest time one spot can take, in seconds.
    #[serde(default)]
    pub min_spot_time_s: f64,
}

/// The `scanning` beam model. Typical numbers: OpenTPS's PBS timing (`scenarios/machine-opentps-pbs.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScanningBeam {
    /// `[energy MeV, s per MU]` rows, energies strictly increasing: the time per MU at an energy is
    /// interpolated linearly between rows and clamped to the first / last row outside them.
    pub s_per_mu_by_energy: Vec<[f64; 2]>,
    /// Scanning speed of the spot in the isocentre plane, mm/s, for both axes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scan_speed_mm_per_s: Option<f64>,
    /// Scanning speed along x, mm/s (with `scan_speed_y_mm_per_s`, instead of one speed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scan_speed_x_mm_per_s: Option<f64>,
    /// Scanning speed along y, mm/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scan_speed_y_mm_per_s: Option<f64>,
    /// Which distance the scanning speed covers between two spots (default `per_axis`).
    #[serde(default, skip_serializing_if = "ScanDistance::is_per_axis")]
    pub scan_distance: ScanDistance,
    /// Shortest time one spot can take, s.
    #[serde(default)]
    pub min_spot_time_s: f64,
    /// Time added to every spot-to-spot move for the magnets to settle, s.
    #[serde(default)]
    pub settling_time_s: f64,
    /// Largest MU one spot may deliver in one pass; a heavier spot is split into equal parts
    /// delivered in extra paintings (passes over the layer's spots, in the plan's order).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_mu_per_spot: Option<f64>,
    /// Fixed beam-on overhead of every layer, spent before its first spot, s.
    #[serde(default)]
    pub layer_overhead_s: f64,
    /// Pause between two bursts of a layer, s (a synchrocyclotron's burst switching): every pass
    /// over the layer's spots (a plan painting, or an extra pass for spots above
    /// `max_mu_per_spot`) is one burst, and the beam waits this long before the next pass.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub burst_switching_time_s: f64,
    /// A synchrotron's spills: the charge one spill holds, the wait for the next, multi-energy
    /// extraction. Absent for a continuous beam.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spill: Option<SpillModel>,
}

/// Whether an optional time is absent (0): such fields are left out of written machine models, so
/// older outputs read unchanged.
fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

impl<'de> Deserialize<'de> for BeamModel {
    /// `kind` selects the model; without it the object is a `per_mu` model (the only kind before
    /// kinds existed). The rest of the object is read as that kind, unknown fields refused.
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let mut map = serde_json::Map::<String, serde_json::Value>::deserialize(d)?;
        let kind = match map.remove("kind") {
            None => "per_mu".to_string(),
            Some(serde_json::Value::String(k)) => k,
            Some(other) => {
                return Err(D::Error::custom(format!(
                    "`kind`: expected \"per_mu\" or \"scanning\", got {other}"
                )))
            }
        };
        let value = serde_json::Value::Object(map);
        match kind.as_str() {
            "per_mu" => serde_json::from_value(value)
                .map(BeamModel::PerMu)
                .map_err(|e| D::Error::custom(format!("(kind per_mu) {e}"))),
            "scanning" => serde_json::from_value(value)
                .map(BeamModel::Scanning)
                .map_err(|e| D::Error::custom(format!("(kind scanning) {e}"))),
            other => Err(D::Error::custom(format!(
                "unknown beam model kind \"{other}\"; expected \"per_mu\" or \"scanning\""
            ))),
        }
    }
}

impl BeamModel {
    /// The model with every time per MU divided by `scale` (a dose rate `scale` times higher).
    pub fn with_dose_rate_scale(&self, scale: f64) -> BeamModel {
        let mut m = self.clone();
        match &mut m {
            BeamModel::PerMu(b) => b.s_per_mu /= scale,
            BeamModel::Scanning(b) => b.s_per_mu_by_energy.iter_mut().for_each(|r| r[1] /= scale),
        }
        m
    }

    /// The `scanning` model with both axes scanning at `mm_per_s`; `None` for `per_mu`, which has
    /// no scanning speed.
    pub fn with_scan_speed(&self, mm_per_s: f64) -> Option<BeamModel> {
        match self {
            BeamModel::PerMu(_) => None,
            BeamModel::Scanning(b) => Some(BeamModel::Scanning(ScanningBeam {
                scan_speed_mm_per_s: Some(mm_per_s),
                scan_speed_x_mm_per_s: None,
                scan_speed_y_mm_per_s: None,
                ..b.clone()
            })),
        }
    }

    /// The `scanning` model with `s` seconds between bursts; `None` for `per_mu`, which has no
    /// bursts.
    pub fn with_burst_switching_time(&self, s: f64) -> Option<BeamModel> {
        match self {
            BeamModel::PerMu(_) => None,
            BeamModel::Scanning(b) => Some(BeamModel::Scanning(ScanningBeam {
                burst_switching_time_s: s,
                ..b.clone()
            })),
        }
    }

    /// The model with every spill holding `mu`; `None` without spills.
    pub fn with_spill_charge(&self, mu: f64) -> Option<BeamModel> {
        self.with_spill(|s| s.charge_mu = mu)
    }

    /// The model with `s` seconds to the next spill; `None` without spills.
    pub fn with_spill_refill_time(&self, s: f64) -> Option<BeamModel> {
        self.with_spill(|m| m.refill_time_s = s)
    }

    /// The model with at most `n` layers per spill (1: every layer a new spill, as without
    /// multi-energy extraction); `None` without spills.
    pub fn with_spill_max_layers(&self, n: u32) -> Option<BeamModel> {
        self.with_spill(|m| m.max_layers_per_spill = Some(n))
    }

    /// A copy with the spill model changed by `f`; `None` without spills.
    fn with_spill(&self, f: impl FnOnce(&mut SpillModel)) -> Option<BeamModel> {
        let mut m = self.clone();
        match &mut m {
            BeamModel::Scanning(ScanningBeam { spill: Some(s), .. }) => f(s),
            _ => return None,
        }
        Some(m)
    }

    /// The spill model, if the beam comes in spills.
    pub fn spill(&self) -> Option<&SpillModel> {
        match self {
            BeamModel::Scanning(b) => b.spill.as_ref(),
            BeamModel::PerMu(_) => None,
        }
    }

    /// The time between bursts of a `scanning` model (0 without bursts); `None` for `per_mu`.
    pub fn burst_switching_time_s(&self) -> Option<f64> {
        match self {
            BeamModel::PerMu(_) => None,
            BeamModel::Scanning(b) => Some(b.burst_switching_time_s),
        }
    }

    /// The name of the kind, as in the machine file.
    pub fn kind(&self) -> &'static str {
        match self {
            BeamModel::PerMu(_) => "per_mu",
            BeamModel::Scanning(_) => "scanning",
        }
    }
}

impl ScanningBeam {
    /// Seconds per MU at `energy_mev`: linear between the table's rows, clamped at its ends.
    pub fn s_per_mu_at(&self, energy_mev: f64) -> f64 {
        interpolate_clamped(&self.s_per_mu_by_energy, energy_mev)
    }

    /// Scanning speeds along x and y, mm/s.
    pub fn speeds_mm_per_s(&self) -> (f64, f64) {
        match (
            self.scan_speed_mm_per_s,
            self.scan_speed_x_mm_per_s,
            self.scan_speed_y_mm_per_s,
        ) {
            (Some(v), _, _) => (v, v),
            (None, Some(x), Some(y)) => (x, y),
            _ => (f64::NAN, f64::NAN),
        }
    }

    /// Time to move the spot from `a` to `b` (mm) as [`ScanDistance`] says, plus the settling
    /// time.
    pub fn move_time_s(&self, a: [f64; 2], b: [f64; 2]) -> f64 {
        let (vx, vy) = self.speeds_mm_per_s();
        let (dx, dy) = ((b[0] - a[0]).abs(), (b[1] - a[1]).abs());
        let scan = match self.scan_distance {
            ScanDistance::PerAxis => (dx / vx).max(dy / vy),
            ScanDistance::Euclidean => dx.hypot(dy) / vx,
        };
        scan + self.settling_time_s
    }
}

/// How the time of a spot-to-spot move follows from the distance. Both occur in real machines:
/// two scanning magnets that move together, each at its own speed, versus one speed along the
/// path (OpenTPS's `SimpleBeamDeliveryTimings`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ScanDistance {
    /// The axes move at the same time, each at its speed: `max(|dx| / vx, |dy| / vy)`.
    #[default]
    PerAxis,
    /// The straight-line distance at one speed (`scan_speed_mm_per_s`): `hypot(dx, dy) / v`.
    Euclidean,
}

impl ScanDistance {
    /// Whether this is the default, `per_axis` (left out when a machine is written).
    pub fn is_per_axis(&self) -> bool {
        *self == ScanDistance::PerAxis
    }
}

/// One delivery of one spot (one painting of it), times relative to the layer's beam-on.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpotEvent {
    /// Index of the spot in the layer's list (from 0).
    pub spot: usize,
    /// Painting (pass over the layer's spots) that delivers it, from 0.
    pub painting: usize,
    /// Spot position in mm, when the plan gives positions.
    pub position_mm: Option<[f64; 2]>,
    /// MU delivered by this event.
    pub mu: f64,
    /// The spill it is extracted from (index since the plan's first spill), when the beam model
    /// has spills.
    pub spill: Option<usize>,
    /// Irradiation start and end after the layer's beam-on, s.
    pub start_s: f64,
    /// Irradiation end after the layer's beam-on, s.
    pub end_s: f64,
}

/// A layer's beam-on time split into its parts, seconds.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LayerBeamTime {
    /// Time the spots are irradiated.
    pub spot_irradiation_s: f64,
    /// Time between spots (scanning or spot switching, settling) and the layer overhead.
    pub scanning_s: f64,
    /// Pauses between the layer's bursts (a synchrocyclotron's burst switching).
    pub burst_switching_s: f64,
    /// Waiting for the next spill beyond the scanning move made meanwhile (a synchrotron).
    pub spill_waiting_s: f64,
}

impl LayerBeamTime {
    /// The whole beam-on time of the layer.
    pub fn total_s(self) -> f64 {
        self.spot_irradiation_s + self.scanning_s + self.burst_switching_s + self.spill_waiting_s
    }
}

/// Most spot deliveries (spots × paintings, splits included) of one layer.
pub const MAX_SPOT_DELIVERIES: usize = 5_000_000;

/// Why a layer's spots cannot be timed under a beam model.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SpotTimingError {
    /// The `scanning` model needs `spots.positions_mm`.
    NoPositions,
    /// Splitting spots above `max_mu_per_spot` gives more than [`MAX_SPOT_DELIVERIES`].
    TooManyDeliveries {
        /// The number of deliveries the split would give.
        count: usize,
    },
}

/// MU per spot of a layer: the given list, or the total shared equally.
fn spot_mu(spots: &Spots) -> impl Iterator<Item = f64> + '_ {
    let n = spots.count as usize;
    let equal = spots.total_mu.map(|t| t / spots.count.max(1) as f64);
    (0..n).map(move |i| match &spots.mu {
        Some(mu) => mu.get(i).copied().unwrap_or(0.0),
        None => equal.unwrap_or(0.0),
    })
}

/// The MU of all of a layer's spots.
pub fn layer_mu(spots: &Spots) -> f64 {
    spot_mu(spots).sum()
}

/// Calls `visit` for every delivery of a spot of `spots` (energy `energy_mev`) under `beam`, in
/// delivery order, and returns the layer's beam-on time split into its parts. A beam model with
/// spills starts the layer in a full spill (use [`crate::BeamSequence`] to carry spills from layer
/// to layer).
pub fn time_spots(
    spots: &Spots,
    energy_mev: f64,
    beam: &BeamModel,
    mut visit: impl FnMut(&SpotEvent),
) -> Result<LayerBeamTime, SpotTimingError> {
    let mut spill = beam.spill().map(|m| m.fresh(None));
    time_spots_in(spots, energy_mev, beam, spill.as_mut(), &mut visit)
}

/// [`time_spots`] starting in `spill` (when the beam model has spills), which is left as the
/// layer leaves it.
pub(crate) fn time_spots_in(
    spots: &Spots,
    energy_mev: f64,
    beam: &BeamModel,
    spill: Option<&mut Spill>,
    visit: &mut dyn FnMut(&SpotEvent),
) -> Result<LayerBeamTime, SpotTimingError> {
    match beam {
        BeamModel::PerMu(b) => Ok(per_mu_layer(b, spots, visit)),
        BeamModel::Scanning(b) => {
            let positions = spots
                .positions_mm
                .as_ref()
                .ok_or(SpotTimingError::NoPositions)?;
            let spill = b.spill.as_ref().zip(spill);
            scan_layer(b, spots, energy_mev, positions, spill, visit)
        }
    }
}

/// The `per_mu` model's layer: every painting over the spots, a fixed switch between spots.
fn per_mu_layer(b: &PerMuBeam, spots: &Spots, visit: &mut dyn FnMut(&SpotEvent)) -> LayerBeamTime {
    let paintings = spots.paintings.unwrap_or(1).max(1) as usize;
    let scale = 1.0 / paintings as f64;
    let position = |i: usize| spots.positions_mm.as_ref().and_then(|p| p.get(i).copied());
    let mut time = LayerBeamTime::default();
    let mut t = 0.0;
    let mut gaps = 0u64;
    for painting in 0..paintings {
        for (spot, mu) in spot_mu(spots).enumerate() {
            if painting > 0 || spot > 0 {
                t += b.spot_switch_time_s;
                gaps += 1;
            }
            let mu = mu * scale;
            let d = (mu * b.s_per_mu).max(b.min_spot_time_s);
            visit(&SpotEvent {
                spot,
                painting,
                position_mm: position(spot),
                mu,
                spill: None,
                start_s: t,
                end_s: t + d,
            });
            t += d;
            time.spot_irradiation_s += d;
        }
    }
    time.scanning_s = gaps as f64 * b.spot_switch_time_s;
    time
}

/// A layer's beam-on time under `beam`: the explicit `irradiation_time_s` (all of it counted as
/// irradiation), else its spots' time.
pub fn layer_beam_time(
    layer: &EnergyLayer,
    beam: &BeamModel,
) -> Result<LayerBeamTime, SpotTimingError> {
    match (layer.irradiation_time_s, &layer.spots) {
        (Some(t), _) => Ok(LayerBeamTime {
            spot_irradiation_s: t,
            ..LayerBeamTime::default()
        }),
        (None, Some(spots)) => layer_spots_time(spots, layer.energy_mev, beam),
        (None, None) => Ok(LayerBeamTime::default()),
    }
}

/// [`time_spots`] without the events; closed form for equal spots under `per_mu`.
fn layer_spots_time(
    spots: &Spots,
    energy_mev: f64,
    beam: &BeamModel,
) -> Result<LayerBeamTime, SpotTimingError> {
    if let (BeamModel::PerMu(b), None, Some(total)) = (beam, &spots.mu, spots.total_mu) {
        let n = f64::from(spots.count) * f64::from(spots.paintings.unwrap_or(1).max(1));
        if n >= 1.0 {
            return Ok(LayerBeamTime {
                spot_irradiation_s: n * (total / n * b.s_per_mu).max(b.min_spot_time_s),
                scanning_s: (n - 1.0) * b.spot_switch_time_s,
                ..LayerBeamTime::default()
            });
        }
    }
    time_spots(spots, energy_mev, beam, |_| {})
}

/// The `scanning` model's layer: every plan painting and extra pass (a burst) over the spots in
/// the plan's order, with the spill (if any) refilled where a spot needs more than it has left.
fn scan_layer(
    b: &ScanningBeam,
    spots: &Spots,
    energy_mev: f64,
    positions: &[[f64; 2]],
    mut spill: Option<(&SpillModel, &mut Spill)>,
    visit: &mut dyn FnMut(&SpotEvent),
) -> Result<LayerBeamTime, SpotTimingError> {
    let paintings = spots.paintings.unwrap_or(1).max(1) as usize;
    let scale = 1.0 / paintings as f64;
    let rate = b.s_per_mu_at(energy_mev);
    let parts = |mu: f64| match b.max_mu_per_spot {
        Some(max) if mu > max => (mu / max).ceil() as usize,
        _ => 1,
    };
    let passes = spot_mu(spots).map(|m| parts(m * scale)).max().unwrap_or(1);
    check_deliveries(spots, paintings, &parts, spill.as_ref().map(|s| s.0))?;
    let mut time = LayerBeamTime {
        scanning_s: b.layer_overhead_s,
        ..LayerBeamTime::default()
    };
    let mut t = b.layer_overhead_s;
    let mut at: Option<[f64; 2]> = None;
    for plan_painting in 0..paintings {
        for pass in 0..passes {
            // Every pass after the first is a new burst.
            if at.is_some() {
                t += b.burst_switching_time_s;
                time.burst_switching_s += b.burst_switching_time_s;
            }
            for (spot, mu) in spot_mu(spots).enumerate() {
                let mu = mu * scale;
                let k = parts(mu);
                if pass >= k {
                    continue;
                }
                let p = positions.get(spot).copied().unwrap_or([0.0, 0.0]);
                let mu = mu / k as f64;
                let m = at.map_or(0.0, |from| b.move_time_s(from, p));
                // The magnets move while the next spill comes.
                let wait = match spill.as_mut() {
                    Some((model, s)) if model.refill_before(s, mu) => {
                        **s = model.fresh(Some(s));
                        model.refill_time_s
                    }
                    _ => 0.0,
                };
                t += m.max(wait);
                time.scanning_s += m;
                time.spill_waiting_s += (wait - m).max(0.0);
                at = Some(p);
                let mut event = SpotEvent {
                    spot,
                    painting: plan_painting * passes + pass,
                    position_mm: Some(p),
                    mu,
                    spill: None,
                    start_s: t,
                    end_s: t,
                };
                let mut left = mu;
                loop {
                    let part = match spill.as_mut() {
                        Some((model, s)) => {
                            let part = if model.negligible(left - s.remaining_mu) {
                                left
                            } else {
                                left.min(s.remaining_mu)
                            };
                            s.remaining_mu = (s.remaining_mu - part).max(0.0);
                            event.spill = Some(s.index);
                            part
                        }
                        None => left,
                    };
                    let d = (part * rate).max(b.min_spot_time_s);
                    event.mu = part;
                    event.start_s = t;
                    event.end_s = t + d;
                    visit(&event);
                    t += d;
                    time.spot_irradiation_s += d;
                    left -= part;
                    match spill.as_mut() {
                        Some((model, s)) if !model.negligible(left) => {
                            **s = model.fresh(Some(s));
                            t += model.refill_time_s;
                            time.spill_waiting_s += model.refill_time_s;
                        }
                        _ => break,
                    }
                }
            }
        }
    }
    Ok(time)
}

/// Refuses a layer whose spot deliveries (paintings, splits above `max_mu_per_spot`, parts of
/// spots across spills) would exceed [`MAX_SPOT_DELIVERIES`].
fn check_deliveries(
    spots: &Spots,
    paintings: usize,
    parts: &dyn Fn(f64) -> usize,
    spill: Option<&SpillModel>,
) -> Result<(), SpotTimingError> {
    let scale = 1.0 / paintings as f64;
    let per_painting = spot_mu(spots).fold(0usize, |n, m| n.saturating_add(parts(m * scale)));
    // A spot is split across spills only where a spill runs out: at most once per spill.
    let spill_ends = spill.map_or(0.0, |s| (layer_mu(spots) / s.charge_mu).ceil() + 1.0);
    let count = paintings
        .saturating_mul(per_painting)
        .saturating_add(spill_ends.min(MAX_SPOT_DELIVERIES as f64) as usize);
    if count > MAX_SPOT_DELIVERIES {
        return Err(SpotTimingError::TooManyDeliveries { count });
    }
    Ok(())
}
