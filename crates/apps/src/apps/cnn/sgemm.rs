//! The matrix products of the convolution blocks ([`super::fast`]): `C = A B` with the right-hand
//! matrix in tiles of [`TILE`] columns (the im2col matrix is written straight into that layout,
//! so nothing is packed), and `C = A B^T` as dot products along rows (the weight gradient, whose
//! two operands both run along the long pixel axis). Register-blocked loops over fixed-size
//! arrays that the compiler turns into AVX-512 (16 lanes), AVX2 (8 lanes) or plain code, one
//! copy per instruction set, chosen at run time ([`Isa`]).
//!
//! Why not the `gemm` crate: its f32 kernels use AVX-512 only behind a feature whose packing
//! made the training step slower here (a quarter of the time packing), and every call packed
//! the im2col matrix again; PyTorch's oneDNN uses AVX-512 on the same machine.
//!
//! Results do not depend on the instruction set: every output is the same sequence of fused
//! multiply-adds (`f32::mul_add`) in the same order whatever the vector width, and the row
//! sums of [`gemm_nt`] reduce 16 lanes in one fixed tree. `tests` check each instruction set
//! against a plain triple loop in f64 on seeded random shapes and against each other bit for
//! bit.

use std::borrow::Cow;

/// Columns of one tile of a right-hand matrix (two AVX-512 vectors of f32).
pub const TILE: usize = 32;
/// Rows of `C` computed together by [`gemm_nn`] (16 AVX-512 accumulators with [`TILE`]).
const MR: usize = 8;
/// Rows of `A` and of `B` combined together by [`gemm_nt`] (16 accumulators of 16 lanes).
const NT: usize = 4;

/// Where the values of a right-hand matrix lie: the element of row `r`, column `j` (of
/// [`gemm_nn`]'s `B`; row `j`, column `r` of [`gemm_nt`]'s, whose tiles run along its inner
/// dimension) at `tiles[j / TILE] + rows[r] + j % TILE`: each row of a tile is [`TILE`]
/// consecutive values. Strided layouts ([`Tiled::row_major`], [`Tiled::packed`]) and a
/// convolution's input read in place (a tile is a 32-pixel stretch of an output row, a row an
/// offset `(channel, a, b)` into the image: [`Tiled::gather`]) are both of this form.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Tiled<'a> {
    /// Where each tile starts.
    tiles: Cow<'a, [usize]>,
    /// Where each row starts inside a tile.
    rows: Cow<'a, [usize]>,
}

impl Tiled<'static> {
    /// A row-major `rows x cols` matrix with `ld` values a row.
    pub fn row_major(ld: usize, rows: usize, cols: usize) -> Self {
        Tiled {
            tiles: (0..cols.div_ceil(TILE)).map(|t| t * TILE).collect(),
            rows: (0..rows).map(|r| r * ld).collect(),
        }
    }

    /// A `rows x cols` matrix tile after tile, each `rows x TILE` row-major (what
    /// [`super::im2col::im2col`] writes).
    pub fn packed(rows: usize, cols: usize) -> Self {
        Tiled {
            tiles: (0..cols.div_ceil(TILE)).map(|t| t * rows * TILE).collect(),
            rows: (0..rows).map(|r| r * TILE).collect(),
        }
    }
}

impl<'a> Tiled<'a> {
    /// Tiles and rows starting where the slices say.
    pub fn gather(tiles: &'a [usize], rows: &'a [usize]) -> Self {
        Tiled {
            tiles: Cow::Borrowed(tiles),
            rows: Cow::Borrowed(rows),
        }
    }

    /// Checks the layout against a matrix of `rows` rows and `cols` columns in `len` values:
    /// every value read (the partial last tile's first `cols % TILE` columns only) lies
    /// inside.
    fn check(&self, rows: usize, cols: usize, len: usize) {
        if rows == 0 || cols == 0 {
            return;
        }
        assert!(self.rows.len() >= rows, "B has too few rows");
        let tiles = cols.div_ceil(TILE);
        assert!(self.tiles.len() >= tiles, "B has too few tiles");
        let top = self.rows[..rows].iter().max().copied().unwrap_or(0);
        for (t, &base) in self.tiles[..tiles].iter().enumerate() {
            let w = (cols - t * TILE).min(TILE);
            assert!(base + top + w <= len, "B too short");
        }
    }
}

