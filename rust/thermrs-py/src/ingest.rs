//! Extraction of recordings for Python: `extract` (tables as numpy columns, the report as
//! JSON), `decompress_chunks` and `checksum_chunks` (for benchmarks), `status_names`.

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use thermrs_core::ingest;

use crate::convert::{array, columns, rows};
use crate::guard::call;
use crate::progress::Pending;
use crate::rig::PyRig;

/// Extract a recording: returns (frames, thermal, joints, ambient) column dicts of numpy arrays
/// (handed over without copying) and the report as JSON. Runs without the GIL; `progress` is
/// called as progress(bytes_done, bytes_total, frames_done); Ctrl-C stops it.
#[pyfunction]
#[pyo3(signature = (path, rig, *, progress = None, min_sigma_px = None, threshold_sigma = None, verify_crc = true, content_hash = false))]
#[allow(clippy::too_many_arguments)] // the Python function's keyword arguments, one each
fn extract<'py>(
    py: Python<'py>,
    path: PathBuf,
    rig: &PyRig,
    progress: Option<Py<PyAny>>,
    min_sigma_px: Option<f64>,
    threshold_sigma: Option<f64>,
    verify_crc: bool,
    content_hash: bool,
) -> PyResult<Bound<'py, PyTuple>> {
    let pending = Pending::default();
    let cb = |done: u64, total: u64, frames: u64| -> bool {
        pending.attach(|py| {
            py.check_signals()?;
            match &progress {
                Some(f) => f.call1(py, (done, total, frames)).map(|_| ()),
                None => Ok(()),
            }
        })
    };
    let inner = &rig.inner;
    let res = py.detach(|| {
        call(&format!("reading {}", path.display()), || {
            let opts = options(min_sigma_px, threshold_sigma, verify_crc, content_hash);
            let (tables, report) = ingest::extract(&path, inner, &opts, &cb)?;
            let report = serde_json::to_string(&report).expect("report serialises");
            Ok((tables, report))
        })
    });
    if let Some(e) = pending.take() {
        return Err(e);
    }
    let (tables, report) = res?;
    to_py(py, tables, report)
}

/// The extraction options from `extract`'s keyword arguments (`None`: the core's default).
pub(crate) fn options(
    min_sigma_px: Option<f64>,
    threshold_sigma: Option<f64>,
    verify_crc: bool,
    content_hash: bool,
) -> ingest::ExtractOptions {
    let mut opts = ingest::ExtractOptions {
        verify_crc,
        content_hash,
        ..ingest::ExtractOptions::default()
    };
    if let Some(v) = min_sigma_px {
        opts.spot.min_sigma_px = v;
    }
    if let Some(v) = threshold_sigma {
        opts.spot.detect_sigmas = v;
    }
    opts
}

/// The tables as (frames, thermal, joints, ambient) dicts of numpy columns, and the report.
pub(crate) fn to_py<'py>(
    py: Python<'py>,
    t: ingest::Tables,
    report: String,
) -> PyResult<Bound<'py, PyTuple>> {
    let n = t.joints.t_ns.len();
    let joints = columns(
        py,
        vec![
            ("t_ns", array(py, t.joints.t_ns)),
            ("position", rows(py, t.joints.position, (n, 6))),
        ],
    )?;
    let ambient = columns(
        py,
        vec![
            ("t_ns", array(py, t.ambient.t_ns)),
            ("temperature_c", array(py, t.ambient.temperature_c)),
        ],
    )?;
    PyTuple::new(
        py,
        [
            frames(py, t.frames)?.into_any(),
            thermal(py, t.thermal)?.into_any(),
            joints.into_any(),
            ambient.into_any(),
            report.into_pyobject(py)?.into_any(),
        ],
    )
}

