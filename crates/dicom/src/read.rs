//! Reading: bytes -> DICOM object (dicom-object) -> the plain [`IonPlan`] structs that `convert` turns
//! into an arc plan. Every required attribute is checked here, with its location in the file.

use std::io::Read;

use dicom_core::value::{PrimitiveValue, Value};
use dicom_core::Tag;
use dicom_dictionary_std::{tags, uids, StandardSopClassDictionary};
use dicom_encoding::transfer_syntax::{Codec, TransferSyntaxIndex};
use dicom_object::file::ReadPreamble;
use dicom_object::{DefaultDicomObject, FileMetaTable, InMemDicomObject, OpenFileOptions};
use dicom_parser::dataset::read::{DataSetReaderOptions, ValueReadStrategy};
use dicom_parser::dataset::{DataSetReader, DataToken};
use dicom_transfer_syntax_registry::TransferSyntaxRegistry;

use arcsim_plan::{MAX_SPOTS_PER_LAYER, MAX_SPOT_POSITION_MM};

use crate::error::{DicomImportError, Location};

/// SOP class UID of RT Ion Plan Storage, the only class this crate imports.
pub const RT_ION_PLAN_STORAGE: &str = uids::RT_ION_PLAN_STORAGE;
/// SOP class UID of (photon) RT Plan Storage, rejected with a dedicated message.
pub const RT_PLAN_STORAGE: &str = uids::RT_PLAN_STORAGE;

/// Length of the DICOM file preamble that precedes the "DICM" magic.
const PREAMBLE_LEN: usize = 128;

/// Deepest nesting of sequences accepted in a file (a sequence inside an item of a sequence is 2
/// levels). An RT Ion Plan needs fewer than 10 (IonBeamSequence > IonControlPointSequence >
/// ReferencedDoseReferenceSequence is 3). dicom-object builds nested sequences recursively, so a
/// file nested thousands of levels deep would overflow the stack and abort the process; such a file
/// is refused before it is parsed.
pub const MAX_NESTING: usize = 64;

/// Largest NumberOfPaintings (300A,039A) accepted, the native format's limit
/// ([`arcsim_plan::MAX_PAINTINGS`]). Delivery systems repaint a layer a few to a few dozen times;
/// each painting is one more pass over the layer's spots when the plan is timed, so a huge count from
/// a corrupt file would otherwise turn a few kilobytes into billions of spot deliveries.
pub const MAX_PAINTINGS: u32 = arcsim_plan::MAX_PAINTINGS;

/// Most spot deliveries accepted in a plan: the sum over all energy layers of the spot count x
/// NumberOfPaintings. Clinical plans have at most a few hundred thousand; this bounds the work of
/// timing the imported plan (one spot event per delivery). Each layer also holds at most
/// [`arcsim_plan::MAX_SPOTS_PER_LAYER`] (1,000,000) spots.
pub const MAX_SPOTS: u64 = 5_000_000;

type Result<T, E = DicomImportError> = std::result::Result<T, E>;

/// An attribute: its tag and its keyword, for reading and for error messages.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Attr {
    pub tag: Tag,
    pub keyword: &'static str,
}

macro_rules! attrs {
    ($($name:ident = $keyword:literal,)*) => {
        $(pub(crate) const $name: Attr = Attr { tag: tags::$name, keyword: $keyword };)*
    };
}

attrs! {
    SOP_CLASS_UID = "SOPClassUID",
    SOP_INSTANCE_UID = "SOPInstanceUID",
    RT_PLAN_LABEL = "RTPlanLabel",
    RT_PLAN_NAME = "RTPlanName",
    FRACTION_GROUP_SEQUENCE = "FractionGroupSequence",
    REFERENCED_BEAM_SEQUENCE = "ReferencedBeamSequence",
    REFERENCED_BEAM_NUMBER = "ReferencedBeamNumber",
    BEAM_METERSET = "BeamMeterset",
    ION_BEAM_SEQUENCE = "IonBeamSequence",
    BEAM_NUMBER = "BeamNumber",
    BEAM_NAME = "BeamName",
    BEAM_TYPE = "BeamType",
    TREATMENT_DELIVERY_TYPE = "TreatmentDeliveryType",
    FINAL_CUMULATIVE_METERSET_WEIGHT = "FinalCumulativeMetersetWeight",
    NUMBER_OF_CONTROL_POINTS = "NumberOfControlPoints",
    ION_CONTROL_POINT_SEQUENCE = "IonControlPointSequence",
    GANTRY_ANGLE = "GantryAngle",
    GANTRY_ROTATION_DIRECTION = "GantryRotationDirection",
    NOMINAL_BEAM_ENERGY = "NominalBeamEnergy",
    NUMBER_OF_SCAN_SPOT_POSITIONS = "NumberOfScanSpotPositions",
    SCAN_SPOT_POSITION_MAP = "ScanSpotPositionMap",
    SCAN_SPOT_METERSET_WEIGHTS = "ScanSpotMetersetWeights",
    NUMBER_OF_PAINTINGS = "NumberOfPaintings",
}

