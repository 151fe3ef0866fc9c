//! The `filtered_noise` dataset kind: a white complex circular seed (`E|z|^2 = 1`, real and
//! imaginary parts `N(0, 1/2)`) on a grid padded by the half-width, filtered in 'valid' mode
//! (no edge effects) by a separable correlating filter of one family (exponential or dyadic,
//! its parameters scalars or spatial maps), then `x = mu + std * y / sd(y)` with the analytic
//! `sd(y)`. Sample `s` draws from ChaCha20 seeded with the data seed on stream `s`, so samples
//! are generated in parallel and the stack does not depend on the thread count. K-distributed
//! clutter (`texture_shape`) scales sample `s` by the square root of a gamma texture drawn on
//! stream `2^40 + s`. The stack is allocated fallibly: one the memory cannot hold fails its
//! job.

use super::cost::{Cost, Sizes, C128, USUAL_HALF_WIDTH, USUAL_PIXELS, USUAL_SAMPLES};
use super::kind::{DataError, DatasetKind, Materialised};
use crate::alloc::{try_zeros, AllocError};
use crate::experiment::context::{Ctx, SpecError};
use crate::experiment::maps::check_range;
use crate::experiment::maps::{Map, ParamMap};
use crate::io::npy::Stack;
use crate::seeds::{texture, white_seed_into};
use crate::stats::filters::{bank_bytes, filter_flops};
use crate::stats::filters::{dyadic_taps, exponential_taps, filter_seed, FilterBank};
use ndarray::{Array2, Array3};
use num_complex::Complex64;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The fields of every family.
const NOISE: [&str; 8] = [
    "family",
    "size",
    "samples",
    "half_width",
    "mean",
    "mean_im",
    "std",
    "texture_shape",
];
/// The fields of the exponential family.
const EXPONENTIAL: [&str; 10] = [
    "alpha_h", "alpha_v", NOISE[0], NOISE[1], NOISE[2], NOISE[3], NOISE[4], NOISE[5], NOISE[6],
    NOISE[7],
];
/// The fields of the dyadic family.
const DYADIC: [&str; 10] = [
    "r_h", "r_v", NOISE[0], NOISE[1], NOISE[2], NOISE[3], NOISE[4], NOISE[5], NOISE[6], NOISE[7],
];

/// The fields of a `filtered_noise` dataset as written.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    /// Filter family.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub family: Option<Family>,
    /// Exponential: horizontal alpha (scalar or map).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpha_h: Option<ParamMap>,
    /// Exponential: vertical alpha (scalar or map).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpha_v: Option<ParamMap>,
    /// Dyadic: horizontal `r_1..r_L`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub r_h: Option<Vec<ParamMap>>,
    /// Dyadic: vertical `r_1..r_L`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub r_v: Option<Vec<ParamMap>>,
    /// Image size `[H, W]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size: Option<[usize; 2]>,
    /// Number of samples `N`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples: Option<usize>,
    /// Filter half-width `K` (default 8; the seed grid is padded by it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_width: Option<usize>,
    /// Real part of the mean map (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mean: Option<ParamMap>,
    /// Imaginary part of the mean map (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mean_im: Option<ParamMap>,
    /// Standard-deviation map (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub std: Option<ParamMap>,
    /// Shape `nu` of a gamma texture (K-distributed clutter, see
    /// [`FilteredNoise::texture_shape`]); absent: Gaussian.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texture_shape: Option<f64>,
}

/// Filter families of `filtered_noise`.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Family {
    /// `exp(-|d| / alpha)` per direction (`alpha_h`, `alpha_v`).
    Exponential,
    /// Dyadic steps `r_1..r_L` per direction (`r_h`, `r_v`).
    Dyadic,
}

