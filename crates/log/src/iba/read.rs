//! Reading an IBA-style beam folder: each file's layout as the public readers (REGGUI's
//! `load_PBS_logs.m`, OncoRay's `logfile_extractor.py`) read it; every problem named by file
//! and line.

use std::path::{Path, PathBuf};

use super::element::{is_element_layout, read_element_spots};
use super::events::{check_events, read_events};
use super::settings::{read_beam_file, read_config, read_specif, BeamFile, Config};
use super::time::parse_stamp;
use super::{IbaBeam, IbaLayer, IbaLog, IbaSpot, BURST_PERIOD_S, SAMPLE_PERIOD_S};
use crate::LogError;

/// A chamber position at or below this, mm, is the recorder's "no position" (-10000).
const NO_POSITION_MM: f64 = -1000.0;

/// Whether `path` is a folder (read as an IBA-style log rather than a CSV or DICOM file).
pub fn is_iba_folder(path: &Path) -> bool {
    path.is_dir()
}

/// Reads the IBA-style log at `dir`: a beam folder (holding `map_record_*` files), or a folder
/// of beam folders (one per arc, in name order).
pub fn read_iba_log(dir: &Path) -> Result<IbaLog, LogError> {
    let source = dir.display().to_string();
    let mut notes = Vec::new();
    let folders = if list(dir)?.iter().any(|p| is_record(p)) {
        vec![dir.to_path_buf()]
    } else {
        let mut subs: Vec<PathBuf> = list_entries(dir)?
            .into_iter()
            .filter(|p| p.is_dir())
            .collect();
        subs.sort();
        let beams: Vec<PathBuf> = subs
            .into_iter()
            .filter(|d| list(d).is_ok_and(|f| f.iter().any(|p| is_record(p))))
            .collect();
        if beams.is_empty() {
            return Err(LogError::file(
                &source,
                "no map_record_* file here or in a folder below; expected an IBA-style beam folder (map_record_NNNN_part_MM files, beam_config, beam, events) or a folder of them",
            ));
        }
        beams
    };
    let mut origin = None;
    let beams = folders
        .iter()
        .map(|f| read_beam(f, &mut notes, &mut origin))
        .collect::<Result<Vec<_>, _>>()?;
    let mut log = IbaLog {
        source,
        beams,
        notes,
    };
    rebase(&mut log);
    Ok(log)
}

fn list_entries(dir: &Path) -> Result<Vec<PathBuf>, LogError> {
    let name = dir.display().to_string();
    let rd = std::fs::read_dir(dir)
        .map_err(|e| LogError::file(&name, format!("cannot read the folder: {e}")))?;
    let mut out = Vec::new();
    for entry in rd {
        let entry =
            entry.map_err(|e| LogError::file(&name, format!("cannot read the folder: {e}")))?;
        out.push(entry.path());
    }
    Ok(out)
}

