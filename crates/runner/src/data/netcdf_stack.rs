//! A `netcdf` dataset as a stack: two variables `[time, rows, cols]` of a NetCDF-3 file
//! combined as `u + i v` (fill and missing values are NaN, so masked pixels such as land are
//! excluded by the analysis), optionally with each pixel's per-calendar-month mean removed
//! (anomalies, the usual treatment of monthly geophysical fields), calendar months from
//! [`crate::io::netcdf::time`].

use crate::experiment::NetcdfDataset;
use crate::io::netcdf::time::months;
use crate::io::netcdf::{NcError, NcFile};
use ndarray::{Array3, Ix3};
use num_complex::Complex64;

/// Loads the stack `[N, H, W]` of a `netcdf` dataset.
///
/// # Errors
/// [`NcError`] if the file or a variable cannot be read; a months error as a message.
pub fn load(d: &NetcdfDataset) -> Result<Array3<Complex64>, anyhow::Error> {
    let file = NcFile::open(&d.path)?;
    let read = |name: &str| -> Result<Array3<f64>, NcError> {
        Ok(file
            .read_f64(name)?
            .into_dimensionality::<Ix3>()
            .expect("3-D, checked at validation"))
    };
    let u = read(&d.u)?;
    let v = d.v.as_deref().map(read).transpose()?;
    let mut x: Array3<Complex64> = crate::alloc::try_zeros(u.raw_dim(), "the NetCDF stack")?;
    match &v {
        Some(v) => ndarray::Zip::from(&mut x)
            .and(&u)
            .and(v)
            .for_each(|x, &a, &b| *x = Complex64::new(a, b)),
        None => ndarray::Zip::from(&mut x)
            .and(&u)
            .for_each(|x, &a| *x = Complex64::new(a, 0.0)),
    }
    drop((u, v));
    if d.remove_monthly_mean {
        let months = months(&file, &d.u).map_err(anyhow::Error::msg)?;
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
