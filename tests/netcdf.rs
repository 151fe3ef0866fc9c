//! The `netcdf` dataset kind on a committed slice of NOAA's monthly surface winds
//! (`tests/data/navy_winds_slice.nc`: the first 3 months of `monthly_navy_winds.cdf`, 73 x 144,
//! made by `tests/netcdf_crosscheck.py`): the stack is `UWND + i VWND` exactly as the reader
//! decodes it, calendar months come from the time units, and bad variables are refused with
//! the YAML path.

use isar_clutter::io::netcdf::time::months;
use isar_clutter::io::netcdf::NcFile;
use isar_clutter::run::plan;
use ndarray::Ix3;
use std::path::{Path, PathBuf};

fn slice() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/navy_winds_slice.nc")
}

fn spec(dir: &Path, extra: &str) -> PathBuf {
    let text = format!(
        "name: winds\nseed: 1\ndatasets:\n  - id: w\n    kind: netcdf\n    path: {}\n{extra}analysis:\n  levels: 4\n",
        slice().display()
    );
    let p = dir.join("spec.yaml");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn the_stack_is_u_plus_i_v() {
    let dir = tempfile::tempdir().unwrap();
    let plan = plan::load(&spec(dir.path(), "    u: UWND\n    v: VWND\n")).unwrap();
    let job = &plan.jobs[0];
    assert_eq!(job.dataset.shape(), (3, 73, 144));
    assert_eq!(job.dataset.kind(), "netcdf");
    let stack = job
        .dataset
        .materialise(job.data_seed)
        .unwrap()
        .stack
        .to_complex128(false);
    let nc = NcFile::open(&slice()).unwrap();
    let u = nc
        .read_f64("UWND")
        .unwrap()
        .into_dimensionality::<Ix3>()
        .unwrap();
    let v = nc
        .read_f64("VWND")
        .unwrap()
        .into_dimensionality::<Ix3>()
        .unwrap();
    for (t, i, j) in [(0, 0, 0), (1, 36, 72), (2, 72, 143), (2, 10, 100)] {
        assert_eq!(stack[[t, i, j]].re, u[[t, i, j]]);
        assert_eq!(stack[[t, i, j]].im, v[[t, i, j]]);
    }
    // The analysis runs at 4 levels on the 73 x 144 grid.
    let a = isar_clutter::stats::analysis::analyse(stack.view(), 4).unwrap();
    assert_eq!(a.levels[3].shape(), (4, 9));
}

#[test]
fn calendar_months_come_from_the_time_units() {
    let nc = NcFile::open(&slice()).unwrap();
    let m = months(&nc, "UWND").unwrap();
    assert_eq!(m.len(), 3);
    // Consecutive monthly means: three consecutive calendar months.
    assert_eq!(m[1], m[0] % 12 + 1);
    assert_eq!(m[2], m[1] % 12 + 1);
    // With one sample per month, removing the monthly mean leaves zeros.
    let dir = tempfile::tempdir().unwrap();
    let plan = plan::load(&spec(
        dir.path(),
        "    u: UWND\n    v: VWND\n    remove_monthly_mean: true\n",
    ))
    .unwrap();
    let job = &plan.jobs[0];
    let stack = job
        .dataset
        .materialise(job.data_seed)
        .unwrap()
        .stack
        .to_complex128(false);
    assert!(stack.iter().all(|z| z.norm() < 1e-12));
}

#[test]
fn bad_variables_are_refused_with_the_yaml_path() {
    let dir = tempfile::tempdir().unwrap();
    let e = plan::load(&spec(dir.path(), "    u: UWIND\n"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("datasets[0].u") && e.contains("no variable \"UWIND\"") && e.contains("VWND"),
        "{e}"
    );
    let e = plan::load(&spec(dir.path(), "    u: UWND\n    v: FNOCX\n"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("datasets[0].v") && e.contains("3-D"), "{e}");
    let e = plan::load(&spec(dir.path(), "")).unwrap_err().to_string();
    assert!(
        e.contains("datasets[0].u") && e.contains("needs `u`"),
        "{e}"
    );
}
