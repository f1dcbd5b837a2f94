//! Strict TOML parsing shared by rig and scenario files: unknown keys, missing keys and wrong
//! types are rejected by serde with the key path (via `serde_path_to_error`) and the line; then
//! the file's own validation runs. Every error is one line naming the file, line and key.

use crate::error::{FileKind, KeyError, RigError};

fn line_of(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())].matches('\n').count() + 1
}

fn one_line(message: &str) -> String {
    message.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Parse TOML strictly into `T` and validate it: every error one line naming the file, the
/// line where the parser can tell, and the key (`kind` is `rig` or `scenario`). Shared by rig
/// and scenario files.
pub fn parse_strict<T: serde::de::DeserializeOwned>(
    text: &str,
    source_name: &str,
    kind: FileKind,
    validate: impl Fn(&T) -> Result<(), KeyError>,
) -> Result<T, RigError> {
    let err = |line: Option<usize>, key: String, message: String| RigError {
        kind,
        source_name: source_name.to_string(),
        line,
        key,
        message,
    };
    let de = toml::Deserializer::parse(text).map_err(|e| {
        let line = e.span().map(|s| line_of(text, s.start));
        // Name the key of a "duplicate key" (the span covers it).
        let key = match e.span() {
            Some(s) if e.message().contains("duplicate") => text
                .get(s)
                .map(|k| k.trim().trim_matches(['[', ']']).trim().to_string())
                .unwrap_or_default(),
            _ => String::new(),
        };
        err(line, key, one_line(e.message()))
    })?;
    let value: T = serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        let key = if path == "." { String::new() } else { path };
        err(
            inner.span().map(|s| line_of(text, s.start)),
            key,
            one_line(inner.message()),
        )
    })?;
    validate(&value).map_err(|e| err(None, e.key, e.message))?;
    Ok(value)
}
