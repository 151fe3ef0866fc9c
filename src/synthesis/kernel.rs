//! The spatially varying filter of Methods 1 and 2 in sample format 2: the same separable
//! filter as [`crate::stats::filters::filter_seed`] (eq. 33), applied in `f32` to the
//! format's white seed ([`crate::seeds::normal`]) with the multiply-adds shared wherever the
//! fitted parameters allow.
//!
//! Every fitted filter is symmetric (`f(d) = f(-d)`), and the taps of a pixel take few distinct
//! values over the offsets: offsets `d >= 1` whose taps are equal at *every* pixel form a
//! class (Method 2: `{1}, {2, 3}, {4..7}`, its dyadic bands; Method 1: one class per offset).
//! For each seed row the class sums `B_t(j) = sum_{d in t} (w(j + d) + w(j - d))` are formed
//! once and shared by every output row that reads the row; an output row group whose pixels
//! share their horizontal taps (the two rows of a level-1 cell) forms
//! `H(r, j) = sum_t c_t(j) B_t(r, j)`, one multiply-add per class instead of one per tap,
//! and each output pixel then weights the vertical class sums of `H` by its vertical
//! coefficients, into which the output scale `std / sd(y)` is folded. Per pixel of a 64 x 64
//! model with half-width 8: about 3 + 1.5 x 18 (Method 2) or 9 + 4.5 x 18 (Method 1)
//! multiply-adds per component for the horizontal pass and as many vertical terms as classes,
//! against 17 x 9 + 17 for the direct sum with shared horizontal sums.
//!
//! Multiply-adds are fused (`f32::mul_add`), so results are the same bits with or without the
//! AVX2 + FMA path (which only compiles the same loops for those instructions). The direct
//! double sum in `f64` ([`crate::stats::filters::filter_pixel_direct`]) is the oracle of the
//! tests: the two agree to `f32` rounding.

use crate::stats::filters::FilterBank;
use ndarray::Array2;
use num_complex::{Complex32, Complex64};

/// Columns per register block of the kernel: 4 AVX2 vectors per component, so that 8
/// independent multiply-add chains hide the instruction's latency (with one vector per
/// component the chains' latency, not the arithmetic, bounded the kernel to a quarter of its
/// speed).
const B: usize = 32;

/// A Method 1 or 2 filter bank prepared for sample format 2 (see the module documentation).
#[derive(Debug, Clone)]
pub struct FastFilter {
    h: usize,
    w: usize,
    k: usize,
    /// Offset classes of the horizontal taps (offsets `>= 1` with a non-zero tap somewhere).
    hclass: Vec<Vec<usize>>,
    /// Offset classes of the vertical taps.
    vclass: Vec<Vec<usize>>,
    /// Largest offset in a vertical class (0 if none): the seed rows an output row reads.
    reach_v: usize,
    /// Runs `[start, end)` of output rows with identical horizontal taps.
    groups: Vec<(usize, usize)>,
    /// `[group][1 + hclass][w]`: the centre tap, then one coefficient per class.
    hcoef: Vec<f32>,
    /// `[row][1 + vclass][w]`: the same for the vertical taps, times `std / sd(y)`.
    vcoef: Vec<f32>,
    /// Mean per pixel, real parts then imaginary parts (`[2][h * w]`).
    mean: Vec<f32>,
}

/// Per-thread working memory of [`FastFilter::sample`].
#[derive(Debug, Default)]
pub struct Scratch {
    words: Vec<u32>,
    re: Vec<f32>,
    im: Vec<f32>,
    basis: Vec<f32>,
    hsum: Vec<f32>,
}

impl Scratch {
    /// The first `n` complex normals of stream `index` of `seed` (format 2), as real and
    /// imaginary parts.
    pub fn normals(&mut self, seed: u64, index: usize, n: usize) -> (&[f32], &[f32]) {
        self.re.resize(n, 0.0);
        self.im.resize(n, 0.0);
        crate::seeds::normal::complex_normals(
            seed,
            index as u64,
            &mut self.words,
            &mut self.re,
            &mut self.im,
        );
        (&self.re, &self.im)
    }
}

