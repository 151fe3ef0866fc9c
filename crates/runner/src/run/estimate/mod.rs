//! Memory and work of every job, estimated from its validated parameters before anything is
//! allocated, and the check that refuses a plan whose largest job cannot fit: in the machine's
//! memory ([`machine_memory`]) or under `--max-memory` ([`parse_size`]), or whose work passes
//! [`MAX_FLOPS`].
//!
//! `validate` and `run --dry-run` call [`crate::run::check::check`], which refuses the spec when a job cannot fit,
//! at the YAML path of the size furthest above its usual value ([`Blame`]: `calibration.points`,
//! `datasets[0].samples`), or at the job's section when no size is unusual; `run` itself fails
//! only the job that cannot fit (the scheduler asks [`crate::run::jobs::JobKind::estimate`] and
//! [`Estimate::exceeds`]), so the other jobs still write their tables. Every numeric spec key
//! that scales memory or work enters an estimate (`tests/estimate_every_key` walks the schema and sets
//! each to an absurd value); the others are values, not sizes.
//!
//! # The model
//!
//! With `N` samples of `P = H x W` pixels, `M` generated samples, `K` the filter half-width,
//! `k = n_f x n_phi` k-space points and `S` the image side of an imaged dataset, the peak
//! bytes of a job are the sum of what is alive at its largest moment (complex128 is 16 bytes):
//!
//! - the dataset as materialised ([`crate::experiment::DatasetKind::materialise`]): filtered noise `16 N P` plus its filter
//!   bank (`2 P (8 (2K+1) + 48)`, twice that when the bank varies over the image); an `.npy`
//!   stack nothing (it is mapped from the file; the page cache holds it); NetCDF `32 N P` while
//!   the two variables are combined, `16 N P` kept; `kspace` the file as complex128 `16 N k`
//!   (plus the file's own element size while it is widened) and the images twice, `32 N S^2`;
//!   `vegetation_isar` `16 N (k + S^2)`, twice that with a calibration chain, plus the plant's
//!   scatterers (about `100 + 16 n_phi` bytes each) and the chain's Mie series (below);
//! - the complex128 copy of the stack (`16 N P`, plus one element-size copy for a mapped
//!   stack) that the noise floor, the hypotheses, `full_covariance`, `fourth_order` and every
//!   metric read;
//! - the analysis maps (about `96 P`), the filter's lag rows (`outputs.filter_lags`, about
//!   `200` bytes a lag) and the hypotheses' correlating function (`(2 max_offset + 1)^2` cells
//!   of about `100` bytes);
//! - a synthesis model: `full_covariance` keeps the centred samples (`16 N P`) and packs them
//!   for its sampler (`8 N P`; the `P x P` covariance is never formed); Methods 1 and 2 their
//!   filter bank as above; `fourth_order` `82 P`;
//! - the generated samples (`8 M P`, complex64);
//! - the metrics: the CMD's normalised stacks and their packings (`16 (N1 + N2) P`), the KL
//!   histograms (`16 bins W / block` per band, 16 bands at a time) and maps;
//! - a noise floor by `draws`: an independent draw of `M` samples (`16 M P`, or a second
//!   simulation of the plants) and its comparison with the original;
//! - a calibration (the `calibration` section, or a plant dataset's chain): about `256` bytes a
//!   frequency point, and the Mie series of the sphere, `ka + 6 ka^(1/3) + 8` terms of about
//!   `28` bytes at the largest `ka = 2 pi f_stop sphere_radius / c`;
//! - a CNN training: its datasets as materialised and concatenated (`32 N P` over the classes),
//!   its model, the training, validation and test sets (`8 P` plus the prepared input each) and a
//!   mini-batch's activations (`8 P f_1` a sample, `min(batch_size, training set)` samples).
//!
//! The model of a dataset job is [`dataset::dataset_job`] (its datasets' own terms come from their
//! kinds, [`crate::experiment::DatasetKind::cost`]); each job of the run as a whole states its
//! own beside its kind (`run/jobs/calibration.rs`, `hypotheses.rs`, `cnn/`).
//!
//! Work is counted in floating-point operations of the dominant kernels (filtering, imaging,
//! analysis, sampling, the CMD by the forms of [`crate::stats::cmd::choose_forms`], the plants'
//! scatterers and wind sub-steps, the Mie series, the correlating function, a training's
//! `6 x` forward multiply-adds per sample and epoch, a thirtieth of that on a GPU); sequential
//! code (the wind, the Mie recurrences) is counted at what its time would allow a reference
//! core of 30 Gflop/s. It is a guide to run time, good to a factor of a few. All arithmetic is in `f64` and converted to `u64` with saturation, so
//! absurd sizes give huge estimates, never an overflow.

pub mod dataset;
mod outputs;

pub use outputs::{footprint, Footprint};

use std::fmt;

pub use crate::resources::{human_bytes, machine_memory};

pub use crate::experiment::datasets::{Blame, Sizes};