/// GantryRotationDirection (300A,011F) as written in the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Rotation {
    Cw,
    Cc,
    None,
}

/// BeamType (300A,00C4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum BeamKind {
    Static,
    Dynamic,
}

/// The parts of an RT Ion Plan that the conversion needs.
#[derive(Debug, Clone)]
pub(crate) struct IonPlan {
    pub label: Option<String>,
    pub plan_name: Option<String>,
    pub sop_instance_uid: Option<String>,
    /// Treatment beams ordered by BeamNumber.
    pub beams: Vec<IonBeam>,
    /// Beams left out (setup beams, beams without spots), for the plan description.
    pub skipped: Vec<String>,
}

/// One ion beam, with control-point attributes already inherited.
#[derive(Debug, Clone)]
pub(crate) struct IonBeam {
    pub number: i64,
    pub name: Option<String>,
    pub kind: BeamKind,
    /// BeamMeterset / FinalCumulativeMetersetWeight: the MU of one unit of meterset weight.
    pub mu_per_weight: f64,
    pub control_points: Vec<IonControlPoint>,
}

/// One item of IonControlPointSequence, with the gantry angle and direction inherited from earlier
/// control points of the same beam when absent.
#[derive(Debug, Clone)]
pub(crate) struct IonControlPoint {
    pub angle_deg: f64,
    /// Direction of the rotation from this control point to the next one.
    pub rotation: Rotation,
    /// The energy layer this control point starts, when it carries spot weights above 0.
    pub layer: Option<IonLayer>,
}

/// The spots a control point delivers (energy and paintings inherited when absent).
#[derive(Debug, Clone)]
pub(crate) struct IonLayer {
    pub energy_mev: f64,
    /// ScanSpotMetersetWeights, one per spot; the total over all paintings.
    pub weights: Vec<f64>,
    /// ScanSpotPositionMap as `[x, y]` in mm, one per spot in the file's order; None when the control
    /// point has no map.
    pub positions_mm: Option<Vec<[f64; 2]>>,
    /// NumberOfPaintings: how many times the spot list is delivered.
    pub paintings: u32,
}

/// True when `bytes` starts with a 128-byte preamble followed by "DICM".
pub fn has_dicom_magic(bytes: &[u8]) -> bool {
    bytes.get(PREAMBLE_LEN..PREAMBLE_LEN + 4) == Some(b"DICM".as_slice())
}

/// True when the file at `path` starts with a 128-byte preamble and "DICM" (whatever its extension).
pub fn is_dicom_file(path: impl AsRef<std::path::Path>) -> bool {
    let mut head = [0u8; PREAMBLE_LEN + 4];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .map(|()| has_dicom_magic(&head))
        .unwrap_or(false)
}

/// Parses a complete DICOM file held in memory (preamble, meta group, data set).
pub fn parse_bytes(bytes: &[u8]) -> Result<DefaultDicomObject> {
    if bytes.len() < PREAMBLE_LEN + 4 {
        return Err(DicomImportError::NotDicom {
            reason: format!(
                "{} bytes, shorter than the 128-byte preamble and \"DICM\" magic",
                bytes.len()
            ),
        });
    }
    if !has_dicom_magic(bytes) {
        return Err(DicomImportError::NotDicom {
            reason: "no \"DICM\" magic after the 128-byte preamble".into(),
        });
    }
    check_nesting(bytes)?;
    OpenFileOptions::new()
        .read_preamble(ReadPreamble::Always)
        .from_reader(bytes)
        .map_err(|e| DicomImportError::Unreadable {
            reason: error_chain(&e),
        })
}

