//! Seeded, deterministic example plans (synthetic, not clinical) for tests, benchmarks and demos.
//!
//! Same kind and seed give byte-identical JSON on every platform: the PRNG is a self-written
//! splitmix64 and only exactly-rounded float operations (+, -, *, /, round) are used.

use std::fmt;
use std::str::FromStr;

use crate::model::{
    Arc, ArcPlan, ControlPoint, EnergyLayer, RotationDirection, Spots, PLAN_FORMAT,
};

/// The kinds of example plan, each shaped like a typical treatment site.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PlanKind {
    /// 180 control points every 2 deg, one layer each, 100-180 MeV, 10 upward switches.
    Prostate,
    /// 360 control points every 1 deg, 1-3 layers each, 70-160 MeV.
    HeadNeck,
    /// Two sub-arcs, CW then CC (a direction change), one layer each.
    TwoArc,
    /// A 120 deg partial arc, 1-2 layers per control point, spots given by total MU.
    Lung,
}

impl PlanKind {
    /// Every kind.
    pub const ALL: [PlanKind; 4] = [
        PlanKind::Prostate,
        PlanKind::HeadNeck,
        PlanKind::TwoArc,
        PlanKind::Lung,
    ];

    /// The name used on the command line and as the file stem in `plans/`.
    pub fn name(self) -> &'static str {
        match self {
            PlanKind::Prostate => "prostate",
            PlanKind::HeadNeck => "head-neck",
            PlanKind::TwoArc => "two-arc",
            PlanKind::Lung => "lung",
        }
    }
}

impl fmt::Display for PlanKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for PlanKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        PlanKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = PlanKind::ALL.iter().map(|k| k.name()).collect();
                format!(
                    "unknown plan kind \"{s}\"; expected one of {}",
                    names.join(", ")
                )
            })
    }
}

/// Beam timing the spot counts and MU are sized for (the ATOM machine: 5 ms/MU, 2 ms per spot switch).
const S_PER_MU: f64 = 0.005;
const SPOT_SWITCH_S: f64 = 0.002;

/// How spots are written: every spot's MU, or the layer's total MU.
#[derive(Clone, Copy)]
enum SpotStyle {
    PerSpot,
    Total,
}

struct ArcSpec {
    direction: RotationDirection,
    start_deg: f64,
    /// Signed step between control points, degrees.
    step_deg: f64,
    control_points: usize,
    /// Upward energy switches inside this arc.
    upward_switches: usize,
}

impl ArcSpec {
    /// Degrees from the first control point to the last.
    fn span_deg(&self) -> f64 {
        self.step_deg.abs() * (self.control_points - 1) as f64
    }
}

struct Spec {
    arcs: Vec<ArcSpec>,
    layers_per_cp: (u32, u32),
    energy_mev: (f64, f64),
    /// Target irradiation time range per layer under the ATOM beam model, seconds.
    time_s: (f64, f64),
    style: SpotStyle,
    what: &'static str,
}

