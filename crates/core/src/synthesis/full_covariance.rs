//! The full covariance baseline (4.1): the Gaussian with the sample mean and covariance,
//! sampled in `O(N P)` without forming the `P x P` matrix: a sample is the mean plus
//! `sum_k z_k d_k` over the fitted samples' deviations `d_k` (centred, divided by `sqrt(N)`)
//! with `N` independent normals `z_k`, computed as a batched GEMM ([`crate::stats::lowrank`]).

use super::method::{
    ArrayStore, Cost, CostSize, Layout, Moments, Needs, Recorded, SynthesisMethod,
};
use super::options::{FitError, FitOptions};
use crate::stats::analysis::Analysis;
use crate::stats::lowrank::Panels;
use ndarray::{Array3, ArrayView3};
use num_complex::{Complex32, Complex64};
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use std::sync::OnceLock;

/// Samples per task of the sampler: each deviation panel serves this many samples while it
/// is in L1.
const BATCH: usize = 48;

/// Bytes of a complex128.
const C128: f64 = 16.0;

/// A fitted full-covariance model.
#[derive(Debug, Clone)]
pub struct FullCovariance {
    /// The per-pixel moments.
    pub moments: Moments,
    /// The centred samples scaled by `1/sqrt(N)`, `[N, H, W]`.
    pub deviations: Array3<Complex64>,
    /// `deviations` packed for the sampler's kernel, made on first use.
    packed: OnceLock<Panels>,
}

impl FullCovariance {
    /// The model of `deviations` with `moments`.
    fn new(moments: Moments, deviations: Array3<Complex64>) -> Self {
        FullCovariance {
            moments,
            deviations,
            packed: OnceLock::new(),
        }
    }

    /// The deviation sums `sum_k z_k d_k` of samples `first .. first + count` into `acc`
    /// (`count x 2P` f32, real and imaginary parts interleaved), `z_k` the sample's normals
    /// drawn in order from its stream (see [`crate::stats::lowrank`] for the arithmetic, which
    /// does not depend on `count`), then `finish` on each finished run of values.
    fn sums(
        &self,
        seed: u64,
        first: usize,
        count: usize,
        acc: &mut [f32],
        finish: impl Fn(usize, &mut [f32]),
    ) {
        let panels = self
            .packed
            .get_or_init(|| Panels::new(self.deviations.view()));
        let n = panels.n();
        let mut z = vec![0.0f32; count * n];
        let (mut words, mut re, mut im) = (
            Vec::new(),
            vec![0.0; n.div_ceil(2)],
            vec![0.0; n.div_ceil(2)],
        );
        for (c, zc) in z.chunks_exact_mut(n.max(1)).enumerate() {
            if self.moments.sample_format == 1 {
                let mut rng = ChaCha20Rng::seed_from_u64(seed);
                rng.set_stream((first + c) as u64);
                for v in zc {
                    let x: f64 = StandardNormal.sample(&mut rng);
                    *v = x as f32;
                }
            } else {
                // Format 2: the real and imaginary parts of the stream's complex normals, in
                // order, scaled to unit variance.
                crate::seeds::normal::complex_normals(
                    seed,
                    (first + c) as u64,
                    &mut words,
                    &mut re,
                    &mut im,
                );
                for (m, v) in zc.iter_mut().enumerate() {
                    let part = if m % 2 == 0 { re[m / 2] } else { im[m / 2] };
                    *v = part * std::f32::consts::SQRT_2;
                }
            }
        }
        crate::stats::lowrank::combine_then(panels, &z, count, acc, finish);
    }

    /// Samples `first ..` (as many as `out` holds, `H * W` each) in complex128,
    /// the mean plus the f32 deviation sums.
    fn c128(&self, seed: u64, first: usize, out: &mut [Complex64]) {
        let p = self.moments.mean.len();
        let mut acc = vec![0.0f32; 2 * out.len()];
        self.sums(seed, first, out.len() / p, &mut acc, |_, _| {});
        let mean = self.moments.mean.as_slice().expect("standard layout");
        for (i, (x, a)) in out.iter_mut().zip(acc.chunks_exact(2)).enumerate() {
            *x = mean[i % p] + Complex64::new(f64::from(a[0]), f64::from(a[1]));
        }
    }

