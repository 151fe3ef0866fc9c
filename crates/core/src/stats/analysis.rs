//! Multiscale second-order analysis of a stack of complex images (dissertation ch. 3.3,
//! docs/definitions.md §3): per-pixel mean and variance, and for levels `1..=L` the directional
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
//! the four Haar coefficients (with the signs that follow from the printed filters, not those
//! of the printed eq. 43; docs/definitions.md §3); the explicit solve is kept as a test oracle
//! in [`crate::stats::oracle`].
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
    /// Writes the interleaved components `[re0, im0, re1, im1, ...]` of `src`, minus those of
    /// `shift` (same length, converted to f64 alike), into `x` (length `2 * src.len()`), and
    /// adds them and their squares to `s` and `q`.
    fn load_shifted(src: &[Self], shift: &[Self], x: &mut [f64], s: &mut [f64], q: &mut [f64]);

    /// The interleaved components of `v` as f64 (the imaginary part of real input is 0).
    fn components(v: Self) -> [f64; 2];
}

/// The shared body of [`Sample::load_shifted`] over a flat slice of components.
#[inline(always)]
fn load_components<C: Copy + Into<f64>>(
    comp: &[C],
    shift: &[C],
    x: &mut [f64],
    s: &mut [f64],
    q: &mut [f64],
) {
    let n = comp.len();
    let (shift, x, s, q) = (&shift[..n], &mut x[..n], &mut s[..n], &mut q[..n]);
    for k in 0..n {
        let v = comp[k].into() - shift[k].into();
        x[k] = v;
        s[k] += v;
        q[k] += v * v;
    }
}

impl Sample for Complex<f32> {
    #[inline(always)]
    fn load_shifted(src: &[Self], shift: &[Self], x: &mut [f64], s: &mut [f64], q: &mut [f64]) {
        load_components(
            bytemuck::cast_slice::<_, f32>(src),
            bytemuck::cast_slice::<_, f32>(shift),
            x,
            s,
            q,
        )
    }

    fn components(v: Self) -> [f64; 2] {
        [v.re.into(), v.im.into()]
    }
}

impl Sample for Complex<f64> {
    #[inline(always)]
    fn load_shifted(src: &[Self], shift: &[Self], x: &mut [f64], s: &mut [f64], q: &mut [f64]) {
        load_components(
            bytemuck::cast_slice::<_, f64>(src),
            bytemuck::cast_slice::<_, f64>(shift),
            x,
            s,
            q,
        )
    }

    fn components(v: Self) -> [f64; 2] {
        [v.re, v.im]
    }
}

/// Real input: the imaginary component is zero (and so is its shift).
#[inline(always)]
fn load_real<C: Copy + Into<f64>>(
    src: &[C],
    shift: &[C],
    x: &mut [f64],
    s: &mut [f64],
    q: &mut [f64],
) {
    for (k, v) in src.iter().enumerate() {
        let v = (*v).into() - shift[k].into();
        x[2 * k] = v;
        x[2 * k + 1] = 0.0;
        s[2 * k] += v;
        q[2 * k] += v * v;
    }
}

impl Sample for f32 {
    #[inline(always)]
    fn load_shifted(src: &[Self], shift: &[Self], x: &mut [f64], s: &mut [f64], q: &mut [f64]) {
        load_real(src, shift, x, s, q)
    }

    fn components(v: Self) -> [f64; 2] {
        [v.into(), 0.0]
    }
}

impl Sample for f64 {
    #[inline(always)]
    fn load_shifted(src: &[Self], shift: &[Self], x: &mut [f64], s: &mut [f64], q: &mut [f64]) {
        load_real(src, shift, x, s, q)
    }