fn spec(kind: PlanKind) -> Spec {
    let arc = |direction, start_deg, step_deg, control_points, upward_switches| ArcSpec {
        direction,
        start_deg,
        step_deg,
        control_points,
        upward_switches,
    };
    use RotationDirection::{Cc, Cw};
    match kind {
        PlanKind::Prostate => Spec {
            arcs: vec![arc(Cw, 1.0, 2.0, 180, 10)],
            layers_per_cp: (1, 1),
            energy_mev: (100.0, 180.0),
            time_s: (0.06, 0.29),
            style: SpotStyle::PerSpot,
            what: "prostate-like full arc: 180 control points 1..359 deg every 2 deg, one layer each, 100-180 MeV mostly downward with 10 upward switches",
        },
        PlanKind::HeadNeck => Spec {
            arcs: vec![arc(Cw, 0.5, 1.0, 360, 20)],
            layers_per_cp: (1, 3),
            energy_mev: (70.0, 160.0),
            time_s: (0.05, 0.35),
            style: SpotStyle::PerSpot,
            what: "head-and-neck-like full arc: 360 control points 0.5..359.5 deg every 1 deg, 1-3 layers each, 70-160 MeV with 20 upward switches",
        },
        PlanKind::TwoArc => Spec {
            arcs: vec![arc(Cw, 20.0, 4.0, 81, 5), arc(Cc, 340.0, -4.0, 81, 5)],
            layers_per_cp: (1, 1),
            energy_mev: (90.0, 170.0),
            time_s: (0.06, 0.29),
            style: SpotStyle::PerSpot,
            what: "two sub-arcs: CW 20..340 deg then CC 340..20 deg every 4 deg (a direction change), one layer each, 90-170 MeV",
        },
        PlanKind::Lung => Spec {
            arcs: vec![arc(Cw, 150.0, 2.0, 61, 6)],
            layers_per_cp: (1, 2),
            energy_mev: (90.0, 200.0),
            time_s: (0.05, 0.3),
            style: SpotStyle::Total,
            what: "lung-like partial arc: 61 control points 150..270 deg every 2 deg, 1-2 layers each, 90-200 MeV, spots given by total MU",
        },
    }
}

/// splitmix64 (Steele, Lea, Flood 2014): tiny, fast, and good enough for example data.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1) with 53 random bits.
    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// Uniform integer in lo..=hi.
    fn int(&mut self, lo: u32, hi: u32) -> u32 {
        lo + (self.next_u64() % u64::from(hi - lo + 1)) as u32
    }
}

fn round_to(x: f64, step: f64) -> f64 {
    (x / step).round() * step
}

/// Rounds to `decimals` places so the JSON shows short numbers (1e3 is exact, unlike 0.001).
fn round_dec(x: f64, scale: f64) -> f64 {
    (x * scale).round() / scale
}

/// What a user may change of a kind's shape (`generate-plan --spacing/--layers/--energy`): each
/// `None` keeps the kind's own. Large plans for solver tests and benchmarks (e.g. a two-arc plan
/// of some 870 layers: `two-arc`, spacing 2.2°, 2–4 layers per control point) come from these.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Shape {
    /// Degrees between control points; each arc keeps its start angle and its span, so the
    /// number of control points follows (⌊span / spacing⌋ + 1).
    pub spacing_deg: Option<f64>,
    /// Least and most layers per control point (each drawn uniformly).
    pub layers_per_cp: Option<(u32, u32)>,
    /// Lowest and highest energy (MeV); the runs of descending energies span most of it.
    pub energy_mev: Option<(f64, f64)>,
    /// Least and most spot spacing (mm): each layer's grid spacing falls linearly with its
    /// energy across the plan's energy range, from the most at the lowest energy to the least at
    /// the highest (smaller spots at higher energies). 5 mm for every layer when `None`.
    pub spot_spacing_mm: Option<(f64, f64)>,
}

/// The spot spacings [`Shape`] accepts (mm).
pub const SPOT_SPACING_RANGE_MM: (f64, f64) = (0.5, 30.0);

/// The largest number of layers per control point [`Shape`] accepts.
pub const MAX_LAYERS_PER_CP: u32 = 20;
/// The energy range [`Shape`] accepts (MeV): what proton therapy machines deliver, with room.
pub const ENERGY_RANGE_MEV: (f64, f64) = (10.0, 400.0);
/// The narrowest spacing [`Shape`] accepts (deg): finer than any arc plan's control points.
pub const MIN_SPACING_DEG: f64 = 0.1;

/// A [`Shape`] field out of range: which option, what was given, what is expected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{option}: {given} is not allowed; expected {expected}")]
pub struct ShapeError {
    /// The command-line option (`--spacing`, `--layers`, `--energy`).
    pub option: &'static str,
    /// What was given, with its unit.
    pub given: String,
    /// What the option takes.
    pub expected: String,
}

