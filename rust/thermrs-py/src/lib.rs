//! `thermrs._native`: thin pyo3 bindings of `thermrs-core`.
//!
//! The bindings only convert: numpy arrays in (contiguous float64, checked), numpy arrays out
//! (Rust vectors handed over without a copy), core errors to typed Python exceptions. Long work
//! runs in chunks with the GIL released (`py.detach`); between chunks the bindings check for
//! signals (Ctrl-C) and report progress through an optional `progress(done, total)` callback.

use std::path::PathBuf;

use numpy::ndarray::Array2;
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray2,
    PyUntypedArrayMethods,
};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

use std::sync::Mutex;
use thermrs_core::error::Error as CoreError;

use pyo3::types::{PyDict, PyTuple};
use thermrs_core::effects::Effects;
use thermrs_core::explain;
use thermrs_core::ingest;
use thermrs_core::model::{FlangeOutput, ForwardModel, SPOT_WIDTH};
use thermrs_core::rig::Rig;

mod effects;

mod panic;

create_exception!(
    thermrs._native,
    ThermrsError,
    PyException,
    "Base class of every error thermrs raises on purpose."
);
create_exception!(
    thermrs._native,
    RigError,
    ThermrsError,
    "A rig file that does not parse or does not validate; the message names the key."
);
create_exception!(
    thermrs._native,
    ScenarioError,
    ThermrsError,
    "A scenario file that does not parse or does not validate; the message names the key."
);
create_exception!(
    thermrs._native,
    RecordingError,
    ThermrsError,
    "A recording that cannot be used: not MCAP, or none of the rig's topics in it."
);
create_exception!(
    thermrs._native,
    InputError,
    ThermrsError,
    "Arguments or data that do not fit: shapes, names, values, unreadable files."
);

/// Samples per GIL-free chunk; between chunks: signals and progress.
const CHUNK: usize = 1 << 18;
/// How often a long call without chunks (the simulator) checks for signals.
const SIGNAL_EVERY: std::time::Duration = std::time::Duration::from_millis(20);

fn to_py(e: CoreError) -> PyErr {
    match e {
        CoreError::Rig(r) if r.kind == thermrs_core::error::FileKind::Scenario => {
            ScenarioError::new_err(r.to_string())
        }
        CoreError::Rig(r) => RigError::new_err(r.to_string()),
        CoreError::Recording(m) => RecordingError::new_err(m),
        CoreError::Interrupted => pyo3::exceptions::PyKeyboardInterrupt::new_err("interrupted"),
        other => InputError::new_err(other.to_string()),
    }
}

/// A validated rig (wraps the core's `Rig`).
#[pyclass(frozen, module = "thermrs._native", name = "Rig")]
struct PyRig {
    inner: Rig,
}

#[pymethods]
impl PyRig {
    /// Read and validate a rig file.
    #[staticmethod]
    fn from_path(py: Python<'_>, path: PathBuf) -> PyResult<PyRig> {
        let inner = py
            .detach(|| panic::guard("reading a rig", || Rig::from_path(&path)))
            .map_err(panic::to_py)?
            .map_err(to_py)?;
        Ok(PyRig { inner })
    }

    /// Parse and validate rig TOML text; `source_name` names it in errors.
    #[staticmethod]
    #[pyo3(signature = (text, source_name = "<string>"))]
    fn from_toml(text: &str, source_name: &str) -> PyResult<PyRig> {
        let inner = panic::guard("reading a rig", || Rig::from_toml(text, source_name))
            .map_err(panic::to_py)?
            .map_err(|e| to_py(e.into()))?;
        Ok(PyRig { inner })
    }

    /// The rig as a JSON string (all keys of the file, defaults filled in).
    fn to_json(&self) -> String {
        self.inner.to_json()
    }

    /// The rig explained pose by pose (SPEC §7 `thermrs rig --json`, extended) as JSON, plus
    /// a `problems` list (poses whose own camera the laser misses).
    fn explain_json(&self) -> PyResult<String> {
        let view = panic::guard("explaining a rig", || explain::explain(&self.inner))
            .map_err(panic::to_py)?
            .map_err(to_py)?;
        let mut v = view.to_spec_json();
        v["problems"] = serde_json::json!(view.problems);
        Ok(v.to_string())
    }

    /// The temperature names the nominal model maps lengths to, in column order.
    fn mapped_temperatures(&self) -> Vec<String> {
        self.inner.mapped_temperatures()
    }
}