    fn components(v: Self) -> [f64; 2] {
        [v, 0.0]
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
/// use isar_clutter_core::stats::analysis::{analyse, Direction};
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
            let rows = band.min(h - r0);
            analyse_band(
                data,
                Band {
                    n,
                    h,
                    w,
                    r0,
                    rows,
                    levels,
                },
            )
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

/// Accumulators of one cell: twelve lane sums, the real and imaginary halves of the six pair
/// products `Re(a conj b) = a.re b.re + a.im b.im`, kept apart so the loop is element-wise.
const CELL: usize = 12;
/// Lane offsets inside a cell's accumulators (real half; the imaginary half follows).
const P13: usize = 0;
const P24: usize = 2;
const P14: usize = 4;
const P23: usize = 6;
const P12: usize = 8;
const P34: usize = 10;

/// Running sums of one level inside a band. Components are interleaved (`[re, im]` per unit,
/// row-major). Only level 1 accumulates unit moments per sample; a coarser unit is the sum of
/// four finer ones, so its moments follow exactly from the finer level's moments and pair sums
/// (see [`LevelAcc::coarser_moments`]).
struct LevelAcc {
    /// Unit grid of this level inside the band.
    urows: usize,
    ucols: usize,
    /// Unit components of the current sample (shifted); level 1 uses only the front, for the
    /// two pixel rows being paired.
    x: Vec<f64>,
    /// Sums of shifted components (level 1: accumulated; coarser: derived at the end).
    s: Vec<f64>,
    /// Sums of squared shifted components, per component (as `s`).
    q: Vec<f64>,
    /// Pair sums, `CELL` lanes per complete cell.
    pairs: Vec<f64>,
}

/// The three 4-lane products of one cell (`t = [u1.re, u1.im, u2.re, u2.im]`,
/// `b = [u3.re, u3.im, u4.re, u4.im]`) added to its accumulators, one vector multiply and add
/// each on 256-bit targets; returns the cell sum (the coarser unit).
#[inline(always)]
fn accumulate_cell(t: [f64; 4], b: [f64; 4], a: &mut [f64; CELL]) -> [f64; 2] {
    let swapped = [b[2], b[3], b[0], b[1]];
    let (left, right) = ([t[0], t[1], b[0], b[1]], [t[2], t[3], b[2], b[3]]);
    for i in 0..4 {
        a[P13 + i] += t[i] * b[i]; // P13, then P24
        a[P14 + i] += t[i] * swapped[i]; // P14, then P23
        a[P12 + i] += left[i] * right[i]; // P12, then P34
    }
    [(t[0] + t[2]) + (b[0] + b[2]), (t[1] + t[3]) + (b[1] + b[3])]
}

/// One row of cells: `top` and `bot` hold the components of the cells' upper and lower units
/// (4 per cell), `acc` their accumulators; the cell sums go to `out` when given.
#[inline(always)]
fn add_cell_row(top: &[f64], bot: &[f64], acc: &mut [f64], mut out: Option<&mut [f64]>) {
    for (c, ((t, b), a)) in top
        .chunks_exact(4)
        .zip(bot.chunks_exact(4))
        .zip(acc.chunks_exact_mut(CELL))
        .enumerate()
    {
        let t: [f64; 4] = t.try_into().expect("chunk of 4");
        let b: [f64; 4] = b.try_into().expect("chunk of 4");
        let sum = accumulate_cell(t, b, a.try_into().expect("chunk of CELL"));
        if let Some(o) = out.as_deref_mut() {
            o[2 * c..2 * c + 2].copy_from_slice(&sum);
        }
    }
}

impl LevelAcc {
    fn new(urows: usize, ucols: usize) -> Self {
        let comps = 2 * urows * ucols;
        LevelAcc {
            urows,
            ucols,
            x: vec![0.0; comps],
            s: vec![0.0; comps],
            q: vec![0.0; comps],
            pairs: vec![0.0; (urows / 2) * (ucols / 2) * CELL],
        }
    }

    /// Level 1: loads one sample's band (shifted), two pixel rows at a time, into the front of
    /// `x` (so the loaded values are still in L1 when their pairs are formed), adds them to the
    /// moment sums, and adds the pairs of that row of cells.
    #[inline(always)]
    fn add_pixels<T: Sample>(&mut self, src: &[T], shift: &[T], mut next: Option<&mut [f64]>) {
        let (ccols, w) = (self.ucols / 2, self.ucols);
        // Rows 2r and 2r + 1 (an odd last row alone: it belongs to no cell, only to the moments).
        for r in 0..self.urows.div_ceil(2) {
            let px = 2 * r * w..((2 * r + 2) * w).min(self.urows * w);
            let comps = 2 * px.start..2 * px.end;
            let x = &mut self.x[..comps.len()];
            T::load_shifted(
                &src[px.clone()],
                &shift[px],
                x,
                &mut self.s[comps.clone()],
                &mut self.q[comps],
            );
            if x.len() == 4 * w {
                let (top, bot) = x.split_at(2 * w);
                add_cell_row(
                    &top[..4 * ccols],
                    &bot[..4 * ccols],
                    &mut self.pairs[r * ccols * CELL..][..ccols * CELL],
                    next.as_deref_mut()
                        .map(|n| &mut n[r * 2 * ccols..][..2 * ccols]),
                );
            }
        }
    }

    /// Adds the pair products of every complete cell of the current unit values `x`, and
    /// writes the cell sums (the next level's units) into `next` when given.
    #[inline(always)]
    fn add_pairs(&mut self, mut next: Option<&mut [f64]>) {
        let (crows, ccols, row) = (self.urows / 2, self.ucols / 2, 2 * self.ucols);
        for r in 0..crows {
            add_cell_row(
                &self.x[2 * r * row..][..4 * ccols],
                &self.x[(2 * r + 1) * row..][..4 * ccols],
                &mut self.pairs[r * ccols * CELL..][..ccols * CELL],
                next.as_deref_mut()
                    .map(|n| &mut n[r * 2 * ccols..][..2 * ccols]),
            );
        }
    }

    /// Moment sums of the next level's units (this level's cells): for `U = u1 + u2 + u3 + u4`
    /// and each component, `sum U = sum of sum u_i` and
    /// `sum U^2 = sum of sum u_i^2 + 2 * sum over the six pairs of sum u_i u_j`.
    fn coarser_moments(&self, next: &mut LevelAcc) {
        let (ccols, uc) = (self.ucols / 2, self.ucols);
        for r in 0..self.urows / 2 {
            for c in 0..ccols {
                let units = [
                    2 * r * uc + 2 * c,
                    2 * r * uc + 2 * c + 1,
                    (2 * r + 1) * uc + 2 * c,
                    (2 * r + 1) * uc + 2 * c + 1,
                ];
                let a = &self.pairs[(r * ccols + c) * CELL..][..CELL];
                let k = r * ccols + c;
                for lane in 0..2 {
                    let pairs: f64 = [P13, P24, P14, P23, P12, P34]
                        .iter()
                        .map(|p| a[p + lane])
                        .sum();
                    next.s[2 * k + lane] = units.iter().map(|u| self.s[2 * u + lane]).sum();
                    next.q[2 * k + lane] =
                        units.iter().map(|u| self.q[2 * u + lane]).sum::<f64>() + 2.0 * pairs;
                }
            }
        }
    }

    /// Finalises the six maps (corr H, V, D, cov H, V, D) of this level.
    fn finish(&self, n: usize) -> [Vec<f64>; 6] {
        let inv = 1.0 / n as f64;
        let (crows, ccols, uc) = (self.urows / 2, self.ucols / 2, self.ucols);
        let mut maps: [Vec<f64>; 6] = std::array::from_fn(|_| Vec::with_capacity(crows * ccols));
        // Shifted mean and standard deviation of unit k.
        let moments = |k: usize| {
            let (mr, mi) = (self.s[2 * k] * inv, self.s[2 * k + 1] * inv);
            let var = (self.q[2 * k] + self.q[2 * k + 1]) * inv - mr * mr - mi * mi;
            ((mr, mi), non_negative(var).sqrt())
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
                let a = &self.pairs[(r * ccols + c) * CELL..][..CELL];
                let cov = |lane: usize, x: (f64, f64), y: (f64, f64)| {
                    (a[lane] + a[lane + 1]) * inv - (x.0 * y.0 + x.1 * y.1)
                };
                let sums = [
                    (cov(P12, m1, m2) + cov(P34, m3, m4), s1 * s2 + s3 * s4),
                    (cov(P13, m1, m3) + cov(P24, m2, m4), s1 * s3 + s2 * s4),
                    (cov(P14, m1, m4) + cov(P23, m2, m3), s1 * s4 + s2 * s3),
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

/// The directional statistics `[(rho, cov); 3]` (H, V, D) of the level cell at `(r, c)` from a
/// function giving the covariance of two units by their `(row, col)` (a unit with itself: its
/// variance). The definition the kernel's closed form implements, shared by the slow oracle and
/// the exact expected maps.
pub fn cell_directions(
    r: usize,
    c: usize,
    cov: impl Fn((usize, usize), (usize, usize)) -> f64,
) -> [(f64, f64); 3] {
    let u = [
        (2 * r, 2 * c),
        (2 * r, 2 * c + 1),
        (2 * r + 1, 2 * c),
        (2 * r + 1, 2 * c + 1),
    ];
    let s: Vec<f64> = u.iter().map(|&a| cov(a, a).sqrt()).collect();
    let cv = |i: usize, j: usize| cov(u[i], u[j]);
    [
        cell_stats(cv(0, 1) + cv(2, 3), s[0] * s[1] + s[2] * s[3]),
        cell_stats(cv(0, 2) + cv(1, 3), s[0] * s[2] + s[1] * s[3]),
        cell_stats(cv(0, 3) + cv(1, 2), s[0] * s[3] + s[1] * s[2]),
    ]
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

/// Hints the CPU to fetch `next` (the band of the next sample, one page-strided block that the
/// hardware prefetcher does not predict) into the cache while the current sample is processed.
#[inline(always)]
fn prefetch<T>(next: &[T]) {
    #[cfg(target_arch = "x86_64")]
    {
        let bytes = std::mem::size_of_val(next);
        let base = next.as_ptr() as *const i8;
        for off in (0..bytes).step_by(64) {
            // SAFETY: the address lies inside `next`; a prefetch never faults or writes.
            unsafe {
                std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(base.add(off))
            };
        }
    }
}

/// Geometry of one band: `rows` rows starting at `r0` of an `n x h x w` stack.
#[derive(Clone, Copy)]
struct Band {
    n: usize,
    h: usize,
    w: usize,
    r0: usize,
    rows: usize,
    levels: usize,
}

/// Analyses one band, with AVX2 code generation where the CPU has it (the arithmetic and its
/// order are the same on every path, so results are bitwise identical).
fn analyse_band<T: Sample>(data: &[T], band: Band) -> BandResult {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { analyse_band_avx2(data, band) };
        }
    }
    analyse_band_body(data, band)
}

/// [`analyse_band_body`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn analyse_band_avx2<T: Sample>(data: &[T], band: Band) -> BandResult {
    analyse_band_body(data, band)
}

/// Analyses rows `r0 .. r0 + rows` of every sample.
#[inline(always)]
fn analyse_band_body<T: Sample>(data: &[T], band: Band) -> BandResult {
    let Band {
        n,
        h,
        w,
        r0,
        rows,
        levels,
    } = band;
    let mut accs: Vec<LevelAcc> = (0..levels)
        .map(|l| LevelAcc::new(rows >> l, w >> l))
        .collect();
    let plane = h * w;
    let span = r0 * w..(r0 + rows) * w;
    // The shift: sample 0's pixels, read in their stored type (half the cache footprint of
    // f64 components) and converted like every sample.
    let shift = &data[span.clone()];
    for sample in 0..n {
        let src = &data[sample * plane + span.start..sample * plane + span.end];
        if sample + 1 < n {
            prefetch(&data[(sample + 1) * plane + span.start..(sample + 1) * plane + span.end]);
        }
        let (first, rest) = accs.split_first_mut().expect("at least one level");
        first.add_pixels(
            src,
            shift,
            rest.first_mut().map(|next| next.x.as_mut_slice()),
        );
        for l in 1..levels {
            let (cur, rest) = accs[l..].split_first_mut().expect("level exists");
            cur.add_pairs(rest.first_mut().map(|next| next.x.as_mut_slice()));
        }
    }
    for l in 1..levels {
        let (finer, coarser) = accs.split_at_mut(l);
        finer[l - 1].coarser_moments(&mut coarser[0]);
    }
    let finished = accs.iter().map(|a| a.finish(n)).collect();
    let px = &accs[0];
    let inv = 1.0 / n as f64;
    let mut mean = Vec::with_capacity(rows * w);
    let mut variance = Vec::with_capacity(rows * w);
    for ((&sh, s), q) in shift
        .iter()
        .zip(px.s.chunks_exact(2))
        .zip(px.q.chunks_exact(2))
    {
        let (mr, mi) = (s[0] * inv, s[1] * inv);
        let [sr, si] = T::components(sh);
        mean.push(Complex64::new(sr + mr, si + mi));
        variance.push(non_negative((q[0] + q[1]) * inv - mr * mr - mi * mi));
    }
    BandResult {
        mean,
        variance,
        levels: finished,
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
