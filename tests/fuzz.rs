//! Bounded fuzzing (proptest) of the three readers of untrusted files: the `.npy` header
//! parser, the spec loader and the model-folder loader. Each must answer `Ok` or `Err` for
//! any input and never panic; where the input is known to be bad (a shape whose size
//! overflows, a truncated file, an array of the wrong shape) the answer must be `Err`. Case
//! counts keep each property to a few seconds in release.

mod common;

use isar_clutter::io::{model, npy};
use isar_clutter::synthesis::{fit, FitOptions, Method};
use ndarray::{ArrayD, IxDyn};
use ndarray_npy::WriteNpyExt;
use num_complex::Complex64;
use proptest::prelude::*;
use std::path::{Path, PathBuf};

/// A path in a folder shared by every case of this binary (one name per test, so that the
/// tests, which run in parallel, never share a file; the cases of one test run in turn).
fn scratch(name: &str) -> PathBuf {
    static DIR: std::sync::OnceLock<tempfile::TempDir> = std::sync::OnceLock::new();
    DIR.get_or_init(|| tempfile::tempdir().unwrap())
        .path()
        .join(name)
}

// ---- (a) the `.npy` header parser ----

/// A header built from parts that may each be wrong: the descriptor, the shape (dimensions
/// up to `u64::MAX`), the version byte; the file may be cut short.
#[derive(Debug, Clone)]
struct NpyCase {
    version: u8,
    descr: String,
    fortran: &'static str,
    shape: Vec<u64>,
    data: usize,
    cut: Option<usize>,
}

fn npy_case() -> impl Strategy<Value = NpyCase> {
    let descr = prop_oneof![
        Just("<c8".to_string()),
        Just("<c16".to_string()),
        Just("<f4".to_string()),
        Just("<f8".to_string()),
        Just("|u1".to_string()),
        Just(">f8".to_string()),
        "[<>|]?[a-zA-Z]{0,2}[0-9]{0,3}",
    ];
    let dim = prop_oneof![
        0u64..6,
        Just(u64::MAX),
        Just(1 << 62),
        Just(1 << 32),
        any::<u64>()
    ];
    (
        prop_oneof![Just(1u8), Just(2), Just(3), any::<u8>()],
        descr,
        prop_oneof![Just("False"), Just("True"), Just("0"), Just("")],
        proptest::collection::vec(dim, 0..5),
        0usize..600,
        proptest::option::of(0usize..200),
    )
        .prop_map(|(version, descr, fortran, shape, data, cut)| NpyCase {
            version,
            descr,
            fortran,
            shape,
            data,
            cut,
        })
}

impl NpyCase {
    /// The file's bytes and where its header ends.
    fn bytes(&self) -> (Vec<u8>, usize) {
        let dims: Vec<String> = self.shape.iter().map(u64::to_string).collect();
        let shape = match dims.len() {
            1 => format!("({},)", dims[0]),
            _ => format!("({})", dims.join(", ")),
        };
        let dict = format!(
            "{{'descr': '{}', 'fortran_order': {}, 'shape': {shape}, }}\n",
            self.descr, self.fortran
        );
        let mut out = b"\x93NUMPY".to_vec();
        out.push(self.version);
        out.push(0);
        if self.version == 1 {
            out.extend((dict.len() as u16).to_le_bytes());
        } else {
            out.extend((dict.len() as u32).to_le_bytes());
        }
        out.extend(dict.as_bytes());
        let header_end = out.len();
        out.extend((0..self.data).map(|i| (i * 37) as u8));
        if let Some(c) = self.cut {
            out.truncate(c);
        }
        (out, header_end)
    }

    /// Bytes of data the shape declares for `size`-byte elements; `None` where no array can
    /// hold them: the non-zero axes' bytes exceed `isize::MAX` (ndarray's rule).
    fn declared(&self, size: u64) -> Option<u64> {
        let nonzero = self
            .shape
            .iter()
            .filter(|&&d| d != 0)
            .try_fold(size, |n, &d| n.checked_mul(d))
            .filter(|&n| n <= isize::MAX as u64 - 4096)?;
        Some(if self.shape.contains(&0) { 0 } else { nonzero })
    }
}

