//! The OSCAR ocean-current layout (dissertation §5.2, PO.DAAC `OSCAR_L4_OC_third-deg`, files
//! `oscar_vel<year>.nc`): files written by the test-only NetCDF-3 writer of [`super::tests`]
//! with OSCAR's dimensions (`time`, `year`, `depth` = 1, `latitude` from 80 N down,
//! `longitude` from 20 E with the overlap repeated), coordinate variables and attributes
//! (`time` in "day since 1992-10-05 00:00:00", `u`, `v`, `um`, `vm` of type double with NaN
//! over land and `missing_value = NaN`) are read back as stacks `[time, latitude, longitude]`
//! exactly as written; a dimension of length other than 1 between time and the image is
//! refused naming it; NetCDF-4 (HDF5) and gzip-compressed files are refused saying how to
//! convert them.

use super::tests::{s, text, write_tmp, WFile, WVar};
use super::time::{days_from_civil, months};
use super::*;

/// Samples written (OSCAR 2019 has 72, every 5 days from 1 January).
const T: usize = 3;
/// Latitudes: 80, 40, 0, -40, -80 (OSCAR: 481 from 80 to -80 by 1/3 degree).
const NLAT: usize = 5;
/// Longitudes: 20 to 420 by 40 (OSCAR: 1201 from 20 to 420 by 1/3 degree); the last two
/// repeat the first two, as OSCAR's last 40 degrees repeat its first.
const NLON: usize = 11;
/// The 5-day steps (from 2019-01-01) of the samples written: 1 January, 5 February, 7 March.
const STEPS: [i32; T] = [0, 7, 13];

/// Whether pixel `(i, j)` is land (NaN in every sample), repeated in the overlap.
fn land(i: usize, j: usize) -> bool {
    let j = j % 9;
    (i == 0 && j < 2) || (i == 2 && j == 3) || (i == 4 && j == 5)
}

/// The values of `u` (`which` = 0), `v` (1), `um` (2) or `vm` (3) at `(t, i, j)`, NaN on land,
/// the overlap columns repeating the first ones.
fn value(which: usize, t: usize, i: usize, j: usize) -> f64 {
    if land(i, j) {
        return f64::NAN;
    }
    let j = j % 9;
    let x = 0.013 * (t * 100 + i * 11 + j) as f64 - 0.7;
    [x, 0.3 - 0.5 * x, 1.5 * x, -x][which]
}

/// A 4-D velocity variable of OSCAR's: `(time, depth, latitude, longitude)`, double (or float
/// when `single`), `missing_value = NaN`, `depth_len` depths (OSCAR: 1; the others repeat
/// the first).
fn velocity(
    name: &'static str,
    which: usize,
    long_name: &str,
    single: bool,
    depth_len: usize,
) -> WVar {
    let mut vals = Vec::new();
    for t in 0..T {
        for _ in 0..depth_len {
            for i in 0..NLAT {
                vals.extend((0..NLON).map(|j| value(which, t, i, j)));
            }
        }
    }
    let (data, missing) = if single {
        let v = vals.iter().map(|&x| x as f32).collect();
        (AttrValue::Floats(v), AttrValue::Floats(vec![f32::NAN]))
    } else {
        (AttrValue::Doubles(vals), AttrValue::Doubles(vec![f64::NAN]))
    };
    WVar {
        name,
        dims: vec![0, 2, 3, 4],
        attrs: vec![
            (s("units"), text("meter/sec")),
            (s("long_name"), text(long_name)),
            (s("missing_value"), missing),
        ],
        data,
    }
}

