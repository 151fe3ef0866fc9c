//! Correlation matrix distance (CMD, Herdin et al. 2005, eq. 24) between two
//! stacks of complex images, computed exactly and fast without ever holding a
//! P x P (or N x N) matrix in memory.
//!
//! A stack of N samples of P pixels is turned into its centred, per-pixel
//! normalised and 1/sqrt(N)-scaled data matrix A (N x P, see [`Normalised`]),
//! so that the sample correlation matrix is R = A^H A. The distance
//! `d = 1 - tr(R1 R2) / (||R1||_F ||R2||_F)` needs three sums of squares, each
//! of which has a Gram (sample-pair) form and a Full (pixel-pair) form:
//!
//! * `||R||_F^2 = ||A A^H||_F^2` (N x N, ~N^2 P / 2 complex multiply-adds with
//!   Hermitian symmetry) `= ||A^H A||_F^2` (P x P, ~P^2 N / 2),
//! * `tr(R1 R2) = ||A1 A2^H||_F^2` (N1 x N2, ~N1 N2 P), or
//!   `sum_pq Re(R1[p,q] conj(R2[p,q]))`, which is free once blocks of both
//!   R1 and R2 are formed anyway for the two norms (P^2 (N1 + N2) / 2 in all).
//!
//! [`cmd_terms`] picks the cheapest combination with that cost model and
//! evaluates it block by block on the caller's rayon pool: f32 products in an
//! AVX2+FMA micro-kernel (runtime-detected, portable fallback otherwise), f32
//! accumulation over at most `KC_MAX` (= 256 <= 512) terms, then f64 for
//! everything after that. The result is bitwise independent of the number of
//! threads. [`cmd_oracle`] is the slow, literal f64 reference used by the
//! tests.

use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};

// ---------------------------------------------------------------------------
// Blocking and accuracy
//
// Every quantity is a sum of |S_ij|^2 (or Re(S1_ij conj(S2_ij))) over the
// entries of a complex product S = U^H V, where the rows of U and V are
// "items" (samples for the Gram form, pixels for the Full form) and the inner
// dimension K runs over the other axis. S is never stored whole:
//
// * Items are cut into blocks of `BLOCK` items (a multiple of lcm(MR, NR)), so
//   the same partition serves as row and column blocks. For symmetric
//   (Hermitian) products only blocks (I, J) with I <= J are computed; an
//   off-diagonal block counts twice, and inside a diagonal block micro-tiles
//   strictly below the diagonal are skipped and the remaining entries are
//   weighted 2 (above), 1 (on) or 0 (below the diagonal).
// * One block owns an f64 tile of its S entries (<= 96 x 96 complex = 147 KiB,
//   fits L2 next to the packed U chunk). K is cut into `nchunks` equal
//   chunks of `kc <= KC_MAX` terms. For each chunk, for each NR-wide V
//   micro-panel (kept in L1, kc x 48 bytes) and each MR-wide U micro-panel
//   (streamed from L2, kc x 64 bytes), the micro-kernel forms the MR x NR
//   complex partial products in 12 AVX registers (f32 FMAs) and adds them to
//   the f64 tile. After the last chunk the tile is squared and summed in f64.
// * Operands are packed into k-major micro-panels, chunk-major so that one
//   chunk of a block's panels is contiguous, with zero padding in both the
//   item and the K direction (zeros are exact). The V side of each product is
//   packed once per call (in parallel). The U side is packed per task, one
//   item block at a time into per-thread scratch, by re-packing the block's
//   V panels (contiguous reads); a task is a strip of up to STRIP blocks of
//   one block row, so this costs ~1/STRIP of a V packing per block. (Packing
//   U globally as well would cost another fresh N x P copy: page faults are
//   expensive, ~0.8 s per GiB on the target VM.)
// * Parallelism: one lane per rayon thread pulls tasks (largest first) from
//   an atomic counter; the Full cross term's blocks of R1 and R2 are formed
//   in the same task so that their product can be summed right away.
//
// Accuracy: each f32 partial sum has at most KC_MAX = 256 terms, so its
// rounding error is bounded by ~256 * 2^-24 * sum|u||v| ≈ 1.5e-5 relative
// (worst case; ~sqrt(256) * 6e-8 ≈ 1e-6 typical), and the f32 rounding of
// the inputs adds ~6e-8 per factor. Everything after the chunk (sums over
// chunks, squaring, sums over entries and blocks) is f64, so its error
// (~1e-16 * log terms) is negligible. The resulting relative errors of the
// three sums of squares are ~1e-7 in practice; the tests check < 1e-5
// against the f64 oracle.
//
// Determinism: the task list, the chunking and the order of every sum inside
// a task depend only on the shapes; threads only decide who computes a task.
// Each task's partial sums are stored under the task's index and added up
// sequentially in task order, never in completion order.
// ---------------------------------------------------------------------------

