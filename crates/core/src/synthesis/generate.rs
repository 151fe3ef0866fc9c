//! Generating samples from a fitted [`Model`]: the public entry points (complex128 or
//! complex64, into a new array or a buffer the caller owns), each handing a run of
//! consecutive samples to the model's method. Sample `s` always comes from stream `s` of the seed, in
//! the model's sample format (see [`super`]), so output never depends on threads or batches.

use super::registry::Model;
use crate::alloc::{try_zeros, AllocError};
use ndarray::Array3;
use num_complex::{Complex32, Complex64};

impl Model {
    /// Image size `(H, W)`.
    pub fn shape(&self) -> (usize, usize) {
        self.moments().mean.dim()
    }

    /// Writes sample `index` of the generation seeded by `seed` into `out` (`H * W`), as
    /// [`Model::generate`] makes it.
    ///
    /// # Panics
    /// If the model's sample format is not one of [`super::SAMPLE_FORMATS`].
    pub fn sample_into(&self, seed: u64, index: usize, out: &mut [Complex64]) {
        self.generate_c128_into(seed, index, out);
    }

    /// Generates samples `first .. first + count` as complex64 (the format of saved samples),
    /// in parallel on the caller's rayon pool.
    ///
    /// # Panics
    /// If the samples do not fit in memory (see [`Model::try_generate_c64`]).
    pub fn generate_c64(&self, seed: u64, first: usize, count: usize) -> Array3<Complex32> {
        self.try_generate_c64(seed, first, count)
            .unwrap_or_else(|e| panic!("{e}"))
    }

    /// [`Model::generate_c64`] with the output allocated fallibly.
    ///
    /// # Errors
    /// [`AllocError`] if the `count x H x W` complex64 samples do not fit in memory.
    pub fn try_generate_c64(
        &self,
        seed: u64,
        first: usize,
        count: usize,
    ) -> Result<Array3<Complex32>, AllocError> {
        let (h, w) = self.shape();
        let mut out = try_zeros((count, h, w), "the generated samples")?;
        self.generate_c64_into(seed, first, out.as_slice_mut().expect("standard layout"));
        Ok(out)
    }

    /// Writes samples `first ..` (as many as `out` holds, `H * W` each) as complex64 into
    /// `out`, in parallel on the caller's rayon pool: [`Model::generate_c64`] into a buffer the
    /// caller owns (and may reuse).
    ///
    /// # Panics
    /// If `out` does not hold a whole number of samples.
    pub fn generate_c64_into(&self, seed: u64, first: usize, out: &mut [Complex32]) {
        let (h, w) = self.shape();
        assert_eq!(out.len() % (h * w).max(1), 0, "whole samples");
        self.dispatch_c64(seed, first, out);
    }

    /// Generates samples `first .. first + count` of the generation seeded by `seed`, in
    /// parallel on the caller's rayon pool.
    ///
    /// # Panics
    /// If the samples do not fit in memory (see [`Model::try_generate`]).
    pub fn generate(&self, seed: u64, first: usize, count: usize) -> Array3<Complex64> {
        self.try_generate(seed, first, count)
            .unwrap_or_else(|e| panic!("{e}"))
    }

    /// [`Model::generate`] with the output allocated fallibly.
    ///
    /// # Errors
    /// [`AllocError`] if the `count x H x W` complex128 samples do not fit in memory.
    pub fn try_generate(
        &self,
        seed: u64,
        first: usize,
        count: usize,
    ) -> Result<Array3<Complex64>, AllocError> {
        let (h, w) = self.shape();
        let mut out = try_zeros((count, h, w), "the generated samples")?;
        self.generate_c128_into(seed, first, out.as_slice_mut().expect("standard layout"));
        Ok(out)
    }

    /// Writes samples `first ..` (as many as `out` holds) as complex128 into `out`.
    fn generate_c128_into(&self, seed: u64, first: usize, out: &mut [Complex64]) {
        let (h, w) = self.shape();
        assert_eq!(out.len() % (h * w).max(1), 0, "whole samples");
        self.dispatch_c128(seed, first, out);
    }
}
