//! The spots of the layer being delivered, in a 2D beam's-eye view.
//!
//! Like the delivery, everything temporal goes through `send_columns` with explicit `time` /
//! `angle_cdeg` columns (the caller's time cursor is left alone).

use std::collections::HashMap;

use arcsim_sequencer::SpotRow;
use rerun::components::Radius;
use rerun::{Color, RecordingStream};

use crate::delivery::{index_columns, rgb, viridis};
use crate::{paths, ViewerError};

/// Most updates of the spot colours logged per layer (see [`log_spots`]).
pub const MAX_SPOT_UPDATES_PER_LAYER: usize = 64;

/// Colour of a spot not irradiated yet in its layer.
const PENDING: Color = rgb(72, 72, 72);
/// Spot radii (UI points: the same on screen at any zoom and spot density).
const SPOT_RADIUS_PT: f32 = 3.5;
const CURRENT_RADIUS_PT: f32 = 6.5;
/// The faintest delivered spot sits this far up the colour ramp, so it stands out from the
/// grey of pending spots (the darkest viridis colours are as dim as the grey).
const RAMP_FLOOR: f64 = 0.2;

/// One point of the view: a spot of the layer (several rows when the layer is repainted).
struct Spot {
    pos: [f32; 2],
    /// MU of all its paintings.
    total_mu: f64,
}

/// The rows of one layer that can be drawn, with their spots.
struct Layer<'a> {
    first: &'a SpotRow,
    /// Rows with a position, in delivery order, each with the index of its spot in `spots`.
    rows: Vec<(&'a SpotRow, usize)>,
    spots: Vec<Spot>,
    paintings: usize,
}

/// A row's position in view coordinates (mm, y negated: Rerun's 2D views point y down).
fn position(r: &SpotRow) -> Option<[f32; 2]> {
    match (r.x_mm, r.y_mm) {
        (Some(x), Some(y)) if x.is_finite() && y.is_finite() => Some([x as f32, -y as f32]),
        _ => None,
    }
}

fn mu(r: &SpotRow) -> f64 {
    if r.mu.is_finite() {
        r.mu.max(0.0)
    } else {
        0.0
    }
}

fn finite_times(r: &SpotRow) -> bool {
    r.t_start_s.is_finite() && r.t_end_s.is_finite()
}

/// Groups consecutive rows of one layer; layers without a drawable row are left out.
fn layers(spots: &[SpotRow]) -> Vec<Layer<'_>> {
    let mut out = vec![];
    for group in spots.chunk_by(|a, b| a.layer_index == b.layer_index) {
        let mut index: HashMap<usize, usize> = HashMap::new();
        let mut layer = Layer {
            first: &group[0],
            rows: vec![],
            spots: vec![],
            paintings: 0,
        };
        for r in group.iter().filter(|r| finite_times(r)) {
            let Some(pos) = position(r) else { continue };
            let k = *index.entry(r.spot).or_insert_with(|| {
                layer.spots.push(Spot { pos, total_mu: 0.0 });
                layer.spots.len() - 1
            });
            layer.spots[k].total_mu += mu(r);
            layer.paintings = layer.paintings.max(r.painting + 1);
            layer.rows.push((r, k));
        }
        if !layer.rows.is_empty() {
            out.push(layer);
        }
    }
    out
}

/// `m` rows cut into at most `max` consecutive, non-empty, near-equal batches: `(start, end)`.
fn batches(m: usize, max: usize) -> impl Iterator<Item = (usize, usize)> {
    let b = m.min(max.max(1));
    (0..b).map(move |k| (k * m / b, (k + 1) * m / b))
}

/// Bounding box (min, max) of points.
fn bounds(points: impl IntoIterator<Item = [f32; 2]>) -> Option<([f32; 2], [f32; 2])> {
    points.into_iter().fold(None, |acc, p| {
        let (lo, hi) = acc.unwrap_or((p, p));
        Some((
            [lo[0].min(p[0]), lo[1].min(p[1])],
            [hi[0].max(p[0]), hi[1].max(p[1])],
        ))
    })
}