/// The instruction sets the kernels are compiled for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Isa {
    /// AVX-512 (F and VL) with FMA.
    Avx512,
    /// AVX2 with FMA.
    Avx2,
    /// The baseline (fused multiply-adds through the C library: slow, same values).
    Plain,
}

impl Isa {
    /// The best instruction set of this processor (found once).
    pub fn best() -> Isa {
        static BEST: std::sync::OnceLock<Isa> = std::sync::OnceLock::new();
        *BEST.get_or_init(|| {
            #[cfg(target_arch = "x86_64")]
            {
                if std::arch::is_x86_feature_detected!("avx512f")
                    && std::arch::is_x86_feature_detected!("avx512vl")
                    && std::arch::is_x86_feature_detected!("fma")
                {
                    return Isa::Avx512;
                }
                if std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
                {
                    return Isa::Avx2;
                }
            }
            Isa::Plain
        })
    }

    /// The instruction sets this processor runs (the best first).
    pub fn available() -> Vec<Isa> {
        [Isa::Avx512, Isa::Avx2, Isa::Plain]
            .into_iter()
            .filter(|i| i.runs_here())
            .collect()
    }

    /// Whether this processor runs the instruction set (each set includes the ones below it).
    pub fn runs_here(self) -> bool {
        let rank = |i: Isa| match i {
            Isa::Avx512 => 2,
            Isa::Avx2 => 1,
            Isa::Plain => 0,
        };
        rank(self) <= rank(Isa::best())
    }
}

/// `c[i ldc + j] = (if acc { c[i ldc + j] } else { 0 }) + sum_k a[i a_rs + k a_cs] B(k, j)` for
/// `i < m`, `j < n`, `k < kk`, with `B` laid out as `bl` says, on the best instruction set.
#[allow(clippy::too_many_arguments)]
pub fn gemm_nn(
    m: usize,
    n: usize,
    kk: usize,
    a: &[f32],
    (a_rs, a_cs): (usize, usize),
    b: &[f32],
    bl: &Tiled,
    c: &mut [f32],
    ldc: usize,
    acc: bool,
) {
    gemm_nn_on(Isa::best(), m, n, kk, a, (a_rs, a_cs), b, bl, c, ldc, acc);
}

/// [`gemm_nn`] on a given instruction set (which the processor must run).
#[allow(clippy::too_many_arguments)]
pub fn gemm_nn_on(
    isa: Isa,
    m: usize,
    n: usize,
    kk: usize,
    a: &[f32],
    (a_rs, a_cs): (usize, usize),
    b: &[f32],
    bl: &Tiled,
    c: &mut [f32],
    ldc: usize,
    acc: bool,
) {
    if m == 0 || n == 0 {
        return;
    }
    assert!(c.len() >= (m - 1) * ldc + n, "C too short");
    assert!(ldc >= n, "C's rows overlap");
    if kk > 0 {
        assert!(a.len() > (m - 1) * a_rs + (kk - 1) * a_cs, "A too short");
        bl.check(kk, n, b.len());
    }
    assert!(isa.runs_here(), "{isa:?} not run here");
    let p = NnArgs {
        m,
        n,
        kk,
        a: a.as_ptr(),
        a_rs,
        a_cs,
        b: b.as_ptr(),
        tiles: bl.tiles.as_ptr(),
        rows: bl.rows.as_ptr(),
        c: c.as_mut_ptr(),
        ldc,
        acc,
    };
    // SAFETY: the asserts above keep every index inside the slices (partial tiles of B are
    // copied, see `nn_body`), `c` is a unique borrow, and the instruction set runs here.
    unsafe {
        match isa {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => nn_avx512(&p),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => nn_avx2(&p),
            _ => nn_body(&p),
        }
    }
}

