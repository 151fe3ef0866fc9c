//! UAVSAR single-look complex scenes as NASA JPL's UAVSAR project distributes them: the pixels
//! in a `.slc` file (little-endian complex64, real then imaginary, row after row: the rows
//! along track, the columns across) and their sizes in the flight line's annotation file
//! (`.ann`: `key (unit) = value ; comment` lines, `;` starting a comment line). A window of a
//! scene is read a row at a time, so a stack of windows from scenes of any size holds only the
//! windows in memory. A scene's geographic places come from the flight line's `.llh` file
//! (little-endian float32 latitude, longitude, height for every block of range x azimuth looks,
//! `llh_<k>_<R>x<A>`: e.g. every 8 rows and 2 columns for `2x8`), which a map box reads
//! ([`llh_grid`]).

use super::cut::Window;
use num_complex::Complex32;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// Why a UAVSAR file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum UavsarError {
    /// The file cannot be opened or read.
    #[error("cannot read {path}: {cause}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause (in the message, so that a chain printed with `{:#}` says it once).
        cause: std::io::Error,
    },
    /// An annotation field is missing or not a size.
    #[error("{path}: field `{field}` {reason}")]
    Field {
        /// The annotation file.
        path: PathBuf,
        /// The field's key.
        field: String,
        /// What is wrong.
        reason: String,
    },
    /// The `.slc` file's length is not the annotation's rows x columns complex64 values.
    #[error(
        "{path} holds {bytes} bytes; its annotation {annotation} gives {rows} rows x {cols} \
         columns of complex64 values, {want} bytes (a truncated download, or another segment's \
         or product's annotation)"
    )]
    Size {
        /// The `.slc` file.
        path: PathBuf,
        /// Its length.
        bytes: u64,
        /// The annotation file.
        annotation: PathBuf,
        /// Rows the annotation gives.
        rows: usize,
        /// Columns the annotation gives.
        cols: usize,
        /// The length they need.
        want: u64,
    },
}

/// An annotation file's fields, in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct Annotation {
    /// The file.
    pub path: PathBuf,
    /// `(key, value)`: the key without its `(unit)`, the value without its `; comment`.
    pub fields: Vec<(String, String)>,
}

impl Annotation {
    /// Reads and parses the annotation file at `path`.
    ///
    /// # Errors
    /// [`UavsarError::Io`] if it cannot be read (or is not text).
    pub fn read(path: &Path) -> Result<Annotation, UavsarError> {
        let io = |cause| UavsarError::Io {
            path: path.to_path_buf(),
            cause,
        };
        let bytes = std::fs::read(path).map_err(io)?;
        let text = String::from_utf8_lossy(&bytes);
        Ok(Annotation::parse(path, super::strip_bom(&text)))
    }

    /// The fields of annotation `text` (read from `path`): each line `key (unit) = value ;
    /// comment`, blank lines and lines starting with `;` skipped.
    pub fn parse(path: &Path, text: &str) -> Annotation {
        let fields = text
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty() && !l.starts_with(';'))
            .filter_map(|l| {
                let (key, value) = l.split_once('=')?;
                let key = key.split_once('(').map_or(key, |(k, _)| k).trim();
                let value = value.split_once(';').map_or(value, |(v, _)| v).trim();
                Some((key.to_string(), value.to_string()))
            })
            .collect();
        Annotation {
            path: path.to_path_buf(),
            fields,
        }
    }

    /// The value of `key` (compared without case), the first where it repeats.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.fields
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(key))
            .map(|(_, v)| v.as_str())
    }

    /// A size field: a positive whole number (written as an integer or a float).
    fn size(&self, key: &str) -> Result<usize, UavsarError> {
        let field = |reason: String| UavsarError::Field {
            path: self.path.clone(),
            field: key.to_string(),
            reason,
        };
        let text = self
            .get(key)
            .ok_or_else(|| field("is missing (is this the scene's annotation?)".into()))?;
        let x: f64 = text
            .parse()
            .map_err(|_| field(format!("is {text:?}, not a number")))?;
        if !(x >= 1.0 && x.fract() == 0.0 && x <= 1e9) {
            return Err(field(format!("is {text}, not a size in 1..=1e9")));
        }
        Ok(x as usize)
    }

    /// `(rows, columns)` of segment `segment`'s full-resolution SLC (`slc_<segment>_1x1 Rows`
    /// and `... Columns`).
    ///
    /// # Errors
    /// [`UavsarError::Field`] naming the missing or bad field.
    pub fn slc_dims(&self, segment: usize) -> Result<(usize, usize), UavsarError> {
        Ok((
            self.size(&format!("slc_{segment}_1x1 Rows"))?,
            self.size(&format!("slc_{segment}_1x1 Columns"))?,
        ))
    }
}

