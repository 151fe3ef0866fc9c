//! The `fit` and `generate` commands: the library's [`isar_clutter::workflow`] on the
//! command line's arguments, on a pool of `--jobs` threads, with a progress bar and a line of
//! what was written.

use super::args::{CutArgs, FitArgs, GenerateArgs};
use super::pool;
use anyhow::Result;
use isar_clutter::synthesis::FitOptions;
use isar_clutter::workflow::{self, Generation, Input};

/// `fit`: load, analyse, fit, save.
///
/// # Errors
/// From [`workflow::fit_folder`], or an unknown method or sign scheme.
pub fn fit(a: FitArgs) -> Result<()> {
    let input = Input {
        path: &a.input,
        var: a.var.as_deref(),
        layout: a.layout.as_deref(),
    };
    let method = workflow::method_named(&a.method)?;
    let options = FitOptions {
        half_width: a.half_width,
        levels: a.levels,
        negative_signs: workflow::negative_signs_named(&a.negative_signs)?,
    };
    let fitted = pool(a.jobs)?.install(|| workflow::fit_folder(&input, method, &a.out, options))?;
    say_removed(&fitted.removed, &a.out);
    let info = &fitted.info;
    eprintln!(
        "{} fitted to {} ({} samples of {}x{}) -> {}",
        method.as_str(),
        info.source,
        info.samples_fitted,
        info.height,
        info.width,
        a.out.display()
    );
    Ok(())
}

/// `generate`: stream the samples into the file with a progress bar on a terminal.
///
/// # Errors
/// From [`workflow::generate`], or `.mat` options given for a `.npy`.
pub fn generate(a: GenerateArgs) -> Result<()> {
    let mat = workflow::mat_output(&a.out, a.mat_version.as_deref(), a.mat_class, a.var)?;
    let run = Generation {
        seed: a.seed,
        samples: a.samples,
        chunk: a.chunk,
        sample_format: a.sample_format,
        buffered: a.buffered,
    };
    let bar = indicatif::ProgressBar::new(run.samples as u64);
    if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let t = std::time::Instant::now();
    let progress = |done: usize| bar.set_position(done as u64);
    let done = pool(a.jobs)?
        .install(|| workflow::generate(&a.model, &a.out, mat.as_ref(), &run, progress))?;
    bar.finish_and_clear();
    say_removed(&done.removed, &a.out);
    let s = t.elapsed().as_secs_f64();
    let again = match &done.record {
        Some(record) => format!(" (how to write it again: {})", record.display()),
        None => String::new(),
    };
    eprintln!(
        "{} sample(s) (format {}) -> {}{again} in {s:.2} s ({:.0} samples/s)",
        run.samples,
        done.sample_format,
        a.out.display(),
        run.samples as f64 / s
    );
    Ok(())
}

/// `cut`: a scene into a stack of clutter patches, with a line saying what was written.
///
/// # Errors
/// From [`isar_clutter::io::cut::cut_npy`], or `--out` locked or not a stack `cut` wrote, or
/// a killed writer's temporary that cannot be removed.
pub fn cut(a: CutArgs) -> Result<()> {
    use isar_clutter::io::cut;
    let record = cut::record_path(&a.out);
    let _lock = isar_clutter::io::outdir::lock_output(&a.out, "cut")?;
    isar_clutter::io::outdir::check_file_output(&a.out, "stack .npy", |_| record.is_file())?;
    // As `generate` and `fit`: the temporary of a killed `cut` of the same output goes.
    say_removed(
        &isar_clutter::io::outdir::remove_dead_temporaries_of(&a.out)?,
        &a.out,
    );
    let options = cut::CutOptions {
        patch: a.patch,
        stride: a.stride.unwrap_or(a.patch),
        window: a.window,
        avoid: a.avoid.clone(),
        polygon: a.polygon.clone(),
        avoid_mask: a.avoid_mask.clone(),
    };
    let t = std::time::Instant::now();
    let bar = indicatif::ProgressBar::new_spinner();
    if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let progress = |n: usize| {
        bar.set_message(format!("{n} patches written"));
        bar.tick();
    };
    let map = isar_clutter::io::scenes::SceneOptions {
        window: a.map_box,
        polygon: a.map_polygon.clone().map(|p| p.0),
        calibration: a.calibration.clone(),
    };
    let done = cut_inputs(&a, (&options, &map), progress)?;
    bar.finish_and_clear();
    eprintln!(
        "{} patch(es) of {}x{} ({} place(s) x {} scene(s)) -> {} (places: {}) in {:.2} s",
        done.samples(),
        options.patch.rows,
        options.patch.cols,
        done.places,
        done.scenes,
        a.out.display(),
        done.record.display(),
        t.elapsed().as_secs_f64()
    );
    Ok(())
}