/// The classes of offsets `1..=k` of `taps` (one `2k + 1` vector per pixel): offsets whose taps
/// are equal at every pixel, in order of their first offset; offsets whose tap is zero at
/// every pixel are left out.
fn classes(taps: &[Vec<f64>], k: usize) -> Vec<Vec<usize>> {
    let mut out: Vec<Vec<usize>> = Vec::new();
    for d in 1..=k {
        if taps.iter().all(|t| t[k + d] == 0.0) {
            continue;
        }
        match out
            .iter_mut()
            .find(|c| taps.iter().all(|t| t[k + c[0]] == t[k + d]))
        {
            Some(c) => c.push(d),
            None => out.push(vec![d]),
        }
    }
    out
}

impl FastFilter {
    /// Prepares `bank` (per-pixel symmetric taps, as Methods 1 and 2 fit them) for a model
    /// with per-pixel `mean` and `std`.
    ///
    /// # Panics
    /// If a tap is not symmetric (`f(d) != f(-d)`) or the maps do not match the bank.
    pub fn new(bank: &FilterBank, mean: &Array2<Complex64>, std: &Array2<f64>) -> Self {
        let (h, w, k) = (bank.height, bank.width, bank.half_width);
        assert_eq!(mean.dim(), (h, w));
        assert_eq!(std.dim(), (h, w));
        for t in bank.vertical.iter().chain(&bank.horizontal) {
            assert!(
                (1..=k).all(|d| t[k + d] == t[k - d]),
                "sample format 2 needs symmetric taps"
            );
        }
        let hclass = classes(&bank.horizontal, k);
        let vclass = classes(&bank.vertical, k);
        let reach_v = vclass.iter().flatten().copied().max().unwrap_or(0);
        let mut groups: Vec<(usize, usize)> = Vec::new();
        let same_row = |a: usize, b: usize| {
            (0..w).all(|j| bank.horizontal[a * w + j] == bank.horizontal[b * w + j])
        };
        for i in 0..h {
            match groups.last_mut() {
                Some((g0, g1)) if same_row(*g0, i) => *g1 = i + 1,
                _ => groups.push((i, i + 1)),
            }
        }
        let coefficients = |taps: &[f64], class: &[Vec<usize>], scale: f64| {
            std::iter::once(taps[k] * scale)
                .chain(class.iter().map(|c| taps[k + c[0]] * scale))
                .map(|x| x as f32)
                .collect::<Vec<_>>()
        };
        let arrange =
            |rows: &mut dyn Iterator<Item = usize>, n: usize, f: &dyn Fn(usize) -> Vec<f32>| {
                let mut out = Vec::new();
                for i in rows {
                    let per: Vec<Vec<f32>> = (0..w).map(|j| f(i * w + j)).collect();
                    for t in 0..n {
                        out.extend(per.iter().map(|c| c[t]));
                    }
                }
                out
            };
        let hcoef = arrange(&mut groups.iter().map(|g| g.0), 1 + hclass.len(), &|p| {
            coefficients(&bank.horizontal[p], &hclass, 1.0)
        });
        let sds = bank.output_sds();
        let std = std.as_slice().expect("standard layout");
        let vcoef = arrange(&mut (0..h), 1 + vclass.len(), &|p| {
            coefficients(&bank.vertical[p], &vclass, std[p] / sds[p])
        });
        let mean = mean
            .iter()
            .map(|z| z.re as f32)
            .chain(mean.iter().map(|z| z.im as f32))
            .collect();
        FastFilter {
            h,
            w,
            k,
            hclass,
            vclass,
            reach_v,
            groups,
            hcoef,
            vcoef,
            mean,
        }
    }

    /// Complex values of the padded white seed, `(h + 2k) (w + 2k)`.
    pub fn seed_len(&self) -> usize {
        (self.h + 2 * self.k) * (self.w + 2 * self.k)
    }

    /// Sample `index` of the generation seeded by `seed` (format 2) into `out` (`h * w`).
    pub fn sample(&self, seed: u64, index: usize, scratch: &mut Scratch, out: &mut [Complex32]) {
        scratch.normals(seed, index, self.seed_len());
        self.filter(scratch, out);
    }