/// The latitude/longitude grid of segment `segment`'s SLC `slc` (of `dims` pixels) from its
/// annotation `ann`: the `.llh` product `llh_<k>_<R>x<A>` (`R` range looks along the columns,
/// `A` azimuth looks along the rows), its size from `llh_<k>_<R>x<A>.set_rows` / `.set_cols`
/// (or `... Rows` / `... Columns`), its file named by the field `llh_<k>_<R>x<A>` beside the
/// annotation, else `<name>_s<k>_<R>x<A>.llh` beside the SLC, else the one file beside it
/// ending in `_s<k>_<R>x<A>.llh` ([`llh_product`]).
///
/// # Errors
/// Naming the annotation's field or the file: no `.llh` product in the annotation, a size that
/// does not cover the SLC in blocks of its looks, a file of another length.
pub fn llh_grid(
    ann: &Annotation,
    slc: &Path,
    segment: usize,
    dims: (usize, usize),
) -> Result<super::mapping::PointGrid, String> {
    let (key, looks, file) = llh_product(ann, slc, segment)?;
    let size = |dot: &str, word: &str| {
        ann.size(&format!("{key}.{dot}"))
            .or_else(|_| ann.size(&format!("{key} {word}")))
            .map_err(|_| {
                format!(
                    "{}: field `{key}.{dot}` (or `{key} {word}`) is missing or not a size",
                    ann.path.display()
                )
            })
    };
    let (rows, cols) = (size("set_rows", "Rows")?, size("set_cols", "Columns")?);
    for (n, look, full, what) in [
        (rows, looks[0], dims.0, "rows"),
        (cols, looks[1], dims.1, "columns"),
    ] {
        if look == 0 || !(n == full / look || n == full.div_ceil(look)) {
            return Err(format!(
                "{}: `{key}` has {n} {what}, which do not cover the SLC's {full} in blocks of \
                 {look} (another segment's or product's annotation?)",
                ann.path.display()
            ));
        }
    }
    let bytes = std::fs::read(&file).map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    if bytes.len() != rows * cols * 12 {
        return Err(format!(
            "{} holds {} bytes; `{key}` gives {rows} x {cols} points of three float32 values, \
             {} bytes",
            file.display(),
            bytes.len(),
            rows * cols * 12
        ));
    }
    let value = |k: usize| f32::from_le_bytes([bytes[k], bytes[k + 1], bytes[k + 2], bytes[k + 3]]);
    let (y, x) = (0..rows * cols)
        .map(|p| (value(12 * p), value(12 * p + 4)))
        .unzip();
    Ok(super::mapping::PointGrid {
        rows,
        cols,
        block: looks,
        dims,
        x,
        y,
    })
}

/// The `.llh` product of segment `segment` in annotation `ann`: its key `llh_<k>_<R>x<A>`, the
/// pixels a point stands for `[A, R]` (rows, columns), and its file (the field's value beside
/// the annotation, else `<name>_s<k>_<R>x<A>.llh` beside `slc`, else the one file beside it
/// ending in `_s<k>_<R>x<A>.llh`: UAVSAR names a stack's without the acquisition's fields).
///
/// # Errors
/// If the annotation names no such product.
fn llh_product(
    ann: &Annotation,
    slc: &Path,
    segment: usize,
) -> Result<(String, [usize; 2], PathBuf), String> {
    let prefix = format!("llh_{segment}_");
    let tag = ann
        .fields
        .iter()
        .filter_map(|(k, _)| {
            k.to_ascii_lowercase()
                .strip_prefix(&prefix)
                .map(str::to_string)
        })
        .map(|rest| {
            rest.split(['.', ' '])
                .next()
                .unwrap_or_default()
                .to_string()
        })
        .find(|t| {
            t.split_once('x')
                .is_some_and(|(a, b)| a.parse::<usize>().is_ok() && b.parse::<usize>().is_ok())
        })
        .ok_or_else(|| {
            format!(
                "{}: no `llh_{segment}_<R>x<A>` field: UAVSAR's latitude/longitude product is \
                 not annotated, so the scene has no geographic places",
                ann.path.display()
            )
        })?;
    let (r, a) = tag.split_once('x').unwrap_or_default();
    let looks: [usize; 2] = [a.parse().unwrap_or(0), r.parse().unwrap_or(0)];
    let key = format!("llh_{segment}_{tag}");
    let named = ann
        .get(&key)
        .filter(|v| v.to_ascii_lowercase().ends_with(".llh"))
        .map(|v| ann.path.with_file_name(v));
    let file = named.unwrap_or_else(|| match slc_base(slc) {
        Some((name, _)) => slc.with_file_name(format!("{name}_s{segment}_{tag}.llh")),
        None => slc.with_extension("llh"),
    });
    if file.is_file() {
        return Ok((key, looks, file));
    }
    // UAVSAR names a stack's `.llh` without the acquisition's fields
    // (`{site}_{line}_{stack}_{BC}_s<k>_<R>x<A>.llh`): the one file of that ending beside the SLC.
    let ending = format!("_s{segment}_{tag}.llh");
    let dir = slc
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let mut found: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|d| {
            d.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| {
                    p.file_name()
                        .and_then(|n| n.to_str())
                        .is_some_and(|n| n.to_ascii_lowercase().ends_with(&ending))
                })
                .collect()
        })
        .unwrap_or_default();
    found.sort();
    match found.len() {
        1 => Ok((key, looks, found.remove(0))),
        0 => Err(format!(
            "no `.llh` file for {}: tried {} and files ending in {ending} beside it",
            slc.display(),
            file.display()
        )),
        _ => Err(format!(
            "{} files end in {ending} beside {} ({}): name the one in the annotation's `{key}`",
            found.len(),
            slc.display(),
            found
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )),
    }
}

