//! `fit` and `generate` from files to files, as the command line and the Python bindings run
//! them: the input stack read from a `.npy` or a `.mat` variable; a fitted model saved as a
//! model folder (refused over anything that is not an earlier model of the tool's, swapped in
//! whole); samples streamed from a model folder into a `.npy` or a `.mat`. Each output is
//! locked while it is written and checked to be the tool's before it is replaced; what killed
//! writers left beside it is removed and named in the result. Progress goes to a callback; the
//! thread pool is the caller's (rayon's current one).

use crate::io::mat::{is_mat_path, MatClass, MatFile, MatOutput, MatVersion};
use crate::io::model::{GenerationRecord, ModelInfo};
use crate::io::npy::Stack;
use crate::synthesis::{fit, FitOptions, Method, Model, NegativeSigns};
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

/// The stack `fit` reads: a `.npy`, or a `.mat` variable; `layout` as given (`nhw` or `hwn`;
/// default: `hwn` for a `.mat`, `nhw` for a `.npy`).
pub struct Input<'a> {
    /// The file.
    pub path: &'a Path,
    /// The variable of a `.mat` (default: its only stack).
    pub var: Option<&'a str>,
    /// The order of the axes.
    pub layout: Option<&'a str>,
}

/// A stack read by [`Input::load`].
pub struct Loaded {
    /// The stack in its stored element type.
    pub stack: Stack,
    /// Whether its axes are `[H, W, N]` (else `[N, H, W]`).
    pub hwn: bool,
    /// Its name for the model's `source`: the path, and the variable of a `.mat`.
    pub source: String,
}

impl Input<'_> {
    /// The stack, whether its axes are `[H, W, N]`, and its name for the model's `source`.
    ///
    /// # Errors
    /// Naming the file: unreadable, not a stack, an unknown layout, or `var` for a `.npy`.
    pub fn load(&self) -> Result<Loaded> {
        let mat = is_mat_path(self.path);
        let hwn = match self.layout {
            None => mat,
            Some("nhw") => false,
            Some("hwn") => true,
            Some(other) => bail!("unknown layout {other:?}: nhw or hwn"),
        };
        if !mat {
            if self.var.is_some() {
                bail!(
                    "--var names a variable of a .mat input; {} is read as .npy",
                    self.path.display()
                );
            }
            let stack = Stack::load(self.path)?;
            let source = self.path.display().to_string();
            return Ok(Loaded { stack, hwn, source });
        }
        let file = MatFile::open(self.path)?;
        let name = file.stack_variable(self.var)?.name.clone();
        let stack = Stack::Generated(file.read_stack(Some(&name))?);
        let source = format!("{} (variable {name})", self.path.display());
        Ok(Loaded { stack, hwn, source })
    }
}

/// The `.mat` output `generate` writes, from `out`'s extension and the `.mat` options
/// (`None`: a `.npy`, where no `.mat` option may be given). `version` is `"5"` or `"7.3"`
/// (the default).
///
/// # Errors
/// When a `.mat` option is given for a `.npy` output.
pub fn mat_output(
    out: &Path,
    version: Option<&str>,
    class: Option<MatClass>,
    var: Option<String>,
) -> Result<Option<MatOutput>> {
    if !is_mat_path(out) {
        if version.is_some() || class.is_some() || var.is_some() {
            bail!(
                "--mat-version, --mat-class and --var apply to a .mat output; {} is written as \
                 .npy",
                out.display()
            );
        }
        return Ok(None);
    }
    Ok(Some(MatOutput {
        version: match version {
            Some("5") => MatVersion::V5,
            _ => MatVersion::V73,
        },
        class: class.unwrap_or(MatClass::Single),
        variable: var.unwrap_or_else(|| "samples".into()),
    }))
}

/// The seed, number, block size and sample format of a `generate`.
pub struct Generation {
    /// The seed of the white noise (sample `i`'s stream is derived from it and `i`).
    pub seed: u64,
    /// How many samples.
    pub samples: usize,
    /// Samples generated per block.
    pub chunk: usize,
    /// The sample format, overriding the model's.
    pub sample_format: Option<u32>,
    /// Write the `.npy` through the page cache, not with direct I/O.
    pub buffered: bool,
}

/// What [`generate`] wrote.
pub struct Generated {
    /// The sample format the samples were generated with.
    pub sample_format: u32,
    /// For a `.npy`, the record of how to write the file again.
    pub record: Option<PathBuf>,
    /// The temporaries of killed writers that were removed beside the output.
    pub removed: Vec<String>,
}

