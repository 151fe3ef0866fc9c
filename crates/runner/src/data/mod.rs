//! Materialises validated datasets into stacks: synthetic filtered noise (generated from the
//! job's data seed) or a stack loaded from a file (`.npy`, `.mat`, NetCDF, k-space).
//!
//! Synthetic samples: a white complex circular seed (`E|z|^2 = 1`, real and imaginary parts
//! `N(0, 1/2)`) on a grid padded by the half-width, filtered in 'valid' mode (no edge
//! effects), then `x = mu + std * y / sd(y)` with the analytic `sd(y)`. Sample `s` draws from
//! ChaCha20 seeded with the data seed on stream `s`, so samples are generated in parallel and
//! the stack does not depend on the thread count. K-distributed clutter (`texture_shape`)
//! scales sample `s` by the square root of a gamma texture drawn on stream `2^40 + s`.
//!
//! The stacks are allocated fallibly ([`crate::alloc::try_zeros`]): a stack the memory cannot
//! hold is a [`DataError::Alloc`] that fails its job, not an abort of the process.

use crate::alloc::{try_zeros, AllocError};
use crate::experiment::{Dataset, FilterParams, FilteredNoise, Layout, Map, RawDataset};
use crate::io::npy::{NpyError, Stack};
use crate::seeds::{texture, white_seed_into};
use crate::stats::filters::{dyadic_taps, exponential_taps, filter_seed, FilterBank};
use ndarray::{Array2, Array3};
use num_complex::Complex64;
use rayon::prelude::*;

pub mod netcdf_stack;

