//! How a control point's tolerance window is divided among its layers: the one rule the resolver
//! (and through it the sequencer) and the re-sequencer's estimate share.

use crate::model::ControlPoint;

/// One layer's part of its control point's window, along the arc's rotation direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LayerWindow {
    /// Centre of the layer's sub-window, measured from the start of the control point's window
    /// (its edge the gantry reaches first) along the rotation direction (deg).
    pub centre_from_start_deg: f64,
    /// Full width of the layer's sub-window (deg).
    pub width_deg: f64,
}

impl LayerWindow {
    /// The centre's offset from the control point's angle along the rotation direction (deg),
    /// for a control-point window `window_deg` wide: multiply by the direction's
    /// [`crate::RotationDirection::sign`] and add the control point's angle to get the layer's
    /// gantry angle.
    pub fn offset_deg(&self, window_deg: f64) -> f64 {
        -window_deg / 2.0 + self.centre_from_start_deg
    }
}

/// The sub-window of each layer of `cp` (in its delivery order) when the control point's window
/// is `window_deg` wide: consecutive sub-windows along the rotation direction, the first layer's
/// at the window's start, each layer centred in its own. Their widths are proportional to the
/// layers' `window_share`s where every layer gives a finite positive one; otherwise (no shares,
/// the default) the window is split into equal sub-windows. A share moves with its layer, so a
/// reordered control point gives each layer the same width, at its new place.
pub fn layer_windows(cp: &ControlPoint, window_deg: f64) -> Vec<LayerWindow> {
    let shares: Option<Vec<f64>> = cp
        .layers
        .iter()
        .map(|l| l.window_share.filter(|s| s.is_finite() && *s > 0.0))
        .collect();
    let total: f64 = shares.iter().flatten().sum();
    match shares {
        Some(shares) if !shares.is_empty() && total.is_finite() => {
            let mut before = 0.0;
            shares
                .iter()
                .map(|&share| {
                    let w = LayerWindow {
                        centre_from_start_deg: window_deg * ((before + share / 2.0) / total),
                        width_deg: window_deg * (share / total),
                    };
                    before += share;
                    w
                })
                .collect()
        }
        _ => {
            // Equal sub-windows (the arithmetic of the format's first version, kept bit for bit).
            let sub = window_deg / cp.layers.len() as f64;
            (0..cp.layers.len())
                .map(|l| LayerWindow {
                    centre_from_start_deg: sub * (l as f64 + 0.5),
                    width_deg: sub,
                })
                .collect()
        }
    }
}
