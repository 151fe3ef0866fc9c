//! The values `isar-clutter slurm` hands to `sbatch`, checked when the command line is read so
//! that a mistyped `--time` or `--mem` is refused at once (exit 2, nothing written), not by
//! `sbatch` after the scripts were written: [`time`] and [`mem`] accept exactly the forms of
//! sbatch's manual page.

/// Checks a time limit in one of sbatch's forms: `minutes`, `minutes:seconds`,
/// `hours:minutes:seconds`, `days-hours`, `days-hours:minutes`, `days-hours:minutes:seconds`,
/// or `UNLIMITED` / `INFINITE`.
///
/// # Errors
/// Naming the text and the accepted forms.
pub fn time(text: &str) -> Result<String, String> {
    let refuse = || {
        format!(
            "{text:?} is not a Slurm time limit: minutes, minutes:seconds, hours:minutes:seconds, \
             days-hours, days-hours:minutes or days-hours:minutes:seconds (e.g. 90, 2:00:00, 1-12)"
        )
    };
    let t = text.trim();
    if matches!(t.to_ascii_uppercase().as_str(), "UNLIMITED" | "INFINITE") {
        return Ok(t.to_string());
    }
    let number = |s: &str| !s.is_empty() && s.len() <= 9 && s.bytes().all(|b| b.is_ascii_digit());
    let (days, clock) = match t.split_once('-') {
        Some((d, rest)) => (Some(d), rest),
        None => (None, t),
    };
    let parts: Vec<&str> = clock.split(':').collect();
    let fits = days.is_none_or(number)
        && parts.iter().all(|p| number(p))
        && (1..=3).contains(&parts.len());
    if !fits || t.parse::<u64>().is_ok_and(|m| m == 0) {
        return Err(refuse());
    }
    Ok(t.to_string())
}

/// Checks a memory size as sbatch's `--mem` takes it: a whole number with an optional unit
/// `K`, `M` (the default), `G` or `T` (`8G`, `500M`, `16000`).
///
/// # Errors
/// Naming the text and the accepted form.
pub fn mem(text: &str) -> Result<String, String> {
    let t = text.trim();
    let digits = t.trim_end_matches(['K', 'M', 'G', 'T', 'k', 'm', 'g', 't']);
    let unit = t.len() - digits.len();
    let ok = unit <= 1
        && !digits.is_empty()
        && digits.len() <= 12
        && digits.bytes().all(|b| b.is_ascii_digit());
    if !ok || digits.parse::<u64>().is_ok_and(|v| v == 0) {
        return Err(format!(
            "{text:?} is not a Slurm memory size: a whole number of megabytes, or with a unit \
             K, M, G or T (e.g. 8G, 500M)"
        ));
    }
    Ok(t.to_string())
}

#[cfg(test)]
mod tests {
    #[test]
    fn time_limits_in_sbatch_forms_pass_and_others_are_refused() {
        for good in [
            "90",
            "30:00",
            "2:00:00",
            "1-12",
            "1-12:30",
            "2-00:00:00",
            "UNLIMITED",
        ] {
            assert_eq!(super::time(good).as_deref(), Ok(good), "{good}");
        }
        for bad in [
            "soon",
            "",
            "0",
            "1:2:3:4",
            "1-",
            "-5",
            "2h",
            "1-2:3:4:5",
            "1.5",
            "::",
        ] {
            let e = super::time(bad).expect_err(bad);
            assert!(e.contains("is not a Slurm time limit"), "{e}");
        }
    }

    #[test]
    fn memory_sizes_in_sbatch_form_pass_and_others_are_refused() {
        for good in ["8G", "500M", "16000", "1T", "64k"] {
            assert_eq!(super::mem(good).as_deref(), Ok(good), "{good}");
        }
        for bad in ["lots", "", "0", "8GB", "1.5G", "G", "-1G", "8 G"] {
            let e = super::mem(bad).expect_err(bad);
            assert!(e.contains("is not a Slurm memory size"), "{e}");
        }
    }
}
