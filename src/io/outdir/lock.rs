//! The lock of an output folder: who holds it ([`Holder`]: pid, host, boot id and process
//! start time, so that a dead holder, or a reused pid, is recognised), taking it, and taking
//! over a dead holder's.

use super::STATE;
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::fs::{self, OpenOptions};
use std::path::Path;

/// Who holds (or held) an output folder: enough to tell a live holder from a dead one.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Holder {
    /// Process id.
    pub pid: u32,
    /// Host name.
    pub host: String,
    /// The kernel's boot id (`/proc/sys/kernel/random/boot_id`): a pid of another boot is dead.
    pub boot_id: String,
    /// Start time of the process in clock ticks after boot (`/proc/<pid>/stat` field 22): a
    /// reused pid has another.
    pub process_start: u64,
    /// Wall-clock start of the claim, seconds since the Unix epoch.
    pub started_unix_s: u64,
    /// What is writing: `run`, `report`.
    pub command: String,
}

impl Holder {
    /// This process, now.
    pub fn me(command: &str) -> Holder {
        let pid = std::process::id();
        Holder {
            pid,
            host: hostname(),
            boot_id: boot_id(),
            process_start: process_start(pid).unwrap_or(0),
            started_unix_s: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_secs())
                .unwrap_or(0),
            command: command.into(),
        }
    }

    /// Whether the holder is certainly dead: same host, and another boot, or no process with
    /// its pid, or one that started at another time, or a zombie (killed, not yet reaped by
    /// its parent: it writes nothing more). `false` for another host, and without `/proc`
    /// (unknowable).
    pub fn is_dead(&self) -> bool {
        if self.host != hostname() {
            return false;
        }
        if !self.boot_id.is_empty() && self.boot_id != boot_id() {
            return true;
        }
        is_gone(self.pid)
            || process_start(self.pid)
                .is_some_and(|start| self.process_start != 0 && start != self.process_start)
    }

    /// `run (pid 12, host h, started 2026-11-23 23:51:20 UTC)`.
    pub fn describe(&self) -> String {
        format!(
            "{} (pid {}, host {}, started {})",
            self.command,
            self.pid,
            self.host,
            utc(self.started_unix_s)
        )
    }
}

/// Takes the lock of `root` for `me`, taking over a dead holder's.
pub(super) fn take_lock(
    root: &Path,
    name: &str,
    me: &Holder,
    notes: &mut Vec<String>,
) -> Result<()> {
    let path = root.join(STATE).join(name);
    for _ in 0..3 {
        match OpenOptions::new().write(true).create_new(true).open(&path) {
            Ok(mut f) => {
                // Not synced: a lock outlives its holder only while the holder lives, and after
                // a crash a lock that is missing, empty or half written is taken over (below).
                serde_json::to_writer_pretty(&mut f, me)?;
                return Ok(());
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                let holder: Option<Holder> = fs::read_to_string(&path)
                    .ok()
                    .and_then(|t| serde_json::from_str(&t).ok());
                match holder {
                    Some(h) if !h.is_dead() => bail!(
                        "{} is locked by a {} that is still writing into it{}: wait for it to \
                         finish, or use another --out; if it is certainly gone, remove {}",
                        root.display(),
                        h.describe(),
                        if h.host != me.host {
                            " (on another host: its liveness cannot be checked from here)"
                        } else {
                            ""
                        },
                        path.display()
                    ),
                    Some(h) => notes.push(format!(
                        "took over the stale lock of a {} that is gone",
                        h.describe()
                    )),
                    None => notes.push(format!(
                        "took over an unreadable lock {} (a writer killed while taking it)",
                        path.display()
                    )),
                }
                fs::remove_file(&path)
                    .with_context(|| format!("cannot remove stale lock {}", path.display()))?;
            }
            Err(e) => {
                return Err(e).with_context(|| format!("cannot create lock {}", path.display()))
            }
        }
    }
    bail!("cannot take the lock {} (contended)", path.display())
}

pub(super) fn hostname() -> String {
    fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|s| s.trim().to_string())
        .or_else(|_| std::env::var("HOSTNAME"))
        .unwrap_or_default()
}

fn boot_id() -> String {
    fs::read_to_string("/proc/sys/kernel/random/boot_id")
        .map(|s| s.trim().to_string())
        .unwrap_or_default()
}

/// Start time of process `pid` in clock ticks after boot; `None` if there is no such process
/// (or no `/proc`).
fn process_start(pid: u32) -> Option<u64> {
    process_stat(pid).map(|(_, start)| start)
}

/// Whether no live process of this machine has `pid`: none has it, or a zombie (killed, not
/// yet reaped) does. `false` where there is no `/proc` to tell (not Linux).
pub(super) fn is_gone(pid: u32) -> bool {
    fs::metadata("/proc/self/stat").is_ok()
        && process_stat(pid).is_none_or(|(state, _)| matches!(state, 'Z' | 'X'))
}

/// State (`R`, `S`, `Z` for a zombie...) and start time in clock ticks after boot of process
/// `pid`, from `/proc/<pid>/stat`; `None` if there is no such process (or no `/proc`).
pub(super) fn process_stat(pid: u32) -> Option<(char, u64)> {
    let stat = fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // Fields after the command name (which may hold spaces) start at field 3 (the state);
    // field 22 (the start time) is index 19 of them.
    let mut rest = stat[stat.rfind(')')? + 1..].split_whitespace();
    let state = rest.next()?.chars().next()?;
    Some((state, rest.nth(18)?.parse().ok()?))
}

/// `2026-11-23 23:51:20 UTC` from seconds since the epoch.
pub(super) fn utc(s: u64) -> String {
    let (days, rem) = (s / 86_400, s % 86_400);
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02}:{:02} UTC",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// The live holders of the other locks of `root` (`lock`, `lock.shard-<i>`) than `mine`, by
/// lock name; dead holders' locks are removed (said in `notes`).
///
/// # Errors
/// If the state folder cannot be read or a dead lock removed.
pub(super) fn other_locks(
    root: &Path,
    mine: &str,
    notes: &mut Vec<String>,
) -> Result<Vec<(String, Holder)>> {
    let state = root.join(STATE);
    let mut live = vec![];
    for e in fs::read_dir(&state)
        .with_context(|| format!("cannot read {}", state.display()))?
        .flatten()
    {
        let name = e.file_name().to_string_lossy().into_owned();
        if name == mine || !(name == "lock" || name.starts_with("lock.shard-")) {
            continue;
        }
        let holder: Option<Holder> = fs::read_to_string(e.path())
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok());
        match holder {
            Some(h) if !h.is_dead() => live.push((name, h)),
            Some(h) => {
                notes.push(format!(
                    "removed the stale {name} of a {} that is gone",
                    h.describe()
                ));
                let _ = fs::remove_file(e.path());
            }
            None => {} // being written by its taker this instant, or unreadable: left alone
        }
    }
    Ok(live)
}