/// The `.llh` file a map box on `scene` reads ([`llh_grid`]).
///
/// # Errors
/// If its annotation cannot be read or names no `.llh` product.
pub fn llh_file(scene: &UavsarScene) -> Result<PathBuf, String> {
    let ann = Annotation::read(&scene.annotation).map_err(|e| e.to_string())?;
    Ok(llh_product(&ann, &scene.slc, segment_of(&scene.slc))?.2)
}

/// The segment of an SLC file named `..._s<k>_1x1.slc` (UAVSAR's naming), else 1.
pub fn segment_of(slc: &Path) -> usize {
    slc_base(slc).map_or(1, |(_, k)| k)
}

/// `(name before _s<k>, k)` of a file named `<name>_s<k>_1x1.slc`.
fn slc_base(slc: &Path) -> Option<(String, usize)> {
    let stem = slc.file_stem()?.to_str()?;
    let rest = stem.strip_suffix("_1x1")?;
    let (name, seg) = rest.rsplit_once("_s")?;
    Some((name.to_string(), seg.parse().ok()?))
}

/// Where the annotation of `slc` is looked for, in order: UAVSAR's naming (`<name>.ann` beside
/// `<name>_s<k>_1x1.slc`), then the file's own stem (`<stem>.ann`).
pub fn annotation_candidates(slc: &Path) -> Vec<PathBuf> {
    let mut out = vec![];
    if let Some((name, _)) = slc_base(slc) {
        out.push(slc.with_file_name(format!("{name}.ann")));
    }
    out.push(slc.with_extension("ann"));
    out
}

/// Checks that `slc` holds `dims` complex64 values, as its `annotation` says.
///
/// # Errors
/// [`UavsarError::Io`] if it cannot be read, [`UavsarError::Size`] if its length differs.
pub fn check_length(
    slc: &Path,
    annotation: &Path,
    (rows, cols): (usize, usize),
) -> Result<(), UavsarError> {
    let bytes = std::fs::metadata(slc)
        .map_err(|cause| UavsarError::Io {
            path: slc.to_path_buf(),
            cause,
        })?
        .len();
    let want = (rows as u64).saturating_mul(cols as u64).saturating_mul(8);
    if bytes != want {
        return Err(UavsarError::Size {
            path: slc.to_path_buf(),
            bytes,
            annotation: annotation.to_path_buf(),
            rows,
            cols,
            want,
        });
    }
    Ok(())
}

