//! Where one run of logged beam segments splits into the planned layers: the cut that best
//! fits the layers' MU, angles and the gaps between them (an exhaustive search within a bound),
//! or the longest gaps.

use super::*;

/// `run` with the segments across gaps shorter than [`MIN_LAYER_CHANGE_S`] merged.
pub(super) fn merge_short_gaps(run: &[BeamSegment]) -> Vec<BeamSegment> {
    let mut out: Vec<BeamSegment> = Vec::with_capacity(run.len());
    for sg in run {
        match out.last_mut() {
            Some(last) if sg.start_s - last.end_s < MIN_LAYER_CHANGE_S => {
                last.end_s = sg.end_s;
                last.angle_end_deg = sg.angle_end_deg;
                last.end_uncertain = sg.end_uncertain;
                last.mu = last.mu.zip(sg.mu).map(|(a, b)| a + b);
            }
            _ => out.push(*sg),
        }
    }
    out
}

/// Weight of a cut's gap (per unit of `ln(1 + gap / period)`) against the squared log-ratio of
/// a layer's logged to planned beam-on: enough to choose the longer gap between splits whose
/// times fit alike, too little to cut at a long pause where the times say otherwise.
pub(super) const GAP_WEIGHT: f64 = 0.02;

/// Weight of the MU misfit against the time misfit's: a log's MU are the dose monitor's, exact
/// to its resolution, where a beam-on time leans on the base's beam model; a layer's MU off by
/// 2 % outweighs any gap's length.
pub(super) const MU_FIT_WEIGHT: f64 = 100.0;

/// Cost of a segment irradiated outside its layer's window (plus [`ANGLE_TOLERANCE_DEG`]):
/// larger than any time misfit, so windows decide wherever they differ.
pub(super) const OUTSIDE_WINDOW_COST: f64 = 100.0;

/// A group may last at most this many times its layer's planned beam-on (after the run's
/// scale) plus a few periods: it bounds the search, and a layer that much longer than the
/// plan is beyond what the time can tell (the longest gaps decide then).
pub(super) const MAX_GROUP_RATIO: f64 = 4.0;

/// Most layer × segment end points [`layer_cuts`] searches (a run of 1000 layers in 10,000
/// segments): each visits the segments its layer's time allows.
pub(super) const MAX_SEARCH: usize = 10_000_000;

/// What [`layer_cuts`] weighs each group by, in one unit: the prefix sums of the segments'
/// amounts, each layer's expected amount (after the run's common scale), the floor under both,
/// and the misfit's weight.
pub(super) struct Weighing {
    pub(super) prefix: Vec<f64>,
    pub(super) expected: Vec<f64>,
    pub(super) floor: f64,
    pub(super) weight: f64,
}

/// The MU where the log and the plan both give it (the dose monitor's count, which no beam
/// model can skew), else the beam-on time; scaled by the run's logged over planned amount.
pub(super) fn weighing(run: &[BeamSegment], layers: &[Planned], period_s: f64) -> Weighing {
    let by_mu =
        run.iter().all(|sg| sg.mu.is_some_and(|mu| mu >= 0.0)) && layers.iter().all(|p| p.mu > 0.0);
    let amount = |sg: &BeamSegment| match (by_mu, sg.mu) {
        (true, Some(mu)) => mu,
        _ => (sg.end_s - sg.start_s).max(0.0),
    };
    let planned_amount = |p: &Planned| if by_mu { p.mu } else { p.on_s };
    let floor = if by_mu {
        1e-3 * layers.iter().map(|p| p.mu).sum::<f64>() / layers.len().max(1) as f64
    } else {
        2.0 * period_s.max(1e-6)
    };
    let mut prefix = vec![0.0; run.len() + 1];
    for (i, sg) in run.iter().enumerate() {
        prefix[i + 1] = prefix[i] + amount(sg);
    }
    let planned: f64 = layers.iter().map(planned_amount).sum();
    let logged = prefix[run.len()];
    let scale = if planned > 0.0 && logged > 0.0 {
        logged / planned
    } else {
        1.0
    };
    Weighing {
        prefix,
        expected: layers.iter().map(|p| scale * planned_amount(p)).collect(),
        floor,
        weight: if by_mu { MU_FIT_WEIGHT } else { 1.0 },
    }
}

