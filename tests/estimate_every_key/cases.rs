//! The bases (a small valid spec of each section) and the explicit list of numeric keys: for
//! each, an absurd value, the base it is set in, and whether it scales memory or work (then
//! `validate` must refuse it, naming the YAML path) or is a value that does not (then only
//! "no crash" is asked of it).

use super::schema::Base;
use ndarray::Array3;
use ndarray_npy::WriteNpyExt;
use num_complex::Complex;
use std::path::Path;

/// 10^12 as an integer.
pub const BIG: &str = "1000000000000";
/// The largest integer a `usize` key takes (`u64::MAX`), tried after [`BIG`].
pub const MAX: &str = "18446744073709551615";
/// 10^12 as a float.
pub const HUGE: &str = "1.0e12";

/// Filtered noise with a uniform filter (its lag rows are written), maps as patterns.
const NOISE: &str = "name: walk
seed: 1
datasets:
  - id: d
    kind: filtered_noise
    family: exponential
    alpha_h: 1.0
    alpha_v: 2.0
    size: [16, 16]
    samples: 8
    half_width: 2
    mean: {pattern: left_right, left: 0.0, right: 1.0}
    mean_im: {pattern: top_bottom, top: 0.0, bottom: 1.0}
    std: {pattern: ramp, axis: horizontal, from: 1.0, to: 2.0}
    texture_shape: 2.0
analysis:
  levels: 1
outputs:
  filter_lags: 2
";

/// A dyadic filter with a pattern among its parameters.
const DYADIC: &str = "name: walk
seed: 1
datasets:
  - id: d
    kind: filtered_noise
    family: dyadic
    r_h: [0.3, {pattern: constant, value: 0.1}]
    r_v: [0.2, 0.1]
    size: [16, 16]
    samples: 8
    half_width: 3
analysis:
  levels: 1
";

/// Synthesis with Method 2, KL metrics with parameters and the CMD, a noise floor by draws.
const SYN: &str = "name: walk
seed: 1
datasets:
  - id: d
    kind: filtered_noise
    family: exponential
    alpha_h: 1.0
    alpha_v: 1.0
    size: [8, 8]
    samples: 8
    half_width: 2
analysis:
  levels: 1
synthesis:
  methods: [uncorrelated, method2]
  samples: 8
  half_width: 2
  levels: 1
metrics:
  - cmd
  - kl_pixel: {bins: 8, smoothing: 0.5}
  - kl_area: {bins: 8, block: 4}
noise_floor: draws
";

/// A simulated plant (a small measurement and image) with the hypothesis tests.
const PLANT: &str = "name: walk
seed: 1
datasets:
  - id: plant_a_light
    kind: vegetation_isar
    plant: A
    wind: light
    samples: 2
    image_size: 8
    measurement: {f_start: 2.0e9, f_stop: 18.0e9, frequencies: 16, azimuth_span_deg: 51.0, azimuths: 16}
    scene:
      noise_db: -40.0
      background_residual: 0.001
      sample_interval_s: 2.0
      plant: {n_stems: 2}
      wind: {speed_mps: 1.5}
analysis:
  levels: 1
hypotheses:
  max_offset: 2
";

/// A simulated plant measured through a calibration chain.
const PLANT_CAL: &str = "name: walk
seed: 1
datasets:
  - id: p
    kind: vegetation_isar
    plant: B
    samples: 2
    image_size: 8
    measurement: {azimuths: 16}
    calibration: {points: 16, sphere_radius: 0.0127, f_start: 2.0e9, f_stop: 18.0e9}
analysis:
  levels: 1
";

/// Measured k-space data (`kspace.npy`, 2 x 8 x 8, written by [`bases`]).
const KSPACE: &str = "name: walk
seed: 1
datasets:
  - id: k
    kind: kspace
    path: kspace.npy
    freqs: [8.0e9, 8.1e9, 8.2e9, 8.3e9, 8.4e9, 8.5e9, 8.6e9, 8.7e9]
    azimuths_deg: [-4.0, -3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0]
    image_size: 8
