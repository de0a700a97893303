//! Writing a re-sequenced plan back as DICOM: the file reads back as the re-sequenced plan, keeps
//! every attribute the new order does not change, and says what it is (new UID, the original
//! referenced, unapproved). The oracles here are independent of the writer: the cumulative weights
//! are summed from the spot weights in the new order, inherited attributes are resolved by walking
//! the written sequence.

use std::collections::BTreeMap;

use arcsim_dicom::{read_rt_ion_plan_from_bytes, write_resequenced, WriteError};
use arcsim_plan::ArcPlan;
use arcsim_test_support::dicom::{self, BeamSpec, PlanSpec};
use dicom_core::header::Header;
use dicom_core::value::DataSetSequence;
use dicom_core::{DataElement, Tag, VR};
use dicom_dictionary_std::tags;
use dicom_object::mem::InMemElement;
use dicom_object::{from_reader, InMemDicomObject};

fn parse(bytes: &[u8]) -> InMemDicomObject {
    // from_reader expects the stream after the 128-byte preamble.
    from_reader(&bytes[128..])
        .expect("a DICOM file")
        .into_inner()
}

fn seq(obj: &InMemDicomObject, tag: Tag) -> &[InMemDicomObject] {
    obj.get(tag).and_then(|e| e.items()).unwrap_or_default()
}

fn float(obj: &InMemDicomObject, tag: Tag) -> Option<f64> {
    obj.get(tag).and_then(|e| e.to_float64().ok())
}

fn string(obj: &InMemDicomObject, tag: Tag) -> Option<String> {
    obj.get(tag)
        .and_then(|e| e.to_str().ok())
        .map(|s| s.trim_end_matches(['\0', ' ']).to_string())
}

/// `plan` with each control point's layers reversed: every control point with 2+ layers moves.
fn reversed_inside(plan: &ArcPlan) -> ArcPlan {
    let mut out = plan.clone();
    for cp in out.arcs.iter_mut().flat_map(|a| &mut a.control_points) {
        cp.layers.reverse();
    }
    out
}

/// The multi-layer fixture with extra attributes to carry over: a patient name and a private tag
/// at the top, approval, a snout position given once (inherited by every control point), a dose
/// reference coefficient in every control point (cumulative weight / final weight).
fn rich_fixture() -> PlanSpec {
    let mut spec = dicom::multi_layer_arc_plan();
    for beam in &mut spec.beams {
        let total = beam.final_weight();
        beam.extra.push(DataElement::new(
            tags::SNOUT_SEQUENCE,
            VR::SQ,
            DataSetSequence::from(vec![{
                let mut s = InMemDicomObject::new_empty();
                s.put(DataElement::new(tags::SNOUT_ID, VR::SH, "SNOUT-A"));
                s
            }]),
        ));
        for (c, cp) in beam.cps.iter_mut().enumerate() {
            if c == 0 {
                cp.extra.push(DataElement::new(
                    tags::SNOUT_POSITION,
                    VR::FL,
                    dicom_core::value::PrimitiveValue::F32([421.5].into_iter().collect()),
                ));
            }
            let mut item = InMemDicomObject::new_empty();
            item.put(DataElement::new(
                tags::REFERENCED_DOSE_REFERENCE_NUMBER,
                VR::IS,
                "1",
            ));
            item.put(DataElement::new(
                tags::CUMULATIVE_DOSE_REFERENCE_COEFFICIENT,
                VR::DS,
                dicom::ds(cp.cumulative / total),
            ));
            cp.extra.push(DataElement::new(
                tags::REFERENCED_DOSE_REFERENCE_SEQUENCE,
                VR::SQ,
                DataSetSequence::from(vec![item]),
            ));
        }
    }
    spec
}

fn with_top_level(bytes: &[u8]) -> Vec<u8> {
    let mut obj = parse(bytes);
    obj.put(DataElement::new(tags::PATIENT_NAME, VR::PN, "Phantom^Arc"));
    obj.put(DataElement::new(tags::APPROVAL_STATUS, VR::CS, "APPROVED"));
    obj.put(DataElement::new(tags::REVIEWER_NAME, VR::PN, "Doe^Jane"));
    obj.put(DataElement::new(Tag(0x0011, 0x0010), VR::LO, "ARCSIM TEST"));
    obj.put(DataElement::new(Tag(0x0011, 0x1001), VR::LO, "kept"));
    dicom::file_bytes(obj)
}

#[test]
fn a_reordered_plan_reads_back_as_the_resequenced_plan() {
    let original = with_top_level(&rich_fixture().to_bytes());
    let plan = read_rt_ion_plan_from_bytes(&original).expect("fixture imports");
    let target = reversed_inside(&plan);
    assert_ne!(plan.arcs, target.arcs, "the fixture has layers to move");
    let written = write_resequenced(&original, &target).expect("written back");
    assert_eq!(written.beams_reordered, 2);
    let back = read_rt_ion_plan_from_bytes(&written.bytes).expect("our importer reads it");
    assert_eq!(back.arcs, target.arcs);
    assert_eq!(back.name, plan.name);
}

