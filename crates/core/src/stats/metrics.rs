//! Similarity measures between two stacks (dissertation ch. 2.5 and 4.4, docs/definitions.md
//! §6): histogram KL divergence per pixel and per image area, on real and imaginary parts with
//! shared bin edges; the multiscale correlation RMSE (eq. 25) with the dissertation's summaries.
//! The correlation matrix distance lives in [`crate::stats::cmd`]. Kernels are pure functions of
//! array views; the caller's rayon pool decides the parallelism, and every result is
//! independent of the thread count (no reduction crosses tasks).
//!
//! KL conventions (the dissertation leaves them open; these are recorded in every output row):
//! `D(P || Q) = sum_k p_k ln(p_k / q_k)` in nats, `P` from the first stack (the original), `Q`
//! from the second (the generated one); `B` equal-width bins spanning the minimum to the
//! maximum of the union of both sets; an empty bin receives `smoothing` pseudo-counts (the
//! non-empty ones keep theirs) before normalising, so `D` stays finite when `smoothing > 0`.
//! The symmetric option is eq. 23, `D(P || Q) + D(Q || P)`. `mean_over_bins` divides the sum
//! over bins by the number of bins (the mean of `p_k ln(p_k / q_k)`, what MATLAB's
//! `mean(p .* log(p ./ q))` computes): with it, the symmetric form's floor for two samples of
//! one distribution is about `(B - 1) / B (1/N + 1/M)`, the law every KL value the
//! dissertation prints follows (docs/definitions.md section 6). `bias_correction: resplit`
//! subtracts the estimator's mean over [`RESPLITS`] random re-splits of the pooled counts into
//! sets of `N` and `M` (its value when both sets come from one distribution), so its floor is
//! near zero. dB applies `10 log10` to the reported statistic (the mean or worst of the linear
//! map); the maps stay linear.

use crate::stats::analysis::{Analysis, Direction};
use ndarray::{Array2, ArrayView3, Axis};
use num_complex::Complex;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Default number of histogram bins.
pub const DEFAULT_BINS: usize = 32;
/// Default pseudo-count given to an empty bin.
pub const DEFAULT_SMOOTHING: f64 = 0.5;
/// Default block edge of the per-area KL (8 x 8 pixels, as in the dissertation).
pub const DEFAULT_BLOCK: usize = 8;

/// Random re-splits of the pooled counts behind `bias_correction: resplit`.
pub const RESPLITS: usize = 20;

/// How the KL divergence's sampling floor is removed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BiasCorrection {
    /// None: the plug-in estimate, whose floor is about `c (1/N + 1/M)`.
    #[default]
    None,
    /// Minus the estimate's mean over [`RESPLITS`] random re-splits of the pooled counts into
    /// sets of `N` and `M` values (drawn from ChaCha8 seeded by the unit and component, so the
    /// value is a function of the two stacks alone). Its floor is near zero; a model that
    /// copies the original's own sampling noise can score below zero.
    Resplit,
}

impl BiasCorrection {
    /// The name in specs and tables.
    pub fn as_str(self) -> &'static str {
        match self {
            BiasCorrection::None => "none",
            BiasCorrection::Resplit => "resplit",
        }
    }
}

/// Parameters of the histogram KL divergence.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct KlOptions {
    /// Number of equal-width bins over the union of both sets.
    pub bins: usize,
    /// Pseudo-count given to each empty bin before normalising (`>= 0`).
    pub smoothing: f64,
    /// Eq. 23: `D(P || Q) + D(Q || P)` instead of `D(P || Q)`.
    pub symmetric: bool,
    /// Report statistics as `10 log10` of the linear value.
    pub db: bool,
    /// The sum over bins divided by the number of bins (the mean over bins).
    #[serde(default)]
    pub mean_over_bins: bool,
    /// How the sampling floor is removed.
    #[serde(default)]
    pub bias_correction: BiasCorrection,
}

impl Default for KlOptions {
    fn default() -> Self {
        KlOptions {
            bins: DEFAULT_BINS,
            smoothing: DEFAULT_SMOOTHING,
            symmetric: false,
            db: false,
            mean_over_bins: false,
            bias_correction: BiasCorrection::None,
        }
    }
}

