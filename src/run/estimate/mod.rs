//! Memory and work of every job, estimated from its validated parameters before anything is
//! allocated, and the check that refuses a plan whose largest job cannot fit: in the machine's
//! memory ([`machine_memory`]) or under `--max-memory` ([`parse_size`]).
//!
//! `validate` and `run --dry-run` call [`check`], which refuses the spec (naming the dataset's
//! YAML path) when a job cannot fit; `run` itself fails only the job that cannot fit (the
//! scheduler asks [`crate::run::jobs::JobKind::estimate`] and [`Estimate::exceeds`]), so the
//! other jobs still write their tables.
//!
//! # The model
//!
//! With `N` samples of `P = H x W` pixels, `M` generated samples, `K` the filter half-width,
//! `k = n_f x n_phi` k-space points and `S` the image side of an imaged dataset, the peak
//! bytes of a job are the sum of what is alive at its largest moment (complex128 is 16 bytes):
//!
//! - the dataset as materialised ([`crate::data::materialise`]): filtered noise `16 N P` plus its filter
//!   bank (`2 P (8 (2K+1) + 48)`, twice that when the bank varies over the image); an `.npy`
//!   stack nothing (it is mapped from the file; the page cache holds it); NetCDF `32 N P` while
//!   the two variables are combined, `16 N P` kept; `kspace` the file as complex128 `16 N k`
//!   (plus the file's own element size while it is widened) and the images twice, `32 N S^2`;
//!   `vegetation_isar` `16 N (k + S^2)`, twice that with a calibration chain;
//! - the complex128 copy of the stack (`16 N P`, plus one element-size copy for a mapped
//!   stack) that the noise floor, the hypotheses, `full_covariance`, `fourth_order` and every
//!   metric read;
//! - the analysis maps (about `96 P`);
//! - a synthesis model: `full_covariance` keeps the centred samples (`16 N P`) and packs them
//!   for its sampler (`8 N P`; the `P x P` covariance is never formed); Methods 1 and 2 their
//!   filter bank as above; `fourth_order` `82 P`;
//! - the generated samples (`8 M P`, complex64);
//! - the metrics: the CMD's normalised stacks and their packings (`16 (N1 + N2) P`), the KL
//!   histograms (`16 bins W / block` per band, 16 bands at a time) and maps;
//! - a noise floor by `draws`: an independent draw of `M` samples (`16 M P`, or a second
//!   simulation of the plants) and its comparison with the original.
//!
//! Work is counted in floating-point operations of the dominant kernels (filtering, imaging,
//! analysis, sampling, the CMD by the forms of [`crate::stats::cmd::choose_forms`]); it is a
//! guide to run time, good to a factor of a few. All arithmetic is in `f64` and converted to
//! `u64` with saturation, so absurd sizes give huge estimates, never an overflow.

use crate::experiment::{Dataset, FilterParams, Map, SpecError};
use crate::run::jobs::all::AllJobs;
use crate::run::plan::{Job, NoiseFloorPlan, Plan};
use crate::stats::cmd::{choose_forms, Form};
use crate::stats::metrics::Metric;
use crate::synthesis::Method;
use std::fmt;

/// Peak memory and work of one job.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// Peak bytes allocated while the job runs (see the module's model).
    pub bytes: u64,
    /// Floating-point operations of its dominant kernels.
    pub flops: f64,
}

impl Estimate {
    /// What a job without a dataset needs at most (the calibration, the hypothesis tests, the
    /// default of [`crate::run::jobs::JobKind::estimate`]): 8 MiB and 10^8 operations.
    pub const SMALL: Estimate = Estimate {
        bytes: 8 << 20,
        flops: 1e8,
    };

    /// An estimate from byte and operation counts in `f64` (negative or NaN counts give 0,
    /// counts past `u64::MAX` saturate).
    pub fn new(bytes: f64, flops: f64) -> Estimate {
        Estimate {
            bytes: bytes as u64,
            flops: if flops.is_nan() { 0.0 } else { flops.max(0.0) },
        }
    }

    /// Why the job cannot run under `limit`, or `None` when it fits.
    pub fn exceeds(&self, limit: &Limit) -> Option<String> {
        (self.bytes > limit.bytes).then(|| {
            format!(
                "needs about {} of memory (estimated before allocating), more than {}",
                human_bytes(self.bytes),
                limit
            )
        })
    }
}