/// The folder's files, in name order.
fn list(dir: &Path) -> Result<Vec<PathBuf>, LogError> {
    let mut files: Vec<PathBuf> = list_entries(dir)?
        .into_iter()
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    Ok(files)
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// A layer's record: `map_record_*` (the 250 µs rows or the element layout) or, from a
/// synchrocyclotron's recorder, `burst_record_*`; tuning records are not the plan's spots.
fn is_record(p: &Path) -> bool {
    let n = file_name(p);
    (n.contains("map_record_") || n.contains("burst_record_"))
        && !n.contains("tuning")
        && !n.starts_with('.')
}

/// The kind of record file `name` is (`map_record_` or `burst_record_`) and its specif's.
fn record_kind(name: &str) -> (&'static str, &'static str) {
    if name.contains("burst_record_") {
        ("burst_record_", "burst_specif_")
    } else {
        ("map_record_", "map_specif_")
    }
}

pub(super) fn read_text(p: &Path) -> Result<String, LogError> {
    let name = p.display().to_string();
    let len = std::fs::metadata(p)
        .map_err(|e| LogError::file(&name, format!("cannot open: {e}")))?
        .len();
    if len > crate::MAX_LOG_BYTES {
        return Err(LogError::file(
            &name,
            format!("{len} bytes; expected at most {}", crate::MAX_LOG_BYTES),
        ));
    }
    let bytes = std::fs::read(p).map_err(|e| LogError::file(&name, format!("cannot read: {e}")))?;
    String::from_utf8(bytes).map_err(|e| {
        LogError::file(
            &name,
            format!(
                "not text (invalid UTF-8 at byte {}); expected a CSV file",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

/// The layer number and part of `map_record_NNNN_part_MM…` (or `map_specif_…`), or of
/// `burst_record_NNNN_MM…` (or `burst_specif_…`).
fn layer_and_part(name: &str, kind: &str) -> Option<(u32, u32)> {
    let rest = &name[name.find(kind)? + kind.len()..];
    let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
    let layer = digits.parse().ok()?;
    let after = &rest[digits.len()..];
    let part_digits = |from: &str| -> Option<u32> {
        let d: String = from.chars().take_while(char::is_ascii_digit).collect();
        d.parse().ok()
    };
    let part = if let Some(i) = after.find("_part_") {
        part_digits(&after[i + 6..])
    } else if kind.starts_with("burst") {
        after.strip_prefix('_').and_then(part_digits)
    } else {
        None
    };
    Some((layer, part.unwrap_or(1)))
}

/// A data line of a record, split at its commas, for reading its fields by column with errors
/// that name the file, the line and the column.
pub(super) struct CsvRow<'a> {
    pub fields: Vec<&'a str>,
    /// How many columns the header names.
    pub width: usize,
    pub name: &'a str,
    pub line: u64,
}

impl<'a> CsvRow<'a> {
    /// Column `c`'s field (`what` names it in an error).
    pub fn get(&self, c: usize, what: &str) -> Result<&'a str, LogError> {
        self.fields.get(c).copied().ok_or_else(|| {
            LogError::at(
                self.name,
                self.line,
                Some(what),
                format!("{} fields; expected {}", self.fields.len(), self.width),
            )
        })
    }

    /// Column `c`'s field as a finite number.
    pub fn number(&self, c: usize, what: &str) -> Result<f64, LogError> {
        let s = self.get(c, what)?;
        s.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| {
                LogError::at(
                    self.name,
                    self.line,
                    Some(what),
                    format!("`{s}`; expected a number"),
                )
            })
    }
}

/// One `map_record` row.
struct Row {
    submap: i64,
    /// The stamp, s after the log's origin, and its resolution.
    t_s: f64,
    resolution_s: f64,
    /// Physics X and Y on the chamber, mm.
    pos: [f64; 2],
    charge_c: f64,
    line: u64,
}

fn read_rows(name: &str, text: &str, origin: &mut Option<i64>) -> Result<Vec<Row>, LogError> {
    let mut lines = text.lines().enumerate();
    let header = loop {
        match lines.next() {
            Some((i, l)) if l.contains("SUBMAP_NUMBER") => break (i as u64 + 1, l),
            Some(_) => {}
            None => {
                return Err(LogError::file(name, "no header line with SUBMAP_NUMBER; expected a map_record file (SUBMAP_NUMBER, TIME, X_POSITION(mm), Y_POSITION(mm), DOSE_PRIM(C))"));
            }
        }
    };
    let head: Vec<&str> = header.1.split(',').map(str::trim).collect();
    let col = |h: &str| {
        head.iter().position(|x| *x == h).ok_or_else(|| {
            LogError::at(name, header.0, None, format!("no column `{h}`; expected SUBMAP_NUMBER, TIME, X_POSITION(mm), Y_POSITION(mm), DOSE_PRIM(C)"))
        })
    };
    let cols = [
        col("SUBMAP_NUMBER")?,
        col("TIME")?,
        col("X_POSITION(mm)")?,
        col("Y_POSITION(mm)")?,
        col("DOSE_PRIM(C)")?,
    ];
    let mut rows = Vec::new();
    for (i, l) in lines {
        let line = i as u64 + 1;
        if l.trim().is_empty() {
            break; // the footer follows the blank line after the data
        }
        let row = CsvRow {
            fields: l.split(',').map(str::trim).collect(),
            width: head.len(),
            name,
            line,
        };
        let submap = row.number(cols[0], "SUBMAP_NUMBER")?;
        let stamp = parse_stamp(row.get(cols[1], "TIME")?)
            .map_err(|m| LogError::at(name, line, Some("TIME"), m))?;
        let t = stamp.since(origin);
        if let Some(prev) = rows.last().map(|r: &Row| r.t_s) {
            if t < prev {
                return Err(LogError::at(
                    name,
                    line,
                    Some("TIME"),
                    "earlier than the row before; expected rows in time order",
                ));
            }
        }
        rows.push(Row {
            submap: submap as i64,
            t_s: t,
            resolution_s: stamp.resolution_s,
            pos: [
                row.number(cols[2], "X_POSITION(mm)")?,
                row.number(cols[3], "Y_POSITION(mm)")?,
            ],
            charge_c: row.number(cols[4], "DOSE_PRIM(C)")?,
            line,
        });
    }
    Ok(rows)
}

/// Each row's time: rows are 0.25 ms apart and each stamp is its row's time read down to the
/// stamp's resolution, so along a run of rows whose stamps agree with one 0.25 ms grid the grid
/// is placed mid-way in what the stamps allow; a run ends where the stamps leave the grid (a
/// pause in recording: one longer than the stamps' resolution plus a period is found at the row
/// after it).
fn row_times(rows: &[Row]) -> Vec<f64> {
    let mut out = vec![0.0; rows.len()];
    let mut i0 = 0;
    while i0 < rows.len() {
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        let mut j = i0;
        while j < rows.len() {
            let k = (j - i0) as f64 * SAMPLE_PERIOD_S;
            let s = &rows[j];
            let (l, h) = (lo.max(s.t_s - k), hi.min(s.t_s + s.resolution_s - k));
            if l > h + 1e-9 {
                break;
            }
            (lo, hi) = (l, h);
            j += 1;
        }
        let t0 = 0.5 * (lo + hi);
        for (m, t) in out.iter_mut().enumerate().take(j).skip(i0) {
            *t = t0 + (m - i0) as f64 * SAMPLE_PERIOD_S;
        }
        i0 = j;
    }
    out
}

/// A spot as a record file gives it: times (s after the log's origin), physics X and Y on the
/// chamber (mm), charge (C) and the line of its first row.
#[derive(Debug)]
pub(super) struct RawSpot {
    pub t_start_s: f64,
    pub t_end_s: f64,
    pub pos: [f64; 2],
    pub charge_c: f64,
    pub line: u64,
}

/// The spots of a record in the 250 µs layout: runs of consecutive rows of one submap number
/// with charge, at least one of them with a position (the last such row's is the spot's). A
/// charged row without a position (the chamber had not yet placed the beam) counts towards its
/// spot's time and charge.
fn row_spots(name: &str, text: &str, origin: &mut Option<i64>) -> Result<Vec<RawSpot>, LogError> {
    let rows = read_rows(name, text, origin)?;
    let times = row_times(&rows);
    let charged = |r: &Row| r.submap >= 0 && r.charge_c > 0.0;
    let placed = |r: &Row| r.pos[0] > NO_POSITION_MM && r.pos[1] > NO_POSITION_MM;
    let mut spots = Vec::new();
    let mut i = 0;
    while i < rows.len() {
        if !charged(&rows[i]) {
            i += 1;
            continue;
        }
        let first = i;
        let (mut charge, mut pos) = (0.0, None);
        while i < rows.len() && charged(&rows[i]) && rows[i].submap == rows[first].submap {
            charge += rows[i].charge_c.abs();
            if placed(&rows[i]) {
                pos = Some(rows[i].pos);
            }
            i += 1;
        }
        if let Some(pos) = pos {
            spots.push(RawSpot {
                t_start_s: times[first],
                t_end_s: times[i - 1] + SAMPLE_PERIOD_S,
                pos,
                charge_c: charge,
                line: rows[first].line,
            });
        }
    }
    Ok(spots)
}

/// The layer's records: spots, the chamber's positions turned to the isocentre plane; also the
/// longest time step of its records and the resolution of the layer's place in time (the
/// element layout places a layer by its `START_IRRADIATION` stamp).
fn read_layer(
    number: u32,
    files: &[(PathBuf, Option<PathBuf>)],
    config: &Config,
    origin: &mut Option<i64>,
) -> Result<(IbaLayer, [f64; 2]), LogError> {
    let mut spots = Vec::new();
    let mut range = None;
    let (mut resolution_s, mut placed_s): (f64, f64) = (0.0, 0.0);
    for (record, specif) in files {
        let (r, offset) = match specif {
            Some(s) => read_specif(s)?,
            None => (None, [0.0, 0.0]),
        };
        range = range.or(r);
        let name = record.display().to_string();
        let burst = file_name(record).contains("burst_record_");
        let text = read_text(record)?;
        let raw = if burst || is_element_layout(&text) {
            let default = if burst {
                BURST_PERIOD_S
            } else {
                SAMPLE_PERIOD_S
            };
            let (raw, period, stamp) = read_element_spots(&name, &text, origin, default)?;
            resolution_s = resolution_s.max(period);
            placed_s = placed_s.max(period).max(stamp);
            raw
        } else {
            resolution_s = resolution_s.max(SAMPLE_PERIOD_S);
            placed_s = placed_s.max(SAMPLE_PERIOD_S);
            row_spots(&name, &text, origin)?
        };
        // Physics X ↔ IEC gantry y, physics Y ↔ IEC gantry x.
        let scale = |axis: usize| match (config.sad_mm, config.ic_to_iso_mm) {
            (Some(sad), Some(d)) => sad[axis] / (sad[axis] - d[axis]),
            _ => 1.0,
        };
        spots.extend(raw.into_iter().map(|r| IbaSpot {
            t_start_s: r.t_start_s,
            t_end_s: r.t_end_s,
            x_mm: (r.pos[1] - offset[1]) * scale(1),
            y_mm: (r.pos[0] - offset[0]) * scale(0),
            charge_c: r.charge_c,
            file: name.clone(),
            line: r.line,
        }));
    }
    spots.sort_by(|a, b| a.t_start_s.total_cmp(&b.t_start_s));
    Ok((
        IbaLayer {
            number,
            range,
            spots,
        },
        [resolution_s, placed_s],
    ))
}

fn read_beam(
    dir: &Path,
    notes: &mut Vec<String>,
    origin: &mut Option<i64>,
) -> Result<IbaBeam, LogError> {
    let folder = dir.display().to_string();
    let files = list(dir)?;
    let find = |pred: &dyn Fn(&str) -> bool| files.iter().find(|p| pred(&file_name(p))).cloned();
    let config = match find(&|n| n.contains("beam_config")) {
        Some(p) => read_config(&p)?,
        None => {
            notes.push(format!("{folder}: no beam_config file: no charge per MU, positions not scaled to the isocentre"));
            Config::default()
        }
    };
    let beam = match find(&|n| {
        n.starts_with("beam.") || (n.contains("beam.") && !n.contains("beam_config"))
    }) {
        Some(p) => read_beam_file(&p, notes)?,
        None => BeamFile {
            gantry_angle_deg: None,
            correction: 1.0,
        },
    };
    let tunings = files
        .iter()
        .filter(|p| {
            let n = file_name(p);
            (n.contains("map_record") || n.contains("burst_record")) && n.contains("tuning")
        })
        .count();
    if tunings > 0 {
        notes.push(format!(
            "{folder}: {tunings} tuning record(s) not read (their spots are not in the plan)"
        ));
    }
    // Each specif file by its kind, layer and part, then the records grouped by layer number,
    // parts in order, each with its specif file.
    let specifs: Vec<(&str, (u32, u32), &PathBuf)> = files
        .iter()
        .filter_map(|q| {
            let m = file_name(q);
            if m.contains("tuning") {
                return None;
            }
            ["map_specif_", "burst_specif_"]
                .into_iter()
                .find(|k| m.contains(k))
                .and_then(|k| layer_and_part(&m, k).map(|lp| (k, lp, q)))
        })
        .collect();
    let mut records: Vec<(u32, u32, PathBuf, Option<PathBuf>)> = Vec::new();
    for p in files.iter().filter(|p| is_record(p)) {
        let n = file_name(p);
        let (kind, specif_kind) = record_kind(&n);
        let (layer, part) = layer_and_part(&n, kind).ok_or_else(|| {
            LogError::file(
                &p.display().to_string(),
                format!(
                    "no layer number after {kind}; expected {kind}NNNN_part_MM or {kind}NNNN_MM"
                ),
            )
        })?;
        let specif = specifs
            .iter()
            .find(|(k, lp, _)| *k == specif_kind && *lp == (layer, part))
            .map(|s| s.2.clone());
        records.push((layer, part, p.clone(), specif));
    }
    records.sort_by_key(|r| (r.0, r.1));
    let mut layers = Vec::new();
    let (mut time_step_s, mut edge_resolution_s): (f64, f64) = (0.0, 0.0);
    let mut k = 0;
    while k < records.len() {
        let number = records[k].0;
        let group: Vec<(PathBuf, Option<PathBuf>)> = records[k..]
            .iter()
            .take_while(|r| r.0 == number)
            .map(|r| (r.2.clone(), r.3.clone()))
            .collect();
        k += group.len();
        let (layer, [step, placed]) = read_layer(number, &group, &config, origin)?;
        time_step_s = time_step_s.max(step);
        edge_resolution_s = edge_resolution_s.max(placed);
        if layer.spots.is_empty() {
            notes.push(format!("{folder}: layer {number} records no spot"));
        } else {
            layers.push(layer);
        }
    }
    let events = find(&|n| n.contains("events"));
    let arcs = match &events {
        Some(p) => read_events(p, origin)?,
        None => Vec::new(),
    };
    let beam = IbaBeam {
        folder,
        gantry_angle_deg: beam.gantry_angle_deg,
        mu_per_coulomb: config.charge_per_mu_c.map(|c| 1.0 / (c * beam.correction)),
        positions_at_isocentre: config.sad_mm.is_some() && config.ic_to_iso_mm.is_some(),
        time_step_s,
        edge_resolution_s,
        layers,
        arcs,
    };
    check_events(&beam, events.as_deref(), *origin)?;
    Ok(beam)
}

/// Times from the log's first spot (absolute stamps keep ~0.2 µs; these keep more).
fn rebase(log: &mut IbaLog) {
    let origin = log
        .beams
        .iter()
        .flat_map(|b| {
            b.layers
                .iter()
                .flat_map(|l| l.spots.first().map(|s| s.t_start_s))
                .chain(b.arcs.iter().map(|a| a.start_s))
        })
        .fold(f64::INFINITY, f64::min);
    if !origin.is_finite() {
        return;
    }
    for b in &mut log.beams {
        for s in b.layers.iter_mut().flat_map(|l| l.spots.iter_mut()) {
            s.t_start_s -= origin;
            s.t_end_s -= origin;
        }
        for a in &mut b.arcs {
            a.start_s -= origin;
            a.end_s -= origin;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// A spot whose first rows have charge but no position yet (-10000): they count towards its
    /// time and charge; a charged run that never gets a position is no spot.
    #[test]
    fn charged_rows_before_the_position_belong_to_their_spot() {
        let mut text =
            String::from("SUBMAP_NUMBER,TIME,X_POSITION(mm),Y_POSITION(mm),DOSE_PRIM(C)\n");
        let rows = [
            (-1, -10000.0, 0.0),
            (0, -10000.0, 1e-10),
            (0, 1.0, 1e-10),
            (0, 1.5, 1e-10),
            (-1, -10000.0, 0.0),
            (1, -10000.0, 2e-10),
            (-1, -10000.0, 0.0),
            (-1, -10000.0, 0.0),
        ];
        for (k, (submap, x, q)) in rows.iter().enumerate() {
            let ms = k / 4;
            text.push_str(&format!(
                "{submap},01/01/2026 08:00:00.{ms:03},{x},{x},{q:e}\n"
            ));
        }
        let spots = row_spots("rec", &text, &mut None).expect("read");
        assert_eq!(spots.len(), 1, "{spots:?}");
        let s = &spots[0];
        assert!((s.charge_c - 3e-10).abs() < 1e-22);
        assert!((s.t_end_s - s.t_start_s - 3.0 * SAMPLE_PERIOD_S).abs() < 1e-12);
        assert_eq!((s.pos, s.line), ([1.5, 1.5], 3));
    }

    /// Rows every 0.25 ms from a random phase, with a pause of 1.5–50 ms somewhere, stamped by a
    /// millisecond clock that truncates: every row's time is found within half a sampling period.
    #[test]
    fn row_times_place_the_grid_within_half_a_period_of_the_truth() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(46);
        for _ in 0..500 {
            let t0 = 1000.0 + rng.random::<f64>() * 1e-3;
            let n = rng.random_range(20..400);
            let pause_at = rng.random_range(8..n - 8);
            let pause = 1.5e-3 + rng.random::<f64>() * 0.0485;
            let truth: Vec<f64> = (0..n)
                .map(|k| t0 + k as f64 * SAMPLE_PERIOD_S + if k >= pause_at { pause } else { 0.0 })
                .collect();
            let rows: Vec<Row> = truth
                .iter()
                .map(|t| Row {
                    submap: 0,
                    t_s: (t * 1e3 + 1e-9).floor() / 1e3,
                    resolution_s: 1e-3,
                    pos: [0.0, 0.0],
                    charge_c: 0.0,
                    line: 0,
                })
                .collect();
            let got = row_times(&rows);
            for (g, t) in got.iter().zip(&truth) {
                assert!(
                    (g - t).abs() <= 0.5 * SAMPLE_PERIOD_S + 1e-9,
                    "{g} against {t}"
                );
            }
        }
    }
}
