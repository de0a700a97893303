//! RT Ion Plan import, end to end: generated DICOM files -> ArcPlan, checked value by value.

use arcsim_dicom::{
    is_dicom_file, read_rt_ion_plan, read_rt_ion_plan_from_bytes, rt_ion_plan_from_dataset,
    DicomImportError, Location, MAX_NESTING, MAX_PAINTINGS, MAX_SPOTS, POSITION_RESOLUTION_MM,
};
use arcsim_plan::{ArcPlan, RotationDirection, Spots, MAX_SPOTS_PER_LAYER, PLAN_FORMAT};
use arcsim_test_support::dicom::{self, BeamSpec, Layer, PlanSpec, SpotMap};
use arcsim_test_support::{temp_dir, temp_file};
use dicom_core::value::PrimitiveValue;
use dicom_core::{DataElement, VR};
use dicom_dictionary_std::tags;

const TOL: f64 = 1e-9;

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= TOL * b.abs().max(1.0)
}

fn import(spec: &PlanSpec, file_name: &str) -> ArcPlan {
    let path = spec.write(file_name);
    match read_rt_ion_plan(&path) {
        Ok(plan) => plan,
        Err(e) => panic!("import of {file_name} failed: {e}"),
    }
}

fn import_err(spec: &PlanSpec) -> DicomImportError {
    match read_rt_ion_plan_from_bytes(&spec.to_bytes()) {
        Ok(_) => panic!("expected an import error"),
        Err(e) => e,
    }
}

fn spots_of(plan: &ArcPlan, arc: usize, cp: usize, layer: usize) -> &Spots {
    plan.arcs[arc].control_points[cp].layers[layer]
        .spots
        .as_ref()
        .expect("spots")
}

fn layer_mu(plan: &ArcPlan, arc: usize, cp: usize, layer: usize) -> Vec<f64> {
    let spots = plan.arcs[arc].control_points[cp].layers[layer]
        .spots
        .as_ref()
        .expect("spots");
    spots.mu.clone().expect("per-spot MU")
}

fn total_mu(plan: &ArcPlan) -> f64 {
    plan.arcs
        .iter()
        .flat_map(|a| &a.control_points)
        .flat_map(|cp| &cp.layers)
        .filter_map(|l| l.spots.as_ref()?.mu.as_ref())
        .flatten()
        .sum()
}

fn angles(plan: &ArcPlan, arc: usize) -> Vec<f64> {
    plan.arcs[arc]
        .control_points
        .iter()
        .map(|cp| cp.angle_deg)
        .collect()
}

// ---- arcs ------------------------------------------------------------------------------------------

#[test]
fn dynamic_arc_of_180_layer_pairs() {
    let spec = dicom::dynamic_arc_plan();
    assert_eq!(
        spec.beams[0].cps.len(),
        360,
        "fixture: 180 layers as control-point pairs"
    );
    let plan = import(&spec, "arc180.dcm");

    assert_eq!(plan.format, PLAN_FORMAT);
    assert_eq!(plan.name, "ARC180");
    assert_eq!(plan.arcs.len(), 1);
    let arc = &plan.arcs[0];
    assert_eq!(arc.direction, RotationDirection::Cw);
    assert_eq!(arc.control_points.len(), 180);

    let final_weight = spec.beams[0].final_weight();
    for (i, cp) in arc.control_points.iter().enumerate() {
        // 181, 183, ..., 359, 361 (= 1 in the file), ..., 539: unwrapped across 360.
        assert!(
            close(cp.angle_deg, 181.0 + 2.0 * i as f64),
            "cp {i}: angle {}",
            cp.angle_deg
        );
        assert_eq!(cp.layers.len(), 1, "cp {i}");
        let layer = &cp.layers[0];
        assert_eq!(
            layer.energy_mev,
            dicom::energy_of(i),
            "cp {i}: energy (inherited where absent)"
        );
        let weights = dicom::weights_of(i);
        let spots = layer.spots.as_ref().expect("spots");
        assert_eq!(spots.count as usize, weights.len(), "cp {i}: spot count");
        assert!(spots.total_mu.is_none());
        let mu = spots.mu.as_ref().expect("mu");
        for (m, w) in mu.iter().zip(&weights) {
            assert!(
                close(*m, f64::from(*w) * 1234.5 / final_weight),
                "cp {i}: {m} vs weight {w}"
            );
        }
        assert!(layer.irradiation_time_s.is_none() && layer.switching_time_s.is_none());
        assert!(cp.window_deg.is_none() && cp.required_speed_deg_per_s.is_none());
    }
    assert!(
        close(total_mu(&plan), 1234.5),
        "all spots add up to BeamMeterset: {}",
        total_mu(&plan)
    );
    let description = plan.description.as_deref().unwrap_or_default();
    assert!(
        description.contains("ARC180") && description.contains("dynamic"),
        "{description}"
    );
}

#[test]
fn static_beams_form_one_arc_in_beam_number_order() {
    let spec = dicom::static_arc_plan();
    let plan = import(&spec, "static5.dcm");
    assert_eq!(plan.arcs.len(), 1);
    assert_eq!(plan.arcs[0].direction, RotationDirection::Cw);
    // 340, 350, 0, 10, 20 in the file: CW across 0.
    assert_eq!(angles(&plan, 0), vec![340.0, 350.0, 360.0, 370.0, 380.0]);
    for i in 0..5 {
        let cp = &plan.arcs[0].control_points[i];
        assert_eq!(cp.layers.len(), 1);
        assert_eq!(cp.layers[0].energy_mev, 150.0 - i as f64);
        let weights = dicom::weights_of(i);
        let sum: f64 = weights.iter().map(|&w| f64::from(w)).sum();
        let meterset = 100.0 + 10.0 * i as f64;
        let mu = layer_mu(&plan, 0, i, 0);
        assert_eq!(mu.len(), weights.len());
        for (m, w) in mu.iter().zip(&weights) {
            assert!(
                close(*m, f64::from(*w) * meterset / sum),
                "beam {}: {m}",
                i + 1
            );
        }
    }
}

fn static_beams(angles: &[f64]) -> PlanSpec {
    let beams = angles
        .iter()
        .enumerate()
        .map(|(i, &a)| {
            let layer = Layer {
                angle: a,
                energy: 100.0 + i as f64,
                weights: dicom::weights_of(i),
            };
            BeamSpec::from_layers(i as i64 + 1, "STATIC", "NONE", 50.0, &[layer])
        })
        .collect();
    PlanSpec::ion("STATIC", beams)
}

#[test]
fn static_beams_split_where_the_angle_turns_back() {
    let plan = import(
        &static_beams(&[10.0, 20.0, 30.0, 25.0, 15.0]),
        "reverse.dcm",
    );
    assert_eq!(plan.arcs.len(), 2);
    assert_eq!(plan.arcs[0].direction, RotationDirection::Cw);
    assert_eq!(angles(&plan, 0), vec![10.0, 20.0, 30.0]);
    assert_eq!(plan.arcs[1].direction, RotationDirection::Cc);
    assert_eq!(angles(&plan, 1), vec![25.0, 15.0]);
}

