//! `isar_clutter._native`: the Python extension over the core crate. `analyse` gives a
//! stack's multiscale maps as numpy arrays (the names and numbers of a run's `maps/`), `fit`
//! a [`Model`], which saves and loads the command line's model folders and generates samples
//! straight into a numpy array with the GIL released (sample `i` of a seed is the one
//! `isar-clutter generate --seed` writes); `load_uavsar`, `load_geotiff` and `load_sicd` read radar
//! scenes (`load.rs`). The Python package `isar_clutter` wraps it.

/// Large blocks (the generated samples, stacks read) come straight from the kernel with
/// transparent huge pages requested, as in the command line
/// ([`isar_clutter_core::alloc::LargeMapAlloc`]): with the system allocator, the pages of a
/// fresh numpy array of samples were faulted in 4 KiB at a time, and `Model.generate` ran at
/// 0.78 of the command line's rate (BENCHMARKS.md). The extension's own allocations only:
/// arrays numpy allocates itself are Python's.
#[global_allocator]
static GLOBAL: isar_clutter_core::alloc::LargeMapAlloc = isar_clutter_core::alloc::LargeMapAlloc;

use isar_clutter_core::io::model::ModelInfo;
use isar_clutter_core::stats::analysis::{Analysis, Direction};
use isar_clutter_core::synthesis::{FitOptions, Model as CoreModel};
use isar_clutter_core::workflow;
use numpy::{IntoPyArray, PyArray3};
use pyo3::exceptions::{PyMemoryError, PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

mod input;
mod load;

/// An error of the core as a Python exception: its message with its causes.
fn os_error(e: &anyhow::Error) -> PyErr {
    PyOSError::new_err(format!("{e:#}"))
}

/// The maps of an analysis as a dict of numpy arrays, named as a run's `maps/<job>/` files
/// (without `.npy`): `mean` (complex128 `[H, W]`), `variance`, and
/// `level{L}_correlation_{D}` / `level{L}_covariance_{D}` for every level and direction.
fn maps<'py>(py: Python<'py>, a: Analysis) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("samples", a.samples)?;
    d.set_item("mean", a.mean.into_pyarray(py))?;
    d.set_item("variance", a.variance.into_pyarray(py))?;
    for lm in a.levels {
        for dir in Direction::ALL {
            let i = dir as usize;
            d.set_item(
                format!("level{}_correlation_{dir}", lm.level),
                lm.correlation[i].clone().into_pyarray(py),
            )?;
            d.set_item(
                format!("level{}_covariance_{dir}", lm.level),
                lm.covariance[i].clone().into_pyarray(py),
            )?;
        }
    }
    Ok(d)
}

/// analyse(stack, levels=3, layout="nhw")
/// --
///
/// The multiscale analysis of `stack` (`[N, H, W]`, complex or real): a dict of numpy arrays
/// named as a run's `maps/` files: `mean`, `variance`, `level{L}_correlation_{H,V,D}`,
/// `level{L}_covariance_{H,V,D}`, and `samples`.
#[pyfunction]
#[pyo3(signature = (stack, levels = 3, layout = "nhw"))]
fn analyse<'py>(
    py: Python<'py>,
    stack: &Bound<'py, PyAny>,
    levels: usize,
    layout: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let hwn = input::is_hwn(layout)?;
    let s = input::stack(stack, "stack")?;
    let a = s.analyse(py, hwn, levels, "stack")?;
    maps(py, a)
}

/// A synthesis model: fitted with `fit`, or loaded from a model folder.
#[pyclass(module = "isar_clutter._native", frozen)]
struct Model {
    model: CoreModel,
    info: ModelInfo,
}

/// fit(stack, method="method2", half_width=8, levels=3, negative_signs="multiscale",
/// layout="nhw", source="numpy array")
/// --
///
/// Fits a synthesis model to `stack` as `isar-clutter fit` does.
#[pyfunction]
#[pyo3(signature = (stack, method = "method2", half_width = 8, levels = 3,
                    negative_signs = "multiscale", layout = "nhw", source = "numpy array"))]
