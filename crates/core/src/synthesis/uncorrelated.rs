//! The uncorrelated model (5.3.8.2 item 5): the per-pixel mean and variance only, every pixel
//! an independent complex normal; the control that tells variance features from correlation
//! features.

use super::kernel::Scratch;
use super::method::{
    ArrayStore, Cost, CostSize, Layout, Moments, Needs, Recorded, SynthesisMethod,
};
use super::options::{FitError, FitOptions};
use super::sampling::{self, OneAtATime};
use crate::stats::analysis::Analysis;
use ndarray::ArrayView3;
use num_complex::{Complex32, Complex64};
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};

/// A fitted uncorrelated model.
#[derive(Debug, Clone)]
pub struct Uncorrelated {
    /// The per-pixel moments.
    pub moments: Moments,
}

impl OneAtATime for Uncorrelated {
    /// Sample `index` in format 1: per pixel two ChaCha20 normals scaled by `std / sqrt 2`.
    fn sample_f64(&self, seed: u64, index: usize, out: &mut [Complex64]) {
        let w = self.moments.mean.dim().1;
        let mut rng = ChaCha20Rng::seed_from_u64(seed);
        rng.set_stream(index as u64);
        let scale = std::f64::consts::FRAC_1_SQRT_2;
        for (p, x) in out.iter_mut().enumerate() {
            let (re, im): (f64, f64) = (
                StandardNormal.sample(&mut rng),
                StandardNormal.sample(&mut rng),
            );
            let s = self.moments.std[[p / w, p % w]] * scale;
            *x = self.moments.mean[[p / w, p % w]] + Complex64::new(re * s, im * s);
        }
    }

    /// Sample `index` in format 2: the stream's complex normals scaled by `std`, in `f32`.
    fn sample_f32(&self, seed: u64, index: usize, scratch: &mut Scratch, out: &mut [Complex32]) {
        let (re, im) = scratch.normals(seed, index, out.len());
        let (mean, std) = (
            self.moments.mean.as_slice().expect("standard layout"),
            self.moments.std.as_slice().expect("standard layout"),
        );
        for (p, x) in out.iter_mut().enumerate() {
            let s = std[p] as f32;
            *x = Complex32::new(mean[p].re as f32 + re[p] * s, mean[p].im as f32 + im[p] * s);
        }
    }
}

impl SynthesisMethod for Uncorrelated {
    const NAME: &'static str = "uncorrelated";
    const FILES: &'static [&'static str] = &[];

    fn needs() -> Needs {
        Needs {
            levels: false,
            stack: false,
            half_width: false,
        }
    }

    fn model_order() -> Option<i64> {
        Some(2)
    }

    fn fit(
        moments: Moments,
        _analysis: &Analysis,
        _stack: Option<ArrayView3<Complex64>>,
        _opts: &FitOptions,
    ) -> Result<Self, FitError> {
        Ok(Uncorrelated { moments })
    }

    fn moments(&self) -> &Moments {
        &self.moments
    }

    fn set_sample_format(&mut self, format: u32) {
        self.moments.sample_format = format;
    }

    fn generate_c128(&self, seed: u64, first: usize, out: &mut [Complex64]) {
        sampling::generate_c128(self, &self.moments, seed, first, out)
    }

    fn generate_c64(&self, seed: u64, first: usize, out: &mut [Complex32]) {
        sampling::generate_c64(self, &self.moments, seed, first, out)
    }

    fn recorded(&self) -> Recorded {
        Recorded::default()
    }

    fn save(&self, _store: &mut impl ArrayStore) -> anyhow::Result<()> {
        Ok(())
    }

    fn check(_layout: &Layout) -> anyhow::Result<()> {
        Ok(())
    }

    fn load(moments: Moments, _layout: &Layout, _store: &impl ArrayStore) -> anyhow::Result<Self> {
        Ok(Uncorrelated { moments })
    }

    fn cost(size: &CostSize) -> Cost {
        let p = size.pixels;
        Cost {
            model_bytes: 24.0 * p,
            fit_flops: 4.0 * size.fitted * p,
            generate_flops: 20.0 * size.generated * p,
        }
    }
}