#[test]
fn static_beams_at_one_angle_share_a_control_point() {
    let plan = import(&static_beams(&[90.0, 90.0, 100.0]), "same-angle.dcm");
    assert_eq!(plan.arcs.len(), 1);
    assert_eq!(angles(&plan, 0), vec![90.0, 100.0]);
    let energies: Vec<f64> = plan.arcs[0].control_points[0]
        .layers
        .iter()
        .map(|l| l.energy_mev)
        .collect();
    assert_eq!(energies, vec![100.0, 101.0]);
}

#[test]
fn a_single_static_beam_is_a_one_point_cw_arc() {
    let plan = import(&static_beams(&[45.0]), "single.dcm");
    assert_eq!(plan.arcs.len(), 1);
    assert_eq!(plan.arcs[0].direction, RotationDirection::Cw);
    assert_eq!(angles(&plan, 0), vec![45.0]);
}

#[test]
fn cw_and_cc_dynamic_beams_are_separate_sub_arcs() {
    let plan = import(&dicom::two_arc_plan(), "two-arcs.dcm");
    assert_eq!(plan.arcs.len(), 2);
    assert_eq!(plan.arcs[0].direction, RotationDirection::Cw);
    assert_eq!(plan.arcs[1].direction, RotationDirection::Cc);
    let expected_cw: Vec<f64> = (0..11).map(|i| 180.0 + 2.0 * i as f64).collect();
    let expected_cc: Vec<f64> = (0..11).map(|i| 200.0 - 2.0 * i as f64).collect();
    assert_eq!(angles(&plan, 0), expected_cw);
    assert_eq!(angles(&plan, 1), expected_cc);
    // Each beam's MU follow its own BeamMeterset (500 and 400).
    let arc_mu = |a: usize| -> f64 {
        (0..11)
            .map(|c| layer_mu(&plan, a, c, 0).iter().sum::<f64>())
            .sum()
    };
    assert!(close(arc_mu(0), 500.0) && close(arc_mu(1), 400.0));
}

#[test]
fn layers_at_one_angle_of_a_dynamic_beam_share_a_control_point() {
    let layers: Vec<Layer> = [
        (0.0, 150.0),
        (0.0, 140.0),
        (2.0, 150.0),
        (2.0, 130.0),
        (4.0, 120.0),
    ]
    .iter()
    .enumerate()
    .map(|(i, &(angle, energy))| Layer {
        angle,
        energy,
        weights: dicom::weights_of(i),
    })
    .collect();
    let spec = PlanSpec::ion(
        "MULTI",
        vec![BeamSpec::from_layers(1, "DYNAMIC", "CW", 10.0, &layers)],
    );
    let plan = import(&spec, "multi.dcm");
    assert_eq!(angles(&plan, 0), vec![0.0, 2.0, 4.0]);
    let energies: Vec<Vec<f64>> = plan.arcs[0]
        .control_points
        .iter()
        .map(|cp| cp.layers.iter().map(|l| l.energy_mev).collect())
        .collect();
    assert_eq!(
        energies,
        vec![vec![150.0, 140.0], vec![150.0, 130.0], vec![120.0]]
    );
}

#[test]
fn a_dynamic_beam_that_reverses_is_split() {
    let layers: Vec<Layer> = [0.0, 2.0, 4.0, 2.0, 0.0]
        .iter()
        .enumerate()
        .map(|(i, &angle)| Layer {
            angle,
            energy: 100.0,
            weights: dicom::weights_of(i),
        })
        .collect();
    let mut beam = BeamSpec::from_layers(1, "DYNAMIC", "CW", 10.0, &layers);
    // From the third layer on the gantry turns back: CC.
    for cp in beam.cps.iter_mut().skip(5) {
        if cp.rotation.is_some() {
            cp.rotation = Some("CC");
        }
    }
    beam.cps[5].rotation = Some("CC");
    beam.cps[4].rotation = Some("CC");
    let plan = import(&PlanSpec::ion("REV", vec![beam]), "reverse-dynamic.dcm");
    assert_eq!(plan.arcs.len(), 2);
    assert_eq!(
        (plan.arcs[0].direction, angles(&plan, 0)),
        (RotationDirection::Cw, vec![0.0, 2.0, 4.0])
    );
    assert_eq!(
        (plan.arcs[1].direction, angles(&plan, 1)),
        (RotationDirection::Cc, vec![2.0, 0.0])
    );
}

#[test]
fn a_cc_arc_across_zero_stays_above_zero() {
    let layers = dicom::dynamic_arc_layers(10.0, -5.0, 5); // 10, 5, 0, 355, 350
    let plan = import(
        &PlanSpec::ion(
            "CC0",
            vec![BeamSpec::from_layers(1, "DYNAMIC", "CC", 10.0, &layers)],
        ),
        "cc0.dcm",
    );
    assert_eq!(plan.arcs[0].direction, RotationDirection::Cc);
    assert_eq!(angles(&plan, 0), vec![370.0, 365.0, 360.0, 355.0, 350.0]);
}

#[test]
fn rotation_none_takes_the_shortest_way() {
    let layers = dicom::dynamic_arc_layers(10.0, -2.0, 3);
    let plan = import(
        &PlanSpec::ion(
            "NONE",
            vec![BeamSpec::from_layers(1, "DYNAMIC", "NONE", 10.0, &layers)],
        ),
        "none.dcm",
    );
    assert_eq!(plan.arcs[0].direction, RotationDirection::Cc);
    assert_eq!(angles(&plan, 0), vec![10.0, 8.0, 6.0]);
}

#[test]
fn paintings_are_kept_as_a_count_and_each_spot_has_its_total_mu() {
    // The spot list is not repeated once per painting (that would give 3 x the spots, each with
    // MU / 3): the layer keeps one spot per DICOM spot with its total MU and `paintings` says how
    // many passes the beam model makes over them.
    let layers = dicom::dynamic_arc_layers(0.0, 2.0, 2);
    let mut beam = BeamSpec::from_layers(1, "DYNAMIC", "CW", 80.0, &layers);
    beam.cps[0].paintings = Some(3);
    beam.cps[2].paintings = Some(1);
    let final_weight = beam.final_weight();
    let plan = import(&PlanSpec::ion("PAINT", vec![beam]), "paint.dcm");
    let w0 = dicom::weights_of(0);
    let spots = spots_of(&plan, 0, 0, 0);
    assert_eq!(
        spots.count as usize,
        w0.len(),
        "one native spot per DICOM spot"
    );
    assert_eq!(spots.paintings, Some(3));
    let mu0 = layer_mu(&plan, 0, 0, 0);
    assert_eq!(mu0.len(), w0.len());
    for (k, (m, w)) in mu0.iter().zip(&w0).enumerate() {
        assert!(
            close(*m, f64::from(*w) * 80.0 / final_weight),
            "spot {k}: {m} is the total over the 3 paintings"
        );
    }
    let spots1 = spots_of(&plan, 0, 1, 0);
    assert_eq!(spots1.count as usize, dicom::weights_of(1).len());
    assert_eq!(spots1.paintings, None, "NumberOfPaintings 1 is left out");
    assert!(
        close(total_mu(&plan), 80.0),
        "the MU add up to BeamMeterset"
    );
}

