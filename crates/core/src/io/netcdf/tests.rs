//! Round trips through a minimal NetCDF-3 writer (test-only), error
//! handling on damaged files, and cross-checks against scipy on NOAA's
//! `monthly_navy_winds.cdf` (fixtures made by `tests/netcdf_crosscheck.py`).

use super::header::*;
use super::*;
use std::path::PathBuf;

// ------------------------------------------------------------------
// Minimal NetCDF-3 writer, only for tests.
// ------------------------------------------------------------------

/// A variable to write: its data (all records, C order) in its type.
pub(super) struct WVar {
    pub(super) name: &'static str,
    pub(super) dims: Vec<usize>,
    pub(super) attrs: Vec<(String, AttrValue)>,
    pub(super) data: AttrValue,
}

/// A file to write. A dimension of length 0 is the unlimited one.
pub(super) struct WFile {
    pub(super) version: u8,
    pub(super) dims: Vec<(&'static str, usize)>,
    pub(super) numrecs: usize,
    pub(super) streaming: bool,
    pub(super) gattrs: Vec<(String, AttrValue)>,
    pub(super) vars: Vec<WVar>,
}

fn be_values(v: &AttrValue) -> Vec<u8> {
    match v {
        AttrValue::Text(s) => s.as_bytes().to_vec(),
        AttrValue::Bytes(x) => x.iter().map(|&b| b as u8).collect(),
        AttrValue::Shorts(x) => x.iter().flat_map(|b| b.to_be_bytes()).collect(),
        AttrValue::Ints(x) => x.iter().flat_map(|b| b.to_be_bytes()).collect(),
        AttrValue::Floats(x) => x.iter().flat_map(|b| b.to_be_bytes()).collect(),
        AttrValue::Doubles(x) => x.iter().flat_map(|b| b.to_be_bytes()).collect(),
    }
}

fn put_u32(out: &mut Vec<u8>, x: u32) {
    out.extend_from_slice(&x.to_be_bytes());
}

fn put_padded(out: &mut Vec<u8>, b: &[u8]) {
    out.extend_from_slice(b);
    out.resize(out.len() + (pad4(b.len() as u64) as usize - b.len()), 0);
}

fn put_name(out: &mut Vec<u8>, s: &str) {
    put_u32(out, s.len() as u32);
    put_padded(out, s.as_bytes());
}

fn put_attrs(out: &mut Vec<u8>, attrs: &[(String, AttrValue)]) {
    if attrs.is_empty() {
        put_u32(out, 0);
        put_u32(out, 0);
        return;
    }
    put_u32(out, NC_ATTRIBUTE);
    put_u32(out, attrs.len() as u32);
    for (name, v) in attrs {
        put_name(out, name);
        put_u32(out, v.nc_type().code());
        let b = be_values(v);
        put_u32(out, (b.len() / v.nc_type().size()) as u32);
        put_padded(out, &b);
    }
}

impl WFile {
    fn is_record(&self, v: &WVar) -> bool {
        v.dims.first().is_some_and(|&d| self.dims[d].1 == 0)
    }

    /// Bytes of one record (record variables) or of the whole variable.
    fn slab_bytes(&self, v: &WVar) -> usize {
        let skip = usize::from(self.is_record(v));
        v.dims[skip..]
            .iter()
            .map(|&d| self.dims[d].1)
            .product::<usize>()
            * v.data.nc_type().size()
    }

    fn header(&self, begins: &[u64]) -> Vec<u8> {
        let mut out = b"CDF".to_vec();
        out.push(self.version);
        put_u32(
            &mut out,
            if self.streaming {
                STREAMING
            } else {
                self.numrecs as u32
            },
        );
        if self.dims.is_empty() {
            put_u32(&mut out, 0);
            put_u32(&mut out, 0);
        } else {
            put_u32(&mut out, NC_DIMENSION);
            put_u32(&mut out, self.dims.len() as u32);
            for (n, l) in &self.dims {
                put_name(&mut out, n);
                put_u32(&mut out, *l as u32);
            }
        }
        put_attrs(&mut out, &self.gattrs);
        if self.vars.is_empty() {
            put_u32(&mut out, 0);
            put_u32(&mut out, 0);
        } else {
            put_u32(&mut out, NC_VARIABLE);
            put_u32(&mut out, self.vars.len() as u32);
            for (v, &begin) in self.vars.iter().zip(begins) {
                put_name(&mut out, v.name);
                put_u32(&mut out, v.dims.len() as u32);
                for &d in &v.dims {
                    put_u32(&mut out, d as u32);
                }
                put_attrs(&mut out, &v.attrs);
                put_u32(&mut out, v.data.nc_type().code());
                put_u32(&mut out, pad4(self.slab_bytes(v) as u64) as u32);
                if self.version == 1 {
                    put_u32(&mut out, begin as u32);
                } else {
                    out.extend_from_slice(&begin.to_be_bytes());
                }
            }
        }
        out
    }

