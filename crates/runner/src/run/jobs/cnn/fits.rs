//! The synthesis models the CNN trainings fit, shared between the trainings of one process.
//! Every training of one class, normalisation and method fits the same model to the same fit
//! part (the trainings of other sizes and repeats differ only in what they draw from it), so a
//! run of `cnn_classification.yaml` fitted each model 8 times; now once.
//!
//! Process-wide state: a memo of at most [`KEEP`] models, keyed by the XXH3-128 of the fit
//! part's values and shape, the method and the fit options, so a model is reused only for the
//! same numbers and settings, whatever job, spec or thread asks. Fitting is a pure function of
//! those, so a reused model is the one a fresh fit gives: the tables are the same with or
//! without the memo (`tests::a_shared_fit_is_the_fresh_fit`). The oldest entry goes first. No
//! lock is held while fitting (a fit runs on the pool, which may hand this thread another
//! training that asks for the same model): two trainings that start together may both fit it.

use crate::apps::cnn::classification::fit_model;
use crate::synthesis::{FitOptions, Method, Model};
use anyhow::Result;
use ndarray::ArrayView3;
use num_complex::Complex64;
use std::sync::{Arc, Mutex, OnceLock};

/// Models kept (a classification section fits classes x normalisations x methods of them:
/// 32 for the shipped spec).
const KEEP: usize = 64;

/// Fitted models with their keys, oldest first.
type Memo = Mutex<Vec<(u128, Arc<Model>)>>;

/// The memo.
fn memo() -> &'static Memo {
    static MEMO: OnceLock<Memo> = OnceLock::new();
    MEMO.get_or_init(Default::default)
}

/// What identifies a fit: its settings, the shape and every value of the fit part.
fn key(fit_part: ArrayView3<Complex64>, method: Method, opts: FitOptions) -> u128 {
    let mut bytes = format!("{}/{:?}/{:?}/", method.as_str(), opts, fit_part.dim()).into_bytes();
    bytes.reserve(16 * fit_part.len());
    for z in fit_part.iter() {
        bytes.extend_from_slice(&z.re.to_le_bytes());
        bytes.extend_from_slice(&z.im.to_le_bytes());
    }
    xxhash_rust::xxh3::xxh3_128(&bytes)
}

/// `method` fitted to `fit_part` with `opts` ([`fit_model`]), or the model an earlier training
/// of this process fitted to the same values with the same settings.
///
/// # Errors
/// As [`fit_model`] (a failed fit is not kept).
pub fn fitted(
    fit_part: ArrayView3<Complex64>,
    method: Method,
    opts: FitOptions,
) -> Result<Arc<Model>> {
    let key = key(fit_part, method, opts);
    let lock = || memo().lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, model)) = lock().iter().find(|(k, _)| *k == key) {
        return Ok(model.clone());
    }
    let model = Arc::new(fit_model(fit_part, method, opts)?);
    let mut memo = lock();
    if !memo.iter().any(|(k, _)| *k == key) {
        if memo.len() >= KEEP {
            memo.remove(0);
        }
        memo.push((key, model.clone()));
    }
    Ok(model)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array3;
    use rand::{RngExt, SeedableRng};

    fn stack(seed: u64) -> Array3<Complex64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        Array3::from_shape_simple_fn((12, 16, 16), || {
            Complex64::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5)
        })
    }

    /// A model from the memo generates exactly what a fresh fit's model generates, for
    /// Method 1, Method 2 and full covariance; other values or settings are fitted anew.
    #[test]
    fn a_shared_fit_is_the_fresh_fit() {
        let opts = FitOptions {
            half_width: 3,
            levels: 2,
            ..FitOptions::default()
        };
        for (seed, method) in [
            (1, Method::Method1),
            (2, Method::Method2),
            (3, Method::FullCovariance),
        ] {
            let s = stack(seed);
            let first = fitted(s.view(), method, opts).unwrap();
            let again = fitted(s.view(), method, opts).unwrap();
            assert!(Arc::ptr_eq(&first, &again), "{method:?}: fitted again");
            let fresh = fit_model(s.view(), method, opts).unwrap();
            let (a, b) = (
                again.try_generate_c64(seed, 0, 5).unwrap(),
                fresh.try_generate_c64(seed, 0, 5).unwrap(),
            );
            assert!(
                a.iter()
                    .zip(b.iter())
                    .all(|(x, y)| x.re.to_bits() == y.re.to_bits()
                        && x.im.to_bits() == y.im.to_bits()),
                "{method:?}: the shared model draws other samples"
            );
            let mut other = s.clone();
            other[[0, 0, 0]].re += 1e-12;
            assert!(!Arc::ptr_eq(
                &first,
                &fitted(other.view(), method, opts).unwrap()
            ));
            let wider = FitOptions {
                half_width: 4,
                ..opts
            };
            assert!(!Arc::ptr_eq(
                &first,
                &fitted(s.view(), method, wider).unwrap()
            ));
        }
    }
}