#[test]
fn setup_beams_are_left_out_and_listed() {
    let mut spec = dicom::two_arc_plan();
    spec.beams[1].delivery = "SETUP";
    let plan = import(&spec, "setup.dcm");
    assert_eq!(plan.arcs.len(), 1);
    assert!(plan
        .description
        .as_deref()
        .unwrap_or_default()
        .contains("setup beam"));
}

// ---- entry points and round trip ---------------------------------------------------------------------

#[test]
fn all_entry_points_agree_and_json_round_trips() {
    let spec = dicom::two_arc_plan();
    let path = spec.write("plan.dcm");
    let from_path = read_rt_ion_plan(&path).expect("from path");
    let mut from_bytes = read_rt_ion_plan_from_bytes(&spec.to_bytes()).expect("from bytes");
    let mut from_dataset = rt_ion_plan_from_dataset(&spec.dataset()).expect("from data set");
    // Only the bytes/data-set variants lack a file name; all have the label here.
    assert_eq!(from_path, from_bytes);
    from_bytes.name.clear();
    from_dataset.name.clear();
    assert_eq!(from_bytes, from_dataset);

    let json = arcsim_plan::to_json(&from_path);
    let back = arcsim_plan::parse_plan(&json, "plan.json").expect("parses back");
    assert_eq!(back, from_path);
    let pretty = serde_json::to_string_pretty(&from_path).expect("serialises");
    let back: ArcPlan = serde_json::from_str(&pretty).expect("parses back");
    assert_eq!(back, from_path);
}

#[test]
fn plan_without_label_is_named_after_the_file() {
    let mut spec = dicom::static_arc_plan();
    spec.label = None;
    assert_eq!(import(&spec, "my-plan.dcm").name, "my-plan");
}

#[test]
fn dicom_is_recognised_by_content_not_extension() {
    let dcm = temp_file("plan.txt", &dicom::static_arc_plan().to_bytes());
    assert!(is_dicom_file(&dcm));
    let json = temp_file("plan.dcm", b"{\"format\": \"arcsim-plan/1\"}");
    assert!(!is_dicom_file(&json));
    assert!(!is_dicom_file(temp_dir().join("missing.dcm")));
}

// ---- errors ----------------------------------------------------------------------------------------

fn message(e: &DicomImportError) -> String {
    e.to_string()
}

#[test]
fn missing_gantry_angle_names_tag_beam_and_control_point() {
    let mut spec = dicom::two_arc_plan();
    spec.beams[1].cps[0].angle = None;
    let e = import_err(&spec);
    assert!(
        matches!(
            e,
            DicomImportError::MissingTag {
                keyword: "GantryAngle",
                ..
            }
        ),
        "{e:?}"
    );
    let m = message(&e);
    assert!(m.contains("GantryAngle (300A,011E)"), "{m}");
    assert!(
        m.contains("IonBeamSequence[1] (BeamNumber 2) > IonControlPointSequence[0]"),
        "{m}"
    );
}

#[test]
fn missing_energy_names_the_control_point_that_needs_it() {
    let mut spec = dicom::dynamic_arc_plan();
    spec.beams[0].cps[0].energy = None;
    let m = message(&import_err(&spec));
    assert!(
        m.contains("NominalBeamEnergy (300A,0114)") && m.contains("IonControlPointSequence[0]"),
        "{m}"
    );
}

#[test]
fn missing_final_cumulative_meterset_weight() {
    let mut spec = dicom::static_arc_plan();
    spec.beams[0].write_final_weight = false; // BeamNumber 5, first item of the sequence
    let m = message(&import_err(&spec));
    assert!(
        m.contains("FinalCumulativeMetersetWeight (300A,010E)"),
        "{m}"
    );
    assert!(m.contains("IonBeamSequence[0] (BeamNumber 5)"), "{m}");
}

#[test]
fn missing_beam_meterset() {
    let mut spec = dicom::two_arc_plan();
    spec.beams[1].meterset = None;
    let m = message(&import_err(&spec));
    assert!(m.contains("BeamMeterset (300A,0086)"), "{m}");
    assert!(
        m.contains("FractionGroupSequence[0] > ReferencedBeamSequence[1]"),
        "{m}"
    );

    let mut spec = dicom::two_arc_plan();
    spec.beams[0].referenced = false;
    let e = import_err(&spec);
    assert!(
        matches!(e, DicomImportError::NoBeamMeterset { number: 1, .. }),
        "{e:?}"
    );
    assert!(
        message(&e).contains("ReferencedBeamNumber (300C,0006) 1"),
        "{e}"
    );
}

#[test]
fn weight_count_must_equal_spot_count() {
    let mut spec = dicom::dynamic_arc_plan();
    spec.beams[0].cps[4].n_spots = Some(99);
    let e = import_err(&spec);
    assert!(
        matches!(e, DicomImportError::SpotCountMismatch { spots: 99, .. }),
        "{e:?}"
    );
    let m = message(&e);
    assert!(
        m.contains("IonControlPointSequence[4]")
            && m.contains("NumberOfScanSpotPositions (300A,0392) is 99"),
        "{m}"
    );
}

#[test]
fn weights_without_spot_count() {
    let mut spec = dicom::dynamic_arc_plan();
    spec.beams[0].cps[2].n_spots = None;
    let m = message(&import_err(&spec));
    assert!(
        m.contains("missing NumberOfScanSpotPositions (300A,0392)")
            && m.contains("IonControlPointSequence[2]"),
        "{m}"
    );

    let mut spec = dicom::dynamic_arc_plan();
    spec.beams[0].cps[2].weights = None;
    let m = message(&import_err(&spec));
    assert!(
        m.contains("missing ScanSpotMetersetWeights (300A,0396)")
            && m.contains("IonControlPointSequence[2]"),
        "{m}"
    );
}

#[test]
fn photon_plan_is_rejected_clearly() {
    let e = import_err(&dicom::photon_plan());
    assert!(matches!(e, DicomImportError::PhotonPlan { .. }), "{e:?}");
    let m = message(&e);
    assert!(
        m.contains("photon") && m.contains("1.2.840.10008.5.1.4.1.1.481.5"),
        "{m}"
    );
    assert!(m.contains("1.2.840.10008.5.1.4.1.1.481.8"), "{m}");
}

#[test]
fn other_sop_classes_are_named() {
    let mut spec = dicom::static_arc_plan();
    spec.sop_class = dicom_dictionary_std::uids::CT_IMAGE_STORAGE;
    let e = import_err(&spec);
    let m = message(&e);
    assert!(
        m.contains("1.2.840.10008.5.1.4.1.1.2") && m.contains("CT Image Storage"),
        "{m}"
    );
}

#[test]
fn non_dicom_file() {
    let path = temp_file(
        "notes.dcm",
        "just some text, long enough to pass 132 bytes. "
            .repeat(5)
            .as_bytes(),
    );
    let e = read_rt_ion_plan(&path).expect_err("not DICOM");
    assert!(matches!(e, DicomImportError::NotDicom { .. }), "{e:?}");
    assert!(message(&e).contains("DICM"), "{e}");
    let e = read_rt_ion_plan_from_bytes(b"tiny").expect_err("not DICOM");
    assert!(matches!(e, DicomImportError::NotDicom { .. }), "{e:?}");
    let e = read_rt_ion_plan(temp_dir().join("absent.dcm")).expect_err("no file");
    assert!(matches!(e, DicomImportError::Io { .. }), "{e:?}");
}