impl Shape {
    /// Checks every field (`kind` for the largest spacing its arcs allow).
    pub fn check(&self, kind: PlanKind) -> Result<(), ShapeError> {
        if let Some(d) = self.spacing_deg {
            let span = spec(kind)
                .arcs
                .iter()
                .map(ArcSpec::span_deg)
                .fold(f64::INFINITY, f64::min);
            if !(d.is_finite() && d >= MIN_SPACING_DEG && d <= span) {
                return Err(ShapeError {
                    option: "--spacing",
                    given: format!("{} deg", crate::fmt_num(d)),
                    expected: format!(
                        "a spacing from {MIN_SPACING_DEG} deg to the {} arc's span, {span} deg",
                        kind.name()
                    ),
                });
            }
        }
        if let Some((lo, hi)) = self.layers_per_cp {
            if !(1 <= lo && lo <= hi && hi <= MAX_LAYERS_PER_CP) {
                return Err(ShapeError {
                    option: "--layers",
                    given: format!("{lo}-{hi}"),
                    expected: format!(
                        "MIN-MAX layers per control point with 1 <= MIN <= MAX <= {MAX_LAYERS_PER_CP}"
                    ),
                });
            }
        }
        if let Some((lo, hi)) = self.energy_mev {
            let (min, max) = ENERGY_RANGE_MEV;
            if !(lo.is_finite() && hi.is_finite() && min <= lo && lo + 1.0 <= hi && hi <= max) {
                return Err(ShapeError {
                    option: "--energy",
                    given: format!("{}-{} MeV", crate::fmt_num(lo), crate::fmt_num(hi)),
                    expected: format!(
                        "LOW-HIGH MeV with {min} <= LOW, LOW + 1 <= HIGH, HIGH <= {max}"
                    ),
                });
            }
        }
        if let Some((lo, hi)) = self.spot_spacing_mm {
            let (min, max) = SPOT_SPACING_RANGE_MM;
            if !(lo.is_finite() && hi.is_finite() && min <= lo && lo <= hi && hi <= max) {
                return Err(ShapeError {
                    option: "--spot-spacing",
                    given: format!("{}-{} mm", crate::fmt_num(lo), crate::fmt_num(hi)),
                    expected: format!("MIN-MAX mm with {min} <= MIN <= MAX <= {max}"),
                });
            }
        }
        Ok(())
    }

    /// The spot spacing of a layer of `energy_mev` in a plan spanning `range_mev`.
    fn spot_spacing(&self, energy_mev: f64, (lo, hi): (f64, f64)) -> f64 {
        match self.spot_spacing_mm {
            None => SPOT_SPACING_MM,
            Some((min, max)) => {
                let f = ((energy_mev - lo) / (hi - lo).max(1e-9)).clamp(0.0, 1.0);
                round_dec(max - (max - min) * f, 1000.0)
            }
        }
    }

    fn is_default(&self) -> bool {
        *self == Shape::default()
    }

    /// `spec` with this shape's fields in place of its own.
    fn applied(&self, mut spec: Spec) -> Spec {
        if let Some(d) = self.spacing_deg {
            for a in &mut spec.arcs {
                let span = a.span_deg();
                // A hair of slack so that a spacing dividing the span exactly reaches its end.
                a.control_points = (span / d + 1e-9).floor() as usize + 1;
                a.step_deg = d.copysign(a.step_deg);
            }
        }
        if let Some(l) = self.layers_per_cp {
            spec.layers_per_cp = l;
        }
        if let Some(e) = self.energy_mev {
            spec.energy_mev = e;
        }
        spec
    }

    /// The options that made a shaped plan, as `generate-plan` takes them.
    fn options(&self) -> String {
        let mut out = String::new();
        if let Some(d) = self.spacing_deg {
            out.push_str(&format!(" --spacing {d}"));
        }
        if let Some((lo, hi)) = self.layers_per_cp {
            out.push_str(&format!(" --layers {lo}-{hi}"));
        }
        if let Some((lo, hi)) = self.energy_mev {
            out.push_str(&format!(" --energy {lo}-{hi}"));
        }
        if let Some((lo, hi)) = self.spot_spacing_mm {
            out.push_str(&format!(" --spot-spacing {lo}-{hi}"));
        }
        out
    }
}