/// Where a run of segments splits into the run's `layers`: the end (exclusive) of each layer's
/// segments, by the least total misfit (module documentation) over all splits into consecutive
/// groups, found by dynamic programming.
pub(super) fn layer_cuts(run: &[BeamSegment], layers: &[Planned], period_s: f64) -> Vec<usize> {
    let (m, r) = (run.len(), layers.len());
    if r <= 1 || m == r {
        return if r <= 1 { vec![m] } else { (1..=m).collect() };
    }
    // The search visits up to r × m end points; beyond this a run is split at its longest gaps.
    if r.saturating_mul(m) > MAX_SEARCH {
        return longest_gap_cuts(run, r);
    }
    let Weighing {
        prefix,
        expected,
        floor,
        weight,
    } = weighing(run, layers, period_s);
    let outside = |i: usize, p: &Planned| {
        let reach = p.window_deg / 2.0 + ANGLE_TOLERANCE_DEG;
        let seg = run[i];
        [seg.angle_start_deg, seg.angle_end_deg]
            .iter()
            .filter(|&&a| angle_diff_deg(a, p.angle_deg).abs() > reach)
            .count() as f64
    };
    // Outside-window counts per layer as prefix sums over the segments.
    let outside_prefix: Vec<Vec<f64>> = layers
        .iter()
        .map(|p| {
            let mut v = vec![0.0; m + 1];
            for i in 0..m {
                v[i + 1] = v[i] + outside(i, p);
            }
            v
        })
        .collect();
    let gap_bonus = |j: usize| {
        let g = (run[j].start_s - run[j - 1].end_s).max(0.0);
        GAP_WEIGHT * (1.0 + g / period_s.max(1e-6)).ln()
    };
    // best[l][i]: least cost of segments 0..=i as layers 0..=l, layer l ending at i; from[l][i]
    // the first segment of layer l there.
    let mut best = vec![vec![f64::INFINITY; m]; r];
    let mut from = vec![vec![0usize; m]; r];
    for l in 0..r {
        let expected = expected[l];
        let limit = MAX_GROUP_RATIO * expected + 2.0 * floor;
        // Layer l ends at i in [l, m - r + l]; it starts at j in [l, i].
        for i in l..=(m - r + l) {
            let mut j = i;
            loop {
                let on = prefix[i + 1] - prefix[j];
                if on > limit && j < i {
                    break;
                }
                let before = if l == 0 {
                    (j == 0).then_some(0.0)
                } else {
                    Some(best[l - 1][j - 1]).filter(|b| b.is_finite())
                };
                if let Some(before) = before {
                    let fit = weight * ((on + floor) / (expected + floor)).ln().powi(2);
                    let angles =
                        OUTSIDE_WINDOW_COST * (outside_prefix[l][i + 1] - outside_prefix[l][j]);
                    let cut = if l == 0 { 0.0 } else { gap_bonus(j) };
                    let cost = before + fit + angles - cut;
                    if cost < best[l][i] {
                        best[l][i] = cost;
                        from[l][i] = j;
                    }
                }
                if j == l {
                    break;
                }
                j -= 1;
            }
        }
    }
    if !best[r - 1][m - 1].is_finite() {
        return longest_gap_cuts(run, r);
    }
    let mut cuts = vec![m; r];
    let mut i = m - 1;
    for l in (1..r).rev() {
        let j = from[l][i];
        cuts[l - 1] = j;
        i = j - 1;
    }
    cuts
}

/// The cuts at the `layers - 1` longest gaps (when no split keeps every layer within
/// [`MAX_GROUP_RATIO`] of its planned time, or the run is beyond [`MAX_SEARCH`]).
pub(super) fn longest_gap_cuts(run: &[BeamSegment], layers: usize) -> Vec<usize> {
    let mut gaps: Vec<(f64, usize)> = run
        .windows(2)
        .enumerate()
        .map(|(i, w)| (w[1].start_s - w[0].end_s, i + 1))
        .collect();
    gaps.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut cuts: Vec<usize> = gaps
        .iter()
        .take(layers.saturating_sub(1))
        .map(|g| g.1)
        .collect();
    cuts.sort_unstable();
    cuts.push(run.len());
    cuts
}
