//! Generating samples from a fitted model: sample `s` from stream `s` of the seed (filter
//! methods: a white seed filtered and scaled; full covariance: the low-rank GEMM sampler;
//! fourth order: the Fleishman transform), in batches and in parallel, in the model's sample
//! format (1: ChaCha20 and `f64`; 2: ChaCha8, Box-Muller and `f32`, see the module
//! documentation of [`super`]).

use super::kernel::{FastFilter, Scratch};
use super::*;
use crate::alloc::{try_zeros, AllocError};
use num_complex::Complex32;

impl Model {
    /// Image size `(H, W)`.
    pub fn shape(&self) -> (usize, usize) {
        self.mean.dim()
    }

    /// Writes sample `index` of the generation seeded by `seed` into `out` (`H * W`).
    ///
    /// # Panics
    /// If the model's sample format is not one of [`SAMPLE_FORMATS`].
    pub fn sample_into(&self, seed: u64, index: usize, out: &mut [Complex64]) {
        if self.sample_format != 1 {
            let mut buf = vec![Complex32::new(0.0, 0.0); out.len()];
            self.sample_c32(seed, index, &mut Scratch::default(), &mut buf);
            for (o, x) in out.iter_mut().zip(&buf) {
                *o = Complex64::new(f64::from(x.re), f64::from(x.im));
            }
            return;
        }
        let (h, w) = self.shape();
        let mut rng = ChaCha20Rng::seed_from_u64(seed);
        rng.set_stream(index as u64);
        match (&self.filter, &self.deviations) {
            (Some(f), _) => {
                let k = f.bank.half_width;
                let white = crate::seeds::white_seed(seed, index, h + 2 * k, w + 2 * k);
                filter_seed(&f.bank, white.view(), out);
                let (mean, std) = (
                    self.mean.as_slice().expect("standard layout"),
                    self.std.as_slice().expect("standard layout"),
                );
                for (((x, sd), mu), s) in out.iter_mut().zip(f.bank.output_sds()).zip(mean).zip(std)
                {
                    *x = mu + *x * (s / sd);
                }
            }
            (None, Some(_)) => self.full_covariance_c128(seed, index, out),
            (None, None) if self.fourth.is_some() => {
                let f = self.fourth.as_ref().expect("checked");
                for (p, x) in out.iter_mut().enumerate() {
                    let (i, j) = (p / w, p % w);
                    let part = |comp: usize, z: f64| {
                        let coef = [0, 1, 2, 3].map(|k| f.coefficients[[comp, k, i, j]]);
                        f.component_sd[[comp, i, j]] * crate::stats::fleishman::transform(&coef, z)
                    };
                    let (zr, zi): (f64, f64) = (
                        StandardNormal.sample(&mut rng),
                        StandardNormal.sample(&mut rng),
                    );
                    *x = self.mean[[i, j]] + Complex64::new(part(0, zr), part(1, zi));
                }
            }
            (None, None) => {
                let scale = std::f64::consts::FRAC_1_SQRT_2;
                for (p, x) in out.iter_mut().enumerate() {
                    let (re, im): (f64, f64) = (
                        StandardNormal.sample(&mut rng),
                        StandardNormal.sample(&mut rng),
                    );
                    let s = self.std[[p / w, p % w]] * scale;
                    *x = self.mean[[p / w, p % w]] + Complex64::new(re * s, im * s);
                }
            }
        }
    }

