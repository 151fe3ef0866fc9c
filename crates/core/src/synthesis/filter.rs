//! What Methods 1 and 2 share: per-cell filter parameters on the level-1 cell grid, the
//! per-pixel filter bank they make, and [`Filtered`], a fitted filter model with its moments,
//! which generates (a white seed filtered and scaled to the moments), saves its residuals and
//! checks the sizes its folder records. Each method's own file fits its parameters and saves
//! them.

use super::kernel::{FastFilter, Scratch};
use super::method::{ArrayStore, Layout, Moments, Recorded};
use super::sampling::{self, OneAtATime};
use crate::stats::filters::{
    dyadic_taps, exponential_taps_signed, filter_seed, FilterBank, NegativeSigns,
};
use anyhow::bail;
use ndarray::Array2;
use num_complex::{Complex32, Complex64};
use std::sync::OnceLock;

/// Per-cell filter parameters of Methods 1 and 2 (level-1 cell grid).
#[derive(Debug, Clone, PartialEq)]
pub enum CellParams {
    /// Method 1: `alpha` per direction (negative: signed by `signs`; 0: delta; inf: constant).
    Exponential {
        /// Horizontal alpha per cell.
        alpha_h: Array2<f64>,
        /// Vertical alpha per cell.
        alpha_v: Array2<f64>,
        /// How the filters of negative `alpha` are signed.
        signs: NegativeSigns,
    },
    /// Method 2: `r_1..r_L` per direction, `[L][rows][cols]`.
    Dyadic {
        /// Horizontal parameters per level and cell.
        r_h: Vec<Array2<f64>>,
        /// Vertical parameters per level and cell.
        r_v: Vec<Array2<f64>>,
    },
}

impl CellParams {
    /// Level-1 cell grid `(rows, cols)`.
    pub fn cells(&self) -> (usize, usize) {
        match self {
            CellParams::Exponential { alpha_h, .. } => alpha_h.dim(),
            CellParams::Dyadic { r_h, .. } => r_h[0].dim(),
        }
    }

    /// The per-pixel filter bank of an `h x w` image with half-width `k`: every pixel takes the
    /// parameters of the level-1 cell it lies in (the nearest complete cell for an odd last
    /// row or column).
    pub fn bank(&self, k: usize, h: usize, w: usize) -> FilterBank {
        let cells = self.cells();
        let (mut vertical, mut horizontal) = (Vec::with_capacity(h * w), Vec::with_capacity(h * w));
        for i in 0..h {
            for j in 0..w {
                let c = cell_of(i, j, cells);
                let (v, hz) = match self {
                    CellParams::Exponential {
                        alpha_h,
                        alpha_v,
                        signs,
                    } => (
                        exponential_taps_signed(alpha_v[c], k, *signs),
                        exponential_taps_signed(alpha_h[c], k, *signs),
                    ),
                    CellParams::Dyadic { r_h, r_v } => {
                        let at = |p: &[Array2<f64>]| p.iter().map(|m| m[c]).collect::<Vec<_>>();
                        (dyadic_taps(&at(r_v), k), dyadic_taps(&at(r_h), k))
                    }
                };
                vertical.push(v);
                horizontal.push(hz);
            }
        }
        FilterBank::new(k, h, w, vertical, horizontal)
    }
}

/// A fitted spatially varying filter model (Methods 1 and 2).
#[derive(Debug, Clone)]
pub struct FilterModel {
    /// Per-cell parameters.
    pub params: CellParams,
    /// RMS misfit of the reached correlations per cell, horizontal.
    pub residual_h: Array2<f64>,
    /// RMS misfit per cell, vertical.
    pub residual_v: Array2<f64>,
    /// Cells whose target could not be reached (clamped or best fit), per cell 0, 1 or 2
    /// (one per direction).
    pub clamped: Array2<u8>,
    /// The per-pixel filter bank.
    pub bank: FilterBank,
}