/// A validated `filtered_noise` dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct FilteredNoise {
    /// Filter parameters.
    pub filter: FilterParams,
    /// Image height.
    pub height: usize,
    /// Image width.
    pub width: usize,
    /// Samples.
    pub samples: usize,
    /// Filter half-width `K`.
    pub half_width: usize,
    /// Mean, real part.
    pub mean: Map,
    /// Mean, imaginary part.
    pub mean_im: Map,
    /// Standard deviation.
    pub std: Map,
    /// K-distributed clutter: each sample is multiplied by `sqrt(tau)`, `tau ~ Gamma(nu, 1/nu)`
    /// (mean 1), one `tau` per sample (the power of one gust). Mean, variance and correlation
    /// maps are unchanged; the real and imaginary parts get excess kurtosis `3 / nu`. `None`:
    /// Gaussian.
    pub texture_shape: Option<f64>,
}

impl FilteredNoise {
    /// Zero-mean, unit-variance filtered noise of `size = (H, W)`, `samples` samples and filter
    /// half-width `half_width` (what a spec gives when `mean`, `mean_im` and `std` are unset).
    pub fn new(
        filter: FilterParams,
        (height, width): (usize, usize),
        samples: usize,
        half_width: usize,
    ) -> Self {
        FilteredNoise {
            filter,
            height,
            width,
            samples,
            half_width,
            mean: Map::Constant(0.0),
            mean_im: Map::Constant(0.0),
            std: Map::Constant(1.0),
            texture_shape: None,
        }
    }
}

/// Filter parameters per direction.
#[derive(Debug, Clone, PartialEq)]
pub enum FilterParams {
    /// Exponential: `alpha_h`, `alpha_v`.
    Exponential {
        /// Horizontal alpha map.
        alpha_h: Map,
        /// Vertical alpha map.
        alpha_v: Map,
    },
    /// Dyadic: `r_h`, `r_v`.
    Dyadic {
        /// Horizontal `r_1..r_L` maps.
        r_h: Vec<Map>,
        /// Vertical `r_1..r_L` maps.
        r_v: Vec<Map>,
    },
}

impl FilterParams {
    /// Whether every parameter is one value (a uniform bank).
    pub fn is_uniform(&self) -> bool {
        let constant = |m: &Map| matches!(m, Map::Constant(_));
        match self {
            FilterParams::Exponential { alpha_h, alpha_v } => {
                constant(alpha_h) && constant(alpha_v)
            }
            FilterParams::Dyadic { r_h, r_v } => r_h.iter().chain(r_v).all(constant),
        }
    }
}

