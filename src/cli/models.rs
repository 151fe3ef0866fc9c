//! The `fit` and `generate` commands: a model fitted to a stack and saved as a model folder;
//! samples generated from a model folder and streamed into a `.npy` or a `.mat`, each output
//! locked while it is written and checked to be the tool's before it is replaced.

use crate::pool;
use anyhow::{Context, Result};

/// The seed, number, block size and sample format of a `generate`.
pub(crate) struct Generation {
    pub(crate) seed: u64,
    pub(crate) samples: usize,
    pub(crate) chunk: usize,
    /// `--sample-format`, overriding the model's.
    pub(crate) sample_format: Option<u32>,
    /// `--buffered`: write the `.npy` through the page cache, not with direct I/O.
    pub(crate) buffered: bool,
}

/// `generate`: check the output (a `.npy`, or the `.mat` `mat` describes), load the model,
/// stream the samples into the file.
pub(crate) fn generate_command(
    model: &std::path::Path,
    out: &std::path::Path,
    mat: Option<&isar_clutter::io::mat::MatOutput>,
    run: &Generation,
    jobs: Option<usize>,
) -> Result<()> {
    // Held until the samples are in place: a second `generate` into `out` is refused.
    let _lock = isar_clutter::io::outdir::lock_output(out, "generate")?;
    match mat {
        Some(_) => isar_clutter::io::mat::write::check_replaceable(out)?,
        None => {
            use isar_clutter::io::model::{is_generated_npy, is_generation_record, record_path};
            isar_clutter::io::outdir::check_file_output(out, "samples .npy", is_generated_npy)?;
            isar_clutter::io::outdir::check_file_output(
                &record_path(out),
                "generation record",
                is_generation_record,
            )?;
        }
    }
    clear_dead_temporaries(out)?;
    let (mut m, _) = isar_clutter::io::model::load(model)?;
    if let Some(format) = run.sample_format {
        m.sample_format = format;
    }
    if let Some(mat) = mat {
        let (h, w) = m.shape();
        isar_clutter::io::mat::write::check_output(mat, (h, w, run.samples))
            .with_context(|| format!("{} was not written", out.display()))?;
    }
    let record =
        isar_clutter::io::model::GenerationRecord::new(model, &m, run.seed, run.samples, out);
    let bar = indicatif::ProgressBar::new(run.samples as u64);
    if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let t = std::time::Instant::now();
    let progress = |done: usize| bar.set_position(done as u64);
    pool(jobs)?.install(|| match mat {
        Some(mat) => isar_clutter::io::model::generate_to_mat(
            &m,
            run.seed,
            run.samples,
            run.chunk,
            out,
            mat,
            progress,
        ),
        None => isar_clutter::io::model::generate_to_npy(
            &m,
            run.seed,
            (run.samples, run.chunk),
            out,
            if run.buffered {
                isar_clutter::io::stream::WriteMode::Buffered
            } else {
                isar_clutter::io::stream::WriteMode::Direct
            },
            progress,
        )
        .and_then(|_| isar_clutter::io::model::write_generation_record(out, &record)),
    })?;
    bar.finish_and_clear();
    let s = t.elapsed().as_secs_f64();
    let again = match mat {
        Some(_) => String::new(),
        None => format!(
            " (how to write it again: {})",
            isar_clutter::io::model::record_path(out).display()
        ),
    };
    eprintln!(
        "{} sample(s) (format {}) -> {}{again} in {s:.2} s ({:.0} samples/s)",
        run.samples,
        m.sample_format,
        out.display(),
        run.samples as f64 / s
    );
    Ok(())
}

/// The stack `fit` reads: a `.npy`, or a `.mat` variable; `layout` as given.
pub(crate) struct Input<'a> {
    pub(crate) path: &'a std::path::Path,
    pub(crate) var: Option<&'a str>,
    pub(crate) layout: Option<&'a str>,
}

impl Input<'_> {
    /// The stack, whether its axes are `[H, W, N]`, and its name for the model's `source`.
    fn load(&self) -> Result<(isar_clutter::io::npy::Stack, bool, String)> {
        use isar_clutter::io::mat::{is_mat_path, MatFile};
        let mat = is_mat_path(self.path);
        let hwn = match self.layout {
            None => mat,
            Some("nhw") => false,
            Some("hwn") => true,
            Some(other) => anyhow::bail!("unknown layout {other:?}: nhw or hwn"),
        };
        if !mat {
            if self.var.is_some() {
                anyhow::bail!(
                    "--var names a variable of a .mat input; {} is read as .npy",
                    self.path.display()
                );
            }
            let stack = isar_clutter::io::npy::Stack::load(self.path)?;
            return Ok((stack, hwn, self.path.display().to_string()));
        }
        let file = MatFile::open(self.path)?;
        let name = file.stack_variable(self.var)?.name.clone();
        let stack = isar_clutter::io::npy::Stack::Generated(file.read_stack(Some(&name))?);
        Ok((
            stack,
            hwn,
            format!("{} (variable {name})", self.path.display()),
        ))
    }
}

