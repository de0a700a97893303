//! Reading the plan: its ion beams (treatment beams kept, setup beams and beams without spots left
//! out) and each beam's BeamMeterset from the first fraction group (the beams of other fraction
//! groups are left out with a warning).

use dicom_object::InMemDicomObject;

use super::access::{float_at, int_at, invalid, items, missing, required, text};
use super::attr::{
    BEAM_METERSET, BEAM_NAME, BEAM_NUMBER, BEAM_TYPE, FINAL_CUMULATIVE_METERSET_WEIGHT,
    FRACTION_GROUP_NUMBER, FRACTION_GROUP_SEQUENCE, ION_BEAM_SEQUENCE, REFERENCED_BEAM_NUMBER,
    REFERENCED_BEAM_SEQUENCE, RT_PLAN_LABEL, RT_PLAN_NAME, SOP_INSTANCE_UID,
    TREATMENT_DELIVERY_TYPE,
};
use super::control_points::read_control_points;
use super::ion_plan::{BeamKind, IonBeam, IonPlan};
use super::Result;
use crate::error::{DicomImportError, ImportWarning, Location};

/// Most spot deliveries accepted in a plan: the sum over all energy layers of the spot count x
/// NumberOfPaintings. Clinical plans have at most a few hundred thousand; this bounds the work of
/// timing the imported plan (one spot event per delivery). Each layer also holds at most
/// [`arcsim_plan::MAX_SPOTS_PER_LAYER`] (1,000,000) spots.
pub const MAX_SPOTS: u64 = 5_000_000;

/// Largest relative difference accepted between FinalCumulativeMetersetWeight and the sum of a
/// beam's ScanSpotMetersetWeights (single-precision weights, a decimal-string total).
pub const CUMULATIVE_WEIGHT_TOLERANCE: f64 = 1e-4;

