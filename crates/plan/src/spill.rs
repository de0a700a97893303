//! Spills: a synchrotron extracts its beam in spills of limited charge.
//!
//! A spill holds `charge_mu`; a spot that needs more than what is left waits `refill_time_s` for
//! the next spill (deceleration, injection, acceleration), either after taking what is left
//! (`split`) or whole (`next_spill`). Without multi-energy extraction every layer starts a new
//! spill (the energy switch covers the synchrotron's cycle); with it, a layer at the same or a
//! lower energy continues the previous layer's spill after `in_spill_switching_time_s` instead of
//! the energy switch, as long as charge is left. The spill's charge, not its length, is the limit
//! here: a flat-top that ends while the gantry moves is not modelled.

use serde::{Deserialize, Serialize};

use crate::beam::{time_spots_in, BeamModel, LayerBeamTime, SpotEvent, SpotTimingError};
use crate::model::EnergyLayer;

/// A synchrotron's spill structure (`beam.spill` of a `scanning` beam model).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpillModel {
    /// Charge one spill can deliver, MU. The extraction rate is the beam model's time per MU.
    pub charge_mu: f64,
    /// Beam-off time from an exhausted spill to the next one at the same energy, s.
    pub refill_time_s: f64,
    /// Whether a spill may continue into the next layer (at the same or a lower energy).
    #[serde(default)]
    pub multi_energy_extraction: bool,
    /// Switching time between two layers served by one spill, s (instead of the ELST).
    #[serde(default)]
    pub in_spill_switching_time_s: f64,
    /// Most layers one spill may serve (multi-energy extraction); unlimited when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_layers_per_spill: Option<u32>,
    /// What happens to a spot that needs more than the spill has left.
    #[serde(default)]
    pub spot_across_spills: SpotAcrossSpills,
    /// When a layer continues the previous layer's spill (multi-energy extraction).
    #[serde(default, skip_serializing_if = "ContinueSpillIf::is_charge_left")]
    pub continue_spill_if: ContinueSpillIf,
}

/// When multi-energy extraction carries a spill into the next layer.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContinueSpillIf {
    /// Whenever charge is left: the layer may then wait for a new spill part-way.
    #[default]
    ChargeLeft,
    /// Only when what is left covers the whole layer's MU; otherwise the layer starts a new
    /// spill after the energy switch (a controller that knows the plan).
    LayerFits,
}

impl ContinueSpillIf {
    /// Whether this is the default, `charge_left` (left out when a machine is written).
    pub fn is_charge_left(&self) -> bool {
        *self == ContinueSpillIf::ChargeLeft
    }
}

/// What a spot that does not fit in what is left of a spill does.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpotAcrossSpills {
    /// It takes what is left, then the rest from the next spill (or spills).
    #[default]
    Split,
    /// It waits whole for the next spill; a spot larger than a whole spill starts in a new spill
    /// and is split over as many as it needs.
    NextSpill,
}

/// The spill being extracted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spill {
    /// Index of the spill since the plan's first (from 0).
    pub index: usize,
    /// Charge still in it, MU.
    pub remaining_mu: f64,
    /// Layers it has served, the current one included.
    pub layers: u32,
}

impl SpillModel {
    /// Charges below this fraction of a spill count as an empty spill (rounding of MU sums).
    const EMPTY: f64 = 1e-9;

    /// The first spill after `previous` (a full one).
    pub fn fresh(&self, previous: Option<&Spill>) -> Spill {
        Spill {
            index: previous.map_or(0, |s| s.index + 1),
            remaining_mu: self.charge_mu,
            layers: 1,
        }
    }

    /// Whether `mu` counts as nothing against this spill size.
    pub(crate) fn negligible(&self, mu: f64) -> bool {
        mu <= Self::EMPTY * self.charge_mu
    }

    /// Whether a spot of `mu` must wait for a new spill before it starts.
    pub(crate) fn refill_before(&self, spill: &Spill, mu: f64) -> bool {
        let fits = mu <= spill.remaining_mu || self.negligible(mu - spill.remaining_mu);
        match self.spot_across_spills {
            SpotAcrossSpills::Split => !fits && self.negligible(spill.remaining_mu),
            SpotAcrossSpills::NextSpill => {
                !fits && !self.negligible(self.charge_mu - spill.remaining_mu)
            }
        }
    }

