//! The model of a dataset job (analysis or synthesis): its dataset as materialised, the
//! analysis, the synthesis model and its samples, the metrics, the noise floor, the filter's lag
//! rows and the hypotheses' correlating function (the terms of [`super`]'s model), and the
//! sizes of the spec these terms read, each with its usual value, for the blame.

use super::{Estimate, Sizes};
use crate::experiment::{Dataset, FilterParams, Map};
use crate::physics::calibration::ChainParams;
use crate::physics::vegetation::SceneParams;
use crate::run::plan::{Job, NoiseFloorPlan, Plan};
use crate::stats::cmd::{choose_forms, Form};
use crate::stats::metrics::{KlOptions, Metric};
use crate::synthesis::Method;

/// Samples of a usual dataset (and of a usual synthesis), for the blame.
pub(super) const USUAL_SAMPLES: f64 = 1000.0;
/// Pixels of a usual image (64 x 64), for the blame.
pub(super) const USUAL_PIXELS: f64 = 4096.0;
/// The usual filter half-width (the default `half_width`).
const USUAL_HALF_WIDTH: f64 = 8.0;
/// The usual side of an imaged dataset (the default `image_size`).
const USUAL_IMAGE_SIZE: f64 = 64.0;
/// The usual number of frequencies or azimuths of a measurement (the default grid).
const USUAL_GRID: f64 = 256.0;

/// Bytes of one complex128 value.
pub(super) const C128: f64 = 16.0;
/// Bytes of one complex64 value.
pub(super) const C64: f64 = 8.0;
/// KL histogram bands counted in flight at once (one per worker thread of a large machine).
const KL_BANDS: f64 = 16.0;

/// What a dataset costs to materialise.
pub(super) struct Data {
    /// Bytes alive at the peak of the materialisation.
    pub(super) peak: f64,
    /// Bytes the materialised dataset keeps (stack, truth, k-space).
    pub(super) kept: f64,
    /// Extra bytes of its complex128 copy beyond `16 N P` (a mapped stack's element copy).
    pub(super) widen: f64,
    /// Work of the materialisation.
    pub(super) flops: f64,
}

/// The estimate of a dataset job (analysis or synthesis) of `plan`.
pub fn dataset_job(plan: &Plan, job: &Job) -> Estimate {
    let (n, h, w) = job.dataset.shape();
    let (n, p) = (n as f64, h as f64 * w as f64);
    let mut sizes = Sizes::default();
    dataset_sizes(&dataset_at(plan, &job.dataset_id), &job.dataset, &mut sizes);
    let data = data(&job.dataset);
    let maps = 96.0 * p;
    let analysis_flops = 20.0 * n * p;
    let copy = C128 * n * p + data.widen;
    let (bytes, flops) = match (job.method, &job.synthesis) {
        (Some(method), Some(syn)) => {
            let m = syn.samples as f64;
            let k = syn.half_width as f64;
            sizes.add("synthesis.samples", syn.samples, m / USUAL_SAMPLES);
            if matches!(method, Method::Method1 | Method::Method2) {
                sizes.add("synthesis.half_width", syn.half_width, k / USUAL_HALF_WIDTH);
            }
            metric_sizes(plan, &mut sizes);
            let needs_copy = matches!(method, Method::FullCovariance | Method::FourthOrder)
                || !plan.metrics.is_empty();
            let (model, fit_flops) = model(method, n, p, k);
            let generated = C64 * m * p;
            let (cmp, cmp_flops) = compare(&plan.metrics, n, m, h, w);
            let bytes = data.kept
                + maps * 2.0
                + if needs_copy { copy } else { 0.0 }
                + model
                + generated
                + cmp;
            let flops = data.flops
                + analysis_flops * 2.0
                + fit_flops
                + generate_flops(method, n, m, p, k)
                + cmp_flops;
            (bytes.max(data.peak), flops)
        }
        _ => {
            let original = job.noise_floor.is_some() || plan.spec.hypotheses.is_some();
            let (floor, floor_flops) = noise_floor(plan, job, n, h, w, &mut sizes);
            let (lags, lags_flops) = filter_lags(plan, job, &mut sizes);
            let (corr, corr_flops) = correlating(plan, n, h, w, &mut sizes);
            // The k-space copy a job keeps to save it (simulated plants with `save_kspace`).
            let kspace_copy = match &job.dataset {
                Dataset::Vegetation(v) if v.save_kspace => {
                    C64 * n * v.measurement.frequencies as f64 * v.measurement.azimuths as f64
                }
                Dataset::Vegetation(_)
                | Dataset::FilteredNoise(_)
                | Dataset::Npy(_)
                | Dataset::Mat(_)
                | Dataset::Netcdf(_)
                | Dataset::Raw(_)
                | Dataset::Kspace(_) => 0.0,
            };
            let bytes = data.kept
                + maps
                + if original { copy } else { 0.0 }
                + floor.max(kspace_copy)
                + lags
                + corr;
            (
                bytes.max(data.peak),
                data.flops + analysis_flops + floor_flops + lags_flops + corr_flops,
            )
        }
    };
    Estimate::new(bytes, flops).blaming(&sizes)
}

