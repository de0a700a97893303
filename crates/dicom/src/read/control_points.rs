//! Reading one beam's IonControlPointSequence: gantry angle and direction, energy and paintings
//! (each inherited from earlier control points when absent) and the spots of each energy layer.

use dicom_object::InMemDicomObject;

use arcsim_plan::{MAX_SPOTS_PER_LAYER, MAX_SPOT_POSITION_MM};

use super::access::{float_at, floats_at, int_at, invalid, items, missing, text};
use super::attr::{
    GANTRY_ANGLE, GANTRY_ROTATION_DIRECTION, ION_CONTROL_POINT_SEQUENCE, NOMINAL_BEAM_ENERGY,
    NUMBER_OF_CONTROL_POINTS, NUMBER_OF_PAINTINGS, NUMBER_OF_SCAN_SPOT_POSITIONS,
    SCAN_SPOT_METERSET_WEIGHTS, SCAN_SPOT_POSITION_MAP,
};
use super::ion_plan::{IonControlPoint, IonLayer, Rotation};
use super::Result;
use crate::convert::SAME_ANGLE_TOLERANCE_DEG;
use crate::error::{DicomImportError, ImportWarning, Location};

/// Largest NumberOfPaintings (300A,039A) accepted, the native format's limit
/// ([`arcsim_plan::MAX_PAINTINGS`]). Delivery systems repaint a layer a few to a few dozen times;
/// each painting is one more pass over the layer's spots when the plan is timed, so a huge count from
/// a corrupt file would otherwise turn a few kilobytes into billions of spot deliveries.
pub const MAX_PAINTINGS: u32 = arcsim_plan::MAX_PAINTINGS;

/// Reads IonControlPointSequence of one beam, inheriting angle, direction, energy and paintings.
/// Each step between control points must go the way the earlier one's GantryRotationDirection says.
pub(super) fn read_control_points(
    beam: &InMemDicomObject,
    index: usize,
    number: i64,
    warnings: &mut Vec<ImportWarning>,
) -> Result<Vec<IonControlPoint>> {
    let beam_at = Location::Beam {
        beam: index,
        number: Some(number),
    };
    let cps = items(beam, ION_CONTROL_POINT_SEQUENCE)
        .ok_or_else(|| missing(ION_CONTROL_POINT_SEQUENCE, beam_at, None))?;
    check_control_point_count(beam, cps.len(), beam_at)?;
    let mut out: Vec<IonControlPoint> = Vec::with_capacity(cps.len());
    let mut inherited = Inherited {
        energy_mev: None,
        paintings: 1,
    };
    for (c, cp) in cps.iter().enumerate() {
        let at = Location::ControlPoint {
            beam: index,
            number: Some(number),
            control_point: c,
        };
        let point = read_control_point(cp, at, out.last(), &mut inherited, warnings)?;
        if let Some(prev) = out.last() {
            check_step(prev, &point, at)?;
        }
        out.push(point);
    }
    Ok(out)
}

/// The step from `prev` to `point` (at `at`) must go the way `prev`'s GantryRotationDirection
/// says: CW increases the angle, CC decreases it (across 0 either way). A step of exactly 180
/// degrees goes either way.
fn check_step(prev: &IonControlPoint, point: &IonControlPoint, at: Location) -> Result<()> {
    let (from, to) = (prev.angle_deg, point.angle_deg);
    let shortest = crate::convert::shortest_delta(from, to);
    let (name, against) = match prev.rotation {
        Rotation::Cw => (
            "CW (increasing angle)",
            shortest < -SAME_ANGLE_TOLERANCE_DEG,
        ),
        Rotation::Cc => (
            "CC (decreasing angle)",
            shortest > SAME_ANGLE_TOLERANCE_DEG && shortest < 180.0,
        ),
        Rotation::None => return Ok(()),
    };
    if against {
        let Location::ControlPoint { control_point, .. } = at else {
            return Ok(());
        };
        return Err(DicomImportError::Inconsistent {
            keyword: GANTRY_ANGLE.keyword,
            tag: GANTRY_ANGLE.tag,
            at,
            problem: format!(
                "goes from {from} (IonControlPointSequence[{}]) to {to}, against the \
                 GantryRotationDirection (300A,011F) {name} of IonControlPointSequence[{}]; \
                 expected the angle to move that way (the other way round is a turn of {:.6} \
                 degrees)",
                control_point - 1,
                control_point - 1,
                360.0 - shortest.abs()
            ),
        });
    }
    Ok(())
}

/// NumberOfControlPoints, when present, must count the items of IonControlPointSequence.
fn check_control_point_count(beam: &InMemDicomObject, items: usize, at: Location) -> Result<()> {
    if let Some(n) = int_at(beam, NUMBER_OF_CONTROL_POINTS, at)? {
        if usize::try_from(n).ok() != Some(items) {
            return Err(DicomImportError::Inconsistent {
                keyword: NUMBER_OF_CONTROL_POINTS.keyword,
                tag: NUMBER_OF_CONTROL_POINTS.tag,
                at,
                problem: format!(
                    "says {n} but IonControlPointSequence (300A,03A8) has {items} items"
                ),
            });
        }
    }
    Ok(())
}

/// The layer attributes a control point takes from the last earlier control point that gives them.
struct Inherited {
    /// NominalBeamEnergy; None until a control point gives it.
    energy_mev: Option<f64>,
    /// NumberOfPaintings; 1 until a control point gives it.
    paintings: u32,
}

/// Reads one control point; `prev` is the one before it in the same beam, if any. GantryAngle
/// must be in [0, 360) degrees; 360 is read as 0 with a warning.
fn read_control_point(
    cp: &InMemDicomObject,
    at: Location,
    prev: Option<&IonControlPoint>,
    inherited: &mut Inherited,
    warnings: &mut Vec<ImportWarning>,
) -> Result<IonControlPoint> {
    let angle_deg = match (float_at(cp, GANTRY_ANGLE, at)?, prev) {
        // Adding 0 turns -0 into 0.
        (Some(a), _) if (0.0..360.0).contains(&a) => a + 0.0,
        (Some(360.0), _) => {
            warnings.push(ImportWarning::GantryAngle360 { at });
            0.0
        }
        (Some(a), _) => {
            return Err(invalid(
                GANTRY_ANGLE,
                at,
                format!("{a}; expected an angle from 0 up to (not including) 360 degrees"),
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
        inherited.energy_mev = Some(e);
    }
    if let Some(n) = int_at(cp, NUMBER_OF_PAINTINGS, at)? {
        inherited.paintings = u32::try_from(n)
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
        let energy_mev = inherited.energy_mev.ok_or_else(|| {
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
            paintings: inherited.paintings,
        })
    } else {
        None
    };
    Ok(IonControlPoint {
        angle_deg,
        rotation,
        layer,
    })
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
    // A map that is present but empty holds 0 values: refused when there are spots.
    let map = match floats_at(cp, SCAN_SPOT_POSITION_MAP, at)? {
        None if cp.get(SCAN_SPOT_POSITION_MAP.tag).is_some() => Some(Vec::new()),
        map => map,
    };
    let positions_mm = map.map(|map| positions(&map, spots, at)).transpose()?;
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
