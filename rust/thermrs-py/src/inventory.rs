//! What a recording holds (`thermrs_core::inventory`), for `thermrs info`: a JSON document.

use std::path::PathBuf;

use pyo3::prelude::*;
use serde_json::json;
use thermrs_core::inventory as core;

use crate::guard;

/// What the recording at `path` holds, read from its summary and indexes (see the core
/// module); `topics`: those whose messages' log times are wanted. Returns JSON.
#[pyfunction]
#[pyo3(signature = (path, topics = None))]
fn inventory(py: Python<'_>, path: PathBuf, topics: Option<Vec<String>>) -> PyResult<String> {
    let topics = topics.unwrap_or_default();
    let inv = py.detach(|| {
        guard::call("reading a recording's summary", || {
            core::inventory(&path, &topics)
        })
    })?;
    let channels: Vec<_> = inv
        .channels
        .iter()
        .map(|c| {
            json!({"id": c.id, "topic": c.topic, "schema": c.schema, "encoding": c.encoding,
                   "messages": c.messages})
        })
        .collect();
    let metadata: Vec<_> = inv
        .metadata
        .iter()
        .map(|(name, values)| json!({"name": name, "values": values}))
        .collect();
    let attachments: Vec<_> = inv
        .attachments
        .iter()
        .map(|(name, bytes)| json!({"name": name, "bytes": bytes}))
        .collect();
    Ok(json!({
        "storage": inv.storage,
        "bytes": inv.bytes,
        "from_summary": inv.from_summary,
        "profile": inv.profile,
        "library": inv.library,
        "start_ns": inv.start_ns,
        "end_ns": inv.end_ns,
        "chunks": inv.chunks,
        "chunks_decompressed": inv.chunks_decompressed,
        "compression": inv.compression,
        "messages": inv.messages,
        "channels": channels,
        "metadata": metadata,
        "attachments": attachments,
        "log_times": inv.log_times,
        "losses": inv.losses,
        "notes": inv.notes,
    })
    .to_string())
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(inventory, m)?)?;
    Ok(())
}