/// [`cut`]'s cut of its inputs, by their kind (their files' suffixes), with `options`.
fn cut_inputs(
    a: &CutArgs,
    options @ (cut_options, map): (
        &isar_clutter::io::cut::CutOptions,
        &isar_clutter::io::scenes::SceneOptions,
    ),
    progress: impl Fn(usize),
) -> Result<isar_clutter::io::cut::Cut> {
    use isar_clutter::io::cut;
    use isar_clutter::io::scenes::{cut_scenes, SceneOptions};
    use isar_clutter::io::{geotiff::GeoTiff, sicd::Sicd, uavsar::UavsarScene};
    let suffix = |p: &std::path::Path| {
        let s = p.extension().map(|e| e.to_string_lossy().to_lowercase());
        s.unwrap_or_default()
    };
    let kinds: std::collections::BTreeSet<String> = a.input.iter().map(|p| suffix(p)).collect();
    let kinds: Vec<&str> = kinds.iter().map(String::as_str).collect();
    let (input, out, chunk, scenes) = (&a.input, &a.out, a.chunk, options);
    let hdf5 = matches!(kinds[..], ["h5"] | ["hdf5"] | ["he5"]);
    if a.dataset.is_some() && !hdf5 {
        anyhow::bail!(
            "--dataset names the scene's dataset in HDF5 inputs (.h5, .hdf5, .he5); the \
             inputs here are .{}",
            kinds.join(", .")
        );
    }
    let done = match kinds[..] {
        ["npy"] if input.len() == 1 => {
            if map.calibration.is_some() {
                anyhow::bail!(
                    "--calibration: {} is an .npy array, which holds no scale factors",
                    input[0].display()
                );
            }
            if *map != SceneOptions::default() {
                anyhow::bail!(
                    "--map-box, --map-polygon: {} has no georeferencing; give --window and \
                     --polygon in pixels",
                    input[0].display()
                );
            }
            cut::cut_npy(&input[0], out, cut_options, chunk, progress)?
        }
        ["tif"] | ["tiff"] | ["tif", "tiff"] => {
            cut_scenes::<GeoTiff>(input, out, scenes, chunk, progress)?
        }
        ["nitf"] | ["ntf"] | ["nitf", "ntf"] => {
            cut_scenes::<Sicd>(input, out, scenes, chunk, progress)?
        }
        ["slc"] => cut_scenes::<UavsarScene>(input, out, scenes, chunk, progress)?,
        ["h5"] | ["hdf5"] | ["he5"] => {
            let dataset = a.dataset.as_deref().ok_or_else(|| {
                anyhow::anyhow!("--dataset: give the scene's dataset in the HDF5 files (/data/VV)")
            })?;
            let open = |place| h5_scenes(input, dataset, place);
            isar_clutter::io::scenes::cut_opened(open, input, out, scenes, chunk, progress)?
        }
        _ => {
            let given: Vec<String> = input.iter().map(|p| p.display().to_string()).collect();
            anyhow::bail!(
                "--input: one .npy scene (or time stack), or GeoTIFF (.tif, .tiff), SICD (.nitf, \
                 .ntf), UAVSAR (.slc, beside its .ann) or HDF5 (.h5, .hdf5, .he5, with \
                 --dataset) scenes of one format; got {}",
                given.join(", ")
            )
        }
    };
    Ok(done)
}

/// The single scenes `[H, W]` at `dataset` in the HDF5 files `paths`, checked, with `place`.
fn h5_scenes(
    paths: &[std::path::PathBuf],
    dataset: &str,
    place: Option<isar_clutter::io::scenes::Place>,
) -> Result<
    isar_clutter::io::scenes::Scenes<isar_clutter::io::h5stack::H5Scene>,
    isar_clutter::io::scenes::StackError,
> {
    use isar_clutter::io::h5stack::{H5Scene, H5Stack};
    use isar_clutter::io::scenes::{Scenes, StackError};
    let err = |i, message| StackError {
        field: "path",
        index: Some(i),
        message,
    };
    let scenes = paths
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let stack = H5Stack::open(p, dataset, None, false)
                .map_err(|(field, m)| err(i, format!("{m} (--{field})")))?;
            if !stack.scene {
                return Err(err(
                    i,
                    format!(
                        "{}: {dataset:?} is a stack {:?}: cut cuts scenes [H, W] (a stack is \
                         read whole by the hdf5 dataset kind)",
                        p.display(),
                        stack.dims
                    ),
                ));
            }
            Ok(H5Scene::new(stack))
        })
        .collect::<Result<Vec<_>, _>>()?;
    Scenes::new(scenes, place)
}

/// Says which temporaries of killed writers of `out` (a `generate` or `fit` stopped by
/// `kill -9` or a crash) were removed.
fn say_removed(removed: &[String], out: &std::path::Path) {
    for name in removed {
        eprintln!(
            "removed {name}: a killed writer of {} left it",
            out.display()
        );
    }
}
