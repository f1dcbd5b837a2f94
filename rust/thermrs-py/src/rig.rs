//! `thermrs._native.Rig`: a validated rig file (wraps the core's `Rig`).

use std::path::PathBuf;

use pyo3::prelude::*;
use thermrs_core::explain;
use thermrs_core::rig::Rig;

use crate::guard::call;

/// A validated rig (wraps the core's `Rig`).
#[pyclass(frozen, module = "thermrs._native", name = "Rig")]
pub struct PyRig {
    pub(crate) inner: Rig,
}

#[pymethods]
impl PyRig {
    /// Read and validate a rig file.
    #[staticmethod]
    fn from_path(py: Python<'_>, path: PathBuf) -> PyResult<PyRig> {
        let inner = py.detach(|| call("reading a rig", || Rig::from_path(&path)))?;
        Ok(PyRig { inner })
    }

    /// Parse and validate rig TOML text; `source_name` names it in errors.
    #[staticmethod]
    #[pyo3(signature = (text, source_name = "<string>"))]
    fn from_toml(text: &str, source_name: &str) -> PyResult<PyRig> {
        let inner = call("reading a rig", || Ok(Rig::from_toml(text, source_name)?))?;
        Ok(PyRig { inner })
    }

    /// Parse and validate a rig given as JSON (the keys of `to_json`).
    #[staticmethod]
    #[pyo3(signature = (text, source_name = "<json>"))]
    fn from_json(text: &str, source_name: &str) -> PyResult<PyRig> {
        let inner = call("reading a rig", || Ok(Rig::from_json(text, source_name)?))?;
        Ok(PyRig { inner })
    }

    /// The rig as a JSON string (all keys of the file, defaults filled in; `tolerances` only
    /// where the file states them).
    fn to_json(&self) -> PyResult<String> {
        call("writing a rig as JSON", || Ok(self.inner.to_json()))
    }

    /// The rig explained pose by pose (SPEC §7 `thermrs rig --json`, extended) as JSON, plus
    /// a `problems` list (poses whose own camera the laser misses).
    fn explain_json(&self) -> PyResult<String> {
        call("explaining a rig", || {
            let view = explain::explain(&self.inner)?;
            let mut v = view.to_spec_json();
            v["problems"] = serde_json::json!(view.problems);
            Ok(v.to_string())
        })
    }

    /// The tolerances in force (the file's `[tolerances]`, else the defaults) as JSON.
    fn tolerances_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.inner.tolerances())
            .map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))
    }

    /// Whether the file states its `[tolerances]` (else the defaults are in force).
    fn tolerances_stated(&self) -> bool {
        self.inner.tolerances_stated()
    }

    /// The temperature names the nominal model maps lengths to, in column order.
    fn mapped_temperatures(&self) -> PyResult<Vec<String>> {
        call("listing a rig's temperatures", || {
            Ok(self.inner.mapped_temperatures())
        })
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyRig>()
}