impl FilterModel {
    /// A model from fitted cell parameters, their residuals and unreached counts; builds the
    /// per-pixel bank of an `h x w` image with half-width `k`.
    pub fn new(
        params: CellParams,
        (residual_h, residual_v): (Array2<f64>, Array2<f64>),
        clamped: Array2<u8>,
        (k, h, w): (usize, usize, usize),
    ) -> Self {
        let bank = params.bank(k, h, w);
        FilterModel {
            params,
            residual_h,
            residual_v,
            clamped,
            bank,
        }
    }
}

/// The level-1 cell whose parameters pixel `(i, j)` takes (the nearest complete cell for an
/// odd last row or column).
pub(super) fn cell_of(i: usize, j: usize, cells: (usize, usize)) -> (usize, usize) {
    ((i / 2).min(cells.0 - 1), (j / 2).min(cells.1 - 1))
}

/// Largest filter bank or padded white seed (bytes) a loaded model may ask for: a forged
/// `half_width` or image size is refused before anything is allocated.
pub const MAX_WORK_BYTES: u64 = 1 << 36;

/// The level-1 cell grid of a layout, and why arrays have that shape.
pub(super) fn cells(layout: &Layout) -> (Vec<usize>, &'static str) {
    (
        vec![layout.height / 2, layout.width / 2],
        "cell grid of model.json: [height / 2, width / 2]",
    )
}

/// The [`super::SynthesisMethod`] methods that a model holding its [`Filtered`] in a field
/// `filtered` hands to it word for word: its moments, its sample format, and generation in
/// both precisions. Methods 1 and 2 write `delegate_to_filtered!();` in their impls instead of
/// repeating the four.
macro_rules! delegate_to_filtered {
    () => {
        fn moments(&self) -> &Moments {
            &self.filtered.moments
        }

        fn set_sample_format(&mut self, format: u32) {
            self.filtered.moments.sample_format = format;
        }

        fn generate_c128(&self, seed: u64, first: usize, out: &mut [Complex64]) {
            self.filtered.generate_c128(seed, first, out)
        }

        fn generate_c64(&self, seed: u64, first: usize, out: &mut [Complex32]) {
            self.filtered.generate_c64(seed, first, out)
        }
    };
}
pub(super) use delegate_to_filtered;

/// A fitted filter model (Method 1 or 2) with its moments.
#[derive(Debug, Clone)]
pub struct Filtered {
    /// The per-pixel moments.
    pub moments: Moments,
    /// The filters.
    pub filter: FilterModel,
    /// In sample format 2: the bank prepared for the kernel, made on first use.
    fast: OnceLock<FastFilter>,
}

impl Filtered {
    /// The model of `filter` with `moments`.
    pub fn new(moments: Moments, filter: FilterModel) -> Self {
        Filtered {
            moments,
            filter,
            fast: OnceLock::new(),
        }
    }

    /// The bank prepared for the format-2 kernel.
    fn fast(&self) -> &FastFilter {
        self.fast.get_or_init(|| {
            FastFilter::new(&self.filter.bank, &self.moments.mean, &self.moments.std)
        })
    }

    /// [`super::method::SynthesisMethod::generate_c128`] of a filter model.
    pub(super) fn generate_c128(&self, seed: u64, first: usize, out: &mut [Complex64]) {
        sampling::generate_c128(self, &self.moments, seed, first, out)
    }

    /// [`super::method::SynthesisMethod::generate_c64`] of a filter model.
    pub(super) fn generate_c64(&self, seed: u64, first: usize, out: &mut [Complex32]) {
        sampling::generate_c64(self, &self.moments, seed, first, out)
    }

    /// The unreached directions `model.json` records, with `negative_signs` (Method 1's).
    pub(super) fn recorded(&self, negative_signs: Option<NegativeSigns>) -> Recorded {
        Recorded {
            clamped: self.filter.clamped.iter().map(|&c| c as u64).sum(),
            negative_signs,
        }
    }