/// Reads `window` of the scene in `slc` (`cols` columns a row) into `out` (the window's rows x
/// columns values, row-major, as stored: complex64), a row at a time.
///
/// # Errors
/// [`UavsarError::Io`] if the file cannot be read (or ends early).
pub fn read_window(
    slc: &Path,
    cols: usize,
    window: &Window,
    out: &mut [Complex32],
) -> Result<(), UavsarError> {
    assert_eq!(
        out.len(),
        window.rows() * window.cols(),
        "the window's values"
    );
    let io = |cause| UavsarError::Io {
        path: slc.to_path_buf(),
        cause,
    };
    let mut file = std::fs::File::open(slc).map_err(io)?;
    let mut row = vec![0u8; 8 * window.cols()];
    for (r, line) in out.chunks_exact_mut(window.cols().max(1)).enumerate() {
        let at = ((window.r0 + r) as u64 * cols as u64 + window.c0 as u64) * 8;
        file.seek(SeekFrom::Start(at)).map_err(io)?;
        file.read_exact(&mut row).map_err(io)?;
        for (z, b) in line.iter_mut().zip(row.chunks_exact(8)) {
            let re = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            let im = f32::from_le_bytes([b[4], b[5], b[6], b[7]]);
            *z = Complex32::new(re, im);
        }
    }
    Ok(())
}

/// One UAVSAR scene: its `.slc`, the annotation that gave its size, and the size.
#[derive(Debug, Clone, PartialEq)]
pub struct UavsarScene {
    /// The `.slc` file.
    pub slc: PathBuf,
    /// Its annotation file.
    pub annotation: PathBuf,
    /// `(rows, columns)`.
    pub dims: (usize, usize),
}

impl super::scenes::Scene for UavsarScene {
    type Error = UavsarError;

    fn path(&self) -> &Path {
        &self.slc
    }

    fn dims(&self) -> (usize, usize) {
        self.dims
    }

    fn read_window(&self, window: &Window, out: &mut [Complex32]) -> Result<(), UavsarError> {
        read_window(&self.slc, self.dims.1, window, out)
    }

    /// The flight line's latitude/longitude grid ([`llh_grid`]), longitude as map `x`.
    fn georeference(&self) -> Result<super::mapping::Georeference, String> {
        let ann = Annotation::read(&self.annotation).map_err(|e| e.to_string())?;
        let grid = llh_grid(&ann, &self.slc, segment_of(&self.slc), self.dims)?;
        Ok(super::mapping::Georeference::Grid(Box::new(grid)))
    }

    fn describe(&self) -> serde_json::Value {
        serde_json::json!({
            "path": self.slc.display().to_string(),
            "format": "UAVSAR SLC",
            "annotation": self.annotation.display().to_string(),
            "rows": self.dims.0,
            "cols": self.dims.1,
        })
    }
}

/// A scene with its own annotation (UAVSAR's naming, [`annotation_candidates`]), as
/// `isar-clutter cut --input X.slc` opens it.
impl super::scenes::OpenScene for UavsarScene {
    fn open(slc: &Path) -> Result<UavsarScene, UavsarError> {
        let (annotation, dims) = scene_size(slc, 0, &[]).map_err(|e| UavsarError::Field {
            path: slc.to_path_buf(),
            field: e.field.to_string(),
            reason: e.message,
        })?;
        Ok(UavsarScene {
            slc: slc.to_path_buf(),
            annotation,
            dims,
        })
    }
}

/// A stack of coregistered scenes checked against their annotations: the same window of each
/// is one sample (or, cut, each patch of each).
pub type SceneStack = super::scenes::Scenes<UavsarScene>;

pub use super::scenes::StackError;

/// Opens `slcs` with their `annotations` (none: each scene's own, by UAVSAR's naming,
/// [`annotation_candidates`]; one: for every scene; else one per scene): reads each
/// annotation, checks each file's length against it and `window` (default: the whole scene,
/// every scene then of one size) against every scene.
///
/// # Errors
/// A [`StackError`] naming the field (`slc`, `annotation`, `window`), the scene and the file.
pub fn open_stack(
    slcs: &[PathBuf],
    annotations: &[PathBuf],
    window: Option<super::scenes::Place>,
) -> Result<SceneStack, StackError> {
    let err = |field, index, message: String| StackError {
        field,
        index,
        message,
    };
    if slcs.is_empty() {
        return Err(err("slc", None, "name at least one .slc file".into()));
    }
    if annotations.len() > 1 && annotations.len() != slcs.len() {
        return Err(err(
            "annotation",
            None,
            format!(
                "lists {} annotation file(s) for {} scene(s): give one for all, or one per scene",
                annotations.len(),
                slcs.len()
            ),
        ));
    }
    let mut scenes = vec![];
    for (i, slc) in slcs.iter().enumerate() {
        let (annotation, dims) = scene_size(slc, i, annotations)?;
        scenes.push(UavsarScene {
            slc: slc.clone(),
            annotation,
            dims,
        });
    }
    // The scenes' field is `slc` here.
    super::scenes::Scenes::new(scenes, window).map_err(|e| StackError {
        field: if e.field == "path" { "slc" } else { e.field },
        ..e
    })
}