impl KlOptions {
    /// The KL divergence of two histograms with these options: [`kl_counts`], divided by the
    /// bin count when `mean_over_bins`, minus the re-splits' mean under
    /// [`BiasCorrection::Resplit`] (`unit` seeds them).
    pub fn of_counts(&self, p: &[u32], q: &[u32], unit: u64) -> f64 {
        let scale = if self.mean_over_bins {
            1.0 / p.len().max(1) as f64
        } else {
            1.0
        };
        let plain = |p: &[u32], q: &[u32]| kl_counts(p, q, self.smoothing, self.symmetric) * scale;
        let raw = plain(p, q);
        match self.bias_correction {
            BiasCorrection::None => raw,
            BiasCorrection::Resplit => raw - resplit_mean(p, q, unit, RESPLITS, &plain),
        }
    }
}

/// The mean of `kl` over `resplits` random re-splits of the pooled counts of `p` and `q`
/// into sets of their sizes: bin by bin, the first set's share of the bin is hypergeometric
/// given what is left of the pool and of the first set's size (a uniformly random re-split).
fn resplit_mean(
    p: &[u32],
    q: &[u32],
    unit: u64,
    resplits: usize,
    kl: &dyn Fn(&[u32], &[u32]) -> f64,
) -> f64 {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Hypergeometric};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(unit ^ 0x6b6c_5f72_6573_706c);
    let (mut a, mut b) = (vec![0u32; p.len()], vec![0u32; q.len()]);
    let mut total = 0.0;
    for _ in 0..resplits {
        let mut pool: u64 = p.iter().chain(q).map(|&c| c as u64).sum();
        let mut left: u64 = p.iter().map(|&c| c as u64).sum();
        for k in 0..p.len() {
            let here = (p[k] + q[k]) as u64;
            let took = if here == 0 || left == 0 {
                0
            } else if here == pool {
                left
            } else {
                Hypergeometric::new(pool, here, left)
                    .expect("counts within the pool")
                    .sample(&mut rng)
            };
            a[k] = took as u32;
            b[k] = (here - took) as u32;
            pool -= here;
            left -= took;
        }
        total += kl(&a, &b);
    }
    total / resplits as f64
}

/// A validated metric of the `metrics:` section.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Metric {
    /// KL divergence per pixel (the `N` values of one pixel).
    KlPixel(KlOptions),
    /// KL divergence per `block x block` area (all values of the area over all samples).
    KlArea(KlOptions, usize),
    /// Correlation matrix distance (eq. 24).
    Cmd,
    /// Multiscale correlation RMSE (eq. 25) per level and direction.
    MultiscaleRmse,
}

/// The metrics' names in specs, in the `metric` column of `similarity.parquet` and in the
/// comparison maps' file stems ([`map_stem`]): written once here, read by the spec's parser,
/// the jobs, the report and the reproduction.
pub mod name {
    /// KL divergence per pixel.
    pub const KL_PIXEL: &str = "kl_pixel";
    /// KL divergence per image area.
    pub const KL_AREA: &str = "kl_area";
    /// Correlation matrix distance.
    pub const CMD: &str = "cmd";
    /// Multiscale correlation RMSE.
    pub const MULTISCALE_RMSE: &str = "multiscale_rmse";
}

/// The file stem of a comparison map: the metric's name and the component compared, `re` or
/// `im` (`kl_pixel_re`, `kl_area_im`).
pub fn map_stem(metric: &str, component: &str) -> String {
    format!("{metric}_{component}")
}

/// Which metric a [`Metric`] is, without its parameters: what the spec's parser matches
/// (exhaustively, so that a new metric is a compile error there until it is parsed) and what
/// [`Metric::kind`] gives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MetricKind {
    /// [`Metric::KlPixel`].
    KlPixel,
    /// [`Metric::KlArea`].
    KlArea,
    /// [`Metric::Cmd`].
    Cmd,
    /// [`Metric::MultiscaleRmse`].
    MultiscaleRmse,
}

impl MetricKind {
    /// Every kind, in the order specs list them.
    pub const ALL: [MetricKind; 4] = [
        MetricKind::KlPixel,
        MetricKind::KlArea,
        MetricKind::Cmd,
        MetricKind::MultiscaleRmse,
    ];

    /// Its name in specs and tables ([`name`]).
    pub fn name(self) -> &'static str {
        match self {
            MetricKind::KlPixel => name::KL_PIXEL,
            MetricKind::KlArea => name::KL_AREA,
            MetricKind::Cmd => name::CMD,
            MetricKind::MultiscaleRmse => name::MULTISCALE_RMSE,
        }
    }

    /// Every name, comma-separated (for messages).
    pub fn names() -> String {
        MetricKind::ALL.map(MetricKind::name).join(", ")
    }
}