#[test]
fn truncated_files_fail_without_panicking() {
    let bytes = dicom::two_arc_plan().to_bytes();
    let path = temp_file("truncated.dcm", &bytes[..bytes.len() / 2]);
    let e = read_rt_ion_plan(&path).expect_err("truncated");
    assert!(matches!(e, DicomImportError::Unreadable { .. }), "{e:?}");
    assert!(
        message(&e).starts_with("truncated or corrupt DICOM file"),
        "{e}"
    );
    // Every cut point fails, wherever it falls (preamble, meta group, inside a sequence...).
    for cut in (0..bytes.len())
        .step_by(7)
        .chain(bytes.len() - 8..bytes.len())
    {
        assert!(
            read_rt_ion_plan_from_bytes(&bytes[..cut]).is_err(),
            "cut at {cut} of {} was accepted",
            bytes.len()
        );
    }
}

#[test]
fn plan_without_ion_beams() {
    let e = import_err(&PlanSpec::ion("EMPTY", Vec::new()));
    assert!(matches!(e, DicomImportError::NoIonBeams { .. }), "{e:?}");

    let mut spec = dicom::static_arc_plan();
    for beam in &mut spec.beams {
        beam.delivery = "SETUP";
    }
    let e = import_err(&spec);
    assert!(matches!(e, DicomImportError::NoIonBeams { .. }), "{e:?}");
    assert!(message(&e).contains("setup beam"), "{e}");
}

#[test]
fn inconsistent_control_point_count() {
    let mut spec = dicom::static_arc_plan();
    spec.beams[2].number_of_control_points = Some(3);
    let m = message(&import_err(&spec));
    assert!(
        m.contains("NumberOfControlPoints (300A,0110)")
            && m.contains("IonBeamSequence[2] (BeamNumber 3)"),
        "{m}"
    );
    assert!(
        m.contains("says 3 but IonControlPointSequence (300A,03A8) has 2 items"),
        "{m}"
    );
}

// ---- hostile files: bounded resources, no silent guesses -----------------------------------------------

#[test]
fn deeply_nested_sequences_are_refused_before_parsing() {
    // dicom-object parses nested sequences recursively: 8,000 levels would overflow the stack and
    // abort the process. The nesting pre-scan is iterative, so this runs on a test thread's stack.
    for explicit_vr in [true, false] {
        let bytes = dicom::deeply_nested_file(8_000, explicit_vr);
        assert!(bytes.len() > 250_000, "{} bytes", bytes.len());
        let e = read_rt_ion_plan_from_bytes(&bytes).expect_err("nested 8,000 levels deep");
        assert!(
            matches!(
                e,
                DicomImportError::TooDeeplyNested {
                    limit: MAX_NESTING,
                    tag: tags::ION_BEAM_SEQUENCE,
                    ..
                }
            ),
            "explicit VR {explicit_vr}: {e:?}"
        );
        let m = message(&e);
        assert!(
            m.contains("nested deeper than 64 levels")
                && m.contains("level 65 is IonBeamSequence (300A,03A2)"),
            "{m}"
        );

        // Exactly MAX_NESTING levels pass the pre-scan; the parser reads the file and the reader
        // then finds the (empty) beams wanting.
        let e = read_rt_ion_plan_from_bytes(&dicom::deeply_nested_file(MAX_NESTING, explicit_vr))
            .expect_err("not a plan");
        assert!(
            matches!(
                e,
                DicomImportError::MissingTag {
                    keyword: "BeamNumber",
                    ..
                }
            ),
            "explicit VR {explicit_vr}: {e:?}"
        );
    }
}

#[test]
fn number_of_paintings_is_bounded() {
    let paint = |paintings: i64| {
        let layers = dicom::dynamic_arc_layers(0.0, 2.0, 2);
        let mut beam = BeamSpec::from_layers(1, "DYNAMIC", "CW", 80.0, &layers);
        beam.cps[2].paintings = Some(paintings);
        PlanSpec::ion("PAINT", vec![beam])
    };
    for paintings in [i64::from(MAX_PAINTINGS) + 1, 500_000_000, 0, -3] {
        let e = import_err(&paint(paintings));
        assert!(
            matches!(
                e,
                DicomImportError::InvalidValue {
                    keyword: "NumberOfPaintings",
                    ..
                }
            ),
            "{paintings}: {e:?}"
        );
        let m = message(&e);
        assert!(
            m.contains("NumberOfPaintings (300A,039A)")
                && m.contains("IonBeamSequence[0] (BeamNumber 1) > IonControlPointSequence[2]")
                && m.contains(&format!(
                    "{paintings}; expected a whole number from 1 to 1000"
                )),
            "{m}"
        );
    }
    let plan = read_rt_ion_plan_from_bytes(&paint(i64::from(MAX_PAINTINGS)).to_bytes())
        .expect("1000 paintings are accepted");
    // The spot list is not repeated per painting: the count stays the file's.
    let spots = spots_of(&plan, 0, 1, 0);
    assert_eq!(spots.count as usize, dicom::weights_of(1).len());
    assert_eq!(spots.paintings, Some(MAX_PAINTINGS));
}

#[test]
fn spots_after_repainting_are_bounded_plan_wide() {
    // Two beams of 3 layers of 900 spots painted 1,000 times: 5.4 million spots, though each count
    // is in range on its own (and each layer is below arcsim_plan::MAX_SPOTS_PER_LAYER).
    let beam = |number: i64| {
        let layers: Vec<Layer> = (0..3)
            .map(|i| Layer {
                angle: 10.0 * number as f64,
                energy: 100.0 + i as f64,
                weights: vec![1.0; 900],
            })
            .collect();
        let mut beam = BeamSpec::from_layers(number, "STATIC", "NONE", 50.0, &layers);
        beam.cps[0].paintings = Some(i64::from(MAX_PAINTINGS));
        beam
    };
    let e = import_err(&PlanSpec::ion("SPOTS", vec![beam(1), beam(2)]));
    assert!(
        matches!(
            e,
            DicomImportError::TooManySpots {
                spots: 5_400_000,
                limit: MAX_SPOTS
            }
        ),
        "{e:?}"
    );
    let m = message(&e);
    assert!(
        m.contains("5400000 spots after repainting") && m.contains("at most 5000000"),
        "{m}"
    );
    let plan = read_rt_ion_plan_from_bytes(&PlanSpec::ion("SPOTS", vec![beam(1)]).to_bytes())
        .expect("2.7 million spot deliveries are accepted");
    // 900 spots painted 1,000 times (inherited by the later layers): the paintings are a count,
    // not the list repeated into 900,000 spots.
    let spots = spots_of(&plan, 0, 0, 2);
    assert_eq!((spots.count, spots.paintings), (900, Some(MAX_PAINTINGS)));
    assert_eq!(layer_mu(&plan, 0, 0, 2).len(), 900);
}

