//! Conversions: JSON values (how the library crates serialise their results) to Python objects,
//! and lists of records to columns (numpy arrays where the values are numbers or booleans).

use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use serde_json::Value;

/// A JSON value as a Python object (null → None, objects → dict, arrays → list).
pub fn to_py<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => b.into_pyobject(py)?.to_owned().into_any(),
        Value::Number(n) => match (n.as_i64(), n.as_f64()) {
            (Some(i), _) => i.into_pyobject(py)?.into_any(),
            (None, Some(f)) => f.into_pyobject(py)?.into_any(),
            _ => py.None().into_bound(py),
        },
        Value::String(s) => s.into_pyobject(py)?.into_any(),
        Value::Array(a) => {
            let list = PyList::empty(py);
            for x in a {
                list.append(to_py(py, x)?)?;
            }
            list.into_any()
        }
        Value::Object(o) => {
            let d = PyDict::new(py);
            for (k, x) in o {
                d.set_item(k, to_py(py, x)?)?;
            }
            d.into_any()
        }
    })
}

/// Any serialisable value as a Python object.
pub fn serde_to_py<'py>(py: Python<'py>, x: &impl serde::Serialize) -> PyResult<Bound<'py, PyAny>> {
    let v = serde_json::to_value(x)
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
    to_py(py, &v)
}

/// Flattens a JSON object into (dotted key, scalar) pairs (`{"a": {"b": 1}}` → `a.b`), dropping
/// the prefixes in `strip` (e.g. `outcome.`).
fn flatten(prefix: &str, v: &Value, strip: &[&str], out: &mut Vec<(String, Value)>) {
    match v {
        Value::Object(o) => {
            for (k, x) in o {
                let key = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(&key, x, strip, out);
            }
        }
        _ => {
            let mut key = prefix.to_string();
            for s in strip {
                if let Some(rest) = key.strip_prefix(s) {
                    key = rest.to_string();
                }
            }
            out.push((key, v.clone()));
        }
    }
}

/// Records (JSON objects, nested ones flattened to dotted keys) as columns in a dict: a column
/// of numbers is a float64 array (NaN where a record has null), of integers an int64 array when
/// none is missing, of booleans a bool array; anything else a list.
/// Columns named in `first` come first, in that order; the others follow in key order.
pub fn columns<'py>(
    py: Python<'py>,
    records: &[Value],
    strip: &[&str],
    first: &[&str],
) -> PyResult<Bound<'py, PyDict>> {
    let mut keys: Vec<String> = Vec::new();
    let mut flat: Vec<Vec<(String, Value)>> = Vec::with_capacity(records.len());
    for r in records {
        let mut f = Vec::new();
        flatten("", r, strip, &mut f);
        for (k, _) in &f {
            if !keys.contains(k) {
                keys.push(k.clone());
            }
        }
        flat.push(f);
    }
    let rank = |k: &String| first.iter().position(|f| f == k).unwrap_or(first.len());
    keys.sort_by_key(rank); // stable: the rest keep their order
    let d = PyDict::new(py);
    for k in &keys {
        let values: Vec<Value> = flat
            .iter()
            .map(|f| {
                f.iter()
                    .find(|(key, _)| key == k)
                    .map_or(Value::Null, |(_, v)| v.clone())
            })
            .collect();
        d.set_item(k, column(py, &values)?)?;
    }
    Ok(d)
}

fn column<'py>(py: Python<'py>, values: &[Value]) -> PyResult<Bound<'py, PyAny>> {
    let all = |f: fn(&Value) -> bool| values.iter().all(f);
    if !values.is_empty() && all(|v| v.is_i64() || v.is_u64()) {
        let v: Vec<i64> = values.iter().filter_map(Value::as_i64).collect();
        if v.len() == values.len() {
            return Ok(v.into_pyarray(py).into_any());
        }
    }
    if !values.is_empty()
        && all(|v| v.is_number() || v.is_null())
        && values.iter().any(Value::is_number)
    {
        let v: Vec<f64> = values
            .iter()
            .map(|v| v.as_f64().unwrap_or(f64::NAN))
            .collect();
        return Ok(v.into_pyarray(py).into_any());
    }
    if !values.is_empty() && all(Value::is_boolean) {
        let v: Vec<bool> = values.iter().map(|v| v.as_bool() == Some(true)).collect();
        return Ok(v.into_pyarray(py).into_any());
    }
    let list = PyList::empty(py);
    for v in values {
        list.append(to_py(py, v)?)?;
    }
    Ok(list.into_any())
}

/// `pandas.DataFrame(columns)`; an ImportError that says how to get pandas when it is missing.
pub fn data_frame<'py>(
    py: Python<'py>,
    columns: Bound<'py, PyDict>,
) -> PyResult<Bound<'py, PyAny>> {
    let pandas = py.import("pandas").map_err(|_| {
        pyo3::exceptions::PyImportError::new_err(
            "to_pandas() needs pandas: pip install pandas (the columns are also available as a dict of numpy arrays)",
        )
    })?;
    pandas.call_method1("DataFrame", (columns,))
}
