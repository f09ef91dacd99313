//! numpy in and out: any array-like (a numpy array, a list of lists) is read as float64 and
//! its shape checked, with an error naming the argument.

use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyArrayDyn, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyAnyMethods;

use crate::error;

/// A float64 numpy array of shape (n, K) held by Python.
pub type Rows<'py> = Bound<'py, PyArray2<f64>>;

/// `obj` as a float64 array of any shape (copied), with its shape.
fn as_f64(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<(Vec<usize>, Vec<f64>)> {
    let np = obj.py().import("numpy")?;
    let converted = np
        .getattr("asarray")?
        .call1((obj, np.getattr("float64")?))
        .map_err(|e| error(format!("{name}: not an array of numbers ({e})")))?;
    let array = converted
        .cast::<PyArrayDyn<f64>>()
        .map_err(|_| error(format!("{name}: not an array of numbers")))?;
    let readonly = array.readonly();
    let view = readonly.as_array();
    let shape = view.shape().to_vec();
    let values: Vec<f64> = view.iter().copied().collect();
    Ok((shape, values))
}

/// Reads an `(n, K)` array (`n` given or free), checking every value is finite.
pub fn rows<const K: usize>(
    obj: &Bound<'_, PyAny>,
    name: &str,
    n: Option<usize>,
) -> PyResult<Vec<[f64; K]>> {
    let (shape, values) = as_f64(obj, name)?;
    let expected = match n {
        Some(n) => format!("({n}, {K})"),
        None => format!("(n, {K})"),
    };
    if shape.len() != 2 || shape[1] != K || n.is_some_and(|n| shape[0] != n) {
        return Err(error(format!(
            "{name}: expected an array of shape {expected}, got shape {shape:?}"
        )));
    }
    finite_rows(name, &values)
}

/// Reads an `(f, n, K)` array (`n` given, `f` free, at least one), checking every value is
/// finite: one `(n, K)` block per frame.
pub fn frames<const K: usize>(
    obj: &Bound<'_, PyAny>,
    name: &str,
    n: usize,
) -> PyResult<Vec<Vec<[f64; K]>>> {
    let (shape, values) = as_f64(obj, name)?;
    if shape.len() != 3 || shape[1] != n || shape[2] != K {
        return Err(error(format!(
            "{name}: expected an array of shape (frames, {n}, {K}), got shape {shape:?}"
        )));
    }
    if shape[0] == 0 {
        return Err(error(format!("{name}: no frames")));
    }
    let mut out = Vec::with_capacity(shape[0]);
    for (f, block) in values.chunks_exact(n * K).enumerate() {
        out.push(finite_rows(&format!("{name}[{f}]"), block)?);
    }
    Ok(out)
}

/// Rows of `K` from a flat array, naming the first row with a value that is not finite.
fn finite_rows<const K: usize>(name: &str, values: &[f64]) -> PyResult<Vec<[f64; K]>> {
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(error(format!(
            "{name}[{}]: coordinate is not a finite number",
            i / K
        )));
    }
    Ok(values
        .chunks_exact(K)
        .map(|c| {
            let mut row = [0.0; K];
            row.copy_from_slice(c);
            row
        })
        .collect())
}