#[test]
fn two_beams_with_one_beam_number_are_refused() {
    // Otherwise beam 2 would silently take beam 1's BeamMeterset.
    let mut spec = dicom::two_arc_plan();
    spec.beams[1].number = 1;
    let e = import_err(&spec);
    assert!(
        matches!(
            e,
            DicomImportError::DuplicateBeamNumber {
                number: 1,
                first: 0,
                second: 1
            }
        ),
        "{e:?}"
    );
    let m = message(&e);
    assert!(
        m.contains("BeamNumber (300A,00C0) 1")
            && m.contains("IonBeamSequence[0] and IonBeamSequence[1]")
            && m.contains("ReferencedBeamNumber (300C,0006)"),
        "{m}"
    );
}

#[test]
fn several_values_where_one_is_expected_are_refused() {
    let angle_at = "IonBeamSequence[0] (BeamNumber 1) > IonControlPointSequence[2]";
    let check = |e: DicomImportError, keyword: &str, tag: &str, values: &str, at: &str| {
        assert!(
            matches!(&e, DicomImportError::InvalidValue { keyword: k, .. } if *k == keyword),
            "{e:?}"
        );
        let m = message(&e);
        assert!(
            m.contains(&format!("{keyword} {tag}"))
                && m.contains(at)
                && m.contains(&format!("2 values ({values}); expected one")),
            "{m}"
        );
    };

    // A decimal string "10\20": read from a file as two strings, built in memory as one string.
    let mut spec = dicom::two_arc_plan();
    spec.beams[0].cps[2]
        .extra
        .push(DataElement::new(tags::GANTRY_ANGLE, VR::DS, "10\\20"));
    check(
        import_err(&spec),
        "GantryAngle",
        "(300A,011E)",
        "10\\20",
        angle_at,
    );
    let e = rt_ion_plan_from_dataset(&spec.dataset()).expect_err("two angles");
    check(e, "GantryAngle", "(300A,011E)", "10\\20", angle_at);

    // A binary value with two numbers.
    let mut spec = dicom::two_arc_plan();
    spec.beams[0].cps[2].extra.push(DataElement::new(
        tags::GANTRY_ANGLE,
        VR::FD,
        PrimitiveValue::from([10.0f64, 20.0]),
    ));
    check(
        import_err(&spec),
        "GantryAngle",
        "(300A,011E)",
        "10\\20",
        angle_at,
    );

    // An integer string (IS).
    let mut spec = dicom::two_arc_plan();
    spec.beams[1]
        .extra
        .push(DataElement::new(tags::BEAM_NUMBER, VR::IS, "2\\3"));
    check(
        import_err(&spec),
        "BeamNumber",
        "(300A,00C0)",
        "2\\3",
        "IonBeamSequence[1]",
    );
}

// ---- spot positions and paintings -----------------------------------------------------------------------

/// Every coordinate of `got` (imported, mm) is the file's single-precision value to the 1e-6 mm of
/// POSITION_RESOLUTION_MM, in the same order.
fn assert_positions(got: &[[f64; 2]], want: &[[f32; 2]], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: one position per spot");
    for (k, (g, w)) in got.iter().zip(want).enumerate() {
        for axis in 0..2 {
            assert!(
                (g[axis] - f64::from(w[axis])).abs() <= POSITION_RESOLUTION_MM,
                "{what}, spot {k}: {g:?} vs {w:?} in the file"
            );
        }
    }
}

/// The dynamic 180-layer arc with its own spot map on every layer and paintings 3 (layers 0-59,
/// inherited), 1 (60-119) and 7 (120-179).
fn dynamic_arc_with_maps() -> PlanSpec {
    let mut spec = dicom::dynamic_arc_plan();
    let positions: Vec<Vec<[f32; 2]>> = (0..180).map(dicom::positions_of).collect();
    let mut beam = spec.beams.remove(0).with_layer_positions(&positions);
    beam.cps[0].paintings = Some(3);
    beam.cps[120].paintings = Some(1);
    beam.cps[240].paintings = Some(7);
    spec.beams.push(beam);
    spec
}

fn expected_paintings(layer: usize) -> Option<u32> {
    match layer {
        0..60 => Some(3),
        60..120 => None,
        _ => Some(7),
    }
}

#[test]
fn dynamic_arc_with_spot_maps_has_positions_per_layer_in_file_order() {
    let spec = dynamic_arc_with_maps();
    let final_weight = spec.beams[0].final_weight();
    let plan = import(&spec, "arc-maps.dcm");
    assert_eq!(plan.arcs.len(), 1);
    assert_eq!(plan.arcs[0].control_points.len(), 180);
    for i in 0..180 {
        let spots = spots_of(&plan, 0, i, 0);
        let weights = dicom::weights_of(i);
        assert_eq!(spots.count as usize, weights.len(), "layer {i}: spot count");
        assert_eq!(
            spots.paintings,
            expected_paintings(i),
            "layer {i}: paintings"
        );
        let positions = spots.positions_mm.as_deref().expect("positions");
        // positions_of goes back and forth in x and moves 0.1 mm per layer: sorted, shared or
        // shifted positions would not match.
        assert_positions(positions, &dicom::positions_of(i), &format!("layer {i}"));
        let mu = spots.mu.as_deref().expect("mu");
        for (m, w) in mu.iter().zip(&weights) {
            assert!(
                close(*m, f64::from(*w) * 1234.5 / final_weight),
                "layer {i}: {m} is the spot's total MU over its paintings"
            );
        }
    }
    // Single-precision 12.3 (12.300000190734863) imports as 12.3: rounded to 1e-6 mm.
    assert_eq!(
        spots_of(&plan, 0, 0, 0).positions_mm.as_ref().unwrap()[0],
        [-30.0, 12.3]
    );
    assert!(close(total_mu(&plan), 1234.5), "{}", total_mu(&plan));

    // The JSON written from the plan reads back to the same positions and paintings.
    let back =
        arcsim_plan::parse_plan(&arcsim_plan::to_json(&plan), "arc-maps.json").expect("valid plan");
    assert_eq!(back, plan);
}

#[test]
fn static_beams_with_spot_maps_have_positions_per_layer() {
    let mut spec = dicom::static_arc_plan();
    // The file lists beams 5, 4, ..., 1; the arc follows BeamNumber, and so must the positions.
    for beam in &mut spec.beams {
        let i = (beam.number - 1) as usize;
        beam.set_layer_map(0, SpotMap::of(&dicom::positions_of(i)));
        if beam.number == 3 {
            beam.cps[0].paintings = Some(2);
        }
    }
    let plan = import(&spec, "static-maps.dcm");
    assert_eq!(plan.arcs.len(), 1);
    assert_eq!(plan.arcs[0].control_points.len(), 5);
    for i in 0..5 {
        let spots = spots_of(&plan, 0, i, 0);
        assert_eq!(spots.count as usize, dicom::weights_of(i).len());
        assert_eq!(
            spots.paintings,
            (i == 2).then_some(2),
            "beam {}: paintings",
            i + 1
        );
        assert_positions(
            spots.positions_mm.as_deref().expect("positions"),
            &dicom::positions_of(i),
            &format!("beam {}", i + 1),
        );
        // Each beam's MU add up to its own BeamMeterset, paintings or not.
        let sum: f64 = spots.mu.as_ref().unwrap().iter().sum();
        assert!(close(sum, 100.0 + 10.0 * i as f64), "beam {}: {sum}", i + 1);
    }
}