impl fmt::Display for Estimate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} peak memory, {:.1e} flop",
            human_bytes(self.bytes),
            self.flops
        )
    }
}

/// Where a memory limit comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LimitSource {
    /// The machine's memory ([`machine_memory`]).
    Machine,
    /// `--max-memory`.
    Flag,
}

/// The memory a job may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limit {
    /// Bytes.
    pub bytes: u64,
    /// Where the limit comes from.
    pub source: LimitSource,
}

impl fmt::Display for Limit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let size = human_bytes(self.bytes);
        match self.source {
            LimitSource::Machine => write!(f, "the machine's {size}"),
            LimitSource::Flag => write!(f, "--max-memory {size}"),
        }
    }
}

/// The limit jobs run under: the smaller of `max_memory` (`--max-memory`) and the machine's
/// memory; `None` when neither is known.
pub fn limit(max_memory: Option<u64>) -> Option<Limit> {
    let flag = max_memory.map(|bytes| Limit {
        bytes,
        source: LimitSource::Flag,
    });
    let machine = machine_memory().map(|bytes| Limit {
        bytes,
        source: LimitSource::Machine,
    });
    match (flag, machine) {
        (Some(f), Some(m)) if m.bytes < f.bytes => Some(m),
        (Some(f), _) => Some(f),
        (None, m) => m,
    }
}

/// The machine's memory in bytes: `MemTotal` of `/proc/meminfo`, lowered to the cgroup's
/// `memory.max` when that is set (Linux); `None` where neither can be read.
pub fn machine_memory() -> Option<u64> {
    let total = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| meminfo_total(&t));
    let cgroup = std::fs::read_to_string("/sys/fs/cgroup/memory.max")
        .ok()
        .and_then(|t| t.trim().parse::<u64>().ok());
    match (total, cgroup) {
        (Some(t), Some(c)) => Some(t.min(c)),
        (t, c) => t.or(c),
    }
}

/// `MemTotal` (bytes) from the text of `/proc/meminfo` (`MemTotal:  16318412 kB`).
fn meminfo_total(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let mut words = line["MemTotal:".len()..].split_whitespace();
    let value: u64 = words.next()?.parse().ok()?;
    let unit = match words.next() {
        None => 1,
        Some("kB") => 1024,
        Some(_) => return None,
    };
    value.checked_mul(unit)
}

/// Parses a memory size: bytes (`1048576`) or a number with a binary suffix `K`, `M`, `G`, `T`
/// (optionally followed by `B` or `iB`: `8G`, `512MiB`, `1.5G`).
///
/// # Errors
/// A message naming the text when it is not a size.
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let digits = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (number, suffix) = t.split_at(digits);
    let unit: u64 = match suffix.trim().to_ascii_uppercase().as_str() {
        "" | "B" => 1,
        "K" | "KB" | "KIB" => 1 << 10,
        "M" | "MB" | "MIB" => 1 << 20,
        "G" | "GB" | "GIB" => 1 << 30,
        "T" | "TB" | "TIB" => 1 << 40,
        _ => return Err(format!("{text:?} is not a size (bytes, or e.g. 512M, 8G)")),
    };
    let value: f64 = number
        .parse()
        .map_err(|_| format!("{text:?} is not a size (bytes, or e.g. 512M, 8G)"))?;
    let bytes = value * unit as f64;
    if !(bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!(
            "{text:?}: a size is at least 1 byte and below 16 EiB"
        ));
    }
    Ok(bytes as u64)
}

/// Bytes in binary units with three significant digits (`512 B`, `1.50 GiB`, `8.00 EiB`).
pub fn human_bytes(bytes: u64) -> String {
    const UNITS: [&str; 7] = ["B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let mut v = bytes as f64;
    let mut unit = 0;
    while v >= 1024.0 && unit + 1 < UNITS.len() {
        v /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} B")
    } else if v < 10.0 {
        format!("{v:.2} {}", UNITS[unit])
    } else if v < 100.0 {
        format!("{v:.1} {}", UNITS[unit])
    } else {
        format!("{v:.0} {}", UNITS[unit])
    }
}