    /// Filters the white seed held in `scratch.re`, `scratch.im` into `out`.
    fn filter(&self, scratch: &mut Scratch, out: &mut [Complex32]) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                // SAFETY: the CPU supports AVX2 and FMA, checked just above.
                return unsafe { self.filter_avx2(scratch, out) };
            }
        }
        self.filter_body(scratch, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn filter_avx2(&self, scratch: &mut Scratch, out: &mut [Complex32]) {
        self.filter_body(scratch, out)
    }

    /// Filters a white seed given in `f64` (the oracle tests' entry): `seed` row-major
    /// `(h + 2k) x (w + 2k)`.
    pub fn filter_seed(&self, seed: &[Complex64], out: &mut [Complex32]) {
        let mut scratch = Scratch {
            re: seed.iter().map(|z| z.re as f32).collect(),
            im: seed.iter().map(|z| z.im as f32).collect(),
            ..Scratch::default()
        };
        self.filter(&mut scratch, out);
    }

    #[inline(always)]
    fn filter_body(&self, scratch: &mut Scratch, out: &mut [Complex32]) {
        let (h, w, k) = (self.h, self.w, self.k);
        assert_eq!(out.len(), h * w);
        let sw = w + 2 * k;
        let nt = 1 + self.hclass.len();
        let nv = 1 + self.vclass.len();
        let rv = self.reach_v;
        // Seed rows any output row reads: k - rv .. h + k + rv.
        let (first, last) = (k - rv, h + k + rv);
        let stride = nt * 2 * w;
        scratch.basis.resize((last - first) * stride, 0.0);
        let (re, im) = (&scratch.re, &scratch.im);
        assert!(re.len() >= (h + 2 * k) * sw && im.len() == re.len());
        for r in first..last {
            let row = &mut scratch.basis[(r - first) * stride..][..stride];
            for (comp, src) in [re, im].into_iter().enumerate() {
                let src = &src[r * sw..][..sw];
                row[comp * w..][..w].copy_from_slice(&src[k..k + w]);
                for (t, class) in self.hclass.iter().enumerate() {
                    let dst = &mut row[((1 + t) * 2 + comp) * w..][..w];
                    for (c, &d) in class.iter().enumerate() {
                        let (a, b) = (&src[k + d..][..w], &src[k - d..][..w]);
                        if c == 0 {
                            for j in 0..w {
                                dst[j] = a[j] + b[j];
                            }
                        } else {
                            for j in 0..w {
                                dst[j] += a[j] + b[j];
                            }
                        }
                    }
                }
            }
        }
        let max_group = self.groups.iter().map(|g| g.1 - g.0).max().unwrap_or(0);
        scratch.hsum.resize((max_group + 2 * rv) * 2 * w, 0.0);
        for (gi, &(g0, g1)) in self.groups.iter().enumerate() {
            let coef = &self.hcoef[gi * nt * w..][..nt * w];
            let rows = g1 - g0 + 2 * rv;
            // Horizontal: H rows of the group, seed rows g0 + k - rv ...
            for lr in 0..rows {
                let basis = &scratch.basis[(g0 + k - rv + lr - first) * stride..][..stride];
                let hrow = &mut scratch.hsum[lr * 2 * w..][..2 * w];
                let mut j = 0;
                while j + B <= w {
                    horizontal::<B>(coef, basis, w, nt, j, hrow);
                    j += B;
                }
                while j + 8 <= w {
                    horizontal::<8>(coef, basis, w, nt, j, hrow);
                    j += 8;
                }
                while j < w {
                    horizontal::<1>(coef, basis, w, nt, j, hrow);
                    j += 1;
                }
            }
            // Vertical: each output row weights the class sums of its H column.
            for i in g0..g1 {
                let vc = &self.vcoef[i * nv * w..][..nv * w];
                let centre = i - g0 + rv;
                let o = &mut out[i * w..][..w];
                let mean = (&self.mean[i * w..][..w], &self.mean[h * w + i * w..][..w]);
                let mut j = 0;
                while j + B <= w {
                    vertical::<B>(vc, &scratch.hsum, &self.vclass, (w, centre, j), mean, o);
                    j += B;
                }
                while j + 8 <= w {
                    vertical::<8>(vc, &scratch.hsum, &self.vclass, (w, centre, j), mean, o);
                    j += 8;
                }
                while j < w {
                    vertical::<1>(vc, &scratch.hsum, &self.vclass, (w, centre, j), mean, o);
                    j += 1;
                }
            }
        }
    }
}

