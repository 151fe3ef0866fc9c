//! Physical stand-in for the ISAR plant-clutter measurements
//! (docs/definitions.md §10): a plant is a set of point scatterers moved by wind, imaged
//! with the chain of [`crate::physics::isar`].
//!
//! Geometry (fixed by the seed). `n_stems` stems rise from bases on a circle
//! of radius `base_radius_m`, each a chain of point scatterers spaced
//! `scatterer_spacing_m` (amplitude `stem_amplitude` each; a vertical stem
//! is broadside at elevation 0, so its points add coherently in the top
//! view, like a cylinder of RCS `2 pi a L^2 / lambda`). Branches leave the
//! upper part of each stem, with leaves along their outer part. A leaf of
//! length `L` (lognormal spread) has area `A = 0.5 L^2` and is a cluster of
//! `leaf_points` scatterers spread over its plane; each carries
//! `a = leaf_gain * A * (floor + (1 - floor) |n . r_hat0|) / leaf_points`
//! (physical-optics plate law `sqrt(sigma) = sqrt(4 pi) A / lambda`, with the
//! incidence factor evaluated at the centre aspect `r_hat0 = x`), so the
//! cluster's coherent sum also has the plate-like specular pattern.
//! Optional double bounce: a leaf and its nearest stem/branch point at
//! distance `d < double_bounce_max_dist_m` give an equivalent scatterer at
//! the mid-point displaced `d/2` down-range (path `r_hat.r1 + d + r_hat.r2`),
//! amplitude `double_bounce_strength * sqrt(|a1 a2|)`.
//!
//! Wind (sequential, deterministic given the seed). A 2-D Ornstein-Uhlenbeck
//! gust `g` (along- and cross-wind, time constant `tau`, std
//! `turbulence_intensity * U`; a shared part with fraction
//! `gust_coherence` of the variance plus an independent part per stem):
//! `dg = -g dt / tau + sigma sqrt(2 / tau) dW`. Drag `~ |V| V` gives a
//! steady tip deflection `D0 = deflection_gain * flexibility * U^2` along the
//! wind and a fluctuating load `deflection_gain * flexibility * U (2 g_u, g_v)`
//! driving damped oscillators for every stem and branch:
//! `x'' + 2 zeta w x' + w^2 x = w^2 F(t)` (semi-implicit Euler, 40 steps per
//! period). A point at height fraction `s` of a stem moves by `D s^2`
//! (cantilever-like shape); branch points add their own oscillator times
//! `t^2` along the branch. Leaves flutter faster: two orientation angles and
//! a 2-D translation follow OU processes with correlation time
//! `1 / (2 pi f_flutter)` and stds `leaf_flutter_scale * U * (L / 0.1 m)` (rad,
//! capped at 1) and `0.3 L` times that (m). All scatterers also get an
//! independent residual jitter `residual_motion_m` per sample (non-zero even
//! without wind). Receiver noise is complex white Gaussian noise of power
//! `10^(noise_db/10) * P`, with `P = sum |a_k|^2` the static clutter power
//! (mean of `|E|^2` over k-space for resolved scatterers); the background
//! residual is a fixed set of 32 weak random points of total power
//! `background_residual * P` inside a 0.25 m radius.

use crate::physics::isar::{self, ImagingOptions, Measurement};
use ndarray::{Array3, Axis};
use num_complex::Complex64;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

pub mod calibration;
mod params;
mod plant;

use params::bad;
pub use params::{parse_dataset_id, PlantParams, SceneParams, VegError, WindParams};
use plant::{build_plant, normal, scatterers, Pose, WindSim};

fn rng_stream(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(stream);
    r
}

/// Fallible version of [`simulate`]: validates all parameters first.
pub fn try_simulate(
    p: &SceneParams,
    m: &Measurement,
    opts: &ImagingOptions,
    n: usize,
    seed: u64,
) -> Result<(Array3<Complex64>, Array3<Complex64>), VegError> {
    p.validate()?;
    m.validate()?;
    if opts.size < 2 {
        return Err(bad("size", "image size must be >= 2"));
    }
    let (nf, np, sz) = (m.n_f(), m.n_phi(), opts.size);
    let mut geo_rng = rng_stream(seed, 0);
    let mut plant = build_plant(&p.plant, &mut geo_rng);
    // clutter reference power of the static plant
    let still = Pose {
        stem_d: vec![[0.0; 2]; p.plant.n_stems],
        br_d: vec![[0.0; 2]; plant.n_branches],
        leaf: vec![[0.0; 4]; plant.leaves.len()],
    };
    let p_ref: f64 = scatterers(&p.plant, &plant, &still)
        .iter()
        .map(|(a, _)| a.norm_sqr())
        .sum();
    let bg_pow: f64 = plant.background.iter().map(|(a, _)| a.norm_sqr()).sum();
    let bg_scale = if bg_pow > 0.0 {
        (p.background_residual * p_ref / bg_pow).sqrt()
    } else {
        0.0
    };
    for b in plant.background.iter_mut() {
        b.0 *= bg_scale;
    }
    let noise_sigma = (10f64.powf(p.noise_db / 10.0) * p_ref / 2.0).sqrt();
    // wind process: sequential, one stream
    let mut wind_rng = rng_stream(seed, 1);
    let mut sim = WindSim::new(&p.plant, &p.wind, &plant, &mut wind_rng);
    let mut kdata: Array3<Complex64> =
        crate::alloc::try_zeros((n, nf, np), "the simulated k-space data")?;
    let mut images: Array3<Complex64> =
        crate::alloc::try_zeros((n, sz, sz), "the simulated images")?;
    for s in 0..n {
        if s > 0 {
            sim.advance(p.sample_interval_s, &mut wind_rng);
        }
        let pose = sim.pose();
        let mut pts = scatterers(&p.plant, &plant, &pose);
        // per-sample stream: residual jitter and receiver noise
        let mut srng = rng_stream(seed, 2 + s as u64);
        if p.wind.residual_motion_m > 0.0 {
            for (_, r) in pts.iter_mut() {
                for c in r.iter_mut() {
                    *c += p.wind.residual_motion_m * normal(&mut srng);
                }
            }
        }
        pts.extend(plant.background.iter().cloned());
        let mut e = isar::point_response(&pts, m);
        if noise_sigma > 0.0 {
            for v in e.iter_mut() {
                *v += Complex64::new(
                    noise_sigma * normal(&mut srng),
                    noise_sigma * normal(&mut srng),
                );
            }
        }
        let img = isar::try_image(e.view(), m, opts)?;
        images.index_axis_mut(Axis(0), s).assign(&img);
        kdata.index_axis_mut(Axis(0), s).assign(&e);
    }
    Ok((kdata, images))
}