analysis:
  levels: 1
";

/// The calibration alone.
const CAL: &str = "name: walk
seed: 1
calibration:
  points: 64
  sphere_radius: 0.0127
  f_start: 2.0e9
  f_stop: 18.0e9
  clutter: [[0.3, 0.01]]
";

/// Two filtered-noise classes and one tiny training per method.
const CLASS: &str = "name: walk
seed: 1
datasets:
  - {id: a, kind: filtered_noise, family: exponential, alpha_h: 1.0, alpha_v: 1.0, size: [32, 32], samples: 10, half_width: 2}
  - {id: b, kind: filtered_noise, family: exponential, alpha_h: 3.0, alpha_v: 3.0, size: [32, 32], samples: 10, half_width: 2}
analysis:
  levels: 1
classification:
  classes: [a, b]
  methods: [original, method2]
  train_sizes: [4]
  holdout: 0.2
  original_fraction: 0.1
  repeats: 1
  half_width: 3
  levels: 1
  training: {epochs: 1, batch_size: 4, learning_rate: 0.01, momentum: 0.9, l2: 0.0001}
";

/// One clutter dataset and one tiny location training per method.
const LOC: &str = "name: walk
seed: 1
datasets:
  - {id: c, kind: filtered_noise, family: exponential, alpha_h: 1.0, alpha_v: 1.0, size: [64, 64], samples: 8, half_width: 2}
analysis:
  levels: 1
location:
  clutter: c
  fit_samples: 4
  methods: [original, method2]
  generated_samples: 4
  targets: [constant]
  scr_db: [0.0]
  repeats: 1
  half_width: 3
  levels: 1
  training: {epochs: 1, batch_size: 2, learning_rate: 0.01, momentum: 0.9, l2: 0.0001}
";

/// Every base in its own folder under `root`, with the files it reads.
pub fn bases(root: &Path) -> Vec<Base> {
    [
        ("noise", NOISE),
        ("dyadic", DYADIC),
        ("syn", SYN),
        ("plant", PLANT),
        ("plant_cal", PLANT_CAL),
        ("kspace", KSPACE),
        ("cal", CAL),
        ("class", CLASS),
        ("loc", LOC),
    ]
    .into_iter()
    .map(|(name, text)| {
        let dir = root.join(name);
        std::fs::create_dir_all(&dir).unwrap();
        if name == "kspace" {
            let data = Array3::from_shape_fn((2, 8, 8), |(n, f, a)| {
                Complex::new((n + f) as f32 * 0.1, a as f32 * 0.05 - 0.2)
            });
            data.write_npy(std::fs::File::create(dir.join("kspace.npy")).unwrap())
                .unwrap();
        }
        Base {
            name,
            dir,
            doc: serde_yaml_ng::from_str(text).unwrap(),
        }
    })
    .collect()
}

