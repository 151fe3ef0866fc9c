//! Multiscale second-order analysis of a stack of complex images (dissertation ch. 3.3,
//! SPEC-NOTES section 2): per-pixel mean and variance, and for levels `1..=L` the directional
//! (H, V, D) correlation and covariance maps of neighbouring units inside non-overlapping 2x2
//! blocks, estimated without the full covariance matrix.
//!
//! Level-`L` units are unnormalised block sums of `2^(L-1) x 2^(L-1)` pixels (the unnormalised
//! 2x2 Haar approximation filter `[[1, 1], [1, 1]]` applied repeatedly; scaling does not change
//! correlations). For a cell with units `1` top-left, `2` top-right, `3` bottom-left and `4`
//! bottom-right, `c` the real part of the complex covariance and `s` the standard deviations:
//!
//! ```text
//! rho_H = (c12 + c34) / (s1 s2 + s3 s4)     cov_H = (c12 + c34) / 2
//! rho_V = (c13 + c24) / (s1 s3 + s2 s4)     cov_V = (c13 + c24) / 2
//! rho_D = (c14 + c23) / (s1 s4 + s2 s3)     cov_D = (c14 + c23) / 2
//! ```
//!
//! This is the closed-form solution of the 4x4 system of eq. 52 built from the variances of
//! the four Haar coefficients (with the signs of SPEC-NOTES, not the printed eq. 43); the
//! explicit solve is kept as a test oracle in [`crate::oracle`].
//!
//! The kernel reads the stack once, in its stored element type (no f64 copy of the input), and
//! accumulates in f64 with the shifted-data algorithm (Chan, Golub & LeVeque, 1983): every
//! pixel is shifted by its value in sample 0 before its moments are summed, which removes the
//! cancellation of the naive one-pass formula when the mean is large against the spread.
//! Work is split into horizontal bands of `2^L` rows; each band is owned by one task and
//! processed sample by sample in order, so the result is bitwise identical for any thread
//! count.

use ndarray::{Array2, ArrayView3};
use num_complex::{Complex, Complex64};
use rayon::prelude::*;
use std::fmt;

/// One of the three neighbour directions of the multiscale analysis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Direction {
    /// Horizontal neighbours: same row, adjacent columns (units 1-2 and 3-4).
    H,
    /// Vertical neighbours: same column, adjacent rows (units 1-3 and 2-4).
    V,
    /// Diagonal neighbours (units 1-4 and 2-3).
    D,
}

impl Direction {
    /// The three directions in table order.
    pub const ALL: [Direction; 3] = [Direction::H, Direction::V, Direction::D];

    /// The one-letter name used in output tables (`"H"`, `"V"`, `"D"`).
    pub fn as_str(self) -> &'static str {
        match self {
            Direction::H => "H",
            Direction::V => "V",
            Direction::D => "D",
        }
    }
}

impl fmt::Display for Direction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// An element type the analysis can read: complex or real, single or double precision.
pub trait Sample: Copy + Send + Sync + 'static {
    /// Real and imaginary parts in f64.
    fn parts(self) -> (f64, f64);
}

impl Sample for Complex<f32> {
    #[inline(always)]
    fn parts(self) -> (f64, f64) {
        (self.re as f64, self.im as f64)
    }
}

impl Sample for Complex<f64> {
    #[inline(always)]
    fn parts(self) -> (f64, f64) {
        (self.re, self.im)
    }
}

impl Sample for f32 {
    #[inline(always)]
    fn parts(self) -> (f64, f64) {
        (self as f64, 0.0)
    }
}

impl Sample for f64 {
    #[inline(always)]
    fn parts(self) -> (f64, f64) {
        (self, 0.0)
    }
}

/// Why an analysis cannot run on a stack.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum AnalysisError {
    /// Fewer than two samples: no variance can be estimated.
    #[error("the stack has {0} sample(s); at least 2 are needed to estimate variances")]
    TooFewSamples(usize),
    /// `levels` is zero.
    #[error("levels must be at least 1")]
    NoLevels,
    /// The image is too small for the requested number of levels.
    #[error(
        "{levels} level(s) need images of at least {need}x{need} pixels, the stack's are {height}x{width}"
    )]
    TooDeep {
        /// Requested levels.
        levels: usize,
        /// Minimum side length, `2^levels`.
        need: usize,
        /// Image height.
        height: usize,
        /// Image width.
        width: usize,
    },
}

/// Checks that `levels` fit an `height x width` image: `floor(side / 2^levels) >= 1`.
pub fn check_levels(levels: usize, height: usize, width: usize) -> Result<(), AnalysisError> {
    if levels == 0 {
        return Err(AnalysisError::NoLevels);
    }
    let need = 1usize.checked_shl(levels as u32).unwrap_or(usize::MAX);
    if levels >= usize::BITS as usize || height < need || width < need {
        return Err(AnalysisError::TooDeep {
            levels,
            need,
            height,
            width,
        });
    }
    Ok(())
}