    pub(super) fn encode(&self) -> Vec<u8> {
        let header_len = self.header(&vec![0; self.vars.len()]).len() as u64;
        let mut begins = vec![0u64; self.vars.len()];
        let mut off = header_len;
        for (k, v) in self.vars.iter().enumerate() {
            if !self.is_record(v) {
                begins[k] = off;
                off += pad4(self.slab_bytes(v) as u64);
            }
        }
        let nrecvars = self.vars.iter().filter(|v| self.is_record(v)).count();
        for (k, v) in self.vars.iter().enumerate() {
            if self.is_record(v) {
                begins[k] = off;
                off += if nrecvars == 1 {
                    self.slab_bytes(v) as u64
                } else {
                    pad4(self.slab_bytes(v) as u64)
                };
            }
        }
        let mut out = self.header(&begins);
        for v in self.vars.iter().filter(|v| !self.is_record(v)) {
            put_padded(&mut out, &be_values(&v.data));
        }
        for r in 0..self.numrecs {
            for v in self.vars.iter().filter(|v| self.is_record(v)) {
                let n = self.slab_bytes(v);
                let chunk = &be_values(&v.data)[r * n..(r + 1) * n];
                if nrecvars == 1 {
                    out.extend_from_slice(chunk);
                } else {
                    put_padded(&mut out, chunk);
                }
            }
        }
        out
    }
}

pub(super) fn write_tmp(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.path().join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

pub(super) fn s(x: &str) -> String {
    x.to_string()
}

pub(super) fn text(x: &str) -> AttrValue {
    AttrValue::Text(x.to_string())
}

/// A file with fixed and record variables of every type, attributes of
/// every type, fill/missing values and packing.
fn sample(version: u8) -> WFile {
    // dims: 0 time (unlimited), 1 y = 2, 2 x = 3, 3 odd = 5
    WFile {
        version,
        dims: vec![("time", 0), ("y", 2), ("x", 3), ("odd", 5)],
        numrecs: 3,
        streaming: false,
        gattrs: vec![
            (s("title"), text("test file \u{e9}")),
            (s("gb"), AttrValue::Bytes(vec![-128, 0, 127])),
            (s("gs"), AttrValue::Shorts(vec![-32768, 1, 32767])),
            (s("gi"), AttrValue::Ints(vec![i32::MIN, 7, i32::MAX])),
            (s("gf"), AttrValue::Floats(vec![1.5, -0.25])),
            (s("gd"), AttrValue::Doubles(vec![std::f64::consts::PI])),
            (s("empty"), text("")),
        ],
        vars: vec![
            WVar {
                name: "b",
                dims: vec![1, 2],
                attrs: vec![(s("_FillValue"), AttrValue::Bytes(vec![-127]))],
                data: AttrValue::Bytes(vec![-128, -127, 0, 1, 2, 127]),
            },
            WVar {
                name: "c",
                dims: vec![3],
                attrs: vec![(s("long_name"), text("chars"))],
                data: text("hello"),
            },
            WVar {
                name: "s",
                dims: vec![2],
                attrs: vec![
                    (s("scale_factor"), AttrValue::Floats(vec![0.5])),
                    (s("add_offset"), AttrValue::Doubles(vec![10.0])),
                    (s("_FillValue"), AttrValue::Shorts(vec![-32768])),
                ],
                data: AttrValue::Shorts(vec![-32768, 4, -4]),
            },
            WVar {
                name: "i",
                dims: vec![1, 2],
                attrs: vec![(s("missing_value"), AttrValue::Ints(vec![-999, -998]))],
                data: AttrValue::Ints(vec![1, -999, 3, -998, i32::MAX, i32::MIN]),
            },
            WVar {
                name: "f",
                dims: vec![3],
                attrs: vec![
                    (s("_FillValue"), AttrValue::Floats(vec![9.969_21e36])),
                    // Declared as double: compared after conversion to float.
                    (s("missing_value"), AttrValue::Doubles(vec![-99.9])),
                    (s("units"), text("m/s")),
                ],
                data: AttrValue::Floats(vec![1.25, 9.969_21e36, -99.9, f32::MIN_POSITIVE, 3.0]),
            },
            WVar {
                name: "d",
                dims: vec![1, 2],
                attrs: vec![(s("_FillValue"), AttrValue::Doubles(vec![-1e30]))],
                data: AttrValue::Doubles(vec![0.1, -1e30, 1e300, -0.0, 5.5, 6.5]),
            },
            WVar {
                name: "scalar",
                dims: vec![],
                attrs: vec![],
                data: AttrValue::Doubles(vec![3.25]),
            },
            // Record variables.
            WVar {
                name: "rb",
                dims: vec![0, 2],
                attrs: vec![],
                data: AttrValue::Bytes(vec![1, 2, 3, 4, 5, 6, 7, 8, -9]),
            },
            WVar {
                name: "rc",
                dims: vec![0, 3],
                attrs: vec![],
                data: text("abcdefghijklmno"),
            },
            WVar {
                name: "rs",
                dims: vec![0],
                attrs: vec![(s("_FillValue"), AttrValue::Shorts(vec![-1]))],
                data: AttrValue::Shorts(vec![10, -1, 30]),
            },
            WVar {
                name: "ri",
                dims: vec![0, 2],
                attrs: vec![(s("scale_factor"), AttrValue::Doubles(vec![2.0]))],
                data: AttrValue::Ints(vec![1, 2, 3, 4, 5, 6, 7, 8, 9]),
            },
            WVar {
                name: "rf",
                dims: vec![0, 1, 2],
                attrs: vec![(s("_FillValue"), AttrValue::Floats(vec![-1.0]))],
                data: AttrValue::Floats(
                    (0..18)
                        .map(|k| if k == 7 { -1.0 } else { k as f32 * 0.5 })
                        .collect(),
                ),
            },
            WVar {
                name: "rd",
                dims: vec![0],
                attrs: vec![(s("units"), text("hours since 2000-01-01"))],
                data: AttrValue::Doubles(vec![0.0, 6.0, 12.0]),
            },
        ],
    }
}

fn values(a: &ArrayD<f64>) -> Vec<f64> {
    a.iter().copied().collect()
}

/// Equality that treats NaN == NaN and distinguishes nothing else.
fn same(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| (x.is_nan() && y.is_nan()) || x == y)
}

fn check_sample(nc: &NcFile) {
    let nan = f64::NAN;
    assert_eq!(nc.numrecs(), 3);
    assert_eq!(nc.dimensions().len(), 4);
    assert!(nc.dimensions()[0].unlimited);
    assert_eq!(
        nc.dimensions()[3],
        Dimension {
            name: s("odd"),
            len: 5,
            unlimited: false
        }
    );
    let w = sample(nc.version());
    assert_eq!(nc.global_attrs(), &w.gattrs[..]);
    assert_eq!(nc.attr(None, "title"), Some(&text("test file \u{e9}")));
    assert_eq!(nc.attr(Some("f"), "units"), Some(&text("m/s")));
    assert_eq!(nc.attr(Some("nope"), "units"), None);
    assert_eq!(nc.attr(Some("f"), "nope"), None);
    for (v, wv) in nc.variables().iter().zip(&w.vars) {
        assert_eq!(v.name, wv.name);
        assert_eq!(v.dims, wv.dims);
        assert_eq!(v.attrs, wv.attrs);
        assert_eq!(v.nc_type, wv.data.nc_type());
        assert_eq!(v.is_record, w.is_record(wv));
    }
    let get = |n: &str| values(&nc.read_f64(n).unwrap());
    let shape = |n: &str| nc.shape(nc.variable(n).unwrap());
    assert_eq!(shape("b"), vec![2, 3]);
    assert_eq!(shape("scalar"), Vec::<usize>::new());
    assert_eq!(shape("rf"), vec![3, 2, 3]);
    assert_eq!(shape("rs"), vec![3]);
    assert!(same(&get("b"), &[-128.0, nan, 0.0, 1.0, 2.0, 127.0]));
    assert!(same(&get("s"), &[nan, 12.0, 8.0]));
    assert!(same(
        &get("i"),
        &[1.0, nan, 3.0, nan, f64::from(i32::MAX), f64::from(i32::MIN)]
    ));
    assert!(same(
        &get("f"),
        &[1.25, nan, nan, f64::from(f32::MIN_POSITIVE), 3.0]
    ));
    assert!(same(&get("d"), &[0.1, nan, 1e300, -0.0, 5.5, 6.5]));
    assert!(same(&get("scalar"), &[3.25]));
    assert!(same(&get("rb"), &[1., 2., 3., 4., 5., 6., 7., 8., -9.]));
    assert!(same(&get("rs"), &[10.0, nan, 30.0]));
    assert!(same(
        &get("ri"),
        &(1..=9).map(|k| 2.0 * f64::from(k)).collect::<Vec<_>>()
    ));
    let rf: Vec<f64> = (0..18)
        .map(|k| if k == 7 { nan } else { f64::from(k) * 0.5 })
        .collect();
    assert!(same(&get("rf"), &rf));
    assert_eq!(nc.read_f64("rf").unwrap().shape(), &[3, 2, 3]);
    assert!(same(&get("rd"), &[0.0, 6.0, 12.0]));
    assert!(matches!(nc.read_f64("c"), Err(NcError::NotNumeric { .. })));
    assert!(matches!(nc.read_f64("rc"), Err(NcError::NotNumeric { .. })));
    match nc.read_f64("missing") {
        Err(e @ NcError::VariableNotFound { .. }) => {
            let msg = e.to_string();
            assert!(msg.contains("missing") && msg.contains(".nc"), "{msg}");
        }
        other => panic!("expected VariableNotFound, got {other:?}"),
    }
}

#[test]
fn roundtrip_cdf1_and_cdf2() {
    let dir = tempfile::tempdir().unwrap();
    for version in [1u8, 2] {
        let bytes = sample(version).encode();
        let p = write_tmp(&dir, &format!("sample{version}.nc"), &bytes);
        let nc = NcFile::open(&p).unwrap();
        assert_eq!(nc.version(), version);
        assert_eq!(nc.path(), p.as_path());
        check_sample(&nc);
    }
}

#[test]
fn streaming_numrecs_is_computed_from_file_size() {
    let mut w = sample(1);
    w.streaming = true;
    let nc = NcFile::from_bytes(Path::new("stream.nc"), w.encode()).unwrap();
    check_sample(&nc);
}

#[test]
fn single_record_variable_is_not_padded() {
    // A lone byte record variable of 3 values: records are 3 bytes apart.
    for (dims, data, shape) in [
        (
            vec![0, 1],
            AttrValue::Bytes(vec![1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12]),
            vec![4, 3],
        ),
        (vec![0], AttrValue::Shorts(vec![-5, 6, -7, 8]), vec![4]),
    ] {
        let expect = data.as_f64_vec().unwrap();
        let w = WFile {
            version: 1,
            dims: vec![("rec", 0), ("three", 3)],
            numrecs: 4,
            streaming: false,
            gattrs: vec![],
            vars: vec![
                WVar {
                    name: "fixed",
                    dims: vec![1],
                    attrs: vec![],
                    data: AttrValue::Bytes(vec![9, 8, 7]),
                },
                WVar {
                    name: "r",
                    dims,
                    attrs: vec![],
                    data,
                },
            ],
        };
        let bytes = w.encode();
        let nc = NcFile::from_bytes(Path::new("single.nc"), bytes.clone()).unwrap();
        let r = nc.read_f64("r").unwrap();
        assert_eq!(r.shape(), &shape[..]);
        assert_eq!(values(&r), expect);
        assert_eq!(values(&nc.read_f64("fixed").unwrap()), vec![9.0, 8.0, 7.0]);
        // File ends right after the unpadded last record.
        let v = nc.variable("r").unwrap();
        let rec = shape.iter().skip(1).product::<usize>() * v.nc_type.size();
        assert_eq!(v.begin as usize + 4 * rec, bytes.len());
    }
}

#[test]
fn empty_file_and_zero_records() {
    let w = WFile {
        version: 2,
        dims: vec![],
        numrecs: 0,
        streaming: false,
        gattrs: vec![],
        vars: vec![],
    };
    let nc = NcFile::from_bytes(Path::new("empty.nc"), w.encode()).unwrap();
    assert!(nc.dimensions().is_empty() && nc.variables().is_empty());
    let mut w = sample(1);
    w.numrecs = 0;
    for v in &mut w.vars {
        if v.dims.first() == Some(&0) {
            v.data = match &v.data {
                AttrValue::Text(_) => text(""),
                AttrValue::Bytes(_) => AttrValue::Bytes(vec![]),
                AttrValue::Shorts(_) => AttrValue::Shorts(vec![]),
                AttrValue::Ints(_) => AttrValue::Ints(vec![]),
                AttrValue::Floats(_) => AttrValue::Floats(vec![]),
                AttrValue::Doubles(_) => AttrValue::Doubles(vec![]),
            };
        }
    }
    let nc = NcFile::from_bytes(Path::new("norec.nc"), w.encode()).unwrap();
    assert_eq!(nc.read_f64("rf").unwrap().shape(), &[0, 2, 3]);
    assert_eq!(nc.read_f64("d").unwrap().len(), 6);
}

#[test]
fn errors_name_the_file_and_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let good = sample(1).encode();