#[allow(clippy::too_many_arguments)]
fn fit(
    py: Python<'_>,
    stack: &Bound<'_, PyAny>,
    method: &str,
    half_width: usize,
    levels: usize,
    negative_signs: &str,
    layout: &str,
    source: &str,
) -> PyResult<Model> {
    let method = workflow::method_named(method)
        .map_err(|e| PyValueError::new_err(format!("method: {e}")))?;
    let negative_signs = workflow::negative_signs_named(negative_signs)
        .map_err(|e| PyValueError::new_err(format!("negative_signs: {e}")))?;
    if half_width == 0 {
        return Err(PyValueError::new_err("half_width must be at least 1"));
    }
    let hwn = input::is_hwn(layout)?;
    let s = input::stack(stack, "stack")?;
    let depth = method.needs().depth(levels);
    let analysis = s.analyse(py, hwn, depth, "stack")?;
    let full = if method.needs().stack {
        Some(s.to_complex128(hwn, "stack")?)
    } else {
        None
    };
    let options = FitOptions {
        half_width,
        levels,
        negative_signs,
    };
    let source = source.to_string();
    let (model, info) = py
        .detach(|| workflow::fit_analysed(method, &analysis, full.as_ref(), options, source))
        .map_err(|e| fit_error(&e))?;
    Ok(Model { model, info })
}

/// A failed fit as Python sees it: `MemoryError` when the model would not fit in memory
/// (refused before allocating, or an allocation that failed), `ValueError` otherwise.
fn fit_error(e: &anyhow::Error) -> PyErr {
    use isar_clutter_core::synthesis::FitError;
    match e.downcast_ref::<FitError>() {
        Some(FitError::Memory { .. } | FitError::Alloc(_)) => {
            PyMemoryError::new_err(format!("{e:#}"))
        }
        _ => PyValueError::new_err(format!("{e:#}")),
    }
}