/// The coordinate variables of an OSCAR file: `time` (int, days since 1992-10-05), `year`
/// (float, fractional year), `depth` (float, 15 m), `latitude` and `longitude` (double).
fn coordinates(depth_len: usize) -> Vec<WVar> {
    let day0 = days_from_civil(2019, 1, 1) - days_from_civil(1992, 10, 5);
    let days: Vec<i32> = STEPS.iter().map(|k| day0 as i32 + 5 * k).collect();
    let years = STEPS.iter().map(|&k| 2019.0 + 5.0 * k as f32 / 365.0);
    let var = |name, dims, units: &str, long_name: &str, data| WVar {
        name,
        dims,
        attrs: vec![(s("units"), text(units)), (s("long_name"), text(long_name))],
        data,
    };
    let day_units = "day since 1992-10-05 00:00:00";
    vec![
        var(
            "time",
            vec![0],
            day_units,
            "Day since 1992-10-05 00:00:00",
            AttrValue::Ints(days),
        ),
        var(
            "year",
            vec![1],
            "time in years",
            "Time in fractional year",
            AttrValue::Floats(years.collect()),
        ),
        var(
            "depth",
            vec![2],
            "meter",
            "Depth",
            AttrValue::Floats(vec![15.0; depth_len]),
        ),
        var(
            "latitude",
            vec![3],
            "degrees-north",
            "Latitude",
            AttrValue::Doubles((0..NLAT).map(|i| 80.0 - 40.0 * i as f64).collect()),
        ),
        var(
            "longitude",
            vec![4],
            "degrees-east",
            "Longitude",
            AttrValue::Doubles((0..NLON).map(|j| 20.0 + 40.0 * j as f64).collect()),
        ),
    ]
}

/// A file in OSCAR's layout: CDF-`version`, `time` unlimited or fixed, velocities double or
/// float (`single`), `depth_len` depths (OSCAR's files: 1).
fn oscar(version: u8, unlimited: bool, single: bool, depth_len: usize) -> WFile {
    let mut vars = coordinates(depth_len);
    vars.push(velocity(
        "u",
        0,
        "Ocean Surface Zonal Currents",
        single,
        depth_len,
    ));
    vars.push(velocity(
        "v",
        1,
        "Ocean Surface Meridional Currents",
        single,
        depth_len,
    ));
    let um = "Ocean Surface Zonal Currents Maximum Mask";
    vars.push(velocity("um", 2, um, single, depth_len));
    let vm = "Ocean Surface Meridional Currents Maximum Mask";
    vars.push(velocity("vm", 3, vm, single, depth_len));
    let note2 = "Longitude extends from 20 E to 420 E to avoid a break in major ocean basins. \
                 Data repeats in overlap region.";
    WFile {
        version,
        dims: vec![
            ("time", if unlimited { 0 } else { T }),
            ("year", T),
            ("depth", depth_len),
            ("latitude", NLAT),
            ("longitude", NLON),
        ],
        numrecs: if unlimited { T } else { 0 },
        streaming: false,
        gattrs: vec![
            (s("VARIABLE"), text("Ocean Surface Currents")),
            (s("DATATYPE"), text("1/72 YEAR Interval")),
            (s("GEORANGE"), text("20 to 420 -80 to 80")),
            (s("note2"), text(note2)),
        ],
        vars,
    }
}

/// Checks the stack of velocity `name` (`which` as in [`value`]) against what was written.
fn check_velocity(nc: &NcFile, name: &str, which: usize, single: bool) {
    assert_eq!(nc.stack_shape(name).unwrap(), (T, NLAT, NLON));
    assert_eq!(nc.read_f64(name).unwrap().shape(), &[T, 1, NLAT, NLON]);
    let x = nc.read_stack(name).unwrap();
    assert_eq!(x.dim(), (T, NLAT, NLON));
    for ((t, i, j), &got) in x.indexed_iter() {
        let want = value(which, t, i, j);
        let want = if single { f64::from(want as f32) } else { want };
        if land(i, j) {
            assert!(
                got.is_nan(),
                "{name}[{t}, {i}, {j}] = {got}, land must be NaN"
            );
        } else {
            assert_eq!(got.to_bits(), want.to_bits(), "{name}[{t}, {i}, {j}]");
        }
    }
    // The overlap (380 and 420 E) repeats 20 and 60 E.
    for t in 0..T {
        for i in 0..NLAT {
            for j in 0..2 {
                let (a, b) = (x[[t, i, j]], x[[t, i, j + 9]]);
                assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()));
            }
        }
    }
}