#[test]
fn the_new_plan_has_its_own_uid_references_the_original_and_awaits_review() {
    let original = with_top_level(&rich_fixture().to_bytes());
    let plan = read_rt_ion_plan_from_bytes(&original).expect("fixture imports");
    let written = write_resequenced(&original, &reversed_inside(&plan)).expect("written back");
    let before = parse(&original);
    let after = parse(&written.bytes);
    let old_uid = string(&before, tags::SOP_INSTANCE_UID).expect("uid");
    let new_uid = string(&after, tags::SOP_INSTANCE_UID).expect("uid");
    assert_eq!(new_uid, written.sop_instance_uid);
    assert_ne!(new_uid, old_uid);
    assert!(
        new_uid.starts_with("2.25.") && new_uid.len() <= 64,
        "{new_uid}"
    );
    assert!(
        new_uid[5..].chars().all(|c| c.is_ascii_digit()),
        "{new_uid}"
    );
    let meta = from_reader(&written.bytes[128..]).expect("file");
    assert_eq!(
        meta.meta()
            .media_storage_sop_instance_uid()
            .trim_end_matches('\0'),
        new_uid
    );
    // A second write is another plan.
    let again = write_resequenced(&original, &reversed_inside(&plan)).expect("written back");
    assert_ne!(again.sop_instance_uid, written.sop_instance_uid);

    let refs = seq(&after, tags::REFERENCED_RT_PLAN_SEQUENCE);
    assert_eq!(refs.len(), 1);
    assert_eq!(
        string(&refs[0], tags::REFERENCED_SOP_INSTANCE_UID),
        Some(old_uid)
    );
    assert_eq!(
        string(&refs[0], tags::REFERENCED_SOP_CLASS_UID).as_deref(),
        Some("1.2.840.10008.5.1.4.1.1.481.8")
    );
    assert_eq!(
        string(&refs[0], tags::RT_PLAN_RELATIONSHIP).as_deref(),
        Some("PREDECESSOR")
    );
    assert_eq!(
        string(&after, tags::APPROVAL_STATUS).as_deref(),
        Some("UNAPPROVED")
    );
    assert!(after.get(tags::REVIEWER_NAME).is_none());
}

/// Two elements hold the same value (sequences item by item; strings without their padding; the
/// encoded lengths, which differ between writers, ignored).
fn same(a: &InMemElement, b: &InMemElement) -> bool {
    if a.tag() != b.tag() {
        return false;
    }
    match (a.items(), b.items()) {
        (Some(x), Some(y)) => x.len() == y.len() && x.iter().zip(y).all(|(p, q)| same_set(p, q)),
        (None, None) => match (a.to_str(), b.to_str()) {
            (Ok(p), Ok(q)) => p.trim_end_matches(['\0', ' ']) == q.trim_end_matches(['\0', ' ']),
            _ => a.value() == b.value(),
        },
        _ => false,
    }
}

fn same_set(a: &InMemDicomObject, b: &InMemDicomObject) -> bool {
    a.tags().count() == b.tags().count()
        && a.iter().all(|e| b.get(e.tag()).is_some_and(|f| same(e, f)))
}

/// Every attribute in force at each control point, resolving inheritance by walking the sequence.
fn in_force(cps: &[InMemDicomObject]) -> Vec<BTreeMap<Tag, InMemElement>> {
    let own = [
        tags::CONTROL_POINT_INDEX,
        tags::CUMULATIVE_METERSET_WEIGHT,
        tags::REFERENCED_DOSE_REFERENCE_SEQUENCE,
    ];
    let mut state = BTreeMap::new();
    cps.iter()
        .map(|cp| {
            for e in cp.iter().filter(|e| !own.contains(&e.tag())) {
                state.insert(e.tag(), e.clone());
            }
            state.clone()
        })
        .collect()
}

