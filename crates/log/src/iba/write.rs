//! Writing a simulated delivery as an IBA-style log: the files the reader takes, in the layout
//! the public readers parse (docs/records.md#iba-logs). The nozzle's constants are invented
//! ([`IbaNozzle::default`]); no vendor file is copied.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::PathBuf;

use arcsim_sequencer::{Delivery, LayerRow, SpotRow};

use super::time::{format_element_stamp, format_stamp};
use super::{BURST_PERIOD_S, SAMPLE_PERIOD_S};

/// Which of the recorder's layouts a written log takes (docs/records.md#iba-logs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum IbaLayout {
    /// `map_record` files of a row per 0.25 ms: `SUBMAP_NUMBER`, `TIME`, positions, charge.
    #[default]
    Rows,
    /// `map_record` files in the element layout: an element per 0.25 ms of a spot, with its
    /// `SPOT_ID` and a microsecond `FPGA_COUNT`, the layer's first stamped in
    /// `START_IRRADIATION`.
    Elements,
    /// A synchrocyclotron's `burst_record` files: the element layout with one element per
    /// 1 ms beam pulse.
    Bursts,
}

impl std::str::FromStr for IbaLayout {
    type Err = String;

    /// `rows`, `elements` or `bursts`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "rows" => Ok(IbaLayout::Rows),
            "elements" => Ok(IbaLayout::Elements),
            "bursts" => Ok(IbaLayout::Bursts),
            _ => Err(format!("`{s}`; expected rows, elements or bursts")),
        }
    }
}

impl IbaLayout {
    /// The time between elements (or rows), s.
    fn period_s(self) -> f64 {
        match self {
            IbaLayout::Rows | IbaLayout::Elements => SAMPLE_PERIOD_S,
            IbaLayout::Bursts => BURST_PERIOD_S,
        }
    }
}

/// The nozzle and chamber a written log pretends to come from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IbaNozzle {
    /// Charge the primary chamber collects per MU at reference conditions, C.
    pub charge_per_mu_c: f64,
    /// Source-to-axis distances, mm: [physics X, physics Y].
    pub sad_mm: [f64; 2],
    /// Chamber-to-isocentre distances, mm: [physics X, physics Y].
    pub ic_to_iso_mm: [f64; 2],
    /// The chamber's offsets, mm: [physics X, physics Y].
    pub ic_offset_mm: [f64; 2],
    /// The chamber's temperature (K) and pressure (hPa) during the delivery.
    pub temperature_k: f64,
    /// See `temperature_k`.
    pub pressure_hpa: f64,
}

impl Default for IbaNozzle {
    /// Invented values of a plausible size (a fixture's, not a machine's).
    fn default() -> Self {
        IbaNozzle {
            charge_per_mu_c: 3.0e-9,
            sad_mm: [2300.0, 1900.0],
            ic_to_iso_mm: [1150.0, 1150.0],
            ic_offset_mm: [0.3, -0.2],
            temperature_k: 296.0,
            pressure_hpa: 1005.0,
        }
    }
}

impl IbaNozzle {
    /// The chamber's charge per MU relative to its reference conditions: (p · T_ref) / (T ·
    /// p_ref), the air density the reader corrects for.
    fn correction(&self) -> f64 {
        (self.pressure_hpa * super::DEFAULT_REFERENCE_TEMPERATURE_K)
            / (self.temperature_k * super::DEFAULT_REFERENCE_PRESSURE_HPA)
    }
}

/// Seconds since 1970-01-01 of `YYYYMMDDHHMMSS` (the `--record-start` format).
pub fn start_seconds(digits: &str) -> Result<f64, String> {
    let ok = digits.len() == 14 && digits.bytes().all(|b| b.is_ascii_digit());
    if !ok {
        return Err(format!("`{digits}`; expected YYYYMMDDHHMMSS"));
    }
    let text = format!(
        "{}/{}/{} {}:{}:{}",
        &digits[6..8],
        &digits[4..6],
        &digits[0..4],
        &digits[8..10],
        &digits[10..12],
        &digits[12..14]
    );
    super::time::parse_stamp(&text).map(|s| s.seconds())
}

/// A layer's range written into its `map_specif`, g/cm² of water by the Bragg–Kleeman rule
/// R = 0.0022·E^1.77 (a textbook fit; written for the layout only, never read back).
fn range_g_cm2(energy_mev: f64) -> f64 {
    0.0022 * energy_mev.powf(1.77)
}