/// Reads the plan data out of an RT Ion Plan data set (the SOP class is checked by the caller).
/// Only the beams the first fraction group references are imported; `warnings` gets a note when
/// other fraction groups are left out, and the warnings of the control points.
pub(crate) fn read_ion_plan(
    ds: &InMemDicomObject,
    warnings: &mut Vec<ImportWarning>,
) -> Result<IonPlan> {
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
    for (index, item) in beam_items.iter().enumerate() {
        let number = beam_number(item, index, &numbers)?;
        numbers.push((number, index));
    }
    let groups = fraction_groups(ds, &numbers)?;
    if let [first, others @ ..] = groups.as_slice() {
        if !others.is_empty() {
            warnings.push(ImportWarning::OtherFractionGroups {
                imported: first.name.clone(),
                left_out: others
                    .iter()
                    .map(|g| (g.name.clone(), g.beams.iter().map(|b| b.number).collect()))
                    .collect(),
            });
        }
    }
    for (item, &(number, index)) in beam_items.iter().zip(&numbers) {
        match read_beam(item, index, number, &groups, warnings)? {
            BeamRead::Treatment(beam) => plan.beams.push(beam),
            BeamRead::Skipped(why) => plan.skipped.push(why),
        }
    }
    check_spot_total(&plan.beams)?;
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

/// One item of FractionGroupSequence: its name in messages and the beams it references.
struct FractionGroup {
    /// FractionGroupNumber, else "#index".
    name: String,
    beams: Vec<BeamReference>,
}

/// One item of ReferencedBeamSequence.
struct BeamReference {
    number: i64,
    /// BeamMeterset, when given.
    meterset: Option<f64>,
    at: Location,
}

/// The fraction groups of the plan (empty when FractionGroupSequence is absent). Every
/// ReferencedBeamNumber must be the BeamNumber of a beam (`numbers`: BeamNumber -> index).
fn fraction_groups(ds: &InMemDicomObject, numbers: &[(i64, usize)]) -> Result<Vec<FractionGroup>> {
    let Some(groups) = items(ds, FRACTION_GROUP_SEQUENCE) else {
        return Ok(Vec::new());
    };
    let mut out = Vec::with_capacity(groups.len());
    for (g, group) in groups.iter().enumerate() {
        let name = int_at(
            group,
            FRACTION_GROUP_NUMBER,
            Location::FractionGroup { group: g },
        )?
        .map_or_else(|| format!("#{g}"), |n| n.to_string());
        let mut beams = Vec::new();
        for (i, item) in items(group, REFERENCED_BEAM_SEQUENCE)
            .unwrap_or_default()
            .iter()
            .enumerate()
        {
            let at = Location::ReferencedBeam { group: g, item: i };
            let number = required(
                int_at(item, REFERENCED_BEAM_NUMBER, at)?,
                REFERENCED_BEAM_NUMBER,
                at,
            )?;
            if !numbers.iter().any(|(n, _)| *n == number) {
                return Err(DicomImportError::UnknownBeamReference {
                    keyword: REFERENCED_BEAM_NUMBER.keyword,
                    tag: REFERENCED_BEAM_NUMBER.tag,
                    at,
                    number,
                    beams: numbers.iter().map(|(n, _)| *n).collect(),
                });
            }
            beams.push(BeamReference {
                number,
                meterset: float_at(item, BEAM_METERSET, at)?,
                at,
            });
        }
        out.push(FractionGroup { name, beams });
    }
    Ok(out)
}

/// What one item of IonBeamSequence turned out to be.
enum BeamRead {
    /// A treatment beam with spots to deliver.
    Treatment(IonBeam),
    /// A beam left out, described for the plan description ("beam 3 (setup beam)").
    Skipped(String),
}

/// The BeamNumber of the beam at `index`: required, and different from those of the beams before it
/// (`numbers`: BeamNumber -> index).
fn beam_number(item: &InMemDicomObject, index: usize, numbers: &[(i64, usize)]) -> Result<i64> {
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
    Ok(number)
}

/// Reads one item of IonBeamSequence, numbered `number`: its kind, its control points and the MU of
/// one unit of meterset weight; a setup beam, a beam without spots or a beam of another fraction
/// group than the first is left out.
fn read_beam(
    item: &InMemDicomObject,
    index: usize,
    number: i64,
    groups: &[FractionGroup],
    warnings: &mut Vec<ImportWarning>,
) -> Result<BeamRead> {
    let at = Location::Beam {
        beam: index,
        number: Some(number),
    };
    let delivery = text(item, TREATMENT_DELIVERY_TYPE);
    if delivery.as_deref() == Some("SETUP") {
        return Ok(BeamRead::Skipped(format!("beam {number} (setup beam)")));
    }
    if let [first, others @ ..] = groups {
        if !first.beams.iter().any(|b| b.number == number) {
            if let Some(group) = others
                .iter()
                .find(|g| g.beams.iter().any(|b| b.number == number))
            {
                return Ok(BeamRead::Skipped(format!(
                    "beam {number} (fraction group {})",
                    group.name
                )));
            }
        }
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
    let control_points = read_control_points(item, index, number, warnings)?;
    if control_points.iter().all(|cp| cp.layer.is_none()) {
        return Ok(BeamRead::Skipped(format!(
            "beam {number} (no spot with a meterset weight above 0)"
        )));
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
    let weights: f64 = control_points
        .iter()
        .filter_map(|cp| cp.layer.as_ref())
        .flat_map(|l| &l.weights)
        .sum();
    if (final_weight - weights).abs() > CUMULATIVE_WEIGHT_TOLERANCE * final_weight.max(weights) {
        return Err(DicomImportError::Inconsistent {
            keyword: FINAL_CUMULATIVE_METERSET_WEIGHT.keyword,
            tag: FINAL_CUMULATIVE_METERSET_WEIGHT.tag,
            at,
            problem: format!(
                "{final_weight}, but the ScanSpotMetersetWeights (300A,0396) of the beam's control \
                 points sum to {weights}; expected the two to agree (within {} %), since the MU of \
                 a spot is its weight x BeamMeterset / FinalCumulativeMetersetWeight",
                CUMULATIVE_WEIGHT_TOLERANCE * 100.0
            ),
        });
    }
    let meterset = beam_meterset(groups, index, number)?;
    Ok(BeamRead::Treatment(IonBeam {
        item: index,
        number,
        name: text(item, BEAM_NAME),
        kind,
        mu_per_weight: meterset / final_weight,
        control_points,
    }))
}

/// Refuses a plan of more than [`MAX_SPOTS`] spot deliveries (spots x paintings over all layers).
fn check_spot_total(beams: &[IonBeam]) -> Result<()> {
    let spots: u64 = beams
        .iter()
        .flat_map(|b| &b.control_points)
        .filter_map(|cp| cp.layer.as_ref())
        .map(|l| l.weights.len() as u64 * u64::from(l.paintings))
        .sum();
    if spots > MAX_SPOTS {
        return Err(DicomImportError::TooManySpots {
            spots,
            limit: MAX_SPOTS,
        });
    }
    Ok(())
}

/// BeamMeterset of the beam numbered `number`, from the first fraction group that references it
/// (the beams of the other groups are left out before this is asked).
fn beam_meterset(groups: &[FractionGroup], index: usize, number: i64) -> Result<f64> {
    let beam_at = Location::Beam {
        beam: index,
        number: Some(number),
    };
    if groups.is_empty() {
        return Err(missing(
            FRACTION_GROUP_SEQUENCE,
            Location::Dataset,
            Some("it holds the BeamMeterset of every beam"),
        ));
    }
    let Some(reference) = groups
        .iter()
        .flat_map(|g| &g.beams)
        .find(|b| b.number == number)
    else {
        return Err(DicomImportError::NoBeamMeterset {
            at: beam_at,
            number,
        });
    };
    let mu = required(reference.meterset, BEAM_METERSET, reference.at)?;
    if !(mu.is_finite() && mu >= 0.0) {
        return Err(invalid(
            BEAM_METERSET,
            reference.at,
            format!("{mu}; expected a finite MU value >= 0"),
        ));
    }
    Ok(mu)
}