    /// The spill the next layer (energy `energy_mev`, arc `arc`) starts in, and whether it is the
    /// previous layer's (so the switch into it is `in_spill_switching_time_s`).
    fn next(
        &self,
        previous: Option<&Previous>,
        arc: usize,
        energy_mev: f64,
        layer_mu: f64,
    ) -> (Spill, bool) {
        let Some(p) = previous else {
            return (self.fresh(None), false);
        };
        let Some(spill) = p.spill.as_ref() else {
            return (self.fresh(None), false);
        };
        let room = self.max_layers_per_spill.is_none_or(|m| spill.layers < m);
        let continues = self.multi_energy_extraction
            && p.arc == arc
            && energy_mev <= p.energy_mev
            && room
            && !self.negligible(spill.remaining_mu)
            && match self.continue_spill_if {
                ContinueSpillIf::ChargeLeft => true,
                ContinueSpillIf::LayerFits => {
                    layer_mu <= spill.remaining_mu || self.negligible(layer_mu - spill.remaining_mu)
                }
            };
        if continues {
            let mut s = *spill;
            s.layers += 1;
            (s, true)
        } else {
            (self.fresh(Some(spill)), false)
        }
    }
}

/// The layer before, as the next one needs it.
#[derive(Debug, Clone, Copy)]
struct Previous {
    arc: usize,
    energy_mev: f64,
    spill: Option<Spill>,
}

/// A layer's beam-on time, and whether it continues the previous layer's spill.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LayerBeam {
    /// The beam-on time, split into its parts.
    pub time: LayerBeamTime,
    /// Whether the layer is delivered from the previous layer's spill (multi-energy extraction):
    /// the switch into it is then the spill model's `in_spill_switching_time_s`.
    pub same_spill: bool,
}

/// Times a plan's layers one after the other in delivery order, carrying the spill (if the beam
/// model has spills) from each layer to the next. Resolution and the per-spot timeline both walk a
/// plan with it, so the two agree.
#[derive(Debug, Clone)]
pub struct BeamSequence<'a> {
    beam: &'a BeamModel,
    previous: Option<Previous>,
}

impl<'a> BeamSequence<'a> {
    /// A sequence before the plan's first layer.
    pub fn new(beam: &'a BeamModel) -> Self {
        BeamSequence {
            beam,
            previous: None,
        }
    }

    /// [`BeamSequence::next_layer`] without the spot deliveries: without spills, the layer's time
    /// as [`crate::layer_beam_time`] gives it (a closed form for equal spots under `per_mu`).
    pub fn next_layer_time(
        &mut self,
        arc: usize,
        layer: &EnergyLayer,
    ) -> Result<LayerBeam, SpotTimingError> {
        if self.beam.spill().is_some() {
            return self.next_layer(arc, layer, &mut |_| {});
        }
        let time = crate::beam::layer_beam_time(layer, self.beam)?;
        self.previous = Some(Previous {
            arc,
            energy_mev: layer.energy_mev,
            spill: None,
        });
        Ok(LayerBeam {
            time,
            same_spill: false,
        })
    }

    /// Times the next layer in delivery order (in arc `arc`), calling `visit` for each of its spot
    /// deliveries. A layer given by `irradiation_time_s` keeps that time and, its charge unknown,
    /// has a spill of its own that the next layer does not continue.
    pub fn next_layer(
        &mut self,
        arc: usize,
        layer: &EnergyLayer,
        visit: &mut dyn FnMut(&SpotEvent),
    ) -> Result<LayerBeam, SpotTimingError> {
        let model = self.beam.spill();
        let (mut spill, same_spill) = match model {
            Some(m) if layer.irradiation_time_s.is_some() => (
                Some(m.fresh(self.previous.and_then(|p| p.spill).as_ref())),
                false,
            ),
            Some(m) => {
                let mu = layer.spots.as_ref().map_or(0.0, crate::beam::layer_mu);
                let (s, same) = m.next(self.previous.as_ref(), arc, layer.energy_mev, mu);
                (Some(s), same)
            }
            None => (None, false),
        };
        let time = match (layer.irradiation_time_s, &layer.spots) {
            (Some(t), _) => {
                if let Some(s) = spill.as_mut() {
                    s.remaining_mu = 0.0;
                }
                LayerBeamTime {
                    spot_irradiation_s: t,
                    ..LayerBeamTime::default()
                }
            }
            (None, Some(spots)) => {
                time_spots_in(spots, layer.energy_mev, self.beam, spill.as_mut(), visit)?
            }
            (None, None) => LayerBeamTime::default(),
        };
        self.previous = Some(Previous {
            arc,
            energy_mev: layer.energy_mev,
            spill,
        });
        Ok(LayerBeam { time, same_spill })
    }
}