/// The forward model of a rig with one expansion law (see `thermrs.model`).
#[pyclass(frozen, module = "thermrs._native", name = "ForwardModel")]
struct PyForwardModel {
    inner: ForwardModel,
    /// The effects it was built with (lag and chip shifts act outside the geometry).
    effects: Effects,
}

fn report(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    done: usize,
    total: usize,
) -> PyResult<()> {
    py.check_signals()?;
    if let Some(cb) = progress {
        cb.call1((done, total))?;
    }
    Ok(())
}

impl PyForwardModel {
    /// Shared driver: check shapes, then run `f` chunk by chunk without the GIL.
    fn run<F>(
        &self,
        py: Python<'_>,
        q: &PyReadonlyArray2<'_, f64>,
        temperatures: &Option<Vec<PyReadonlyArray1<'_, f64>>>,
        width: usize,
        progress: Option<&Bound<'_, PyAny>>,
        f: F,
    ) -> PyResult<Vec<f64>>
    where
        F: Fn(&[f64], Option<&[&[f64]]>, &mut [f64]) -> Result<(), CoreError> + Sync,
    {
        let shape = q.shape();
        if shape[1] != 6 {
            return Err(InputError::new_err(format!(
                "joints must have shape (N, 6), got ({}, {})",
                shape[0], shape[1]
            )));
        }
        let n = shape[0];
        let q = q
            .as_slice()
            .map_err(|_| InputError::new_err("joints must be a C-contiguous float64 array"))?;
        let cols: Option<Vec<&[f64]>> = match temperatures {
            None => None,
            Some(ts) => Some(
                ts.iter()
                    .map(|t| t.as_slice())
                    .collect::<Result<_, _>>()
                    .map_err(|_| {
                        InputError::new_err("temperatures must be C-contiguous float64 arrays")
                    })?,
            ),
        };
        self.inner.batch_len(q, cols.as_deref()).map_err(to_py)?;
        let mut out = vec![0.0f64; n * width];
        let mut start = 0;
        report(py, progress, 0, n)?;
        while start < n {
            let end = (start + CHUNK).min(n);
            let qc = &q[6 * start..6 * end];
            let tc: Option<Vec<&[f64]>> = cols
                .as_ref()
                .map(|cs| cs.iter().map(|c| &c[start..end]).collect());
            let oc = &mut out[width * start..width * end];
            py.detach(|| panic::guard("computing the forward model", || f(qc, tc.as_deref(), oc)))
                .map_err(panic::to_py)?
                .map_err(to_py)?;
            start = end;
            report(py, progress, start, n)?;
        }
        Ok(out)
    }
}

#[pymethods]
impl PyForwardModel {
    #[new]
    #[pyo3(signature = (rig, *, alpha_per_k = None, reference_c = None, effects_json = None))]
    fn new(
        rig: &PyRig,
        alpha_per_k: Option<f64>,
        reference_c: Option<f64>,
        effects_json: Option<&str>,
    ) -> PyResult<PyForwardModel> {
        let list = match effects_json {
            Some(j) => effects::parse_list(j)?,
            None => Vec::new(),
        };
        let built = panic::guard("building the forward model", || {
            let fx = Effects::build(
                &rig.inner,
                &list,
                alpha_per_k.unwrap_or(rig.inner.expansion.alpha_per_k),
                reference_c.unwrap_or(rig.inner.expansion.reference_c),
            )?;
            let inner = ForwardModel::new(&rig.inner, &fx.params)?;
            Ok::<_, CoreError>(PyForwardModel { inner, effects: fx })
        });
        built.map_err(panic::to_py)?.map_err(to_py)
    }

    /// Whether an effect lags the structure behind the surface temperatures.
    fn has_lag(&self) -> bool {
        self.effects.lag_tau_s.is_some()
    }

    /// Whether an effect shifts chips.
    fn shifts_chips(&self) -> bool {
        self.effects.shifts_chips()
    }

