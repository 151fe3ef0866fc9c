//! What a dataset costs, for the estimates of the jobs that read it: the sizes of the spec
//! that scale it ([`Sizes`], each with its usual value, for the blame), and the bytes and work
//! of its materialisation ([`Cost`]), with the counting helpers the kinds share (filter banks,
//! imaging, the plant simulation, the Mie series of a calibration sphere). The model as a whole
//! is documented in the runner's `run::estimate` module.

use crate::physics::calibration::ChainParams;
use crate::physics::vegetation::SceneParams;
use std::fmt;

/// Samples of a usual dataset (and of a usual synthesis), for the blame.
pub const USUAL_SAMPLES: f64 = 1000.0;
/// Pixels of a usual image (64 x 64), for the blame.
pub const USUAL_PIXELS: f64 = 4096.0;
/// The usual filter half-width (the default `half_width`).
pub const USUAL_HALF_WIDTH: f64 = 8.0;
/// The usual side of an imaged dataset (the default `image_size`).
pub const USUAL_IMAGE_SIZE: f64 = 64.0;
/// The usual number of frequencies or azimuths of a measurement (the default grid).
pub const USUAL_GRID: f64 = 256.0;
/// Bytes of one complex128 value.
pub const C128: f64 = 16.0;
/// Bytes of one complex64 value.
pub const C64: f64 = 8.0;

/// What a dataset costs to materialise.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Cost {
    /// Bytes alive at the peak of the materialisation.
    pub peak: f64,
    /// Bytes the materialised dataset keeps (stack, truth, k-space).
    pub kept: f64,
    /// Extra bytes of its complex128 copy beyond `16 N P` (a mapped stack's element copy).
    pub widen: f64,
    /// Work of the materialisation.
    pub flops: f64,
    /// Bytes of the k-space copy an analysis job keeps to save it (`save_kspace`).
    pub saved_kspace: f64,
}

/// A size of the spec that an estimate reads, located in the spec.
#[derive(Debug, Clone, PartialEq)]
pub struct Blame {
    /// YAML path of the key (`datasets[0].samples`, `calibration.points`).
    pub path: String,
    /// Its value as written (`1000000000000`, `[4096, 4096]`).
    pub value: String,
    /// How many times its usual value it is (the default, or a typical study's value).
    pub ratio: f64,
}

/// The sizes an estimate reads, each with how far it is above its usual value.
#[derive(Debug, Clone, Default)]
pub struct Sizes(Vec<Blame>);

impl Sizes {
    /// Records the size at `path` with value `value` (as written) and `ratio` = value / usual
    /// value (for a spacing or another size whose smaller values cost more: usual / value).
    pub fn add(&mut self, path: impl Into<String>, value: impl fmt::Display, ratio: f64) {
        self.0.push(Blame {
            path: path.into(),
            value: value.to_string(),
            ratio: if ratio.is_nan() { 0.0 } else { ratio },
        });
    }

    /// The size furthest above its usual value, if any is above it.
    pub fn furthest(&self) -> Option<&Blame> {
        self.0
            .iter()
            .filter(|b| b.ratio > 1.0)
            .fold(None, |best: Option<&Blame>, b| match best {
                Some(a) if a.ratio >= b.ratio => Some(a),
                _ => Some(b),
            })
    }
}

/// Records the size of a stack read from a file (`npy`, `mat`, `raw`, `netcdf`), for the blame.
pub fn file_sizes(at: &str, (n, h, w): (usize, usize, usize), s: &mut Sizes) {
    let stack = n as f64 * h as f64 * w as f64 / (USUAL_SAMPLES * USUAL_PIXELS);
    s.add(
        format!("{at}.path"),
        format!("a {n} x {h} x {w} stack"),
        stack,
    );
}

/// Records the sizes of a calibration chain at `at` (`calibration`,
/// `datasets[i].calibration`): its frequency points and the electrical size of its sphere.
pub fn chain_sizes(at: &str, c: &ChainParams, s: &mut Sizes) {
    s.add(format!("{at}.points"), c.points, c.points as f64 / 801.0);
    s.add(
        format!("{at}.sphere_radius"),
        c.sphere_radius,
        c.sphere_radius / (0.0254 / 2.0),
    );
    s.add(format!("{at}.f_stop"), c.f_stop, c.f_stop / 18e9);
}