    let e = NcFile::open(&dir.path().join("absent.nc")).unwrap_err();
    assert!(matches!(e, NcError::Io { .. }) && e.to_string().contains("absent.nc"));

    let p = write_tmp(&dir, "hdf.nc", b"\x89HDF\r\n\x1a\n");
    let e = NcFile::open(&p).unwrap_err();
    assert!(matches!(e, NcError::BadMagic { .. }), "{e}");
    assert!(e.to_string().contains("hdf.nc"));
    assert!(matches!(
        NcFile::from_bytes(Path::new("x"), vec![]),
        Err(NcError::BadMagic { .. })
    ));

    let mut cdf5 = good.clone();
    cdf5[3] = 5;
    let e = NcFile::from_bytes(Path::new("five.nc"), cdf5).unwrap_err();
    assert!(
        matches!(e, NcError::UnsupportedVersion { version: 5, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("five.nc"));

    // Unknown type: patch the type code of variable "b" (NC_BYTE = 1) to 7 (CDF-5 NC_UBYTE).
    let nc = NcFile::from_bytes(Path::new("ok.nc"), good.clone()).unwrap();
    let b = nc.variable("b").unwrap();
    // In CDF-1 the type precedes vsize (4 bytes) and begin (4 bytes).
    let begin_bytes = (b.begin as u32).to_be_bytes();
    let mut pos = None;
    for k in 0..good.len() - 12 {
        if good[k..k + 4] == 1u32.to_be_bytes()
            && good[k + 4..k + 8] == 8u32.to_be_bytes()
            && good[k + 8..k + 12] == begin_bytes
        {
            pos = Some(k);
        }
    }
    let mut bad_type = good.clone();
    bad_type[pos.unwrap() + 3] = 7;
    let e = NcFile::from_bytes(Path::new("type.nc"), bad_type).unwrap_err();
    assert!(matches!(e, NcError::UnknownType { code: 7, .. }), "{e}");
    assert!(e.to_string().contains("\"b\""), "{e}");

    // Data beyond the end of file.
    let short = &good[..good.len() - 1];
    let e = NcFile::from_bytes(Path::new("cut.nc"), short.to_vec()).unwrap_err();
    assert!(matches!(e, NcError::DataBeyondEof { .. }), "{e}");
    assert!(e.to_string().contains("cut.nc"));

    // Every truncation of the header is an error, never a panic.
    let header_len = nc.variables().iter().map(|v| v.begin).min().unwrap() as usize;
    for n in 0..header_len {
        let e = NcFile::from_bytes(Path::new("trunc.nc"), good[..n].to_vec()).unwrap_err();
        if n >= 8 {
            assert!(
                matches!(
                    e,
                    NcError::TruncatedHeader { .. } | NcError::BadHeader { .. }
                ),
                "prefix {n}: {e}"
            );
        }
    }
    // Truncation inside the data section.
    for n in header_len..good.len() {
        assert!(NcFile::from_bytes(Path::new("trunc.nc"), good[..n].to_vec()).is_err());
    }
}

#[test]
fn corrupted_headers_never_panic() {
    let good = sample(2).encode();
    let header_len = 1200.min(good.len());
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for _ in 0..3000 {
        let mut b = good.clone();
        for _ in 0..1 + next() % 3 {
            let k = 4 + (next() as usize) % (header_len - 4);
            b[k] = match next() % 4 {
                0 => 0xFF,
                1 => 0,
                _ => next() as u8,
            };
        }
        if let Ok(nc) = NcFile::from_bytes(Path::new("fuzz.nc"), b) {
            for v in nc.variables() {
                let _ = nc.read_f64(&v.name);
                let _ = nc.shape(v);
            }
        }
    }
}

// ------------------------------------------------------------------
// NOAA monthly_navy_winds.cdf (ferret-datasets), cross-checked with scipy.
// ------------------------------------------------------------------

const FIXTURE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/data/navy_winds_values.txt"
);
const SLICE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/data/navy_winds_slice.nc"
);

