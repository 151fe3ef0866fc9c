//! The registration of the dataset kinds: one line per kind at the bottom, which makes the
//! [`Dataset`] enum of validated datasets, the parsed entry [`KindSpec`] and their dispatch
//! (a kind's file and this line are all a new kind needs).

use super::super::context::{Ctx, SpecError};
use super::cost::{Cost, Sizes};
use ndarray::Array3;
use num_complex::Complex64;
use serde::Deserialize;
use std::path::PathBuf;

use super::kind::{DataError, DatasetKind, Materialised};

/// Makes [`Dataset`] and [`KindSpec`] from the registered kinds, and their dispatch.
macro_rules! register {
    ($($variant:ident($kind:ty),)+) => {
        /// A validated dataset, of one of the registered kinds.
        #[derive(Debug, Clone, PartialEq)]
        pub enum Dataset {
            $(
                #[doc = concat!("A `", stringify!($variant), "` dataset.")]
                $variant(Box<$kind>),
            )+
        }

        /// A dataset entry's kind and fields as written.
        #[derive(Debug, Clone, PartialEq)]
        pub enum KindSpec {
            $(
                #[doc = concat!("The fields of a `", stringify!($variant), "` dataset.")]
                $variant(Box<<$kind as DatasetKind>::Spec>),
            )+
        }

        /// Every kind's name, in registration order.
        pub const KIND_NAMES: &[&str] = &[$(<$kind as DatasetKind>::NAME,)+];

        /// Every field some kind takes (to tell a field of another kind from a typo).
        pub(crate) const KIND_FIELDS: &[&[&str]] = &[$(<$kind as DatasetKind>::FIELDS,)+];

        impl KindSpec {
            /// Parses the fields of kind `name` from `fields` (a map's remaining entries).
            pub(crate) fn parse<'de, D: serde::Deserializer<'de>>(
                name: &str,
                fields: D,
            ) -> Result<KindSpec, D::Error> {
                $(
                    if name == <$kind as DatasetKind>::NAME {
                        return <<$kind as DatasetKind>::Spec as Deserialize>::deserialize(fields)
                            .map(|s| KindSpec::$variant(Box::new(s)));
                    }
                )+
                Err(serde::de::Error::unknown_variant(name, KIND_NAMES))
            }

            /// The fields the kind `name` takes (`None`: no such kind).
            pub(crate) fn fields_of(name: &str) -> Option<&'static [&'static str]> {
                $(
                    if name == <$kind as DatasetKind>::NAME {
                        return Some(<$kind as DatasetKind>::FIELDS);
                    }
                )+
                None
            }

            /// The kind's name.
            pub fn name(&self) -> &'static str {
                match self { $(KindSpec::$variant(_) => <$kind as DatasetKind>::NAME,)+ }
            }

            /// The fields that apply to these values.
            pub fn applies(&self) -> &'static [&'static str] {
                match self { $(KindSpec::$variant(s) => <$kind as DatasetKind>::applies(s),)+ }
            }

            /// The field blamed for too few samples.
            pub(super) fn samples_field(&self) -> &'static str {
                match self {
                    $(KindSpec::$variant(_) => <$kind as DatasetKind>::SAMPLES_FIELD,)+
                }
            }

            /// The values as written, for serialisation.
            pub(crate) fn to_value(&self) -> serde_yaml_ng::Value {
                match self {
                    $(KindSpec::$variant(s) => {
                        serde_yaml_ng::to_value(s).expect("dataset fields serialise")
                    })+
                }
            }

            /// Validates the fields into a [`Dataset`].
            ///
            /// # Errors
            /// The kind's [`DatasetKind::check`] error.
            pub fn check(&self, ctx: &Ctx, at: &str) -> Result<Dataset, SpecError> {
                Ok(match self {
                    $(KindSpec::$variant(s) => {
                        Dataset::$variant(Box::new(<$kind as DatasetKind>::check(s, ctx, at)?))
                    })+
                })
            }
        }

        impl Dataset {
            /// The kind name used in specs and tables.
            pub fn kind(&self) -> &'static str {
                match self { $(Dataset::$variant(_) => <$kind as DatasetKind>::NAME,)+ }
            }
            /// See [`DatasetKind::shape`].
            pub fn shape(&self) -> (usize, usize, usize) {
                match self { $(Dataset::$variant(d) => d.shape(),)+ }
            }
            /// See [`DatasetKind::input_files`].
            pub fn input_files(&self) -> Vec<PathBuf> {
                match self { $(Dataset::$variant(d) => d.input_files(),)+ }
            }
            /// See [`DatasetKind::worth_sharing`].
            pub fn worth_sharing(&self) -> bool {
                match self { $(Dataset::$variant(d) => d.worth_sharing(),)+ }
            }
            /// See [`DatasetKind::redrawable`].
            pub fn redrawable(&self) -> Option<bool> {
                match self { $(Dataset::$variant(d) => d.redrawable(),)+ }
            }
            /// See [`DatasetKind::kspace_grid`].
            pub fn kspace_grid(&self) -> Option<(usize, usize)> {
                match self { $(Dataset::$variant(d) => d.kspace_grid(),)+ }
            }
            /// See [`DatasetKind::known_filter`].
            pub fn known_filter(&self) -> Option<usize> {
                match self { $(Dataset::$variant(d) => d.known_filter(),)+ }
            }
            /// See [`DatasetKind::sizes`].
            pub fn sizes(&self, at: &str, s: &mut Sizes) {
                match self { $(Dataset::$variant(d) => d.sizes(at, s),)+ }
            }
            /// See [`DatasetKind::cost`].
            pub fn cost(&self) -> Cost {
                match self { $(Dataset::$variant(d) => d.cost(),)+ }
            }
            /// See [`DatasetKind::redraw_cost`].
            pub fn redraw_cost(&self, samples: usize) -> Cost {
                match self { $(Dataset::$variant(d) => d.redraw_cost(samples),)+ }
            }
            /// See [`DatasetKind::materialise`].
            ///
            /// # Errors
            /// As there.
            pub fn materialise(&self, data_seed: u64) -> Result<Materialised, DataError> {
                match self { $(Dataset::$variant(d) => d.materialise(data_seed),)+ }
            }
            /// See [`DatasetKind::metadata`].
            pub fn metadata(&self) -> Option<serde_json::Value> {
                match self { $(Dataset::$variant(d) => d.metadata(),)+ }
            }
            /// See [`DatasetKind::redraw`].
            pub fn redraw(
                &self,
                samples: usize,
                seed: u64,
                data: &Materialised,
            ) -> Option<Result<Array3<Complex64>, DataError>> {
                match self { $(Dataset::$variant(d) => d.redraw(samples, seed, data),)+ }
            }
        }
    };
}

// The registration: one line per kind.
register! {
    FilteredNoise(super::filtered_noise::FilteredNoise),
    Npy(super::npy::NpyDataset),
    Mat(super::mat::MatDataset),
    Raw(super::raw::RawDataset),
    Netcdf(super::netcdf::NetcdfDataset),
    Vegetation(super::vegetation::VegetationDataset),
    Kspace(super::kspace::KspaceDataset),
    Uavsar(super::uavsar::UavsarDataset),
    Hdf5(super::hdf5::Hdf5Dataset),
    Geotiff(super::geotiff::GeotiffDataset),
    Sicd(super::sicd::SicdDataset),
}