/// `generate`: checks the output (a `.npy`, or the `.mat` `mat` describes), loads the model,
/// streams the samples into the file, calling `progress` with the count written.
///
/// # Errors
/// Naming the output or the model: locked by another writer, not the tool's, the model
/// unreadable, or the writing failed (nothing is left at `out` then).
pub fn generate(
    model: &Path,
    out: &Path,
    mat: Option<&MatOutput>,
    run: &Generation,
    progress: impl Fn(usize),
) -> Result<Generated> {
    use crate::io::model::{is_generated_npy, is_generation_record, record_path};
    // Held until the samples are in place: a second `generate` into `out` is refused.
    let _lock = crate::io::outdir::lock_output(out, "generate")?;
    match mat {
        Some(_) => crate::io::mat::write::check_replaceable(out)?,
        None => {
            crate::io::outdir::check_file_output(out, "samples .npy", is_generated_npy)?;
            crate::io::outdir::check_file_output(
                &record_path(out),
                "generation record",
                is_generation_record,
            )?;
        }
    }
    let removed = crate::io::outdir::remove_dead_temporaries_of(out)?;
    let (mut m, _) = crate::io::model::load(model)?;
    check_disk(&m, out, mat, run.samples)?;
    if let Some(format) = run.sample_format {
        m.set_sample_format(format);
    }
    let record = GenerationRecord::new(model, &m, run.seed, run.samples, out);
    match mat {
        Some(mat) => {
            let (h, w) = m.shape();
            crate::io::mat::write::check_output(mat, (h, w, run.samples))
                .with_context(|| format!("{} was not written", out.display()))?;
            crate::io::model::generate_to_mat(
                &m,
                run.seed,
                run.samples,
                run.chunk,
                out,
                mat,
                progress,
            )?;
        }
        None => {
            let mode = if run.buffered {
                crate::io::stream::WriteMode::Buffered
            } else {
                crate::io::stream::WriteMode::Direct
            };
            crate::io::model::generate_to_npy(
                &m,
                run.seed,
                (run.samples, run.chunk),
                out,
                mode,
                progress,
            )?;
            crate::io::model::write_generation_record(out, &record)?;
        }
    }
    Ok(Generated {
        sample_format: m.moments().sample_format,
        record: mat.is_none().then(|| record_path(out)),
        removed,
    })
}

/// Refuses `samples` samples of `model` at `out` when they would not fit in the free space of
/// its file system ([`crate::resources::disk_shortfall`]), before anything is written.
///
/// # Errors
/// Naming the samples, the bytes and the free space.
fn check_disk(model: &Model, out: &Path, mat: Option<&MatOutput>, samples: usize) -> Result<()> {
    let (h, w) = model.shape();
    let value = match mat.map(|m| m.class) {
        Some(MatClass::Double) => 16,
        _ => 8,
    };
    let bytes = crate::resources::saturating_bytes(&[samples, h, w, value]);
    match crate::resources::disk_shortfall(
        out,
        bytes,
        &format!("the {samples} samples (--samples)"),
    ) {
        Some(why) => bail!("{why}: lower --samples or choose another --out"),
        None => Ok(()),
    }
}

/// The method of its name (`method1`, `method2`, `full_covariance`, `uncorrelated`,
/// `fourth_order`).
///
/// # Errors
/// Listing the names, for an unknown one.
pub fn method_named(name: &str) -> Result<Method> {
    Ok(name.parse()?)
}

/// The sign scheme of its name (`multiscale`, `alternating`).
///
/// # Errors
/// Listing the names, for an unknown one.
pub fn negative_signs_named(name: &str) -> Result<NegativeSigns> {
    serde_json::from_value(serde_json::Value::String(name.into())).map_err(|_| {
        anyhow::anyhow!("unknown --negative-signs {name:?}: multiscale or alternating")
    })
}

/// What [`fit_folder`] wrote.
pub struct Fitted {
    /// The model folder's record (method, shape, samples fitted, source).
    pub info: ModelInfo,
    /// The temporaries of killed writers that were removed beside the output.
    pub removed: Vec<String>,
}