/// Records the sizes of a plant scene at `at` (`datasets[i].scene`); the usual values are the
/// largest of the presets.
pub fn scene_sizes(at: &str, scene: &SceneParams, s: &mut Sizes) {
    let p = &scene.plant;
    let mut add = |key: &str, value: f64, ratio: f64| s.add(format!("{at}.{key}"), value, ratio);
    add("plant.n_stems", p.n_stems as f64, p.n_stems as f64 / 4.0);
    add(
        "plant.branches_per_stem",
        p.branches_per_stem as f64,
        p.branches_per_stem as f64 / 8.0,
    );
    add(
        "plant.leaves_per_branch",
        p.leaves_per_branch as f64,
        p.leaves_per_branch as f64 / 4.0,
    );
    add(
        "plant.leaf_points",
        p.leaf_points as f64,
        p.leaf_points as f64 / 8.0,
    );
    add(
        "plant.stem_height_m",
        p.stem_height_m,
        p.stem_height_m / 1.0,
    );
    add(
        "plant.branch_length_m",
        p.branch_length_m,
        p.branch_length_m / 0.08,
    );
    add(
        "plant.scatterer_spacing_m",
        p.scatterer_spacing_m,
        0.01 / p.scatterer_spacing_m,
    );
    add(
        "plant.stem_sway_freq_hz",
        p.stem_sway_freq_hz,
        p.stem_sway_freq_hz / 1.2,
    );
    add(
        "plant.branch_sway_freq_hz",
        p.branch_sway_freq_hz,
        p.branch_sway_freq_hz / 4.0,
    );
    add(
        "sample_interval_s",
        scene.sample_interval_s,
        scene.sample_interval_s / 2.0,
    );
}

/// Operations to image one measurement of `k` points into `s2` pixels (polar reformatting and
/// a 2-D FFT).
pub fn imaging_flops(k: f64, s2: f64) -> f64 {
    20.0 * k + 5.0 * s2 * s2.max(2.0).log2()
}

/// What a simulated plant costs.
pub struct Plant {
    /// Point scatterers of one sample.
    pub scatterers: f64,
    /// Bytes of the geometry and of one sample's scatterers and their phase steps.
    pub bytes: f64,
    /// Work of the geometry (the leaves' double-bounce partners) and of the wind.
    pub flops: f64,
}

/// The plant of `scene` over `n` samples of `azimuths` azimuths: stem and branch points at
/// their spacing, leaf clusters of `leaf_points` each (and a double-bounce point), and the wind's
/// sub-steps (40 per period of the fastest sway, over the burn-in of up to 600 s and every
/// sample interval), each moving every stem and branch.
pub fn plant(scene: &SceneParams, n: f64, azimuths: f64) -> Plant {
    let p = &scene.plant;
    let spacing = p.scatterer_spacing_m.max(1e-12);
    let stems = p.n_stems as f64;
    let branches = stems * p.branches_per_stem as f64;
    let leaves = branches * p.leaves_per_branch as f64;
    let structure =
        stems * (p.stem_height_m / spacing + 2.0) + branches * (p.branch_length_m / spacing).ceil();
    let scatterers = structure + leaves * (p.leaf_points as f64 + 1.0) + 32.0;
    let double_bounce = if p.double_bounce {
        10.0 * leaves * structure
    } else {
        0.0
    };
    let w = &scene.wind;
    let f_max = p.stem_sway_freq_hz.max(p.branch_sway_freq_hz);
    let t_osc = 1.0 / (p.sway_damping * 2.0 * std::f64::consts::PI * p.stem_sway_freq_hz);
    let burn = (5.0 * w.gust_time_constant_s.max(t_osc)).min(600.0);
    let time = burn + (n - 1.0).max(0.0) * scene.sample_interval_s;
    let substeps = time * 40.0 * f_max + n + 1.0;
    // Sequential: a sub-step of the preset plants (11 oscillators, 6 normal draws) takes about
    // 60 ns, some 1800 operations of the reference core; 170 per oscillator.
    Plant {
        scatterers,
        bytes: scatterers * (100.0 + C128 * azimuths),
        flops: double_bounce + substeps * 170.0 * (stems + branches + 1.0) + 40.0 * n * leaves,
    }
}

/// Bytes (the recurrences of one evaluation at the largest `ka`) and work of `evaluations` Mie
/// series of the chain's sphere over its frequency points: `ka + 6 ka^(1/3) + 8` terms at
/// `ka = 2 pi f sphere_radius / c`, each about 15 ns of sequential recurrences and complex
/// divisions (some 450 operations of the reference core; 250 at the largest `ka`).
pub fn mie(c: &ChainParams, evaluations: f64) -> (f64, f64) {
    let ka = 2.0 * std::f64::consts::PI * c.f_stop.abs() * c.sphere_radius.abs()
        / crate::physics::calibration::C;
    let terms = if ka < 0.01 {
        1.0
    } else {
        ka + 6.0 * ka.cbrt() + 8.0
    };
    (28.0 * terms, evaluations * c.points as f64 * 250.0 * terms)
}