/// Refuses a file whose sequences nest deeper than [`MAX_NESTING`], before dicom-object (which
/// recurses once per level) parses it. The scan walks the data set's tokens with dicom-parser's
/// iterative reader (values read as raw bytes, not decoded). Whatever the scan cannot read (meta
/// group, transfer syntax, a corrupt element) ends it without error: the parser then reports it.
fn check_nesting(bytes: &[u8]) -> Result<()> {
    let Some(mut rest) = bytes.get(PREAMBLE_LEN..) else {
        return Ok(());
    };
    // Reads "DICM" and the meta group, leaving `rest` at the start of the data set.
    let Ok(meta) = FileMetaTable::from_reader(&mut rest) else {
        return Ok(());
    };
    let Some(ts) = TransferSyntaxRegistry.get(meta.transfer_syntax()) else {
        return Ok(());
    };
    let source: Box<dyn Read + '_> = match ts.codec() {
        Codec::Dataset(Some(adapter)) => adapter.adapt_reader(Box::new(rest)),
        Codec::Dataset(None) => return Ok(()),
        Codec::None | Codec::EncapsulatedPixelData(..) => Box::new(rest),
    };
    let options = DataSetReaderOptions::default().value_read(ValueReadStrategy::Raw);
    let Ok(tokens) = DataSetReader::new_with_ts_options(source, ts, options) else {
        return Ok(());
    };
    let mut depth = 0usize;
    for token in tokens {
        match token {
            Ok(DataToken::SequenceStart { tag, .. }) => {
                depth += 1;
                if depth > MAX_NESTING {
                    return Err(too_deep(tag));
                }
            }
            Ok(DataToken::PixelSequenceStart) => {
                depth += 1;
                if depth > MAX_NESTING {
                    return Err(too_deep(tags::PIXEL_DATA));
                }
            }
            Ok(DataToken::SequenceEnd) => depth = depth.saturating_sub(1),
            Ok(_) => {}
            Err(_) => break,
        }
    }
    Ok(())
}

fn too_deep(tag: Tag) -> DicomImportError {
    use dicom_core::dictionary::DataDictionary;
    DicomImportError::TooDeeplyNested {
        limit: MAX_NESTING,
        keyword: dicom_dictionary_std::StandardDataDictionary
            .by_tag(tag)
            .map(|e| e.alias),
        tag,
    }
}

/// An error and its causes, joined by ": ".
fn error_chain(err: &dyn std::error::Error) -> String {
    let mut msg = err.to_string();
    let mut source = err.source();
    while let Some(cause) = source {
        let text = cause.to_string();
        if !msg.contains(&text) {
            msg.push_str(": ");
            msg.push_str(&text);
        }
        source = cause.source();
    }
    msg
}

/// Checks the SOP class: RT Ion Plan passes, a photon RT Plan and everything else get a clear error.
pub fn check_sop_class(uid: Option<&str>) -> Result<()> {
    let Some(uid) = uid.map(|u| u.trim_end_matches(['\0', ' '])) else {
        return Err(DicomImportError::MissingTag {
            keyword: SOP_CLASS_UID.keyword,
            tag: SOP_CLASS_UID.tag,
            at: Location::Dataset,
            note: Some("cannot tell whether this is an RT Ion Plan"),
        });
    };
    match uid {
        RT_ION_PLAN_STORAGE => Ok(()),
        RT_PLAN_STORAGE => Err(DicomImportError::PhotonPlan {
            sop_class_uid: uid.to_string(),
        }),
        other => {
            use dicom_core::dictionary::UidDictionary;
            let name = StandardSopClassDictionary
                .by_uid(other)
                .map(|e| e.name.to_string());
            Err(DicomImportError::NotIonPlan {
                sop_class_uid: other.to_string(),
                name,
            })
        }
    }
}

/// The SOP class UID of a file: SOPClassUID (0008,0016) of the data set, else the meta group's
/// MediaStorageSOPClassUID (0002,0002).
pub fn sop_class_of(obj: &DefaultDicomObject) -> Option<String> {
    text(obj, SOP_CLASS_UID).or_else(|| {
        let uid = obj.meta().media_storage_sop_class_uid();
        (!uid.is_empty()).then(|| uid.to_string())
    })
}