/// Everything a reader of `.npy` may do with a file; returns whether the header was accepted.
fn read_everything(path: &Path) -> bool {
    let header = npy::read_header(path);
    let _ = npy::read_real_map(path);
    let _ = npy::read_real_vector(path);
    let _ = npy::read_raw_header(path);
    if let Ok(stack) = npy::Stack::load(path) {
        // Only reached for complete data, so tiny: the whole stack is cheap to touch.
        let count: usize = header
            .as_ref()
            .expect("a loaded stack has a header")
            .count();
        assert_eq!(stack.to_complex128(false).len(), count);
        let _ = stack.analyse(false, 1);
    }
    header.is_ok()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1000, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn npy_arbitrary_bytes_are_refused(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        let p = scratch("arbitrary.npy");
        std::fs::write(&p, &bytes).unwrap();
        // Without the magic string nothing is a header.
        prop_assert!(!read_everything(&p) || bytes.starts_with(b"\x93NUMPY"));
    }

    #[test]
    fn npy_mutated_headers_give_err_never_panic(case in npy_case()) {
        let p = scratch("mutated.npy");
        let (bytes, header_end) = case.bytes();
        std::fs::write(&p, &bytes).unwrap();
        let accepted = read_everything(&p);
        let size = match case.descr.as_str() {
            "<c8" | "<f8" => Some(8),
            "<c16" => Some(16),
            "<f4" => Some(4),
            _ => None,
        };
        let well_formed = matches!(case.version, 1..=3)
            && matches!(case.fortran, "True" | "False")
            && case.cut.is_none_or(|c| c >= header_end);
        // Overflowing sizes, unknown dtypes and broken dicts are refused.
        if size.is_none() || !matches!(case.fortran, "True" | "False") {
            prop_assert!(!accepted);
        }
        if let Some(size) = size {
            if case.declared(size).is_none() {
                prop_assert!(!accepted, "overflowing shape {:?} accepted", case.shape);
            } else if well_formed {
                prop_assert!(accepted, "a valid header refused: {case:?}");
            }
            // A stack loads only when its data are all there.
            if let Ok(stack) = npy::Stack::load(&p) {
                let need = case.declared(size).unwrap() as usize;
                prop_assert_eq!(stack.bytes(), need);
                prop_assert!(bytes.len() >= need);
            }
        }
    }
}

// ---- (b) the spec loader ----

const SEED_SPECS: [&str; 3] = [
    include_str!("../experiments/table4_exponential.yaml"),
    include_str!("../experiments/synthesis_methods.yaml"),
    include_str!("../experiments/similarity_nonexponential.yaml"),
];

const TOKENS: [&str; 24] = [
    ".nan",
    ".inf",
    "-.inf",
    "1e400",
    "-1",
    "0",
    "18446744073709551616",
    "[",
    "]",
    "{",
    "}",
    ": ",
    "\n",
    "- ",
    "~",
    "*a",
    "&a ",
    "!!float ",
    "'",
    "\"",
    "#",
    "\u{feff}",
    "\t",
    "<<: ",
];

/// One edit of a spec's text: delete a range, insert a token, or duplicate a line.
#[derive(Debug, Clone)]
enum Edit {
    Delete(usize, usize),
    Insert(usize, usize),
    DuplicateLine(usize),
    ReplaceNumber(usize, usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<usize>(), 1usize..20).prop_map(|(a, n)| Edit::Delete(a, n)),
        (any::<usize>(), 0..TOKENS.len()).prop_map(|(a, t)| Edit::Insert(a, t)),
        any::<usize>().prop_map(Edit::DuplicateLine),
        (any::<usize>(), 0..TOKENS.len()).prop_map(|(a, t)| Edit::ReplaceNumber(a, t)),
    ]
}

/// The largest char boundary of `s` at or below `i % (len + 1)`.
fn boundary(s: &str, i: usize) -> usize {
    let mut i = i % (s.len() + 1);
    while !s.is_char_boundary(i) {
        i -= 1;
    }
    i
}

