//! Writing a re-sequenced plan back as a DICOM RT Ion Plan, for review in the planning system.
//!
//! The file is the original with the energy layers of each beam in the new order and nothing else
//! changed but what the new order and the new identity require (see [`write_resequenced`]). The
//! written file is imported again before it is returned: it must give exactly the re-sequenced
//! plan.

mod beam;

use std::collections::BTreeMap;

use arcsim_plan::ArcPlan;
use dicom_core::value::DataSetSequence;
use dicom_core::{DataElement, VR};
use dicom_dictionary_std::tags;
use dicom_object::InMemDicomObject;

use crate::read::access::items;
use crate::read::attr::{ION_BEAM_SEQUENCE, ION_CONTROL_POINT_SEQUENCE};
use crate::{convert, read, DicomImportError, Location, DEFAULT_PLAN_NAME};

/// RTPlanRelationship (300A,0055) of the reference to the original: "plan used in derivation of
/// current plan" (DICOM PS3.3 C.8.8.9).
pub const RELATIONSHIP_TO_ORIGINAL: &str = "PREDECESSOR";

/// Why a re-sequenced plan cannot be written back as DICOM.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    /// The original file does not import.
    #[error("the original plan: {0}")]
    Import(#[from] DicomImportError),
    /// The re-sequenced plan is not the original's layers reordered inside control points.
    #[error(
        "arc {arc}{}: {problem}; a DICOM plan is written back only with layers reordered inside \
         their control points (arcs keep their order and direction: write arcsim JSON instead)",
        control_point.map(|c| format!(", control point {c}")).unwrap_or_default()
    )]
    NotAReorder {
        /// Arc index in the plan.
        arc: usize,
        /// Control point index in the arc, when the problem is one control point's.
        control_point: Option<usize>,
        /// What differs.
        problem: String,
    },
    /// A control point's attributes cannot keep their meaning in the new order.
    #[error("{at}: {problem}")]
    Unorderable {
        /// The control point.
        at: Location,
        /// Why.
        problem: String,
    },
    /// dicom-object could not encode the file.
    #[error("cannot encode the DICOM file: {0}")]
    Encode(String),
    /// The written file does not import to the re-sequenced plan (a bug; nothing is returned).
    #[error(
        "the written DICOM file does not read back as the re-sequenced plan (a bug in arcsim): {0}"
    )]
    ReadBack(String),
}

/// A DICOM RT Ion Plan written for a re-sequenced plan.
#[derive(Debug, Clone)]
pub struct ResequencedDicom {
    /// The complete file (preamble, meta group, data set in the original's transfer syntax).
    pub bytes: Vec<u8>,
    /// Its new SOPInstanceUID (a UUID-derived "2.25." UID).
    pub sop_instance_uid: String,
    /// The original's SOPInstanceUID, which the new plan references.
    pub original_sop_instance_uid: Option<String>,
    /// Beams whose control points were reordered.
    pub beams_reordered: usize,
}