    /// Full covariance: the deviation sums `sum_k z_k d_k` of samples `first .. first + count`
    /// into `acc` (`count x 2P` f32, real and imaginary parts interleaved), `z_k` the sample's
    /// normals drawn in order from its ChaCha20 stream (see [`crate::stats::lowrank`] for the
    /// arithmetic, which does not depend on `count`).
    fn full_covariance_sums(
        &self,
        seed: u64,
        first: usize,
        count: usize,
        acc: &mut [f32],
        finish: impl Fn(usize, &mut [f32]),
    ) {
        let dev = self.deviations.as_ref().expect("a full-covariance model");
        let panels = self
            .packed
            .get_or_init(|| crate::stats::lowrank::Panels::new(dev.view()));
        let n = panels.n();
        let mut z = vec![0.0f32; count * n];
        let (mut words, mut re, mut im) = (
            Vec::new(),
            vec![0.0; n.div_ceil(2)],
            vec![0.0; n.div_ceil(2)],
        );
        for (c, zc) in z.chunks_exact_mut(n.max(1)).enumerate() {
            if self.sample_format == 1 {
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

    /// Full covariance: samples `first ..` (as many as `out` holds, `H * W` each) in complex128,
    /// the mean plus the f32 deviation sums.
    fn full_covariance_c128(&self, seed: u64, first: usize, out: &mut [Complex64]) {
        let p = self.mean.len();
        let mut acc = vec![0.0f32; 2 * out.len()];
        self.full_covariance_sums(seed, first, out.len() / p, &mut acc, |_, _| {});
        let mean = self.mean.as_slice().expect("standard layout");
        for (i, (x, a)) in out.iter_mut().zip(acc.chunks_exact(2)).enumerate() {
            *x = mean[i % p] + Complex64::new(f64::from(a[0]), f64::from(a[1]));
        }
    }

    /// Full covariance: samples `first ..` (as many as `out` holds, `H * W` each) as complex64,
    /// the mean plus the f32 deviation sums added in f64 and rounded once.
    fn full_covariance_c64(&self, seed: u64, first: usize, out: &mut [Complex32]) {
        let mean: &[f64] = bytemuck::cast_slice(self.mean.as_slice().expect("standard layout"));
        let flat: &mut [f32] = bytemuck::cast_slice_mut(out);
        let count = flat.len() / mean.len();
        self.full_covariance_sums(seed, first, count, flat, |c0, values| {
            for (x, mu) in values.iter_mut().zip(&mean[c0..]) {
                *x = (mu + f64::from(*x)) as f32;
            }
        });
    }

    /// Methods 1 and 2: the bank prepared for the format-2 kernel.
    fn fast(&self) -> &FastFilter {
        self.fast.get_or_init(|| {
            let f = self.filter.as_ref().expect("a filter model");
            FastFilter::new(&f.bank, &self.mean, &self.std)
        })
    }

    /// Sample `index` in format 2 (every method but full covariance, which is sampled in
    /// batches) into `out` (`H * W`).
    ///
    /// # Panics
    /// If the model's sample format is not 2.
    pub fn sample_c32(
        &self,
        seed: u64,
        index: usize,
        scratch: &mut Scratch,
        out: &mut [Complex32],
    ) {
        assert_eq!(
            self.sample_format, 2,
            "sample format {} is not generated by this version",
            self.sample_format
        );
        if self.filter.is_some() {
            return self.fast().sample(seed, index, scratch, out);
        }
        if self.deviations.is_some() {
            return self.full_covariance_c64(seed, index, out);
        }
        let w = self.shape().1;
        let (re, im) = scratch.normals(seed, index, out.len());
        let (mean, std) = (
            self.mean.as_slice().expect("standard layout"),
            self.std.as_slice().expect("standard layout"),
        );
        match &self.fourth {
            Some(f) => {
                // Per pixel and component, in f32: the mean plus the component's standard
                // deviation times Fleishman's cubic of the unit normal `sqrt 2` times the part.
                let p = out.len();
                let c = self.fourth_f32.get_or_init(|| {
                    let mut c = vec![0.0f32; 2 * 5 * p];
                    for comp in 0..2 {
                        for (q, m) in mean.iter().enumerate() {
                            let (i, j) = (q / w, q % w);
                            let sd = f.component_sd[[comp, i, j]];
                            c[(comp * 5) * p + q] = (if comp == 0 { m.re } else { m.im }) as f32;
                            for k in 0..4 {
                                c[(comp * 5 + 1 + k) * p + q] =
                                    (sd * f.coefficients[[comp, k, i, j]]) as f32;
                            }
                        }
                    }
                    c
                });
                let sqrt2 = std::f32::consts::SQRT_2;
                let part = |comp: usize, q: usize, z: f32| {
                    let at = |k: usize| c[(comp * 5 + k) * p + q];
                    at(0) + (at(1) + z * (at(2) + z * (at(3) + z * at(4))))
                };
                for (q, x) in out.iter_mut().enumerate() {
                    *x = Complex32::new(part(0, q, re[q] * sqrt2), part(1, q, im[q] * sqrt2));
                }
            }
            None => {
                for (p, x) in out.iter_mut().enumerate() {
                    let s = std[p] as f32;
                    *x = Complex32::new(
                        mean[p].re as f32 + re[p] * s,
                        mean[p].im as f32 + im[p] * s,
                    );
                }
            }
        }
    }

    /// Generates samples `first .. first + count` as complex64 (the format of saved samples),
    /// in parallel on the caller's rayon pool; each sample is computed in f64 and rounded.
    ///
    /// # Panics
    /// If the samples do not fit in memory (see [`Model::try_generate_c64`]).
    pub fn generate_c64(
        &self,
        seed: u64,
        first: usize,
        count: usize,
    ) -> Array3<num_complex::Complex<f32>> {
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
    ) -> Result<Array3<num_complex::Complex<f32>>, AllocError> {
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
        if let (None, Some(_)) = (&self.filter, &self.deviations) {
            out.par_chunks_mut(FULL_COVARIANCE_BATCH * h * w)
                .enumerate()
                .for_each(|(b, block)| {
                    self.full_covariance_c64(seed, first + b * FULL_COVARIANCE_BATCH, block)
                });
            return;
        }
        if self.sample_format != 1 {
            out.par_chunks_mut(h * w)
                .enumerate()
                .for_each_init(Scratch::default, |scratch, (s, plane)| {
                    self.sample_c32(seed, first + s, scratch, plane)
                });
            return;
        }
        out.par_chunks_mut(h * w).enumerate().for_each_init(
            || vec![Complex64::new(0.0, 0.0); h * w],
            |buf, (s, plane)| {
                self.sample_into(seed, first + s, buf);
                for (o, x) in plane.iter_mut().zip(buf.iter()) {
                    *o = Complex32::new(x.re as f32, x.im as f32);
                }
            },
        );
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
        if let (None, Some(_)) = (&self.filter, &self.deviations) {
            out.as_slice_mut()
                .expect("standard layout")
                .par_chunks_mut(FULL_COVARIANCE_BATCH * h * w)
                .enumerate()
                .for_each(|(b, block)| {
                    self.full_covariance_c128(seed, first + b * FULL_COVARIANCE_BATCH, block)
                });
            return Ok(out);
        }
        if self.sample_format != 1 {
            out.as_slice_mut()
                .expect("standard layout")
                .par_chunks_mut(h * w)
                .enumerate()
                .for_each_init(
                    || (Scratch::default(), vec![Complex32::new(0.0, 0.0); h * w]),
                    |(scratch, buf), (s, plane)| {
                        self.sample_c32(seed, first + s, scratch, buf);
                        for (o, x) in plane.iter_mut().zip(buf.iter()) {
                            *o = Complex64::new(f64::from(x.re), f64::from(x.im));
                        }
                    },
                );
            return Ok(out);
        }
        out.as_slice_mut()
            .expect("standard layout")
            .par_chunks_mut(h * w)
            .enumerate()
            .for_each(|(s, plane)| self.sample_into(seed, first + s, plane));
        Ok(out)
    }
}