/// The forms [`cmd_terms`] uses for stacks of `n1` and `n2` samples of `p`
/// pixels, as `[form1, form2, form_cross]`.
///
/// Cost model in complex multiply-adds (Hermitian halving included): a norm
/// costs `N^2 P / 2` as Gram and `P^2 N / 2` as Full, so on its own the Gram
/// form wins iff `N <= P`; the Gram cross term costs `N1 N2 P`. A Full cross
/// term needs no work of its own but requires both norms in Full form, for
/// `P^2 (N1 + N2) / 2` in all; it is chosen when that is cheaper than the best
/// separate plan (always when both N > P, and e.g. for 1000 vs 5000 samples of
/// 4096 pixels, where it saves ~22 %).
pub fn choose_forms(n1: usize, n2: usize, p: usize) -> [Form; 3] {
    let (n1f, n2f, pf) = (n1 as f64, n2 as f64, p as f64);
    let norm = |n: usize, nf: f64| {
        if n <= p {
            (Form::Gram, nf * nf * pf / 2.0)
        } else {
            (Form::Full, pf * pf * nf / 2.0)
        }
    };
    let (f1, c1) = norm(n1, n1f);
    let (f2, c2) = norm(n2, n2f);
    let separate = c1 + c2 + n1f * n2f * pf;
    let joint = pf * pf * (n1f + n2f) / 2.0;
    if joint < separate {
        [Form::Full, Form::Full, Form::Full]
    } else {
        [f1, f2, Form::Gram]
    }
}

/// The three terms of eq. 24 for two normalised stacks with the same pixels,
/// with the forms from [`choose_forms`], in parallel on the caller's rayon
/// pool (no other threads are spawned). The result is bitwise identical for
/// any number of threads. With no pixels (P = 0) all terms are 0 and the
/// distance is NaN.
///
/// # Panics
/// If the two stacks have different pixel counts.
pub fn cmd_terms(a1: &Normalised, a2: &Normalised) -> CmdTerms {
    cmd_terms_with_forms(a1, a2, choose_forms(a1.n, a2.n, a1.p))
}

/// Like [`cmd_terms`] but with the forms `[form1, form2, form_cross]` given
/// explicitly (for tests and diagnostics).
///
/// # Panics
/// If the pixel counts differ, or if `form_cross` is `Full` while a norm is
/// not (the Full cross term is made from the blocks of the two Full norms).
pub fn cmd_terms_with_forms(a1: &Normalised, a2: &Normalised, forms: [Form; 3]) -> CmdTerms {
    cmd_terms_impl(a1, a2, forms, select_kernel())
}

mod kernel;
mod layout;
mod oracle;
mod packing;
mod terms;

use kernel::{select_kernel, Kernel};
use layout::{block_panels, BLOCK, BLOCK_TILE, MR, NR, TILE};
pub use oracle::{cmd_oracle, cmd_oracle_terms};
use packing::{pack_range, repack_block, Layout, Packed, Panels, View};
pub use terms::{CmdTerms, Form, Normalised};

// ---------------------------------------------------------------------------
// Blocks and tasks
// ---------------------------------------------------------------------------

/// Is micro-tile (U panel `ip`, V panel `jp`) strictly below the diagonal?
#[inline]
fn strictly_lower(ip: usize, jp: usize) -> bool {
    MR * ip > NR * jp + NR - 1
}