/// `c[i ldc + t] = (if acc { c[i ldc + t] } else { 0 }) + sum_k a[i lda + k] B(t, k)` for
/// `i < m`, `t < n`, `k < kk` (row `t` of `B` along the tiles as `bl` says), on the best
/// instruction set.
#[allow(clippy::too_many_arguments)]
pub fn gemm_nt(
    m: usize,
    n: usize,
    kk: usize,
    a: &[f32],
    lda: usize,
    b: &[f32],
    bl: &Tiled,
    c: &mut [f32],
    ldc: usize,
    acc: bool,
) {
    gemm_nt_on(Isa::best(), m, n, kk, a, lda, b, bl, c, ldc, acc);
}

/// [`gemm_nt`] on a given instruction set (which the processor must run).
#[allow(clippy::too_many_arguments)]
pub fn gemm_nt_on(
    isa: Isa,
    m: usize,
    n: usize,
    kk: usize,
    a: &[f32],
    lda: usize,
    b: &[f32],
    bl: &Tiled,
    c: &mut [f32],
    ldc: usize,
    acc: bool,
) {
    if m == 0 || n == 0 {
        return;
    }
    assert!(c.len() >= (m - 1) * ldc + n, "C too short");
    assert!(ldc >= n, "C's rows overlap");
    if kk > 0 {
        assert!(a.len() >= (m - 1) * lda + kk, "A too short");
        bl.check(n, kk, b.len());
    }
    assert!(isa.runs_here(), "{isa:?} not run here");
    let p = NtArgs {
        m,
        n,
        kk,
        a: a.as_ptr(),
        lda,
        b: b.as_ptr(),
        tiles: bl.tiles.as_ptr(),
        rows: bl.rows.as_ptr(),
        c: c.as_mut_ptr(),
        ldc,
        acc,
    };
    // SAFETY: as in `gemm_nn_on`.
    unsafe {
        match isa {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => nt_avx512(&p),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => nt_avx2(&p),
            _ => nt_body::<false>(&p),
        }
    }
}

/// The operands of [`gemm_nn`], checked.
struct NnArgs {
    m: usize,
    n: usize,
    kk: usize,
    a: *const f32,
    a_rs: usize,
    a_cs: usize,
    b: *const f32,
    tiles: *const usize,
    rows: *const usize,
    c: *mut f32,
    ldc: usize,
    acc: bool,
}