/// YAML path of the dataset `id` (`datasets[i]`; `datasets` when the spec lacks it).
pub(super) fn dataset_at(plan: &Plan, id: &str) -> String {
    match plan.spec.datasets.iter().position(|d| d.id == id) {
        Some(i) => format!("datasets[{i}]"),
        None => "datasets".into(),
    }
}

/// Records the sizes of dataset `d` (at YAML path `at`) that its materialisation reads.
pub(super) fn dataset_sizes(at: &str, d: &Dataset, s: &mut Sizes) {
    let (n, h, w) = d.shape();
    let pixels = h as f64 * w as f64;
    let stack = n as f64 * pixels / (USUAL_SAMPLES * USUAL_PIXELS);
    match d {
        Dataset::FilteredNoise(f) => {
            s.add(format!("{at}.samples"), n, n as f64 / USUAL_SAMPLES);
            s.add(
                format!("{at}.size"),
                format!("[{h}, {w}]"),
                pixels / USUAL_PIXELS,
            );
            let k = f.half_width;
            s.add(format!("{at}.half_width"), k, k as f64 / USUAL_HALF_WIDTH);
        }
        Dataset::Npy(_) | Dataset::Mat(_) | Dataset::Netcdf(_) | Dataset::Raw(_) => {
            s.add(
                format!("{at}.path"),
                format!("a {n} x {h} x {w} stack"),
                stack,
            );
        }
        Dataset::Kspace(k) => {
            let file: f64 = k.header.shape.iter().map(|&v| v as f64).product();
            let shape = format!("a {:?} k-space stack", k.header.shape);
            s.add(
                format!("{at}.path"),
                shape,
                file / (USUAL_SAMPLES * USUAL_GRID * USUAL_GRID),
            );
            let side = k.image_size;
            s.add(
                format!("{at}.image_size"),
                side,
                side as f64 / USUAL_IMAGE_SIZE,
            );
        }
        Dataset::Vegetation(v) => {
            s.add(format!("{at}.samples"), n, n as f64 / USUAL_SAMPLES);
            let side = v.image_size;
            s.add(
                format!("{at}.image_size"),
                side,
                side as f64 / USUAL_IMAGE_SIZE,
            );
            let m = &v.measurement;
            match &v.calibration {
                Some(c) => chain_sizes(&format!("{at}.calibration"), c, s),
                None => s.add(
                    format!("{at}.measurement.frequencies"),
                    m.frequencies,
                    m.frequencies as f64 / USUAL_GRID,
                ),
            }
            s.add(
                format!("{at}.measurement.azimuths"),
                m.azimuths,
                m.azimuths as f64 / USUAL_GRID,
            );
            scene_sizes(&format!("{at}.scene"), &v.scene, s);
        }
    }
}