/// Locations of the real file: `$NAVY_WINDS_CDF`, then where
/// `dpkg -x ferret-datasets_*.deb /tmp/ferret` or an installed package puts it.
fn real_file() -> Option<PathBuf> {
    let mut c: Vec<PathBuf> = std::env::var_os("NAVY_WINDS_CDF")
        .map(PathBuf::from)
        .into_iter()
        .collect();
    c.push(PathBuf::from(
        "/tmp/ferret/usr/share/ferret-vis/data/monthly_navy_winds.cdf",
    ));
    c.push(PathBuf::from(
        "/usr/share/ferret-vis/data/monthly_navy_winds.cdf",
    ));
    c.into_iter().find(|p| p.is_file())
}

struct Fixture {
    shapes: Vec<(String, Vec<usize>)>,
    /// (var, nan count, bit sum, weighted bit sum) for all records.
    check: Vec<(String, usize, u64, u64)>,
    /// Same for the first 3 records.
    slice_check: Vec<(String, usize, u64, u64)>,
    /// (var, [t, j, i], value) with value NaN for fill.
    values: Vec<(String, [usize; 3], f64)>,
}

fn fixture() -> Fixture {
    let text = std::fs::read_to_string(FIXTURE).expect("fixture tests/data/navy_winds_values.txt");
    let mut f = Fixture {
        shapes: vec![],
        check: vec![],
        slice_check: vec![],
        values: vec![],
    };
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w[0] {
            "SHAPE" => f
                .shapes
                .push((s(w[1]), w[2..].iter().map(|x| x.parse().unwrap()).collect())),
            "CHECK" | "SLICECHECK" => {
                let row = (
                    s(w[1]),
                    w[2].parse().unwrap(),
                    w[3].parse().unwrap(),
                    w[4].parse().unwrap(),
                );
                if w[0] == "CHECK" {
                    f.check.push(row)
                } else {
                    f.slice_check.push(row)
                }
            }
            "V" => f.values.push((
                s(w[1]),
                [
                    w[2].parse().unwrap(),
                    w[3].parse().unwrap(),
                    w[4].parse().unwrap(),
                ],
                if w[5] == "nan" {
                    f64::NAN
                } else {
                    w[5].parse().unwrap()
                },
            )),
            _ => {}
        }
    }
    f
}

