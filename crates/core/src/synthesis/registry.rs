//! The registry of synthesis methods: the list below (one line each: the [`Method`] variant
//! and the type implementing [`SynthesisMethod`]), which [`methods!`] turns into the
//! [`Method`] enum with its names, the [`Model`] enum with one variant per method, and the
//! matches that hand each call to the method's type; then a method's name read and written
//! (`FromStr`, `Display`, serde) from the names the types declare.

use super::method::{
    ArrayStore, Cost, CostSize, Layout, Moments, Needs, Recorded, SynthesisMethod,
};
use super::options::{FitError, FitOptions};
use super::{fourth_order, full_covariance, method1, method2, uncorrelated};
use crate::stats::analysis::Analysis;
use ndarray::ArrayView3;
use num_complex::{Complex32, Complex64};
use std::fmt;

/// Declares the methods: `Variant(Type),` per method, each with its doc comment.
macro_rules! methods {
    ($($(#[$doc:meta])* $variant:ident($ty:ty),)*) => {
        /// Synthesis methods: each one file implementing [`SynthesisMethod`], listed once in
        /// the registry of this module.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum Method {
            $($(#[$doc])* $variant,)*
        }

        impl Method {
            /// Every method, in the registry's order.
            pub const ALL: &'static [Method] = &[$(Method::$variant,)*];

            /// Their names, in the same order.
            pub const NAMES: &'static [&'static str] =
                &[$(<$ty as SynthesisMethod>::NAME,)*];

            /// The name used in specs, job ids and tables.
            pub fn as_str(self) -> &'static str {
                match self {
                    $(Method::$variant => <$ty as SynthesisMethod>::NAME,)*
                }
            }

            /// What its fit reads.
            pub fn needs(self) -> Needs {
                match self {
                    $(Method::$variant => <$ty as SynthesisMethod>::needs(),)*
                }
            }

            /// The per-pixel model order a KL model-order test reads it as, if any.
            pub fn model_order(self) -> Option<i64> {
                match self {
                    $(Method::$variant => <$ty as SynthesisMethod>::model_order(),)*
                }
            }

            /// The arrays its model folder holds besides the moments.
            pub fn files(self) -> &'static [&'static str] {
                match self {
                    $(Method::$variant => <$ty as SynthesisMethod>::FILES,)*
                }
            }

            /// What fitting it and generating from it cost.
            pub fn cost(self, size: &CostSize) -> Cost {
                match self {
                    $(Method::$variant => <$ty as SynthesisMethod>::cost(size),)*
                }
            }

            /// Checks the sizes a model folder of it records, before any array is read.
            ///
            /// # Errors
            /// If they cannot belong to a model of it.
            pub fn check(self, layout: &Layout) -> anyhow::Result<()> {
                match self {
                    $(Method::$variant => <$ty as SynthesisMethod>::check(layout),)*
                }
            }

            /// Reads a model of it back from `store`.
            ///
            /// # Errors
            /// If an array is missing, mis-shaped or holds a value the model cannot hold.
            pub fn load(
                self,
                moments: Moments,
                layout: &Layout,
                store: &impl ArrayStore,
            ) -> anyhow::Result<Model> {
                Ok(match self {
                    $(Method::$variant => {
                        Model::$variant(<$ty as SynthesisMethod>::load(moments, layout, store)?)
                    })*
                })
            }

            /// Fits a model of it with `moments` (see [`SynthesisMethod::fit`]).
            pub(super) fn fit_moments(
                self,
                moments: Moments,
                analysis: &Analysis,
                stack: Option<ArrayView3<Complex64>>,
                opts: &FitOptions,
            ) -> Result<Model, FitError> {
                Ok(match self {
                    $(Method::$variant => Model::$variant(
                        <$ty as SynthesisMethod>::fit(moments, analysis, stack, opts)?,
                    ),)*
                })
            }
        }

        /// A fitted model, ready to generate samples: one variant per method.
        #[derive(Debug, Clone)]
        pub enum Model {
            $($(#[$doc])* $variant($ty),)*
        }

        impl Model {
            /// Its method.
            pub fn method(&self) -> Method {
                match self {
                    $(Model::$variant(_) => Method::$variant,)*
                }
            }

            /// Its per-pixel moments and sample format.
            pub fn moments(&self) -> &Moments {
                match self {
                    $(Model::$variant(m) => m.moments(),)*
                }
            }

            /// Draws later samples in sample format `format` (1 or 2).
            pub fn set_sample_format(&mut self, format: u32) {
                match self {
                    $(Model::$variant(m) => m.set_sample_format(format),)*
                }
            }

            /// What `model.json` records of it.
            pub fn recorded(&self) -> Recorded {
                match self {
                    $(Model::$variant(m) => m.recorded(),)*
                }
            }

            /// Writes its method's arrays (the moments are the caller's).
            ///
            /// # Errors
            /// If an array cannot be written.
            pub fn save(&self, store: &mut impl ArrayStore) -> anyhow::Result<()> {
                match self {
                    $(Model::$variant(m) => m.save(store),)*
                }
            }

            /// Samples `first ..` into `out` as complex128 (whole samples).
            pub(super) fn dispatch_c128(&self, seed: u64, first: usize, out: &mut [Complex64]) {
                match self {
                    $(Model::$variant(m) => m.generate_c128(seed, first, out),)*
                }
            }

            /// Samples `first ..` into `out` as complex64 (whole samples).
            pub(super) fn dispatch_c64(&self, seed: u64, first: usize, out: &mut [Complex32]) {
                match self {
                    $(Model::$variant(m) => m.generate_c64(seed, first, out),)*
                }
            }
        }
    };
}

methods! {
    /// Spatially varying exponential filter (4.2).
    Method1(method1::Exponential),
    /// Spatially varying dyadic filter (4.3).
    Method2(method2::Dyadic),
    /// Exact low-rank Gaussian sampler with the sample covariance (4.1).
    FullCovariance(full_covariance::FullCovariance),
    /// Mean and variance only (5.3.8.2 item 5).
    Uncorrelated(uncorrelated::Uncorrelated),
    /// Per pixel and component: mean, variance, skewness and excess kurtosis by Fleishman's
    /// power method, no spatial correlation (the fourth-order model of 3.2).
    FourthOrder(fourth_order::FourthOrder),
}

/// A name that is not a method's.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown method {name:?}: {listed}", name = .0, listed = Method::listed())]
pub struct UnknownMethod(pub String);

impl Method {
    /// The names as a sentence lists them: `method1, method2, ... or fourth_order`.
    pub fn listed() -> String {
        match Method::NAMES.split_last() {
            Some((last, [])) => last.to_string(),
            Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
            None => String::new(),
        }
    }
}

impl std::str::FromStr for Method {
    type Err = UnknownMethod;

    fn from_str(s: &str) -> Result<Method, UnknownMethod> {
        Method::ALL
            .iter()
            .copied()
            .find(|m| m.as_str() == s)
            .ok_or_else(|| UnknownMethod(s.to_string()))
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl serde::Serialize for Method {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

impl<'de> serde::Deserialize<'de> for Method {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Method, D::Error> {
        /// Reads a method's name as serde's derive would (the same message for another).
        struct Name;
        impl serde::de::Visitor<'_> for Name {
            type Value = Method;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a synthesis method's name")
            }

            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Method, E> {
                v.parse().map_err(|_| E::unknown_variant(v, Method::NAMES))
            }
        }
        d.deserialize_str(Name)
    }
}