/// Generates the example plan of `kind` from `seed`; deterministic.
pub fn generate(kind: PlanKind, seed: u64) -> ArcPlan {
    build(kind, seed, &Shape::default())
}

/// Generates the example plan of `kind` from `seed` in another `shape`; deterministic (the same
/// kind, seed and shape give the same plan; the default shape gives [`generate`]'s).
pub fn generate_shaped(kind: PlanKind, seed: u64, shape: &Shape) -> Result<ArcPlan, ShapeError> {
    shape.check(kind)?;
    Ok(build(kind, seed, shape))
}

fn build(kind: PlanKind, seed: u64, shape: &Shape) -> ArcPlan {
    let spec = shape.applied(spec(kind));
    let mut rng = SplitMix64(seed ^ 0x5EED_A5C5_1A00_0000);
    let arcs: Vec<Arc> = spec
        .arcs
        .iter()
        .map(|a| {
            let counts: Vec<u32> = (0..a.control_points)
                .map(|_| rng.int(spec.layers_per_cp.0, spec.layers_per_cp.1))
                .collect();
            let total: usize = counts.iter().map(|&n| n as usize).sum();
            let mut energies =
                energy_sequence(&mut rng, total, spec.energy_mev, a.upward_switches).into_iter();
            let control_points = counts
                .iter()
                .enumerate()
                .map(|(i, &n)| ControlPoint {
                    angle_deg: round_dec(a.start_deg + a.step_deg * i as f64, 1e6),
                    required_speed_deg_per_s: None,
                    window_deg: None,
                    layers: (0..n)
                        .map(|_| {
                            let energy_mev = energies.next().unwrap_or(spec.energy_mev.0);
                            let spacing = shape.spot_spacing(energy_mev, spec.energy_mev);
                            EnergyLayer {
                                energy_mev,
                                spots: Some(spots(&mut rng, spec.time_s, spec.style, spacing)),
                                irradiation_time_s: None,
                                switching_time_s: None,
                                window_share: None,
                            }
                        })
                        .collect(),
                })
                .collect();
            Arc {
                direction: a.direction,
                control_points,
            }
        })
        .collect();
    let (what, options) = if shape.is_default() {
        (spec.what.to_string(), String::new())
    } else {
        let layers: usize = arcs
            .iter()
            .flat_map(|a| &a.control_points)
            .map(|cp| cp.layers.len())
            .sum();
        (
            format!(
                "{} reshaped: {} control points every {} deg, {}-{} layers each ({layers} layers), {}-{} MeV",
                kind.name(),
                spec.arcs
                    .iter()
                    .map(|a| a.control_points.to_string())
                    .collect::<Vec<_>>()
                    .join(" + "),
                spec.arcs.first().map_or(0.0, |a| a.step_deg.abs()),
                spec.layers_per_cp.0,
                spec.layers_per_cp.1,
                spec.energy_mev.0,
                spec.energy_mev.1
            ),
            shape.options(),
        )
    };
    ArcPlan {
        format: PLAN_FORMAT.to_string(),
        name: kind.name().to_string(),
        description: Some(format!(
            "Synthetic {what}. Generated by `arcsim generate-plan --kind {} --seed {seed}{options}`; not clinical data.",
            kind.name()
        )),
        arcs,
    }
}