/// The annotation of scene `i` (`slc`; see [`open_stack`] for `annotations`), and the
/// scene's `(rows, columns)` from it, its file's length checked.
fn scene_size(
    slc: &Path,
    i: usize,
    annotations: &[PathBuf],
) -> Result<(PathBuf, (usize, usize)), StackError> {
    let err = |field, index, message: String| StackError {
        field,
        index,
        message,
    };
    let (path, field, index) = match annotations.len() {
        0 => {
            let tried = annotation_candidates(slc);
            let found = tried.iter().find(|p| p.is_file()).cloned();
            let found = found.ok_or_else(|| {
                let tried: Vec<String> = tried.iter().map(|p| p.display().to_string()).collect();
                err(
                    "slc",
                    Some(i),
                    format!(
                        "no annotation file found for {} (tried {}); give `annotation`",
                        slc.display(),
                        tried.join(", ")
                    ),
                )
            })?;
            (found, "slc", Some(i))
        }
        1 => (annotations[0].clone(), "annotation", None),
        _ => (annotations[i].clone(), "annotation", Some(i)),
    };
    let d = Annotation::read(&path)
        .and_then(|a| a.slc_dims(segment_of(slc)))
        .map_err(|e| err(field, index, e.to_string()))?;
    check_length(slc, &path, d).map_err(|e| err("slc", Some(i), e.to_string()))?;
    Ok((path, d))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn annotation_lines_give_keys_without_units_and_values_without_comments() {
        let a = Annotation::parse(
            Path::new("x.ann"),
            "; a comment = not a field\n\
             slc_1_1x1 Rows                (pixels)   = 8460   ; samples along track\n\
             slc_1_1x1 Columns             (pixels)   = 3300.0\n\
             Center Wavelength             (cm)       = 23.8403545\n\
             Site Description              (&)        = Brazos River, TX\n",
        );
        assert_eq!(a.slc_dims(1).unwrap(), (8460, 3300));
        assert_eq!(a.get("center wavelength"), Some("23.8403545"));
        assert_eq!(a.get("Site Description"), Some("Brazos River, TX"));
        assert_eq!(a.get("a comment"), None);
        let e = a.slc_dims(2).unwrap_err().to_string();
        assert!(e.contains("x.ann") && e.contains("slc_2_1x1 Rows"), "{e}");
        let bad = Annotation::parse(Path::new("y.ann"), "slc_1_1x1 Rows = 12.5\n");
        let e = bad.slc_dims(1).unwrap_err().to_string();
        assert!(e.contains("slc_1_1x1 Rows") && e.contains("12.5"), "{e}");
    }

    #[test]
    fn segments_and_annotations_follow_uavsar_names() {
        let slc = Path::new("/d/SanAnd_08525_14084_011_140515_L090HH_03_BC_s2_1x1.slc");
        assert_eq!(segment_of(slc), 2);
        assert_eq!(
            annotation_candidates(slc)[0],
            Path::new("/d/SanAnd_08525_14084_011_140515_L090HH_03_BC.ann")
        );
        assert_eq!(segment_of(Path::new("scene.slc")), 1);
        assert_eq!(
            annotation_candidates(Path::new("scene.slc")),
            [PathBuf::from("scene.ann")]
        );
    }

    #[test]
    fn a_window_is_read_as_the_slow_oracle_indexes_it() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let (rows, cols) = (7, 9);
        let values: Vec<(f32, f32)> = (0..rows * cols)
            .map(|_| (rng.random(), rng.random()))
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let slc = dir.path().join("s.slc");
        let bytes: Vec<u8> = values
            .iter()
            .flat_map(|(re, im)| [re.to_le_bytes(), im.to_le_bytes()].concat())
            .collect();
        std::fs::write(&slc, bytes).unwrap();
        check_length(&slc, Path::new("s.ann"), (rows, cols)).unwrap();
        let e = check_length(&slc, Path::new("s.ann"), (rows, cols + 1)).unwrap_err();
        assert!(e.to_string().contains("s.ann"), "{e}");
        let w = Window::at(2, 3, 4, 5);
        assert!(w.inside(rows, cols) && !w.inside(5, cols));
        let mut out = vec![Complex32::default(); 20];
        read_window(&slc, cols, &w, &mut out).unwrap();
        for r in 0..4 {
            for c in 0..5 {
                let (re, im) = values[(2 + r) * cols + 3 + c];
                assert_eq!(out[r * 5 + c], Complex32::new(re, im));
            }
        }
    }
}