    /// Samples `first ..` (as many as `out` holds, `H * W` each) as complex64,
    /// the mean plus the f32 deviation sums added in f64 and rounded once.
    fn c64(&self, seed: u64, first: usize, out: &mut [Complex32]) {
        let mean: &[f64] =
            bytemuck::cast_slice(self.moments.mean.as_slice().expect("standard layout"));
        let flat: &mut [f32] = bytemuck::cast_slice_mut(out);
        let count = flat.len() / mean.len();
        self.sums(seed, first, count, flat, |c0, values| {
            for (x, mu) in values.iter_mut().zip(&mean[c0..]) {
                *x = (mu + f64::from(*x)) as f32;
            }
        });
    }
}

impl SynthesisMethod for FullCovariance {
    const NAME: &'static str = "full_covariance";
    const FILES: &'static [&'static str] = &["deviations.npy"];

    fn needs() -> Needs {
        Needs {
            levels: false,
            stack: true,
            half_width: false,
        }
    }

    fn model_order() -> Option<i64> {
        None
    }

    fn fit(
        moments: Moments,
        _analysis: &Analysis,
        stack: Option<ArrayView3<Complex64>>,
        _opts: &FitOptions,
    ) -> Result<Self, FitError> {
        let stack = stack.expect("full_covariance is fitted from the stack itself");
        let n = stack.dim().0;
        let scale = 1.0 / (n as f64).sqrt();
        let mu = &moments.mean;
        let mut dev: Array3<Complex64> =
            crate::alloc::try_zeros(stack.dim(), "the full-covariance deviations")?;
        ndarray::Zip::indexed(&mut dev)
            .and(&stack)
            .for_each(|(_, i, j), d, &x| *d = (x - mu[[i, j]]) * scale);
        Ok(FullCovariance::new(moments, dev))
    }

    fn moments(&self) -> &Moments {
        &self.moments
    }

    fn set_sample_format(&mut self, format: u32) {
        self.moments.sample_format = format;
    }

    fn generate_c128(&self, seed: u64, first: usize, out: &mut [Complex64]) {
        let p = self.moments.mean.len();
        out.par_chunks_mut(BATCH * p)
            .enumerate()
            .for_each(|(b, block)| self.c128(seed, first + b * BATCH, block));
    }

    fn generate_c64(&self, seed: u64, first: usize, out: &mut [Complex32]) {
        let p = self.moments.mean.len();
        out.par_chunks_mut(BATCH * p)
            .enumerate()
            .for_each(|(b, block)| self.c64(seed, first + b * BATCH, block));
    }

    fn recorded(&self) -> Recorded {
        Recorded::default()
    }

    fn save(&self, store: &mut impl ArrayStore) -> anyhow::Result<()> {
        store.write("deviations.npy", &self.deviations)
    }

    fn check(_layout: &Layout) -> anyhow::Result<()> {
        Ok(())
    }

    fn load(moments: Moments, layout: &Layout, store: &impl ArrayStore) -> anyhow::Result<Self> {
        let deviations = store.read(
            "deviations.npy",
            (
                vec![layout.samples_fitted, layout.height, layout.width],
                "samples_fitted, height and width of model.json",
            ),
            (&|z: &Complex64| z.is_finite(), "deviations must be finite"),
        )?;
        Ok(FullCovariance::new(moments, deviations))
    }

    fn cost(size: &CostSize) -> Cost {
        let (n, p) = (size.fitted, size.pixels);
        Cost {
            // The centred samples, and their f32 packing (16-column panels) for the sampler.
            model_bytes: 24.0 * p + C128 * n * p + 4.0 * n * (2.0 * p / 16.0).ceil() * 16.0,
            fit_flops: 4.0 * n * p,
            generate_flops: 4.0 * n * size.generated * p,
        }
    }
}