/// `n` energies in 0.1 MeV steps: `upward + 1` strictly descending runs from near the top of the range
/// to near its bottom, so there are exactly `upward` upward switches (as in energy-sequenced arcs).
fn energy_sequence(
    rng: &mut SplitMix64,
    n: usize,
    (lo, hi): (f64, f64),
    upward: usize,
) -> Vec<f64> {
    const MIN_RUN: usize = 3;
    let runs = (upward + 1).min(n / MIN_RUN).max(1);
    let weights: Vec<f64> = (0..runs).map(|_| rng.range(0.7, 1.3)).collect();
    let sum: f64 = weights.iter().sum();
    let mut lengths: Vec<usize> = weights
        .iter()
        .map(|w| ((n as f64 * w / sum).round() as usize).max(MIN_RUN.min(n)))
        .collect();
    // Fix the total, one layer at a time, keeping every run at least MIN_RUN long.
    let mut i = 0;
    while lengths.iter().sum::<usize>() != n {
        let k = i % runs;
        if lengths.iter().sum::<usize>() < n {
            lengths[k] += 1;
        } else if lengths[k] > MIN_RUN {
            lengths[k] -= 1;
        }
        i += 1;
    }
    let span = hi - lo;
    let mut out = Vec::with_capacity(n);
    for len in lengths {
        let top = round_to(hi - 0.15 * span * rng.unit(), 0.1);
        let bottom = round_to(lo + 0.15 * span * rng.unit(), 0.1);
        let step = if len > 1 {
            (top - bottom) / (len - 1) as f64
        } else {
            0.0
        };
        let mut prev = f64::INFINITY;
        for j in 0..len {
            let jitter = if j == 0 || j + 1 == len {
                0.0
            } else {
                rng.range(-0.3, 0.3) * step
            };
            let mut e = round_dec(top - step * j as f64 + jitter, 10.0);
            if e >= prev {
                e = round_dec(prev - 0.1, 10.0);
            }
            out.push(e);
            prev = e;
        }
    }
    out
}

/// Spots sized so the layer takes a time in `time_s` under the ATOM beam model.
fn spots(
    rng: &mut SplitMix64,
    (t_lo, t_hi): (f64, f64),
    style: SpotStyle,
    spacing_mm: f64,
) -> Spots {
    let target = rng.range(t_lo, t_hi);
    // At most 40 % of the layer time goes to switching between spots.
    let max_count = ((0.4 * target / SPOT_SWITCH_S) as u32 + 1).clamp(3, 80);
    let count = rng.int((max_count / 3).max(3), max_count);
    let total_mu = (target - f64::from(count - 1) * SPOT_SWITCH_S) / S_PER_MU;
    match style {
        SpotStyle::Total => Spots {
            count,
            mu: None,
            total_mu: Some(round_dec(total_mu, 1000.0)),
            positions_mm: Some(spot_grid(count, spacing_mm)),
            paintings: None,
        },
        SpotStyle::PerSpot => {
            let weights: Vec<f64> = (0..count).map(|_| rng.range(0.3, 1.7)).collect();
            let sum: f64 = weights.iter().sum();
            let mu = weights
                .iter()
                .map(|w| round_dec(total_mu * w / sum, 1000.0).max(0.02))
                .collect();
            Spots {
                count,
                mu: Some(mu),
                total_mu: None,
                positions_mm: Some(spot_grid(count, spacing_mm)),
                paintings: None,
            }
        }
    }
}

/// Spacing of the generated spot grid unless a [`Shape`] sets it, mm (a typical spot spacing
/// for 3–5 mm sigma spots).
const SPOT_SPACING_MM: f64 = 5.0;

/// `count` spot positions `spacing_mm` apart on a square grid centred on the isocentre, delivered row by row in a
/// serpentine (each row the other way), the usual scanning order. Draws no random numbers, so
/// the spots' MU and everything else generated stay as they were before plans had positions.
fn spot_grid(count: u32, spacing_mm: f64) -> Vec<[f64; 2]> {
    let side = (f64::from(count).sqrt().ceil() as u32).max(1);
    let half = f64::from(side - 1) / 2.0;
    (0..count)
        .map(|i| {
            let (row, k) = (i / side, i % side);
            let col = if row % 2 == 0 { k } else { side - 1 - k };
            [
                (f64::from(col) - half) * spacing_mm,
                (f64::from(row) - half) * spacing_mm,
            ]
        })
        .collect()
}

