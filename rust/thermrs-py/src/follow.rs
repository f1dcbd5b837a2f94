//! A recording followed while it is written, for Python: `Follower` (`thermrs watch`).

use std::path::PathBuf;
use std::sync::Mutex;

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use thermrs_core::ingest::{Follow, FollowState};

use crate::guard::call;
use crate::ingest::{options, to_py};
use crate::progress::Pending;
use crate::rig::PyRig;

/// Follows an MCAP file or a rosbag2 SQLite database while it is written: each `step` reads
/// only the complete records (the committed rows) added since the last (a record still being
/// written is waited for, never reported lost).
#[pyclass(module = "thermrs._native", name = "Follower")]
pub struct PyFollower {
    inner: Mutex<Follow>,
}

#[pymethods]
impl PyFollower {
    /// A follower of `path` from its start, or from `state` (JSON from `state_json`).
    #[new]
    #[pyo3(signature = (path, *, state = None))]
    fn new(path: PathBuf, state: Option<&str>) -> PyResult<Self> {
        let inner = match state {
            None => Follow::new(&path),
            Some(s) => {
                let st: FollowState = serde_json::from_str(s)
                    .map_err(|e| PyValueError::new_err(format!("a follower's state: {e}")))?;
                Follow::resume(&path, &st)
            }
        };
        Ok(PyFollower {
            inner: Mutex::new(inner),
        })
    }

    /// Read what was added: returns (frames, thermal, joints, ambient, report JSON) as
    /// `extract` does, the byte range read (from, to: file offsets; a SQLite database: bytes
    /// of message data from its first row) and whether the recording is complete.
    /// Runs without the GIL; Ctrl-C stops it, leaving the follower where it was.
    #[pyo3(signature = (rig, *, progress = None, min_sigma_px = None, threshold_sigma = None, verify_crc = true))]
    fn step<'py>(
        &self,
        py: Python<'py>,
        rig: &PyRig,
        progress: Option<Py<PyAny>>,
        min_sigma_px: Option<f64>,
        threshold_sigma: Option<f64>,
        verify_crc: bool,
    ) -> PyResult<(Bound<'py, PyTuple>, u64, u64, bool)> {
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
        let follow = &self.inner;
        let res = py.detach(|| {
            let mut f = follow.lock().unwrap_or_else(|p| p.into_inner());
            let what = format!("following the recording at {}", f.position());
            call(&what, || {
                let opts = options(min_sigma_px, threshold_sigma, verify_crc, false);
                let s = f.step(inner, &opts, &cb)?;
                let report = serde_json::to_string(&s.report).expect("report serialises");
                Ok((s.tables, report, s.from, s.to, s.closed))
            })
        });
        if let Some(e) = pending.take() {
            return Err(e);
        }
        let (tables, report, from, to, closed) = res?;
        Ok((to_py(py, tables, report)?, from, to, closed))
    }

    /// What to keep to go on later in another process (`Follower(path, state=...)`), as JSON.
    fn state_json(&self) -> String {
        let f = self.inner.lock().unwrap_or_else(|p| p.into_inner());
        serde_json::to_string(&f.state()).expect("state serialises")
    }

    /// The file offset up to which the recording has been read.
    #[getter]
    fn position(&self) -> u64 {
        self.inner
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .position()
    }

    /// Whether the recording was complete at the last step.
    #[getter]
    fn closed(&self) -> bool {
        self.inner
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .closed()
    }

    /// Topics of the channels met so far.
    fn topics(&self) -> Vec<String> {
        self.inner
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .topics()
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyFollower>()?;
    Ok(())
}