/// Directional maps of one decomposition level.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelMaps {
    /// Decomposition level, starting at 1 (pixel neighbours).
    pub level: usize,
    /// Correlation maps indexed by `Direction as usize` (H, V, D); NaN where undefined.
    pub correlation: [Array2<f64>; 3],
    /// Covariance maps indexed like `correlation`.
    pub covariance: [Array2<f64>; 3],
}

/// Summary of one level and direction: means over the cells that are not NaN.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionSummary {
    /// Mean correlation over non-NaN cells (NaN if there are none).
    pub mean_correlation: f64,
    /// Mean covariance over non-NaN cells (NaN if there are none).
    pub mean_covariance: f64,
    /// Cells whose correlation is NaN (masked data or zero variance).
    pub nan_cells: usize,
}

impl LevelMaps {
    /// Map shape `(rows, cols)`: `floor(H / 2^level) x floor(W / 2^level)`.
    pub fn shape(&self) -> (usize, usize) {
        self.correlation[0].dim()
    }

    /// Correlation map of one direction.
    pub fn correlation(&self, dir: Direction) -> &Array2<f64> {
        &self.correlation[dir as usize]
    }

    /// Covariance map of one direction.
    pub fn covariance(&self, dir: Direction) -> &Array2<f64> {
        &self.covariance[dir as usize]
    }

    /// NaN-aware means of the correlation and covariance maps of `dir`.
    pub fn summary(&self, dir: Direction) -> DirectionSummary {
        let (mean_correlation, nan_cells) = nan_mean(self.correlation(dir));
        let (mean_covariance, _) = nan_mean(self.covariance(dir));
        DirectionSummary {
            mean_correlation,
            mean_covariance,
            nan_cells,
        }
    }
}

/// Mean of the non-NaN entries and the number of NaN entries.
pub fn nan_mean(map: &Array2<f64>) -> (f64, usize) {
    let (mut sum, mut count, mut nans) = (0.0, 0usize, 0usize);
    for &v in map.iter() {
        if v.is_nan() {
            nans += 1;
        } else {
            sum += v;
            count += 1;
        }
    }
    let mean = if count == 0 {
        f64::NAN
    } else {
        sum / count as f64
    };
    (mean, nans)
}

/// Result of the multiscale analysis of one stack.
#[derive(Clone, Debug, PartialEq)]
pub struct Analysis {
    /// Number of samples `N`.
    pub samples: usize,
    /// Per-pixel sample mean (`H x W`).
    pub mean: Array2<Complex64>,
    /// Per-pixel variance `E|x - mu|^2` with `1/N` normalisation (`H x W`).
    pub variance: Array2<f64>,
    /// Directional maps for levels `1..=L`.
    pub levels: Vec<LevelMaps>,
}

/// Runs the multiscale analysis of `stack` (`[N, H, W]`) for levels `1..=levels`.
///
/// Parallelism comes from the caller's rayon pool; results do not depend on its size.
///
/// # Errors
/// [`AnalysisError`] if `N < 2`, `levels == 0` or the image is smaller than `2^levels`.
///
/// # Example
/// ```
/// use isar_clutter::analysis::{analyse, Direction};
/// use ndarray::Array3;
/// // Two samples of a 2x2 image whose right column copies the left one: rho_H = 1.
/// let stack = Array3::from_shape_fn((2, 2, 2), |(n, r, _c)| (n * 2 + r) as f64 * (n as f64 - 0.5));
/// let a = analyse(stack.view(), 1).unwrap();
/// assert!((a.levels[0].correlation(Direction::H)[[0, 0]] - 1.0).abs() < 1e-12);
/// ```
pub fn analyse<T: Sample>(stack: ArrayView3<T>, levels: usize) -> Result<Analysis, AnalysisError> {
    let (n, h, w) = stack.dim();
    if n < 2 {
        return Err(AnalysisError::TooFewSamples(n));
    }
    check_levels(levels, h, w)?;
    let owned;
    let stack = if stack.is_standard_layout() {
        stack
    } else {
        owned = stack.as_standard_layout().into_owned();
        owned.view()
    };
    let data = stack.as_slice().expect("standard layout");
    let band = 1usize << levels;
    let bands: Vec<BandResult> = (0..h.div_ceil(band))
        .into_par_iter()
        .map(|b| {
            let r0 = b * band;
            analyse_band(data, n, h, w, r0, band.min(h - r0), levels)
        })
        .collect();
    Ok(assemble(bands, n, h, w, levels))
}