#[test]
fn oscar_layout_reads_as_time_latitude_longitude_stacks() {
    let dir = tempfile::tempdir().unwrap();
    for version in [1, 2] {
        for unlimited in [false, true] {
            for single in [false, true] {
                let name = format!("oscar_vel2019_{version}_{unlimited}_{single}.nc");
                let p = write_tmp(&dir, &name, &oscar(version, unlimited, single, 1).encode());
                let nc = NcFile::open(&p).unwrap();
                assert_eq!(nc.version(), version);
                assert_eq!(nc.numrecs(), if unlimited { T } else { 0 });
                for (which, v) in ["u", "v", "um", "vm"].into_iter().enumerate() {
                    check_velocity(&nc, v, which, single);
                }
                // Coordinates as written; the time axis gives the calendar months.
                assert_eq!(nc.read_f64("depth").unwrap().as_slice().unwrap(), &[15.0]);
                let lat = nc.read_f64("latitude").unwrap();
                assert_eq!(lat.as_slice().unwrap(), &[80.0, 40.0, 0.0, -40.0, -80.0]);
                let lon = nc.read_f64("longitude").unwrap();
                assert_eq!((lon[0], lon[NLON - 1]), (20.0, 420.0));
                assert_eq!(months(&nc, "u").unwrap(), vec![1, 2, 3]);
                assert_eq!(months(&nc, "v").unwrap(), vec![1, 2, 3]);
            }
        }
    }
}

#[test]
fn an_extra_dimension_longer_than_one_is_refused_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_tmp(&dir, "two_depths.nc", &oscar(1, true, false, 2).encode());
    let nc = NcFile::open(&p).unwrap();
    for e in [
        nc.stack_shape("u").unwrap_err(),
        nc.read_stack("v").unwrap_err(),
    ] {
        assert!(
            matches!(&e, NcError::ExtraDimension { dim, len: 2, .. } if dim == "depth"),
            "{e}"
        );
        let m = e.to_string();
        assert!(
            m.contains("two_depths.nc") && m.contains("dimension \"depth\" of length 2"),
            "{m}"
        );
    }
    assert!(nc
        .stack_shape("u")
        .unwrap_err()
        .to_string()
        .contains("\"u\""));
    // The variable as stored is still readable, 4-D.
    assert_eq!(nc.read_f64("u").unwrap().shape(), &[T, 2, NLAT, NLON]);
    // Fewer than 3 dimensions: not a stack; an unknown name: not found.
    let e = nc.stack_shape("latitude").unwrap_err();
    assert!(
        matches!(e, NcError::NotAStack { .. }) && e.to_string().contains("3-D"),
        "{e}"
    );
    let e = nc.read_stack("w").unwrap_err();
    assert!(matches!(e, NcError::VariableNotFound { .. }), "{e}");
}

#[test]
fn netcdf4_and_gzip_files_say_how_to_convert_them() {
    let hdf5 = b"\x89HDF\r\n\x1a\n\0\0\0\0".to_vec();
    let e = NcFile::from_bytes(Path::new("oscar_vel2019.nc"), hdf5).unwrap_err();
    assert!(matches!(e, NcError::BadMagic { .. }), "{e}");
    let m = e.to_string();
    assert!(
        m.contains("oscar_vel2019.nc") && m.contains("nccopy -k classic"),
        "{m}"
    );
    let gz = vec![0x1f, 0x8b, 8, 0, 0, 0];
    let m = NcFile::from_bytes(Path::new("oscar_vel2019.nc.gz"), gz)
        .unwrap_err()
        .to_string();
    assert!(m.contains("gunzip"), "{m}");
    let m = NcFile::from_bytes(Path::new("x.nc"), b"PK\x03\x04".to_vec())
        .unwrap_err()
        .to_string();
    assert!(!m.contains("nccopy") && !m.contains("gunzip"), "{m}");
}
