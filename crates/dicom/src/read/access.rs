//! Reading one attribute of a data set. Absent and empty attributes both read as None; a value that
//! cannot be read is an error naming the attribute and its [`Location`] in the file.

use dicom_core::value::{PrimitiveValue, Value};
use dicom_object::InMemDicomObject;

use super::attr::Attr;
use super::Result;
use crate::error::{DicomImportError, Location};

/// The error for a required attribute that is absent (or empty) at `at`.
pub(crate) fn missing(attr: Attr, at: Location, note: Option<&'static str>) -> DicomImportError {
    DicomImportError::MissingTag {
        keyword: attr.keyword,
        tag: attr.tag,
        at,
        note,
    }
}

/// The error for an attribute whose value is not what the import accepts.
pub(crate) fn invalid(attr: Attr, at: Location, problem: String) -> DicomImportError {
    DicomImportError::InvalidValue {
        keyword: attr.keyword,
        tag: attr.tag,
        at,
        problem,
    }
}

/// `value`, or the [`missing`] error when it is None.
pub(crate) fn required<T>(value: Option<T>, attr: Attr, at: Location) -> Result<T> {
    value.ok_or_else(|| missing(attr, at, None))
}

/// The items of a sequence attribute; None when absent or empty.
pub(crate) fn items(obj: &InMemDicomObject, attr: Attr) -> Option<&[InMemDicomObject]> {
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
pub(crate) fn text(obj: &InMemDicomObject, attr: Attr) -> Option<String> {
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

/// A single-valued number.
pub(crate) fn float_at(obj: &InMemDicomObject, attr: Attr, at: Location) -> Result<Option<f64>> {
    single(obj, attr, at)?
        .map(|p| {
            p.to_float64()
                .map_err(|e| invalid(attr, at, format!("not a number: {e}")))
        })
        .transpose()
}

/// A list of numbers (any count).
pub(crate) fn floats_at(
    obj: &InMemDicomObject,
    attr: Attr,
    at: Location,
) -> Result<Option<Vec<f64>>> {
    primitive(obj, attr)
        .map(|p| {
            p.to_multi_float64()
                .map_err(|e| invalid(attr, at, format!("not a list of numbers: {e}")))
        })
        .transpose()
}

/// A single-valued whole number.
pub(crate) fn int_at(obj: &InMemDicomObject, attr: Attr, at: Location) -> Result<Option<i64>> {
    single(obj, attr, at)?
        .map(|p| {
            p.to_int::<i64>()
                .map_err(|e| invalid(attr, at, format!("not a whole number: {e}")))
        })
        .transpose()
}
