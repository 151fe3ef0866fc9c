//! Tests of output folder ownership: claims, locks, journal-based cleaning, completeness.

use super::lock::utc;
use super::*;

#[test]
fn temporary_names_of_both_writers_are_recognised() {
    assert_eq!(temporary_of(".a.npy.tmp-12"), Some(("a.npy", 12)));
    assert_eq!(temporary_of(".fig.png.34-7.tmp"), Some(("fig.png", 34)));
    assert_eq!(temporary_of("a.npy"), None);
    assert_eq!(temporary_of(".a.tmp-x"), None);
    assert_eq!(temporary_of(".notes.tmp"), None);
}

#[test]
fn utc_formats_known_instants() {
    assert_eq!(utc(0), "1970-01-01 00:00:00 UTC");
    assert_eq!(utc(1_795_477_880), "2026-11-23 23:51:20 UTC");
    assert_eq!(utc(951_782_400), "2000-02-29 00:00:00 UTC");
}

#[test]
fn this_process_is_alive_and_a_dead_pid_is_not() {
    // What decides whether a temporary file's writer is gone (`remove_dead_temporaries_of`);
    // a lock's holder is alive while its lock is held (`is_held`).
    assert!(!super::lock::is_gone(std::process::id()));
    assert!(super::lock::is_gone(999_999_999));
}

#[test]
fn a_killed_writer_not_yet_reaped_is_gone() {
    // A writer killed a moment ago whose parent has not reaped it yet is a zombie: it still
    // answers `kill(pid, 0)` and keeps its /proc entry, but it writes nothing more.
    let mut child = std::process::Command::new("sleep")
        .arg("30")
        .spawn()
        .unwrap();
    let pid = child.id();
    assert!(!super::lock::is_gone(pid), "a running writer");
    // SAFETY: `kill` on our own child's pid; the child is not reaped before the check below.
    assert_eq!(unsafe { libc::kill(pid as i32, libc::SIGKILL) }, 0);
    let t = std::time::Instant::now();
    while super::lock::process_stat(pid).unwrap().0 != 'Z' {
        assert!(
            t.elapsed().as_secs() < 10,
            "the child never became a zombie"
        );
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    assert!(super::lock::is_gone(pid), "an unreaped, killed writer");
    child.wait().unwrap();
    assert!(super::lock::is_gone(pid), "a reaped writer");
}

#[test]
fn a_claim_cleans_only_its_own_records() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("out");
    {
        let d = OutDir::claim(&root, Some("e"), Purpose::Run).unwrap();
        crate::io::atomic::atomic_write(&root.join("maps/a/x.npy"), |w| Ok(w.write_all(b"1")?))
            .unwrap();
        crate::io::atomic::atomic_write(&root.join("maps/b/x.npy"), |w| Ok(w.write_all(b"2")?))
            .unwrap();
        assert_eq!(d.remove_stale(|_| true).unwrap(), 0);
        d.complete().unwrap();
    }
    // A user's file beside the tool's, and a temporary file of a dead writer.
    fs::write(root.join("maps/b/notes.txt"), b"mine").unwrap();
    fs::write(root.join("maps/b/.x.npy.tmp-999999999"), b"half").unwrap();
    let d = OutDir::claim(&root, Some("e"), Purpose::Run).unwrap();
    assert!(!root.join("maps/b/.x.npy.tmp-999999999").exists());
    assert!(
        d.notes.iter().any(|n| n.contains("1 temporary")),
        "{:?}",
        d.notes
    );
    // A second claim while the first holds the lock is refused.
    let err = OutDir::claim(&root, Some("e"), Purpose::Run).unwrap_err();
    assert!(format!("{err:#}").contains("locked by a run"), "{err:#}");
    crate::io::atomic::atomic_write(&root.join("maps/a/x.npy"), |w| Ok(w.write_all(b"3")?))
        .unwrap();
    assert_eq!(d.remove_stale(|_| true).unwrap(), 1);
    assert!(!root.join("maps/b/x.npy").exists());
    assert_eq!(fs::read(root.join("maps/b/notes.txt")).unwrap(), b"mine");
    assert_eq!(fs::read(root.join("maps/a/x.npy")).unwrap(), b"3");
    let owned = d.owned().unwrap();
    assert_eq!(
        owned.into_iter().collect::<Vec<_>>(),
        [PathBuf::from("maps/a/x.npy")]
    );
    // Another experiment's name is refused, and so is a foreign folder.
    drop(d);
    let err = OutDir::claim(&root, Some("other"), Purpose::Run).unwrap_err();
    assert!(format!("{err:#}").contains("experiment \"e\""), "{err:#}");
    let foreign = dir.path().join("thesis");
    fs::create_dir_all(&foreign).unwrap();
    fs::write(foreign.join("overview.png"), b"x").unwrap();
    let err = OutDir::claim(&foreign, Some("e"), Purpose::Run).unwrap_err();
    assert!(format!("{err:#}").contains("overview.png"), "{err:#}");
    assert_eq!(fs::read_dir(&foreign).unwrap().count(), 1);
}