/// Why a dataset cannot be materialised.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// A file cannot be read or decoded, or the imaging fails on its data.
    #[error(transparent)]
    Npy(#[from] NpyError),
    /// A MATLAB file's variable cannot be read.
    #[error(transparent)]
    Mat(#[from] crate::io::mat::MatError),
    /// A stack does not fit in memory.
    #[error(transparent)]
    Alloc(#[from] AllocError),
}

/// A dataset ready for analysis.
pub struct Materialised {
    /// The stack.
    pub stack: Stack,
    /// Whether the stack's axes are `[H, W, N]`.
    pub hwn: bool,
    /// For synthetic data: the filter bank and the standard-deviation map (the ground truth).
    pub truth: Option<(FilterBank, Array2<f64>)>,
    /// For `vegetation_isar` with `save_kspace`: the simulated `E(f, phi)`, `[N, n_f, n_phi]`.
    pub kspace: Option<Array3<Complex64>>,
    /// For `vegetation_isar`: the mean over the samples of `E(f, phi)`, `[n_f, n_phi]` (the
    /// dissertation's mean k-space image, Fig. 48).
    pub mean_kspace: Option<Array2<Complex64>>,
}

/// Builds the per-pixel filter bank of a `filtered_noise` dataset.
pub fn filter_bank(d: &FilteredNoise) -> FilterBank {
    let (h, w, k) = (d.height, d.width, d.half_width);
    let grid = |m: &Map| m.grid(h, w);
    let (vertical, horizontal): (Vec<Vec<f64>>, Vec<Vec<f64>>) = match &d.filter {
        FilterParams::Exponential { alpha_h, alpha_v } => {
            let (ah, av) = (grid(alpha_h), grid(alpha_v));
            ah.iter()
                .zip(av.iter())
                .map(|(&a_h, &a_v)| (exponential_taps(a_v, k), exponential_taps(a_h, k)))
                .unzip()
        }
        FilterParams::Dyadic { r_h, r_v } => {
            let rh: Vec<Array2<f64>> = r_h.iter().map(grid).collect();
            let rv: Vec<Array2<f64>> = r_v.iter().map(grid).collect();
            (0..h * w)
                .map(|p| {
                    let at = |maps: &[Array2<f64>]| {
                        maps.iter().map(|m| m[[p / w, p % w]]).collect::<Vec<_>>()
                    };
                    (dyadic_taps(&at(&rv), k), dyadic_taps(&at(&rh), k))
                })
                .unzip()
        }
    };
    FilterBank::new(k, h, w, vertical, horizontal)
}

/// Generates the `[N, H, W]` stack of a `filtered_noise` dataset.
///
/// # Errors
/// [`AllocError`] when the stack does not fit in memory.
pub fn generate(
    d: &FilteredNoise,
    bank: &FilterBank,
    data_seed: u64,
) -> Result<Array3<Complex64>, AllocError> {
    let (h, w, k) = (d.height, d.width, d.half_width);
    let (mean, mean_im, std) = (d.mean.grid(h, w), d.mean_im.grid(h, w), d.std.grid(h, w));
    let gain: Vec<f64> = (0..h * w)
        .map(|p| std[[p / w, p % w]] / bank.output_sd(p))
        .collect();
    let mu: Vec<Complex64> = mean
        .iter()
        .zip(mean_im.iter())
        .map(|(&a, &b)| Complex64::new(a, b))
        .collect();
    let mut out = try_zeros((d.samples, h, w), "the filtered-noise stack")?;
    let data = out.as_slice_mut().expect("standard layout");
    let padded = (h + 2 * k, w + 2 * k);
    data.par_chunks_mut(h * w).enumerate().for_each_init(
        || Array2::zeros(padded),
        |seed, (s, plane)| {
            white_seed_into(data_seed, s, seed.as_slice_mut().expect("standard layout"));
            filter_seed(bank, seed.view(), plane);
            let t = d
                .texture_shape
                .map_or(1.0, |nu| texture(data_seed, s, nu).sqrt());
            for ((x, g), m) in plane.iter_mut().zip(&gain).zip(&mu) {
                *x = m + *x * (*g * t);
            }
        },
    );
    Ok(out)
}

/// Loads or generates the stack of a dataset.
///
/// # Errors
/// [`DataError`] if a file's stack cannot be read or a stack does not fit in memory.
///
/// Long because it is the one match over the dataset kinds, each arm a few lines.
pub fn materialise(dataset: &Dataset, data_seed: u64) -> Result<Materialised, DataError> {
    Ok(match dataset {
        Dataset::FilteredNoise(d) => {
            let bank = filter_bank(d);
            let stack = generate(d, &bank, data_seed)?;
            let std = d.std.grid(d.height, d.width);
            Materialised {
                stack: Stack::Generated(stack),
                hwn: false,
                truth: Some((bank, std)),
                kspace: None,
                mean_kspace: None,
            }
        }
        Dataset::Kspace(k) => {
            let e = Stack::load(&k.path)?.to_complex128(false);
            let opts = crate::physics::isar::ImagingOptions {
                size: k.image_size,
                ..Default::default()
            };
            let planes: Vec<Result<ndarray::Array2<Complex64>, String>> = (0..k.samples)
                .into_par_iter()
                .map(|s| {
                    crate::physics::isar::try_image(
                        e.index_axis(ndarray::Axis(0), s),
                        &k.measurement,
                        &opts,
                    )
                    .map_err(|e| e.to_string())
                })
                .collect();
            let mut images = try_zeros(
                (k.samples, k.image_size, k.image_size),
                "the images of the k-space data",
            )?;
            for (s, p) in planes.into_iter().enumerate() {
                let p = p.map_err(|reason| NpyError::Data {
                    path: k.path.clone(),
                    reason,
                })?;
                images.index_axis_mut(ndarray::Axis(0), s).assign(&p);
            }
            Materialised {
                stack: Stack::Generated(images),
                hwn: false,
                truth: None,
                kspace: None,
                mean_kspace: e
                    .slice(ndarray::s![..k.samples, .., ..])
                    .mean_axis(ndarray::Axis(0)),
            }
        }
        Dataset::Vegetation(v) => {
            let opts = crate::physics::isar::ImagingOptions {
                size: v.image_size,
                ..Default::default()
            };
            let grid = v.measurement.grid().map_err(|e| NpyError::Data {
                path: "vegetation_isar".into(),
                reason: e.to_string(),
            })?;
            let (mut kspace, mut images) = crate::physics::vegetation::try_simulate(
                &v.scene, &grid, &opts, v.samples, data_seed,
            )
            .map_err(|e| NpyError::Data {
                path: "vegetation_isar".into(),
                reason: e.to_string(),
            })?;
            if let Some(chain) = &v.calibration {
                (kspace, images) = calibrated(chain, &kspace, &grid, &opts, data_seed)?;
            }
            Materialised {
                stack: Stack::Generated(images),
                hwn: false,
                truth: None,
                mean_kspace: kspace.mean_axis(ndarray::Axis(0)),
                kspace: v.save_kspace.then_some(kspace),
            }
        }
        Dataset::Netcdf(n) => Materialised {
            stack: Stack::Generated(crate::data::netcdf_stack::load(n).map_err(|e| {
                NpyError::Data {
                    path: n.path.clone(),
                    reason: format!("{e:#}"),
                }
            })?),
            hwn: false,
            truth: None,
            kspace: None,
            mean_kspace: None,
        },
        Dataset::Mat(m) => Materialised {
            stack: crate::io::mat::load_stack(&m.path, Some(&m.variable))?,
            hwn: m.layout == Layout::Hwn,
            truth: None,
            kspace: None,
            mean_kspace: None,
        },
        Dataset::Raw(r) => Materialised {
            stack: Stack::Generated(read_raw(r)?),
            hwn: r.layout == Layout::Hwn,
            truth: None,
            kspace: None,
            mean_kspace: None,
        },
        Dataset::Npy(n) => Materialised {
            stack: Stack::load(&n.path)?,
            hwn: n.layout == Layout::Hwn,
            truth: None,
            kspace: None,
            mean_kspace: None,
        },
    })
}

/// The values of a raw dataset's file as complex128, in their stored order (`[N, H, W]`, or
/// `[H, W, N]` with `layout: hwn`), read a block at a time.
fn read_raw(r: &RawDataset) -> Result<Array3<Complex64>, DataError> {
    use std::io::Read;
    let (n, h, w) = r.shape;
    let dims = match r.layout {
        Layout::Nhw => (n, h, w),
        Layout::Hwn => (h, w, n),
    };
    let data_err = |e: std::io::Error| NpyError::Data {
        path: r.path.clone(),
        reason: e.to_string(),
    };
    let mut out: Array3<Complex64> = try_zeros(dims, "the raw stack")?;
    let mut file = std::io::BufReader::new(std::fs::File::open(&r.path).map_err(data_err)?);
    let mut block = vec![0u8; 8 << 13];
    for chunk in out
        .as_slice_mut()
        .expect("standard layout")
        .chunks_mut(1 << 13)
    {
        let bytes = &mut block[..8 * chunk.len()];
        file.read_exact(bytes).map_err(data_err)?;
        for (z, b) in chunk.iter_mut().zip(bytes.chunks_exact(8)) {
            let re = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            let im = f32::from_le_bytes([b[4], b[5], b[6], b[7]]);
            *z = Complex64::new(re.into(), im.into());
        }
    }
    Ok(out)
}

/// Measures simulated k-space data through the calibration chain and calibrates them (one
/// measurement per sample and azimuth, each with its own noise stream), then images them.
fn calibrated(
    chain: &crate::physics::calibration::ChainParams,
    kspace: &Array3<Complex64>,
    grid: &crate::physics::isar::Measurement,
    opts: &crate::physics::isar::ImagingOptions,
    data_seed: u64,
) -> Result<(Array3<Complex64>, Array3<Complex64>), DataError> {
    use crate::physics::calibration::{factor, measure_and_calibrate};
    let seed = crate::seeds::derive_seed(data_seed, "calibration", "");
    let a = factor(chain, seed);
    let (n, nf, nphi) = kspace.dim();
    let mut out = try_zeros((n, nf, nphi), "the calibrated k-space data")?;
    out.as_slice_mut()
        .expect("standard layout")
        .par_chunks_mut(nf * nphi)
        .enumerate()
        .for_each(|(s, plane)| {
            for j in 0..nphi {
                let e: Vec<Complex64> = (0..nf).map(|i| kspace[[s, i, j]]).collect();
                // Streams 0-3 are the sphere's; each (sample, azimuth) measurement gets its own.
                let stream = 4 + (s * nphi + j) as u64;
                let c = measure_and_calibrate(chain, &e, &a, seed, stream);
                for i in 0..nf {
                    plane[i * nphi + j] = c[i];
                }
            }
        });
    let mut images = try_zeros((n, opts.size, opts.size), "the calibrated images")?;
    for s in 0..n {
        let img = crate::physics::isar::try_image(out.index_axis(ndarray::Axis(0), s), grid, opts)
            .map_err(|e| NpyError::Data {
                path: "vegetation_isar".into(),
                reason: e.to_string(),
            })?;
        images.index_axis_mut(ndarray::Axis(0), s).assign(&img);
    }
    Ok((out, images))
}