impl std::str::FromStr for MetricKind {
    type Err = String;

    /// The kind of a metric's name; an unknown name lists the known ones.
    fn from_str(s: &str) -> Result<Self, String> {
        MetricKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| format!("unknown metric {s:?}; known: {}", MetricKind::names()))
    }
}

impl Metric {
    /// Which metric it is.
    pub fn kind(&self) -> MetricKind {
        match self {
            Metric::KlPixel(_) => MetricKind::KlPixel,
            Metric::KlArea(..) => MetricKind::KlArea,
            Metric::Cmd => MetricKind::Cmd,
            Metric::MultiscaleRmse => MetricKind::MultiscaleRmse,
        }
    }

    /// The metric's name in specs and tables ([`name`]).
    pub fn name(&self) -> &'static str {
        self.kind().name()
    }
}

/// A complex or real element whose real and imaginary parts the metrics read, in f64.
pub trait Parts: Copy + Send + Sync {
    /// `(re, im)`.
    fn parts(self) -> (f64, f64);
}

impl Parts for Complex<f32> {
    #[inline(always)]
    fn parts(self) -> (f64, f64) {
        (self.re as f64, self.im as f64)
    }
}

impl Parts for Complex<f64> {
    #[inline(always)]
    fn parts(self) -> (f64, f64) {
        (self.re, self.im)
    }
}

/// Equal-width histogram of `values` over `[lo, hi]` with `bins` bins (the top edge belongs to
/// the last bin). Values outside the range are clamped into the end bins.
pub fn histogram(values: &[f64], lo: f64, hi: f64, bins: usize) -> Vec<u32> {
    let mut counts = vec![0u32; bins];
    for &v in values {
        counts[bin_of(v, lo, bin_scale(lo, hi, bins), bins)] += 1;
    }
    counts
}

#[inline(always)]
fn bin_scale(lo: f64, hi: f64, bins: usize) -> f64 {
    if hi > lo {
        bins as f64 / (hi - lo)
    } else {
        0.0
    }
}

#[inline(always)]
fn bin_of(v: f64, lo: f64, scale: f64, bins: usize) -> usize {
    // `as usize` saturates negative values to 0.
    (((v - lo) * scale) as usize).min(bins - 1)
}

/// KL divergence `D(P || Q)` of two histograms with identical edges (counts), with `smoothing`
/// pseudo-counts in every empty bin; symmetric (eq. 23) when asked. Returns 0 for two empty
/// histograms, infinity when `smoothing = 0` and `Q` is empty where `P` is not.
pub fn kl_counts<C: Copy + Into<f64>>(p: &[C], q: &[C], smoothing: f64, symmetric: bool) -> f64 {
    let dist = |c: &[C]| -> Vec<f64> {
        let raw: Vec<f64> = c
            .iter()
            .map(|&x| {
                let x: f64 = x.into();
                if x == 0.0 {
                    smoothing
                } else {
                    x
                }
            })
            .collect();
        let total: f64 = raw.iter().sum();
        raw.iter()
            .map(|&x| if total > 0.0 { x / total } else { 0.0 })
            .collect()
    };
    let (p, q) = (dist(p), dist(q));
    let d = |p: &[f64], q: &[f64]| -> f64 {
        p.iter()
            .zip(q)
            .filter(|(&a, _)| a > 0.0)
            .map(|(&a, &b)| a * (a / b).ln())
            .sum()
    };
    if symmetric {
        d(&p, &q) + d(&q, &p)
    } else {
        d(&p, &q)
    }
}