/// Reads the plan data out of an RT Ion Plan data set (the SOP class is checked by the caller).
pub(crate) fn read_ion_plan(ds: &InMemDicomObject) -> Result<IonPlan> {
    let beam_items = items(ds, ION_BEAM_SEQUENCE).ok_or_else(|| DicomImportError::NoIonBeams {
        reason: format!(
            "{} {} is missing or empty",
            ION_BEAM_SEQUENCE.keyword, ION_BEAM_SEQUENCE.tag
        ),
    })?;
    let mut plan = IonPlan {
        label: text(ds, RT_PLAN_LABEL),
        plan_name: text(ds, RT_PLAN_NAME),
        sop_instance_uid: text(ds, SOP_INSTANCE_UID),
        beams: Vec::new(),
        skipped: Vec::new(),
    };
    // BeamNumber -> index of the first beam with it: the fraction group refers to beams by number.
    let mut numbers: Vec<(i64, usize)> = Vec::with_capacity(beam_items.len());
    // Spot deliveries (spots x paintings), over all the beams imported so far.
    let mut spot_total = 0u64;
    for (index, item) in beam_items.iter().enumerate() {
        let at = Location::Beam {
            beam: index,
            number: None,
        };
        let number = required(int_at(item, BEAM_NUMBER, at)?, BEAM_NUMBER, at)?;
        if let Some(&(_, first)) = numbers.iter().find(|(n, _)| *n == number) {
            return Err(DicomImportError::DuplicateBeamNumber {
                number,
                first,
                second: index,
            });
        }
        numbers.push((number, index));
        let at = Location::Beam {
            beam: index,
            number: Some(number),
        };
        let delivery = text(item, TREATMENT_DELIVERY_TYPE);
        if delivery.as_deref() == Some("SETUP") {
            plan.skipped.push(format!("beam {number} (setup beam)"));
            continue;
        }
        let kind = match text(item, BEAM_TYPE).as_deref() {
            Some("STATIC") => Some(BeamKind::Static),
            Some("DYNAMIC") => Some(BeamKind::Dynamic),
            None => None,
            Some(other) => {
                return Err(invalid(
                    BEAM_TYPE,
                    at,
                    format!("\"{other}\"; expected STATIC or DYNAMIC"),
                ))
            }
        };
        let control_points = read_control_points(item, index, number)?;
        spot_total += control_points
            .iter()
            .filter_map(|cp| cp.layer.as_ref())
            .map(|l| l.weights.len() as u64 * u64::from(l.paintings))
            .sum::<u64>();
        if control_points.iter().all(|cp| cp.layer.is_none()) {
            plan.skipped.push(format!(
                "beam {number} (no spot with a meterset weight above 0)"
            ));
            continue;
        }
        // Without BeamType, a beam that stays at one angle is static.
        let kind = kind.unwrap_or_else(|| {
            let first = control_points[0].angle_deg;
            if control_points.iter().all(|cp| cp.angle_deg == first) {
                BeamKind::Static
            } else {
                BeamKind::Dynamic
            }
        });
        let final_weight = required(
            float_at(item, FINAL_CUMULATIVE_METERSET_WEIGHT, at)?,
            FINAL_CUMULATIVE_METERSET_WEIGHT,
            at,
        )?;
        if !(final_weight.is_finite() && final_weight > 0.0) {
            return Err(invalid(
                FINAL_CUMULATIVE_METERSET_WEIGHT,
                at,
                format!("{final_weight}; expected a number above 0"),
            ));
        }
        let meterset = beam_meterset(ds, index, number)?;
        plan.beams.push(IonBeam {
            number,
            name: text(item, BEAM_NAME),
            kind,
            mu_per_weight: meterset / final_weight,
            control_points,
        });
    }
    if spot_total > MAX_SPOTS {
        return Err(DicomImportError::TooManySpots {
            spots: spot_total,
            limit: MAX_SPOTS,
        });
    }
    if plan.beams.is_empty() {
        return Err(DicomImportError::NoIonBeams {
            reason: if plan.skipped.is_empty() {
                format!(
                    "{} {} has no items",
                    ION_BEAM_SEQUENCE.keyword, ION_BEAM_SEQUENCE.tag
                )
            } else {
                format!("left out {}", plan.skipped.join(", "))
            },
        });
    }
    plan.beams.sort_by_key(|b| b.number);
    Ok(plan)
}