/// The files of the IBA-style log of `delivery` (its spot deliveries `spots`, the delivery
/// starting `start_s` seconds after 1970-01-01) in the recorder's `layout`: paths relative to
/// the log's folder (one `beam_NN` folder per arc) and their text.
pub fn iba_log_files(
    delivery: &Delivery,
    spots: &[SpotRow],
    start_s: f64,
    nozzle: &IbaNozzle,
    layout: IbaLayout,
) -> Vec<(PathBuf, String)> {
    let stamp_name = |t: f64| {
        // ddMMyyyy HH:MM:SS.fff → yyyyMMdd_HHMMSS_fff
        let s = format_stamp(start_s + t);
        format!(
            "{}{}{}_{}{}{}_{}",
            &s[6..10],
            &s[3..5],
            &s[0..2],
            &s[11..13],
            &s[14..16],
            &s[17..19],
            &s[20..23]
        )
    };
    let mut files = Vec::new();
    // Each layer's spot deliveries, in their order.
    let mut by_layer: BTreeMap<usize, Vec<&SpotRow>> = BTreeMap::new();
    for s in spots {
        by_layer.entry(s.layer_index).or_default().push(s);
    }
    let arcs: Vec<usize> = {
        let mut a: Vec<usize> = delivery.layers.iter().map(|l| l.arc).collect();
        a.dedup();
        a
    };
    for arc in arcs {
        let dir = PathBuf::from(format!("beam_{:02}", arc + 1));
        let layers: Vec<_> = delivery.layers.iter().filter(|l| l.arc == arc).collect();
        let Some(first) = layers.first() else {
            continue;
        };
        let angle = |t: f64| {
            delivery
                .timeline
                .as_ref()
                .map_or(first.angle_deg, |tl| tl.state_at(t).angle_deg)
                .rem_euclid(360.0)
        };
        let name0 = stamp_name(first.t_start_s);
        for (file, text) in beam_files(arc, angle(first.t_start_s), nozzle, layout) {
            files.push((dir.join(format!("{file}.{name0}.csv")), text));
        }
        let mut events = String::new();
        for (n, layer) in layers.iter().enumerate() {
            for (t, kind) in [(layer.t_start_s, "START"), (layer.t_end_s, "END")] {
                let _ = writeln!(
                    events,
                    "{},recordEvent,{kind}_ARC_ANGLE_IRRADIATION,Target={:.3} Actual={:.3}",
                    format_stamp(start_s + t),
                    layer.angle_deg.rem_euclid(360.0),
                    angle(t)
                );
            }
            let layer_spots = by_layer.get(&layer.index).map_or(&[][..], Vec::as_slice);
            let name = stamp_name(layer.t_start_s);
            for (file, text) in
                layer_files(layer, layer_spots, (n, &name), start_s, (nozzle, layout))
            {
                files.push((dir.join(file), text));
            }
        }
        files.push((dir.join(format!("events.{name0}.csv")), events));
    }
    files
}

