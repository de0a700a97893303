//! One beam's IonControlPointSequence with its energy layers in a new order.
//!
//! A layer is a *block* of control points: the one that carries its spot weights and the ones after
//! it up to the next layer (usually one, with zero weights). Control points before the first layer
//! stay first. Blocks move whole; then, so that every control point means what it meant before:
//! - an attribute a control point inherited (absent, so the previous control point's value holds)
//!   is written into it wherever its new predecessor would pass on another value;
//! - ControlPointIndex counts the new order;
//! - CumulativeMetersetWeight and each ReferencedDoseReferenceSequence item's
//!   CumulativeDoseReferenceCoefficient are rebased: a block keeps its increments and starts where
//!   the blocks now before it end (the last control point keeps the beam's total).

use std::collections::BTreeMap;

use dicom_core::header::Header;
use dicom_core::value::DataSetSequence;
use dicom_core::{DataElement, Tag, VR};
use dicom_dictionary_std::tags;
use dicom_object::mem::InMemElement;
use dicom_object::InMemDicomObject;

use super::WriteError;
use crate::read::access::float_at;
use crate::Location;

/// Attributes that belong to one control point alone: never inherited, never copied forward.
const OWN: [Tag; 6] = [
    tags::CONTROL_POINT_INDEX,
    tags::CUMULATIVE_METERSET_WEIGHT,
    tags::SCAN_SPOT_METERSET_WEIGHTS,
    tags::SCAN_SPOT_POSITION_MAP,
    tags::NUMBER_OF_SCAN_SPOT_POSITIONS,
    tags::REFERENCED_DOSE_REFERENCE_SEQUENCE,
];

/// The control points of one beam (`cps`), its layers (control-point indices, ascending) delivered
/// in `order` (the same indices, permuted). `beam` locates errors.
pub(super) fn reorder(
    cps: &[InMemDicomObject],
    layers: &[usize],
    order: &[usize],
    beam: (usize, i64),
) -> Result<Vec<InMemDicomObject>, WriteError> {
    let Some(&first) = layers.first() else {
        return Ok(cps.to_vec());
    };
    let block = |start: usize| {
        let next = layers.iter().find(|&&l| l > start).copied();
        start..next.unwrap_or(cps.len())
    };
    let sequence: Vec<usize> = (0..first)
        .chain(order.iter().flat_map(|&l| block(l)))
        .collect();
    let states = inherited_states(cps);
    let at = |c: usize| Location::ControlPoint {
        beam: beam.0,
        number: Some(beam.1),
        control_point: c,
    };
    let cumulative = rebased(cps, layers, order, &at, &|cp, c| {
        float_at(cp, crate::read::attr::CUMULATIVE_METERSET_WEIGHT, at(c))
            .map_err(WriteError::Import)
    })?;
    let doses = dose_coefficients(cps, layers, order, &at)?;

    let mut out = Vec::with_capacity(sequence.len());
    for (position, &c) in sequence.iter().enumerate() {
        let mut item = cps[c].clone();
        // What the control point now before this one passes on (nothing for the first).
        let before = position.checked_sub(1).map(|p| &states[sequence[p]]);
        for (tag, element) in &states[c] {
            if item.get(*tag).is_none() && before.and_then(|b| b.get(tag)) != Some(element) {
                item.put(element.clone());
            }
        }
        let cleared = before.and_then(|b| b.keys().find(|t| !states[c].contains_key(t)));
        if let Some(tag) = cleared {
            return Err(WriteError::Unorderable {
                at: at(c),
                problem: format!(
                    "it has no {tag} while the control point now before it (IonControlPointSequence[{}]) gives one, and DICOM cannot clear an inherited value",
                    sequence[position - 1]
                ),
            });
        }
        item.put(DataElement::new(
            tags::CONTROL_POINT_INDEX,
            VR::IS,
            position.to_string(),
        ));
        if let Some(values) = &cumulative {
            item.put(DataElement::new(
                tags::CUMULATIVE_METERSET_WEIGHT,
                VR::DS,
                decimal_string(values[c]),
            ));
        }
        for (number, values) in &doses {
            set_dose_coefficient(&mut item, *number, values[c]);
        }
        out.push(item);
    }
    Ok(out)
}

/// Per control point, every inheritable attribute in force there (its own or an earlier one's).
fn inherited_states(cps: &[InMemDicomObject]) -> Vec<BTreeMap<Tag, InMemElement>> {
    let mut state: BTreeMap<Tag, InMemElement> = BTreeMap::new();
    cps.iter()
        .map(|cp| {
            for element in cp.iter() {
                if !OWN.contains(&element.tag()) {
                    state.insert(element.tag(), element.clone());
                }
            }
            state.clone()
        })
        .collect()
}