/// The operands of [`gemm_nt`], checked.
struct NtArgs {
    m: usize,
    n: usize,
    kk: usize,
    a: *const f32,
    lda: usize,
    b: *const f32,
    tiles: *const usize,
    rows: *const usize,
    c: *mut f32,
    ldc: usize,
    acc: bool,
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
unsafe fn nn_avx512(p: &NnArgs) {
    nn_body(p)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn nn_avx2(p: &NnArgs) {
    nn_body(p)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
unsafe fn nt_avx512(p: &NtArgs) {
    nt_body::<true>(p)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn nt_avx2(p: &NtArgs) {
    nt_body::<false>(p)
}

/// [`gemm_nn`]: tile after tile of `B` (a partial last tile copied with zeros), [`MR`] rows of
/// `C` at a time.
#[inline(always)]
unsafe fn nn_body(p: &NnArgs) {
    let mut pad: Vec<f32> = Vec::new();
    let mut packed_rows: Vec<usize> = Vec::new();
    for jt in 0..p.n.div_ceil(TILE) {
        let j0 = jt * TILE;
        let w = (p.n - j0).min(TILE);
        let base = *p.tiles.add(jt);
        let (bp, rows) = if w == TILE {
            (p.b.add(base), p.rows)
        } else {
            pad.clear();
            pad.resize(p.kk * TILE, 0.0);
            for k in 0..p.kk {
                let src = p.b.add(base + *p.rows.add(k));
                for l in 0..w {
                    pad[k * TILE + l] = *src.add(l);
                }
            }
            if packed_rows.len() < p.kk {
                packed_rows = (0..p.kk).map(|k| k * TILE).collect();
            }
            (pad.as_ptr(), packed_rows.as_ptr())
        };
        let mut i0 = 0;
        while i0 < p.m {
            let r = (p.m - i0).min(MR);
            let a = p.a.add(i0 * p.a_rs);
            let c = p.c.add(i0 * p.ldc + j0);
            let t = NnTile {
                kk: p.kk,
                a,
                a_rs: p.a_rs,
                a_cs: p.a_cs,
                b: bp,
                rows,
                c,
                ldc: p.ldc,
                w,
                acc: p.acc,
            };
            match r {
                8 => nn_tile::<8>(&t),
                7 => nn_tile::<7>(&t),
                6 => nn_tile::<6>(&t),
                5 => nn_tile::<5>(&t),
                4 => nn_tile::<4>(&t),
                3 => nn_tile::<3>(&t),
                2 => nn_tile::<2>(&t),
                _ => nn_tile::<1>(&t),
            }
            i0 += r;
        }
    }
}

/// One `R x TILE` block of [`gemm_nn`].
struct NnTile {
    kk: usize,
    a: *const f32,
    a_rs: usize,
    a_cs: usize,
    b: *const f32,
    rows: *const usize,
    c: *mut f32,
    ldc: usize,
    w: usize,
    acc: bool,
}

/// `R` rows by [`TILE`] columns of `C`, accumulated in registers over the whole inner
/// dimension.
#[inline(always)]
unsafe fn nn_tile<const R: usize>(t: &NnTile) {
    let mut s = [[0.0f32; TILE]; R];
    if t.acc {
        for (r, row) in s.iter_mut().enumerate() {
            *row = load(t.c.add(r * t.ldc), t.w);
        }
    }
    for k in 0..t.kk {
        let bv: [f32; TILE] = *(t.b.add(*t.rows.add(k)) as *const [f32; TILE]);
        for (r, row) in s.iter_mut().enumerate() {
            let av = *t.a.add(r * t.a_rs + k * t.a_cs);
            for l in 0..TILE {
                row[l] = av.mul_add(bv[l], row[l]);
            }
        }
    }
    for (r, row) in s.iter().enumerate() {
        store(t.c.add(r * t.ldc), *row, t.w);
    }
}

/// The first `w` of [`TILE`] values at `p`, zeros after (a value, so that the caller's
/// accumulators stay in registers).
#[inline(always)]
unsafe fn load(p: *const f32, w: usize) -> [f32; TILE] {
    if w == TILE {
        *(p as *const [f32; TILE])
    } else {
        let mut x = [0.0f32; TILE];
        std::ptr::copy_nonoverlapping(p, x.as_mut_ptr(), w);
        x
    }
}

/// Writes the first `w` values of `v` to `p`.
#[inline(always)]
unsafe fn store(p: *mut f32, v: [f32; TILE], w: usize) {
    if w == TILE {
        *(p as *mut [f32; TILE]) = v;
    } else {
        std::ptr::copy_nonoverlapping(v.as_ptr(), p, w);
    }
}

/// [`gemm_nt`]: [`NT`] rows of `B` (kept in the caches) against every block of [`NT`] rows of
/// `A`.
#[inline(always)]
unsafe fn nt_body<const WIDE: bool>(p: &NtArgs) {
    let mut t0 = 0;
    while t0 < p.n {
        let tn = (p.n - t0).min(NT);
        let mut i0 = 0;
        while i0 < p.m {
            let rn = (p.m - i0).min(NT);
            let t = NtTile {
                kk: p.kk,
                a: p.a.add(i0 * p.lda),
                lda: p.lda,
                b: p.b,
                tiles: p.tiles,
                rows: p.rows.add(t0),
                c: p.c.add(i0 * p.ldc + t0),
                ldc: p.ldc,
                acc: p.acc,
            };
            match (rn, tn) {
                (4, 4) => nt_tile::<4, 4, WIDE>(&t),
                (4, 3) => nt_tile::<4, 3, false>(&t),
                (4, 2) => nt_tile::<4, 2, false>(&t),
                (4, _) => nt_tile::<4, 1, false>(&t),
                (3, 4) => nt_tile::<3, 4, false>(&t),
                (3, 3) => nt_tile::<3, 3, false>(&t),
                (3, 2) => nt_tile::<3, 2, false>(&t),
                (3, _) => nt_tile::<3, 1, false>(&t),
                (2, 4) => nt_tile::<2, 4, false>(&t),
                (2, 3) => nt_tile::<2, 3, false>(&t),
                (2, 2) => nt_tile::<2, 2, false>(&t),
                (2, _) => nt_tile::<2, 1, false>(&t),
                (_, 4) => nt_tile::<1, 4, false>(&t),
                (_, 3) => nt_tile::<1, 3, false>(&t),
                (_, 2) => nt_tile::<1, 2, false>(&t),
                (_, _) => nt_tile::<1, 1, false>(&t),
            }
            i0 += rn;
        }
        t0 += tn;
    }
}

/// One `R x T` block of [`gemm_nt`].
struct NtTile {
    kk: usize,
    a: *const f32,
    lda: usize,
    b: *const f32,
    tiles: *const usize,
    rows: *const usize,
    c: *mut f32,
    ldc: usize,
    acc: bool,
}

/// Half a tile: the lanes of one partial sum.
const HALF: usize = TILE / 2;

/// `R x T` dot products of length `kk`: 16-lane partial sums over the tiles (both halves of a
/// tile into the same lanes), a partial last tile copied with zeros, then each sum's lanes
/// added in a fixed tree.
#[inline(always)]
unsafe fn nt_tile<const R: usize, const T: usize, const WIDE: bool>(t: &NtTile) {
    let mut s = [[[0.0f32; HALF]; T]; R];
    let full = t.kk / TILE;
    #[cfg(target_arch = "x86_64")]
    if WIDE && R == NT && T == NT {
        // SAFETY: `WIDE` only from `nt_avx512`, on a processor with AVX-512; the tile is
        // `NT x NT`, what the kernel reads and writes.
        let s4 = &mut *(&mut s as *mut [[[f32; HALF]; T]; R]).cast::<[[[f32; HALF]; NT]; NT]>();
        nt_full_avx512(t, full, s4);
    }
    let start = if WIDE && R == NT && T == NT && cfg!(target_arch = "x86_64") {
        full
    } else {
        0
    };
    for kt in start..full {
        let mut bv = [[0.0f32; TILE]; T];
        for (ti, v) in bv.iter_mut().enumerate() {
            *v = *(t.b.add(*t.tiles.add(kt) + *t.rows.add(ti)) as *const [f32; TILE]);
        }
        for (r, sr) in s.iter_mut().enumerate() {
            let av: [f32; TILE] = *(t.a.add(r * t.lda + kt * TILE) as *const [f32; TILE]);
            nt_step(sr, &av, &bv);
        }
    }
    let rest = t.kk - full * TILE;
    if rest > 0 {
        let mut bv = [[0.0f32; TILE]; T];
        for (ti, v) in bv.iter_mut().enumerate() {
            let src = t.b.add(*t.tiles.add(full) + *t.rows.add(ti));
            for (l, x) in v.iter_mut().enumerate().take(rest) {
                *x = *src.add(l);
            }
        }
        for (r, sr) in s.iter_mut().enumerate() {
            let mut av = [0.0f32; TILE];
            let src = t.a.add(r * t.lda + full * TILE);
            for (l, x) in av.iter_mut().enumerate().take(rest) {
                *x = *src.add(l);
            }
            nt_step(sr, &av, &bv);
        }
    }
    for (r, sr) in s.iter().enumerate() {
        for (ti, lanes) in sr.iter().enumerate() {
            let c = t.c.add(r * t.ldc + ti);
            let v = lane_tree(lanes);
            *c = if t.acc { *c + v } else { v };
        }
    }
}

/// The whole tiles of an `NT x NT` block of [`nt_tile`] in AVX-512 registers: the same
/// fused multiply-adds in the same order as [`nt_step`] (which the compiler kept spilling to
/// the stack here), 16 accumulators, the four rows of `B` loaded once a tile.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn nt_full_avx512(t: &NtTile, full: usize, s: &mut [[[f32; HALF]; NT]; NT]) {
    use std::arch::x86_64::{__m512, _mm512_fmadd_ps, _mm512_loadu_ps, _mm512_storeu_ps};
    let zero = _mm512_loadu_ps([0.0f32; HALF].as_ptr());
    let mut acc: [[__m512; NT]; NT] = [[zero; NT]; NT];
    let rows: [usize; NT] = std::array::from_fn(|ti| *t.rows.add(ti));
    for kt in 0..full {
        let base = t.b.add(*t.tiles.add(kt));
        let b0: [__m512; NT] = std::array::from_fn(|ti| _mm512_loadu_ps(base.add(rows[ti])));
        let b1: [__m512; NT] = std::array::from_fn(|ti| _mm512_loadu_ps(base.add(rows[ti] + HALF)));
        for (r, ar) in acc.iter_mut().enumerate() {
            let ap = t.a.add(r * t.lda + kt * TILE);
            let (a0, a1) = (_mm512_loadu_ps(ap), _mm512_loadu_ps(ap.add(HALF)));
            for ti in 0..NT {
                ar[ti] = _mm512_fmadd_ps(a0, b0[ti], ar[ti]);
                ar[ti] = _mm512_fmadd_ps(a1, b1[ti], ar[ti]);
            }
        }
    }
    for (sr, ar) in s.iter_mut().zip(&acc) {
        for (lanes, v) in sr.iter_mut().zip(ar) {
            _mm512_storeu_ps(lanes.as_mut_ptr(), *v);
        }
    }
}

/// One tile of [`nt_tile`]: both halves of `a` times those of each row of `b` into the lanes.
#[inline(always)]
fn nt_step<const T: usize>(sr: &mut [[f32; HALF]; T], a: &[f32; TILE], b: &[[f32; TILE]; T]) {
    for (lanes, bt) in sr.iter_mut().zip(b) {
        for l in 0..HALF {
            lanes[l] = a[l].mul_add(bt[l], lanes[l]);
        }
        for l in 0..HALF {
            lanes[l] = a[HALF + l].mul_add(bt[HALF + l], lanes[l]);
        }
    }
}

/// The sum of 16 lanes: halves added pairwise down to one (the same order on every
/// instruction set).
#[inline(always)]
fn lane_tree(v: &[f32; HALF]) -> f32 {
    let mut x = *v;
    let mut w = HALF;
    while w > 1 {
        w /= 2;
        for l in 0..w {
            x[l] += x[l + w];
        }
    }
    x[0]
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random(rng: &mut ChaCha8Rng, len: usize) -> Vec<f32> {
        (0..len).map(|_| rng.random_range(-1.0f32..1.0)).collect()
    }

    /// Element (k, j) of a tiled matrix.
    fn at(b: &[f32], bl: &Tiled, k: usize, j: usize) -> f32 {
        b[bl.tiles[j / TILE] + bl.rows[k] + j % TILE]
    }

    /// Keeps the best instruction set's result in `first`; asserts every later one equals it
    /// bit for bit.
    fn same_bits_as_first(first: &mut Option<Vec<f32>>, c: Vec<f32>, isa: Isa, case: usize) {
        match first {
            None => *first = Some(c),
            Some(f) => assert!(
                f.iter().zip(&c).all(|(x, y)| x.to_bits() == y.to_bits()),
                "{isa:?} differs from the best instruction set, case {case}"
            ),
        }
    }

    /// Overlapping tiles and rows at random places of a buffer (as a convolution's input read
    /// in place), or a strided layout.
    fn layout(
        rng: &mut ChaCha8Rng,
        case: usize,
        rows: usize,
        cols: usize,
    ) -> (Vec<f32>, Tiled<'static>) {
        let tiles = cols.div_ceil(TILE);
        match case % 3 {
            0 => {
                let ld = cols + case % 4;
                (
                    random(rng, (rows * ld).max(1)),
                    Tiled::row_major(ld, rows, cols),
                )
            }
            1 => (random(rng, rows * tiles * TILE), Tiled::packed(rows, cols)),
            _ => {
                let t: Vec<usize> = (0..tiles).map(|_| rng.random_range(0..60)).collect();
                let r: Vec<usize> = (0..rows).map(|_| rng.random_range(0..60)).collect();
                let b = random(rng, 120 + TILE);
                (
                    b,
                    Tiled {
                        tiles: t.into(),
                        rows: r.into(),
                    },
                )
            }
        }
    }

    #[test]
    fn nn_matches_a_triple_loop_in_f64_on_every_instruction_set_bit_for_bit_between_them() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for case in 0..60 {
            let m = rng.random_range(1..20usize);
            let n = rng.random_range(1..100usize);
            let kk = rng.random_range(0..40usize);
            let a_t = case % 2 == 1;
            let (a_rs, a_cs) = if a_t { (1, m) } else { (kk, 1) };
            let a = random(&mut rng, (m * kk).max(1));
            let (b, bl) = layout(&mut rng, case, kk, n);
            let ldc = n + case % 3;
            let c0 = random(&mut rng, m * ldc);
            let acc = case % 4 < 2;
            let mut first: Option<Vec<f32>> = None;
            for isa in Isa::available() {
                let mut c = c0.clone();
                gemm_nn_on(isa, m, n, kk, &a, (a_rs, a_cs), &b, &bl, &mut c, ldc, acc);
                for i in 0..m {
                    for j in 0..n {
                        let mut want = if acc { f64::from(c0[i * ldc + j]) } else { 0.0 };
                        for k in 0..kk {
                            want +=
                                f64::from(a[i * a_rs + k * a_cs]) * f64::from(at(&b, &bl, k, j));
                        }
                        let got = f64::from(c[i * ldc + j]);
                        assert!(
                            (got - want).abs() <= 1e-5 * (1.0 + kk as f64),
                            "{isa:?} case {case} ({m}x{n}x{kk}) at ({i},{j}): {got} vs {want}"
                        );
                    }
                    // Columns past n are left alone.
                    for j in n..ldc {
                        assert_eq!(c[i * ldc + j].to_bits(), c0[i * ldc + j].to_bits());
                    }
                }
                same_bits_as_first(&mut first, c, isa, case);
            }
        }
    }

    #[test]
    fn nt_matches_a_triple_loop_in_f64_on_every_instruction_set_bit_for_bit_between_them() {
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        for case in 0..60 {
            let m = rng.random_range(1..11usize);
            let n = rng.random_range(1..11usize);
            let kk = rng.random_range(0..130usize);
            let lda = kk + case % 3;
            let a = random(&mut rng, (m * lda).max(1));
            let (b, bl) = layout(&mut rng, case, n, kk);
            let ldc = n + case % 2;
            let c0 = random(&mut rng, m * ldc);
            let acc = case % 4 < 2;
            let mut first: Option<Vec<f32>> = None;
            for isa in Isa::available() {
                let mut c = c0.clone();
                gemm_nt_on(isa, m, n, kk, &a, lda, &b, &bl, &mut c, ldc, acc);
                for i in 0..m {
                    for t in 0..n {
                        let mut want = if acc { f64::from(c0[i * ldc + t]) } else { 0.0 };
                        for k in 0..kk {
                            want += f64::from(a[i * lda + k]) * f64::from(at(&b, &bl, t, k));
                        }
                        let got = f64::from(c[i * ldc + t]);
                        assert!(
                            (got - want).abs() <= 1e-5 * (1.0 + kk as f64),
                            "{isa:?} case {case} ({m}x{n}x{kk}) at ({i},{t}): {got} vs {want}"
                        );
                    }
                }
                same_bits_as_first(&mut first, c, isa, case);
            }
        }
    }
}