/// The columns of all layers, built up before sending (one `send_columns` per entity).
#[derive(Default)]
struct Columns {
    /// Layer starts and ends: the layer's spot positions, then none.
    pos_times: Vec<f64>,
    pos_angles: Vec<f64>,
    pos_lengths: Vec<usize>,
    positions: Vec<[f32; 2]>,
    /// Updates (and layer ends): colours of every spot, the highlighted batch, the layer box.
    upd_times: Vec<f64>,
    upd_angles: Vec<f64>,
    color_lengths: Vec<usize>,
    colors: Vec<Color>,
    cur_lengths: Vec<usize>,
    cur_positions: Vec<[f32; 2]>,
    cur_colors: Vec<Color>,
    box_lengths: Vec<usize>,
    box_centers: Vec<[f32; 2]>,
    box_half_sizes: Vec<[f32; 2]>,
    box_labels: Vec<String>,
}

fn painting_text(first: usize, last: usize, paintings: usize) -> String {
    if first == last {
        format!("painting {} of {paintings}", first + 1)
    } else {
        format!("paintings {}–{} of {paintings}", first + 1, last + 1)
    }
}

/// The bursts (counted from 1, like paintings) and spills (indexed as in `--spots`) a batch of
/// rows spans, for the layer's label; empty on a machine without them.
fn structure_text(first: &SpotRow, last: &SpotRow) -> String {
    let span = |name: &str, a: Option<usize>, b: Option<usize>, base: usize| match (a, b) {
        (Some(a), Some(b)) if a == b => format!(", {name} {}", a + base),
        (Some(a), Some(b)) => format!(", {name}s {}–{}", a + base, b + base),
        _ => String::new(),
    };
    span("burst", first.burst, last.burst, 1) + &span("spill", first.spill, last.spill, 0)
}

impl Columns {
    fn add_layer(&mut self, layer: &Layer, energy_mev: Option<f64>, margin: f32) {
        let n = layer.spots.len();
        let m = layer.rows.len();
        let (first_row, last_row) = (layer.rows[0].0, layer.rows[m - 1].0);
        let t_start = first_row.t_start_s;
        // Rows come in delivery order; should they not, no update goes back in time.
        let t_end = layer
            .rows
            .iter()
            .map(|(r, _)| r.t_end_s)
            .fold(t_start, f64::max);

        self.pos_times.extend([t_start, t_end]);
        self.pos_angles
            .extend([first_row.angle_start_deg, last_row.angle_end_deg]);
        self.pos_lengths.extend([n, 0]);
        self.positions.extend(layer.spots.iter().map(|s| s.pos));

        let max_mu = layer.spots.iter().map(|s| s.total_mu).fold(0.0, f64::max);
        let scale = if max_mu > 0.0 { max_mu } else { 1.0 };
        let lit = |mu: f64| viridis(RAMP_FLOOR + (1.0 - RAMP_FLOOR) * mu / scale);
        let (lo, hi) = bounds(layer.spots.iter().map(|s| s.pos)).expect("a drawable layer");
        let center = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
        let half = [
            (hi[0] - lo[0]) / 2.0 + margin,
            (hi[1] - lo[1]) / 2.0 + margin,
        ];
        let f = layer.first;
        let mut title = format!(
            "layer {} (arc {}, cp {}, layer {})",
            f.layer_index, f.arc, f.control_point, f.layer
        );
        if let Some(e) = energy_mev.filter(|e| e.is_finite()) {
            title.push_str(&format!(", {e:.1} MeV"));
        }

        let mut delivered_mu = vec![0.0; n];
        let mut delivered = vec![false; n];
        let mut done = 0;
        let mut t = t_start;
        for (a, b) in batches(m, MAX_SPOT_UPDATES_PER_LAYER) {
            let batch = &layer.rows[a..b];
            for &(r, k) in batch {
                delivered_mu[k] += mu(r);
                done += usize::from(!std::mem::replace(&mut delivered[k], true));
            }
            t = t.max(batch[0].0.t_start_s);
            self.upd_times.push(t);
            self.upd_angles.push(batch[0].0.angle_start_deg);

            self.color_lengths.push(n);
            self.colors.extend((0..n).map(|k| {
                if delivered[k] {
                    lit(delivered_mu[k])
                } else {
                    PENDING
                }
            }));

            // The batch's spots, each once (a batch can hold several paintings of one spot).
            let before = self.cur_positions.len();
            let mut seen: Vec<usize> = batch.iter().map(|&(_, k)| k).collect();
            seen.sort_unstable();
            seen.dedup();
            for k in seen {
                self.cur_positions.push(layer.spots[k].pos);
                self.cur_colors.push(lit(delivered_mu[k]));
            }
            self.cur_lengths.push(self.cur_positions.len() - before);

            let (first, last) = (batch[0].0, batch[batch.len() - 1].0);
            let paintings = painting_text(first.painting, last.painting, layer.paintings)
                + &structure_text(first, last);
            self.box_lengths.push(1);
            self.box_centers.push(center);
            self.box_half_sizes.push(half);
            self.box_labels.push(format!(
                "{title}, {paintings}: {done}/{n} spots, max {max_mu:.3} MU/spot"
            ));
        }
        // The layer ends: nothing is shown until the next one starts.
        self.upd_times.push(t_end);
        self.upd_angles.push(last_row.angle_end_deg);
        self.color_lengths.push(0);
        self.cur_lengths.push(0);
        self.box_lengths.push(0);
    }
}