/// Is micro-tile (U panel `ip`, V panel `jp`) strictly above the diagonal?
#[inline]
fn strictly_upper(ip: usize, jp: usize) -> bool {
    MR * ip + MR - 1 < NR * jp
}

/// Fills `tile` with the block of S = U^H V over all of `u`'s panels and V
/// panels `vp` (all chunks). For a diagonal block of a Hermitian product
/// (`diag`) the micro-tiles strictly below the diagonal are left at zero.
fn block_product(
    kern: Kernel,
    u: &Panels,
    v: &Panels,
    vp: &Range<usize>,
    diag: bool,
    tile: &mut [f64],
) {
    debug_assert_eq!((u.lay.kc, u.lay.nchunks), (v.lay.kc, v.lay.nchunks));
    let nu = u.count;
    let up = u.first..u.first + nu;
    let tile = &mut tile[..nu * vp.len() * TILE];
    tile.fill(0.0);
    for c in 0..u.lay.nchunks {
        for (jl, jp) in vp.clone().enumerate() {
            let vpan = v.panel(c, jp);
            for (il, ip) in up.clone().enumerate() {
                if diag && strictly_lower(ip, jp) {
                    continue;
                }
                let t = (jl * nu + il) * TILE;
                kern(u.lay.kc, u.panel(c, ip), vpan, &mut tile[t..t + TILE]);
            }
        }
    }
}