/// Per-unit KL maps of the real (`[0]`) and imaginary (`[1]`) parts of two stacks `[N, H, W]`
/// with equal `H x W`: a unit is a `block x block` area (all its values over all samples);
/// `block = 1` is the per-pixel KL. The maps are `floor(H/block) x floor(W/block)`; a unit in
/// which either stack has a NaN is NaN.
///
/// # Panics
/// If the image sizes differ, `block` is 0 or larger than the image, or `opts.bins` is 0.
pub fn kl_maps<A: Parts, B: Parts>(
    a: ArrayView3<A>,
    b: ArrayView3<B>,
    block: usize,
    opts: &KlOptions,
) -> [Array2<f64>; 2] {
    let (_, h, w) = a.dim();
    assert_eq!((h, w), (b.dim().1, b.dim().2), "image sizes differ");
    assert!(block >= 1 && block <= h.min(w), "block {block} for {h}x{w}");
    assert!(opts.bins >= 1, "bins must be positive");
    let (mh, mw) = (h / block, w / block);
    let rows: Vec<[Vec<f64>; 2]> = (0..mh)
        .into_par_iter()
        .map(|bi| kl_band(a, b, bi * block, block, mw, opts))
        .collect();
    let mut out = [Array2::zeros((mh, mw)), Array2::zeros((mh, mw))];
    for (bi, row) in rows.iter().enumerate() {
        for c in 0..2 {
            out[c]
                .row_mut(bi)
                .assign(&ndarray::ArrayView1::from(&row[c]));
        }
    }
    out
}

/// Running minimum and maximum of both components of one unit; NaN poisons it.
#[derive(Clone, Copy)]
struct Range {
    lo: [f64; 2],
    hi: [f64; 2],
    nan: bool,
}

/// The KL values of the units of one band of `block` image rows starting at `row0`.
fn kl_band<A: Parts, B: Parts>(
    a: ArrayView3<A>,
    b: ArrayView3<B>,
    row0: usize,
    block: usize,
    units: usize,
    opts: &KlOptions,
) -> [Vec<f64>; 2] {
    let bins = opts.bins;
    let mut range = vec![
        Range {
            lo: [f64::INFINITY; 2],
            hi: [f64::NEG_INFINITY; 2],
            nan: false,
        };
        units
    ];
    for_each_value(a, row0, block, units, |u, re, im| {
        update(&mut range[u], re, im)
    });
    for_each_value(b, row0, block, units, |u, re, im| {
        update(&mut range[u], re, im)
    });
    let scale: Vec<[f64; 2]> = range
        .iter()
        .map(|r| [0, 1].map(|c| bin_scale(r.lo[c], r.hi[c], bins)))
        .collect();
    // counts[(unit * 2 + component) * bins + bin]
    let count = |s: &mut [u32], u: usize, re: f64, im: f64| {
        let r = &range[u];
        for (c, v) in [re, im].into_iter().enumerate() {
            s[(u * 2 + c) * bins + bin_of(v, r.lo[c], scale[u][c], bins)] += 1;
        }
    };
    let mut ca = vec![0u32; units * 2 * bins];
    let mut cb = vec![0u32; units * 2 * bins];
    for_each_value(a, row0, block, units, |u, re, im| count(&mut ca, u, re, im));
    for_each_value(b, row0, block, units, |u, re, im| count(&mut cb, u, re, im));
    [0, 1].map(|c| {
        (0..units)
            .map(|u| {
                if range[u].nan {
                    return f64::NAN;
                }
                let at = (u * 2 + c) * bins..(u * 2 + c + 1) * bins;
                let id = (((row0 as u64) << 32) | (u as u64)) << 1 | c as u64;
                opts.of_counts(&ca[at.clone()], &cb[at], id)
            })
            .collect()
    })
}

#[inline(always)]
fn update(r: &mut Range, re: f64, im: f64) {
    if re.is_nan() || im.is_nan() {
        r.nan = true;
        return;
    }
    r.lo = [r.lo[0].min(re), r.lo[1].min(im)];
    r.hi = [r.hi[0].max(re), r.hi[1].max(im)];
}

/// Calls `f(unit, re, im)` for every value of the band's units, sample by sample (rows are
/// contiguous, so the band is read in memory order).
#[inline(always)]
fn for_each_value<T: Parts>(
    x: ArrayView3<T>,
    row0: usize,
    block: usize,
    units: usize,
    mut f: impl FnMut(usize, f64, f64),
) {
    for sample in x.axis_iter(Axis(0)) {
        for r in row0..row0 + block {
            let row = sample.row(r);
            for (j, v) in row.iter().take(units * block).enumerate() {
                let (re, im) = v.parts();
                f(j / block, re, im);
            }
        }
    }
}

/// Mean of the finite values of a map and the number of NaN cells (`(NaN, n)` if all are NaN).
pub fn finite_mean(map: &Array2<f64>) -> (f64, usize) {
    let (mut s, mut n, mut nan) = (0.0, 0usize, 0usize);
    for &v in map {
        if v.is_nan() {
            nan += 1;
        } else {
            s += v;
            n += 1;
        }
    }
    (if n > 0 { s / n as f64 } else { f64::NAN }, nan)
}