/// Reads IonControlPointSequence of one beam, inheriting angle, direction, energy and paintings.
fn read_control_points(
    beam: &InMemDicomObject,
    index: usize,
    number: i64,
) -> Result<Vec<IonControlPoint>> {
    let beam_at = Location::Beam {
        beam: index,
        number: Some(number),
    };
    let cps = items(beam, ION_CONTROL_POINT_SEQUENCE)
        .ok_or_else(|| missing(ION_CONTROL_POINT_SEQUENCE, beam_at, None))?;
    if let Some(n) = int_at(beam, NUMBER_OF_CONTROL_POINTS, beam_at)? {
        if usize::try_from(n).ok() != Some(cps.len()) {
            return Err(DicomImportError::Inconsistent {
                keyword: NUMBER_OF_CONTROL_POINTS.keyword,
                tag: NUMBER_OF_CONTROL_POINTS.tag,
                at: beam_at,
                problem: format!(
                    "says {n} but IonControlPointSequence (300A,03A8) has {} items",
                    cps.len()
                ),
            });
        }
    }
    let mut out: Vec<IonControlPoint> = Vec::with_capacity(cps.len());
    let mut energy_mev: Option<f64> = None;
    let mut paintings = 1u32;
    for (c, cp) in cps.iter().enumerate() {
        let at = Location::ControlPoint {
            beam: index,
            number: Some(number),
            control_point: c,
        };
        let prev = out.last();
        let angle_deg = match (float_at(cp, GANTRY_ANGLE, at)?, prev) {
            (Some(a), _) if a.is_finite() => a,
            (Some(a), _) => {
                return Err(invalid(
                    GANTRY_ANGLE,
                    at,
                    format!("{a}; expected a finite angle"),
                ))
            }
            (None, Some(p)) => p.angle_deg,
            (None, None) => {
                return Err(missing(
                    GANTRY_ANGLE,
                    at,
                    Some("required on the first control point"),
                ))
            }
        };
        let rotation = match text(cp, GANTRY_ROTATION_DIRECTION).as_deref() {
            Some("CW") => Rotation::Cw,
            Some("CC") => Rotation::Cc,
            Some("NONE") => Rotation::None,
            Some(other) => {
                return Err(invalid(
                    GANTRY_ROTATION_DIRECTION,
                    at,
                    format!("\"{other}\"; expected CW, CC or NONE"),
                ))
            }
            None => prev.map_or(Rotation::None, |p| p.rotation),
        };
        if let Some(e) = float_at(cp, NOMINAL_BEAM_ENERGY, at)? {
            energy_mev = Some(e);
        }
        if let Some(n) = int_at(cp, NUMBER_OF_PAINTINGS, at)? {
            paintings = u32::try_from(n)
                .ok()
                .filter(|n| (1..=MAX_PAINTINGS).contains(n))
                .ok_or_else(|| {
                    invalid(
                        NUMBER_OF_PAINTINGS,
                        at,
                        format!("{n}; expected a whole number from 1 to {MAX_PAINTINGS}"),
                    )
                })?;
        }
        let SpotList {
            weights,
            positions_mm,
        } = read_spots(cp, at)?;
        let layer = if weights.iter().sum::<f64>() > 0.0 {
            let energy_mev = energy_mev.ok_or_else(|| {
                missing(
                    NOMINAL_BEAM_ENERGY,
                    at,
                    Some("this control point delivers spots and no earlier control point gives the energy"),
                )
            })?;
            Some(IonLayer {
                energy_mev,
                weights,
                positions_mm,
                paintings,
            })
        } else {
            None
        };
        out.push(IonControlPoint {
            angle_deg,
            rotation,
            layer,
        });
    }
    Ok(out)
}

/// The spots of one control point as read from the file.
struct SpotList {
    weights: Vec<f64>,
    positions_mm: Option<Vec<[f64; 2]>>,
}

