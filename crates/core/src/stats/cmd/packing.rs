//! Packing of the normalised data matrix into f32 panels: the layout of a product (Gram or
//! pixel-pair form), panel ranges, and the blocks the micro-kernels read.

use super::layout::{block_panels, BLOCK, KC_MAX, MR, NR};
use super::terms::Normalised;
use rayon::prelude::*;
use std::ops::Range;
/// Which axis of A is the item axis of a product.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum View {
    /// Items are samples (rows of A), K runs over pixels: Gram form.
    Rows,
    /// Items are pixels (columns of A), K runs over samples: Full form.
    Cols,
}

/// Geometry of one operand packed into micro-panels of `w` items: panel `i`
/// of chunk `c` holds, for each of its `kc` inner indices, `w` real parts
/// then `w` imaginary parts. Padding (items beyond the end, inner indices
/// beyond K) is zero.
#[derive(Clone, Copy)]
pub(super) struct Layout {
    pub(super) view: View,
    pub(super) w: usize,
    pub(super) items: usize,
    pub(super) k: usize,
    pub(super) kc: usize,
    pub(super) nchunks: usize,
}

impl Layout {
    pub(super) fn new(a: &Normalised, view: View, w: usize) -> Layout {
        let (items, k) = match view {
            View::Rows => (a.n, a.p),
            View::Cols => (a.p, a.n),
        };
        // K is split into equal chunks of at most KC_MAX terms.
        let nchunks = k.div_ceil(KC_MAX).max(1);
        let kc = k.div_ceil(nchunks).max(1);
        Layout {
            view,
            w,
            items,
            k,
            kc,
            nchunks,
        }
    }

    /// Floats in one micro-panel of one chunk.
    fn panel_len(&self) -> usize {
        self.kc * 2 * self.w
    }

    /// Number of micro-panels covering all items.
    fn npanels(&self) -> usize {
        self.items.div_ceil(self.w)
    }

    /// Writes micro-panels `panels` of chunk `c` of `a` into `dst` (their
    /// consecutive `panel_len()` slices, all of them, padding included, so
    /// `dst` may hold stale data).
    fn pack_group(&self, a: &Normalised, c: usize, panels: Range<usize>, dst: &mut [f32]) {
        // Monomorphised on the width so that the per-k copies are fixed-size
        // moves rather than calls to memcpy.
        match self.w {
            MR => self.pack_group_w::<MR>(a, c, panels, dst),
            NR => self.pack_group_w::<NR>(a, c, panels, dst),
            _ => unreachable!("panel width is MR or NR"),
        }
    }

    fn pack_group_w<const W: usize>(
        &self,
        a: &Normalised,
        c: usize,
        panels: Range<usize>,
        dst: &mut [f32],
    ) {
        let len = self.panel_len();
        let dst = &mut dst[..panels.len() * len];
        let k0 = (c * self.kc).min(self.k);
        let k1 = (k0 + self.kc).min(self.k);
        let i0 = (panels.start * W).min(self.items);
        let i1 = (panels.end * W).min(self.items);
        // Zero padding: items beyond the end (last panel), K beyond the end.
        if i1 < panels.end * W {
            dst[(i1 - i0) / W * len..].fill(0.0);
        }
        if k1 - k0 < self.kc {
            for pan in dst.chunks_exact_mut(len) {
                pan[(k1 - k0) * 2 * W..].fill(0.0);
            }
        }
        match self.view {
            View::Rows => {
                // Item rows are contiguous in K: read each row once, scatter
                // into its lane of the panel.
                for (pan, pi) in dst.chunks_exact_mut(len).zip(panels) {
                    for l in 0..W.min(self.items.saturating_sub(pi * W)) {
                        let src = (pi * W + l) * a.p;
                        let sre = &a.re[src + k0..src + k1];
                        let sim = &a.im[src + k0..src + k1];
                        for (d, (&r, &i)) in pan.chunks_exact_mut(2 * W).zip(sre.iter().zip(sim)) {
                            d[l] = r;
                            d[W + l] = i;
                        }
                    }
                }
            }
            View::Cols => {
                // Sample rows hold the items: read a row segment once (whole
                // cache lines), copy W items into each panel.
                let full = (i1 - i0) / W;
                for (kk, s) in (k0..k1).enumerate() {
                    let re = &a.re[s * a.p + i0..s * a.p + i1];
                    let im = &a.im[s * a.p + i0..s * a.p + i1];
                    for q in 0..full {
                        let d = &mut dst[q * len + kk * 2 * W..q * len + (kk + 1) * 2 * W];
                        let r: &[f32; W] = re[q * W..(q + 1) * W].try_into().unwrap();
                        let i: &[f32; W] = im[q * W..(q + 1) * W].try_into().unwrap();
                        d[..W].copy_from_slice(r);
                        d[W..].copy_from_slice(i);
                    }
                    let m = (i1 - i0) - full * W;
                    if m > 0 {
                        let d = &mut dst[full * len + kk * 2 * W..];
                        d[..m].copy_from_slice(&re[full * W..]);
                        d[W..W + m].copy_from_slice(&im[full * W..]);
                    }
                }
            }
        }
    }
}