#[test]
fn every_attribute_the_order_does_not_change_is_carried_over() {
    let original = with_top_level(&rich_fixture().to_bytes());
    let plan = read_rt_ion_plan_from_bytes(&original).expect("fixture imports");
    let written = write_resequenced(&original, &reversed_inside(&plan)).expect("written back");
    let (before, after) = (parse(&original), parse(&written.bytes));
    let changed = [
        tags::SOP_INSTANCE_UID,
        tags::REFERENCED_RT_PLAN_SEQUENCE,
        tags::APPROVAL_STATUS,
        tags::REVIEWER_NAME,
        tags::ION_BEAM_SEQUENCE,
    ];
    for e in before.iter().filter(|e| !changed.contains(&e.tag())) {
        assert!(
            after.get(e.tag()).is_some_and(|f| same(e, f)),
            "{} changed",
            e.tag()
        );
    }
    for (b, (old, new)) in seq(&before, tags::ION_BEAM_SEQUENCE)
        .iter()
        .zip(seq(&after, tags::ION_BEAM_SEQUENCE))
        .enumerate()
    {
        for e in old
            .iter()
            .filter(|e| e.tag() != tags::ION_CONTROL_POINT_SEQUENCE)
        {
            assert!(
                new.get(e.tag()).is_some_and(|f| same(e, f)),
                "beam {b}: {} changed",
                e.tag()
            );
        }
        let (old_cps, new_cps) = (
            seq(old, tags::ION_CONTROL_POINT_SEQUENCE),
            seq(new, tags::ION_CONTROL_POINT_SEQUENCE),
        );
        assert_eq!(old_cps.len(), new_cps.len());
        // Each written control point is an original one (found by its weights and positions) with
        // the same attributes in force.
        let (old_state, new_state) = (in_force(old_cps), in_force(new_cps));
        let mut used = vec![false; old_cps.len()];
        for (c, state) in new_state.iter().enumerate() {
            let o = (0..old_cps.len())
                .find(|&o| {
                    !used[o]
                        && old_state[o].len() == state.len()
                        && old_state[o]
                            .iter()
                            .all(|(t, e)| state.get(t).is_some_and(|f| same(e, f)))
                })
                .unwrap_or_else(|| {
                    panic!("beam {b} control point {c}: no original has its attributes")
                });
            used[o] = true;
            assert_eq!(
                string(&new_cps[c], tags::CONTROL_POINT_INDEX),
                Some(c.to_string())
            );
        }
    }
}

#[test]
fn cumulative_weights_and_dose_coefficients_follow_the_new_order() {
    let spec = rich_fixture();
    let original = spec.to_bytes();
    let plan = read_rt_ion_plan_from_bytes(&original).expect("fixture imports");
    let written = write_resequenced(&original, &reversed_inside(&plan)).expect("written back");
    let after = parse(&written.bytes);
    for (b, beam) in seq(&after, tags::ION_BEAM_SEQUENCE).iter().enumerate() {
        let total = spec.beams[b].final_weight();
        let mut delivered = 0.0;
        for (c, cp) in seq(beam, tags::ION_CONTROL_POINT_SEQUENCE)
            .iter()
            .enumerate()
        {
            let cumulative = float(cp, tags::CUMULATIVE_METERSET_WEIGHT).expect("cumulative");
            assert!(
                (cumulative - delivered).abs() < 1e-6 * total,
                "beam {b} control point {c}: CumulativeMetersetWeight {cumulative}, the weights before it sum to {delivered}"
            );
            let dose = seq(cp, tags::REFERENCED_DOSE_REFERENCE_SEQUENCE);
            let coefficient =
                float(&dose[0], tags::CUMULATIVE_DOSE_REFERENCE_COEFFICIENT).expect("coefficient");
            assert!(
                (coefficient - delivered / total).abs() < 1e-6,
                "beam {b} control point {c}: coefficient {coefficient}, expected {}",
                delivered / total
            );
            let weights: f64 = cp
                .get(tags::SCAN_SPOT_METERSET_WEIGHTS)
                .and_then(|e| e.to_multi_float64().ok())
                .map_or(0.0, |w| w.iter().sum());
            delivered += weights;
        }
        assert!((delivered - total).abs() < 1e-6 * total);
    }
}

#[test]
fn the_order_as_given_changes_only_the_identity() {
    let original = rich_fixture().to_bytes();
    let plan = read_rt_ion_plan_from_bytes(&original).expect("fixture imports");
    let written = write_resequenced(&original, &plan).expect("written back");
    assert_eq!(written.beams_reordered, 0);
    let (before, after) = (parse(&original), parse(&written.bytes));
    let beams = |o: &InMemDicomObject| o.get(tags::ION_BEAM_SEQUENCE).cloned();
    let (old, new) = (
        beams(&before).expect("beams"),
        beams(&after).expect("beams"),
    );
    assert!(same(&old, &new), "the beams changed");
}