impl DatasetKind for FilteredNoise {
    const NAME: &'static str = "filtered_noise";
    const FIELDS: &'static [&'static str] = &[
        "family",
        "alpha_h",
        "alpha_v",
        "r_h",
        "r_v",
        "size",
        "samples",
        "half_width",
        "mean",
        "mean_im",
        "std",
        "texture_shape",
    ];
    const SAMPLES_FIELD: &'static str = "samples";
    type Spec = Spec;

    fn applies(spec: &Spec) -> &'static [&'static str] {
        match spec.family {
            Some(Family::Dyadic) => &DYADIC,
            Some(Family::Exponential) | None => &EXPONENTIAL,
        }
    }

    fn check(spec: &Spec, ctx: &Ctx, at: &str) -> Result<Self, SpecError> {
        let set = [
            ("alpha_h", spec.alpha_h.is_some()),
            ("alpha_v", spec.alpha_v.is_some()),
            ("r_h", spec.r_h.is_some()),
            ("r_v", spec.r_v.is_some()),
        ];
        let allowed = Self::applies(spec);
        if let Some((f, _)) = set.iter().find(|(f, set)| *set && !allowed.contains(f)) {
            let family = match spec.family {
                Some(Family::Dyadic) => "dyadic",
                Some(Family::Exponential) | None => "exponential",
            };
            return Err(ctx.err(
                format!("{at}.{f}"),
                format!(
                    "`{f}` does not apply to this dataset (kind filtered_noise, family {family}); it takes: {}",
                    allowed.join(", ")
                ),
            ));
        }
        check_fields(spec, ctx, at)
    }

    fn shape(&self) -> (usize, usize, usize) {
        (self.samples, self.height, self.width)
    }

    fn input_files(&self) -> Vec<PathBuf> {
        vec![]
    }

    fn worth_sharing(&self) -> bool {
        false
    }

    fn redrawable(&self) -> Option<bool> {
        Some(true)
    }

    fn known_filter(&self) -> Option<usize> {
        self.filter.is_uniform().then_some(self.half_width)
    }

    fn sizes(&self, at: &str, s: &mut Sizes) {
        let (n, h, w) = self.shape();
        let pixels = h as f64 * w as f64;
        s.add(format!("{at}.samples"), n, n as f64 / USUAL_SAMPLES);
        s.add(
            format!("{at}.size"),
            format!("[{h}, {w}]"),
            pixels / USUAL_PIXELS,
        );
        let k = self.half_width;
        s.add(format!("{at}.half_width"), k, k as f64 / USUAL_HALF_WIDTH);
    }

    fn cost(&self) -> Cost {
        let (n, p) = (self.samples as f64, (self.height * self.width) as f64);
        let k = self.half_width as f64;
        let varying = !self.filter.is_uniform();
        let bank = bank_bytes(p, k, varying);
        let kept = C128 * n * p + bank + 48.0 * p;
        Cost {
            peak: kept,
            kept,
            flops: n * p * filter_flops(k, varying),
            ..Cost::default()
        }
    }

    fn redraw_cost(&self, samples: usize) -> Cost {
        let (m, p) = (samples as f64, (self.height * self.width) as f64);
        Cost {
            peak: C128 * m * p,
            kept: C128 * m * p,
            flops: m * p * filter_flops(self.half_width as f64, !self.filter.is_uniform()),
            ..Cost::default()
        }
    }

    fn materialise(&self, data_seed: u64) -> Result<Materialised, DataError> {
        let bank = filter_bank(self);
        let stack = generate(self, &bank, data_seed)?;
        let std = self.std.grid(self.height, self.width);
        Ok(Materialised {
            truth: Some((bank, std)),
            ..Materialised::plain(Stack::Generated(stack), false)
        })
    }

    fn redraw(
        &self,
        samples: usize,
        seed: u64,
        data: &Materialised,
    ) -> Option<Result<Array3<Complex64>, DataError>> {
        let mut spec = self.clone();
        spec.samples = samples;
        Some(
            match &data.truth {
                Some((bank, _)) => generate(&spec, bank, seed),
                None => generate(&spec, &filter_bank(&spec), seed),
            }
            .map_err(DataError::from),
        )
    }
}

/// Checks a filtered-noise dataset's fields into its typed parameters, each with its YAML
/// path; the family's filter by [`exponential_filter`] or [`dyadic_filter`].
fn check_fields(spec: &Spec, ctx: &Ctx, at: &str) -> Result<FilteredNoise, SpecError> {
    let family = spec.family.ok_or_else(|| {
        ctx.err(
            format!("{at}.family"),
            "kind filtered_noise needs `family` (exponential or dyadic)",
        )
    })?;
    let [h, w] = spec.size.ok_or_else(|| {
        ctx.err(
            format!("{at}.size"),
            "kind filtered_noise needs `size: [H, W]`",
        )
    })?;
    if h == 0 || w == 0 {
        return Err(ctx.err(
            format!("{at}.size"),
            format!("size must be positive, got [{h}, {w}]"),
        ));
    }
    let samples = spec.samples.ok_or_else(|| {
        ctx.err(
            format!("{at}.samples"),
            "kind filtered_noise needs `samples`",
        )
    })?;
    let half_width = spec.half_width.unwrap_or(8);
    let map = |p: &Option<ParamMap>, name: &str, default: f64| -> Result<Map, SpecError> {
        match p {
            Some(p) => p.check(ctx, &format!("{at}.{name}"), h, w),
            None => Ok(Map::Constant(default)),
        }
    };
    let filter = match family {
        Family::Exponential => exponential_filter(spec, ctx, at, (h, w))?,
        Family::Dyadic => dyadic_filter(spec, ctx, at, (h, w), half_width)?,
    };
    let std = map(&spec.std, "std", 1.0)?;
    check_range(
        ctx,
        &format!("{at}.std"),
        &std,
        |v| v >= 0.0 && v.is_finite(),
        "std must be finite and >= 0",
    )?;
    let texture_shape = spec.texture_shape;
    if let Some(nu) = texture_shape {
        if !(nu > 0.0 && nu.is_finite()) {
            return Err(ctx.err(
                format!("{at}.texture_shape"),
                format!("texture_shape {nu} must be finite and > 0"),
            ));
        }
    }
    let finite = |p: &Option<ParamMap>, name: &str| -> Result<Map, SpecError> {
        let m = map(p, name, 0.0)?;
        check_range(
            ctx,
            &format!("{at}.{name}"),
            &m,
            f64::is_finite,
            &format!("{name} must be finite"),
        )?;
        Ok(m)
    };
    Ok(FilteredNoise {
        filter,
        height: h,
        width: w,
        samples,
        half_width,
        mean: finite(&spec.mean, "mean")?,
        mean_im: finite(&spec.mean_im, "mean_im")?,
        std,
        texture_shape,
    })
}