/// The job of a plan with the largest peak memory.
#[derive(Debug, Clone, PartialEq)]
pub struct Largest {
    /// The job's id.
    pub id: String,
    /// Its estimate.
    pub estimate: Estimate,
    /// The limit it was checked against (`None`: none known).
    pub limit: Option<Limit>,
}

impl fmt::Display for Largest {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "largest job {}: {}", self.id, self.estimate)?;
        if let Some(l) = &self.limit {
            write!(f, " (limit: {l})")?;
        }
        Ok(())
    }
}

/// Estimates every job of `plan` and refuses the plan when one cannot fit under `limit`
/// (see [`limit`]); returns the largest job.
///
/// # Errors
/// A [`SpecError`] at the dataset's YAML path (`datasets[i]`) naming the job, its estimate and
/// the limit.
pub fn check(plan: &Plan, limit: Option<Limit>) -> Result<Largest, SpecError> {
    let all = AllJobs::new(plan);
    let mut largest: Option<Largest> = None;
    for job in all.list() {
        let e = job.estimate(plan);
        if let Some(why) = limit.as_ref().and_then(|l| e.exceeds(l)) {
            let dataset = plan
                .jobs
                .iter()
                .find(|j| j.id == job.id())
                .and_then(|j| plan.spec.datasets.iter().position(|d| d.id == j.dataset_id));
            let (at, advice) = match dataset {
                Some(i) => (format!("datasets[{i}]"), "; make the dataset smaller"),
                None => (job.kind().to_string(), ""),
            };
            return Err(SpecError::at(
                &plan.file,
                at,
                format!("job {} {why}{advice}", job.id()),
            ));
        }
        if largest.as_ref().is_none_or(|l| e.bytes > l.estimate.bytes) {
            largest = Some(Largest {
                id: job.id().to_string(),
                estimate: e,
                limit,
            });
        }
    }
    Ok(largest.unwrap_or(Largest {
        id: "(none)".into(),
        estimate: Estimate::new(0.0, 0.0),
        limit,
    }))
}

/// Bytes of one complex128 value.
const C128: f64 = 16.0;
/// Bytes of one complex64 value.
const C64: f64 = 8.0;
/// KL histogram bands counted in flight at once (one per worker thread of a large machine).
const KL_BANDS: f64 = 16.0;

/// What a dataset costs to materialise.
struct Data {
    /// Bytes alive at the peak of the materialisation.
    peak: f64,
    /// Bytes the materialised dataset keeps (stack, truth, k-space).
    kept: f64,
    /// Extra bytes of its complex128 copy beyond `16 N P` (a mapped stack's element copy).
    widen: f64,
    /// Work of the materialisation.
    flops: f64,
}

/// The estimate of a dataset job (analysis or synthesis) of `plan`.
pub fn dataset_job(plan: &Plan, job: &Job) -> Estimate {
    let (n, h, w) = job.dataset.shape();
    let (n, p) = (n as f64, h as f64 * w as f64);
    let data = data(&job.dataset);
    let maps = 96.0 * p;
    let analysis_flops = 20.0 * n * p;
    let copy = C128 * n * p + data.widen;
    let (bytes, flops) = match (job.method, &job.synthesis) {
        (Some(method), Some(syn)) => {
            let m = syn.samples as f64;
            let k = syn.half_width as f64;
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
            let (floor, floor_flops) = noise_floor(plan, job, n, h, w);
            let kspace_copy = match &job.dataset {
                Dataset::Vegetation(v) if v.save_kspace => {
                    C64 * n * v.measurement.frequencies as f64 * v.measurement.azimuths as f64
                }
                _ => 0.0,
            };
            let bytes =
                data.kept + maps + if original { copy } else { 0.0 } + floor.max(kspace_copy);
            (
                bytes.max(data.peak),
                data.flops + analysis_flops + floor_flops,
            )
        }
    };
    Estimate::new(bytes, flops)
}