/// Most work one job may take, in operations of the reference core (30 Gflop/s): about 40
/// days of that core, a few days of a whole large machine, far beyond any study the tool is
/// meant for (the shipped experiments' largest job takes under 10^13); a job past it comes
/// from an absurd size and is refused like one that cannot fit in memory.
pub const MAX_FLOPS: f64 = 1e17;

/// Peak memory and work of one job.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// Peak bytes allocated while the job runs (see the module's model).
    pub bytes: u64,
    /// Floating-point operations of its dominant kernels.
    pub flops: f64,
    /// The size of the spec furthest above its usual value, when one is above it: what to lower
    /// when the job cannot fit.
    pub blame: Option<Blame>,
}

impl Estimate {
    /// What a job without a dataset needs at most (the hypothesis tests with the usual
    /// `max_offset`, the location summary): 8 MiB and 10^8 operations.
    pub const SMALL: Estimate = Estimate {
        bytes: 8 << 20,
        flops: 1e8,
        blame: None,
    };

    /// An estimate from byte and operation counts in `f64` (negative or NaN counts give 0,
    /// counts past `u64::MAX` saturate).
    pub fn new(bytes: f64, flops: f64) -> Estimate {
        Estimate {
            bytes: bytes as u64,
            flops: if flops.is_nan() { 0.0 } else { flops.max(0.0) },
            blame: None,
        }
    }

    /// The estimate blaming the size of `sizes` furthest above its usual value.
    pub fn blaming(mut self, sizes: &Sizes) -> Estimate {
        self.blame = sizes.furthest().cloned();
        self
    }

    /// Why the job cannot run: its memory is more than `limit` (when one is known) or its work
    /// more than [`MAX_FLOPS`]; `None` when it fits. The reason names the blamed size.
    pub fn exceeds(&self, limit: Option<&Limit>) -> Option<String> {
        let why = match limit {
            Some(l) if self.bytes > l.bytes => format!(
                "needs about {} of memory (estimated before allocating), more than {}",
                human_bytes(self.bytes),
                l
            ),
            _ if self.flops > MAX_FLOPS => format!(
                "needs about {:.1e} flop of work (estimated before running), more than the {:.0e} one job may take (weeks of one core)",
                self.flops, MAX_FLOPS
            ),
            _ => return None,
        };
        Some(match &self.blame {
            Some(b) => format!(
                "{why}; {} = {} is {} times its usual value",
                b.path,
                b.value,
                times(b.ratio)
            ),
            None => why,
        })
    }
}

/// A ratio as a readable multiple (`250`, `1.2e9`).
fn times(ratio: f64) -> String {
    if ratio < 1e4 {
        format!("{ratio:.0}")
    } else {
        format!("{ratio:.1e}")
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
    fn absurd_counts_saturate_instead_of_overflowing() {
        let e = Estimate::new(1e40, f64::INFINITY);
        assert_eq!(e.bytes, u64::MAX);
        assert_eq!(Estimate::new(f64::NAN, f64::NAN), Estimate::new(0.0, 0.0));
        let limit = Limit {
            bytes: 8 << 30,
            source: LimitSource::Flag,
        };
        let why = e.exceeds(Some(&limit)).expect("too large");
        assert!(
            why.contains("16.0 EiB") && why.contains("--max-memory 8.00 GiB"),
            "{why}"
        );
        assert_eq!(Estimate::SMALL.exceeds(Some(&limit)), None);
    }

    #[test]
    fn absurd_work_is_refused_without_a_memory_limit() {
        let e = Estimate::new(1.0, 2.0 * MAX_FLOPS);
        let why = e.exceeds(None).expect("too much work");
        assert!(why.contains("2.0e17 flop of work"), "{why}");
        assert_eq!(Estimate::new(1e30, MAX_FLOPS).exceeds(None), None);
    }

    #[test]
    fn the_blamed_size_is_the_one_furthest_above_its_usual_value() {
        let mut sizes = Sizes::default();
        sizes.add("datasets[0].samples", 2000, 2.0);
        sizes.add("datasets[0].size", "[4096, 4096]", 4096.0);
        sizes.add("datasets[0].half_width", 4, 0.5);
        let e = Estimate::new(1e30, 1.0).blaming(&sizes);
        let b = e.blame.as_ref().expect("a size above its usual value");
        assert_eq!(
            (b.path.as_str(), b.value.as_str()),
            ("datasets[0].size", "[4096, 4096]")
        );
        let limit = Limit {
            bytes: 1 << 30,
            source: LimitSource::Machine,
        };
        let why = e.exceeds(Some(&limit)).expect("too large");
        assert!(
            why.ends_with("; datasets[0].size = [4096, 4096] is 4096 times its usual value"),
            "{why}"
        );
        // Nothing above its usual value: nothing to blame.
        let mut usual = Sizes::default();
        usual.add("calibration.points", 801, 1.0);
        assert_eq!(usual.furthest(), None);
    }
}
