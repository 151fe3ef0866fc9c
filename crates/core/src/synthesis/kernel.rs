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
//! AVX2 + FMA and AVX-512 paths (the same operations per lane, wider). The direct
//! double sum in `f64` ([`crate::stats::filters::filter_pixel_direct`]) is the oracle of the
//! tests: the two agree to `f32` rounding.

use crate::stats::filters::FilterBank;
use ndarray::Array2;
use num_complex::{Complex32, Complex64};

/// Columns per block of the vertical pass (two AVX2 vectors per component).
const B: usize = 16;

/// Columns per block of the horizontal pass, which forms two rows at once: 8 independent
/// multiply-add chains, enough to hide the instruction's latency (with one vector per
/// component the chains' latency, not the arithmetic, bounded the kernel), and each
/// coefficient load serves both rows.
const H: usize = 16;

/// Columns per tile of the image (see [`FastFilter::filter_body`]).
const T: usize = 32;

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
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            if std::arch::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU supports AVX-512 F, AVX2 and FMA, checked just above.
                return unsafe { self.filter_avx512(scratch, out) };
            }
            // SAFETY: the CPU supports AVX2 and FMA, checked just above.
            return unsafe { self.filter_avx2(scratch, out) };
        }
        self.filter_body::<false, false>(scratch, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn filter_avx2(&self, scratch: &mut Scratch, out: &mut [Complex32]) {
        self.filter_body::<true, false>(scratch, out)
    }

    /// Whole tiles through the AVX-512 blocks ([`super::kernel_avx512`]), the rest as on AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx2,fma")]
    fn filter_avx512(&self, scratch: &mut Scratch, out: &mut [Complex32]) {
        self.filter_body::<true, true>(scratch, out)
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

    /// The kernel; `AVX`: full blocks through the AVX2 + FMA intrinsics (the caller checked
    /// the CPU), whose arithmetic per lane is that of the portable blocks.
    ///
    /// The image is done in tiles of [`T`] columns, top to bottom within a tile, so that the
    /// class sums of the seed rows a row group reads (a window moving down two rows per group)
    /// stay in L1 in a ring of rows: on the whole image at once they were 368 KiB for Method 1,
    /// read from L2 nine times per sample, and those loads bounded the kernel.
    #[inline(always)]
    fn filter_body<const AVX: bool, const WIDE: bool>(
        &self,
        scratch: &mut Scratch,
        out: &mut [Complex32],
    ) {
        let (h, w, k) = (self.h, self.w, self.k);
        assert_eq!(out.len(), h * w);
        let sw = w + 2 * k;
        let nt = 1 + self.hclass.len();
        let rv = self.reach_v;
        let max_group = self.groups.iter().map(|g| g.1 - g.0).max().unwrap_or(0);
        let ring = max_group + 2 * rv;
        let slot = nt * 2 * T;
        let Scratch {
            re,
            im,
            basis,
            hsum,
            ..
        } = scratch;
        basis.resize(ring * slot, 0.0);
        hsum.resize(ring * 2 * T, 0.0);
        let (re, im) = (&*re, &*im);
        assert!(re.len() >= (h + 2 * k) * sw && im.len() == re.len());
        for j0 in (0..w).step_by(T) {
            let tw = T.min(w - j0);
            // The next seed row whose class sums are not yet in the ring.
            let mut next = 0;
            for (gi, &(g0, g1)) in self.groups.iter().enumerate() {
                let (start, end) = (g0 + k - rv, g1 + k + rv);
                for r in next.max(start)..end {
                    let dst = &mut basis[(r % ring) * slot..][..slot];
                    for (comp, src) in [re, im].into_iter().enumerate() {
                        let src = &src[r * sw + j0..][..tw + 2 * k];
                        let mut x = 0;
                        #[cfg(target_arch = "x86_64")]
                        #[cfg(target_arch = "x86_64")]
                        while WIDE && x + 16 <= tw {
                            // SAFETY: AVX-512 is present (WIDE); as below for 16 columns (the
                            // class offsets reach k to either side of `src + k + x`).
                            unsafe {
                                let (s, d) =
                                    (src.as_ptr().add(k + x), dst.as_mut_ptr().add(comp * T + x));
                                super::kernel_avx512::basis(s, &self.hclass, d, T)
                            };
                            x += 16;
                        }
                        #[cfg(target_arch = "x86_64")]
                        if AVX {
                            while x + 8 <= tw {
                                // SAFETY: AVX2 is present (AVX); columns x .. x + 8 <= tw of
                                // the source row shifted by -k ..= k lie in `src`
                                // (`tw + 2k`), and the slot holds `2 nt T` values.
                                unsafe {
                                    basis_avx2(
                                        src.as_ptr().add(k + x),
                                        &self.hclass,
                                        dst.as_mut_ptr().add(comp * T + x),
                                    )
                                };
                                x += 8;
                            }
                        }
                        for x in x..tw {
                            let at = |o: usize| src[k + x + o] + src[k + x - o];
                            dst[comp * T + x] = src[k + x];
                            for (t, class) in self.hclass.iter().enumerate() {
                                let mut acc = at(class[0]);
                                for &off in &class[1..] {
                                    acc += at(off);
                                }
                                dst[((1 + t) * 2 + comp) * T + x] = acc;
                            }
                        }
                    }
                }
                next = next.max(end);
                self.group_tile::<AVX, WIDE>(gi, (g0, g1), (j0, tw), (basis, hsum), out);
            }
        }
    }

    /// One row group (output rows `g0 .. g1`) on the tile of columns `j0 .. j0 + tw`, its
    /// seed rows' class sums in the ring: the horizontal sums H of its seed rows, then its
    /// output pixels.
    ///
    /// Long because it is the inner kernel, unrolled by hand so that the compiler keeps its
    /// accumulators in registers.
    #[inline(always)]
    fn group_tile<const AVX: bool, const WIDE: bool>(
        &self,
        gi: usize,
        (g0, g1): (usize, usize),
        (j0, tw): (usize, usize),
        (basis, hsum): (&[f32], &mut [f32]),
        out: &mut [Complex32],
    ) {
        let (h, w, k, rv) = (self.h, self.w, self.k, self.reach_v);
        let nt = 1 + self.hclass.len();
        let nv = 1 + self.vclass.len();
        let slot = nt * 2 * T;
        let ring = basis.len() / slot;
        let coef = &self.hcoef[gi * nt * w + j0..];
        let rows = g1 - g0 + 2 * rv;
        let start = g0 + k - rv;
        // Horizontal, two rows at a time so that each coefficient load serves both.
        let mut lr = 0;
        while lr < rows {
            let pair = lr + 1 < rows;
            let b0 = &basis[((start + lr) % ring) * slot..][..slot];
            let b1 = if pair {
                &basis[((start + lr + 1) % ring) * slot..][..slot]
            } else {
                b0
            };
            let (h0, h1) = hsum[lr * 2 * T..].split_at_mut(2 * T);
            let h1 = if pair { &mut h1[..2 * T] } else { &mut [][..] };
            let mut j = 0;
            #[cfg(target_arch = "x86_64")]
            if AVX {
                assert!(coef.len() >= (nt - 1) * w + tw);
                let h1p = if pair {
                    h1.as_mut_ptr()
                } else {
                    h0.as_mut_ptr()
                };
                while WIDE && j + 2 * H <= tw {
                    // SAFETY: AVX-512 is present (WIDE); as below for 32 columns.
                    unsafe {
                        super::kernel_avx512::horizontal(
                            coef.as_ptr().add(j),
                            [b0.as_ptr().add(j), b1.as_ptr().add(j)],
                            (w, nt, T),
                            [h0.as_mut_ptr().add(j), h1p.add(j)],
                            pair,
                        )
                    };
                    j += 2 * H;
                }
                while j + H <= tw {
                    // SAFETY: AVX2 and FMA are present (AVX); the 16 columns from j lie in
                    // the tile (j + 16 <= tw <= T): coefficient rows `t w` apart (checked
                    // above), basis slots of `2 nt T`, H rows of `2 T` (a lone row writes
                    // only h0).
                    unsafe {
                        horizontal_avx2(
                            coef.as_ptr().add(j),
                            [b0.as_ptr().add(j), b1.as_ptr().add(j)],
                            (w, nt),
                            [h0.as_mut_ptr().add(j), h1p.add(j)],
                            pair,
                        )
                    };
                    j += H;
                }
            }
            while j + H <= tw {
                horizontal::<H>(coef, [b0, b1], (w, nt, j), [h0, h1], pair);
                j += H;
            }
            while j < tw {
                horizontal::<1>(coef, [b0, b1], (w, nt, j), [h0, h1], pair);
                j += 1;
            }
            lr += 2;
        }
        // Vertical: each output row weights the class sums of its H column.
        for i in g0..g1 {
            let vc = &self.vcoef[i * nv * w + j0..];
            let centre = i - g0 + rv;
            let o = &mut out[i * w + j0..][..tw];
            let mean = (
                &self.mean[i * w + j0..][..tw],
                &self.mean[h * w + i * w + j0..][..tw],
            );
            let mut j = 0;
            #[cfg(target_arch = "x86_64")]
            if AVX {
                assert!(
                    (centre + rv + 1) * 2 * T <= hsum.len()
                        && centre >= rv
                        && vc.len() >= (nv - 1) * w + tw
                );
                while WIDE && j + 2 * B <= tw {
                    // SAFETY: AVX-512 is present (WIDE); as below for 32 columns.
                    unsafe {
                        super::kernel_avx512::vertical(
                            vc.as_ptr().add(j),
                            hsum.as_ptr().add(j),
                            (w, centre, T),
                            &self.vclass,
                            (mean.0.as_ptr().add(j), mean.1.as_ptr().add(j)),
                            o.as_mut_ptr().add(j),
                        )
                    };
                    j += 2 * B;
                }
                while j + B <= tw {
                    // SAFETY: AVX2 and FMA are present (AVX); columns j .. j + 16 <= tw of
                    // the coefficient rows, the mean rows, the output row and the H rows
                    // centre - rv ..= centre + rv, all inside by the assertion.
                    unsafe {
                        vertical_avx2(
                            vc.as_ptr().add(j),
                            hsum.as_ptr().add(j),
                            (w, centre),
                            &self.vclass,
                            (mean.0.as_ptr().add(j), mean.1.as_ptr().add(j)),
                            o.as_mut_ptr().add(j),
                        )
                    };
                    j += B;
                }
            }
            while j + B <= tw {
                vertical::<B>(vc, hsum, &self.vclass, (w, centre, j), mean, o);
                j += B;
            }
            while j < tw {
                vertical::<1>(vc, hsum, &self.vclass, (w, centre, j), mean, o);
                j += 1;
            }
        }
    }
}

/// `N` columns from `j` of two horizontal rows (the second only if `pair`):
/// `H = c_0 B_0 + sum_t c_t B_t` per component; coefficient rows `w` apart, basis slots and
/// H rows laid out per tile ([`T`] columns per component and class).
#[inline(always)]
fn horizontal<const N: usize>(
    coef: &[f32],
    basis: [&[f32]; 2],
    (w, nt, j): (usize, usize, usize),
    hrow: [&mut [f32]; 2],
    pair: bool,
) {
    let at = |s: &[f32], o: usize| -> [f32; N] { s[o + j..][..N].try_into().expect("a block") };
    let c0 = at(coef, 0);
    let mut acc: [[[f32; N]; 2]; 2] = std::array::from_fn(|r| {
        std::array::from_fn(|comp| {
            let b = at(basis[r], comp * T);
            std::array::from_fn(|x| c0[x] * b[x])
        })
    });
    for t in 1..nt {
        let c = at(coef, t * w);
        for (row, acc) in basis.iter().zip(acc.iter_mut()) {
            for (comp, acc) in acc.iter_mut().enumerate() {
                let b = at(row, (2 * t + comp) * T);
                for x in 0..N {
                    acc[x] = c[x].mul_add(b[x], acc[x]);
                }
            }
        }
    }
    let [h0, h1] = hrow;
    h0[j..][..N].copy_from_slice(&acc[0][0]);
    h0[T + j..][..N].copy_from_slice(&acc[0][1]);
    if pair {
        h1[j..][..N].copy_from_slice(&acc[1][0]);
        h1[T + j..][..N].copy_from_slice(&acc[1][1]);
    }
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
    let row = |r: usize| (at(hsum, r * 2 * T), at(hsum, r * 2 * T + T));
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

/// The class sums of 8 columns of one seed row and component: `src` at the row's first of the
/// 8 centre columns, `dst` at the same column of the slot's centre row (class `t` is written
/// `2 (1 + t) T` further). Per column as the portable loop: the centre value, then per class
/// the sum of its symmetric pairs in order.
///
/// # Safety
/// The CPU has AVX2; `src - k .. src + 8 + k` is valid for every class offset up to `k`, and
/// `dst + 2 t T + 8` for every class `t`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn basis_avx2(src: *const f32, hclass: &[Vec<usize>], dst: *mut f32) {
    use std::arch::x86_64::*;
    // SAFETY (whole body): every offset stays within the ranges the caller guarantees.
    unsafe {
        _mm256_storeu_ps(dst, _mm256_loadu_ps(src));
        for (t, class) in hclass.iter().enumerate() {
            let pair =
                |d: usize| _mm256_add_ps(_mm256_loadu_ps(src.add(d)), _mm256_loadu_ps(src.sub(d)));
            let mut acc = pair(class[0]);
            for &d in &class[1..] {
                acc = _mm256_add_ps(acc, pair(d));
            }
            _mm256_storeu_ps(dst.add((1 + t) * 2 * T), acc);
        }
    }
}

/// [`horizontal`] for 16 columns with AVX2 + FMA intrinsics: pointers at column `j` of the
/// coefficients, the two basis rows and the two H rows (the second written only if `pair`).
///
/// # Safety
/// The CPU has AVX2 and FMA; 16 columns from each pointer are valid, for `nt` classes
/// (`coef + t w`, `basis + (2 t + comp) w`) and both components of the H rows (`+ w`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn horizontal_avx2(
    coef: *const f32,
    basis: [*const f32; 2],
    (w, nt): (usize, usize),
    hrow: [*mut f32; 2],
    pair: bool,
) {
    use std::arch::x86_64::*;
    // SAFETY (whole body): every offset stays within the ranges the caller guarantees.
    unsafe {
        let c = [_mm256_loadu_ps(coef), _mm256_loadu_ps(coef.add(8))];
        let mut acc = [[_mm256_setzero_ps(); 4]; 2];
        for r in 0..2 {
            for comp in 0..2 {
                for v in 0..2 {
                    let b = _mm256_loadu_ps(basis[r].add(comp * T + 8 * v));
                    acc[r][2 * comp + v] = _mm256_mul_ps(c[v], b);
                }
            }
        }
        for t in 1..nt {
            let ct = coef.add(t * w);
            let c = [_mm256_loadu_ps(ct), _mm256_loadu_ps(ct.add(8))];
            for r in 0..2 {
                for comp in 0..2 {
                    for v in 0..2 {
                        let b = _mm256_loadu_ps(basis[r].add((2 * t + comp) * T + 8 * v));
                        acc[r][2 * comp + v] = _mm256_fmadd_ps(c[v], b, acc[r][2 * comp + v]);
                    }
                }
            }
        }
        for r in 0..1 + usize::from(pair) {
            for comp in 0..2 {
                for v in 0..2 {
                    _mm256_storeu_ps(hrow[r].add(comp * T + 8 * v), acc[r][2 * comp + v]);
                }
            }
        }
    }
}