#[test]
fn a_position_map_of_the_wrong_length_is_located() {
    // Beam 2 of the two-arc plan, layer 2 (control point 4) has 5 spots: 10 values expected.
    for len in [9, 12, 2] {
        let mut spec = dicom::two_arc_plan();
        let mut values: Vec<f32> = dicom::positions_of(2).concat();
        values.resize(len, 1.5);
        spec.beams[1].set_layer_map(2, SpotMap::Values(values));
        let e = import_err(&spec);
        assert!(
            matches!(
                e,
                DicomImportError::Inconsistent {
                    keyword: "ScanSpotPositionMap",
                    tag: tags::SCAN_SPOT_POSITION_MAP,
                    at: Location::ControlPoint {
                        beam: 1,
                        number: Some(2),
                        control_point: 4
                    },
                    ..
                }
            ),
            "{len} values: {e:?}"
        );
        let m = message(&e);
        assert!(
            m.contains("ScanSpotPositionMap (300A,0394)")
                && m.contains("IonBeamSequence[1] (BeamNumber 2) > IonControlPointSequence[4]")
                && m.contains(&format!(
                    "{len} values for 5 spots; expected 2 per spot (x, y)"
                )),
            "{m}"
        );
    }
    // The zero-weight control point that closes a layer is checked too.
    let mut spec = dicom::two_arc_plan();
    spec.beams[0].cps[7].spot_map = SpotMap::Values(vec![0.0; 3]);
    let e = import_err(&spec);
    assert!(
        matches!(
            e,
            DicomImportError::Inconsistent {
                at: Location::ControlPoint {
                    beam: 0,
                    number: Some(1),
                    control_point: 7
                },
                ..
            }
        ),
        "{e:?}"
    );
}

#[test]
fn a_non_finite_or_far_position_is_located() {
    // Layer 3 (control points 6 and 7) has 6 spots; spot 4 gets the bad coordinate.
    for (x, y, shown) in [
        (-19.5, f32::NAN, "spot 4 is at (-19.5, NaN) mm"),
        (f32::INFINITY, 2.0, "spot 4 is at (inf, 2) mm"),
        (1.0, -2.0e4, "spot 4 is at (1, -20000) mm"),
    ] {
        let mut spec = dicom::dynamic_arc_plan();
        let mut positions = dicom::positions_of(3);
        positions[4] = [x, y];
        spec.beams[0].set_layer_map(3, SpotMap::of(&positions));
        let e = import_err(&spec);
        assert!(
            matches!(
                e,
                DicomImportError::InvalidValue {
                    keyword: "ScanSpotPositionMap",
                    tag: tags::SCAN_SPOT_POSITION_MAP,
                    at: Location::ControlPoint {
                        beam: 0,
                        number: Some(1),
                        control_point: 6
                    },
                    ..
                }
            ),
            "{shown}: {e:?}"
        );
        let m = message(&e);
        assert!(
            m.contains("invalid ScanSpotPositionMap (300A,0394)")
                && m.contains("IonBeamSequence[0] (BeamNumber 1) > IonControlPointSequence[6]")
                && m.contains(shown)
                && m.contains("expected finite coordinates between -10000 and 10000 mm"),
            "{m}"
        );
    }
}

#[test]
fn a_plan_without_position_maps_imports_without_positions() {
    let old_style = import(
        &dicom::dynamic_arc_plan().without_spot_maps(),
        "no-maps.dcm",
    );
    let mut with_maps = import(&dicom::dynamic_arc_plan(), "raster-maps.dcm");
    for cp in &mut with_maps.arcs[0].control_points {
        let spots = cp.layers[0].spots.as_mut().unwrap();
        // The builder's default map: spot j at (5 j, -2.5 j) mm.
        let raster: Vec<[f64; 2]> = (0..spots.count)
            .map(|j| [5.0 * f64::from(j), -2.5 * f64::from(j)])
            .collect();
        assert_eq!(spots.positions_mm.take(), Some(raster));
    }
    // Without maps: no positions, and nothing else differs.
    assert_eq!(old_style, with_maps);

    // Maps on the even layers only: positions on those, none on the others.
    let mut spec = dicom::dynamic_arc_plan();
    for layer in 0..180 {
        let map = if layer % 2 == 0 {
            SpotMap::of(&dicom::positions_of(layer))
        } else {
            SpotMap::Absent
        };
        spec.beams[0].set_layer_map(layer, map);
    }
    let plan = import(&spec, "some-maps.dcm");
    for layer in 0..180 {
        let positions = spots_of(&plan, 0, layer, 0).positions_mm.as_deref();
        match positions {
            Some(p) if layer % 2 == 0 => {
                assert_positions(p, &dicom::positions_of(layer), &format!("layer {layer}"))
            }
            None if layer % 2 == 1 => {}
            other => panic!("layer {layer}: {other:?}"),
        }
    }
}

#[test]
fn paintings_time_as_the_repeated_spot_list_did_under_per_mu() {
    // A paintings count must time under per_mu as the spot list repeated once per painting, each
    // spot with MU / paintings (rounded to 1e-9 MU), does.
    let machine = arcsim_plan::parse_machine(
        r#"{
            "format": "arcsim-machine/1",
            "name": "per-mu",
            "gantry": {"max_speed_deg_per_s": 5.0, "max_accel_deg_per_s2": 0.5, "max_jerk_deg_per_s3": 0.5},
            "beam": {"s_per_mu": 0.005, "spot_switch_time_s": 0.002, "min_spot_time_s": 0.001},
            "elst": {"kind": "constant", "up_s": 5.0, "down_s": 0.5, "same_s": 0.0},
            "default_window_deg": 1.0
        }"#,
        "per-mu.json",
    )
    .expect("machine");
    let plan = import(&dynamic_arc_with_maps(), "arc-maps-timing.dcm");
    let mut expanded = plan.clone();
    for cp in &mut expanded.arcs[0].control_points {
        let spots = cp.layers[0].spots.as_mut().unwrap();
        let n = spots.paintings.take().unwrap_or(1) as usize;
        let once: Vec<f64> = spots
            .mu
            .as_ref()
            .unwrap()
            .iter()
            .map(|m| (m / n as f64 * 1e9).round() / 1e9)
            .collect();
        spots.mu = Some(once.repeat(n));
        spots.count = (once.len() * n) as u32;
        spots.positions_mm = None;
    }
    let new = arcsim_plan::resolve(&plan, &machine).expect("resolves");
    let old = arcsim_plan::resolve(&expanded, &machine).expect("resolves");
    let beam_on = |arcs: &[arcsim_plan::ResolvedArc]| -> Vec<f64> {
        arcs.iter()
            .flat_map(|a| &a.layers)
            .map(|l| l.irradiation_s)
            .collect()
    };
    let (new, old) = (beam_on(&new), beam_on(&old));
    assert_eq!(new.len(), 180);
    for (i, (a, b)) in new.iter().zip(&old).enumerate() {
        assert!((a - b).abs() <= 1e-9 * b, "layer {i}: {a} s vs {b} s");
    }
    // Layer 150 is painted 7 times: 7 x its spots, each MU / 7 (at least 1 ms), 2 ms apart.
    let mu = layer_mu(&plan, 0, 150, 0);
    let seven_passes = 7.0 * mu.iter().map(|m| (m / 7.0 * 0.005).max(0.001)).sum::<f64>()
        + (7 * mu.len() - 1) as f64 * 0.002;
    assert!(
        (new[150] - seven_passes).abs() <= 1e-9 * seven_passes,
        "{} s vs {seven_passes} s",
        new[150]
    );
}