/// Bytes and work of materialising `d` (see the module's model).
fn data(d: &Dataset) -> Data {
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
            let k = (ks.measurement.n_f() * ks.measurement.n_phi()) as f64;
            let s2 = (ks.image_size * ks.image_size) as f64;
            let widen = (elem + C128) * file;
            Data {
                peak: widen.max(C128 * file + 2.0 * C128 * n * s2),
                kept: C128 * n * s2,
                widen: 0.0,
                flops: n * imaging_flops(k, s2),
            }
        }
        Dataset::Vegetation(v) => {
            let k = v.measurement.frequencies as f64 * v.measurement.azimuths as f64;
            let s2 = (v.image_size * v.image_size) as f64;
            let both = C128 * n * (k + s2);
            let chain = if v.calibration.is_some() { 2.0 } else { 1.0 };
            let kept = C128 * n * s2 + if v.save_kspace { C128 * n * k } else { 0.0 };
            let points = scatterers(&v.scene.plant);
            Data {
                peak: chain * both + 100.0 * points,
                kept,
                widen: 0.0,
                flops: n * (8.0 * points * k + imaging_flops(k, s2)),
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

/// Point scatterers of a simulated plant: stem and branch points at their spacing, leaf
/// clusters of `leaf_points` each.
fn scatterers(plant: &crate::physics::vegetation::PlantParams) -> f64 {
    let spacing = plant.scatterer_spacing_m.max(1e-9);
    let stems = plant.n_stems as f64;
    let branches = stems * plant.branches_per_stem as f64;
    stems * plant.stem_height_m / spacing
        + branches * plant.branch_length_m / spacing
        + branches * plant.leaves_per_branch as f64 * plant.leaf_points as f64
}

/// Bytes and fitting work of a model of `method` fitted to `n` samples of `p` pixels.
fn model(method: Method, n: f64, p: f64, k: f64) -> (f64, f64) {
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
fn generate_flops(method: Method, n: f64, m: f64, p: f64, k: f64) -> f64 {
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
fn noise_floor(plan: &Plan, job: &Job, n: f64, h: usize, w: usize) -> (f64, f64) {
    let p = h as f64 * w as f64;
    match job.noise_floor {
        None => (0.0, 0.0),
        Some(NoiseFloorPlan::Halves) => {
            let half = (n / 2.0).floor();
            let (b, f) = compare(&plan.metrics, half, half, h, w);
            (b + 192.0 * p, f + 20.0 * n * p)
        }
        Some(NoiseFloorPlan::Draws { samples, .. }) => {
            let m = samples as f64;
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
    fn sizes_parse_with_binary_suffixes() {
        assert_eq!(parse_size("1048576"), Ok(1 << 20));
        assert_eq!(parse_size("512M"), Ok(512 << 20));
        assert_eq!(parse_size("8G"), Ok(8 << 30));
        assert_eq!(parse_size("8GiB"), Ok(8 << 30));
        assert_eq!(parse_size("1.5g"), Ok(3 << 29));
        assert_eq!(parse_size("2T"), Ok(2 << 40));
        for bad in ["", "G", "8X", "-1G", "0", "1e30", "99999999999T", "1.2.3M"] {
            assert!(parse_size(bad).is_err(), "{bad:?} must be refused");
        }
    }

    #[test]
    fn meminfo_total_is_read_in_bytes() {
        let text = "MemFree:  10 kB\nMemTotal:       16318412 kB\nSwapTotal: 0 kB\n";
        assert_eq!(meminfo_total(text), Some(16318412 * 1024));
        assert_eq!(meminfo_total("MemFree: 1 kB\n"), None);
        assert_eq!(meminfo_total("MemTotal: x kB\n"), None);
    }

    #[test]
    fn bytes_print_in_binary_units() {
        assert_eq!(human_bytes(512), "512 B");
        assert_eq!(human_bytes(3 << 29), "1.50 GiB");
        assert_eq!(human_bytes(200 << 20), "200 MiB");
        assert_eq!(human_bytes(u64::MAX), "16.0 EiB");
    }

    #[test]
    fn absurd_counts_saturate_instead_of_overflowing() {
        let e = Estimate::new(1e40, f64::INFINITY);
        assert_eq!(e.bytes, u64::MAX);
        assert_eq!(Estimate::new(f64::NAN, f64::NAN), Estimate::new(0.0, 0.0));
        let limit = Limit {
            bytes: 8 << 30,
            source: LimitSource::Flag,
        };
        let why = e.exceeds(&limit).expect("too large");
        assert!(
            why.contains("16.0 EiB") && why.contains("--max-memory 8.00 GiB"),
            "{why}"
        );
        assert_eq!(Estimate::SMALL.exceeds(&limit), None);
    }

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
