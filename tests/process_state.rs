//! The process-global state is listed: every `static` item of the source (outside tests) has
//! its row in docs/architecture.md's "Process-global state" table, and every row names a
//! `static` that exists, so that a reader of the architecture document sees all the state a
//! process keeps beside its arguments.

mod common;

use common::rust_files;
use std::fs;
use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Every `static` item of the tree outside tests: `(file, name)`, the file relative to the
/// root (thread-locals included: their `static` line inside `thread_local!`).
fn statics() -> std::collections::BTreeSet<(String, String)> {
    let mut out = std::collections::BTreeSet::new();
    for dir in ["crates", "src", "python/src"] {
        for file in rust_files(&root().join(dir)) {
            let text = fs::read_to_string(&file).unwrap();
            // The source before its unit-test module (a test-only item elsewhere stays).
            let text = text.split("#[cfg(test)]\nmod tests {").next().unwrap();
            if file.ends_with("tests.rs") {
                continue;
            }
            for line in text.lines() {
                let t = line.trim_start();
                let t = t
                    .strip_prefix("pub(crate) ")
                    .or_else(|| t.strip_prefix("pub "))
                    .unwrap_or(t);
                if let Some(rest) = t.strip_prefix("static ") {
                    let name: String = rest
                        .chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_')
                        .collect();
                    let rel = file
                        .strip_prefix(root())
                        .unwrap()
                        .to_string_lossy()
                        .to_string();
                    out.insert((rel, name));
                }
            }
        }
    }
    out
}

/// The rows of docs/architecture.md's "Process-global state" table: `(file, name)`.
fn listed_statics(doc: &str) -> std::collections::BTreeSet<(String, String)> {
    let section = doc
        .split("## Process-global state")
        .nth(1)
        .expect("a Process-global state section")
        .split("\n## ")
        .next()
        .unwrap();
    section
        .lines()
        .filter(|l| l.starts_with("| `"))
        .map(|l| {
            let cells: Vec<&str> = l.split('|').map(|c| c.trim().trim_matches('`')).collect();
            (cells[2].to_string(), cells[1].to_string())
        })
        .collect()
}

#[test]
fn every_process_global_static_is_listed_in_the_architecture_document() {
    let doc = fs::read_to_string(root().join("docs/architecture.md")).unwrap();
    let listed = listed_statics(&doc);
    let found = statics();
    assert!(
        found.len() >= 10,
        "only {} statics read: {found:?}",
        found.len()
    );
    let unlisted: Vec<_> = found.difference(&listed).collect();
    let gone: Vec<_> = listed.difference(&found).collect();
    assert!(
        unlisted.is_empty() && gone.is_empty(),
        "docs/architecture.md's process-global state: not listed {unlisted:?}; listed but gone {gone:?}"
    );
}
