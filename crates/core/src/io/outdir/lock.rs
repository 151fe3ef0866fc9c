//! The locks of the tool's outputs (an output folder, a `generate` or `fit` output): taken
//! atomically with an open-file-description lock (`fcntl(F_OFD_SETLK)`) on a lock file, so that of two writers started at the same
//! instant exactly one holds it and the kernel releases it when its holder dies; the file
//! records who holds it ([`Holder`]: pid, host, boot id and process start time), for the
//! refusal's message and for telling a finished writer from a dead one elsewhere.

use crate::io::journal::STATE;
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::fs::{self, File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::os::fd::AsRawFd;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Who holds (or held) an output folder, as its lock file records it for a refusal's message
/// and a take-over's note (whether a holder is alive is the lock's to say, not the record's).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Holder {
    /// Process id.
    pub pid: u32,
    /// Host name.
    pub host: String,
    /// The kernel's boot id (`/proc/sys/kernel/random/boot_id`).
    pub boot_id: String,
    /// Start time of the process in clock ticks after boot (`/proc/<pid>/stat` field 22), which
    /// tells the holder from a later process with the same pid.
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

/// A lock this process holds: its lock file, open and locked for writing with an
/// open-file-description lock (`fcntl(F_OFD_SETLK)`, Linux 3.15+). The kernel releases it when
/// the file is closed, so when its holder ends, however it ends: a lock held is a writer alive
/// (on a network file system, a client alive, through the file system's lock manager). The
/// file's content, the [`Holder`], only says who. Dropping it removes the file while still
/// holding the lock, then closes it.
#[derive(Debug)]
pub struct HeldLock {
    /// Closed when dropped, after the unlink (the lock goes with it).
    _file: File,
    path: PathBuf,
    /// Folders made to hold the lock file, deepest first: removed when dropped if nothing else
    /// was put in them (a refused `generate` leaves no empty folder behind).
    made: Vec<PathBuf>,
}

impl Drop for HeldLock {
    fn drop(&mut self) {
        // Unlinked while held: a taker that opened this file meanwhile finds it replaced or
        // gone once it gets the lock (the inode check of `take_lock`) and tries again.
        let _ = fs::remove_file(&self.path);
        for folder in &self.made {
            if fs::remove_dir(folder).is_err() {
                break; // not empty: the writer's output is in it
            }
        }
    }
}

/// Opens the state file `path` (`what`: `lock`, `journal`) with `options`, never through a
/// symbolic link (`O_NOFOLLOW`): a link planted in its place is refused, naming it, and its
/// target is left untouched.
///
/// # Errors
/// When `path` is a symbolic link, or cannot be opened.
pub fn open_no_follow(options: &mut OpenOptions, path: &Path, what: &str) -> Result<File> {
    use std::os::unix::fs::OpenOptionsExt;
    match options.custom_flags(libc::O_NOFOLLOW).open(path) {
        Err(e) if e.raw_os_error() == Some(libc::ELOOP) => bail!(
            "the {what} file {} is a symbolic link: the tool never writes its state through \
             one (remove the link; nothing was changed)",
            path.display()
        ),
        r => r.with_context(|| format!("cannot create the {what} file {}", path.display())),
    }
}

/// Takes the lock at `path` for `me`, atomically: of two takers at the same instant exactly
/// one gets it, and the other is refused at once, naming the holder. The lock file of a holder
/// that died (killed: the kernel released its lock, the file stayed) is taken over and said in
/// `notes`. `what` names the locked thing in the refusal (`/data/out`, `samples.npy`).
///
/// # Errors
/// When the lock is held by a live writer (the message names it), or the lock file cannot be
/// created or locked (a file system without locks).
pub fn take_lock(
    path: &Path,
    what: &str,
    me: &Holder,
    notes: &mut Vec<String>,
) -> Result<HeldLock> {
    loop {
        let mut file = open_no_follow(
            OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false),
            path,
            "lock",
        )?;
        match ofd_lock(&file, libc::F_OFD_SETLK) {
            Ok(true) => {}
            Ok(false) => bail!(
                "{what} is locked by {} that is still writing into it: wait for it to finish, \
                 or choose another --out (nothing was changed)",
                describe_holder(&read_holder(path)),
            ),
            Err(e) => {
                return Err(e).with_context(|| {
                    format!(
                        "cannot lock {}: the file system refuses fcntl locks, which the tool \
                         needs to keep two writers apart",
                        path.display()
                    )
                })
            }
        }
        // The holder before us may have removed the file between our open and our lock: then
        // the lock we hold is on a file nobody else will open. Try again on the path's file.
        if !same_inode(&file, path) {
            continue;
        }
        let mut text = String::new();
        let _ = file.read_to_string(&mut text);
        if !text.trim().is_empty() {
            notes.push(match serde_json::from_str::<Holder>(&text) {
                Ok(h) => format!("took over the lock of a {} that is gone", h.describe()),
                Err(_) => format!(
                    "took over the lock {} of a writer that is gone",
                    path.display()
                ),
            });
        }
        let record = serde_json::to_vec_pretty(me)?;
        file.set_len(0)
            .and_then(|()| file.seek(SeekFrom::Start(0)))
            .and_then(|_| file.write_all(&record))
            .with_context(|| format!("cannot write the lock {}", path.display()))?;
        return Ok(HeldLock {
            _file: file,
            path: path.to_path_buf(),
            made: Vec::new(),
        });
    }
}

