//! Target location data (docs/definitions.md §12, target location): an 8x8 target on a 5x5 grid of
//! locations added to clutter at a signal-to-clutter ratio. Centres at pixel
//! `(8 + 12 i, 8 + 12 j)`, label `5 i + j`; the target occupies rows and columns `c - 4 ..
//! c + 3`. The constant target is one pattern drawn once from the master seed; the stochastic
//! target is new in every sample; both have unit mean power before scaling by
//! `sqrt(P_c 10^(SCR / 10))`, `P_c` the mean over the image of the clutter's per-pixel
//! variance.

use super::train::Labelled;
use crate::location_grid::{centre, LOCATIONS, TARGET};
use ndarray::{Array3, ArrayView3, Axis};
use num_complex::{Complex32, Complex64};
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

/// Target kinds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TargetKind {
    /// One fixed pattern in every sample.
    Constant,
    /// New i.i.d. circular Gaussian pixels in every sample.
    Stochastic,
}

impl TargetKind {
    /// The name used in specs, ids and tables.
    pub fn as_str(self) -> &'static str {
        match self {
            TargetKind::Constant => "constant",
            TargetKind::Stochastic => "stochastic",
        }
    }
}

/// The originals a location network is tested on (5.3.8.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TestSet {
    /// The clutter samples after those the methods were fitted on and `original` trained and
    /// validated on: data no network saw.
    HeldOut,
    /// Every clutter sample, those seen included (the dissertation's protocol, 5.3.8: its
    /// networks were tested on all 1000 originals).
    All,
}

impl TestSet {
    /// The name used in specs and tables.
    pub fn as_str(self) -> &'static str {
        match self {
            TestSet::HeldOut => "held_out",
            TestSet::All => "all",
        }
    }
}

/// `TARGET * TARGET` i.i.d. circular complex Gaussian pixels with unit mean power
/// (`E|t|^2 = 1`), drawn from `rng`.
pub fn random_pattern(rng: &mut ChaCha20Rng) -> Vec<Complex32> {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    (0..TARGET * TARGET)
        .map(|_| {
            let (re, im): (f64, f64) = (StandardNormal.sample(rng), StandardNormal.sample(rng));
            Complex32::new((re * s) as f32, (im * s) as f32)
        })
        .collect()
}

/// The constant target: a pattern drawn from `seed` and scaled to unit mean power exactly.
pub fn constant_pattern(seed: u64) -> Vec<Complex32> {
    let mut p = random_pattern(&mut ChaCha20Rng::seed_from_u64(seed));
    let power = p.iter().map(|z| f64::from(z.norm_sqr())).sum::<f64>() / p.len() as f64;
    let k = (1.0 / power).sqrt() as f32;
    p.iter_mut().for_each(|z| *z *= k);
    p
}

/// Amplitude that scales a unit-power target to `scr_db` over clutter of power `p_c`.
pub fn amplitude(p_c: f64, scr_db: f64) -> f64 {
    (p_c * 10f64.powf(scr_db / 10.0)).sqrt()
}

/// Adds `pattern` scaled by `amp` at location `label` of `image` (`H x W`, row-major).
pub fn insert(
    image: &mut [Complex32],
    width: usize,
    label: usize,
    pattern: &[Complex32],
    amp: f32,
) {
    let (ci, cj) = centre(label);
    for a in 0..TARGET {
        for b in 0..TARGET {
            image[(ci - 4 + a) * width + (cj - 4 + b)] += pattern[a * TARGET + b] * amp;
        }
    }
}

/// Turns clutter images (`N * H * W`) into a labelled set: image `k` gets a target at location
/// `k mod 25` (balanced). The stochastic target of image `k` is drawn from ChaCha20 seeded with
/// `seed` on stream `k`.
pub fn with_targets(
    clutter: &[Complex32],
    width: usize,
    pixels: usize,
    kind: TargetKind,
    constant: &[Complex32],
    amp: f64,
    seed: u64,
) -> Labelled {
    let mut set = Labelled::default();
    let mut img = vec![Complex32::new(0.0, 0.0); pixels];
    for (k, c) in clutter.chunks_exact(pixels).enumerate() {
        img.copy_from_slice(c);
        let label = k % LOCATIONS;
        let pattern = match kind {
            TargetKind::Constant => constant.to_vec(),
            TargetKind::Stochastic => {
                let mut rng = ChaCha20Rng::seed_from_u64(seed);
                rng.set_stream(k as u64);
                random_pattern(&mut rng)
            }
        };
        insert(&mut img, width, label, &pattern, amp as f32);
        set.push(&img, label);
    }
    set
}

/// How a location experiment's clutter stack is split (5.3.8.2): one seeded permutation of its
/// samples; the methods are fitted on its first `fit` samples, `original`'s network trains and
/// validates on its first `originals` (the fit part among them), and every network is tested on
/// the rest ([`TestSet::HeldOut`]) or on every sample ([`TestSet::All`], the dissertation's own
/// protocol).
pub struct Split {
    perm: Vec<usize>,
    fit: usize,
    originals: usize,
}

impl Split {
    /// The split of `n` samples, permuted with `seed`.
    pub fn new(n: usize, seed: u64, fit: usize, originals: usize) -> Self {
        Split {
            perm: super::classification::permutation(n, seed),
            fit,
            originals,
        }
    }