    /// A surface temperature series as the structure sees it (`thermal_lag`; unchanged
    /// without it), times in seconds.
    fn structure_temperatures<'py>(
        &self,
        py: Python<'py>,
        t_s: PyReadonlyArray1<'py, f64>,
        x: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let (t, x) = (t_s.as_slice()?, x.as_slice()?);
        let y = panic::guard("lagging temperatures", || {
            self.effects.structure_series(t, x)
        })
        .map_err(panic::to_py)?
        .map_err(to_py)?;
        Ok(y.into_pyarray(py))
    }

    /// The chip effects' apparent shift (N, 2) µm of one camera's spot, per sample of ambient
    /// temperature and time since the run began (s).
    fn chip_shifts<'py>(
        &self,
        py: Python<'py>,
        camera: &str,
        ambient_c: PyReadonlyArray1<'py, f64>,
        t_since_start_s: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let cam = self.inner.camera_index(camera).map_err(to_py)?;
        let (a, t) = (ambient_c.as_slice()?, t_since_start_s.as_slice()?);
        if a.len() != t.len() {
            return Err(InputError::new_err(format!(
                "ambient_c and t_since_start_s must have equal lengths, got {} and {}",
                a.len(),
                t.len()
            )));
        }
        let mut out = Vec::with_capacity(2 * a.len());
        for (&ak, &tk) in a.iter().zip(t) {
            out.extend_from_slice(&self.effects.chip_shift_um(cam, ak, tk));
        }
        let arr = Array2::from_shape_vec((a.len(), 2), out).expect("shape");
        Ok(arr.into_pyarray(py))
    }

    /// Temperature names, in the order `temperatures` columns are expected.
    fn temperature_names(&self) -> Vec<String> {
        self.inner.temperature_names().to_vec()
    }

    /// Flange positions (N, 3) in mm.
    #[pyo3(signature = (q, temperatures = None, progress = None))]
    fn flange_positions<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<'py, f64>,
        temperatures: Option<Vec<PyReadonlyArray1<'py, f64>>>,
        progress: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let n = q.shape()[0];
        let out = self.run(py, &q, &temperatures, 3, progress.as_ref(), |q, t, o| {
            self.inner.flange_batch(q, t, FlangeOutput::Position, o)
        })?;
        let arr = Array2::from_shape_vec((n, 3), out).expect("shape");
        Ok(arr.into_pyarray(py))
    }

    /// Flange transforms (N, 4, 4), homogeneous, base frame.
    #[pyo3(signature = (q, temperatures = None, progress = None))]
    fn flange_transforms<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<'py, f64>,
        temperatures: Option<Vec<PyReadonlyArray1<'py, f64>>>,
        progress: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let n = q.shape()[0];
        let out = self.run(py, &q, &temperatures, 16, progress.as_ref(), |q, t, o| {
            self.inner.flange_batch(q, t, FlangeOutput::Matrix, o)
        })?;
        let arr = numpy::ndarray::Array3::from_shape_vec((n, 4, 4), out).expect("shape");
        Ok(arr.into_pyarray(py))
    }

    /// Laser spot on one camera's chip plane: (N, 4) columns x_px, y_px, distance_mm,
    /// incidence_deg; NaN where the ray does not meet the plane in front of the laser.
    #[pyo3(signature = (camera, q, temperatures = None, progress = None))]
    fn spots<'py>(
        &self,
        py: Python<'py>,
        camera: &str,
        q: PyReadonlyArray2<'py, f64>,
        temperatures: Option<Vec<PyReadonlyArray1<'py, f64>>>,
        progress: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let cam = self.inner.camera_index(camera).map_err(to_py)?;
        let n = q.shape()[0];
        let out = self.run(
            py,
            &q,
            &temperatures,
            SPOT_WIDTH,
            progress.as_ref(),
            |q, t, o| self.inner.spot_batch(cam, q, t, o),
        )?;
        let arr = Array2::from_shape_vec((n, SPOT_WIDTH), out).expect("shape");
        Ok(arr.into_pyarray(py))
    }
}

fn columns<'py>(
    py: Python<'py>,
    pairs: Vec<(&str, Bound<'py, PyAny>)>,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (k, v) in pairs {
        d.set_item(k, v)?;
    }
    Ok(d)
}

