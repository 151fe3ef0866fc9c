//! Readable job ids: the dataset id, the method and every swept value
//! (`held.method2.alpha_h=0.5`), made safe as file names; a short hash of the job's identity
//! is appended only where ids collide after sanitising, or are too long.

use crate::run::params::Params;
use crate::seeds::sha256_hex;
use serde_json::Value as Json;
use std::collections::HashMap;

/// Longest job id before a hash suffix replaces the tail.
const MAX_ID_LEN: usize = 96;

/// Formats a swept value for a job id.
fn id_value(v: &Json) -> String {
    match v {
        Json::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// Makes a string safe as a file name.
fn sanitize(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "._=+-".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// What a job's id is made of.
pub struct IdParts<'a> {
    /// The dataset's id.
    pub dataset: &'a str,
    /// The synthesis method, if any.
    pub method: Option<&'a str>,
    /// The swept values.
    pub params: &'a Params,
    /// The canonical identity (hashed into the suffix of a colliding or long id).
    pub identity: String,
}

/// Readable ids of `jobs`, in order; a short hash of the identity is appended only where ids
/// collide after sanitising, or are too long.
pub fn readable_ids(jobs: &[IdParts]) -> Vec<String> {
    let readable: Vec<String> = jobs
        .iter()
        .map(|j| {
            let mut id = sanitize(j.dataset);
            if let Some(m) = j.method {
                id.push('.');
                id.push_str(m);
            }
            for (k, v) in j.params.iter() {
                id.push_str(&format!(".{}={}", sanitize(k), sanitize(&id_value(v))));
            }
            id
        })
        .collect();
    let mut count: HashMap<&str, usize> = HashMap::new();
    for id in &readable {
        *count.entry(id).or_default() += 1;
    }
    jobs.iter()
        .zip(&readable)
        .map(|(job, id)| {
            if count[id.as_str()] > 1 || id.len() > MAX_ID_LEN {
                let hash = &sha256_hex(job.identity.as_bytes())[..8];
                let keep: String = id.chars().take(MAX_ID_LEN).collect();
                format!("{keep}~{hash}")
            } else {
                id.clone()
            }
        })
        .collect()
}
