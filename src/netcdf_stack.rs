//! A `netcdf` dataset as a stack: two variables `[time, rows, cols]` of a NetCDF-3 file
//! combined as `u + i v` (fill and missing values are NaN, so masked pixels such as land are
//! excluded by the analysis), optionally with each pixel's per-calendar-month mean removed
//! (anomalies, the usual treatment of monthly geophysical fields). Calendar months come from the
//! time coordinate's CF-style `units` (`<unit> since <date>[ <time>]`, proleptic Gregorian).

use crate::netcdf::{NcError, NcFile};
use crate::spec::NetcdfDataset;
use ndarray::{Array3, Ix3};
use num_complex::Complex64;

/// Days from 1970-01-01 to a proleptic Gregorian date (H. Hinnant's `days_from_civil`).
pub fn days_from_civil(y: i64, m: u32, d: u32) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (i64::from(m) + 9) % 12;
    let doy = (153 * mp + 2) / 5 + i64::from(d) - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// The proleptic Gregorian `(year, month, day)` of a day count from 1970-01-01.
pub fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (
        if m <= 2 {
            yoe + era * 400 + 1
        } else {
            yoe + era * 400
        },
        m,
        d,
    )
}

/// Parses CF time units `<unit> since YYYY-MM-DD[ hh:mm[:ss]]` into (seconds per unit, epoch
/// in seconds from 1970-01-01).
pub fn parse_time_units(units: &str) -> Result<(f64, f64), String> {
    let (unit, since) = units
        .split_once(" since ")
        .ok_or_else(|| format!("time units {units:?} are not `<unit> since <date>`"))?;
    let scale = match unit.trim().to_ascii_lowercase().trim_end_matches('s') {
        "second" | "sec" => 1.0,
        "minute" | "min" => 60.0,
        "hour" | "hr" | "h" => 3600.0,
        "day" | "d" => 86_400.0,
        other => return Err(format!("time unit {other:?} in {units:?} is not supported")),
    };
    let mut parts = since.split_whitespace();
    let date = parts
        .next()
        .ok_or_else(|| format!("no date in {units:?}"))?;
    let ymd: Vec<&str> = date.split('-').collect();
    let bad = || format!("date {date:?} in {units:?} is not YYYY-MM-DD");
    if ymd.len() != 3 {
        return Err(bad());
    }
    let y: i64 = ymd[0].parse().map_err(|_| bad())?;
    let m: u32 = ymd[1].parse().map_err(|_| bad())?;
    let d: u32 = ymd[2].parse().map_err(|_| bad())?;
    if !(1..=12).contains(&m) || !(1..=31).contains(&d) {
        return Err(bad());
    }
    let mut secs = days_from_civil(y, m, d) as f64 * 86_400.0;
    if let Some(t) = parts.next() {
        let hms: Vec<f64> = t
            .split(':')
            .map(|x| x.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("time {t:?} in {units:?} is not hh:mm[:ss]"))?;
        secs += hms
            .iter()
            .zip([3600.0, 60.0, 1.0])
            .map(|(v, s)| v * s)
            .sum::<f64>();
    }
    Ok((scale, secs))
}

/// The calendar month (1-12) of every time step of variable `var` (its first dimension's
/// coordinate variable and that variable's `units`).
///
/// # Errors
/// A message if the coordinate variable, its units or its values are missing or unusable.
pub fn months(file: &NcFile, var: &str) -> Result<Vec<u32>, String> {
    let v = file
        .variable(var)
        .ok_or_else(|| format!("no variable {var:?}"))?;
    let dim = &file.dimensions()[*v.dims.first().ok_or("a scalar variable has no time axis")?];
    let time = file.variable(&dim.name).ok_or_else(|| {
        format!(
            "the time dimension {:?} has no coordinate variable, so calendar months are unknown",
            dim.name
        )
    })?;
    let units = time
        .attr("units")
        .and_then(|a| a.as_text())
        .ok_or_else(|| format!("the time coordinate {:?} has no `units`", dim.name))?;
    let (scale, epoch) = parse_time_units(units)?;
    let values = file.read_f64(&time.name).map_err(|e| e.to_string())?;
    values
        .iter()
        .map(|&t| {
            if !t.is_finite() {
                return Err(format!("a time value of {:?} is missing", dim.name));
            }
            let days = ((epoch + t * scale) / 86_400.0).floor() as i64;
            Ok(civil_from_days(days).1)
        })
        .collect()
}

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
    let mut x = match &d.v {
        Some(v) => {
            let v = read(v)?;
            ndarray::Zip::from(&u)
                .and(&v)
                .map_collect(|&a, &b| Complex64::new(a, b))
        }
        None => u.mapv(|a| Complex64::new(a, 0.0)),
    };
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
    fn civil_dates_round_trip() {
        assert_eq!(days_from_civil(1970, 1, 1), 0);
        assert_eq!(days_from_civil(2000, 3, 1), 11_017);
        for z in [-800_000i64, -1, 0, 59, 60, 10_000, 18_000, 2_000_000] {
            let (y, m, d) = civil_from_days(z);
            assert_eq!(days_from_civil(y, m, d), z);
        }
        assert_eq!(civil_from_days(days_from_civil(2024, 2, 29)), (2024, 2, 29));
    }

    #[test]
    fn cf_time_units() {
        let (s, e) = parse_time_units("hour since 1980-01-14 14:00:00").unwrap();
        assert_eq!(s, 3600.0);
        assert_eq!(
            e,
            days_from_civil(1980, 1, 14) as f64 * 86_400.0 + 14.0 * 3600.0
        );
        assert_eq!(
            parse_time_units("days since 1900-01-01").unwrap().0,
            86_400.0
        );
        assert!(parse_time_units("fortnights since 1900-01-01").is_err());
        assert!(parse_time_units("days after 1900-01-01").is_err());
    }

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
