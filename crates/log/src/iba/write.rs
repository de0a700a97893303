//! Writing a simulated delivery as an IBA-style log: the files the reader takes, in the layout
//! the public readers parse (docs/records.md#iba-logs). The nozzle's constants are invented
//! ([`IbaNozzle::default`]); no vendor file is copied.

use std::fmt::Write as _;
use std::path::PathBuf;

use arcsim_sequencer::{Delivery, SpotRow};

use super::time::format_stamp;
use super::SAMPLE_PERIOD_S;

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
/// starting `start_s` seconds after 1970-01-01): paths relative to the log's folder (one
/// `beam_NN` folder per arc) and their text.
pub fn iba_log_files(
    delivery: &Delivery,
    spots: &[SpotRow],
    start_s: f64,
    nozzle: &IbaNozzle,
) -> Vec<(PathBuf, String)> {
    let correction = (nozzle.pressure_hpa * super::DEFAULT_REFERENCE_TEMPERATURE_K)
        / (nozzle.temperature_k * super::DEFAULT_REFERENCE_PRESSURE_HPA);
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
        files.push((
            dir.join(format!("beam.{name0}.csv")),
            format!(
                "<PatientId>arcsim-fixture</PatientId>\n<BeamName>arc {}</BeamName>\n<GantryAngle>{:.3}</GantryAngle>\ntemperature,K,{}\nreferenceTemperature,K,{}\npressure,hPa,{}\nreferencePressure,hPa,{}\ndoseCorrectionFactor,,1\n",
                arc + 1,
                angle(first.t_start_s),
                nozzle.temperature_k,
                super::DEFAULT_REFERENCE_TEMPERATURE_K,
                nozzle.pressure_hpa,
                super::DEFAULT_REFERENCE_PRESSURE_HPA
            ),
        ));
        files.push((
            dir.join(format!("beam_config.{name0}.csv")),
            format!(
                "description;parameter;value\nIC23 geometry;SAD parameter;{},{}\nIC23 geometry;distanceFromIcToIsocenter;{},{}\nchargePerMUIC2;Charge per MU on IC2;{:e}\n",
                nozzle.sad_mm[0], nozzle.sad_mm[1], nozzle.ic_to_iso_mm[0], nozzle.ic_to_iso_mm[1], nozzle.charge_per_mu_c
            ),
        ));
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
            let layer_spots: Vec<&SpotRow> = spots
                .iter()
                .filter(|s| s.layer_index == layer.index)
                .collect();
            let name = stamp_name(layer.t_start_s);
            files.push((
                dir.join(format!("map_specif_{n:04}_part_01.{name}.csv")),
                format!(
                    "LAYER_ID,RANGE,NB_PAINTS\n{n},{:.4},1\n[SMX_OFFSET],[SMY_OFFSET],[ICX_OFFSET],[ICY_OFFSET]\n0,0,{},{}\n",
                    range_g_cm2(layer.energy_mev),
                    nozzle.ic_offset_mm[0],
                    nozzle.ic_offset_mm[1]
                ),
            ));
            // A phase of the sampling grid that differs from layer to layer.
            let phase = (layer.index as f64 * 0.618_033_988_75).fract() * SAMPLE_PERIOD_S;
            files.push((
                dir.join(format!("map_record_{n:04}_part_01.{name}.csv")),
                record_text(&layer_spots, (start_s, phase), n, nozzle, correction),
            ));
        }
        files.push((dir.join(format!("events.{name0}.csv")), events));
    }
    files
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
    let scale =
        |axis: usize| nozzle.sad_mm[axis] / (nozzle.sad_mm[axis] - nozzle.ic_to_iso_mm[axis]);
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
                // IEC gantry x is physics Y; y is physics X.
                let px = sp.y_mm.unwrap_or(0.0) / scale(0) + nozzle.ic_offset_mm[0];
                let py = sp.x_mm.unwrap_or(0.0) / scale(1) + nozzle.ic_offset_mm[1];
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