/// [`vertical`] for 16 columns with AVX2 + FMA intrinsics: pointers at column `j` of the
/// coefficients, the H rows (row 0), the mean rows and the output row.
///
/// # Safety
/// The CPU has AVX2 and FMA; 16 columns from each pointer are valid: coefficient rows
/// `0 ..= vclass.len()` (`+ t w`), H rows `centre - d ..= centre + d` for every class offset
/// `d` (`+ r 2 w`, both components), the mean rows and 16 output values.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn vertical_avx2(
    vc: *const f32,
    hsum: *const f32,
    (w, centre): (usize, usize),
    vclass: &[Vec<usize>],
    (mean_re, mean_im): (*const f32, *const f32),
    out: *mut Complex32,
) {
    use std::arch::x86_64::*;
    // SAFETY (whole body): every offset stays within the ranges the caller guarantees.
    unsafe {
        let load4 = |p: *const f32| {
            [
                _mm256_loadu_ps(p),
                _mm256_loadu_ps(p.add(8)),
                _mm256_loadu_ps(p.add(T)),
                _mm256_loadu_ps(p.add(T + 8)),
            ]
        };
        let row = |r: usize| hsum.add(r * 2 * T);
        let c = [_mm256_loadu_ps(vc), _mm256_loadu_ps(vc.add(8))];
        let hc = load4(row(centre));
        let mut acc: [__m256; 4] = std::array::from_fn(|x| _mm256_mul_ps(c[x % 2], hc[x]));
        for (t, class) in vclass.iter().enumerate() {
            let mut s = [_mm256_setzero_ps(); 4];
            for (n, &d) in class.iter().enumerate() {
                let (u, l) = (load4(row(centre + d)), load4(row(centre - d)));
                for x in 0..4 {
                    let p = _mm256_add_ps(u[x], l[x]);
                    s[x] = if n == 0 { p } else { _mm256_add_ps(s[x], p) };
                }
            }
            let ct = vc.add((1 + t) * w);
            let c = [_mm256_loadu_ps(ct), _mm256_loadu_ps(ct.add(8))];
            for x in 0..4 {
                acc[x] = _mm256_fmadd_ps(c[x % 2], s[x], acc[x]);
            }
        }
        let o = out as *mut f32;
        for v in 0..2 {
            let re = _mm256_add_ps(_mm256_loadu_ps(mean_re.add(8 * v)), acc[v]);
            let im = _mm256_add_ps(_mm256_loadu_ps(mean_im.add(8 * v)), acc[2 + v]);
            let (lo, hi) = (_mm256_unpacklo_ps(re, im), _mm256_unpackhi_ps(re, im));
            _mm256_storeu_ps(o.add(16 * v), _mm256_permute2f128_ps(lo, hi, 0x20));
            _mm256_storeu_ps(o.add(16 * v + 8), _mm256_permute2f128_ps(lo, hi, 0x31));
        }
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
            fast.filter_body::<false, false>(&mut scratch, &mut portable);
            assert_eq!(
                out, portable,
                "{shape:?}: the vector path (AVX-512 or AVX2) is the portable path's bits"
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
