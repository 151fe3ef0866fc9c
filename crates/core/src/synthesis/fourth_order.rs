//! The fourth-order model (3.2): per pixel and component the mean, variance, skewness and
//! excess kurtosis, reproduced by Fleishman's power method (a cubic of a unit normal), with no
//! spatial correlation.

use super::kernel::Scratch;
use super::method::{
    ArrayStore, Cost, CostSize, Layout, Moments, Needs, Recorded, SynthesisMethod,
};
use super::options::{FitError, FitOptions};
use super::sampling::{self, OneAtATime};
use crate::stats::analysis::Analysis;
use ndarray::{Array3, ArrayView3};
use num_complex::{Complex32, Complex64};
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};
use std::sync::OnceLock;

/// The fourth-order model's per-pixel parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct FourthOrderModel {
    /// `[component (re, im), coefficient (a, b, c, d), row, col]`.
    pub coefficients: ndarray::Array4<f64>,
    /// Standard deviation per component, `[component, row, col]`.
    pub component_sd: Array3<f64>,
    /// Moment pairs moved to the feasible region, `[component, row, col]` (0 or 1).
    pub infeasible: Array3<u8>,
}

/// Fits Fleishman's power method per pixel and component (real, imaginary) to the stack's
/// mean, variance, skewness and excess kurtosis.
fn fit_coefficients(stack: ArrayView3<Complex64>) -> FourthOrderModel {
    let (_, h, w) = stack.dim();
    let mut coefficients = ndarray::Array4::zeros((2, 4, h, w));
    let mut component_sd = Array3::zeros((2, h, w));
    let mut infeasible = Array3::zeros((2, h, w));
    for i in 0..h {
        for j in 0..w {
            let px = stack.slice(ndarray::s![.., i, j]);
            for comp in 0..2 {
                let values = px.iter().map(move |z| if comp == 0 { z.re } else { z.im });
                let (_, var, g1, g2) = crate::stats::fleishman::sample_moments(values);
                let (coef, moved) = if var > 0.0 {
                    crate::stats::fleishman::coefficients(g1, g2)
                } else {
                    ([0.0, 1.0, 0.0, 0.0], false)
                };
                for (k, c) in coef.iter().enumerate() {
                    coefficients[[comp, k, i, j]] = *c;
                }
                component_sd[[comp, i, j]] = var.sqrt();
                infeasible[[comp, i, j]] = u8::from(moved);
            }
        }
    }
    FourthOrderModel {
        coefficients,
        component_sd,
        infeasible,
    }
}

/// A fitted fourth-order model.
#[derive(Debug, Clone)]
pub struct FourthOrder {
    /// The per-pixel moments.
    pub moments: Moments,
    /// The Fleishman coefficients.
    pub fourth: FourthOrderModel,
    /// In format 2: per component the mean and the four Fleishman coefficients times the
    /// standard deviation, `[2][5][H W]` in `f32`, made on first use.
    f32_coefficients: OnceLock<Vec<f32>>,
}

impl FourthOrder {
    /// The model of `fourth` with `moments`.
    fn new(moments: Moments, fourth: FourthOrderModel) -> Self {
        FourthOrder {
            moments,
            fourth,
            f32_coefficients: OnceLock::new(),
        }
    }

    /// The `f32` coefficients of format 2.
    fn coefficients_f32(&self) -> &[f32] {
        self.f32_coefficients.get_or_init(|| {
            let mean = self.moments.mean.as_slice().expect("standard layout");
            let (p, w) = (mean.len(), self.moments.mean.dim().1);
            let f = &self.fourth;
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
        })
    }
}

impl OneAtATime for FourthOrder {
    /// Sample `index` in format 1: per pixel two ChaCha20 normals through the cubic.
    fn sample_f64(&self, seed: u64, index: usize, out: &mut [Complex64]) {
        let w = self.moments.mean.dim().1;
        let f = &self.fourth;
        let mut rng = ChaCha20Rng::seed_from_u64(seed);
        rng.set_stream(index as u64);
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
            *x = self.moments.mean[[i, j]] + Complex64::new(part(0, zr), part(1, zi));
        }
    }

    /// Sample `index` in format 2: per pixel and component, in `f32`, the mean plus the
    /// component's standard deviation times Fleishman's cubic of the unit normal `sqrt 2`
    /// times the part.
    fn sample_f32(&self, seed: u64, index: usize, scratch: &mut Scratch, out: &mut [Complex32]) {
        let p = out.len();
        let c = self.coefficients_f32();
        let (re, im) = scratch.normals(seed, index, p);
        let sqrt2 = std::f32::consts::SQRT_2;
        let part = |comp: usize, q: usize, z: f32| {
            let at = |k: usize| c[(comp * 5 + k) * p + q];
            at(0) + (at(1) + z * (at(2) + z * (at(3) + z * at(4))))
        };
        for (q, x) in out.iter_mut().enumerate() {
            *x = Complex32::new(part(0, q, re[q] * sqrt2), part(1, q, im[q] * sqrt2));
        }
    }
}

impl SynthesisMethod for FourthOrder {
    const NAME: &'static str = "fourth_order";
    const FILES: &'static [&'static str] = &["fleishman.npy", "component_sd.npy", "infeasible.npy"];

    fn needs() -> Needs {
        Needs {
            levels: false,
            stack: true,
            half_width: false,
        }
    }

    fn model_order() -> Option<i64> {
        Some(4)
    }

    fn fit(
        moments: Moments,
        _analysis: &Analysis,
        stack: Option<ArrayView3<Complex64>>,
        _opts: &FitOptions,
    ) -> Result<Self, FitError> {
        let stack = stack.expect("fourth_order is fitted from the stack itself");
        Ok(FourthOrder::new(moments, fit_coefficients(stack)))
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

    fn save(&self, store: &mut impl ArrayStore) -> anyhow::Result<()> {
        store.write("fleishman.npy", &self.fourth.coefficients)?;
        store.write("component_sd.npy", &self.fourth.component_sd)?;
        store.write("infeasible.npy", &self.fourth.infeasible)
    }

    fn check(_layout: &Layout) -> anyhow::Result<()> {
        Ok(())
    }

    fn load(moments: Moments, layout: &Layout, store: &impl ArrayStore) -> anyhow::Result<Self> {
        const PER_COMPONENT: &str = "[component, height, width] of model.json";
        let (h, w) = (layout.height, layout.width);
        let fourth = FourthOrderModel {
            coefficients: store.read(
                "fleishman.npy",
                (
                    vec![2, 4, h, w],
                    "[component, coefficient, height, width] of model.json",
                ),
                (&|c: &f64| c.is_finite(), "coefficients must be finite"),
            )?,
            component_sd: store.read(
                "component_sd.npy",
                (vec![2, h, w], PER_COMPONENT),
                (
                    &|s: &f64| s.is_finite() && *s >= 0.0,
                    "a standard deviation must be finite and >= 0",
                ),
            )?,
            infeasible: store.read(
                "infeasible.npy",
                (vec![2, h, w], PER_COMPONENT),
                (&|f: &u8| *f <= 1, "an infeasible flag is 0 or 1"),
            )?,
        };
        Ok(FourthOrder::new(moments, fourth))
    }

    fn cost(size: &CostSize) -> Cost {
        let p = size.pixels;
        Cost {
            model_bytes: 24.0 * p + 82.0 * p,
            fit_flops: 30.0 * size.fitted * p,
            generate_flops: 60.0 * size.generated * p,
        }
    }
}