/// Logs the spots of each layer into `rec` on the delivery's timelines (`time`, `angle_cdeg`):
/// a 2D beam's-eye view of the layer being delivered, its spots lit as they are delivered.
///
/// `spots` are the rows of [`arcsim_sequencer::spot_timeline`] (delivery order; a layer's rows
/// are consecutive). `energies_mev[i]` is the nominal energy of layer `i` (delivery order,
/// e.g. from `Delivery::layers`), named in the layer's label; missing entries (or `&[]`) are left
/// out.
///
/// What is shown (entity paths in [`crate::paths`]; positions in mm in the isocentre plane, with
/// y negated so that +y points up on screen):
/// - [`paths::BEV_SPOTS`]: from the start of a layer's first spot to the end of its last, one
///   point per spot of the layer (a repainted spot is one point). Spots not irradiated yet are
///   grey; the others take a viridis colour by the MU delivered to them so far relative to the
///   layer's largest spot MU (highest MU brightest), so a repainted spot brightens with each
///   painting. At the end of the layer the view clears.
/// - [`paths::BEV_CURRENT`]: the spots being irradiated, drawn larger on top.
/// - [`paths::BEV_LAYER`]: the layer's outline, labelled with its index (and energy), the
///   painting (and the burst and spill, on a machine with them), the spots delivered so far and
///   the largest spot MU.
/// - [`paths::BEV_AXES`] (static): lines through the isocentre across all layers' spots.
///
/// Rows without a position are skipped, and so is a layer without any.
///
/// Batching: redrawing the layer after each of its n spots would log O(n²) colours. Instead a
/// layer's rows are cut into at most [`MAX_SPOT_UPDATES_PER_LAYER`] batches of consecutive rows;
/// at the start of each batch the colours of all spots are logged once (the batch's spots count
/// as delivered) and the batch's spots are highlighted. The positions are logged once per layer
/// (colours are a partial update of the same points), so a layer costs at most
/// `n` positions + 64·n colours + `rows` highlighted points, and a layer of up to 64 rows is
/// shown spot by spot.
pub fn log_spots(
    rec: &RecordingStream,
    spots: &[SpotRow],
    energies_mev: &[f64],
) -> Result<(), ViewerError> {
    let layers = layers(spots);
    if layers.is_empty() {
        return Ok(());
    }
    // The field of all layers, isocentre included.
    let all = layers.iter().flat_map(|l| l.spots.iter().map(|s| s.pos));
    let (lo, hi) = bounds(all.chain([[0.0, 0.0]])).expect("the isocentre at least");
    let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1.0);
    let margin = 0.03 * span;

    let mut c = Columns::default();
    for layer in &layers {
        let energy = energies_mev.get(layer.first.layer_index).copied();
        c.add_layer(layer, energy, margin);
    }

    // Static styling and the axes.
    let pad = 2.0 * margin;
    let (x0, x1, y0, y1) = (lo[0] - pad, hi[0] + pad, lo[1] - pad, hi[1] + pad);
    rec.log_static(
        paths::BEV_AXES,
        &rerun::LineStrips2D::new([[[x0, 0.0], [x1, 0.0]], [[0.0, y0], [0.0, y1]]])
            .with_colors([rgb(60, 60, 60)])
            .with_radii([Radius::new_ui_points(0.5)])
            .with_labels(["x", "y"])
            .with_show_labels(false)
            .with_draw_order(10.0),
    )?;
    rec.log_static(
        paths::BEV_SPOTS,
        &rerun::Points2D::update_fields()
            .with_radii([Radius::new_ui_points(SPOT_RADIUS_PT)])
            .with_draw_order(30.0),
    )?;
    rec.log_static(
        paths::BEV_CURRENT,
        &rerun::Points2D::update_fields()
            .with_radii([Radius::new_ui_points(CURRENT_RADIUS_PT)])
            .with_draw_order(31.0),
    )?;
    rec.log_static(
        paths::BEV_LAYER,
        &rerun::Boxes2D::update_fields()
            .with_colors([rgb(110, 110, 110)])
            .with_radii([Radius::new_ui_points(0.75)])
            .with_show_labels(true)
            .with_draw_order(20.0),
    )?;

    // Temporal: positions per layer, then the updates.
    rec.send_columns(
        paths::BEV_SPOTS,
        index_columns(&c.pos_times, c.pos_angles.iter().copied()),
        rerun::Points2D::update_fields()
            .with_positions(c.positions)
            .columns(c.pos_lengths)?,
    )?;
    let upd_index = || index_columns(&c.upd_times, c.upd_angles.iter().copied());
    rec.send_columns(
        paths::BEV_SPOTS,
        upd_index(),
        rerun::Points2D::update_fields()
            .with_colors(c.colors)
            .columns(c.color_lengths)?,
    )?;
    rec.send_columns(
        paths::BEV_CURRENT,
        upd_index(),
        rerun::Points2D::new(c.cur_positions)
            .with_colors(c.cur_colors)
            .columns(c.cur_lengths)?,
    )?;
    rec.send_columns(
        paths::BEV_LAYER,
        upd_index(),
        rerun::Boxes2D::from_centers_and_half_sizes(c.box_centers, c.box_half_sizes)
            .with_labels(c.box_labels)
            .columns(c.box_lengths)?,
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batches_cover_all_rows_in_order() {
        for m in [1, 2, 63, 64, 65, 1000, 10_007] {
            let b: Vec<_> = batches(m, MAX_SPOT_UPDATES_PER_LAYER).collect();
            assert_eq!(b.len(), m.min(MAX_SPOT_UPDATES_PER_LAYER));
            assert_eq!(b[0].0, 0);
            assert_eq!(b[b.len() - 1].1, m);
            assert!(b.windows(2).all(|w| w[0].1 == w[1].0));
            assert!(b.iter().all(|(s, e)| e > s));
        }
        assert_eq!(batches(0, 64).count(), 0);
    }
}
