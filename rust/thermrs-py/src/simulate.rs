//! The simulator for Python: a scenario on a rig written as a recording, the truth as numpy
//! columns.

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::PyDict;
use thermrs_core::error::Error as CoreError;
use thermrs_core::record::RecordError;
use thermrs_core::scenario::Scenario;

use crate::convert::{array, columns, rows};
use crate::guard::call;
use crate::progress::{signal_checker, Pending};
use crate::rig::PyRig;

/// Simulate a scenario on a rig, writing the recording to `out_path` (or, when it is `None`,
/// nothing: the truth alone, no pixel rendered); returns the truth as a dict of numpy columns
/// and the parsed scenario as JSON. Runs without the GIL; Ctrl-C stops it (signals are checked
/// every few milliseconds between cycles and frames). A failed write raises `OSError` naming
/// `out_path`. `cancel`, a callable, is asked as often: once it returns true the call stops
/// with `KeyboardInterrupt` (how a call in a worker thread, which signals never reach, stops).
#[pyfunction]
#[pyo3(signature = (rig, scenario_toml, out_path, *, source_name = "<string>", seed = None, cancel = None))]
fn simulate<'py>(
    py: Python<'py>,
    rig: &PyRig,
    scenario_toml: &str,
    out_path: Option<PathBuf>,
    source_name: &str,
    seed: Option<u64>,
    cancel: Option<Py<PyAny>>,
) -> PyResult<(Bound<'py, PyDict>, String)> {
    let (sc, sc_json) = call("reading a scenario", || {
        let mut sc = Scenario::from_toml(scenario_toml, source_name)?;
        if let Some(s) = seed {
            sc.seed = s;
        }
        let json = serde_json::to_string(&sc).expect("scenario serialises");
        Ok((sc, json))
    })?;
    // Load NumPy's C API now: loading it later, with a Ctrl-C pending, would panic.
    let _ = numpy::PyArray1::<f64>::zeros(py, 0, false);
    let inner = &rig.inner;
    let pending = Pending::default();
    let res = py.detach(|| {
        call("simulating", || {
            let cancel = signal_checker(&pending, cancel.as_ref());
            let Some(out_path) = &out_path else {
                return thermrs_core::simulate::simulate_truth(inner, &sc, &cancel);
            };
            let target = out_path.display().to_string();
            let named = |source: RecordError| CoreError::Write {
                target: target.clone(),
                source,
            };
            let f = std::fs::File::create(out_path).map_err(|e| named(e.into()))?;
            let (w, truth) = thermrs_core::simulate::simulate_cancellable(
                inner,
                &sc,
                std::io::BufWriter::new(f),
                &cancel,
            )
            .map_err(|e| match e {
                CoreError::Write { source, .. } => named(source),
                e => e,
            })?;
            // Flush the buffer here: a failure is an error, not lost in a drop.
            w.into_inner().map_err(|e| named(e.into_error().into()))?;
            Ok(truth)
        })
    });
    if let Some(e) = pending.take() {
        return Err(e);
    }
    let truth = res?;
    py.check_signals()?;
    let n = truth.sample_t_ns.len();
    let k = truth.node_names.len();
    let nl = truth.length_names.len();
    let d = columns(
        py,
        vec![
            ("frame_camera", array(py, truth.frame_camera)),
            ("frame_t_ns", array(py, truth.frame_t_ns)),
            ("frame_run", array(py, truth.frame_run)),
            ("frame_x_px", array(py, truth.frame_x_px)),
            ("frame_y_px", array(py, truth.frame_y_px)),
            ("sample_t_ns", array(py, truth.sample_t_ns)),
            ("sample_run", array(py, truth.sample_run)),
            ("sample_ambient_c", array(py, truth.sample_ambient_c)),
            ("surface_c", rows(py, truth.surface_c, (n, k))),
            ("structure_c", rows(py, truth.structure_c, (n, k))),
            ("lengths_mm", rows(py, truth.lengths_mm, (n, nl))),
        ],
    )?;
    d.set_item("node_names", truth.node_names)?;
    d.set_item("length_names", truth.length_names)?;
    Ok((d, sc_json))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(simulate, m)?)
}
