//! How the architecture tests read the paths a Rust file names: its code without comments and
//! strings, the `crate::`/`super::`/`self::`/crate-name paths it spells (with `use` groups
//! expanded), and the paths through the child modules it declares (a parent's bare
//! `child::f()`).

/// The code of a file without comments and string literals (a doc link or a message that
/// names a module is not an import).
pub fn code_only(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
            i += 2;
            while i + 1 < b.len() && !(b[i] == b'*' && b[i + 1] == b'/') {
                i += 1;
            }
            i += 2;
        } else if b[i] == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                i += if b[i] == b'\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if b[i] == b'\'' && b.get(i + 2) == Some(&b'\'') {
            out.push_str("' '");
            i += 3;
        } else {
            out.push(b[i] as char);
            i += 1;
        }
    }
    out
}

/// The paths a file names: `prefix::a::b` with the segments that follow, and the segments of
/// a `use prefix::{a::{b, c}, d}` group expanded.
pub fn named_paths(code: &str) -> Vec<(String, Vec<String>)> {
    let mut out = Vec::new();
    for prefix in [
        "isar_clutter_core::",
        "isar_clutter::",
        "crate::",
        "super::",
        "self::",
    ] {
        let name = prefix.trim_end_matches("::").to_string();
        for from in after_path_starts(code, prefix) {
            for segs in expand(&code[from..]) {
                out.push((name.clone(), segs));
            }
        }
    }
    out
}

/// Where the text after each `prefix` of `code` starts, skipping a `prefix` that continues a
/// longer name or path (`x_prefix`, `a::prefix`).
pub fn after_path_starts<'a>(code: &'a str, prefix: &'a str) -> impl Iterator<Item = usize> + 'a {
    code.match_indices(prefix).filter_map(move |(start, _)| {
        let before = code[..start].chars().next_back();
        let continues = before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':');
        (!continues).then_some(start + prefix.len())
    })
}

/// The modules a file declares (`mod a;`, `pub mod a;`, `pub(crate) mod a;`; not an inline
/// `mod a { ... }`).
pub fn child_modules(code: &str) -> Vec<String> {
    code.lines()
        .filter_map(|l| {
            let l = l.trim();
            let rest = l
                .strip_prefix("pub mod ")
                .or_else(|| l.strip_prefix("pub(crate) mod "))
                .or_else(|| l.strip_prefix("pub(super) mod "))
                .or_else(|| l.strip_prefix("mod "))?;
            let name = rest.strip_suffix(';')?;
            name.chars()
                .all(|c| c.is_alphanumeric() || c == '_')
                .then(|| name.to_string())
        })
        .collect()
}

/// The paths a file names through a module it declares without `self::` (`child::f()`,
/// `use child::{a, b}`), each starting with the child's name: a parent's bare calls into its
/// children, which a child importing the parent would close into a circle.
pub fn child_paths(code: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    for child in child_modules(code) {
        let prefix = format!("{child}::");
        for from in after_path_starts(code, &prefix) {
            for segs in expand(&code[from..]) {
                out.push(std::iter::once(child.clone()).chain(segs).collect());
            }
        }
    }
    out
}

/// The paths that `text` (what follows `prefix::`) spells: `a::b::C` or a `{...}` group.
pub fn expand(text: &str) -> Vec<Vec<String>> {
    let mut segs = Vec::new();
    let mut rest = text;
    loop {
        let n = rest
            .find(|c: char| !(c.is_alphanumeric() || c == '_'))
            .unwrap_or(rest.len());
        if n == 0 {
            break;
        }
        segs.push(rest[..n].to_string());
        rest = &rest[n..];
        if let Some(r) = rest.strip_prefix("::") {
            rest = r;
        } else {
            break;
        }
    }
    if let Some(inner) = rest.strip_prefix('{') {
        let mut depth = 1;
        let mut end = 0;
        for (i, c) in inner.char_indices() {
            match c {
                '{' => depth += 1,
                '}' => depth -= 1,
                _ => {}
            }
            if depth == 0 {
                end = i;
                break;
            }
        }
        let mut parts = Vec::new();
        let (mut d, mut last) = (0, 0);
        for (i, c) in inner[..end].char_indices() {
            match c {
                '{' => d += 1,
                '}' => d -= 1,
                ',' if d == 0 => {
                    parts.push(&inner[last..i]);
                    last = i + 1;
                }
                _ => {}
            }
        }
        parts.push(&inner[last..end]);
        let mut out = Vec::new();
        for p in parts {
            for tail in expand(p.trim()) {
                out.push(segs.iter().cloned().chain(tail).collect());
            }
        }
        if !out.is_empty() {
            return out;
        }
    }
    vec![segs]
}