#[test]
fn spots_per_layer_are_bounded_not_spots_times_paintings() {
    let layer = |n: usize| {
        let layers = [Layer {
            angle: 0.0,
            energy: 100.0,
            weights: vec![1.0; n],
        }];
        let mut beam = BeamSpec::from_layers(1, "STATIC", "NONE", 50.0, &layers);
        beam.cps[0].paintings = Some(5);
        PlanSpec::ion("BIG", vec![beam]).without_spot_maps()
    };
    // Built as a data set: explicit VR files cannot hold more than 16,383 FL values in one element.
    let e = rt_ion_plan_from_dataset(&layer(MAX_SPOTS_PER_LAYER as usize + 1).dataset())
        .expect_err("a layer of 1,000,001 spots");
    assert!(
        matches!(
            e,
            DicomImportError::InvalidValue {
                keyword: "NumberOfScanSpotPositions",
                at: Location::ControlPoint {
                    control_point: 0,
                    ..
                },
                ..
            }
        ),
        "{e:?}"
    );
    assert!(
        message(&e).contains("1000001; expected at most 1000000 spots in one energy layer"),
        "{e}"
    );
    // 1,000,000 spots painted 5 times: 5,000,000 deliveries, exactly MAX_SPOTS. Repeated into one
    // list they would be 5 times the spots one layer may hold.
    let plan = rt_ion_plan_from_dataset(&layer(MAX_SPOTS_PER_LAYER as usize).dataset())
        .expect("a million spots painted 5 times");
    let spots = spots_of(&plan, 0, 0, 0);
    assert_eq!((spots.count, spots.paintings), (1_000_000, Some(5)));
    assert_eq!(MAX_SPOTS, 5 * u64::from(spots.count));
}

// ---- consistency of the file: meterset weights, fraction groups, angles, position maps -----------

/// The import of `bytes` with its warnings.
fn import_warned(bytes: &[u8]) -> arcsim_dicom::Imported {
    match arcsim_dicom::import_rt_ion_plan_from_bytes(bytes, "fallback") {
        Ok(imported) => imported,
        Err(e) => panic!("import failed: {e}"),
    }
}

#[test]
fn a_final_cumulative_weight_that_is_not_the_sum_of_the_weights_is_an_error() {
    let mut spec = static_beams(&[10.0, 20.0]);
    let sum = spec.beams[1].final_weight();
    // Twice the weights: the MU would silently be halved (50 instead of the BeamMeterset's 100).
    spec.beams[1].final_weight = Some(2.0 * sum);
    let e = import_err(&spec).to_string();
    for part in [
        "FinalCumulativeMetersetWeight (300A,010E)",
        "IonBeamSequence[1] (BeamNumber 2)",
        &dicom::ds(2.0 * sum),
        &format!("sum to {sum}"),
    ] {
        assert!(e.contains(part), "missing {part:?} in: {e}");
    }
    // Within the tolerance (single-precision weights, a decimal-string total) it imports.
    spec.beams[1].final_weight =
        Some(sum * (1.0 + 0.1 * arcsim_dicom::CUMULATIVE_WEIGHT_TOLERANCE));
    let plan = read_rt_ion_plan_from_bytes(&spec.to_bytes()).expect("within tolerance");
    let mu: f64 = spots_of(&plan, 0, 1, 0).mu.iter().flatten().sum();
    assert!(
        (mu - 50.0).abs() < 50.0 * 1e-4,
        "beam 2 delivers its 50 MU: {mu}"
    );
}

/// `spec`'s data set with FractionGroupSequence replaced by `groups`: (FractionGroupNumber, the
/// BeamNumbers it references, each with BeamMeterset 100).
fn with_fraction_groups(spec: &PlanSpec, groups: &[(i64, &[i64])]) -> Vec<u8> {
    use dicom_core::value::DataSetSequence;
    use dicom_object::InMemDicomObject;
    let items: Vec<InMemDicomObject> = groups
        .iter()
        .map(|(number, beams)| {
            let refs: Vec<InMemDicomObject> = beams
                .iter()
                .map(|b| {
                    let mut item = InMemDicomObject::new_empty();
                    item.put(DataElement::new(
                        tags::REFERENCED_BEAM_NUMBER,
                        VR::IS,
                        b.to_string(),
                    ));
                    item.put(DataElement::new(tags::BEAM_METERSET, VR::DS, "100"));
                    item
                })
                .collect();
            let mut group = InMemDicomObject::new_empty();
            group.put(DataElement::new(
                tags::FRACTION_GROUP_NUMBER,
                VR::IS,
                number.to_string(),
            ));
            group.put(DataElement::new(
                tags::REFERENCED_BEAM_SEQUENCE,
                VR::SQ,
                DataSetSequence::from(refs),
            ));
            group
        })
        .collect();
    let mut ds = spec.dataset();
    ds.put(DataElement::new(
        tags::FRACTION_GROUP_SEQUENCE,
        VR::SQ,
        DataSetSequence::from(items),
    ));
    dicom::file_bytes(ds)
}

#[test]
fn only_the_first_fraction_group_is_imported_with_a_warning_naming_the_others() {
    let spec = static_beams(&[10.0, 20.0, 30.0]);
    let bytes = with_fraction_groups(&spec, &[(1, &[1, 2]), (2, &[3])]);
    let imported = import_warned(&bytes);
    let plan = &imported.plan;
    assert_eq!(angles(plan, 0), vec![10.0, 20.0], "beams 1 and 2 only");
    assert_eq!(plan.arcs.len(), 1);
    let description = plan.description.as_deref().unwrap_or_default();
    assert!(
        description.contains("left out beam 3 (fraction group 2)"),
        "{description}"
    );
    assert_eq!(imported.warnings.len(), 1, "{:?}", imported.warnings);
    let w = imported.warnings[0].to_string();
    assert!(
        w.contains("FractionGroupSequence (300A,0070) has 2 fraction groups")
            && w.contains("fraction group 1")
            && w.contains("fraction group 2 (beams 3)"),
        "{w}"
    );
    // One fraction group: no warning.
    let one = import_warned(&with_fraction_groups(&spec, &[(1, &[1, 2, 3])]));
    assert!(one.warnings.is_empty(), "{:?}", one.warnings);
    assert_eq!(angles(&one.plan, 0), vec![10.0, 20.0, 30.0]);
}

#[test]
fn a_fraction_group_reference_to_a_missing_beam_is_an_error() {
    let spec = static_beams(&[10.0, 20.0]);
    let bytes = with_fraction_groups(&spec, &[(1, &[1, 2, 7])]);
    let e = read_rt_ion_plan_from_bytes(&bytes)
        .expect_err("beam 7 does not exist")
        .to_string();
    assert!(
        e.starts_with(
            "ReferencedBeamNumber (300C,0006) in FractionGroupSequence[0] > \
             ReferencedBeamSequence[2] is 7, but no item of IonBeamSequence (300A,03A2) has \
             BeamNumber 7 (the beams are 1, 2)"
        ),
        "{e}"
    );
    // Also in a group that is not imported.
    let bytes = with_fraction_groups(&spec, &[(1, &[1, 2]), (2, &[9])]);
    let e = read_rt_ion_plan_from_bytes(&bytes)
        .expect_err("beam 9 does not exist")
        .to_string();
    assert!(
        e.contains("FractionGroupSequence[1] > ReferencedBeamSequence[0] is 9"),
        "{e}"
    );
}

