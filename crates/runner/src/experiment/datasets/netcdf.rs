//! The `netcdf` dataset kind: two variables `[time, rows, cols]` of a NetCDF-3 file combined
//! as `u + i v` (fill and missing values are NaN, so masked pixels such as land are excluded
//! by the analysis), optionally with each pixel's per-calendar-month mean removed (anomalies,
//! the usual treatment of monthly geophysical fields), calendar months from
//! [`crate::io::netcdf::time`]. A variable may have more dimensions when those between the
//! first (time) and the last two (rows, cols) have length 1, as OSCAR's
//! `u(time, depth, latitude, longitude)` with its single depth
//! ([`NcFile::read_stack`]).

use super::cost::{file_sizes, Cost, Sizes, C128};
use super::kind::{DataError, DatasetKind, Materialised};
use crate::experiment::context::{Ctx, SpecError};
use crate::io::netcdf::time::months;
use crate::io::netcdf::{NcError, NcFile};
use crate::io::npy::{NpyError, Stack};
use ndarray::Array3;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The fields of a `netcdf` dataset as written.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    /// Path of the file, relative to the spec file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<PathBuf>,
    /// The variable giving the real part, `[time, rows, cols]` (or with dimensions of length 1
    /// between time and rows, such as a single depth).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub u: Option<String>,
    /// The variable giving the imaginary part (absent: 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub v: Option<String>,
    /// Subtract each pixel's mean over the samples of the same calendar month (months from
    /// the time coordinate's `units`, e.g. `hour since 1980-01-14 14:00:00`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub remove_monthly_mean: Option<bool>,
}

/// A validated `netcdf` dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct NetcdfDataset {
    /// Resolved path.
    pub path: PathBuf,
    /// Real-part variable.
    pub u: String,
    /// Imaginary-part variable.
    pub v: Option<String>,
    /// Remove the per-calendar-month mean.
    pub remove_monthly_mean: bool,
    /// `(N, H, W)`: the variables' shape.
    pub shape: (usize, usize, usize),
}

impl DatasetKind for NetcdfDataset {
    const NAME: &'static str = "netcdf";
    const FIELDS: &'static [&'static str] = &["path", "u", "v", "remove_monthly_mean"];
    const SAMPLES_FIELD: &'static str = "u";
    type Spec = Spec;

    fn applies(_: &Spec) -> &'static [&'static str] {
        Self::FIELDS
    }

    fn check(spec: &Spec, ctx: &Ctx, at: &str) -> Result<Self, SpecError> {
        let rel = spec
            .path
            .as_ref()
            .ok_or_else(|| ctx.err(format!("{at}.path"), "kind netcdf needs `path`"))?;
        let path = ctx.resolve(rel);
        let file = crate::io::netcdf::NcFile::open(&path)
            .map_err(|e| ctx.err(format!("{at}.path"), e.to_string()))?;
        let u = spec
            .u
            .clone()
            .ok_or_else(|| ctx.err(format!("{at}.u"), "kind netcdf needs `u` (a variable name)"))?;
        let names: Vec<&str> = file.variables().iter().map(|v| v.name.as_str()).collect();
        let shape_of = |name: &str, field: &str| -> Result<(usize, usize, usize), SpecError> {
            let var = file.variable(name).ok_or_else(|| {
                ctx.err(
                    format!("{at}.{field}"),
                    format!(
                        "{} has no variable {name:?} (it has: {})",
                        path.display(),
                        names.join(", ")
                    ),
                )
            })?;
            file.stack_shape(&var.name)
                .map_err(|e| ctx.err(format!("{at}.{field}"), e.to_string()))
        };
        let shape = shape_of(&u, "u")?;
        if let Some(v) = &spec.v {
            let sv = shape_of(v, "v")?;
            if sv != shape {
                return Err(ctx.err(
                    format!("{at}.v"),
                    format!("{v:?} has shape {sv:?}, {u:?} has {shape:?}; they must match"),
                ));
            }
        }
        let remove_monthly_mean = spec.remove_monthly_mean.unwrap_or(false);
        if remove_monthly_mean {
            crate::io::netcdf::time::months(&file, &u)
                .map_err(|e| ctx.err(format!("{at}.remove_monthly_mean"), e))?;
        }
        Ok(NetcdfDataset {
            path,
            u,
            v: spec.v.clone(),
            remove_monthly_mean,
            shape,
        })
    }

    fn shape(&self) -> (usize, usize, usize) {
        self.shape
    }

    fn input_files(&self) -> Vec<PathBuf> {
        vec![self.path.clone()]
    }

    fn sizes(&self, at: &str, s: &mut Sizes) {
        file_sizes(at, self.shape, s);
    }

    fn cost(&self) -> Cost {
        let (n, h, w) = self.shape;
        let np = n as f64 * h as f64 * w as f64;
        Cost {
            peak: 32.0 * np,
            kept: C128 * np,
            flops: 4.0 * np,
            ..Cost::default()
        }
    }

    fn redraw_cost(&self, _: usize) -> Cost {
        Cost::default()
    }

    fn materialise(&self, _: u64) -> Result<Materialised, DataError> {
        let stack = load(self).map_err(|e| NpyError::Data {
            path: self.path.clone(),
            reason: format!("{e:#}"),
        })?;
        Ok(Materialised::plain(Stack::Generated(stack), false))
    }

    fn redraw(
        &self,
        _: usize,
        _: u64,
        _: &Materialised,
    ) -> Option<Result<Array3<Complex64>, DataError>> {
        None
    }
}