#[test]
fn an_interrupted_run_is_refused_by_readers() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("out");
    let d = OutDir::claim(&root, Some("e"), Purpose::Run).unwrap();
    drop(d); // no complete(): the manifest was never written
    let err = check_complete(&root).unwrap_err();
    assert!(format!("{err:#}").contains("incomplete"), "{err:#}");
    assert!(OutDir::claim(
        &root,
        Some("e"),
        Purpose::Report {
            allow_incomplete: false
        }
    )
    .is_err());
    assert!(OutDir::claim(
        &root,
        Some("e"),
        Purpose::Report {
            allow_incomplete: true
        }
    )
    .is_ok());
}

#[test]
fn claims_started_together_give_the_folder_to_exactly_one() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("out");
    for round in 0..5 {
        let barrier = std::sync::Barrier::new(8);
        let results: Vec<Result<OutDir>> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..8)
                .map(|_| {
                    s.spawn(|| {
                        barrier.wait();
                        OutDir::claim(&root, Some("e"), Purpose::Run)
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        let won = results.iter().filter(|r| r.is_ok()).count();
        assert_eq!(won, 1, "round {round}: {won} claims hold the folder");
        let me = format!("locked by a run (pid {},", std::process::id());
        for r in &results {
            if let Err(e) = r {
                assert!(format!("{e:#}").contains(&me), "round {round}: {e:#}");
            }
        }
    }
}

#[test]
fn a_dead_holders_lock_is_taken_over_and_said_and_a_released_one_is_gone() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("out");
    fs::create_dir_all(root.join(STATE)).unwrap();
    // What a writer killed after taking the lock leaves: its record, no lock.
    let mut dead = Holder::me("run");
    dead.pid = 999_999_999;
    fs::write(
        root.join(STATE).join("lock"),
        serde_json::to_vec(&dead).unwrap(),
    )
    .unwrap();
    let d = OutDir::claim(&root, Some("e"), Purpose::Run).unwrap();
    assert!(
        d.notes
            .iter()
            .any(|n| n.contains("took over the lock of a run (pid 999999999,")),
        "{:?}",
        d.notes
    );
    assert!(is_held(&root.join(STATE).join("lock")));
    drop(d);
    assert!(!root.join(STATE).join("lock").exists(), "released: removed");
    // An empty lock file (a writer killed before writing its record) is taken silently.
    fs::write(root.join(STATE).join("lock"), b"").unwrap();
    let d = OutDir::claim(&root, Some("e"), Purpose::Run).unwrap();
    assert!(d.notes.iter().all(|n| !n.contains("lock")), "{:?}", d.notes);
}

#[test]
fn a_probe_never_stands_in_a_takers_way() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.lock");
    let stop = std::sync::atomic::AtomicBool::new(false);
    std::thread::scope(|s| {
        // Another reader asking, as fast as it can, whether the lock is held.
        s.spawn(|| {
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                is_held(&path);
            }
        });
        for i in 0..200 {
            let mut notes = vec![];
            let held = take_lock(&path, "x", &Holder::me("run"), &mut notes)
                .unwrap_or_else(|e| panic!("take {i}: {e:#}"));
            assert!(is_held(&path));
            drop(held);
        }
        stop.store(true, std::sync::atomic::Ordering::Relaxed);
    });
    assert!(!is_held(&path) && !path.exists());
}

#[test]
fn a_second_writer_of_one_output_is_refused_naming_the_first() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("new/samples.npy");
    let held = lock_output(&out, "generate").unwrap();
    let err = lock_output(&out, "generate").unwrap_err();
    let want = format!("locked by a generate (pid {},", std::process::id());
    assert!(format!("{err:#}").contains(&want), "{err:#}");
    drop(held);
    assert!(
        !dir.path().join("new").exists(),
        "the lock file goes with the lock, and the folder made for it while it is empty"
    );
    // A folder the writer put its output in stays, without the lock file.
    let held = lock_output(&out, "generate").unwrap();
    fs::write(&out, b"samples").unwrap();
    drop(held);
    let left: Vec<_> = fs::read_dir(dir.path().join("new"))
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left, ["samples.npy"], "the lock file goes with the lock");
}

#[test]
fn readers_tell_a_live_writer_an_unmerged_sharded_run_and_an_interrupted_run_apart() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("out");
    let d = OutDir::claim(&root, Some("e"), Purpose::Shard { index: 1 }).unwrap();
    let err = format!("{:#}", check_complete(&root).unwrap_err());
    assert!(
        err.contains("a shard (pid") && err.contains("still writing"),
        "{err}"
    );
    drop(d);
    let err = format!("{:#}", check_complete(&root).unwrap_err());
    assert!(
        err.contains("sharded run") && err.contains("merge") && !err.contains("interrupted"),
        "{err}"
    );
    drop(OutDir::claim(&root, Some("e"), Purpose::Run).unwrap());
    let err = format!("{:#}", check_complete(&root).unwrap_err());
    assert!(err.contains("was interrupted"), "{err}");
}