/// The filter of family exponential: `alpha_h` and `alpha_v`, each a map of non-zero values.
fn exponential_filter(
    spec: &Spec,
    ctx: &Ctx,
    at: &str,
    (h, w): (usize, usize),
) -> Result<FilterParams, SpecError> {
    let need = |p: &Option<ParamMap>, name: &str| -> Result<Map, SpecError> {
        let p = p.as_ref().ok_or_else(|| {
            ctx.err(
                format!("{at}.{name}"),
                format!("family exponential needs `{name}`"),
            )
        })?;
        let m = p.check(ctx, &format!("{at}.{name}"), h, w)?;
        check_range(
            ctx,
            &format!("{at}.{name}"),
            &m,
            |v| v != 0.0 && !v.is_nan(),
            "alpha must be non-zero (negative alpha: sign-alternating filter)",
        )?;
        Ok(m)
    };
    Ok(FilterParams::Exponential {
        alpha_h: need(&spec.alpha_h, "alpha_h")?,
        alpha_v: need(&spec.alpha_v, "alpha_v")?,
    })
}

/// The filter of family dyadic: `r_h` and `r_v`, lists of as many finite maps as levels, the
/// levels' reach within `half_width`.
fn dyadic_filter(
    spec: &Spec,
    ctx: &Ctx,
    at: &str,
    (h, w): (usize, usize),
    half_width: usize,
) -> Result<FilterParams, SpecError> {
    let list = |p: &Option<Vec<ParamMap>>, name: &str| -> Result<Vec<Map>, SpecError> {
        let p = p.as_ref().ok_or_else(|| {
            ctx.err(
                format!("{at}.{name}"),
                format!("family dyadic needs `{name}: [r_1, ..., r_L]`"),
            )
        })?;
        if p.is_empty() {
            return Err(ctx.err(format!("{at}.{name}"), "needs at least one parameter"));
        }
        let reach = crate::stats::filters::dyadic_reach(p.len());
        if half_width < reach {
            return Err(ctx.err(format!("{at}.half_width"), format!("a {}-level dyadic filter reaches offset {reach}; half_width {half_width} would truncate it", p.len())));
        }
        p.iter()
            .enumerate()
            .map(|(i, m)| {
                let m = m.check(ctx, &format!("{at}.{name}[{i}]"), h, w)?;
                check_range(
                    ctx,
                    &format!("{at}.{name}[{i}]"),
                    &m,
                    f64::is_finite,
                    "r must be finite",
                )?;
                Ok(m)
            })
            .collect()
    };
    let (r_h, r_v) = (list(&spec.r_h, "r_h")?, list(&spec.r_v, "r_v")?);
    if r_h.len() != r_v.len() {
        return Err(ctx.err(
            format!("{at}.r_v"),
            format!(
                "r_h has {} parameters, r_v {}; they must match",
                r_h.len(),
                r_v.len()
            ),
        ));
    }
    Ok(FilterParams::Dyadic { r_h, r_v })
}