fn apply(text: &str, e: &Edit) -> String {
    let mut s = text.to_string();
    match *e {
        Edit::Delete(a, n) => {
            let a = boundary(&s, a);
            let b = boundary(&s, a + n);
            if b > a {
                s.replace_range(a..b, "");
            }
        }
        Edit::Insert(a, t) => s.insert_str(boundary(&s, a), TOKENS[t]),
        Edit::DuplicateLine(l) => {
            let lines: Vec<&str> = s.lines().collect();
            let k = l % lines.len().max(1);
            let mut out: Vec<&str> = lines.clone();
            if let Some(line) = lines.get(k) {
                out.insert(k, line);
            }
            s = out.join("\n");
        }
        Edit::ReplaceNumber(a, t) => {
            // The number at or after the position becomes a token.
            let a = boundary(&s, a);
            if let Some(start) = s[a..].find(|c: char| c.is_ascii_digit()).map(|i| a + i) {
                let end = s[start..]
                    .find(|c: char| !(c.is_ascii_digit() || c == '.'))
                    .map_or(s.len(), |i| start + i);
                s.replace_range(start..end, TOKENS[t]);
            }
        }
    }
    s
}

/// Loads `text` as a spec from a temporary file: `Ok` or `Err`, never a panic.
fn load_spec(text: &str, name: &str) -> Result<(), String> {
    let p = scratch(name).join("spec.yaml");
    std::fs::create_dir_all(p.parent().unwrap()).unwrap();
    std::fs::write(&p, text).unwrap();
    match isar_clutter::run::plan::load(&p) {
        Ok(_) => Ok(()),
        Err(e) => {
            let m = e.to_string();
            assert!(m.contains("spec.yaml"), "an error must name the file: {m}");
            Err(m)
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 600, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn spec_arbitrary_text_never_panics(text in "(\\PC|\n| ){0,200}") {
        let _ = load_spec(&text, "arbitrary");
    }

    #[test]
    fn spec_mutations_of_valid_specs_never_panic(
        which in 0..SEED_SPECS.len(),
        edits in proptest::collection::vec(edit(), 1..4),
    ) {
        let text = edits.iter().fold(SEED_SPECS[which].to_string(), |t, e| apply(&t, e));
        // Ok or Err (an error names the file, checked by `load_spec`); a panic fails.
        let _ = load_spec(&text, "mutated");
    }
}

#[test]
fn spec_seed_specs_are_valid() {
    for text in SEED_SPECS {
        load_spec(text, "seeds").unwrap();
    }
}

// ---- (c) the model loader ----

/// The element type a model file holds.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Elem {
    F64,
    C128,
    U8,
}

/// Files of each method's folder with their element type.
fn files(method: Method) -> Vec<(&'static str, Elem)> {
    let mut f = vec![("mean.npy", Elem::C128), ("std.npy", Elem::F64)];
    match method {
        Method::Method1 | Method::Method2 => {
            let (a, b) = if method == Method::Method1 {
                ("alpha_h.npy", "alpha_v.npy")
            } else {
                ("r_h.npy", "r_v.npy")
            };
            f.extend([
                (a, Elem::F64),
                (b, Elem::F64),
                ("residual_h.npy", Elem::F64),
                ("residual_v.npy", Elem::F64),
                ("clamped.npy", Elem::U8),
            ]);
        }
        Method::FullCovariance => f.push(("deviations.npy", Elem::C128)),
        Method::FourthOrder => f.extend([
            ("fleishman.npy", Elem::F64),
            ("component_sd.npy", Elem::F64),
            ("infeasible.npy", Elem::U8),
        ]),
        Method::Uncorrelated => {}
    }
    f
}

const METHODS: [Method; 5] = [
    Method::Method1,
    Method::Method2,
    Method::FullCovariance,
    Method::Uncorrelated,
    Method::FourthOrder,
];

/// One valid saved folder per method (8x8 images), made once.
fn models() -> &'static (tempfile::TempDir, Vec<PathBuf>) {
    static MODELS: std::sync::OnceLock<(tempfile::TempDir, Vec<PathBuf>)> =
        std::sync::OnceLock::new();
    MODELS.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let stack = common::random_stack(3, 6, 8, 8);
        let paths = METHODS
            .iter()
            .map(|&method| {
                let levels = if method == Method::Method2 { 2 } else { 1 };
                let a = isar_clutter::stats::analysis::analyse(stack.view(), levels).unwrap();
                let opts = FitOptions {
                    half_width: 3,
                    levels,
                    ..FitOptions::default()
                };
                let m = fit(method, &a, Some(stack.view()), opts).unwrap();
                let info = model::ModelInfo::new(&m, &a, 3, levels, "fuzz".into());
                let out = dir.path().join(method.as_str());
                model::save(&m, &info, &out).unwrap();
                out
            })
            .collect();
        (dir, paths)
    })
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
}