/// Accumulated and finalised statistics of one horizontal band.
struct BandResult {
    /// Finalised pixel means of the band's rows.
    mean: Vec<Complex64>,
    /// Finalised pixel variances of the band's rows.
    variance: Vec<f64>,
    /// Per level: six finalised maps (corr H, V, D, cov H, V, D) of the band's cell rows.
    levels: Vec<[Vec<f64>; 6]>,
}

/// Running sums of one level inside a band: unit moments and the six pair products.
struct LevelAcc {
    /// Unit grid of this level inside the band.
    urows: usize,
    ucols: usize,
    /// Unit values of the current sample (shifted), planar.
    re: Vec<f64>,
    im: Vec<f64>,
    /// Unit values of sample 0, the shift (used at level 1 only: covariances are shift
    /// invariant, so coarser levels inherit the block sums of the shifted pixels).
    shift: Vec<Complex64>,
    /// Sums of shifted unit values and of their squared moduli.
    sre: Vec<f64>,
    sim: Vec<f64>,
    sq: Vec<f64>,
    /// Pair sums per cell: 12, 34, 13, 24, 14, 23.
    pairs: [Vec<f64>; 6],
}

impl LevelAcc {
    fn new(urows: usize, ucols: usize) -> Self {
        let units = urows * ucols;
        let cells = (urows / 2) * (ucols / 2);
        LevelAcc {
            urows,
            ucols,
            re: vec![0.0; units],
            im: vec![0.0; units],
            shift: vec![Complex64::new(0.0, 0.0); units],
            sre: vec![0.0; units],
            sim: vec![0.0; units],
            sq: vec![0.0; units],
            pairs: std::array::from_fn(|_| vec![0.0; cells]),
        }
    }

    /// Adds the current unit values to the unit sums.
    fn add_moments(&mut self) {
        for k in 0..self.re.len() {
            let (a, b) = (self.re[k], self.im[k]);
            self.sre[k] += a;
            self.sim[k] += b;
            self.sq[k] += a * a + b * b;
        }
    }

    /// Adds the pair products of every complete cell, and writes the cell sums (the next
    /// level's units) into `next` when given.
    fn add_pairs(&mut self, mut next: Option<(&mut [f64], &mut [f64])>) {
        let (crows, ccols, uc) = (self.urows / 2, self.ucols / 2, self.ucols);
        let [p12, p34, p13, p24, p14, p23] = &mut self.pairs;
        for r in 0..crows {
            let top = 2 * r * uc;
            let bot = top + uc;
            let (tre, tim) = (&self.re[top..top + uc], &self.im[top..top + uc]);
            let (bre, bim) = (&self.re[bot..bot + uc], &self.im[bot..bot + uc]);
            let out = r * ccols;
            for c in 0..ccols {
                let (a1, b1) = (tre[2 * c], tim[2 * c]);
                let (a2, b2) = (tre[2 * c + 1], tim[2 * c + 1]);
                let (a3, b3) = (bre[2 * c], bim[2 * c]);
                let (a4, b4) = (bre[2 * c + 1], bim[2 * c + 1]);
                let k = out + c;
                p12[k] += a1 * a2 + b1 * b2;
                p34[k] += a3 * a4 + b3 * b4;
                p13[k] += a1 * a3 + b1 * b3;
                p24[k] += a2 * a4 + b2 * b4;
                p14[k] += a1 * a4 + b1 * b4;
                p23[k] += a2 * a3 + b2 * b3;
                if let Some((nre, nim)) = next.as_mut() {
                    nre[k] = a1 + a2 + a3 + a4;
                    nim[k] = b1 + b2 + b3 + b4;
                }
            }
        }
    }

    /// Finalises the six maps (corr H, V, D, cov H, V, D) of this level.
    fn finish(&self, n: usize) -> [Vec<f64>; 6] {
        let inv = 1.0 / n as f64;
        let (crows, ccols, uc) = (self.urows / 2, self.ucols / 2, self.ucols);
        let mut maps: [Vec<f64>; 6] = std::array::from_fn(|_| Vec::with_capacity(crows * ccols));
        let moments = |k: usize| {
            let (mr, mi) = (self.sre[k] * inv, self.sim[k] * inv);
            (
                (mr, mi),
                non_negative(self.sq[k] * inv - mr * mr - mi * mi).sqrt(),
            )
        };
        for r in 0..crows {
            for c in 0..ccols {
                let units = [
                    2 * r * uc + 2 * c,
                    2 * r * uc + 2 * c + 1,
                    (2 * r + 1) * uc + 2 * c,
                    (2 * r + 1) * uc + 2 * c + 1,
                ];
                let [(m1, s1), (m2, s2), (m3, s3), (m4, s4)] = units.map(moments);
                let k = r * ccols + c;
                let cov = |p: &Vec<f64>, a: (f64, f64), b: (f64, f64)| {
                    p[k] * inv - (a.0 * b.0 + a.1 * b.1)
                };
                let [p12, p34, p13, p24, p14, p23] = &self.pairs;
                let sums = [
                    (cov(p12, m1, m2) + cov(p34, m3, m4), s1 * s2 + s3 * s4),
                    (cov(p13, m1, m3) + cov(p24, m2, m4), s1 * s3 + s2 * s4),
                    (cov(p14, m1, m4) + cov(p23, m2, m3), s1 * s4 + s2 * s3),
                ];
                for (d, (csum, denom)) in sums.into_iter().enumerate() {
                    let (corr, cov) = cell_stats(csum, denom);
                    maps[d].push(corr);
                    maps[3 + d].push(cov);
                }
            }
        }
        maps
    }
}