/// A pixel's vertical and horizontal taps.
type Taps = (Vec<f64>, Vec<f64>);

/// Builds the per-pixel filter bank of a `filtered_noise` dataset.
pub fn filter_bank(d: &FilteredNoise) -> FilterBank {
    let (h, w, k) = (d.height, d.width, d.half_width);
    let grid = |m: &Map| m.grid(h, w);
    let (vertical, horizontal): (Vec<Vec<f64>>, Vec<Vec<f64>>) = match &d.filter {
        FilterParams::Exponential { alpha_h, alpha_v } => {
            let (ah, av) = (grid(alpha_h), grid(alpha_v));
            // Most maps are uniform or piecewise constant: a pixel's taps are those of the
            // pixel before it when its parameters are (the same function of the same values).
            let mut last: Option<((f64, f64), Taps)> = None;
            ah.iter()
                .zip(av.iter())
                .map(|(&a_h, &a_v)| match &last {
                    Some((at, taps))
                        if at.0.to_bits() == a_h.to_bits() && at.1.to_bits() == a_v.to_bits() =>
                    {
                        taps.clone()
                    }
                    _ => {
                        let taps = (exponential_taps(a_v, k), exponential_taps(a_h, k));
                        last = Some(((a_h, a_v), taps.clone()));
                        taps
                    }
                })
                .unzip()
        }
        FilterParams::Dyadic { r_h, r_v } => {
            let rh: Vec<Array2<f64>> = r_h.iter().map(grid).collect();
            let rv: Vec<Array2<f64>> = r_v.iter().map(grid).collect();
            (0..h * w)
                .map(|p| {
                    let at = |maps: &[Array2<f64>]| {
                        maps.iter().map(|m| m[[p / w, p % w]]).collect::<Vec<_>>()
                    };
                    (dyadic_taps(&at(&rv), k), dyadic_taps(&at(&rh), k))
                })
                .unzip()
        }
    };
    FilterBank::new(k, h, w, vertical, horizontal)
}

/// Generates the `[N, H, W]` stack of a `filtered_noise` dataset.
///
/// # Errors
/// [`AllocError`] when the stack does not fit in memory.
pub fn generate(
    d: &FilteredNoise,
    bank: &FilterBank,
    data_seed: u64,
) -> Result<Array3<Complex64>, AllocError> {
    let (h, w, k) = (d.height, d.width, d.half_width);
    let (mean, mean_im, std) = (d.mean.grid(h, w), d.mean_im.grid(h, w), d.std.grid(h, w));
    let gain: Vec<f64> = (0..h * w)
        .map(|p| std[[p / w, p % w]] / bank.output_sd(p))
        .collect();
    let mu: Vec<Complex64> = mean
        .iter()
        .zip(mean_im.iter())
        .map(|(&a, &b)| Complex64::new(a, b))
        .collect();
    let mut out = try_zeros((d.samples, h, w), "the filtered-noise stack")?;
    let data = out.as_slice_mut().expect("standard layout");
    let padded = (h + 2 * k, w + 2 * k);
    data.par_chunks_mut(h * w).enumerate().for_each_init(
        || Array2::zeros(padded),
        |seed, (s, plane)| {
            white_seed_into(data_seed, s, seed.as_slice_mut().expect("standard layout"));
            filter_seed(bank, seed.view(), plane);
            let t = d
                .texture_shape
                .map_or(1.0, |nu| texture(data_seed, s, nu).sqrt());
            for ((x, g), m) in plane.iter_mut().zip(&gain).zip(&mu) {
                *x = m + *x * (*g * t);
            }
        },
    );
    Ok(out)
}
