//! The geometry of one convolution block of the networks ([`super::fast`]): input, filters,
//! stride, padding and pooling, with the sizes the kernels derive from it (values per filter,
//! output pixels, the chunk of samples each thread takes).

/// Geometry of one block: input `[n, c, h, w]`, `f` filters of `k x k` with `stride` and
/// padding `top`/`left` (the bottom and right padding follow from the output size
/// `oh x ow`), then, if `pool`, a 2x2 stride-2 max pooling (floor).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BlockGeom {
    /// Samples.
    pub n: usize,
    /// Input channels.
    pub c: usize,
    /// Input height.
    pub h: usize,
    /// Input width.
    pub w: usize,
    /// Filters (output channels).
    pub f: usize,
    /// Kernel side.
    pub k: usize,
    /// Convolution stride.
    pub stride: usize,
    /// Padding above.
    pub top: usize,
    /// Padding on the left.
    pub left: usize,
    /// Convolution output height.
    pub oh: usize,
    /// Convolution output width.
    pub ow: usize,
    /// Whether a 2x2 stride-2 max pooling follows the ReLU.
    pub pool: bool,
}

impl BlockGeom {
    /// Values per filter (`c * k * k`): the inner dimension of the convolution's matrix product.
    pub(crate) fn kk(&self) -> usize {
        self.c * self.k * self.k
    }

    /// Output pixels of the convolution per sample and filter.
    pub(crate) fn p(&self) -> usize {
        self.oh * self.ow
    }

    /// Samples per chunk: about 2048 output pixels per chunk, fewer where the chunk's im2col
    /// matrix would pass 1 MiB (it is written, then read by the product: from the core's own
    /// cache, not the shared one), at least 4 chunks per batch (for two threads); a function of
    /// the shapes only.
    pub(crate) fn chunk(&self) -> usize {
        let pixels = 2048.min((1 << 18) / self.kk().max(1));
        (pixels / self.p()).clamp(1, (self.n / 4).max(1))
    }

    /// Side lengths of the block's output.
    pub fn out_hw(&self) -> (usize, usize) {
        if self.pool {
            (self.oh / 2, self.ow / 2)
        } else {
            (self.oh, self.ow)
        }
    }

    /// Height and width of the input with all its padding, above and below, left and right:
    /// what the `oh x ow` outputs of the convolution read.
    pub fn padded_hw(&self) -> (usize, usize) {
        (
            self.h.max((self.oh - 1) * self.stride + self.k),
            self.w.max((self.ow - 1) * self.stride + self.k),
        )
    }

    /// Whether the padding after differs from the padding before (MATLAB's 'same' puts the
    /// odd one after), in either direction.
    pub fn uneven(&self) -> bool {
        let (hp, wp) = self.padded_hw();
        hp - self.h != 2 * self.top || wp - self.w != 2 * self.left
    }

    /// Shape of the block's output `[n, f, H, W]`.
    pub fn out_shape(&self) -> [usize; 4] {
        let (h, w) = self.out_hw();
        [self.n, self.f, h, w]
    }
}
