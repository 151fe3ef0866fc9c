//! `outputs: {zarr_maps: true}`: a sweep's maps packed into one Zarr v3 store, opened by
//! xarray and zarr-python (`tests/zarr/check_store.py`, in the project's virtualenv `.venv`)
//! and equal, value for value, to the `.npy` maps of the same run; datasets of two sizes make
//! two arrays of a map name; a resumed run packs the same store from the staged chunks; with
//! `npy_maps: false` the maps are the store's few files.

mod common;

use std::path::Path;

/// A sweep over two datasets of two sizes, analysed and synthesised.
fn spec(dir: &Path, npy_maps: bool) -> std::path::PathBuf {
    let path = dir.join(format!("zarr_{npy_maps}.yaml"));
    std::fs::write(
        &path,
        format!(
            "name: zarr_maps\nseed: 5\ndatasets:\n  - {{id: wide, kind: filtered_noise, family: exponential, alpha_h: 1.0, alpha_v: 1.0, size: [16, 24], samples: 40, half_width: 3}}\n  - {{id: small, kind: filtered_noise, family: exponential, alpha_h: 1.0, alpha_v: 2.0, size: [8, 8], samples: 40, half_width: 2}}\nanalysis:\n  levels: 2\nsynthesis:\n  methods: [method2]\n  samples: 40\noutputs:\n  npy_maps: {npy_maps}\n  zarr_maps: true\nsweep:\n  grid:\n    datasets.wide.alpha_h: [0.5, 2.0]\n"
        ),
    )
    .unwrap();
    path
}

/// What `check_store.py` says of `run` (with the `.npy` maps of `npy_run`).
fn check(python: &Path, run: &Path, npy_run: &Path) -> String {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/zarr/check_store.py");
    let o = std::process::Command::new(python)
        .args([script.as_path(), run, npy_run])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Every file under `dir`, relative, sorted.
fn files(dir: &Path) -> Vec<String> {
    let mut out = vec![];
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            if e.path().is_dir() {
                todo.push(e.path());
            } else {
                out.push(e.path().strip_prefix(dir).unwrap().display().to_string());
            }
        }
    }
    out.sort();
    out
}

#[test]
fn a_sweeps_maps_in_one_zarr_store_equal_its_npy_maps() {
    let Some(python) = common::venv_python(&["zarr", "xarray"]) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let both = dir.path().join("both");
    common::run_spec(&spec(dir.path(), true), &both, &["--no-report"]);
    let said = check(&python, &both, &both);
    // 3 datasets (the sweep's 2 and `small`), an analysis and a method2 job each.
    assert!(
        said.contains(" jobs, ") && said.contains("6 jobs"),
        "{said}"
    );
    let arrays: usize = said.split(' ').next().unwrap().parse().unwrap();
    assert!(arrays > 30, "{said}");
    // Two sizes: `variance` (16 x 24, the first job's) and `variance@8x8`.
    let store = files(&both.join("maps.zarr"));
    assert!(store.contains(&"variance/c/0/0/0".to_string()), "{store:?}");
    assert!(
        store.contains(&"variance@8x8/c/0/0/0".to_string()),
        "{store:?}"
    );
    // Resumed: the jobs are skipped and the store is packed again, byte for byte.
    let before: Vec<Vec<u8>> = store
        .iter()
        .map(|f| std::fs::read(both.join("maps.zarr").join(f)).unwrap())
        .collect();
    common::run_spec(&spec(dir.path(), true), &both, &["--no-report"]);
    for (f, b) in store.iter().zip(&before) {
        assert_eq!(
            &std::fs::read(both.join("maps.zarr").join(f)).unwrap(),
            b,
            "{f}"
        );
    }
    // Without .npy maps: no maps/ folder; the store alone, equal to the first run's maps.
    let zarr_only = dir.path().join("zarr_only");
    common::run_spec(&spec(dir.path(), false), &zarr_only, &["--no-report"]);
    assert!(!zarr_only.join("maps").exists());
    assert_eq!(check(&python, &zarr_only, &both), said);
    assert_eq!(files(&zarr_only.join("maps.zarr")).len(), 1 + 2 * arrays);
    // Its report draws every job's maps from the store: the maps the figures read (written
    // into figures/<job>/maps/) are the .npy maps of the first run, value for value.
    let o = common::bin(&["report".as_ref(), zarr_only.as_os_str()]);
    assert!(o.status.success(), "{}", common::text(&o));
    let mut compared = 0;
    for job in std::fs::read_dir(both.join("maps")).unwrap() {
        let job = job.unwrap().file_name();
        let drawn = zarr_only.join("figures").join(&job).join("maps");
        for map in std::fs::read_dir(both.join("maps").join(&job)).unwrap() {
            let map = map.unwrap().path();
            let name = map.file_name().unwrap();
            let ours = drawn.join(name);
            if name.to_string_lossy().starts_with("mean") {
                use ndarray_npy::ReadNpyExt;
                let read = |p: &Path| -> ndarray::Array2<num_complex::Complex64> {
                    ndarray::Array2::read_npy(std::fs::File::open(p).unwrap()).unwrap()
                };
                assert_eq!(read(&ours), read(&map), "{}", ours.display());
            } else {
                let read = |p: &Path| isar_clutter::io::npy::read_real_map(p).unwrap();
                let (a, b) = (read(&ours), read(&map));
                assert!(
                    a.iter()
                        .zip(&b)
                        .all(|(x, y)| x == y || (x.is_nan() && y.is_nan())),
                    "{}",
                    ours.display()
                );
            }
            compared += 1;
        }
        assert!(
            std::fs::read_dir(zarr_only.join("figures").join(&job))
                .unwrap()
                .any(|f| f.unwrap().path().extension().is_some_and(|e| e == "png")),
            "no figure of {job:?}"
        );
    }
    assert!(compared > 60, "{compared} maps compared");
}
