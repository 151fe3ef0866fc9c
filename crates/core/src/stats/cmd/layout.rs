//! The blocking geometry of the CMD products: the register tile of the micro-kernels
//! (`MR x NR` complex entries), the longest f32 partial sum, the block of items a task forms,
//! and the panels of a block.

use std::ops::Range;

/// Items per U micro-panel: one AVX register of real parts, one of imaginary.
pub(super) const MR: usize = 8;
/// Items per V micro-panel (columns of the register tile).
pub(super) const NR: usize = 6;
/// f64 values in one micro-tile: MR x NR complex entries, laid out per column
/// j as `[re of the MR rows | im of the MR rows]`.
pub(super) const TILE: usize = 2 * MR * NR;
/// Largest number of terms summed in f32 before going to f64 (<= 512).
pub(super) const KC_MAX: usize = 256;
/// Items per block, a multiple of lcm(MR, NR) = 24.
pub(super) const BLOCK: usize = 96;
/// f64 values in the tile of one full block.
pub(super) const BLOCK_TILE: usize = (BLOCK / MR) * (BLOCK / NR) * TILE;

/// Micro-panel range of item block `b` for panels of width `w`.
pub(super) fn block_panels(b: usize, items: usize, w: usize) -> Range<usize> {
    let start = b * BLOCK;
    let end = (start + BLOCK).min(items);
    start / w..end.div_ceil(w)
}