/// The plan as pretty JSON with arrays of numbers kept on one line, ending in a newline: the form
/// of the files in `plans/`.
pub fn to_json(plan: &ArcPlan) -> String {
    // Serialising these types cannot fail: string keys, strings, numbers, arrays only.
    let pretty = serde_json::to_string_pretty(plan).unwrap_or_default();
    // Arrays of numbers first, then arrays of those (spot positions).
    let flat = inline_arrays(&pretty, is_number_line);
    inline_arrays(&flat, is_number_array_line)
}

/// `text` with every multi-line array whose elements all satisfy `item` written on one line.
fn inline_arrays(text: &str, item: fn(&str) -> bool) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < lines.len() {
        let line = lines[i];
        if line.ends_with('[') {
            // Find the closing bracket; inline the array when every element is an item.
            let mut j = i + 1;
            while j < lines.len() && item(lines[j]) {
                j += 1;
            }
            if j > i + 1 && j < lines.len() && lines[j].trim_start().starts_with(']') {
                let items: Vec<&str> = lines[i + 1..j].iter().map(|l| l.trim()).collect();
                out.push_str(line);
                out.push_str(&items.join(" "));
                out.push_str(lines[j].trim_start());
                out.push('\n');
                i = j + 1;
                continue;
            }
        }
        out.push_str(line);
        out.push('\n');
        i += 1;
    }
    out
}

/// A line holding one array of numbers written on one line (`[1.0, 2.0],`).
fn is_number_array_line(line: &str) -> bool {
    let t = line.trim().trim_end_matches(',');
    t.strip_prefix('[')
        .and_then(|t| t.strip_suffix(']'))
        .is_some_and(|inner| inner.split_whitespace().all(is_number_line))
}