/// The RT Ion Plan `original` (a complete file) with its layers in the order of `resequenced`, the
/// plan imported from it with layers reordered inside their control points.
///
/// What changes: in each beam whose order changed, the layers' control-point blocks (a layer's
/// control point and the ones up to the next layer) move whole; ControlPointIndex counts the new
/// order; CumulativeMetersetWeight and CumulativeDoseReferenceCoefficient are recomputed (a block
/// keeps its increments); an attribute a control point inherited is written into it where its new
/// predecessor would pass on another value. The file gets a new SOPInstanceUID (also in the meta
/// group), a ReferencedRTPlanSequence item naming the original ([`RELATIONSHIP_TO_ORIGINAL`]), and
/// ApprovalStatus UNAPPROVED (review date, time and reviewer removed): it is a new plan to review.
/// Everything else is carried over as read. The result is imported again and must equal
/// `resequenced` (arcs, control points, layers in order).
pub fn write_resequenced(
    original: &[u8],
    resequenced: &ArcPlan,
) -> Result<ResequencedDicom, WriteError> {
    let mut file = read::parse_bytes(original)?;
    read::check_sop_class(read::sop_class_of(&file).as_deref())?;
    let ion = read::read_ion_plan(&file, &mut Vec::new())?;
    let given = convert::to_arc_plan(&ion, DEFAULT_PLAN_NAME);
    let order = layer_order(&given, resequenced)?;
    // The imported layers, flattened, are the beams' layer control points in BeamNumber order.
    let sources: Vec<(usize, usize)> = ion
        .beams
        .iter()
        .flat_map(|b| {
            b.control_points
                .iter()
                .enumerate()
                .filter(|(_, cp)| cp.layer.is_some())
                .map(move |(c, _)| (b.item, c))
        })
        .collect();
    check_beams_kept(&given, &order, &sources)?;
    let mut per_beam: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for &j in &order {
        let &(b, c) = sources
            .get(j)
            .ok_or_else(|| WriteError::ReadBack(format!("layer {j} has no control point")))?;
        per_beam.entry(b).or_default().push(c);
    }
    let mut beams = items(&file, ION_BEAM_SEQUENCE).unwrap_or_default().to_vec();
    let mut beams_reordered = 0;
    for (b, new_order) in per_beam {
        let mut layers = new_order.clone();
        layers.sort_unstable();
        if layers == new_order {
            continue;
        }
        let number = ion
            .beams
            .iter()
            .find(|x| x.item == b)
            .map_or(0, |x| x.number);
        let cps = items(&beams[b], ION_CONTROL_POINT_SEQUENCE).unwrap_or_default();
        let cps = beam::reorder(cps, &layers, &new_order, (b, number))?;
        beams[b].put(sequence(ION_CONTROL_POINT_SEQUENCE.tag, cps));
        beams_reordered += 1;
    }
    if beams_reordered > 0 {
        file.put(sequence(ION_BEAM_SEQUENCE.tag, beams));
    }
    let uid = new_uid();
    renew_identity(&mut file, &uid, ion.sop_instance_uid.as_deref());

    let mut bytes = Vec::new();
    file.write_all(&mut bytes)
        .map_err(|e| WriteError::Encode(e.to_string()))?;
    let back = crate::import(&bytes, DEFAULT_PLAN_NAME)
        .map_err(|e| WriteError::ReadBack(e.to_string()))?;
    if back.plan.arcs != resequenced.arcs {
        return Err(WriteError::ReadBack(
            "its arcs, control points or layers differ from the re-sequenced plan's".into(),
        ));
    }
    Ok(ResequencedDicom {
        bytes,
        sop_instance_uid: uid,
        original_sop_instance_uid: ion.sop_instance_uid,
        beams_reordered,
    })
}

/// For each layer of `resequenced` in delivery order, the index of the same layer among
/// `given`'s (flattened in delivery order); equal layers are taken in their original order.
fn layer_order(given: &ArcPlan, resequenced: &ArcPlan) -> Result<Vec<usize>, WriteError> {
    let not = |arc, control_point, problem: String| WriteError::NotAReorder {
        arc,
        control_point,
        problem,
    };
    if given.arcs.len() != resequenced.arcs.len() {
        return Err(not(
            0,
            None,
            format!(
                "the plan has {} arcs, the original {}",
                resequenced.arcs.len(),
                given.arcs.len()
            ),
        ));
    }
    let mut order = Vec::new();
    let mut base = 0;
    for (a, (g, r)) in given.arcs.iter().zip(&resequenced.arcs).enumerate() {
        if g.direction != r.direction || g.control_points.len() != r.control_points.len() {
            return Err(not(
                a,
                None,
                "its direction or its control points differ from the original's".into(),
            ));
        }
        for (c, (gc, rc)) in g.control_points.iter().zip(&r.control_points).enumerate() {
            if gc.angle_deg != rc.angle_deg || gc.layers.len() != rc.layers.len() {
                return Err(not(
                    a,
                    Some(c),
                    "its angle or its number of layers differs from the original's".into(),
                ));
            }
            let mut used = vec![false; gc.layers.len()];
            for (l, layer) in rc.layers.iter().enumerate() {
                let j = (0..gc.layers.len())
                    .find(|&j| !used[j] && gc.layers[j] == *layer)
                    .ok_or_else(|| {
                        not(
                            a,
                            Some(c),
                            format!("layer {l} is none of the original control point's layers"),
                        )
                    })?;
                used[j] = true;
                order.push(base + j);
            }
            base += gc.layers.len();
        }
    }
    Ok(order)
}