/// Reads and cross-checks a control point's spot count, position map and weights.
fn read_spots(cp: &InMemDicomObject, at: Location) -> Result<SpotList> {
    let count = int_at(cp, NUMBER_OF_SCAN_SPOT_POSITIONS, at)?;
    let weights = floats_at(cp, SCAN_SPOT_METERSET_WEIGHTS, at)?;
    let (count, weights) = match (count, weights) {
        (None, None) => {
            return Ok(SpotList {
                weights: Vec::new(),
                positions_mm: None,
            })
        }
        (None, Some(_)) => {
            return Err(missing(
                NUMBER_OF_SCAN_SPOT_POSITIONS,
                at,
                Some("ScanSpotMetersetWeights is present"),
            ))
        }
        (Some(n), None) if n > 0 => {
            return Err(missing(
                SCAN_SPOT_METERSET_WEIGHTS,
                at,
                Some("NumberOfScanSpotPositions is above 0"),
            ))
        }
        (Some(n), w) => (n, w.unwrap_or_default()),
    };
    let spots = usize::try_from(count).map_err(|_| {
        invalid(
            NUMBER_OF_SCAN_SPOT_POSITIONS,
            at,
            format!("{count}; expected a count of 0 or more"),
        )
    })?;
    if spots > MAX_SPOTS_PER_LAYER as usize {
        return Err(invalid(
            NUMBER_OF_SCAN_SPOT_POSITIONS,
            at,
            format!("{count}; expected at most {MAX_SPOTS_PER_LAYER} spots in one energy layer"),
        ));
    }
    if weights.len() != spots {
        return Err(DicomImportError::SpotCountMismatch {
            at,
            weights: weights.len(),
            spots,
        });
    }
    let positions_mm = floats_at(cp, SCAN_SPOT_POSITION_MAP, at)?
        .map(|map| positions(&map, spots, at))
        .transpose()?;
    if let Some((i, w)) = weights
        .iter()
        .enumerate()
        .find(|(_, w)| !(w.is_finite() && **w >= 0.0))
    {
        return Err(invalid(
            SCAN_SPOT_METERSET_WEIGHTS,
            at,
            format!("spot {i} has weight {w}; expected a finite weight >= 0"),
        ));
    }
    Ok(SpotList {
        weights,
        positions_mm,
    })
}

/// The `[x, y]` pairs of a ScanSpotPositionMap, checked: 2 values per spot, each finite and within
/// [`MAX_SPOT_POSITION_MM`] of the isocentre axis.
fn positions(map: &[f64], spots: usize, at: Location) -> Result<Vec<[f64; 2]>> {
    if map.len() != 2 * spots {
        return Err(DicomImportError::Inconsistent {
            keyword: SCAN_SPOT_POSITION_MAP.keyword,
            tag: SCAN_SPOT_POSITION_MAP.tag,
            at,
            problem: format!(
                "{} values for {spots} spots; expected 2 per spot (x, y)",
                map.len()
            ),
        });
    }
    let pairs: Vec<[f64; 2]> = map.chunks_exact(2).map(|xy| [xy[0], xy[1]]).collect();
    if let Some((i, [x, y])) = pairs.iter().enumerate().find(|(_, p)| {
        !p.iter()
            .all(|c| c.is_finite() && c.abs() <= MAX_SPOT_POSITION_MM)
    }) {
        return Err(invalid(
            SCAN_SPOT_POSITION_MAP,
            at,
            format!(
                "spot {i} is at ({x}, {y}) mm; expected finite coordinates between -{MAX_SPOT_POSITION_MM} \
                 and {MAX_SPOT_POSITION_MM} mm"
            ),
        ));
    }
    Ok(pairs)
}

/// BeamMeterset of the beam numbered `number`, from the first fraction group that references it.
fn beam_meterset(ds: &InMemDicomObject, index: usize, number: i64) -> Result<f64> {
    let beam_at = Location::Beam {
        beam: index,
        number: Some(number),
    };
    let groups = items(ds, FRACTION_GROUP_SEQUENCE).ok_or_else(|| {
        missing(
            FRACTION_GROUP_SEQUENCE,
            Location::Dataset,
            Some("it holds the BeamMeterset of every beam"),
        )
    })?;
    for (g, group) in groups.iter().enumerate() {
        let Some(refs) = items(group, REFERENCED_BEAM_SEQUENCE) else {
            continue;
        };
        for (i, item) in refs.iter().enumerate() {
            let at = Location::ReferencedBeam { group: g, item: i };
            if int_at(item, REFERENCED_BEAM_NUMBER, at)? != Some(number) {
                continue;
            }
            let mu = required(float_at(item, BEAM_METERSET, at)?, BEAM_METERSET, at)?;
            if !(mu.is_finite() && mu >= 0.0) {
                return Err(invalid(
                    BEAM_METERSET,
                    at,
                    format!("{mu}; expected a finite MU value >= 0"),
                ));
            }
            return Ok(mu);
        }
    }
    Err(DicomImportError::NoBeamMeterset {
        at: beam_at,
        number,
    })
}