    /// The samples the methods are fitted on.
    pub fn fit(&self, stack: &ArrayView3<Complex64>) -> Array3<Complex64> {
        stack.select(Axis(0), &self.perm[..self.fit])
    }

    /// `original`'s samples, training then validation.
    pub fn originals(&self, stack: &ArrayView3<Complex64>) -> Array3<Complex64> {
        stack.select(Axis(0), &self.perm[..self.originals])
    }

    /// The samples of test set `set`.
    pub fn test(&self, stack: &ArrayView3<Complex64>, set: TestSet) -> Array3<Complex64> {
        let from = match set {
            TestSet::HeldOut => self.originals,
            TestSet::All => 0,
        };
        stack.select(Axis(0), &self.perm[from..])
    }
}

/// `P_c`: the mean over the image of the per-pixel variance of `stack` (`[N, H, W]`, the
/// unbiased variance over its samples), the power a target's SCR is relative to.
pub fn clutter_power(stack: &ArrayView3<Complex64>) -> f64 {
    let (n, h, w) = stack.dim();
    let mean = stack.mean_axis(Axis(0)).expect("samples");
    stack
        .axis_iter(Axis(0))
        .map(|plane| {
            plane
                .iter()
                .zip(mean.iter())
                .map(|(z, m)| (z - m).norm_sqr())
                .sum::<f64>()
        })
        .sum::<f64>()
        / ((n.max(2) - 1) * h * w) as f64
}

/// The values of `stack` in single precision, sample after sample (row-major).
pub fn single(stack: &ArrayView3<Complex64>) -> Vec<Complex32> {
    stack
        .iter()
        .map(|z| Complex32::new(z.re as f32, z.im as f32))
        .collect()
}

/// The training images the report shows (Fig. 72): samples 0, 6, 12, 18 and 24 of `set`, one
/// per row of the grid (sample `k` has its target at location `k mod 25`), as `[5, h, w]`; a
/// sample past the set's end stays zero.
pub fn examples(set: &Labelled, h: usize, w: usize) -> Array3<Complex32> {
    let picks = [0usize, 6, 12, 18, 24];
    let pixels = h * w;
    let mut ex = Array3::<Complex32>::zeros((picks.len(), h, w));
    for (k, &l) in picks.iter().enumerate() {
        if l < set.len() {
            ex.index_axis_mut(Axis(0), k)
                .as_slice_mut()
                .expect("standard layout")
                .copy_from_slice(&set.images[l * pixels..(l + 1) * pixels]);
        }
    }
    ex
}

/// The names of the network's outputs, one per location: `row<r>_col<c>` at its centre.
pub fn output_names() -> Vec<String> {
    (0..LOCATIONS)
        .map(|l| {
            let (r, c) = centre(l);
            format!("row{r}_col{c}")
        })
        .collect()
}

/// Where mean accuracy first reaches `level` along increasing SCR, linearly interpolated
/// between the two SCRs around the crossing (the first SCR if it is already reached there);
/// `None` when it never is. `points` are `(scr_db, accuracy)` sorted by SCR.
pub fn crossing(points: &[(f64, f64)], level: f64) -> Option<f64> {
    let first = points.first()?;
    if first.1 >= level {
        return Some(first.0);
    }
    points.windows(2).find_map(|w| {
        let ((x0, y0), (x1, y1)) = (w[0], w[1]);
        (y0 < level && y1 >= level).then(|| x0 + (level - y0) * (x1 - x0) / (y1 - y0))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_grid_matches_the_definitions() {
        assert_eq!(centre(0), (8, 8));
        assert_eq!(centre(4), (8, 56));
        assert_eq!(centre(24), (56, 56));
        assert_eq!(centre(7), (20, 32));
    }

    #[test]
    fn the_constant_target_has_unit_power_and_a_target_lands_on_its_patch() {
        let p = constant_pattern(7);
        let power = p.iter().map(|z| f64::from(z.norm_sqr())).sum::<f64>() / 64.0;
        assert!((power - 1.0).abs() < 1e-6);
        let mut img = vec![Complex32::new(0.0, 0.0); 64 * 64];
        insert(&mut img, 64, 12, &p, 2.0);
        let (ci, cj) = centre(12);
        let nonzero: Vec<usize> = (0..64 * 64).filter(|&i| img[i].norm_sqr() > 0.0).collect();
        assert_eq!(nonzero.len(), 64);
        assert!(nonzero.iter().all(|&i| {
            let (r, c) = (i / 64, i % 64);
            (ci - 4..ci + 4).contains(&r) && (cj - 4..cj + 4).contains(&c)
        }));
        assert_eq!(img[(ci - 4) * 64 + cj - 4], p[0] * 2.0);
    }

    #[test]
    fn crossings_interpolate_linearly() {
        let pts = [(-10.0, 0.04), (-5.0, 0.3), (0.0, 0.7), (5.0, 0.95)];
        assert!((crossing(&pts, 0.5).unwrap() - (-2.5)).abs() < 1e-12);
        assert!((crossing(&pts, 0.9).unwrap() - 4.0).abs() < 1e-12);
        assert_eq!(crossing(&pts, 0.99), None);
        assert_eq!(crossing(&pts, 0.01), Some(-10.0));
        // 10 dB of SCR is 10x the amplitude squared.
        assert!((amplitude(2.0, 10.0) - 20f64.sqrt()).abs() < 1e-12);
    }
}