/// The `.mat` output `generate` writes, from `--out`'s extension and the `.mat` options
/// (`None`: a `.npy`, where no `.mat` option may be given).
pub(crate) fn mat_output(
    out: &std::path::Path,
    version: Option<&str>,
    class: Option<isar_clutter::io::mat::MatClass>,
    var: Option<String>,
) -> Result<Option<isar_clutter::io::mat::MatOutput>> {
    use isar_clutter::io::mat::{is_mat_path, MatClass, MatOutput, MatVersion};
    if !is_mat_path(out) {
        if version.is_some() || class.is_some() || var.is_some() {
            anyhow::bail!(
                "--mat-version, --mat-class and --var apply to a .mat output; {} is written as                  .npy",
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

/// `fit`: load, analyse, fit, save.
pub(crate) fn fit_command(
    input: &Input,
    method: &str,
    out: &std::path::Path,
    half_width: usize,
    levels: usize,
    negative_signs: &str,
) -> Result<()> {
    use isar_clutter::synthesis::{fit, FitOptions, Method, NegativeSigns};
    // Held until the model folder is in place: a second `fit` into `out` is refused.
    let _lock = isar_clutter::io::outdir::lock_output(out, "fit")?;
    let method: Method =
        serde_json::from_value(serde_json::Value::String(method.into())).map_err(|_| {
            anyhow::anyhow!(
                "unknown method {method:?}: method1, method2, full_covariance, uncorrelated or fourth_order"
            )
        })?;
    let negative_signs: NegativeSigns =
        serde_json::from_value(serde_json::Value::String(negative_signs.into())).map_err(|_| {
            anyhow::anyhow!(
                "unknown --negative-signs {negative_signs:?}: multiscale or alternating"
            )
        })?;
    let (stack, hwn, source) = input.load()?;
    let depth = if method == Method::Method2 { levels } else { 1 };
    let analysis = stack
        .analyse(hwn, depth)
        .with_context(|| format!("analysing {source}"))?;
    let full = matches!(method, Method::FullCovariance | Method::FourthOrder)
        .then(|| stack.to_complex128(hwn));
    let model = fit(
        method,
        &analysis,
        full.as_ref().map(|s| s.view()),
        FitOptions {
            half_width,
            levels: depth,
            negative_signs,
        },
    )
    .with_context(|| format!("fitting {} to {source}", method.as_str()))?;
    let info = isar_clutter::io::model::ModelInfo::new(
        &model,
        &analysis,
        half_width,
        depth,
        source.clone(),
    );
    save_model(&model, &info, out)?;
    eprintln!(
        "{} fitted to {source} ({} samples of {}x{}) -> {}",
        method.as_str(),
        info.samples_fitted,
        info.height,
        info.width,
        out.display()
    );
    Ok(())
}

/// Removes what killed writers of `out` left beside it (a `generate` or `fit` stopped by
/// `kill -9` or a crash), saying so on stderr.
fn clear_dead_temporaries(out: &std::path::Path) -> Result<()> {
    for name in isar_clutter::io::outdir::remove_dead_temporaries_of(out)? {
        eprintln!(
            "removed {name}: a killed writer of {} left it",
            out.display()
        );
    }
    Ok(())
}

/// Saves a model folder at `out`: refused if `out` is a file, or a folder that is neither
/// empty nor a model folder holding only model files; written into a temporary folder beside
/// it and swapped in whole, so an earlier model's files never mix with the new one's.
fn save_model(
    model: &isar_clutter::synthesis::Model,
    info: &isar_clutter::io::model::ModelInfo,
    out: &std::path::Path,
) -> Result<()> {
    if let Ok(m) = std::fs::symlink_metadata(out) {
        if !m.is_dir() {
            anyhow::bail!(
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
                !(e.path().is_file() && isar_clutter::io::model::FILES.iter().any(|f| name == **f))
            })
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        let is_model = out.join("model.json").is_file();
        if !entries.is_empty() && (!is_model || !foreign.is_empty()) {
            anyhow::bail!(
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
    clear_dead_temporaries(out)?;
    let tmp = out.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    let saved = isar_clutter::io::model::save(model, info, &tmp)
        .and_then(|()| isar_clutter::io::atomic::swap_in_dir(&tmp, out));
    match saved {
        Ok(true) => {
            // `tmp` now holds the earlier model (model files only, checked above).
            std::fs::remove_dir_all(&tmp)
                .with_context(|| format!("removing the earlier model {}", tmp.display()))?;
            Ok(())
        }
        Ok(false) => Ok(()),
        Err(e) => {
            let _ = std::fs::remove_dir_all(&tmp);
            Err(e).with_context(|| format!("writing the model folder {}", out.display()))
        }
    }
}