#[test]
fn a_plan_that_is_not_a_reorder_is_refused() {
    let original = dicom::multi_layer_arc_plan().to_bytes();
    let plan = read_rt_ion_plan_from_bytes(&original).expect("fixture imports");
    // One spot's MU changed.
    let mut changed = reversed_inside(&plan);
    if let Some(mu) = changed.arcs[0].control_points[2].layers[1]
        .spots
        .as_mut()
        .and_then(|s| s.mu.as_mut())
    {
        mu[0] += 0.001;
    }
    let e = write_resequenced(&original, &changed).expect_err("a changed spot");
    assert!(
        matches!(
            e,
            WriteError::NotAReorder {
                arc: 0,
                control_point: Some(2),
                ..
            }
        ),
        "{e}"
    );
    // An arc turned the other way.
    let mut turned = plan.clone();
    turned.arcs[1].direction = turned.arcs[0].direction;
    let e = write_resequenced(&original, &turned).expect_err("a turned arc");
    assert!(matches!(e, WriteError::NotAReorder { arc: 1, .. }), "{e}");
    assert!(e.to_string().contains("arcsim JSON"), "{e}");
    // A layer moved to another control point.
    let mut moved = plan.clone();
    let layer = moved.arcs[0].control_points[0].layers.pop().expect("layer");
    moved.arcs[0].control_points[1].layers.push(layer);
    assert!(write_resequenced(&original, &moved).is_err());
    // Not a DICOM file.
    assert!(matches!(
        write_resequenced(b"{}", &plan),
        Err(WriteError::Import(_))
    ));
}

#[test]
fn an_attribute_that_cannot_be_cleared_is_refused_by_name() {
    // A control point gives SnoutPosition only from the second layer on: the first layer, moved
    // after it, would inherit a value it never had.
    let mut spec = dicom::multi_layer_arc_plan();
    spec.beams[0].cps[2].extra.push(DataElement::new(
        tags::SNOUT_POSITION,
        VR::FL,
        dicom_core::value::PrimitiveValue::F32([300.0].into_iter().collect()),
    ));
    let original = spec.to_bytes();
    let plan = read_rt_ion_plan_from_bytes(&original).expect("fixture imports");
    let e = write_resequenced(&original, &reversed_inside(&plan)).expect_err("refused");
    let text = e.to_string();
    assert!(
        text.contains("IonControlPointSequence[0]") && text.contains("(300A,030D)"),
        "{text}"
    );
}

/// The file is written in the original's transfer syntax: implicit VR and deflated plans read
/// back as the re-sequenced plan too.
#[test]
fn the_original_transfer_syntax_is_kept() {
    for ts in [
        dicom_dictionary_std::uids::IMPLICIT_VR_LITTLE_ENDIAN,
        dicom_dictionary_std::uids::DEFLATED_EXPLICIT_VR_LITTLE_ENDIAN,
    ] {
        let original = dicom::file_bytes_ts(dicom::multi_layer_arc_plan().dataset(), ts);
        let plan = read_rt_ion_plan_from_bytes(&original).expect("fixture imports");
        let target = reversed_inside(&plan);
        let written = write_resequenced(&original, &target).expect("written back");
        let file = from_reader(&written.bytes[128..]).expect("file");
        assert_eq!(file.meta().transfer_syntax().trim_end_matches('\0'), ts);
        let back = read_rt_ion_plan_from_bytes(&written.bytes).expect("reads back");
        assert_eq!(back.arcs, target.arcs, "{ts}");
    }
}

/// Static beams at one angle make one control point of several beams' layers: reordering inside
/// a beam is written, a layer moved before another beam's is refused with the reason.
#[test]
fn layers_of_static_beams_at_one_angle_stay_with_their_beam() {
    let layer = |energy: f64, i: usize| dicom::Layer {
        angle: 90.0,
        energy,
        weights: dicom::weights_of(i),
    };
    let beams = vec![
        BeamSpec::from_layers(
            1,
            "STATIC",
            "NONE",
            100.0,
            &[layer(120.0, 0), layer(150.0, 1)],
        ),
        BeamSpec::from_layers(
            2,
            "STATIC",
            "NONE",
            100.0,
            &[layer(130.0, 2), layer(160.0, 3)],
        ),
    ];
    let original = PlanSpec::ion("STATIC2", beams).to_bytes();
    let plan = read_rt_ion_plan_from_bytes(&original).expect("fixture imports");
    assert_eq!(plan.arcs[0].control_points.len(), 1);
    assert_eq!(plan.arcs[0].control_points[0].layers.len(), 4);
    // Inside each beam: written.
    let mut inside = plan.clone();
    inside.arcs[0].control_points[0].layers.swap(0, 1);
    inside.arcs[0].control_points[0].layers.swap(2, 3);
    let written = write_resequenced(&original, &inside).expect("written back");
    assert_eq!(written.beams_reordered, 2);
    let back = read_rt_ion_plan_from_bytes(&written.bytes).expect("reads back");
    assert_eq!(back.arcs, inside.arcs);
    // Across beams: refused, naming why.
    let mut across = plan.clone();
    across.arcs[0].control_points[0].layers.swap(1, 2);
    let e = write_resequenced(&original, &across).expect_err("refused");
    assert!(e.to_string().contains("another beam's"), "{e}");
}