/// Reads triangles: an `(k, 3)` array of integer vertex indices, each below `vertices` (an
/// empty sequence is no triangles).
pub fn triangles(obj: &Bound<'_, PyAny>, name: &str, vertices: usize) -> PyResult<Vec<[u32; 3]>> {
    let np = obj.py().import("numpy")?;
    let array = np
        .getattr("asarray")?
        .call1((obj,))
        .map_err(|e| error(format!("{name}: not an array of vertex indices ({e})")))?;
    let size: usize = array.getattr("size")?.extract()?;
    let shape: Vec<usize> = array.getattr("shape")?.extract()?;
    if size == 0 && shape.len() <= 2 && shape.last().is_none_or(|&k| k == 0 || k == 3) {
        return Ok(Vec::new());
    }
    let kind: String = array.getattr("dtype")?.getattr("kind")?.extract()?;
    if kind != "i" && kind != "u" {
        let dtype = array.getattr("dtype")?.str()?.to_string();
        return Err(error(format!(
            "{name}: expected integer vertex indices, got an array of {dtype}"
        )));
    }
    if shape.len() != 2 || shape[1] != 3 {
        return Err(error(format!(
            "{name}: expected an array of shape (k, 3), got shape {shape:?}"
        )));
    }
    let converted = array.call_method1("astype", (np.getattr("int64")?,))?;
    let typed = converted
        .cast::<PyArray2<i64>>()
        .map_err(|_| error(format!("{name}: not an array of vertex indices")))?;
    let readonly = typed.readonly();
    let mut out = Vec::with_capacity(shape[0]);
    for (t, row) in readonly.as_array().rows().into_iter().enumerate() {
        let mut triangle = [0u32; 3];
        for (corner, &v) in triangle.iter_mut().zip(row.iter()) {
            if v < 0 || v as u64 >= vertices as u64 {
                return Err(error(format!(
                    "{name}[{t}]: vertex index {v} is out of range (0..{vertices})"
                )));
            }
            *corner = v as u32;
        }
        out.push(triangle);
    }
    Ok(out)
}

/// An `(k, 3)` int64 numpy array of triangles.
pub fn to_triangles<'py>(
    py: Python<'py>,
    triangles: &[[u32; 3]],
) -> PyResult<Bound<'py, PyArray2<i64>>> {
    let flat: Vec<i64> = triangles.iter().flatten().map(|&i| i64::from(i)).collect();
    let array = Array2::from_shape_vec((triangles.len(), 3), flat)
        .map_err(|e| error(format!("internal shape error: {e}")))?;
    Ok(array.into_pyarray(py))
}

/// Points as `(n, 3)` rows.
pub fn point_rows(points: &[rigfit_core::Point3]) -> Vec<[f64; 3]> {
    points.iter().map(|p| p.coords.into()).collect()
}

/// Vectors as `(n, 3)` rows.
pub fn vector_rows(vectors: &[rigfit_core::Vector3]) -> Vec<[f64; 3]> {
    vectors.iter().map(|&v| v.into()).collect()
}

/// An `(n, K)` numpy array from rows.
pub fn to_rows<'py, const K: usize>(
    py: Python<'py>,
    rows: &[[f64; K]],
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let flat: Vec<f64> = rows.iter().flatten().copied().collect();
    let array = Array2::from_shape_vec((rows.len(), K), flat)
        .map_err(|e| error(format!("internal shape error: {e}")))?;
    Ok(array.into_pyarray(py))
}

/// An `(n, 4, 4)` numpy array from matrices.
pub fn to_matrices<'py>(
    py: Python<'py>,
    matrices: &[rigfit_core::Matrix4],
) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let mut flat = Vec::with_capacity(matrices.len() * 16);
    for m in matrices {
        for r in 0..4 {
            for c in 0..4 {
                flat.push(m[(r, c)]);
            }
        }
    }
    let array = Array3::from_shape_vec((matrices.len(), 4, 4), flat)
        .map_err(|e| error(format!("internal shape error: {e}")))?;
    Ok(array.into_pyarray(py))
}

/// A 1-D int64 numpy array.
pub fn to_ints<'py>(py: Python<'py>, values: Vec<i64>) -> Bound<'py, PyArray1<i64>> {
    Array1::from_vec(values).into_pyarray(py)
}

/// A number argument, or a `RigfitError` naming it.
pub fn number(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<f64> {
    if obj.is_instance_of::<pyo3::types::PyBool>() {
        return Err(error(format!("{name}: expected a number, got a bool")));
    }
    obj.extract::<f64>().map_err(|_| {
        let kind = obj
            .get_type()
            .name()
            .map_or_else(|_| "?".into(), |n| n.to_string());
        error(format!("{name}: expected a number, got {kind}"))
    })
}
