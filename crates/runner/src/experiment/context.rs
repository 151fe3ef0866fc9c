//! What every section's check shares: the validation context ([`Ctx`]: the spec file, for
//! messages and relative paths), the error that locates a problem in the file
//! ([`SpecError`]), and the key-by-key merge of YAML values (a sweep point's overrides).

use std::path::{Path, PathBuf};

/// A spec problem, located in the file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}: {path}{loc}: {message}", file = file.display(), loc = location(*line, *column))]
pub struct SpecError {
    /// The spec file.
    pub file: PathBuf,
    /// YAML path of the offending value (`.` for the document).
    pub path: String,
    /// 1-based line, when the parser reports it.
    pub line: Option<usize>,
    /// 1-based column, when the parser reports it.
    pub column: Option<usize>,
    /// What is wrong.
    pub message: String,
}

fn location(line: Option<usize>, column: Option<usize>) -> String {
    match (line, column) {
        (Some(l), Some(c)) => format!(" (line {l}, column {c})"),
        (Some(l), None) => format!(" (line {l})"),
        _ => String::new(),
    }
}

impl SpecError {
    /// An error at `path` with no line information.
    pub fn at(file: &Path, path: impl Into<String>, message: impl Into<String>) -> Self {
        SpecError {
            file: file.to_path_buf(),
            path: path.into(),
            line: None,
            column: None,
            message: message.into(),
        }
    }
}

/// Validation context: the spec file (for messages and relative paths).
pub struct Ctx<'a> {
    /// Spec file.
    pub file: &'a Path,
}

impl Ctx<'_> {
    /// Resolves a path relative to the spec file's folder.
    pub fn resolve(&self, p: &Path) -> PathBuf {
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.file.parent().unwrap_or(Path::new(".")).join(p)
        }
    }

    pub(crate) fn err(&self, path: impl Into<String>, msg: impl Into<String>) -> SpecError {
        SpecError::at(self.file, path, msg)
    }
}

/// Merges `over` into `base` key by key (mappings recursively; other values replace).
pub(crate) fn merge(base: &mut serde_yaml_ng::Value, over: &serde_yaml_ng::Value) {
    use serde_yaml_ng::Value;
    match (base, over) {
        (Value::Mapping(b), Value::Mapping(o)) => {
            for (k, v) in o {
                match b.get_mut(k) {
                    Some(slot) => merge(slot, v),
                    None => {
                        b.insert(k.clone(), v.clone());
                    }
                }
            }
        }
        (slot, v) => *slot = v.clone(),
    }
}
