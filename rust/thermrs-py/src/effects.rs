//! The SPEC §6 effects (`thermrs_core::effects`) for Python: JSON in, checked, JSON out.

use pyo3::prelude::*;
use thermrs_core::effects::{Effect, EFFECT_NAMES};
use thermrs_core::error::Error as CoreError;

use crate::guard::call;
use crate::rig::PyRig;

/// A JSON list of effects (`[{"name": …, key: value, …}, …]`), each one's values validated;
/// the error names the effect and the key.
pub(crate) fn parse_list(json: &str) -> Result<Vec<Effect>, CoreError> {
    Effect::list_from_json(json)
}

/// One effect as JSON, checked (values in range; with `rig`, the names it uses exist there);
/// returns it normalised (every key, defaults filled in).
#[pyfunction]
#[pyo3(signature = (json, rig = None))]
fn effect_check(json: &str, rig: Option<&PyRig>) -> PyResult<String> {
    call("checking an effect", || {
        let e = Effect::from_json(json)?;
        if let Some(r) = rig {
            e.check(&r.inner)?;
        }
        Ok(serde_json::to_string(&e).expect("effects serialise"))
    })
}

/// The SPEC §6 effect names, in the SPEC's order.
#[pyfunction]
fn effect_names() -> Vec<&'static str> {
    EFFECT_NAMES.to_vec()
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(effect_check, m)?)?;
    m.add_function(wrap_pyfunction!(effect_names, m)?)?;
    Ok(())
}