/// Sum of x * y over one micro-tile in a fixed order (4 interleaved f64
/// accumulators, so it vectorises without depending on the thread count).
#[inline]
fn dot_tile(x: &[f64], y: &[f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    for (xs, ys) in x.chunks_exact(4).zip(y.chunks_exact(4)) {
        for l in 0..4 {
            acc[l] += xs[l] * ys[l];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// `sum_ij w_ij Re(X_ij conj(Y_ij))` over a block tile (so `sum |X|^2` when
/// x == y). Weights of a Hermitian product: 2 for every entry of an
/// off-diagonal block; 2 above, 1 on and 0 below the diagonal of a diagonal
/// block. A rectangular product (`hermitian == false`) weights every entry 1.
fn weighted_sum(
    x: &[f64],
    y: &[f64],
    up: &Range<usize>,
    vp: &Range<usize>,
    hermitian: bool,
    diag: bool,
) -> f64 {
    let nu = up.len();
    let mut total = 0.0f64;
    for (jl, jp) in vp.clone().enumerate() {
        for (il, ip) in up.clone().enumerate() {
            let t = (jl * nu + il) * TILE;
            let (xt, yt) = (&x[t..t + TILE], &y[t..t + TILE]);
            total += if !hermitian {
                dot_tile(xt, yt)
            } else if !diag || strictly_upper(ip, jp) {
                2.0 * dot_tile(xt, yt)
            } else if strictly_lower(ip, jp) {
                0.0
            } else {
                let mut s = 0.0f64;
                for j in 0..NR {
                    for l in 0..MR {
                        let w = match (MR * ip + l).cmp(&(NR * jp + j)) {
                            core::cmp::Ordering::Less => 2.0,
                            core::cmp::Ordering::Equal => 1.0,
                            core::cmp::Ordering::Greater => continue,
                        };
                        let e = j * 2 * MR + l;
                        s += w * (xt[e] * yt[e] + xt[e + MR] * yt[e + MR]);
                    }
                }
                s
            };
        }
    }
    total
}

/// One product S = U^H V whose squared entries are summed: U is packed per
/// task (one item block at a time, amortised over a strip of blocks), V once
/// per call.
struct Product<'a> {
    /// Stack of the U side.
    ua: &'a Normalised,
    /// Layout of the U side.
    ulay: Layout,
    /// The U side already packed as V panels (same stack and view), if any:
    /// U blocks are then re-packed from it (contiguous reads) instead of from
    /// `ua` (strided reads).
    u_from: Option<&'a Packed>,
    v: &'a Packed,
    hermitian: bool,
}

impl<'a> Product<'a> {
    /// A A^H (Rows) or A^H A (Cols) of one stack, given its V packing.
    fn hermitian(a: &'a Normalised, v: &'a Packed) -> Self {
        Product {
            ua: a,
            ulay: Layout { w: MR, ..v.lay },
            u_from: Some(v),
            v,
            hermitian: true,
        }
    }

    /// A1 A2^H, given the Rows V packing of A2 and, if there is one, of A1.
    fn cross(a1: &'a Normalised, v1: Option<&'a Packed>, v2: &'a Packed) -> Self {
        Product {
            ua: a1,
            ulay: Layout::new(a1, View::Rows, MR),
            u_from: v1,
            v: v2,
            hermitian: false,
        }
    }

    fn nblocks_u(&self) -> usize {
        self.ulay.items.div_ceil(BLOCK)
    }

    fn nblocks_v(&self) -> usize {
        self.v.lay.items.div_ceil(BLOCK)
    }

    /// Packs U item block `bi` into `buf`.
    fn pack_u<'b>(&self, bi: usize, buf: &'b mut Vec<f32>) -> Panels<'b> {
        let range = block_panels(bi, self.ulay.items, MR);
        match self.u_from {
            Some(v) => repack_block(v, bi, buf),
            None => pack_range(self.ua, self.ulay, range.clone(), buf),
        }
        Panels {
            lay: self.ulay,
            first: range.start,
            count: range.len(),
            data: buf,
        }
    }

    /// Block (u's block, bj) of S into `tile`; returns the panel ranges.
    fn block(
        &self,
        kern: Kernel,
        u: &Panels,
        bi: usize,
        bj: usize,
        tile: &mut [f64],
    ) -> (Range<usize>, Range<usize>) {
        let vp = block_panels(bj, self.v.lay.items, NR);
        let diag = self.hermitian && bi == bj;
        block_product(kern, u, &self.v.panels(), &vp, diag, tile);
        (u.first..u.first + u.count, vp)
    }

    /// Weighted sum of `Re(X conj(Y))` over the block tile(s) of (bi, bj).
    fn sum(
        &self,
        x: &[f64],
        y: &[f64],
        ranges: &(Range<usize>, Range<usize>),
        bi: usize,
        bj: usize,
    ) -> f64 {
        weighted_sum(x, y, &ranges.0, &ranges.1, self.hermitian, bi == bj)
    }
}

/// What a task computes.
#[derive(Clone, Copy)]
enum Kind {
    /// `products[0]` alone into term 0, or `products[1]` into term 1 (a norm),
    /// or `products[2]` into term 2 (the Gram cross term).
    Single(usize),
    /// `products[0]` and `products[1]` on the same pixel blocks: all three
    /// terms (the Full cross term).
    Joint,
}

/// One unit of parallel work: blocks (bi, bj) for bj in `bj`, of one kind.
/// The U block bi is packed once per task.
struct Task {
    kind: Kind,
    bi: usize,
    bj: Range<usize>,
    cost: f64,
}

/// Blocks per task strip: amortises the U packing, small enough to balance.
const STRIP: usize = 8;

/// Per-thread scratch: packed U blocks and f64 tiles, reused across tasks.
struct Lane {
    u: [Vec<f32>; 2],
    tile: [Vec<f64>; 2],
}

/// The three terms of eq. 24 for two normalised stacks with the given forms and kernel.
///
/// Long because the blocked loop keeps the three terms' accumulators and packed tiles together
/// across pixel blocks.
fn cmd_terms_impl(a1: &Normalised, a2: &Normalised, forms: [Form; 3], kern: Kernel) -> CmdTerms {
    assert_eq!(a1.p, a2.p, "the two stacks must have the same pixels");
    let [form1, form2, form_cross] = forms;
    let joint = form_cross == Form::Full;
    assert!(
        !joint || (form1 == Form::Full && form2 == Form::Full),
        "a Full cross term needs both norms in Full form"
    );
    let view = |f: Form| match f {
        Form::Gram => View::Rows,
        Form::Full => View::Cols,
    };
    // V-side packings, each built in parallel: one per stack in the view
    // of its norm, plus the Rows packing of A2 for a Gram cross term when
    // the second norm is not Gram (only possible with forced forms).
    let v1 = Packed::new(a1, view(form1), NR);
    let v2 = Packed::new(a2, view(form2), NR);
    let v2_rows = (!joint && form2 != Form::Gram).then(|| Packed::new(a2, View::Rows, NR));
    // Products 0 and 1: the norms; product 2: the Gram cross term.
    let mut products = vec![Product::hermitian(a1, &v1), Product::hermitian(a2, &v2)];
    if !joint {
        let v1_rows = (form1 == Form::Gram).then_some(&v1);
        products.push(Product::cross(a1, v1_rows, v2_rows.as_ref().unwrap_or(&v2)));
    }
    // Fixed task list: strips of STRIP blocks along each block row (upper
    // triangle for Hermitian products). Its order only matters for load
    // balance (largest first), never for the result.
    let mut tasks = Vec::new();
    let mut strips = |kind: Kind, prod: &Product, k: usize| {
        for bi in 0..prod.nblocks_u() {
            let j0 = if prod.hermitian { bi } else { 0 };
            for s in (j0..prod.nblocks_v()).step_by(STRIP) {
                let bj = s..(s + STRIP).min(prod.nblocks_v());
                let diag = if prod.hermitian && s == bi { 0.5 } else { 0.0 };
                let cost = (bj.len() as f64 - diag) * k as f64;
                tasks.push(Task { kind, bi, bj, cost });
            }
        }
    };
    if joint {
        strips(Kind::Joint, &products[0], a1.n + a2.n);
    } else {
        for (which, prod) in products.iter().enumerate() {
            strips(Kind::Single(which), prod, prod.ulay.k);
        }
    }
    tasks.sort_by(|x, y| y.cost.total_cmp(&x.cost));

    let run = |task: &Task, lane: &mut Lane| -> [f64; 3] {
        let mut r = [0.0f64; 3];
        let [u0, u1] = &mut lane.u;
        let [t0, t1] = &mut lane.tile;
        match task.kind {
            Kind::Single(which) => {
                let prod = &products[which];
                let u = prod.pack_u(task.bi, u0);
                for bj in task.bj.clone() {
                    let rg = prod.block(kern, &u, task.bi, bj, t0);
                    r[which] += prod.sum(t0, t0, &rg, task.bi, bj);
                }
            }
            Kind::Joint => {
                let (p1, p2) = (&products[0], &products[1]);
                let ua = p1.pack_u(task.bi, u0);
                let ub = p2.pack_u(task.bi, u1);
                for bj in task.bj.clone() {
                    let rg = p1.block(kern, &ua, task.bi, bj, t0);
                    p2.block(kern, &ub, task.bi, bj, t1);
                    r[0] += p1.sum(t0, t0, &rg, task.bi, bj);
                    r[1] += p1.sum(t1, t1, &rg, task.bi, bj);
                    r[2] += p1.sum(t0, t1, &rg, task.bi, bj);
                }
            }
        }
        r
    };

    // One lane per pool thread pulls tasks from a shared counter; each
    // result is stored under its task index, so the reduction below runs in
    // task order whatever thread computed what.
    let next = AtomicUsize::new(0);
    let lanes = rayon::current_num_threads().clamp(1, tasks.len().max(1));
    let done: Vec<Vec<(usize, [f64; 3])>> = (0..lanes)
        .into_par_iter()
        .map(|_| {
            let mut lane = Lane {
                u: [Vec::new(), Vec::new()],
                tile: [vec![0.0; BLOCK_TILE], vec![0.0; BLOCK_TILE]],
            };
            let mut out = Vec::new();
            loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                if i >= tasks.len() {
                    break out;
                }
                out.push((i, run(&tasks[i], &mut lane)));
            }
        })
        .collect();
    let mut partials = vec![[0.0f64; 3]; tasks.len()];
    for (i, r) in done.into_iter().flatten() {
        partials[i] = r;
    }
    let mut sums = [0.0f64; 3];
    for part in &partials {
        for (s, x) in sums.iter_mut().zip(part) {
            *s += x;
        }
    }
    CmdTerms {
        norm1_sq: sums[0],
        norm2_sq: sums[1],
        cross: sums[2],
        form1,
        form2,
        form_cross,
    }
}

#[cfg(test)]
mod tests;
