//! What the machine can give a command, read before anything is allocated or written: its
//! memory ([`machine_memory`], lowered to a cgroup's limit), the free space of the file system
//! an output goes to ([`free_disk`]) and the threads a command may start ([`cap_threads`]).
//! The runner's job estimates, `fit`, `generate` and the Python bindings compare their own
//! estimates with these (docs/spec.md, "Resources of a whole command").

use std::path::Path;

/// Threads a command may start per core: more only adds memory for CPU-bound work (every job
/// in flight holds its arrays), and tens of thousands cannot be started at all.
pub const THREADS_PER_CORE: usize = 4;

/// The cores this process may run on (its affinity and cgroup quota; 1 when unknown).
pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// The most threads a command starts: [`THREADS_PER_CORE`] per core.
pub fn max_threads() -> usize {
    cores().saturating_mul(THREADS_PER_CORE)
}

/// `requested` threads capped at [`max_threads`], with a note naming `what` (`--jobs`,
/// `threads`) when it was lowered.
pub fn cap_threads(requested: usize, what: &str) -> (usize, Option<String>) {
    let most = max_threads();
    if requested <= most {
        return (requested, None);
    }
    let note = format!(
        "{what} {requested} is more than this machine can use ({} cores, at most {THREADS_PER_CORE} \
         threads a core): running {most} threads",
        cores()
    );
    (most, Some(note))
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
pub fn meminfo_total(text: &str) -> Option<u64> {
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

/// Bytes an unprivileged writer may still put on the file system that holds `path` (or, when
/// `path` does not exist yet, its nearest existing ancestor); `None` where it cannot be asked.
pub fn free_disk(path: &Path) -> Option<u64> {
    let abs = std::path::absolute(path).ok()?;
    let existing = abs.ancestors().find(|p| p.exists())?;
    let c = std::ffi::CString::new(existing.as_os_str().as_encoded_bytes()).ok()?;
    let mut s = std::mem::MaybeUninit::<libc::statvfs>::uninit();
    // SAFETY: `c` is a NUL-terminated path and `s` is written by statvfs before it is read.
    if unsafe { libc::statvfs(c.as_ptr(), s.as_mut_ptr()) } != 0 {
        return None;
    }
    // SAFETY: statvfs returned 0, so it filled `s`.
    let s = unsafe { s.assume_init() };
    // The fields' widths differ between platforms (u64 on 64-bit Linux).
    #[allow(clippy::useless_conversion)]
    let (avail, frsize) = (u64::from(s.f_bavail), u64::from(s.f_frsize));
    Some(avail.saturating_mul(frsize))
}

/// The refusal of an output of about `needed` bytes at `path` when the file system holds less
/// free space (`what`: the output, `the 20000 samples`); `None` when it fits or the free space
/// is unknown.
pub fn disk_shortfall(path: &Path, needed: u64, what: &str) -> Option<String> {
    let free = free_disk(path)?;
    (needed > free).then(|| {
        format!(
            "{what} need about {} on disk, more than the {} free on the file system of {} \
             (nothing was written)",
            human_bytes(needed),
            human_bytes(free),
            path.display()
        )
    })
}

/// The product of `factors` (a count of values and their size in bytes), saturating at
/// `u64::MAX`: the size of an output however absurd its arguments.
pub fn saturating_bytes(factors: &[usize]) -> u64 {
    let product = factors
        .iter()
        .fold(1u128, |p, &f| p.saturating_mul(f as u128));
    product.min(u64::MAX as u128) as u64
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

#[cfg(test)]
mod tests {
    use super::*;

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
    fn byte_counts_saturate() {
        assert_eq!(saturating_bytes(&[20000, 8, 8, 8]), 10_240_000);
        assert_eq!(saturating_bytes(&[usize::MAX, 64, 8]), u64::MAX);
    }

    #[test]
    fn threads_are_capped_with_a_note() {
        let most = max_threads();
        assert_eq!(cap_threads(1, "--jobs"), (1, None));
        assert_eq!(cap_threads(most, "--jobs"), (most, None));
        let (n, note) = cap_threads(100_000, "--jobs");
        assert_eq!(n, most);
        assert!(note.unwrap().starts_with("--jobs 100000 is more than"));
    }

    #[test]
    fn free_disk_reads_the_nearest_existing_folder() {
        let dir = tempfile::tempdir().unwrap();
        let free = free_disk(dir.path()).expect("a temporary folder's file system");
        assert!(free > 0);
        let below = free_disk(&dir.path().join("not/yet/made")).unwrap();
        // The same file system, read twice: within what other writers changed meanwhile.
        assert!(below.abs_diff(free) < 1 << 30, "{below} vs {free}");
        assert!(disk_shortfall(dir.path(), u64::MAX, "the samples")
            .unwrap()
            .contains("the samples need about 16.0 EiB on disk"));
        assert_eq!(disk_shortfall(dir.path(), 1, "x"), None);
    }
}