/// NaN count and the order-sensitive checksums of the float32 bit
/// patterns, as computed by `tests/netcdf_crosscheck.py`.
fn checksums(a: &ArrayD<f64>, nrec: usize) -> (usize, u64, u64) {
    let per_rec = a.len() / a.shape()[0];
    let (mut nan, mut s1, mut s2) = (0usize, 0u64, 0u64);
    for (k, &v) in a.iter().take(nrec * per_rec).enumerate() {
        let bits = if v.is_nan() {
            nan += 1;
            0
        } else {
            let f = v as f32;
            assert_eq!(f64::from(f), v, "value is not a float32");
            u64::from(f.to_bits())
        };
        s1 = s1.wrapping_add(bits);
        s2 = s2.wrapping_add(bits.wrapping_mul(k as u64 + 1));
    }
    (nan, s1, s2)
}

fn check_winds_attrs(nc: &NcFile) {
    for (v, long) in [("UWND", "ZONAL WIND"), ("VWND", "MERIDIONAL WIND")] {
        assert_eq!(nc.attr(Some(v), "units"), Some(&text("M/S")));
        assert_eq!(nc.attr(Some(v), "long_name"), Some(&text(long)));
        assert_eq!(
            nc.attr(Some(v), "_FillValue"),
            Some(&AttrValue::Floats(vec![-99.9]))
        );
        assert_eq!(
            nc.attr(Some(v), "missing_value"),
            Some(&AttrValue::Floats(vec![-99.9]))
        );
        assert_eq!(nc.variable(v).unwrap().nc_type, NcType::Float);
        assert!(nc.variable(v).unwrap().is_record);
    }
    assert_eq!(
        nc.attr(Some("TIME"), "units"),
        Some(&text("hour since 1980-01-14 14:00:00"))
    );
    assert_eq!(nc.attr(Some("FNOCX"), "units"), Some(&text("degrees_east")));
    assert_eq!(
        nc.attr(Some("FNOCY"), "units"),
        Some(&text("degrees_north"))
    );
    let lon = nc.read_f64("FNOCX").unwrap();
    let lat = nc.read_f64("FNOCY").unwrap();
    assert_eq!((lon[[0]], lon[[143]]), (20.0, 377.5));
    assert_eq!((lat[[0]], lat[[72]]), (-90.0, 90.0));
}