/// Simulates `n` samples of the scene: builds the plant geometry from
/// `seed` (fixed over samples), advances the wind state sequentially
/// (OU gusts + damped oscillators + leaf flutter; its own ChaCha stream),
/// and for each sample computes `E(f, phi)` with residual jitter and receiver
/// noise from that sample's own ChaCha stream, plus the static background
/// residual, then the image. Returns `(k-space [n, n_f, n_phi], images
/// [n, size, size])`. Bitwise independent of the rayon thread count.
///
/// # Panics
/// On invalid parameters (use [`try_simulate`] to get an error instead).
pub fn simulate(
    p: &SceneParams,
    m: &Measurement,
    opts: &ImagingOptions,
    n: usize,
    seed: u64,
) -> (Array3<Complex64>, Array3<Complex64>) {
    try_simulate(p, m, opts, n, seed).unwrap_or_else(|e| panic!("vegetation::simulate: {e}"))
}

/// Mean over pixels of the sample variance over the stack,
/// `mean_pixels( mean_s |I_s - mean_s I|^2 )`, of images `[n, size, size]`.
pub fn mean_pixel_variance(images: &Array3<Complex64>) -> f64 {
    let n = images.dim().0;
    if n < 2 {
        return 0.0;
    }
    let mean = images.mean_axis(Axis(0)).expect("n >= 1");
    let mut acc = 0.0;
    for s in 0..n {
        let d = &images.index_axis(Axis(0), s) - &mean;
        acc += d.iter().map(|v| v.norm_sqr()).sum::<f64>();
    }
    acc / (n as f64 * mean.len() as f64)
}

/// Mean image over the stack `[n, size, size]` -> `[size, size]`.
pub fn mean_image(images: &Array3<Complex64>) -> ndarray::Array2<Complex64> {
    images
        .mean_axis(Axis(0))
        .unwrap_or_else(|| ndarray::Array2::zeros((images.dim().1, images.dim().2)))
}

/// Excess kurtosis of the real and imaginary parts of the mean-removed pixel
/// values, each pixel standardised by its own std, pooled over pixels whose
/// variance exceeds `frac` of the largest pixel variance (0 for a Gaussian).
pub fn pixel_excess_kurtosis(images: &Array3<Complex64>, frac: f64) -> f64 {
    let (n, h, w) = images.dim();
    let mean = mean_image(images);
    let mut vars = vec![0.0; h * w];
    for r in 0..h {
        for c in 0..w {
            vars[r * w + c] = (0..n)
                .map(|s| (images[[s, r, c]] - mean[[r, c]]).norm_sqr())
                .sum::<f64>()
                / n as f64;
        }
    }
    let vmax = vars.iter().cloned().fold(0.0, f64::max);
    let (mut m4, mut cnt) = (0.0, 0.0);
    for r in 0..h {
        for c in 0..w {
            let v = vars[r * w + c];
            if v <= frac * vmax || v == 0.0 {
                continue;
            }
            let sd = (v / 2.0).sqrt(); // per real component
            for s in 0..n {
                let d = images[[s, r, c]] - mean[[r, c]];
                m4 += (d.re / sd).powi(4) + (d.im / sd).powi(4);
                cnt += 2.0;
            }
        }
    }
    if cnt == 0.0 {
        0.0
    } else {
        m4 / cnt - 3.0
    }
}

/// Bounding box `[x_min, x_max, y_min, y_max]` (m) of the plant's static
/// scatterers for `seed` (the footprint used by the structure test).
pub fn plant_footprint(p: &PlantParams, seed: u64) -> Result<[f64; 4], VegError> {
    p.validate()?;
    let mut geo_rng = rng_stream(seed, 0);
    let plant = build_plant(p, &mut geo_rng);
    let still = Pose {
        stem_d: vec![[0.0; 2]; p.n_stems],
        br_d: vec![[0.0; 2]; plant.n_branches],
        leaf: vec![[0.0; 4]; plant.leaves.len()],
    };
    let pts = scatterers(p, &plant, &still);
    let mut b = [
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    for (_, r) in pts {
        b[0] = b[0].min(r[0]);
        b[1] = b[1].max(r[0]);
        b[2] = b[2].min(r[1]);
        b[3] = b[3].max(r[1]);
    }
    Ok(b)
}

#[cfg(test)]
mod tests;