/// Largest non-NaN value of a map (NaN if there is none).
pub fn finite_max(map: &Array2<f64>) -> f64 {
    map.iter()
        .filter(|v| !v.is_nan())
        .fold(f64::NAN, |m, &v| if m.is_nan() || v > m { v } else { m })
}

/// `10 log10(x)`.
pub fn db(x: f64) -> f64 {
    10.0 * x.log10()
}

/// Eq. 25: `sqrt(mean((x1 - x2)^2))` over the cells where both maps are finite, with the
/// number of cells used (`NaN` when none is).
///
/// # Panics
/// If the shapes differ.
pub fn map_rmse(x1: &Array2<f64>, x2: &Array2<f64>) -> (f64, usize) {
    assert_eq!(x1.dim(), x2.dim(), "map shapes differ");
    let (mut s, mut n) = (0.0, 0usize);
    for (&a, &b) in x1.iter().zip(x2) {
        if a.is_finite() && b.is_finite() {
            s += (a - b) * (a - b);
            n += 1;
        }
    }
    (
        if n > 0 {
            (s / n as f64).sqrt()
        } else {
            f64::NAN
        },
        n,
    )
}

/// Eq. 25 for one level and direction of the correlation maps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelRmse {
    /// Level `L` (1-based).
    pub level: usize,
    /// Direction.
    pub direction: Direction,
    /// The RMSE.
    pub rmse: f64,
    /// Cells compared (finite in both maps).
    pub cells: usize,
}

/// The multiscale correlation RMSE between two analyses for levels `1..=min` of both, in
/// level order, directions H, V, D.
pub fn multiscale_rmse(a: &Analysis, b: &Analysis) -> Vec<LevelRmse> {
    a.levels
        .iter()
        .zip(&b.levels)
        .flat_map(|(la, lb)| {
            Direction::ALL.map(|d| {
                let (rmse, cells) = map_rmse(la.correlation(d), lb.correlation(d));
                LevelRmse {
                    level: la.level,
                    direction: d,
                    rmse,
                    cells,
                }
            })
        })
        .collect()
}