/// A set of consecutive micro-panels `first..first + count`, all chunks,
/// stored chunk-major so that one chunk of the set is contiguous.
pub(super) struct Panels<'a> {
    pub(super) lay: Layout,
    pub(super) first: usize,
    pub(super) count: usize,
    pub(super) data: &'a [f32],
}

impl Panels<'_> {
    /// Micro-panel `pi` (global index) of chunk `c`.
    #[inline]
    pub(super) fn panel(&self, c: usize, pi: usize) -> &[f32] {
        let len = self.lay.panel_len();
        let start = (c * self.count + pi - self.first) * len;
        &self.data[start..start + len]
    }
}

/// Packs panels `range` of `a` into the front of `buf` (grown if needed).
pub(super) fn pack_range(a: &Normalised, lay: Layout, range: Range<usize>, buf: &mut Vec<f32>) {
    let group = range.len() * lay.panel_len();
    let need = lay.nchunks * group;
    if buf.len() < need {
        buf.resize(need, 0.0);
    }
    for (c, dst) in buf[..need].chunks_exact_mut(group).enumerate() {
        lay.pack_group(a, c, range.clone(), dst);
    }
}

/// A whole operand packed once per call (the V side of a product), in
/// parallel.
pub(super) struct Packed {
    pub(super) lay: Layout,
    pub(super) buf: Vec<f32>,
}

impl Packed {
    pub(super) fn new(a: &Normalised, view: View, w: usize) -> Packed {
        let lay = Layout::new(a, view, w);
        let (len, np) = (lay.panel_len(), lay.npanels());
        let mut buf = vec![0.0f32; lay.nchunks * np * len];
        // Parallel units: one chunk of a group of panels covering ~BLOCK
        // items (a contiguous slice of the chunk-major layout).
        let per = BLOCK / lay.w;
        let units: Vec<(usize, Range<usize>)> = (0..lay.nchunks)
            .flat_map(|c| (0..np).step_by(per).map(move |p| (c, p..(p + per).min(np))))
            .collect();
        let mut slices = Vec::with_capacity(units.len());
        let mut rest = &mut buf[..];
        for (_, r) in &units {
            let (head, tail) = rest.split_at_mut(r.len() * len);
            slices.push(head);
            rest = tail;
        }
        units
            .into_par_iter()
            .zip(slices)
            .for_each(|((c, r), dst)| lay.pack_group(a, c, r, dst));
        Packed { lay, buf }
    }

    pub(super) fn panels(&self) -> Panels<'_> {
        Panels {
            lay: self.lay,
            first: 0,
            count: self.lay.npanels(),
            data: &self.buf,
        }
    }
}

/// Re-packs item block `bi` of an NR-wide packing into MR-wide panels at the
/// front of `buf` (grown if needed), same chunking. Reads the block's V panels
/// chunk by chunk (contiguous), so it is much cheaper than packing from the
/// row-major data again.
pub(super) fn repack_block(v: &Packed, bi: usize, buf: &mut Vec<f32>) {
    let lay = v.lay;
    let vr = block_panels(bi, lay.items, NR);
    let ur = block_panels(bi, lay.items, MR);
    let (vlen, ulen) = (lay.panel_len(), lay.kc * 2 * MR);
    let (vgroup, ugroup) = (vr.len() * vlen, ur.len() * ulen);
    let need = lay.nchunks * ugroup;
    if buf.len() < need {
        buf.resize(need, 0.0);
    }
    let np = lay.npanels();
    // Items of the block beyond the V panels stay zero in these.
    let mut re = [0.0f32; BLOCK];
    let mut im = [0.0f32; BLOCK];
    for (c, dst) in buf[..need].chunks_exact_mut(ugroup).enumerate() {
        let src = &v.buf[(c * np + vr.start) * vlen..][..vgroup];
        for kk in 0..lay.kc {
            for (q, pan) in src.chunks_exact(vlen).enumerate() {
                let row: &[f32; 2 * NR] = pan[kk * 2 * NR..(kk + 1) * 2 * NR].try_into().unwrap();
                re[q * NR..(q + 1) * NR].copy_from_slice(&row[..NR]);
                im[q * NR..(q + 1) * NR].copy_from_slice(&row[NR..]);
            }
            for (q, pan) in dst.chunks_exact_mut(ulen).enumerate() {
                let d: &mut [f32; 2 * MR] = (&mut pan[kk * 2 * MR..(kk + 1) * 2 * MR])
                    .try_into()
                    .unwrap();
                d[..MR].copy_from_slice(&re[q * MR..(q + 1) * MR]);
                d[MR..].copy_from_slice(&im[q * MR..(q + 1) * MR]);
            }
        }
    }
}
