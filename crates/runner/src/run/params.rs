//! The swept values of one job ([`Params`]): a small sorted list of (short key, value) pairs
//! whose keys are shared by every job of the plan. A plan of 100,000 jobs holds 100,000 of
//! them; as a `BTreeMap<String, Json>` each cost a whole B-tree leaf (about 630 bytes) and a
//! copy of every key, a third of the plan's memory. It serialises as the JSON object the map
//! gave, keys in byte order, so job identities, and the seeds derived from them, are unchanged.

use serde::ser::{Serialize, SerializeMap, Serializer};
use serde_json::Value as Json;
use std::sync::Arc;

/// Swept values of a job by short key (`alpha_h`, `synthesis.samples`), sorted by key.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Params(Box<[(Arc<str>, Json)]>);

impl Params {
    /// The values of `pairs`, sorted by key; `Err(key)` names a key given twice.
    pub fn new(mut pairs: Vec<(Arc<str>, Json)>) -> Result<Self, Arc<str>> {
        pairs.sort_by(|a, b| a.0.cmp(&b.0));
        if let Some(w) = pairs.windows(2).find(|w| w[0].0 == w[1].0) {
            return Err(w[0].0.clone());
        }
        Ok(Params(pairs.into_boxed_slice()))
    }

    /// The value of `key`, if swept for this job.
    pub fn get(&self, key: &str) -> Option<&Json> {
        self.0
            .binary_search_by(|(k, _)| k.as_ref().cmp(key))
            .ok()
            .map(|i| &self.0[i].1)
    }

    /// The (key, value) pairs in key order.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &Json)> {
        self.0.iter().map(|(k, v)| (k.as_ref(), v))
    }

    /// The number of swept values.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether no value is swept for this job.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

impl Serialize for Params {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(Some(self.0.len()))?;
        for (k, v) in self.iter() {
            map.serialize_entry(k, v)?;
        }
        map.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use std::collections::BTreeMap;

    /// Oracle: the `BTreeMap<String, Json>` the plan used before. Same JSON bytes (the job
    /// identities hash them into seeds), same lookups, on random keys and values.
    #[test]
    fn serialises_and_looks_up_as_the_btree_map_did() {
        let mut rng = ChaCha8Rng::seed_from_u64(31);
        let alphabet = [
            "a",
            "b",
            "alpha_h",
            "alpha_v",
            "r_h.0",
            "synthesis.samples",
            "Z",
            "é",
        ];
        for _ in 0..200 {
            let n = rng.random_range(0..6);
            let mut map = BTreeMap::new();
            let mut pairs = Vec::new();
            for _ in 0..n {
                let key = alphabet[rng.random_range(0..alphabet.len())].to_string();
                if map.contains_key(&key) {
                    continue;
                }
                let value = if rng.random_bool(0.5) {
                    Json::from(rng.random::<f64>())
                } else {
                    Json::from(format!("v{}", rng.random::<u8>()))
                };
                map.insert(key.clone(), value.clone());
                pairs.push((Arc::from(key.as_str()), value));
            }
            let params = Params::new(pairs).unwrap();
            assert_eq!(
                serde_json::to_string(&params).unwrap(),
                serde_json::to_string(&map).unwrap()
            );
            assert_eq!(params.len(), map.len());
            for key in alphabet {
                assert_eq!(params.get(key), map.get(key), "{key}");
            }
            let listed: Vec<(&str, &Json)> = params.iter().collect();
            let expected: Vec<(&str, &Json)> = map.iter().map(|(k, v)| (k.as_str(), v)).collect();
            assert_eq!(listed, expected);
        }
    }

    #[test]
    fn a_key_given_twice_is_named() {
        let pairs = vec![
            (Arc::from("b"), Json::from(1)),
            (Arc::from("a"), Json::from(2)),
            (Arc::from("b"), Json::from(3)),
        ];
        assert_eq!(Params::new(pairs).unwrap_err().as_ref(), "b");
    }
}