/// Loads the stack `[N, H, W]` of a `netcdf` dataset: `u` is read (dimensions of length 1
/// between time and rows dropped) into the real parts, then `v` into the imaginary parts, one
/// variable alive at a time beside the stack.
///
/// # Errors
/// [`NcError`] if the file or a variable cannot be read; a months error as a message.
pub fn load(d: &NetcdfDataset) -> Result<Array3<Complex64>, anyhow::Error> {
    let file = NcFile::open(&d.path)?;
    let months = if d.remove_monthly_mean {
        Some(months(&file, &d.u).map_err(anyhow::Error::msg)?)
    } else {
        None
    };
    let u = file.read_stack(&d.u)?;
    let mut x: Array3<Complex64> = crate::alloc::try_zeros(u.raw_dim(), "the NetCDF stack")?;
    ndarray::Zip::from(&mut x)
        .and(&u)
        .for_each(|x, &a| *x = Complex64::new(a, 0.0));
    drop(u);
    if let Some(name) = &d.v {
        let v = file.read_stack(name)?;
        if v.dim() != x.dim() {
            // Only if the file changed since validation, which compared the shapes.
            return Err(NcError::BadHeader {
                path: d.path.clone(),
                offset: 0,
                msg: format!(
                    "{name:?} has shape {:?}, {:?} has {:?}",
                    v.dim(),
                    d.u,
                    x.dim()
                ),
            }
            .into());
        }
        ndarray::Zip::from(&mut x)
            .and(&v)
            .for_each(|x, &b| x.im = b);
    }
    drop(file);
    if let Some(months) = months {
        remove_monthly_mean(&mut x, &months);
    }
    Ok(x)
}

/// Subtracts from every sample the mean over the samples of its calendar month, per pixel,
/// over the finite values (a pixel NaN in every sample of a month stays NaN).
pub fn remove_monthly_mean(x: &mut Array3<Complex64>, months: &[u32]) {
    let (n, h, w) = x.dim();
    assert_eq!(months.len(), n, "one month per sample");
    for m in 1..=12 {
        let idx: Vec<usize> = (0..n).filter(|&s| months[s] == m).collect();
        if idx.is_empty() {
            continue;
        }
        for i in 0..h {
            for j in 0..w {
                let vals: Vec<Complex64> = idx
                    .iter()
                    .map(|&s| x[[s, i, j]])
                    .filter(|z| z.re.is_finite() && z.im.is_finite())
                    .collect();
                let mean = if vals.is_empty() {
                    Complex64::new(f64::NAN, f64::NAN)
                } else {
                    vals.iter().sum::<Complex64>() / vals.len() as f64
                };
                for &s in &idx {
                    x[[s, i, j]] -= mean;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn monthly_means_are_removed_per_pixel() {
        // Two years of monthly samples of a 1x2 image: value = month + 10 * year + pixel.
        let months: Vec<u32> = (0..24).map(|s| (s % 12) as u32 + 1).collect();
        let mut x = Array3::from_shape_fn((24, 1, 2), |(s, _, j)| {
            Complex64::new((s % 12) as f64 + 10.0 * (s / 12) as f64 + j as f64, 1.0)
        });
        x[[5, 0, 1]] = Complex64::new(f64::NAN, 0.0);
        remove_monthly_mean(&mut x, &months);
        // Per month, the two years differ by 10: anomalies -5 and +5; imaginary parts 0.
        assert!((x[[0, 0, 0]].re + 5.0).abs() < 1e-12 && (x[[12, 0, 0]].re - 5.0).abs() < 1e-12);
        assert!(x[[12, 0, 0]].im.abs() < 1e-12);
        // A NaN sample stays NaN and its month's mean uses the other year only.
        assert!(x[[5, 0, 1]].re.is_nan());
        assert!(x[[17, 0, 1]].re.abs() < 1e-12);
    }
}