/// A control point made of several beams' layers (static beams at one angle) keeps each beam's
/// layers where they were: DICOM delivers the beams one after the other, so a layer cannot
/// change places with another beam's.
fn check_beams_kept(
    given: &ArcPlan,
    order: &[usize],
    sources: &[(usize, usize)],
) -> Result<(), WriteError> {
    let beam_of = |j: usize| sources.get(j).map(|s| s.0);
    let mut start = 0;
    for (a, arc) in given.arcs.iter().enumerate() {
        for (c, cp) in arc.control_points.iter().enumerate() {
            let range = start..start + cp.layers.len();
            let was: Vec<_> = range.clone().map(beam_of).collect();
            let now: Vec<_> = order[range].iter().map(|&j| beam_of(j)).collect();
            if was != now {
                return Err(WriteError::NotAReorder {
                    arc: a,
                    control_point: Some(c),
                    problem: "its layers come from several beams (static beams at one angle) and \
                              a layer changed places with another beam's, which the beams' \
                              order in DICOM cannot express"
                        .into(),
                });
            }
            start += cp.layers.len();
        }
    }
    Ok(())
}

/// New SOPInstanceUID (data set and meta group), the reference to the original, unapproved.
fn renew_identity(file: &mut dicom_object::DefaultDicomObject, uid: &str, original: Option<&str>) {
    file.put(DataElement::new(tags::SOP_INSTANCE_UID, VR::UI, uid));
    file.meta_mut().media_storage_sop_instance_uid = uid.to_string();
    file.meta_mut().update_information_group_length();
    if let Some(original) = original {
        let mut refs = file
            .get(tags::REFERENCED_RT_PLAN_SEQUENCE)
            .and_then(|e| e.items())
            .unwrap_or_default()
            .to_vec();
        let mut item = InMemDicomObject::new_empty();
        item.put(DataElement::new(
            tags::REFERENCED_SOP_CLASS_UID,
            VR::UI,
            read::RT_ION_PLAN_STORAGE,
        ));
        item.put(DataElement::new(
            tags::REFERENCED_SOP_INSTANCE_UID,
            VR::UI,
            original,
        ));
        item.put(DataElement::new(
            tags::RT_PLAN_RELATIONSHIP,
            VR::CS,
            RELATIONSHIP_TO_ORIGINAL,
        ));
        refs.push(item);
        file.put(sequence(tags::REFERENCED_RT_PLAN_SEQUENCE, refs));
    }
    file.put(DataElement::new(
        tags::APPROVAL_STATUS,
        VR::CS,
        "UNAPPROVED",
    ));
    for tag in [tags::REVIEW_DATE, tags::REVIEW_TIME, tags::REVIEWER_NAME] {
        file.remove_element(tag);
    }
}

/// A UUID-derived UID (DICOM PS3.5 B.2): "2.25." and a random (version 4) UUID as a decimal.
pub(crate) fn new_uid() -> String {
    let mut u: u128 = rand::random();
    u = (u & !(0xF << 76)) | (0x4 << 76);
    u = (u & !(0x3 << 62)) | (0x2 << 62);
    format!("2.25.{u}")
}

fn sequence(tag: dicom_core::Tag, items: Vec<InMemDicomObject>) -> DataElement<InMemDicomObject> {
    DataElement::new(tag, VR::SQ, DataSetSequence::from(items))
}
