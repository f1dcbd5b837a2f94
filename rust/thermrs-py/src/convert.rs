//! Conversions to Python: dicts of numpy columns (vectors handed over without a copy).

use numpy::ndarray::Array2;
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A dict of named columns.
pub fn columns<'py>(
    py: Python<'py>,
    pairs: Vec<(&str, Bound<'py, PyAny>)>,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (k, v) in pairs {
        d.set_item(k, v)?;
    }
    Ok(d)
}

/// A vector as a numpy array (no copy).
pub fn array<'py, T: numpy::Element>(py: Python<'py>, v: Vec<T>) -> Bound<'py, PyAny> {
    v.into_pyarray(py).into_any()
}

/// A row-major `shape.0` × `shape.1` vector as a 2-D numpy array (no copy).
pub fn rows<'py>(py: Python<'py>, v: Vec<f64>, shape: (usize, usize)) -> Bound<'py, PyAny> {
    Array2::from_shape_vec(shape, v)
        .expect("N × k")
        .into_pyarray(py)
        .into_any()
}