/// Records the sizes of a calibration chain at `at` (`calibration`,
/// `datasets[i].calibration`): its frequency points and the electrical size of its sphere.
pub(super) fn chain_sizes(at: &str, c: &ChainParams, s: &mut Sizes) {
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
fn scene_sizes(at: &str, scene: &SceneParams, s: &mut Sizes) {
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

/// Records the bins of the KL metrics (`metrics[j].kl_pixel.bins`).
fn metric_sizes(plan: &Plan, s: &mut Sizes) {
    let usual = KlOptions::default().bins as f64;
    for (j, m) in plan.metrics.iter().enumerate() {
        let (name, bins) = match *m {
            Metric::KlPixel(o) => ("kl_pixel", o.bins),
            Metric::KlArea(o, _) => ("kl_area", o.bins),
            Metric::Cmd | Metric::MultiscaleRmse => continue,
        };
        s.add(
            format!("metrics[{j}].{name}.bins"),
            bins,
            bins as f64 / usual,
        );
    }
}

/// Bytes and work of the rows of `filter_correlation` (two directions, lags `0..=L`) that the
/// analysis of uniform filtered noise writes.
fn filter_lags(plan: &Plan, job: &Job, s: &mut Sizes) -> (f64, f64) {
    let Dataset::FilteredNoise(f) = &job.dataset else {
        return (0.0, 0.0);
    };
    if !uniform(&f.filter) {
        return (0.0, 0.0);
    }
    let k = f.half_width as f64;
    let lags = match plan.spec.outputs.filter_lags {
        Some(l) => {
            s.add("outputs.filter_lags", l, l as f64 / k.max(USUAL_HALF_WIDTH));
            l as f64
        }
        None => k,
    };
    let rows = 2.0 * (lags + 1.0);
    (200.0 * rows, rows * 8.0 * (2.0 * k + 1.0))
}

/// Bytes and work of the hypotheses' mean correlating function of an analysis job:
/// `(2 R + 1)^2` offsets, each a pass over the pixels (pairs inside the image: a sum over the
/// samples).
fn correlating(plan: &Plan, n: f64, h: usize, w: usize, s: &mut Sizes) -> (f64, f64) {
    let Some(hs) = &plan.spec.hypotheses else {
        return (0.0, 0.0);
    };
    let r = hs.max_offset as f64;
    s.add("hypotheses.max_offset", hs.max_offset, r / 4.0);
    let cells = (2.0 * r + 1.0).powi(2);
    let (h, w) = (h as f64, w as f64);
    let inside = cells.min((2.0 * h - 1.0) * (2.0 * w - 1.0));
    (
        100.0 * cells,
        cells * h * w * 3.0 + inside * h * w * 8.0 * n,
    )
}

/// Bytes and work of materialising `d` (see the module's model).
pub(super) fn data(d: &Dataset) -> Data {
    let (n, h, w) = d.shape();
    let (n, p) = (n as f64, h as f64 * w as f64);
    match d {
        Dataset::FilteredNoise(f) => {
            let k = f.half_width as f64;
            let varying = !uniform(&f.filter);
            let bank = bank_bytes(p, k, varying);
            let kept = C128 * n * p + bank + 48.0 * p;
            Data {
                peak: kept,
                kept,
                widen: 0.0,
                flops: n * p * filter_flops(k, varying),
            }
        }
        Dataset::Npy(npy) => {
            let elem = npy.header.dtype.size() as f64;
            Data {
                peak: 0.0,
                kept: 0.0,
                widen: elem * n * p,
                flops: 0.0,
            }
        }
        Dataset::Raw(_) => Data {
            // The complex128 stack, filled a block of the file at a time.
            peak: C128 * n * p,
            kept: C128 * n * p,
            widen: 0.0,
            flops: 2.0 * n * p,
        },
        Dataset::Mat(_) => Data {
            // The complex128 stack, filled in place (v5 inflates in small blocks, libhdf5
            // converts through its own small buffer).
            peak: C128 * n * p,
            kept: C128 * n * p,
            widen: 0.0,
            flops: 2.0 * n * p,
        },
        Dataset::Netcdf(_) => Data {
            peak: 32.0 * n * p,
            kept: C128 * n * p,
            widen: 0.0,
            flops: 4.0 * n * p,
        },
        Dataset::Kspace(ks) => {
            let file: f64 = ks.header.shape.iter().map(|&s| s as f64).product();
            let elem = ks.header.dtype.size() as f64;
            let k = ks.measurement.n_f() as f64 * ks.measurement.n_phi() as f64;
            let s2 = ks.image_size as f64 * ks.image_size as f64;
            let widen = (elem + C128) * file;
            Data {
                peak: widen.max(C128 * file + 2.0 * C128 * n * s2),
                kept: C128 * n * s2,
                widen: 0.0,
                flops: n * imaging_flops(k, s2),
            }
        }
        Dataset::Vegetation(v) => {
            let azimuths = v.measurement.azimuths as f64;
            let k = v.measurement.frequencies as f64 * azimuths;
            let s2 = v.image_size as f64 * v.image_size as f64;
            let both = C128 * n * (k + s2);
            let kept = C128 * n * s2 + if v.save_kspace { C128 * n * k } else { 0.0 };
            let plant = plant(&v.scene, n, azimuths);
            // With a chain: its factor a(f) (two Mie series), then every azimuth of every
            // sample measured through the chain's clutter.
            let (chain, chain_bytes, chain_flops) = match &v.calibration {
                Some(c) => {
                    let (bytes, flops) = mie(c, 2.0);
                    let clutter = 30.0 * c.clutter.len() as f64 + 60.0;
                    (2.0, bytes, flops + n * k * clutter)
                }
                None => (1.0, 0.0, 0.0),
            };
            Data {
                peak: chain * both + plant.bytes + chain_bytes,
                kept,
                widen: 0.0,
                flops: n * (8.0 * plant.scatterers * k + imaging_flops(k, s2))
                    + plant.flops
                    + chain_flops,
            }
        }
    }
}

/// Whether every filter parameter of a `filtered_noise` dataset is one value (a uniform bank).
fn uniform(f: &FilterParams) -> bool {
    let constant = |m: &Map| matches!(m, Map::Constant(_));
    match f {
        FilterParams::Exponential { alpha_h, alpha_v } => constant(alpha_h) && constant(alpha_v),
        FilterParams::Dyadic { r_h, r_v } => r_h.iter().chain(r_v).all(constant),
    }
}

/// Bytes of a per-pixel filter bank: two tap vectors of `2K + 1` per pixel (with their
/// headers), plus the planar copy a spatially varying bank builds for its kernel.
fn bank_bytes(p: f64, k: f64, varying: bool) -> f64 {
    let taps = 8.0 * (2.0 * k + 1.0);
    2.0 * p * (taps + 48.0) + if varying { 2.0 * p * taps } else { 0.0 }
}

/// Operations per output pixel of the separable filter: two passes of `2K + 1` complex
/// multiply-adds (uniform), or `(2K + 1)^2` for a spatially varying bank.
fn filter_flops(k: f64, varying: bool) -> f64 {
    let taps = 2.0 * k + 1.0;
    if varying {
        8.0 * taps * taps
    } else {
        16.0 * taps
    }
}

/// Operations to image one measurement of `k` points into `s2` pixels (polar reformatting and
/// a 2-D FFT).
fn imaging_flops(k: f64, s2: f64) -> f64 {
    20.0 * k + 5.0 * s2 * s2.max(2.0).log2()
}

/// What a simulated plant costs.
struct Plant {
    /// Point scatterers of one sample.
    scatterers: f64,
    /// Bytes of the geometry and of one sample's scatterers and their phase steps.
    bytes: f64,
    /// Work of the geometry (the leaves' double-bounce partners) and of the wind.
    flops: f64,
}

/// The plant of `scene` over `n` samples of `azimuths` azimuths: stem and branch points at
/// their spacing, leaf clusters of `leaf_points` each (and a double-bounce point), and the wind's
/// sub-steps (40 per period of the fastest sway, over the burn-in of up to 600 s and every
/// sample interval), each moving every stem and branch.
fn plant(scene: &SceneParams, n: f64, azimuths: f64) -> Plant {
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
pub(super) fn mie(c: &ChainParams, evaluations: f64) -> (f64, f64) {
    let ka = 2.0 * std::f64::consts::PI * c.f_stop.abs() * c.sphere_radius.abs()
        / crate::physics::calibration::C;
    let terms = if ka < 0.01 {
        1.0
    } else {
        ka + 6.0 * ka.cbrt() + 8.0
    };
    (28.0 * terms, evaluations * c.points as f64 * 250.0 * terms)
}

/// Bytes and fitting work of a model of `method` fitted to `n` samples of `p` pixels.
pub(super) fn model(method: Method, n: f64, p: f64, k: f64) -> (f64, f64) {
    let base = 24.0 * p;
    match method {
        Method::Uncorrelated => (base, 4.0 * n * p),
        Method::FourthOrder => (base + 82.0 * p, 30.0 * n * p),
        // The centred samples, and their f32 packing (16-column panels) for the sampler.
        Method::FullCovariance => (
            base + C128 * n * p + 4.0 * n * (2.0 * p / 16.0).ceil() * 16.0,
            4.0 * n * p,
        ),
        // Per level-1 cell (P / 4) and direction, the inversion or the dyadic solve.
        Method::Method1 => (base + bank_bytes(p, k, true), p / 4.0 * 2.0 * 2e4),
        Method::Method2 => (base + bank_bytes(p, k, true), p / 4.0 * 2.0 * 5e6),
    }
}

/// Work of generating `m` samples of `p` pixels.
pub(super) fn generate_flops(method: Method, n: f64, m: f64, p: f64, k: f64) -> f64 {
    match method {
        Method::Method1 | Method::Method2 => m * p * filter_flops(k, true),
        Method::FullCovariance => 4.0 * n * m * p,
        Method::FourthOrder => 60.0 * m * p,
        Method::Uncorrelated => 20.0 * m * p,
    }
}

/// Bytes and work of comparing `n1` with `n2` samples of `h x w` under `metrics`.
fn compare(metrics: &[Metric], n1: f64, n2: f64, h: usize, w: usize) -> (f64, f64) {
    let p = h as f64 * w as f64;
    let (mut bytes, mut flops) = (0.0f64, 0.0);
    for m in metrics {
        let (b, f) = match *m {
            Metric::KlPixel(o) => kl(o.bins, 1, n1 + n2, h, w),
            Metric::KlArea(o, block) => kl(o.bins, block, n1 + n2, h, w),
            // The normalised stacks (f32 pairs) and their V-side packings.
            Metric::Cmd => (2.0 * C64 * (n1 + n2) * p, cmd_flops(n1, n2, p)),
            Metric::MultiscaleRmse => (0.0, 10.0 * p),
        };
        // Metrics run one after the other: the largest is the peak.
        bytes = bytes.max(b);
        flops += f;
    }
    (bytes, flops)
}

/// Bytes (histograms of the bands in flight, and the maps) and work of a KL metric.
fn kl(bins: usize, block: usize, samples: f64, h: usize, w: usize) -> (f64, f64) {
    let block = block.max(1) as f64;
    let (rows, units) = ((h as f64 / block).floor(), (w as f64 / block).floor());
    let band = 2.0 * 4.0 * 2.0 * units * bins as f64;
    (
        band * rows.min(KL_BANDS) + 16.0 * rows * units,
        12.0 * samples * h as f64 * w as f64,
    )
}

/// Work of the CMD with the forms [`choose_forms`] picks (8 operations per complex
/// multiply-add).
fn cmd_flops(n1: f64, n2: f64, p: f64) -> f64 {
    let forms = choose_forms(n1 as usize, n2 as usize, p as usize);
    let norm = |n: f64, f: Form| match f {
        Form::Gram => n * n * p / 2.0,
        Form::Full => p * p * n / 2.0,
    };
    let cross = match forms[2] {
        Form::Gram => n1 * n2 * p,
        Form::Full => 0.0,
    };
    8.0 * (norm(n1, forms[0]) + norm(n2, forms[1]) + cross)
}

/// Bytes and work of an analysis job's noise floor (beyond the original's copy).
fn noise_floor(plan: &Plan, job: &Job, n: f64, h: usize, w: usize, s: &mut Sizes) -> (f64, f64) {
    let p = h as f64 * w as f64;
    match job.noise_floor {
        None => (0.0, 0.0),
        Some(NoiseFloorPlan::Halves) => {
            metric_sizes(plan, s);
            let half = (n / 2.0).floor();
            let (b, f) = compare(&plan.metrics, half, half, h, w);
            (b + 192.0 * p, f + 20.0 * n * p)
        }
        Some(NoiseFloorPlan::Draws { samples, .. }) => {
            let m = samples as f64;
            s.add("synthesis.samples", samples, m / USUAL_SAMPLES);
            metric_sizes(plan, s);
            let draw = match &job.dataset {
                Dataset::Vegetation(v) => {
                    let mut spec = (**v).clone();
                    spec.samples = samples;
                    spec.save_kspace = false;
                    let d = data(&Dataset::Vegetation(Box::new(spec)));
                    Data {
                        peak: d.peak.max(2.0 * C128 * m * p),
                        ..d
                    }
                }
                Dataset::FilteredNoise(f) => Data {
                    peak: C128 * m * p,
                    kept: C128 * m * p,
                    widen: 0.0,
                    flops: m * p * filter_flops(f.half_width as f64, !uniform(&f.filter)),
                },
                _ => Data {
                    peak: 0.0,
                    kept: 0.0,
                    widen: 0.0,
                    flops: 0.0,
                },
            };
            let (b, f) = compare(&plan.metrics, n, m, h, w);
            (
                draw.peak.max(draw.kept + 96.0 * p + b),
                draw.flops + 20.0 * m * p + f,
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cmd_work_follows_the_cheaper_form() {
        // 100 samples of 4096 pixels: Gram norms (N^2 P / 2 each) and the Gram cross term.
        let (n, p) = (100.0, 4096.0);
        assert_eq!(
            cmd_flops(n, n, p),
            8.0 * (n * n * p / 2.0 * 2.0 + n * n * p)
        );
        // 10^5 samples of 16 pixels: the joint Full form, P^2 (N1 + N2) / 2.
        let (n, p) = (1e5, 16.0);
        assert_eq!(cmd_flops(n, n, p), 8.0 * p * p * n);
    }
}