/// Extract a recording: returns (frames, thermal, joints, ambient) column dicts of numpy arrays
/// (handed over without copying) and the report as JSON. Runs without the GIL; `progress` is
/// called as progress(bytes_done, bytes_total, frames_done); Ctrl-C stops it.
#[pyfunction]
#[pyo3(signature = (path, rig, *, progress = None, min_sigma_px = None, threshold_sigma = None, verify_crc = true))]
fn extract<'py>(
    py: Python<'py>,
    path: PathBuf,
    rig: &PyRig,
    progress: Option<Py<PyAny>>,
    min_sigma_px: Option<f64>,
    threshold_sigma: Option<f64>,
    verify_crc: bool,
) -> PyResult<Bound<'py, PyTuple>> {
    let mut opts = ingest::ExtractOptions {
        verify_crc,
        ..ingest::ExtractOptions::default()
    };
    if let Some(v) = min_sigma_px {
        opts.spot.min_sigma_px = v;
    }
    if let Some(v) = threshold_sigma {
        opts.spot.detect_sigmas = v;
    }
    let pending: Mutex<Option<PyErr>> = Mutex::new(None);
    let cb = |done: u64, total: u64, frames: u64| -> bool {
        Python::attach(|py| {
            let r = py.check_signals().and_then(|_| match &progress {
                Some(f) => f.call1(py, (done, total, frames)).map(|_| ()),
                None => Ok(()),
            });
            match r {
                Ok(()) => true,
                Err(e) => {
                    *pending.lock().expect("lock") = Some(e);
                    false
                }
            }
        })
    };
    let inner = &rig.inner;
    let res = py.detach(|| {
        panic::guard(&format!("reading {}", path.display()), || {
            ingest::extract(&path, inner, &opts, &cb)
        })
    });
    if let Some(e) = pending.lock().expect("lock").take() {
        return Err(e);
    }
    let (t, report) = res.map_err(panic::to_py)?.map_err(to_py)?;
    let f = t.frames;
    let frames = columns(
        py,
        vec![
            ("camera", f.camera.into_pyarray(py).into_any()),
            ("t_ns", f.t_ns.into_pyarray(py).into_any()),
            ("x_px", f.x_px.into_pyarray(py).into_any()),
            ("y_px", f.y_px.into_pyarray(py).into_any()),
            ("peak", f.peak.into_pyarray(py).into_any()),
            ("signal", f.signal.into_pyarray(py).into_any()),
            ("size_px", f.size_px.into_pyarray(py).into_any()),
            ("background", f.background.into_pyarray(py).into_any()),
            ("noise", f.noise.into_pyarray(py).into_any()),
            ("status", f.status.into_pyarray(py).into_any()),
        ],
    )?;
    let th = t.thermal;
    let thermal = columns(
        py,
        vec![
            ("t_ns", th.t_ns.into_pyarray(py).into_any()),
            ("roi", th.roi.into_pyarray(py).into_any()),
            ("max_c", th.max_c.into_pyarray(py).into_any()),
            ("peak_c", th.peak_c.into_pyarray(py).into_any()),
            ("x_px", th.x_px.into_pyarray(py).into_any()),
            ("y_px", th.y_px.into_pyarray(py).into_any()),
        ],
    )?;
    let n = t.joints.t_ns.len();
    let pos = Array2::from_shape_vec((n, 6), t.joints.position).expect("N×6");
    let joints = columns(
        py,
        vec![
            ("t_ns", t.joints.t_ns.into_pyarray(py).into_any()),
            ("position", pos.into_pyarray(py).into_any()),
        ],
    )?;
    let ambient = columns(
        py,
        vec![
            ("t_ns", t.ambient.t_ns.into_pyarray(py).into_any()),
            (
                "temperature_c",
                t.ambient.temperature_c.into_pyarray(py).into_any(),
            ),
        ],
    )?;
    let report = serde_json::to_string(&report).expect("report serialises");
    PyTuple::new(
        py,
        [
            frames.into_any(),
            thermal.into_any(),
            joints.into_any(),
            ambient.into_any(),
            report.into_pyobject(py)?.into_any(),
        ],
    )
}

/// Decompress every chunk on one thread, nothing else (the decompressor's own speed; for
/// benchmarks). Returns (chunks, compressed bytes, uncompressed bytes).
#[pyfunction]
fn decompress_chunks(py: Python<'_>, path: PathBuf) -> PyResult<(u64, u64, u64)> {
    let s = py
        .detach(|| ingest::decompress_chunks(&path))
        .map_err(to_py)?;
    Ok((s.chunks, s.compressed_bytes, s.uncompressed_bytes))
}