#[pymethods]
impl Model {
    /// Model.load(path): the model folder `path` (written by `fit` here or by the command line).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Model> {
        let (model, info) = py
            .detach(|| isar_clutter_core::io::model::load(&path))
            .map_err(|e| os_error(&e))?;
        Ok(Model { model, info })
    }

    /// Model.save(path): writes the model folder `path` as `isar-clutter fit --out` does
    /// (refused over anything but an empty folder or an earlier model folder).
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        py.detach(|| workflow::save_model_folder(&self.model, &self.info, &path))
            .map_err(|e| os_error(&e))?;
        Ok(())
    }

    /// The method's name.
    #[getter]
    fn method(&self) -> &'static str {
        self.model.method().as_str()
    }

    /// The image shape `(height, width)`.
    #[getter]
    fn shape(&self) -> (usize, usize) {
        self.model.shape()
    }

    /// The sample format of generated samples (1 or 2).
    #[getter]
    fn sample_format(&self) -> u32 {
        self.model.moments().sample_format
    }

    /// The model folder's record (`model.json`) as a JSON string.
    #[getter]
    fn info_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.info).map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// generate(n, seed, start=0, threads=None) -> complex64 [n, H, W]: samples
    /// `start .. start + n` of the generation seeded by `seed`, byte for byte those of
    /// `isar-clutter generate --seed SEED`; the GIL is released while they are computed on
    /// `threads` threads (default: all cores; more than 4 a core are capped with a `ResourceWarning`).
    #[pyo3(signature = (n, seed, start = 0, threads = None))]
    fn generate<'py>(
        &self,
        py: Python<'py>,
        n: i64,
        seed: u64,
        start: i64,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyArray3<num_complex::Complex32>>> {
        let n = usize::try_from(n)
            .map_err(|_| PyValueError::new_err(format!("n must be 0 or more, not {n}")))?;
        let start = usize::try_from(start)
            .map_err(|_| PyValueError::new_err(format!("start must be 0 or more, not {start}")))?;
        if start.checked_add(n).is_none() {
            return Err(PyValueError::new_err("start + n overflows"));
        }
        if threads == Some(0) {
            return Err(PyValueError::new_err("threads must be at least 1"));
        }
        let threads = match threads.map(|t| isar_clutter_core::resources::cap_threads(t, "threads"))
        {
            Some((t, Some(note))) => {
                let note = std::ffi::CString::new(note).expect("no NUL in the note");
                let kind = py.get_type::<pyo3::exceptions::PyResourceWarning>();
                PyErr::warn(py, &kind, &note, 1)?;
                Some(t)
            }
            capped => capped.map(|(t, _)| t),
        };
        let (h, w) = self.model.shape();
        let mut out = isar_clutter_core::alloc::try_zeros((n, h, w), "the generated samples")
            .map_err(|e| PyMemoryError::new_err(format!("n = {n}: {e}")))?;
        let model = &self.model;
        let slice = out.as_slice_mut().expect("standard layout");
        py.detach(|| -> PyResult<()> {
            match threads {
                None => model.generate_c64_into(seed, start, slice),
                Some(t) => rayon::ThreadPoolBuilder::new()
                    .num_threads(t)
                    .build()
                    .map_err(|e| PyOSError::new_err(format!("threads = {t}: {e}")))?
                    .install(|| model.generate_c64_into(seed, start, slice)),
            }
            Ok(())
        })?;
        Ok(out.into_pyarray(py))
    }

    /// Pickling (a DataLoader's workers under the `spawn` start method, `torch.multiprocessing`):
    /// the model's folder files, written by `save` into a temporary folder and read back.
    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, (Files,))> {
        let this = slf.get();
        let files = py
            .detach(|| -> anyhow::Result<Files> {
                let dir = scratch("pickle")?;
                let saved = isar_clutter_core::io::model::save(&this.model, &this.info, &dir)
                    .and_then(|()| {
                        let mut files = Vec::new();
                        for e in std::fs::read_dir(&dir)? {
                            let e = e?;
                            let name = e.file_name().to_string_lossy().into_owned();
                            files.push((name, std::fs::read(e.path())?));
                        }
                        files.sort();
                        Ok(files)
                    });
                let _ = std::fs::remove_dir_all(&dir);
                saved
            })
            .map_err(|e| os_error(&e))?;
        Ok((slf.get_type().getattr("_from_files")?, (files,)))
    }

    /// The model of a pickled model's folder files (see `__reduce__`).
    #[staticmethod]
    fn _from_files(py: Python<'_>, files: Files) -> PyResult<Model> {
        let (model, info) = py
            .detach(|| -> anyhow::Result<(CoreModel, ModelInfo)> {
                let dir = scratch("unpickle")?;
                let loaded = (|| {
                    for (name, bytes) in &files {
                        if !isar_clutter_core::io::model::is_model_file(name) {
                            anyhow::bail!("{name:?} is not a file of a model folder");
                        }
                        std::fs::write(dir.join(name), bytes)?;
                    }
                    isar_clutter_core::io::model::load(&dir)
                })();
                let _ = std::fs::remove_dir_all(&dir);
                loaded
            })
            .map_err(|e| os_error(&e))?;
        Ok(Model { model, info })
    }

    fn __repr__(&self) -> String {
        let (h, w) = self.model.shape();
        format!(
            "Model(method={:?}, shape=({h}, {w}), sample_format={})",
            self.model.method().as_str(),
            self.model.moments().sample_format
        )
    }
}

/// A model folder's files: name and bytes.
type Files = Vec<(String, Vec<u8>)>;

/// A new empty folder of this process under the system's temporary folder.
fn scratch(what: &str) -> anyhow::Result<PathBuf> {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    let dir = std::env::temp_dir().join(format!(
        "isar-clutter-{what}-{}-{}",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}

/// epoch_seed(seed, epoch): the seed of epoch `epoch` of a stream seeded by `seed` (`seed`
/// itself for epoch 0; otherwise derived from both as every seed of the tool is).
#[pyfunction]
fn epoch_seed(seed: u64, epoch: u64) -> u64 {
    if epoch == 0 {
        seed
    } else {
        isar_clutter_core::seeds::derive_seed(seed, "epoch", &epoch.to_string())
    }
}

/// The module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(analyse, m)?)?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add_function(wrap_pyfunction!(epoch_seed, m)?)?;
    m.add_function(wrap_pyfunction!(load::load_uavsar, m)?)?;
    m.add_function(wrap_pyfunction!(load::load_geotiff, m)?)?;
    m.add_function(wrap_pyfunction!(load::load_sicd, m)?)?;
    m.add_class::<Model>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