/// The beam file and `beam_config` of arc `arc` (its gantry angle at the first beam on), named
/// without their stamp.
fn beam_files(
    arc: usize,
    angle_deg: f64,
    nozzle: &IbaNozzle,
    layout: IbaLayout,
) -> [(&'static str, String); 2] {
    let beam = format!(
        "<PatientId>arcsim-fixture</PatientId>\n<mBeamId>arc{}</mBeamId>\n<mGantryAngle>{angle_deg:.3}</mGantryAngle>\ntemperature,K,{}\nreferenceTemperature,K,{}\npressure,hPa,{}\nreferencePressure,hPa,{}\ndoseCorrectionFactor,,1\n",
        arc + 1,
        nozzle.temperature_k,
        super::DEFAULT_REFERENCE_TEMPERATURE_K,
        nozzle.pressure_hpa,
        super::DEFAULT_REFERENCE_PRESSURE_HPA
    );
    // A synchrocyclotron's config gives its SADs one axis per line.
    let [sx, sy] = nozzle.sad_mm;
    let sad = if layout == IbaLayout::Bursts {
        format!("IC23 geometry;SAD_IC_X according scanalgo;{sx}\nIC23 geometry;SAD_IC_Y according scanalgo;{sy}")
    } else {
        format!("IC23 geometry;SAD parameter;{sx},{sy}")
    };
    let config = format!(
        "description;parameter;value\n{sad}\nIC23 geometry;distanceFromIcToIsocenter;{},{}\nchargePerMUIC2;Charge per MU on IC2;{:e}\n",
        nozzle.ic_to_iso_mm[0], nozzle.ic_to_iso_mm[1], nozzle.charge_per_mu_c
    );
    [("beam", beam), ("beam_config", config)]
}

/// The specif and record files of the `n`-th layer of a beam (`name` its start's stamp in file
/// names), its spot deliveries `spots`.
fn layer_files(
    layer: &LayerRow,
    spots: &[&SpotRow],
    (n, name): (usize, &str),
    start_s: f64,
    (nozzle, layout): (&IbaNozzle, IbaLayout),
) -> [(String, String); 2] {
    let correction = nozzle.correction();
    let range = range_g_cm2(layer.energy_mev);
    let [ox, oy] = nozzle.ic_offset_mm;
    // A phase of the sampling grid that differs from layer to layer.
    let phase = (layer.index as f64 * 0.618_033_988_75).fract() * layout.period_s();
    let (specif, record, text, offsets) = match layout {
        IbaLayout::Rows => (
            format!("map_specif_{n:04}_part_01.{name}.csv"),
            format!("map_record_{n:04}_part_01.{name}.csv"),
            record_text(spots, (start_s, phase), n, nozzle, correction),
            "[SMX_OFFSET],[SMY_OFFSET],[ICX_OFFSET],[ICY_OFFSET]",
        ),
        IbaLayout::Elements => (
            format!("map_specif_{n:04}_part_01.{name}.csv"),
            format!("map_record_{n:04}_part_01.{name}.csv"),
            element_text(spots, (start_s, phase), n, layout, (nozzle, correction)),
            "[SMX_OFFSET],[SMY_OFFSET],[ICX_OFFSET],[ICY_OFFSET]",
        ),
        IbaLayout::Bursts => (
            format!("{name}.burst_specif_{n:04}_01.csv"),
            format!("{name}.burst_record_{n:04}_01.csv"),
            element_text(spots, (start_s, phase), n, layout, (nozzle, correction)),
            // The form REGGUI's S2C2 reader takes.
            "SMX_OFFSET,SMY_OFFSET,ICX_OFFSET,ICY_OFFSET",
        ),
    };
    [
        (
            specif,
            format!("LAYER_ID,RANGE,NB_PAINTS\n{n},{range:.4},1\n{offsets}\n0,0,{ox},{oy}\n"),
        ),
        (record, text),
    ]
}

/// One layer's `map_record`: 10 header lines, the column names, a row per 0.25 ms from 1 ms
/// before the first spot to 1 ms after the last, a blank line and 10 footer lines.
fn record_text(
    spots: &[&SpotRow],
    (start_s, phase): (f64, f64),
    n: usize,
    nozzle: &IbaNozzle,
    correction: f64,
) -> String {
    let mut s = String::new();
    let (Some(first), Some(last)) = (spots.first(), spots.last()) else {
        return s;
    };
    let _ = writeln!(
        s,
        "beamline,arcsim fixture in the layout of IBA-style map_record files (not a vendor file)"
    );
    let _ = writeln!(s, "layerId,{n}");
    let _ = writeln!(s, "partId,1");
    let _ = writeln!(s, "samplingPeriodUs,250");
    for k in 0..6 {
        let _ = writeln!(s, "reserved,{k}");
    }
    s.push_str("SUBMAP_NUMBER,TIME,X_WIDTH(mm),Y_WIDTH(mm),X_POSITION(mm),Y_POSITION(mm),DOSE_PRIM(C),X_POSITION_IC1(mm),Y_POSITION_IC1(mm)\n");
    let g0 = ((first.t_start_s - 1e-3) / SAMPLE_PERIOD_S).floor() * SAMPLE_PERIOD_S - phase;
    let k_of = |t: f64| ((t - g0) / SAMPLE_PERIOD_S).ceil() as i64;
    let k_end = k_of(last.t_end_s + 1e-3);
    let mut spot = 0;
    let mut submap = 0;
    for k in 0..k_end {
        let t = g0 + k as f64 * SAMPLE_PERIOD_S;
        while spot < spots.len() && spots[spot].t_end_s <= t {
            spot += 1;
            submap += 1;
        }
        let stamp = format_stamp(start_s + t);
        match spots.get(spot).filter(|sp| sp.t_start_s <= t) {
            Some(sp) => {
                let rows = (k_of(sp.t_end_s) - k_of(sp.t_start_s)).max(1) as f64;
                let charge = sp.mu * nozzle.charge_per_mu_c * correction / rows;
                let (px, py) = chamber_position(sp, nozzle);
                let _ = writeln!(
                    s,
                    "{submap},{stamp},4.0,4.0,{px:.4},{py:.4},{charge:.6e},{px:.4},{py:.4}"
                );
            }
            None => {
                let _ = writeln!(s, "-1,{stamp},0,0,-10000,-10000,0,-10000,-10000");
            }
        }
    }
    s.push('\n');
    let _ = writeln!(s, "endOfRecord,{}", format_stamp(start_s + last.t_end_s));
    for k in 0..9 {
        let _ = writeln!(s, "reserved,{k}");
    }
    s
}

/// A spot's position on the chamber in physics coordinates (mm): IEC gantry x is physics Y,
/// y is physics X.
fn chamber_position(sp: &SpotRow, nozzle: &IbaNozzle) -> (f64, f64) {
    let scale =
        |axis: usize| nozzle.sad_mm[axis] / (nozzle.sad_mm[axis] - nozzle.ic_to_iso_mm[axis]);
    (
        sp.y_mm.unwrap_or(0.0) / scale(0) + nozzle.ic_offset_mm[0],
        sp.x_mm.unwrap_or(0.0) / scale(1) + nozzle.ic_offset_mm[1],
    )
}

/// One layer's record in the element layout: a few header lines, `START_IRRADIATION` (the
/// layer's first element), the column names and an element per grid point (`layout`'s period,
/// from `phase`) inside each spot's delivery, at least one per spot; a microsecond counter of
/// 23 bits that runs on across files; a blank line and footer lines.
fn element_text(
    spots: &[&SpotRow],
    (start_s, phase): (f64, f64),
    n: usize,
    layout: IbaLayout,
    (nozzle, correction): (&IbaNozzle, f64),
) -> String {
    // The grid in whole microseconds, so that the counter steps by exactly one period.
    let (period_us, phase_us) = (
        (layout.period_s() * 1e6).round() as i64,
        (phase * 1e6).round() as i64,
    );
    let grid_us = |k: i64| k * period_us - phase_us;
    let grid = |k: i64| grid_us(k) as f64 * 1e-6;
    let first_at_or_after =
        |t: f64| ((t * 1e6 + phase_us as f64) / period_us as f64 - 1e-9).ceil() as i64;
    // Each spot's elements: the grid points in [start, end), at least one (the first free one
    // from its start: a spot shorter than the period cannot be recorded as it was).
    let mut elements: Vec<(usize, i64)> = Vec::new();
    for (id, sp) in spots.iter().enumerate() {
        let mut k = first_at_or_after(sp.t_start_s);
        if let Some(&(_, last)) = elements.last() {
            k = k.max(last + 1);
        }
        let from = elements.len();
        while grid(k) < sp.t_end_s || elements.len() == from {
            elements.push((id, k));
            k += 1;
        }
    }
    let start_us = (start_s * 1e6).round() as i64;
    let mut s = String::new();
    let Some(&(_, k0)) = elements.first() else {
        return s;
    };
    let kind = if layout == IbaLayout::Bursts {
        "burst_record"
    } else {
        "map_record"
    };
    let _ = writeln!(
        s,
        "beamline,arcsim fixture in the element layout of IBA-style {kind} files (not a vendor file)"
    );
    let _ = writeln!(s, "layerId,{n}");
    let _ = writeln!(s, "START_IRRADIATION,NB_ELEMENTS");
    let _ = writeln!(
        s,
        "{},{}",
        format_element_stamp(start_s + grid(k0)),
        elements.len()
    );
    s.push_str("#ELEMENT_ID,TIME,SPOT_ID,FPGA_COUNT,PRIM_IC_X_POSITION,PRIM_IC_Y_POSITION,PRIM_IC_CHARGE\n");
    let mut counts = vec![0.0; spots.len()];
    for (id, _) in &elements {
        counts[*id] += 1.0;
    }
    for (e, &(id, k)) in elements.iter().enumerate() {
        let t = start_s + grid(k);
        let count = (start_us + grid_us(k)).rem_euclid(super::COUNTER_WRAP_US);
        let (px, py) = chamber_position(spots[id], nozzle);
        let charge = spots[id].mu * nozzle.charge_per_mu_c * correction / counts[id];
        let _ = writeln!(
            s,
            "{},{},{},{count},{px:.4},{py:.4},{charge:.6e}",
            e + 1,
            format_element_stamp(t),
            id + 1
        );
    }
    s.push('\n');
    for k in 0..5 {
        let _ = writeln!(s, "reserved,{k}");
    }
    s
}