/// One row per CCD frame.
fn frames<'py>(py: Python<'py>, f: ingest::FrameTable) -> PyResult<Bound<'py, PyDict>> {
    columns(
        py,
        vec![
            ("camera", array(py, f.camera)),
            ("t_ns", array(py, f.t_ns)),
            ("x_px", array(py, f.x_px)),
            ("y_px", array(py, f.y_px)),
            ("peak", array(py, f.peak)),
            ("signal", array(py, f.signal)),
            ("size_px", array(py, f.size_px)),
            ("background", array(py, f.background)),
            ("noise", array(py, f.noise)),
            ("status", array(py, f.status)),
        ],
    )
}

/// One row per thermal frame and ROI.
fn thermal<'py>(py: Python<'py>, th: ingest::ThermalTable) -> PyResult<Bound<'py, PyDict>> {
    columns(
        py,
        vec![
            ("t_ns", array(py, th.t_ns)),
            ("roi", array(py, th.roi)),
            ("max_c", array(py, th.max_c)),
            ("peak_c", array(py, th.peak_c)),
            ("x_px", array(py, th.x_px)),
            ("y_px", array(py, th.y_px)),
        ],
    )
}

/// Decompress every chunk on one thread, nothing else (the decompressor's own speed; for
/// benchmarks). Returns (chunks, compressed bytes, uncompressed bytes).
#[pyfunction]
fn decompress_chunks(py: Python<'_>, path: PathBuf) -> PyResult<(u64, u64, u64)> {
    let s = py.detach(|| call("decompressing chunks", || ingest::decompress_chunks(&path)))?;
    Ok((s.chunks, s.compressed_bytes, s.uncompressed_bytes))
}

/// CRC-32 of every chunk in place through the map, nothing else (the floor of a checked
/// extraction; for benchmarks). Returns (chunks, bytes checksummed, last chunk's CRC).
#[pyfunction]
fn checksum_chunks(py: Python<'_>, path: PathBuf) -> PyResult<(u64, u64, u32)> {
    let s = py.detach(|| call("checksumming chunks", || ingest::checksum_chunks(&path)))?;
    Ok((s.chunks, s.bytes, s.last_crc))
}

/// The content hash that identifies a recording in a campaign (BLAKE3 of its bytes, a
/// trailing hole counted by its length; the core's `digest` module; for a bag folder, of its
/// files' hashes in order, the core's `bag` module), as hex.
#[pyfunction]
fn content_hash(py: Python<'_>, path: PathBuf) -> PyResult<String> {
    py.detach(|| {
        call("hashing a recording", || {
            if path.is_dir() {
                thermrs_core::bag::content_hash(&path)
            } else {
                thermrs_core::digest::content_hash(&path)
            }
        })
    })
}

/// Whether `path` is a rosbag2 bag folder read as one recording (`metadata.yaml`, or the
/// numbered files of one split bag; the core's `bag` module).
#[pyfunction]
fn is_bag(path: PathBuf) -> bool {
    thermrs_core::bag::is_bag(&path)
}

/// The files of the bag in `path`, in order (some may be missing).
#[pyfunction]
fn bag_parts(path: PathBuf) -> PyResult<Vec<String>> {
    call("reading a bag's metadata", || {
        let bag = thermrs_core::bag::Bag::open(&path)?;
        Ok(bag.parts.iter().map(|p| p.display().to_string()).collect())
    })
}

/// Names of the frame status codes, in code order.
#[pyfunction]
fn status_names() -> Vec<&'static str> {
    ingest::STATUS_NAMES.to_vec()
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(extract, m)?)?;
    m.add_function(wrap_pyfunction!(is_bag, m)?)?;
    m.add_function(wrap_pyfunction!(bag_parts, m)?)?;
    m.add_function(wrap_pyfunction!(status_names, m)?)?;
    m.add_function(wrap_pyfunction!(decompress_chunks, m)?)?;
    m.add_function(wrap_pyfunction!(checksum_chunks, m)?)?;
    m.add_function(wrap_pyfunction!(content_hash, m)?)?;
    Ok(())
}