#[test]
fn navy_winds_real_file_matches_scipy() {
    let Some(path) = real_file() else {
        eprintln!(
                "note: monthly_navy_winds.cdf not found (set NAVY_WINDS_CDF or run \
                 `cd /tmp && apt-get download ferret-datasets && dpkg -x ferret-datasets_*.deb /tmp/ferret`); skipping"
            );
        return;
    };
    let nc = NcFile::open(&path).unwrap();
    let fx = fixture();
    assert_eq!(nc.version(), 1);
    assert_eq!(nc.numrecs(), 132);
    assert_eq!(
        nc.attr(None, "history"),
        Some(&text("FERRET V4.45 (GUI) 22-May-97"))
    );
    for (name, shape) in &fx.shapes {
        assert_eq!(&nc.shape(nc.variable(name).unwrap()), shape, "{name}");
    }
    assert_eq!(nc.shape(nc.variable("UWND").unwrap()), vec![132, 73, 144]);
    let names: Vec<&str> = nc.dimensions().iter().map(|d| d.name.as_str()).collect();
    assert_eq!(names, ["FNOCX", "FNOCY", "TIME"]);
    check_winds_attrs(&nc);
    let time = nc.read_f64("TIME").unwrap();
    assert_eq!((time[[0]], time[[131]]), (17598.0, 113293.5));
    for (name, nan, s1, s2) in &fx.check {
        let a = nc.read_f64(name).unwrap();
        assert_eq!(checksums(&a, 132), (*nan, *s1, *s2), "{name}");
        let mut n = 0;
        for (_, idx, val) in fx.values.iter().filter(|(v, _, _)| v == name) {
            let got = a[&idx[..]];
            assert!(same(&[got], &[*val]), "{name}{idx:?}: {got} vs scipy {val}");
            n += 1;
        }
        assert!(n >= 200, "only {n} fixture values for {name}");
        eprintln!("{name}: {nan} fill/missing values (NaN), {n} values equal to scipy's");
    }
}