/// The dissertation's summaries (Tables 6 and 11): the mean of the RMSEs over the directions of
/// level 1 (`average_level_1`) and over the directions of levels 1 to 3 (`average_levels_1_3`;
/// `None` with fewer than 3 levels).
pub fn rmse_summaries(rows: &[LevelRmse]) -> (f64, Option<f64>) {
    let mean = |max_level: usize| {
        let v: Vec<f64> = rows
            .iter()
            .filter(|r| r.level <= max_level)
            .map(|r| r.rmse)
            .collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    let deepest = rows.iter().map(|r| r.level).max().unwrap_or(0);
    (mean(1), (deepest >= 3).then(|| mean(3)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_metric_kind_is_listed_once_and_parses_from_its_name() {
        // Exhaustive: a new kind must be given its place in ALL here.
        let place = |k: MetricKind| match k {
            MetricKind::KlPixel => 0,
            MetricKind::KlArea => 1,
            MetricKind::Cmd => 2,
            MetricKind::MultiscaleRmse => 3,
        };
        for (i, k) in MetricKind::ALL.into_iter().enumerate() {
            assert_eq!(place(k), i);
            assert_eq!(k.name().parse::<MetricKind>(), Ok(k));
        }
        assert_eq!(
            "kl".parse::<MetricKind>(),
            Err("unknown metric \"kl\"; known: kl_pixel, kl_area, cmd, multiscale_rmse".into())
        );
    }

    #[test]
    fn kl_of_hand_made_histograms() {
        // P = (1/2, 1/4, 1/4), Q = (1/4, 1/4, 1/2): D = 1/2 ln 2 + 1/4 ln(1/2) = ln(2) / 4.
        let d = kl_counts(&[2u32, 1, 1], &[1u32, 1, 2], 0.5, false);
        assert!((d - std::f64::consts::LN_2 / 4.0).abs() < 1e-15);
        // Reverse: 1/4 ln(1/2) + 1/2 ln 2 = ln(2) / 4 as well; symmetric is the sum.
        let s = kl_counts(&[2u32, 1, 1], &[1u32, 1, 2], 0.5, true);
        assert!((s - std::f64::consts::LN_2 / 2.0).abs() < 1e-15);
    }

    /// The re-splits' mean against the exact mean over every re-split, enumerated: the pooled
    /// values' bin labels, every choice of which `N` of them form the first set.
    #[test]
    fn resplits_converge_to_the_exact_mean_over_every_resplit() {
        let (p, q) = ([2u32, 0, 1, 1], [0u32, 2, 1, 0]);
        let labels: Vec<usize> = p
            .iter()
            .zip(&q)
            .enumerate()
            .flat_map(|(k, (a, b))| std::iter::repeat_n(k, (a + b) as usize))
            .collect();
        let n = p.iter().sum::<u32>() as usize;
        let kl = |a: &[u32], b: &[u32]| kl_counts(a, b, 0.5, true);
        let (mut exact, mut splits) = (0.0, 0usize);
        for mask in 0u32..1 << labels.len() {
            if mask.count_ones() as usize != n {
                continue;
            }
            let (mut a, mut b) = (vec![0u32; 4], vec![0u32; 4]);
            for (i, &k) in labels.iter().enumerate() {
                if mask >> i & 1 == 1 {
                    a[k] += 1;
                } else {
                    b[k] += 1;
                }
            }
            exact += kl(&a, &b);
            splits += 1;
        }
        exact /= splits as f64;
        let draws = 40_000;
        let got = resplit_mean(&p, &q, 7, draws, &kl);
        // The KL of one re-split lies in [0, 3] here: 4 standard errors are below 0.06.
        assert!(
            (got - exact).abs() < 4.0 * 1.5 / (draws as f64).sqrt(),
            "{got} vs {exact}"
        );
        // The split's sizes (4 and 3) are kept.
        assert!(
            resplit_mean(&p, &q, 7, 50, &|a, b| {
                (a.iter().sum::<u32>() == 4 && b.iter().sum::<u32>() == 3) as u8 as f64
            }) == 1.0
        );
    }

    /// Two independent stacks of one distribution: the floor `c = E[KL] / (1/N + 1/M)` of the
    /// symmetric KL averaged over bins (32 bins, 0.5 pseudo-counts) is that of every value the
    /// dissertation prints (Tables 13-15: 0.72-0.75 per pixel at N = M = 100, 0.92-0.94 per 8x8
    /// area at 6400 values a side); the sum over bins (the default) is about 32 times that;
    /// the re-split correction brings it near zero.
    #[test]
    fn the_floor_law_of_each_estimator() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2020);
        let mut stack = |n: usize| {
            ndarray::Array3::from_shape_simple_fn((n, 32, 32), || {
                let (re, im): (f64, f64) = (
                    StandardNormal.sample(&mut rng),
                    StandardNormal.sample(&mut rng),
                );
                Complex::new(re, im)
            })
        };
        let (a, b) = (stack(100), stack(100));
        let floor = |block: usize, o: KlOptions| {
            let maps = kl_maps(a.view(), b.view(), block, &o);
            let s = 2.0 / (100.0 * (block * block) as f64);
            (finite_mean(&maps[0]).0 + finite_mean(&maps[1]).0) / 2.0 / s
        };
        let printed = KlOptions {
            symmetric: true,
            mean_over_bins: true,
            ..KlOptions::default()
        };
        let pixel = floor(1, printed);
        let area = floor(8, printed);
        eprintln!("c: per pixel {pixel:.3}, per area {area:.3}");
        assert!((0.6..0.85).contains(&pixel), "per pixel c = {pixel}");
        assert!((0.85..1.0).contains(&area), "per area c = {area}");
        let summed = floor(
            1,
            KlOptions {
                mean_over_bins: false,
                ..printed
            },
        );
        assert!((summed / pixel - 32.0).abs() < 1e-9, "{summed} / {pixel}");
        let resplit = KlOptions {
            bias_correction: BiasCorrection::Resplit,
            ..printed
        };
        for (block, unit) in [(1, "pixel"), (8, "area")] {
            let corrected = floor(block, resplit);
            eprintln!("c corrected: per {unit} {corrected:.3}");
            assert!(
                corrected.abs() < 0.1,
                "corrected per {unit} c = {corrected}"
            );
        }
    }

    #[test]
    fn histogram_edges_include_both_ends() {
        assert_eq!(histogram(&[0.0, 0.5, 1.0, 0.99], 0.0, 1.0, 2), vec![1, 3]);
        assert_eq!(histogram(&[3.0, 3.0], 3.0, 3.0, 4), vec![2, 0, 0, 0]);
    }
}