/// An open-file-description write lock over the whole file: `F_OFD_SETLK` takes it
/// (`Ok(true)`, or `Ok(false)` when another open file holds one), `F_OFD_GETLK` only tells
/// whether it could be taken, without taking it (so a probe never stands in a taker's way).
fn ofd_lock(file: &File, cmd: libc::c_int) -> std::io::Result<bool> {
    loop {
        // SAFETY: an all-zero `flock` is a valid value of the plain C struct.
        let mut fl: libc::flock = unsafe { std::mem::zeroed() };
        fl.l_type = libc::F_WRLCK as libc::c_short;
        fl.l_whence = libc::SEEK_SET as libc::c_short;
        // l_start = l_len = 0: the whole file; l_pid = 0, as OFD locks require.
        // SAFETY: fcntl on a descriptor this `File` owns and keeps open for the call, with a
        // pointer to a live `flock`.
        if unsafe { libc::fcntl(file.as_raw_fd(), cmd, &mut fl) } == 0 {
            return Ok(cmd != libc::F_OFD_GETLK || fl.l_type == libc::F_UNLCK as libc::c_short);
        }
        let e = std::io::Error::last_os_error();
        match e.raw_os_error() {
            Some(libc::EAGAIN | libc::EACCES) => return Ok(false),
            Some(libc::EINTR) => continue,
            _ => return Err(e),
        }
    }
}

impl HeldLock {
    /// Records that the folders `made` (deepest first) were created for this lock, so that
    /// dropping it removes those it leaves empty.
    pub(super) fn made_folders(mut self, made: Vec<PathBuf>) -> HeldLock {
        self.made = made;
        self
    }
}

/// Whether `path` still names the file `file` has open.
fn same_inode(file: &File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (file.metadata(), fs::metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

/// Whether the lock at `path` is held now, by a writer alive (see [`HeldLock`]); asked with
/// `F_OFD_GETLK`, which takes nothing. A missing file is not held.
pub fn is_held(path: &Path) -> bool {
    let Ok(file) = File::open(path) else {
        return false;
    };
    !matches!(ofd_lock(&file, libc::F_OFD_GETLK), Ok(true))
}

/// How long a refused taker reads a held lock's record that is still empty: its taker writes
/// it right after taking the lock.
const RECORD_WAIT: Duration = Duration::from_millis(300);

/// The holder recorded in a held lock; an empty record is read again for a moment.
pub(super) fn read_holder(path: &Path) -> Option<Holder> {
    let t = Instant::now();
    loop {
        if let Some(h) = fs::read_to_string(path)
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok())
        {
            return Some(h);
        }
        if t.elapsed() > RECORD_WAIT {
            return None;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// `a run (pid 12, host h, started ...)`, or what is known of a holder whose record cannot
/// be read.
pub(super) fn describe_holder(h: &Option<Holder>) -> String {
    match h {
        Some(h) => format!("a {}", h.describe()),
        None => "another process (its record could not be read)".into(),
    }
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
/// lock name, described (`a shard (pid ..., host ..., started ...)`). A lock is live while its
/// file is locked ([`is_held`]); a dead writer's lock file is left for its next taker.
///
/// # Errors
/// If the state folder cannot be read.
pub(super) fn other_locks(root: &Path, mine: &str) -> Result<Vec<(String, String)>> {
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
        if is_held(&e.path()) {
            live.push((name, describe_holder(&read_holder(&e.path()))));
        }
    }
    live.sort();
    Ok(live)
}