/// `N` columns from `j` of one horizontal row: `H = c_0 B_0 + sum_t c_t B_t` per component.
#[inline(always)]
fn horizontal<const N: usize>(
    coef: &[f32],
    basis: &[f32],
    w: usize,
    nt: usize,
    j: usize,
    hrow: &mut [f32],
) {
    let at = |s: &[f32], o: usize| -> [f32; N] { s[o + j..][..N].try_into().expect("a block") };
    let c0 = at(coef, 0);
    let (b0r, b0i) = (at(basis, 0), at(basis, w));
    let mut ar: [f32; N] = std::array::from_fn(|x| c0[x] * b0r[x]);
    let mut ai: [f32; N] = std::array::from_fn(|x| c0[x] * b0i[x]);
    for t in 1..nt {
        let c = at(coef, t * w);
        let (br, bi) = (at(basis, 2 * t * w), at(basis, (2 * t + 1) * w));
        for x in 0..N {
            ar[x] = c[x].mul_add(br[x], ar[x]);
            ai[x] = c[x].mul_add(bi[x], ai[x]);
        }
    }
    hrow[j..][..N].copy_from_slice(&ar);
    hrow[w + j..][..N].copy_from_slice(&ai);
}

/// `N` output pixels from column `j` of the row whose H row is `centre`: the centre
/// coefficient times `H`, plus each class's coefficient times its sum of symmetric pairs of
/// H rows; then the mean added and the pixels written.
#[inline(always)]
fn vertical<const N: usize>(
    vc: &[f32],
    hsum: &[f32],
    vclass: &[Vec<usize>],
    (w, centre, j): (usize, usize, usize),
    (mean_re, mean_im): (&[f32], &[f32]),
    out: &mut [Complex32],
) {
    let at = |s: &[f32], o: usize| -> [f32; N] { s[o + j..][..N].try_into().expect("a block") };
    let row = |r: usize| (at(hsum, r * 2 * w), at(hsum, r * 2 * w + w));
    let c0 = at(vc, 0);
    let (hr, hi) = row(centre);
    let mut ar: [f32; N] = std::array::from_fn(|x| c0[x] * hr[x]);
    let mut ai: [f32; N] = std::array::from_fn(|x| c0[x] * hi[x]);
    for (t, class) in vclass.iter().enumerate() {
        let (mut sr, mut si) = ([0.0f32; N], [0.0f32; N]);
        for (n, &d) in class.iter().enumerate() {
            let ((ur, ui), (lr, li)) = (row(centre + d), row(centre - d));
            for x in 0..N {
                let (pr, pi) = (ur[x] + lr[x], ui[x] + li[x]);
                if n == 0 {
                    (sr[x], si[x]) = (pr, pi);
                } else {
                    sr[x] += pr;
                    si[x] += pi;
                }
            }
        }
        let c = at(vc, (1 + t) * w);
        for x in 0..N {
            ar[x] = c[x].mul_add(sr[x], ar[x]);
            ai[x] = c[x].mul_add(si[x], ai[x]);
        }
    }
    let (mr, mi) = (at(mean_re, 0), at(mean_im, 0));
    for x in 0..N {
        out[j + x] = Complex32::new(mr[x] + ar[x], mi[x] + ai[x]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::filters::{dyadic_taps, exponential_taps, filter_pixel_direct};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    /// A bank of `cells` level-1 cells' taps drawn from `taps(rng)` per cell and direction,
    /// with an odd last row and column (the nearest complete cell's taps).
    fn cell_bank(
        (h, w, k): (usize, usize, usize),
        taps: &dyn Fn(&mut ChaCha8Rng) -> Vec<f64>,
        rng: &mut ChaCha8Rng,
    ) -> FilterBank {
        let cells = (h / 2, w / 2);
        let per: Vec<(Vec<f64>, Vec<f64>)> = (0..cells.0 * cells.1)
            .map(|_| (taps(rng), taps(rng)))
            .collect();
        let (mut v, mut hz) = (Vec::new(), Vec::new());
        for i in 0..h {
            for j in 0..w {
                let c = (i / 2).min(cells.0 - 1) * cells.1 + (j / 2).min(cells.1 - 1);
                v.push(per[c].0.clone());
                hz.push(per[c].1.clone());
            }
        }
        FilterBank::new(k, h, w, v, hz)
    }

    /// The kernel against the direct f64 double sum of eq. 33 (scaled by `std / sd` and the
    /// mean added) on seeded random banks and seeds: agreement to 1e-5 of each pixel's
    /// standard deviation plus its mean (a few hundred f32 roundings of terms of the output's
    /// size, each at most 6e-8 relative).
    #[test]
    fn agrees_with_the_direct_sum_on_random_method1_and_method2_banks() {
        let mut rng = ChaCha8Rng::seed_from_u64(42);
        let exp = |r: &mut ChaCha8Rng| {
            let a: f64 = StandardNormal.sample(r);
            let a = 4.0 * a;
            exponential_taps(a, 5)
        };
        let dy = |r: &mut ChaCha8Rng| {
            let p: Vec<f64> = (0..2).map(|_| StandardNormal.sample(r)).collect();
            dyadic_taps(&p, 5)
        };
        for (shape, taps) in [
            ((12, 20, 5), &exp as &dyn Fn(&mut ChaCha8Rng) -> Vec<f64>),
            ((13, 11, 5), &exp),
            ((16, 17, 5), &dy),
            ((9, 24, 5), &dy),
        ] {
            let (h, w, k) = shape;
            let bank = cell_bank(shape, taps, &mut rng);
            let mean = Array2::from_shape_fn((h, w), |(i, j)| {
                Complex64::new(i as f64 * 0.1, -(j as f64) * 0.05)
            });
            let std = Array2::from_shape_fn((h, w), |(i, j)| 0.5 + ((i * 7 + j) % 5) as f64);
            let fast = FastFilter::new(&bank, &mean, &std);
            let sw = w + 2 * k;
            let seed: Vec<Complex64> = (0..(h + 2 * k) * sw)
                .map(|_| {
                    Complex64::new(
                        StandardNormal.sample(&mut rng),
                        StandardNormal.sample(&mut rng),
                    )
                })
                .map(|z: Complex64| Complex64::new(z.re as f32 as f64, z.im as f32 as f64))
                .collect();
            let mut out = vec![Complex32::new(0.0, 0.0); h * w];
            fast.filter_seed(&seed, &mut out);
            let mut portable = vec![Complex32::new(0.0, 0.0); h * w];
            let mut scratch = Scratch {
                re: seed.iter().map(|z| z.re as f32).collect(),
                im: seed.iter().map(|z| z.im as f32).collect(),
                ..Scratch::default()
            };
            fast.filter_body(&mut scratch, &mut portable);
            assert_eq!(
                out, portable,
                "{shape:?}: the AVX2 path is the portable path's bits"
            );
            for i in 0..h {
                for j in 0..w {
                    let p = i * w + j;
                    let y = filter_pixel_direct(&bank, &seed, sw, i, j);
                    let want = mean[[i, j]] + y * (std[[i, j]] / bank.output_sd(p));
                    let got = Complex64::new(out[p].re as f64, out[p].im as f64);
                    let tol = 1e-5 * (std[[i, j]] + mean[[i, j]].norm());
                    assert!(
                        (got - want).norm() <= tol,
                        "{shape:?} pixel ({i}, {j}): {got} vs {want}"
                    );
                }
            }
        }
    }

    /// Method 2's dyadic bands and Method 1's offsets become the classes, and a zero tap
    /// beyond the dyadic reach is left out.
    #[test]
    fn classes_follow_the_fitted_families() {
        let dy = vec![
            dyadic_taps(&[0.5, 0.2, 0.1], 8),
            dyadic_taps(&[0.3, -0.1, 0.05], 8),
        ];
        assert_eq!(classes(&dy, 8), vec![vec![1], vec![2, 3], vec![4, 5, 6, 7]]);
        let ex = vec![exponential_taps(1.0, 3), exponential_taps(-2.0, 3)];
        assert_eq!(classes(&ex, 3), vec![vec![1], vec![2], vec![3]]);
        let delta = vec![exponential_taps(0.0, 3)];
        assert!(classes(&delta, 3).is_empty());
    }
}
