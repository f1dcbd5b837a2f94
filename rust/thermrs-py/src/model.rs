//! `thermrs._native.ForwardModel`: the forward model of a rig (SPEC §4) with its effects,
//! run over time series in GIL-free chunks with progress and Ctrl-C between them.

use numpy::ndarray::Array2;
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray2,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use thermrs_core::effects::Effects;
use thermrs_core::error::Error as CoreError;
use thermrs_core::model::{FlangeOutput, ForwardModel, SPOT_WIDTH};

use crate::effects;
use crate::errors::InputError;
use crate::guard::call;
use crate::progress::report;
use crate::rig::PyRig;

/// Samples per GIL-free chunk; between chunks: signals and progress.
const CHUNK: usize = 1 << 18;

/// The forward model of a rig with one expansion law (see `thermrs.model`).
#[pyclass(frozen, module = "thermrs._native", name = "ForwardModel")]
pub struct PyForwardModel {
    inner: ForwardModel,
    /// The effects it was built with (lag and chip shifts act outside the geometry).
    effects: Effects,
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
        call("checking the forward model's inputs", || {
            self.inner.batch_len(q, cols.as_deref())
        })?;
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
            py.detach(|| call("computing the forward model", || f(qc, tc.as_deref(), oc)))?;
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
        call("building the forward model", || {
            let list = match effects_json {
                Some(j) => effects::parse_list(j)?,
                None => Vec::new(),
            };
            let fx = Effects::build(
                &rig.inner,
                &list,
                alpha_per_k.unwrap_or(rig.inner.expansion.alpha_per_k),
                reference_c.unwrap_or(rig.inner.expansion.reference_c),
            )?;
            let inner = ForwardModel::new(&rig.inner, &fx.params)?;
            Ok(PyForwardModel { inner, effects: fx })
        })
    }

    /// Whether an effect lags the structure behind the surface temperatures.
    fn has_lag(&self) -> bool {
        self.effects.lag_tau_s.is_some()
    }

    /// Whether an effect shifts chips.
    fn shifts_chips(&self) -> PyResult<bool> {
        call("asking the effects", || Ok(self.effects.shifts_chips()))
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
        let y = call("lagging temperatures", || {
            self.effects.structure_series(t, x)
        })?;
        Ok(y.into_pyarray(py))
    }

    /// Whether camera `camera`'s mount follows the room through a lag (`fixture_drift`'s
    /// `mount_tau_min`).
    fn has_mount_lag(&self, camera: &str) -> PyResult<bool> {
        let cam = call("finding a camera", || self.inner.camera_index(camera))?;
        Ok(self.effects.mount_lag_s(cam).is_some())
    }

    /// An ambient temperature series as camera `camera`'s mount sees it (`fixture_drift`'s
    /// `mount_tau_min`; unchanged without one), times in seconds.
    fn mount_temperatures<'py>(
        &self,
        py: Python<'py>,
        camera: &str,
        t_s: PyReadonlyArray1<'py, f64>,
        x: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let cam = call("finding a camera", || self.inner.camera_index(camera))?;
        let (t, x) = (t_s.as_slice()?, x.as_slice()?);
        let y = call("lagging temperatures", || {
            self.effects.mount_series(cam, t, x)
        })?;
        Ok(y.into_pyarray(py))
    }

    /// The chip effects' apparent shift (N, 2) µm of one camera's spot, per sample of ambient
    /// temperature and time since the run began (s); `mount_c`, the temperature the camera's
    /// mount has reached (default: the ambient).
    #[pyo3(signature = (camera, ambient_c, t_since_start_s, mount_c=None))]
    fn chip_shifts<'py>(
        &self,
        py: Python<'py>,
        camera: &str,
        ambient_c: PyReadonlyArray1<'py, f64>,
        t_since_start_s: PyReadonlyArray1<'py, f64>,
        mount_c: Option<PyReadonlyArray1<'py, f64>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let cam = call("finding a camera", || self.inner.camera_index(camera))?;
        let (a, t) = (ambient_c.as_slice()?, t_since_start_s.as_slice()?);
        let m = match &mount_c {
            Some(m) => m.as_slice()?,
            None => a,
        };
        if a.len() != t.len() || m.len() != a.len() {
            return Err(InputError::new_err(format!(
                "ambient_c, t_since_start_s and mount_c must have equal lengths, got {}, {} and {}",
                a.len(),
                t.len(),
                m.len()
            )));
        }
        let out = call("shifting chips", || {
            let mut out = Vec::with_capacity(2 * a.len());
            for ((&ak, &tk), &mk) in a.iter().zip(t).zip(m) {
                out.extend_from_slice(&self.effects.chip_shift_um(cam, ak, mk, tk));
            }
            Ok(out)
        })?;
        let arr = Array2::from_shape_vec((a.len(), 2), out).expect("shape");
        Ok(arr.into_pyarray(py))
    }

    /// Temperature names, in the order `temperatures` columns are expected.
    fn temperature_names(&self) -> PyResult<Vec<String>> {
        call("listing the model's temperatures", || {
            Ok(self.inner.temperature_names().to_vec())
        })
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
        let cam = call("finding a camera", || self.inner.camera_index(camera))?;
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

/// Number of threads the core's parallel loops use.
#[pyfunction]
fn num_threads() -> PyResult<usize> {
    call(
        "counting threads",
        || Ok(thermrs_core::model::num_threads()),
    )
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyForwardModel>()?;
    m.add_function(wrap_pyfunction!(num_threads, m)?)?;
    Ok(())
}