#[test]
fn a_step_against_the_declared_rotation_is_an_error() {
    let layers = |angles: &[f64]| -> Vec<Layer> {
        angles
            .iter()
            .enumerate()
            .map(|(i, &angle)| Layer {
                angle,
                energy: dicom::energy_of(i),
                weights: dicom::weights_of(i),
            })
            .collect()
    };
    // CW with decreasing angles would otherwise be a 716-degree arc.
    let cw = BeamSpec::from_layers(1, "DYNAMIC", "CW", 100.0, &layers(&[10.0, 8.0, 6.0]));
    let e = import_err(&PlanSpec::ion("BACK", vec![cw])).to_string();
    assert!(
        e.starts_with(
            "inconsistent GantryAngle (300A,011E) in IonBeamSequence[0] (BeamNumber 1) > \
             IonControlPointSequence[2]: goes from 10 (IonControlPointSequence[1]) to 8, against \
             the GantryRotationDirection (300A,011F) CW (increasing angle)"
        ),
        "{e}"
    );
    let cc = BeamSpec::from_layers(1, "DYNAMIC", "CC", 100.0, &layers(&[6.0, 8.0]));
    let e = import_err(&PlanSpec::ion("BACK", vec![cc])).to_string();
    assert!(
        e.contains("IonControlPointSequence[2]: goes from 6") && e.contains("CC (decreasing"),
        "{e}"
    );
    // Across 0 each way is a short step the declared way.
    let cw = BeamSpec::from_layers(1, "DYNAMIC", "CW", 100.0, &layers(&[358.0, 0.0, 2.0]));
    let plan = read_rt_ion_plan_from_bytes(&PlanSpec::ion("OK", vec![cw]).to_bytes())
        .expect("CW across 0");
    assert_eq!(angles(&plan, 0), vec![358.0, 360.0, 362.0]);
    let cc = BeamSpec::from_layers(1, "DYNAMIC", "CC", 100.0, &layers(&[2.0, 0.0, 358.0]));
    let plan = read_rt_ion_plan_from_bytes(&PlanSpec::ion("OK", vec![cc]).to_bytes())
        .expect("CC across 0");
    assert_eq!(angles(&plan, 0), vec![362.0, 360.0, 358.0]);
}

#[test]
fn gantry_angles_outside_0_to_360_are_errors_and_360_is_0_with_a_warning() {
    for bad in [362.0, -2.0, 720.0] {
        let e = import_err(&static_beams(&[10.0, bad])).to_string();
        assert!(
            e.starts_with(&format!(
                "invalid GantryAngle (300A,011E) in IonBeamSequence[1] (BeamNumber 2) > \
                 IonControlPointSequence[0]: {bad}; expected an angle from 0 up to (not \
                 including) 360 degrees"
            )),
            "{bad}: {e}"
        );
    }
    let imported = import_warned(&static_beams(&[350.0, 360.0, 10.0]).to_bytes());
    assert_eq!(angles(&imported.plan, 0), vec![350.0, 360.0, 370.0]);
    let warnings: Vec<String> = imported.warnings.iter().map(ToString::to_string).collect();
    assert_eq!(
        warnings,
        vec![
            "GantryAngle (300A,011E) 360 in IonBeamSequence[1] (BeamNumber 2) > \
             IonControlPointSequence[0] read as 0 (DICOM angles are in [0, 360))"
        ]
    );
}

#[test]
fn a_negative_zero_gantry_angle_is_imported_as_0() {
    let plan = import(&static_beams(&[-0.0, 10.0]), "negzero.dcm");
    assert_eq!(angles(&plan, 0), vec![0.0, 10.0]);
    assert!(plan.arcs[0].control_points[0].angle_deg.is_sign_positive());
    let json = arcsim_plan::to_json(&plan);
    assert!(!json.contains("-0.0"), "{json}");
}

#[test]
fn an_empty_scan_spot_position_map_is_an_error() {
    let mut spec = static_beams(&[10.0, 20.0]);
    spec.beams[1].set_layer_map(0, SpotMap::Values(Vec::new()));
    let e = import_err(&spec).to_string();
    let spots = dicom::weights_of(1).len();
    assert!(
        e.starts_with(&format!(
            "inconsistent ScanSpotPositionMap (300A,0394) in IonBeamSequence[1] (BeamNumber 2) > \
             IonControlPointSequence[0]: 0 values for {spots} spots; expected 2 per spot (x, y)"
        )),
        "{e}"
    );
}

#[test]
fn a_deflated_file_is_read() {
    let spec = dicom::two_arc_plan();
    let deflated = dicom::file_bytes_ts(
        spec.dataset(),
        dicom_dictionary_std::uids::DEFLATED_EXPLICIT_VR_LITTLE_ENDIAN,
    );
    assert!(
        deflated.len() < spec.to_bytes().len(),
        "the fixture is compressed"
    );
    let plan = read_rt_ion_plan_from_bytes(&deflated).expect("deflated file");
    let plain = read_rt_ion_plan_from_bytes(&spec.to_bytes()).expect("plain file");
    assert_eq!(plan, plain);
}

#[test]
fn plan_rule_violations_are_located_in_the_imported_plan_without_the_plan_name() {
    let layers = [Layer {
        angle: 10.0,
        energy: 9999.0,
        weights: dicom::weights_of(0),
    }];
    let beam = BeamSpec::from_layers(1, "STATIC", "NONE", 50.0, &layers);
    let e = import_err(&PlanSpec::ion("HOT", vec![beam])).to_string();
    assert!(
        e.starts_with(
            "the imported plan breaks the arcsim plan rules (arcs, control points and layers \
             counted as imported, from 0): arc 0, control point 0, layer 0, field `energy_mev`: \
             expected an energy in"
        ),
        "{e}"
    );
    assert!(!e.contains("HOT"), "{e}");
}

#[test]
fn an_unknown_transfer_syntax_is_named_as_unsupported() {
    let bytes = dicom::two_arc_plan().to_bytes();
    let (plain, unknown) = (b"1.2.840.10008.1.2.1\0", b"1.2.840.99999.1.2.1\0");
    let at = bytes
        .windows(plain.len())
        .position(|w| w == plain)
        .expect("the meta group names Explicit VR Little Endian");
    let mut patched = bytes.clone();
    patched[at..at + unknown.len()].copy_from_slice(unknown);
    let e = read_rt_ion_plan_from_bytes(&patched)
        .expect_err("unknown transfer syntax")
        .to_string();
    assert!(
        e.starts_with(
            "unsupported transfer syntax 1.2.840.99999.1.2.1 (not a known transfer syntax): \
             arcsim reads DICOM data sets that are uncompressed"
        ),
        "{e}"
    );
    assert!(!e.contains("feature"), "{e}");
}
