//! Time coordinates of NetCDF files: the calendar month of every time step, from the time
//! coordinate's CF-style `units` (`<unit> since <date>[ <time>]`, proleptic Gregorian).

use super::NcFile;

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
}