/// Correlation and covariance of one cell and direction from the summed pair covariance and
/// the summed products of standard deviations. A zero denominator (zero-variance units) gives
/// a NaN correlation and a zero covariance; NaN input stays NaN.
#[inline]
pub(crate) fn cell_stats(csum: f64, denom: f64) -> (f64, f64) {
    if denom == 0.0 {
        (f64::NAN, 0.0)
    } else {
        (csum / denom, csum / 2.0)
    }
}

/// Clamps rounding-negative variances to 0 and keeps NaN (unlike `f64::max`).
#[inline]
fn non_negative(v: f64) -> f64 {
    if v < 0.0 {
        0.0
    } else {
        v
    }
}

/// Analyses rows `r0 .. r0 + rows` of every sample.
fn analyse_band(
    data: &[impl Sample],
    n: usize,
    h: usize,
    w: usize,
    r0: usize,
    rows: usize,
    levels: usize,
) -> BandResult {
    let mut accs: Vec<LevelAcc> = (0..levels)
        .map(|l| LevelAcc::new(rows >> l, w >> l))
        .collect();
    let plane = h * w;
    let base = r0 * w;
    for s in 0..n {
        let src = &data[s * plane + base..s * plane + base + rows * w];
        load_units(src, &mut accs[0], s == 0);
        for l in 0..levels {
            let (cur, rest) = accs[l..].split_first_mut().expect("level exists");
            cur.add_moments();
            match rest.first_mut() {
                Some(next) => cur.add_pairs(Some((&mut next.re, &mut next.im))),
                None => cur.add_pairs(None),
            }
        }
    }
    let finished = accs.iter().map(|a| a.finish(n)).collect();
    let pixels = &accs[0];
    let inv = 1.0 / n as f64;
    let mut mean = Vec::with_capacity(rows * w);
    let mut variance = Vec::with_capacity(rows * w);
    for k in 0..rows * w {
        let (mr, mi) = (pixels.sre[k] * inv, pixels.sim[k] * inv);
        mean.push(pixels.shift[k] + Complex64::new(mr, mi));
        variance.push(non_negative(pixels.sq[k] * inv - mr * mr - mi * mi));
    }
    BandResult {
        mean,
        variance,
        levels: finished,
    }
}

/// Loads one sample's band into the level-1 unit buffers, shifted by sample 0.
fn load_units(src: &[impl Sample], acc: &mut LevelAcc, first: bool) {
    if first {
        for (k, v) in src.iter().enumerate() {
            let (a, b) = v.parts();
            acc.shift[k] = Complex64::new(a, b);
        }
    }
    for (k, v) in src.iter().enumerate() {
        let (a, b) = v.parts();
        let s = acc.shift[k];
        acc.re[k] = a - s.re;
        acc.im[k] = b - s.im;
    }
}

/// Stitches band results into full maps.
fn assemble(bands: Vec<BandResult>, n: usize, h: usize, w: usize, levels: usize) -> Analysis {
    let mut mean = Vec::with_capacity(h * w);
    let mut variance = Vec::with_capacity(h * w);
    let mut maps: Vec<[Vec<f64>; 6]> = (0..levels).map(|_| Default::default()).collect();
    for band in bands {
        mean.extend(band.mean);
        variance.extend(band.variance);
        for (dst, src) in maps.iter_mut().zip(band.levels) {
            for (d, s) in dst.iter_mut().zip(src) {
                d.extend(s);
            }
        }
    }
    let levels = maps
        .into_iter()
        .enumerate()
        .map(|(l, m)| {
            let shape = (h >> (l + 1), w >> (l + 1));
            let mut it = m
                .into_iter()
                .map(|v| Array2::from_shape_vec(shape, v).expect("band maps tile the level"));
            let mut next = || it.next().expect("six maps");
            let correlation = [next(), next(), next()];
            let covariance = [next(), next(), next()];
            LevelMaps {
                level: l + 1,
                correlation,
                covariance,
            }
        })
        .collect();
    Analysis {
        samples: n,
        mean: Array2::from_shape_vec((h, w), mean).expect("bands tile the image"),
        variance: Array2::from_shape_vec((h, w), variance).expect("bands tile the image"),
        levels,
    }
}