/// Simulate a scenario on a rig, writing the recording to `out_path`; returns the truth as a
/// dict of numpy columns and the parsed scenario as JSON. Runs without the GIL; Ctrl-C stops it
/// (signals are checked every few milliseconds between cycles and frames).
#[pyfunction]
#[pyo3(signature = (rig, scenario_toml, out_path, *, source_name = "<string>", seed = None))]
fn simulate<'py>(
    py: Python<'py>,
    rig: &PyRig,
    scenario_toml: &str,
    out_path: PathBuf,
    source_name: &str,
    seed: Option<u64>,
) -> PyResult<(Bound<'py, PyDict>, String)> {
    let mut sc = thermrs_core::scenario::Scenario::from_toml(scenario_toml, source_name)
        .map_err(|e| to_py(e.into()))?;
    if let Some(s) = seed {
        sc.seed = s;
    }
    // Load NumPy's C API now: loading it later, with a Ctrl-C pending, would panic.
    let _ = numpy::PyArray1::<f64>::zeros(py, 0, false);
    let inner = &rig.inner;
    let path = out_path.clone();
    let pending: Mutex<Option<PyErr>> = Mutex::new(None);
    let res = py.detach(|| {
        panic::guard("simulating", || -> Result<_, CoreError> {
            let last = std::cell::Cell::new(std::time::Instant::now());
            let cancel = || -> bool {
                if last.get().elapsed() < SIGNAL_EVERY {
                    return false;
                }
                last.set(std::time::Instant::now());
                Python::attach(|py| match py.check_signals() {
                    Ok(()) => false,
                    Err(e) => {
                        *pending.lock().expect("lock") = Some(e);
                        true
                    }
                })
            };
            let f = std::fs::File::create(&path).map_err(|source| CoreError::Io {
                path: path.display().to_string(),
                source,
            })?;
            let (w, truth) = thermrs_core::simulate::simulate_cancellable(
                inner,
                &sc,
                std::io::BufWriter::new(f),
                &cancel,
            )?;
            drop(w);
            Ok(truth)
        })
    });
    if let Some(e) = pending.lock().expect("lock").take() {
        return Err(e);
    }
    let truth = res.map_err(panic::to_py)?.map_err(to_py)?;
    py.check_signals()?;
    let n = truth.sample_t_ns.len();
    let k = truth.node_names.len();
    let surface = Array2::from_shape_vec((n, k), truth.surface_c).expect("N×nodes");
    let structure = Array2::from_shape_vec((n, k), truth.structure_c).expect("N×nodes");
    let nl = truth.length_names.len();
    let lengths = Array2::from_shape_vec((n, nl), truth.lengths_mm).expect("N×lengths");
    let d = columns(
        py,
        vec![
            (
                "frame_camera",
                truth.frame_camera.into_pyarray(py).into_any(),
            ),
            ("frame_t_ns", truth.frame_t_ns.into_pyarray(py).into_any()),
            ("frame_run", truth.frame_run.into_pyarray(py).into_any()),
            ("frame_x_px", truth.frame_x_px.into_pyarray(py).into_any()),
            ("frame_y_px", truth.frame_y_px.into_pyarray(py).into_any()),
            ("sample_t_ns", truth.sample_t_ns.into_pyarray(py).into_any()),
            ("sample_run", truth.sample_run.into_pyarray(py).into_any()),
            (
                "sample_ambient_c",
                truth.sample_ambient_c.into_pyarray(py).into_any(),
            ),
            ("surface_c", surface.into_pyarray(py).into_any()),
            ("structure_c", structure.into_pyarray(py).into_any()),
            ("lengths_mm", lengths.into_pyarray(py).into_any()),
        ],
    )?;
    d.set_item("node_names", truth.node_names)?;
    d.set_item("length_names", truth.length_names)?;
    Ok((d, serde_json::to_string(&sc).expect("scenario serialises")))
}

/// Names of the frame status codes, in code order.
#[pyfunction]
fn status_names() -> Vec<&'static str> {
    ingest::STATUS_NAMES.to_vec()
}

/// Number of threads the core's parallel loops use.
#[pyfunction]
fn num_threads() -> usize {
    thermrs_core::model::num_threads()
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("ThermrsError", py.get_type::<ThermrsError>())?;
    panic::register(m)?;
    m.add("RigError", py.get_type::<RigError>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("RecordingError", py.get_type::<RecordingError>())?;
    m.add("ScenarioError", py.get_type::<ScenarioError>())?;
    m.add_class::<PyRig>()?;
    m.add_class::<PyForwardModel>()?;
    effects::register(m)?;
    m.add_function(wrap_pyfunction!(num_threads, m)?)?;
    m.add_function(wrap_pyfunction!(extract, m)?)?;
    m.add_function(wrap_pyfunction!(status_names, m)?)?;
    m.add_function(wrap_pyfunction!(decompress_chunks, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    Ok(())
}