/// A replacement array: element type, shape (or the original's), values.
#[derive(Debug, Clone)]
struct Replacement {
    method: usize,
    file: usize,
    elem: Option<Elem>,
    shape: Option<Vec<usize>>,
    values: Vec<f64>,
}

fn value() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => 0.0f64..3.0,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(-1.0),
        1 => Just(1e308),
    ]
}

fn replacement() -> impl Strategy<Value = Replacement> {
    (
        0..METHODS.len(),
        0usize..16,
        proptest::option::weighted(
            0.2,
            prop_oneof![Just(Elem::F64), Just(Elem::C128), Just(Elem::U8)],
        ),
        proptest::option::weighted(0.6, proptest::collection::vec(0usize..10, 0..5)),
        proptest::collection::vec(value(), 1..8),
    )
        .prop_map(|(method, file, elem, shape, values)| Replacement {
            method,
            file,
            elem,
            shape,
            values,
        })
}

fn write_array(path: &Path, elem: Elem, shape: &[usize], values: &[f64]) {
    let at = |i: usize| values[i % values.len()];
    let f = std::fs::File::create(path).unwrap();
    let count: usize = shape.iter().product();
    match elem {
        Elem::F64 => ArrayD::from_shape_vec(IxDyn(shape), (0..count).map(at).collect())
            .unwrap()
            .write_npy(f),
        Elem::C128 => ArrayD::from_shape_vec(
            IxDyn(shape),
            (0..count)
                .map(|i| Complex64::new(at(i), at(i + 1)))
                .collect(),
        )
        .unwrap()
        .write_npy(f),
        Elem::U8 => ArrayD::from_shape_vec(
            IxDyn(shape),
            (0..count).map(|i| (at(i).abs().min(255.0)) as u8).collect(),
        )
        .unwrap()
        .write_npy(f),
    }
    .unwrap();
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn model_with_one_random_array_loads_only_if_consistent(r in replacement()) {
        let (_, paths) = models();
        let method = METHODS[r.method];
        let list = files(method);
        let (name, elem0) = list[r.file % list.len()];
        let folder = scratch("model");
        copy_dir(&paths[r.method], &folder);
        let original = npy::read_raw_header(&folder.join(name)).unwrap().shape;
        let shape = r.shape.clone().unwrap_or_else(|| original.clone());
        let elem = r.elem.unwrap_or(elem0);
        write_array(&folder.join(name), elem, &shape, &r.values);
        match model::load(&folder) {
            Ok((m, _)) => {
                prop_assert_eq!(&shape, &original, "{} of a wrong shape loaded", name);
                prop_assert_eq!(elem, elem0, "{} of a wrong type loaded", name);
                // A model that loads generates without panicking.
                let s = m.generate(1, 0, 1);
                prop_assert_eq!(s.dim(), (1, 8, 8));
            }
            Err(e) => {
                let e = format!("{e:#}");
                prop_assert!(e.contains(name) || e.contains("model.json"), "{}", e);
                // Consistent shapes, types and plain values (finite, >= 0, flags 0 or 1)
                // always load.
                let plain = r.values.iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v));
                prop_assert!(!(shape == original && elem == elem0 && plain), "refused: {}", e);
            }
        }
    }
}