/// `fit`: loads `input`, analyses it (to `options.levels` for Method 2, one level otherwise),
/// fits `method` and saves the model folder `out`.
///
/// # Errors
/// Naming the input or the output: unreadable, not fittable, `out` locked or not a model
/// folder of the tool's.
pub fn fit_folder(
    input: &Input,
    method: Method,
    out: &Path,
    options: FitOptions,
) -> Result<Fitted> {
    // Held until the model folder is in place: a second `fit` into `out` is refused.
    let _lock = crate::io::outdir::lock_output(out, "fit")?;
    let Loaded { stack, hwn, source } = input.load()?;
    let depth = method.needs().depth(options.levels);
    let analysis = stack
        .analyse(hwn, depth)
        .with_context(|| format!("analysing {source}"))?;
    let full = method.needs().stack.then(|| stack.to_complex128(hwn));
    let (model, info) = fit_analysed(method, &analysis, full.as_ref(), options, source)?;
    let removed = save_model(&model, &info, out)?;
    Ok(Fitted { info, removed })
}

/// Fits `method` to a stack's `analysis` (at [`crate::synthesis::Needs::depth`]; `full`: the
/// stack as complex128 `[N, H, W]` where [`crate::synthesis::Needs::stack`]) and makes the model folder's record, `source` naming
/// the stack: what `fit` does between reading the input and saving the folder, shared with
/// the Python bindings so that both give the same model.
///
/// # Errors
/// Naming `source` and the method, when the fit fails.
pub fn fit_analysed(
    method: Method,
    analysis: &crate::stats::analysis::Analysis,
    full: Option<&ndarray::Array3<num_complex::Complex64>>,
    options: FitOptions,
    source: String,
) -> Result<(Model, ModelInfo)> {
    let depth = method.needs().depth(options.levels);
    let model = fit(
        method,
        analysis,
        full.map(|s| s.view()),
        FitOptions {
            levels: depth,
            ..options
        },
    )
    .with_context(|| format!("fitting {} to {source}", method.as_str()))?;
    let info = ModelInfo::new(&model, analysis, options.half_width, depth, source);
    Ok((model, info))
}

/// Saves `model` as the model folder `out` with the policy of `fit` (locked while written;
/// refused over anything but an empty folder or an earlier model of the tool's; swapped in
/// whole). Returns the temporaries of killed writers it removed.
///
/// # Errors
/// Naming `out`: locked, not a model folder, or the writing failed.
pub fn save_model_folder(model: &Model, info: &ModelInfo, out: &Path) -> Result<Vec<String>> {
    let _lock = crate::io::outdir::lock_output(out, "fit")?;
    save_model(model, info, out)
}

/// Saves a model folder at `out`: refused if `out` is a file, or a folder that is neither
/// empty nor a model folder holding only model files; written into a temporary folder beside
/// it and swapped in whole, so an earlier model's files never mix with the new one's. Returns the
/// temporaries of killed writers it removed.
fn save_model(model: &Model, info: &ModelInfo, out: &Path) -> Result<Vec<String>> {
    if let Ok(m) = std::fs::symlink_metadata(out) {
        if !m.is_dir() {
            bail!(
                "{} exists and is not a folder: --out names the model folder to write \
                 (nothing was changed)",
                out.display()
            );
        }
        let entries: Vec<_> = std::fs::read_dir(out)
            .with_context(|| format!("cannot read {}", out.display()))?
            .flatten()
            .collect();
        let foreign: Vec<String> = entries
            .iter()
            .filter(|e| {
                let name = e.file_name();
                !(e.path().is_file() && crate::io::model::is_model_file(&name.to_string_lossy()))
            })
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        let is_model = out.join("model.json").is_file();
        if !entries.is_empty() && (!is_model || !foreign.is_empty()) {
            bail!(
                "{} is not empty and is not a model folder the tool wrote ({}): choose a new \
                 or empty folder for --out (nothing was changed)",
                out.display(),
                if is_model {
                    format!("it also holds {}", foreign.join(", "))
                } else {
                    "no model.json".to_string()
                }
            );
        }
    }
    let name = out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "model".into());
    let removed = crate::io::outdir::remove_dead_temporaries_of(out)?;
    let tmp = out.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    let saved = crate::io::model::save(model, info, &tmp)
        .and_then(|()| crate::io::atomic::swap_in_dir(&tmp, out));
    match saved {
        Ok(true) => {
            // `tmp` now holds the earlier model (model files only, checked above).
            std::fs::remove_dir_all(&tmp)
                .with_context(|| format!("removing the earlier model {}", tmp.display()))?;
            Ok(removed)
        }
        Ok(false) => Ok(removed),
        Err(e) => {
            let _ = std::fs::remove_dir_all(&tmp);
            Err(e).with_context(|| format!("writing the model folder {}", out.display()))
        }
    }
}