/// What an absurd value of a key must give.
#[derive(Debug, Clone, Copy)]
pub enum Expect {
    /// The key scales memory or work: `validate` refuses it with an error at this YAML path
    /// (`""`: the path the value is set at).
    Refused(&'static str),
    /// The key is a value, not a size (the reason): anything but a crash.
    Value(&'static str),
}

/// One absurd value: the generic key it covers (or keys: a component may list alternatives,
/// `{alpha_h,mean}`), the base, the concrete path it is set at and the YAML value.
#[derive(Debug, Clone, Copy)]
pub struct Case {
    /// Generic key (`datasets[].samples`), or a pattern of keys.
    pub key: &'static str,
    /// Base name.
    pub base: &'static str,
    /// Where the value is set (`datasets[0].samples`).
    pub set: &'static str,
    /// The value, as YAML.
    pub value: &'static str,
    /// What it must give.
    pub expect: Expect,
}

const fn size(
    key: &'static str,
    base: &'static str,
    set: &'static str,
    value: &'static str,
) -> Case {
    Case {
        key,
        base,
        set,
        value,
        expect: Expect::Refused(""),
    }
}

const fn value(
    key: &'static str,
    base: &'static str,
    set: &'static str,
    v: &'static str,
    why: &'static str,
) -> Case {
    Case {
        key,
        base,
        set,
        value: v,
        expect: Expect::Value(why),
    }
}

const MAP: &str = "a value of a map (not a size)";
const PHYS: &str = "a physical value (not a size)";
const CHAIN: &str = "a value of the chain (not a size)";
const TRAIN: &str = "a training value (not a size)";

/// Every numeric key of the schema with its absurd value.
pub const CASES: &[Case] = &[
    value("seed", "noise", "seed", BIG, "a seed: hashed, not a size"),
    size("analysis.levels", "noise", "analysis.levels", BIG),
    size("outputs.filter_lags", "noise", "outputs.filter_lags", BIG),
    // Filtered noise.
    Case {
        expect: Expect::Refused("datasets[0].size"),
        ..size("datasets[].size[]", "noise", "datasets[0].size", "[1000000000000, 16]")
    },
    size("datasets[].samples", "noise", "datasets[0].samples", BIG),
    size("datasets[].half_width", "noise", "datasets[0].half_width", BIG),
    value("datasets[].texture_shape", "noise", "datasets[0].texture_shape", HUGE, PHYS),
    value("datasets[].alpha_h", "noise", "datasets[0].alpha_h", HUGE, MAP),
    value("datasets[].alpha_v", "noise", "datasets[0].alpha_v", HUGE, MAP),
    value("datasets[].mean", "noise", "datasets[0].mean", HUGE, MAP),
    value("datasets[].mean_im", "noise", "datasets[0].mean_im", HUGE, MAP),
    value("datasets[].std", "noise", "datasets[0].std", HUGE, MAP),
    value("datasets[].{alpha_h,alpha_v,mean,mean_im,std}.{value,left,right,top,bottom,from,to}", "noise", "datasets[0].mean.right", HUGE, MAP),
    value("datasets[].r_h[]", "dyadic", "datasets[0].r_h[0]", HUGE, MAP),
    value("datasets[].r_v[]", "dyadic", "datasets[0].r_v[1]", HUGE, MAP),
    value("datasets[].{r_h,r_v}[].{value,left,right,top,bottom,from,to}", "dyadic", "datasets[0].r_h[1].value", HUGE, MAP),
    // Synthesis and metrics.
    size("synthesis.samples", "syn", "synthesis.samples", BIG),
    size("synthesis.half_width", "syn", "synthesis.half_width", BIG),
    size("synthesis.levels", "syn", "synthesis.levels", BIG),
    size("metrics[].kl_pixel.bins", "syn", "metrics[1].kl_pixel.bins", BIG),
    size("metrics[].kl_area.bins", "syn", "metrics[2].kl_area.bins", BIG),
    size("metrics[].kl_area.block", "syn", "metrics[2].kl_area.block", BIG),
    value("metrics[].{kl_pixel,kl_area}.smoothing", "syn", "metrics[1].kl_pixel.smoothing", HUGE, "a pseudo-count"),
    value("metrics[].kl_pixel.block", "syn", "metrics[1].kl_pixel.block", BIG, "kl_pixel takes no block"),
    value("metrics[].cmd.{bins,smoothing,block}", "syn", "metrics[0].cmd.bins", BIG, "cmd takes no parameters"),
    value("metrics[].multiscale_rmse.{bins,smoothing,block}", "syn", "metrics[0].multiscale_rmse.bins", BIG, "multiscale_rmse takes no parameters"),
    // Simulated plants.
    size("datasets[].samples", "plant", "datasets[0].samples", BIG),
    size("datasets[].image_size", "plant", "datasets[0].image_size", BIG),
    size("datasets[].measurement.frequencies", "plant", "datasets[0].measurement.frequencies", BIG),
    size("datasets[].measurement.azimuths", "plant", "datasets[0].measurement.azimuths", BIG),
    value("datasets[].measurement.f_start", "plant", "datasets[0].measurement.f_start", HUGE, PHYS),
    value("datasets[].measurement.f_stop", "plant", "datasets[0].measurement.f_stop", HUGE, PHYS),
    value("datasets[].measurement.azimuth_span_deg", "plant", "datasets[0].measurement.azimuth_span_deg", HUGE, PHYS),
    size("hypotheses.max_offset", "plant", "hypotheses.max_offset", BIG),
    size("datasets[].scene.sample_interval_s", "plant", "datasets[0].scene.sample_interval_s", HUGE),
    value("datasets[].scene.noise_db", "plant", "datasets[0].scene.noise_db", HUGE, PHYS),
    value("datasets[].scene.background_residual", "plant", "datasets[0].scene.background_residual", HUGE, PHYS),
    size("datasets[].scene.plant.n_stems", "plant", "datasets[0].scene.plant.n_stems", BIG),
    size("datasets[].scene.plant.branches_per_stem", "plant", "datasets[0].scene.plant.branches_per_stem", BIG),
    size("datasets[].scene.plant.leaves_per_branch", "plant", "datasets[0].scene.plant.leaves_per_branch", BIG),
    size("datasets[].scene.plant.leaf_points", "plant", "datasets[0].scene.plant.leaf_points", BIG),
    size("datasets[].scene.plant.stem_height_m", "plant", "datasets[0].scene.plant.stem_height_m", HUGE),
    size("datasets[].scene.plant.branch_length_m", "plant", "datasets[0].scene.plant.branch_length_m", HUGE),
    size("datasets[].scene.plant.scatterer_spacing_m", "plant", "datasets[0].scene.plant.scatterer_spacing_m", "1.0e-12"),
    size("datasets[].scene.plant.stem_sway_freq_hz", "plant", "datasets[0].scene.plant.stem_sway_freq_hz", HUGE),
    size("datasets[].scene.plant.branch_sway_freq_hz", "plant", "datasets[0].scene.plant.branch_sway_freq_hz", HUGE),
    value("datasets[].scene.plant.base_radius_m", "plant", "datasets[0].scene.plant.base_radius_m", HUGE, PHYS),
    value("datasets[].scene.plant.stem_lean_rad", "plant", "datasets[0].scene.plant.stem_lean_rad", HUGE, PHYS),
    value("datasets[].scene.plant.stem_crookedness_m", "plant", "datasets[0].scene.plant.stem_crookedness_m", HUGE, PHYS),
    value("datasets[].scene.plant.stem_amplitude", "plant", "datasets[0].scene.plant.stem_amplitude", HUGE, PHYS),
    value("datasets[].scene.plant.branch_start_frac", "plant", "datasets[0].scene.plant.branch_start_frac", HUGE, PHYS),
    value("datasets[].scene.plant.branch_elevation_rad", "plant", "datasets[0].scene.plant.branch_elevation_rad", HUGE, PHYS),
    value("datasets[].scene.plant.branch_amplitude", "plant", "datasets[0].scene.plant.branch_amplitude", HUGE, PHYS),
    value("datasets[].scene.plant.leaf_spacing_m", "plant", "datasets[0].scene.plant.leaf_spacing_m", HUGE, PHYS),
    value("datasets[].scene.plant.leaf_size_m", "plant", "datasets[0].scene.plant.leaf_size_m", HUGE, PHYS),
    value("datasets[].scene.plant.leaf_size_spread", "plant", "datasets[0].scene.plant.leaf_size_spread", HUGE, PHYS),
    value("datasets[].scene.plant.leaf_gain", "plant", "datasets[0].scene.plant.leaf_gain", HUGE, PHYS),
    value("datasets[].scene.plant.leaf_diffuse_floor", "plant", "datasets[0].scene.plant.leaf_diffuse_floor", HUGE, PHYS),
    value("datasets[].scene.plant.leaf_max_tilt_rad", "plant", "datasets[0].scene.plant.leaf_max_tilt_rad", HUGE, PHYS),
    value("datasets[].scene.plant.double_bounce_strength", "plant", "datasets[0].scene.plant.double_bounce_strength", HUGE, PHYS),
    value("datasets[].scene.plant.double_bounce_max_dist_m", "plant", "datasets[0].scene.plant.double_bounce_max_dist_m", HUGE, "a distance threshold: the partner search is leaves x points whatever it is"),
    value("datasets[].scene.plant.stem_flexibility", "plant", "datasets[0].scene.plant.stem_flexibility", HUGE, PHYS),
    value("datasets[].scene.plant.branch_flexibility", "plant", "datasets[0].scene.plant.branch_flexibility", HUGE, PHYS),
    value("datasets[].scene.plant.sway_damping", "plant", "datasets[0].scene.plant.sway_damping", HUGE, "a damping ratio: the burn-in is capped at 600 s"),
    value("datasets[].scene.plant.leaf_flutter_freq_hz", "plant", "datasets[0].scene.plant.leaf_flutter_freq_hz", HUGE, "the flutter is an exact OU step, whatever its frequency"),
    value("datasets[].scene.plant.leaf_flutter_scale", "plant", "datasets[0].scene.plant.leaf_flutter_scale", HUGE, PHYS),
    value("datasets[].scene.wind.speed_mps", "plant", "datasets[0].scene.wind.speed_mps", HUGE, PHYS),
    value("datasets[].scene.wind.direction_rad", "plant", "datasets[0].scene.wind.direction_rad", HUGE, PHYS),
    value("datasets[].scene.wind.deflection_gain", "plant", "datasets[0].scene.wind.deflection_gain", HUGE, PHYS),
    value("datasets[].scene.wind.gust_time_constant_s", "plant", "datasets[0].scene.wind.gust_time_constant_s", HUGE, "the burn-in it sets is capped at 600 s"),
    value("datasets[].scene.wind.turbulence_intensity", "plant", "datasets[0].scene.wind.turbulence_intensity", HUGE, PHYS),
    value("datasets[].scene.wind.gust_coherence", "plant", "datasets[0].scene.wind.gust_coherence", HUGE, PHYS),
    value("datasets[].scene.wind.residual_motion_m", "plant", "datasets[0].scene.wind.residual_motion_m", HUGE, PHYS),
    // A plant's calibration chain.
    size("datasets[].calibration.points", "plant_cal", "datasets[0].calibration.points", BIG),
    size("datasets[].calibration.sphere_radius", "plant_cal", "datasets[0].calibration.sphere_radius", HUGE),
    size("datasets[].calibration.f_stop", "plant_cal", "datasets[0].calibration.f_stop", "1.0e25"),
    value("datasets[].calibration.f_start", "plant_cal", "datasets[0].calibration.f_start", HUGE, "bounded by f_stop"),
    value("datasets[].calibration.{gain,ripple,ripple_delay_s,cable_delay_s,background_residual,noise,gate_half_width_m}", "plant_cal", "datasets[0].calibration.gain", HUGE, CHAIN),
    value("datasets[].calibration.clutter[][]", "plant_cal", "datasets[0].calibration.clutter", "[[1.0e12, 1.0e12]]", CHAIN),
    // k-space data.
    size("datasets[].image_size", "kspace", "datasets[0].image_size", BIG),
    value("datasets[].freqs[]", "kspace", "datasets[0].freqs[7]", HUGE, "a frequency of the file's grid (their count is the file's)"),
    value("datasets[].azimuths_deg[]", "kspace", "datasets[0].azimuths_deg[7]", HUGE, "an azimuth of the file's grid (their count is the file's)"),
    // The calibration section.
    size("calibration.points", "cal", "calibration.points", BIG),
    size("calibration.sphere_radius", "cal", "calibration.sphere_radius", HUGE),
    size("calibration.f_stop", "cal", "calibration.f_stop", "1.0e25"),
    value("calibration.f_start", "cal", "calibration.f_start", HUGE, "bounded by f_stop"),
    value("calibration.gain", "cal", "calibration.gain", HUGE, CHAIN),
    value("calibration.ripple", "cal", "calibration.ripple", HUGE, CHAIN),
    value("calibration.ripple_delay_s", "cal", "calibration.ripple_delay_s", HUGE, CHAIN),
    value("calibration.cable_delay_s", "cal", "calibration.cable_delay_s", HUGE, CHAIN),
    value("calibration.background_residual", "cal", "calibration.background_residual", HUGE, CHAIN),
    value("calibration.noise", "cal", "calibration.noise", HUGE, CHAIN),
    value("calibration.gate_half_width_m", "cal", "calibration.gate_half_width_m", HUGE, CHAIN),
    value("calibration.clutter[][]", "cal", "calibration.clutter", "[[1.0e12, 1.0e12]]", CHAIN),
    // Classification.
    size("classification.train_sizes[]", "class", "classification.train_sizes[0]", BIG),
    size("classification.repeats", "class", "classification.repeats", BIG),
    size("classification.half_width", "class", "classification.half_width", BIG),
    size("classification.levels", "class", "classification.levels", BIG),
    size("classification.training.epochs", "class", "classification.training.epochs", BIG),
    Case {
        key: "classification.training.steps",
        base: "class",
        set: "classification.training",
        value: "{protocol: equal_steps, steps: 1000000000000}",
        expect: Expect::Refused("classification.training.steps"),
    },
    value("classification.training.batch_size", "class", "classification.training.batch_size", BIG, "capped at the training set's size"),
    value("classification.training.learning_rate", "class", "classification.training.learning_rate", HUGE, TRAIN),
    value("classification.training.momentum", "class", "classification.training.momentum", HUGE, TRAIN),
    value("classification.training.l2", "class", "classification.training.l2", HUGE, TRAIN),
    value("classification.holdout", "class", "classification.holdout", HUGE, "a fraction"),
    value("classification.original_fraction", "class", "classification.original_fraction", HUGE, "a fraction"),
    value("classification.training.validation_frequency", "class", "classification.training.validation_frequency", BIG, "validation after the last iteration only"),
    // Location.
    size("location.fit_samples", "loc", "location.fit_samples", BIG),
    size("location.original_samples", "loc", "location.original_samples", BIG),
    size("location.generated_samples", "loc", "location.generated_samples", BIG),
    size("location.repeats", "loc", "location.repeats", BIG),
    size("location.half_width", "loc", "location.half_width", BIG),
    size("location.levels", "loc", "location.levels", BIG),
    size("location.training.epochs", "loc", "location.training.epochs", BIG),
    Case {
        key: "location.training.steps",
        base: "loc",
        set: "location.training",
        value: "{protocol: equal_steps, steps: 1000000000000}",
        expect: Expect::Refused("location.training.steps"),
    },
    value("location.training.batch_size", "loc", "location.training.batch_size", BIG, "capped at the training set's size"),
    value("location.training.learning_rate", "loc", "location.training.learning_rate", HUGE, TRAIN),
    value("location.training.momentum", "loc", "location.training.momentum", HUGE, TRAIN),
    value("location.training.l2", "loc", "location.training.l2", HUGE, TRAIN),
    value("location.training.validation_frequency", "loc", "location.training.validation_frequency", BIG, "validation after the last iteration only"),
    value("location.scr_db[]", "loc", "location.scr_db[0]", HUGE, "a ratio in dB"),
];

/// Whether the generic `key` matches `pattern`, whose components may list alternatives
/// (`{alpha_h,mean}` or `{r_h,r_v}[]`).
pub fn matches(pattern: &str, key: &str) -> bool {
    let (p, k): (Vec<&str>, Vec<&str>) = (pattern.split('.').collect(), key.split('.').collect());
    p.len() == k.len()
        && p.iter().zip(&k).all(|(p, k)| match p.strip_prefix('{') {
            None => p == k,
            Some(rest) => {
                let (alternatives, suffix) = rest.split_once('}').unwrap();
                alternatives
                    .split(',')
                    .any(|a| k.strip_suffix(suffix) == Some(a))
            }
        })
}
