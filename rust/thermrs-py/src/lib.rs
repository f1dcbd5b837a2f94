//! `thermrs._native`: thin pyo3 bindings of `thermrs-core`, one file per concept.
//!
//! The bindings only convert: numpy arrays in (contiguous float64, checked), numpy arrays out
//! (Rust vectors handed over without a copy), core errors to typed Python exceptions
//! ([`errors`]). Every core call runs under the panic guard ([`guard::call`]). Long work runs
//! in chunks with the GIL released (`py.detach`); between chunks the bindings check for
//! signals (Ctrl-C) and report progress ([`progress`]).
//!
//! - [`errors`]: the exception classes and the exhaustive core → Python mapping;
//! - [`guard`]: panics as `InternalError`, `call` = guard + mapping;
//! - [`progress`]: GIL-free callbacks, the pending Python error, signal checks;
//! - [`convert`]: numpy column dicts;
//! - [`rig`], [`model`], [`effects`], [`ingest`], [`follow`], [`inventory`], [`simulate`]: one
//!   concept each.

use pyo3::prelude::*;

mod convert;
mod effects;
mod errors;
mod follow;
mod guard;
mod ingest;
mod inventory;
mod model;
mod progress;
mod rig;
mod simulate;

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    errors::register(m)?;
    guard::register(m)?;
    rig::register(m)?;
    model::register(m)?;
    effects::register(m)?;
    ingest::register(m)?;
    follow::register(m)?;
    inventory::register(m)?;
    simulate::register(m)?;
    Ok(())
}