/// Reads a control point's cumulative value (None when absent); the index locates errors.
type ReadValue<'a> = dyn Fn(&InMemDicomObject, usize) -> Result<Option<f64>, WriteError> + 'a;

/// A cumulative value (read by `value`) rebased for the new order, indexed by original control
/// point; None when no control point gives it. Every control point must give it when one does.
fn rebased(
    cps: &[InMemDicomObject],
    layers: &[usize],
    order: &[usize],
    at: &dyn Fn(usize) -> Location,
    value: &ReadValue<'_>,
) -> Result<Option<Vec<f64>>, WriteError> {
    let given: Vec<Option<f64>> = cps
        .iter()
        .enumerate()
        .map(|(c, cp)| value(cp, c))
        .collect::<Result<_, _>>()?;
    if given.iter().all(Option::is_none) {
        return Ok(None);
    }
    let Some(values) = given.iter().copied().collect::<Option<Vec<f64>>>() else {
        let c = given.iter().position(Option::is_none).unwrap_or(0);
        return Err(WriteError::Unorderable {
            at: at(c),
            problem: "a cumulative value (CumulativeMetersetWeight or CumulativeDoseReferenceCoefficient) is absent here while other control points of the beam give it; expected it in every control point, to recompute it in the new order".into(),
        });
    };
    let last = values.len() - 1;
    let mut out = values.clone();
    let mut running = values[layers[0]];
    for &start in order {
        let end = layers.iter().find(|&&l| l > start).copied();
        let range = start..end.unwrap_or(cps.len());
        let total = end.map_or(values[last], |e| values[e]) - values[start];
        for c in range {
            out[c] = running + (values[c] - values[start]);
        }
        running += total;
    }
    // Control points before the first layer keep their values.
    Ok(Some(out))
}

/// CumulativeDoseReferenceCoefficient of each ReferencedDoseReferenceNumber, rebased.
fn dose_coefficients(
    cps: &[InMemDicomObject],
    layers: &[usize],
    order: &[usize],
    at: &dyn Fn(usize) -> Location,
) -> Result<Vec<(i64, Vec<f64>)>, WriteError> {
    let mut numbers: Vec<i64> = cps
        .iter()
        .flat_map(|cp| dose_items(cp).iter().filter_map(dose_number))
        .collect();
    numbers.sort_unstable();
    numbers.dedup();
    let mut out = Vec::new();
    for number in numbers {
        let value = |cp: &InMemDicomObject, c: usize| -> Result<Option<f64>, WriteError> {
            match dose_items(cp)
                .iter()
                .find(|i| dose_number(i) == Some(number))
            {
                Some(item) => float_at(
                    item,
                    crate::read::attr::CUMULATIVE_DOSE_REFERENCE_COEFFICIENT,
                    at(c),
                )
                .map_err(WriteError::Import),
                None => Ok(None),
            }
        };
        if let Some(values) = rebased(cps, layers, order, at, &value)? {
            out.push((number, values));
        }
    }
    Ok(out)
}

fn dose_items(cp: &InMemDicomObject) -> &[InMemDicomObject] {
    cp.get(tags::REFERENCED_DOSE_REFERENCE_SEQUENCE)
        .and_then(|e| e.items())
        .unwrap_or_default()
}

fn dose_number(item: &InMemDicomObject) -> Option<i64> {
    item.get(tags::REFERENCED_DOSE_REFERENCE_NUMBER)
        .and_then(|e| e.to_int::<i64>().ok())
}

fn set_dose_coefficient(cp: &mut InMemDicomObject, number: i64, value: f64) {
    let mut items = dose_items(cp).to_vec();
    for item in items.iter_mut().filter(|i| dose_number(i) == Some(number)) {
        item.put(DataElement::new(
            tags::CUMULATIVE_DOSE_REFERENCE_COEFFICIENT,
            VR::DS,
            decimal_string(value),
        ));
    }
    cp.put(DataElement::new(
        tags::REFERENCED_DOSE_REFERENCE_SEQUENCE,
        VR::SQ,
        DataSetSequence::from(items),
    ));
}

/// `x` as a DICOM decimal string: at most 16 characters, as many significant digits as fit,
/// trailing zeros dropped.
fn decimal_string(x: f64) -> String {
    let x = if x.abs() < 1e-12 { 0.0 } else { x };
    let plain = format!("{x}");
    if plain.len() <= 16 {
        return plain;
    }
    for decimals in (0..=15).rev() {
        let s = format!("{x:.decimals$}");
        let s = if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        };
        if s.len() <= 16 {
            return s;
        }
    }
    format!("{x:.9e}")
}
