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