#[test]
fn navy_winds_slice_fixture() {
    let nc = NcFile::open(Path::new(SLICE)).unwrap();
    let fx = fixture();
    assert_eq!(nc.numrecs(), 3);
    assert_eq!(nc.shape(nc.variable("UWND").unwrap()), vec![3, 73, 144]);
    assert_eq!(nc.shape(nc.variable("VWND").unwrap()), vec![3, 73, 144]);
    assert_eq!(nc.shape(nc.variable("TIME").unwrap()), vec![3]);
    check_winds_attrs(&nc);
    for (name, nan, s1, s2) in &fx.slice_check {
        let a = nc.read_f64(name).unwrap();
        assert_eq!(checksums(&a, 3), (*nan, *s1, *s2), "{name}");
    }
    let u = nc.read_f64("UWND").unwrap();
    let v = nc.read_f64("VWND").unwrap();
    let mut n = 0;
    for (name, idx, val) in fx.values.iter().filter(|(_, idx, _)| idx[0] < 3) {
        let got = if name == "UWND" {
            u[&idx[..]]
        } else {
            v[&idx[..]]
        };
        assert!(same(&[got], &[*val]), "{name}{idx:?}: {got} vs scipy {val}");
        n += 1;
    }
    assert!(n >= 100, "only {n} fixture values in the slice");
}