fn is_number_line(line: &str) -> bool {
    let t = line.trim().trim_end_matches(',');
    !t.is_empty() && t.parse::<f64>().is_ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_shape_is_the_kind_itself() {
        for kind in PlanKind::ALL {
            assert_eq!(
                generate_shaped(kind, 4, &Shape::default()),
                Ok(generate(kind, 4))
            );
        }
    }

    #[test]
    fn spot_spacing_falls_with_energy_and_leaves_the_rest_of_the_plan_alone() {
        let shape = Shape {
            energy_mev: Some((70.0, 230.0)),
            spot_spacing_mm: Some((3.0, 8.0)),
            ..Shape::default()
        };
        let spaced = generate_shaped(PlanKind::Lung, 4, &shape).expect("valid shape");
        let plain = generate_shaped(
            PlanKind::Lung,
            4,
            &Shape {
                spot_spacing_mm: None,
                ..shape
            },
        )
        .expect("valid shape");
        let layers = |p: &ArcPlan| -> Vec<EnergyLayer> {
            p.arcs
                .iter()
                .flat_map(|a| &a.control_points)
                .flat_map(|c| c.layers.clone())
                .collect()
        };
        let mut seen = Vec::new();
        for (a, b) in layers(&spaced).iter().zip(layers(&plain)) {
            let (sa, sb) = (
                a.spots.as_ref().expect("spots"),
                b.spots.as_ref().expect("spots"),
            );
            // Only the positions differ; they are the plain grid scaled by the layer's spacing.
            assert_eq!(
                (a.energy_mev, sa.count, &sa.mu, sa.total_mu),
                (b.energy_mev, sb.count, &sb.mu, sb.total_mu)
            );
            let (pa, pb) = (
                sa.positions_mm.as_ref().expect("xy"),
                sb.positions_mm.as_ref().expect("xy"),
            );
            let f = 1.0 - (a.energy_mev - 70.0) / 160.0;
            let spacing = 3.0 + 5.0 * f;
            for (xa, xb) in pa.iter().zip(pb) {
                for k in 0..2 {
                    assert!(
                        (xa[k] - xb[k] * spacing / 5.0).abs() < 0.01,
                        "{xa:?} {xb:?} at {} MeV",
                        a.energy_mev
                    );
                }
            }
            seen.push(spacing);
        }
        let (lo, hi) = seen
            .iter()
            .fold((f64::INFINITY, 0.0_f64), |(l, h), &v| (l.min(v), h.max(v)));
        assert!(lo < 4.0 && hi > 7.0, "{lo}-{hi}");
        let bad = Shape {
            spot_spacing_mm: Some((8.0, 3.0)),
            ..Shape::default()
        };
        let e = generate_shaped(PlanKind::Lung, 4, &bad).expect_err("MIN above MAX");
        assert_eq!(e.to_string(), "--spot-spacing: 8-3 mm is not allowed; expected MIN-MAX mm with 0.5 <= MIN <= MAX <= 30");
    }

    #[test]
    fn a_shape_sets_spacing_layers_and_energies() {
        let shape = Shape {
            spacing_deg: Some(3.0),
            layers_per_cp: Some((2, 4)),
            energy_mev: Some((70.0, 230.0)),
            spot_spacing_mm: None,
        };
        let plan = generate_shaped(PlanKind::Prostate, 9, &shape).expect("valid shape");
        let cps = &plan.arcs[0].control_points;
        // 1..359 deg: a span of 358 deg every 3 deg.
        assert_eq!(cps.len(), 120);
        assert_eq!(cps[0].angle_deg, 1.0);
        assert!((cps[1].angle_deg - 4.0).abs() < 1e-12);
        let mut counts = [0usize; 5];
        for cp in cps {
            counts[cp.layers.len()] += 1;
            for l in &cp.layers {
                assert!((70.0..=230.0).contains(&l.energy_mev), "{}", l.energy_mev);
            }
        }
        assert_eq!(counts[0] + counts[1], 0);
        assert!(
            counts[2] > 0 && counts[3] > 0 && counts[4] > 0,
            "{counts:?}"
        );
        let all: Vec<f64> = cps
            .iter()
            .flat_map(|cp| &cp.layers)
            .map(|l| l.energy_mev)
            .collect();
        let (lo, hi) = all
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), &e| (a.min(e), b.max(e)));
        assert!(lo < 70.0 + 0.15 * 160.0 + 1.0 && hi > 230.0 - 0.15 * 160.0 - 1.0);
    }

    #[test]
    fn shapes_out_of_range_are_refused_naming_the_option() {
        let bad = [
            (
                Shape {
                    spacing_deg: Some(f64::NAN),
                    ..Default::default()
                },
                "--spacing",
            ),
            (
                Shape {
                    spacing_deg: Some(0.05),
                    ..Default::default()
                },
                "--spacing",
            ),
            (
                Shape {
                    spacing_deg: Some(121.0),
                    ..Default::default()
                },
                "--spacing",
            ),
            (
                Shape {
                    layers_per_cp: Some((0, 2)),
                    ..Default::default()
                },
                "--layers",
            ),
            (
                Shape {
                    layers_per_cp: Some((3, 2)),
                    ..Default::default()
                },
                "--layers",
            ),
            (
                Shape {
                    layers_per_cp: Some((1, 21)),
                    ..Default::default()
                },
                "--layers",
            ),
            (
                Shape {
                    energy_mev: Some((70.0, 70.5)),
                    ..Default::default()
                },
                "--energy",
            ),
            (
                Shape {
                    energy_mev: Some((5.0, 200.0)),
                    ..Default::default()
                },
                "--energy",
            ),
            (
                Shape {
                    energy_mev: Some((70.0, f64::INFINITY)),
                    ..Default::default()
                },
                "--energy",
            ),
        ];
        for (shape, option) in bad {
            // Lung spans 120 deg.
            let e = generate_shaped(PlanKind::Lung, 1, &shape).expect_err("refused");
            assert_eq!(e.option, option, "{shape:?}");
        }
        let edge = Shape {
            spacing_deg: Some(120.0),
            ..Default::default()
        };
        let plan = generate_shaped(PlanKind::Lung, 1, &edge).expect("the whole span");
        assert_eq!(plan.arcs[0].control_points.len(), 2);
    }
}