    /// Writes the residuals and unreached counts both filter methods save.
    pub(super) fn save_fit(&self, store: &mut impl ArrayStore) -> anyhow::Result<()> {
        store.write("residual_h.npy", &self.filter.residual_h)?;
        store.write("residual_v.npy", &self.filter.residual_v)?;
        store.write("clamped.npy", &self.filter.clamped)
    }

    /// Reads back what [`Filtered::save_fit`] wrote and makes the model of `params`.
    pub(super) fn load_fit(
        moments: Moments,
        params: CellParams,
        layout: &Layout,
        store: &impl ArrayStore,
    ) -> anyhow::Result<Self> {
        let residual = |name| {
            store.read(
                name,
                cells(layout),
                (
                    &|e: &f64| !e.is_infinite(),
                    "a residual is finite (NaN for masked cells)",
                ),
            )
        };
        let residuals = (residual("residual_h.npy")?, residual("residual_v.npy")?);
        let clamped = store.read(
            "clamped.npy",
            cells(layout),
            (
                &|c: &u8| *c <= 2,
                "a clamped count is 0, 1 or 2 (one per direction)",
            ),
        )?;
        let shape = (layout.half_width, layout.height, layout.width);
        let filter = FilterModel::new(params, residuals, clamped, shape);
        Ok(Filtered::new(moments, filter))
    }

    /// Refuses an image without a level-1 cell (`name`: the method).
    ///
    /// # Errors
    /// Naming the size.
    pub(super) fn check_image(name: &str, layout: &Layout) -> anyhow::Result<()> {
        let (h, w) = (layout.height, layout.width);
        if h < 2 || w < 2 {
            bail!(
                "{name} needs an image of at least 2x2 pixels (one level-1 cell), this one is {h}x{w}"
            );
        }
        Ok(())
    }

    /// Refuses a half-width and image size whose filter bank or padded white seed would be
    /// larger than [`MAX_WORK_BYTES`].
    ///
    /// # Errors
    /// Naming the size refused.
    pub(super) fn check_work(layout: &Layout) -> anyhow::Result<()> {
        let (h, w, k) = (layout.height, layout.width, layout.half_width);
        let taps = k.checked_mul(2).and_then(|t| t.checked_add(1));
        let bank = taps.and_then(|t| t.checked_mul(h)?.checked_mul(w)?.checked_mul(2 * 8));
        let seed = k.checked_mul(2).and_then(|p| {
            h.checked_add(p)?
                .checked_mul(w.checked_add(p)?)?
                .checked_mul(16)
        });
        for (what, bytes) in [("filter bank", bank), ("padded white seed", seed)] {
            match bytes {
                Some(b) if b as u64 <= MAX_WORK_BYTES => {}
                _ => bail!(
                    "half_width {k} on a {h}x{w} image needs a {what} of {} bytes; at most {MAX_WORK_BYTES} are allowed",
                    bytes.map_or("more than 2^64".to_string(), |b| b.to_string())
                ),
            }
        }
        Ok(())
    }
}

impl OneAtATime for Filtered {
    /// Sample `index` in format 1: the `f64` white seed of stream `index` filtered, scaled
    /// to the moments.
    fn sample_f64(&self, seed: u64, index: usize, out: &mut [Complex64]) {
        let (h, w) = self.moments.mean.dim();
        let bank = &self.filter.bank;
        let k = bank.half_width;
        let white = crate::seeds::white_seed(seed, index, h + 2 * k, w + 2 * k);
        filter_seed(bank, white.view(), out);
        let (mean, std) = (
            self.moments.mean.as_slice().expect("standard layout"),
            self.moments.std.as_slice().expect("standard layout"),
        );
        for (((x, sd), mu), s) in out.iter_mut().zip(bank.output_sds()).zip(mean).zip(std) {
            *x = mu + *x * (s / sd);
        }
    }

    /// Sample `index` in format 2 (the kernel).
    fn sample_f32(&self, seed: u64, index: usize, scratch: &mut Scratch, out: &mut [Complex32]) {
        self.fast().sample(seed, index, scratch, out)
    }
}