// ---- attribute access: absent and empty attributes both read as None -------------------------------

fn missing(attr: Attr, at: Location, note: Option<&'static str>) -> DicomImportError {
    DicomImportError::MissingTag {
        keyword: attr.keyword,
        tag: attr.tag,
        at,
        note,
    }
}

fn invalid(attr: Attr, at: Location, problem: String) -> DicomImportError {
    DicomImportError::InvalidValue {
        keyword: attr.keyword,
        tag: attr.tag,
        at,
        problem,
    }
}

fn required<T>(value: Option<T>, attr: Attr, at: Location) -> Result<T> {
    value.ok_or_else(|| missing(attr, at, None))
}

/// The items of a sequence attribute; None when absent or empty.
fn items(obj: &InMemDicomObject, attr: Attr) -> Option<&[InMemDicomObject]> {
    obj.get(attr.tag)
        .and_then(|e| e.items())
        .filter(|i| !i.is_empty())
}

/// The primitive value of an attribute; None when absent, empty or blank.
fn primitive(obj: &InMemDicomObject, attr: Attr) -> Option<&PrimitiveValue> {
    match obj.get(attr.tag)?.value() {
        Value::Primitive(PrimitiveValue::Empty) => None,
        Value::Primitive(p @ (PrimitiveValue::Str(_) | PrimitiveValue::Strs(_))) => {
            let blank = p
                .to_str()
                .trim_matches(|c: char| c == ' ' || c == '\0' || c == '\\')
                .is_empty();
            (!blank).then_some(p)
        }
        Value::Primitive(p) => Some(p),
        _ => None,
    }
}

/// A text attribute without its padding.
fn text(obj: &InMemDicomObject, attr: Attr) -> Option<String> {
    primitive(obj, attr).map(|p| {
        p.to_str()
            .trim_matches(|c: char| c == ' ' || c == '\0')
            .to_string()
    })
}

/// The primitive value of a single-valued attribute: an error when it holds several values, which
/// would otherwise be read as their first.
fn single(obj: &InMemDicomObject, attr: Attr, at: Location) -> Result<Option<&PrimitiveValue>> {
    let Some(p) = primitive(obj, attr) else {
        return Ok(None);
    };
    let count = value_count(p);
    if count > 1 {
        return Err(invalid(
            attr,
            at,
            format!("{count} values ({}); expected one", shorten(&p.to_str())),
        ));
    }
    Ok(Some(p))
}

/// The number of values of a primitive value. A text value counts its backslash-separated parts: a
/// file's `10\20` reads as two strings, but a data set built in memory may hold it as one.
fn value_count(p: &PrimitiveValue) -> usize {
    match p {
        PrimitiveValue::Str(s) => s.split('\\').count(),
        PrimitiveValue::Strs(parts) => parts.iter().map(|s| s.split('\\').count()).sum(),
        other => other.multiplicity() as usize,
    }
}

/// `text` cut to its first 40 characters (with "...") for an error message.
fn shorten(text: &str) -> String {
    const MAX: usize = 40;
    match text.char_indices().nth(MAX) {
        Some((end, _)) => format!("{}...", &text[..end]),
        None => text.to_string(),
    }
}

fn float_at(obj: &InMemDicomObject, attr: Attr, at: Location) -> Result<Option<f64>> {
    single(obj, attr, at)?
        .map(|p| {
            p.to_float64()
                .map_err(|e| invalid(attr, at, format!("not a number: {e}")))
        })
        .transpose()
}

fn floats_at(obj: &InMemDicomObject, attr: Attr, at: Location) -> Result<Option<Vec<f64>>> {
    primitive(obj, attr)
        .map(|p| {
            p.to_multi_float64()
                .map_err(|e| invalid(attr, at, format!("not a list of numbers: {e}")))
        })
        .transpose()
}

fn int_at(obj: &InMemDicomObject, attr: Attr, at: Location) -> Result<Option<i64>> {
    single(obj, attr, at)?
        .map(|p| {
            p.to_int::<i64>()
                .map_err(|e| invalid(attr, at, format!("not a whole number: {e}")))
        })
        .transpose()
}
