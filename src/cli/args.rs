//! The command line's grammar: the commands and their options as clap parses them, one
//! arguments struct per command (its fields are what the command's function in [`super`]
//! receives). Nothing here runs anything.

use clap::{Args, Parser, Subcommand, ValueEnum};
use isar_clutter::io::mat::MatClass;
use std::path::PathBuf;

/// Multiscale modelling and simulation of ISAR clutter: declarative batch experiments.
#[derive(Parser)]
#[command(name = "isar-clutter", version, about)]
pub struct Cli {
    #[command(subcommand)]
    /// The command to run.
    pub command: Command,
}

/// The commands.
#[derive(Subcommand)]
pub enum Command {
    /// Run every job of a spec and write the results to outputs/<name>/ (or --out).
    Run(RunArgs),
    /// Reproduce the dissertation's tables: run the specs they need (each random statistic
    /// repeated with other master seeds) into OUT/<spec>/seed-<seed>/, resuming what the job
    /// store holds, and write DOC from those folders: every table's cells, printed beside the
    /// tool's mean and spread, with a verdict.
    Reproduce(ReproduceArgs),
    /// Fit the stand-in plants' amplitude and wind-response factors to the dissertation's
    /// Table 16 and write the fit record that the presets use (rebuild to apply it).
    CalibratePlants(CalibratePlantsArgs),
    /// (Re)build figures/ and report.html of a results folder from its files.
    Report(ReportArgs),
    /// Print comparison tables (methods side by side) from a results folder's Parquet files.
    Table(TableArgs),
    /// Assemble the tables, the manifest and the report of a folder from its job store (after
    /// every shard of `run --shards N` finished).
    Merge(MergeArgs),
    /// List the jobs of an output folder: done, failed or missing, per shard.
    Status(StatusArgs),
    /// Check a spec (syntax, types, files, sizes) without running it.
    Validate(ValidateArgs),
    /// Write (and with --submit, submit) Slurm scripts running a spec in shards: an array job
    /// (`run --shards N`, one task per shard) and a merge job after it (`merge OUT`).
    Slurm(SlurmArgs),
    /// Fit a synthesis model to a stack and save it as a model folder.
    Fit(FitArgs),
    /// Generate samples from a model folder into a [M, H, W] complex64 .npy, or a MATLAB .mat
    /// holding an H x W x M single complex array, in constant memory.
    Generate(GenerateArgs),
    /// Cut a scene [H, W] (or a time stack of coregistered scenes [T, H, W]) in an .npy into a
    /// stack of clutter patches [N, h, w] (complex64 .npy) that `fit` and specs read, in
    /// constant memory; the patches' places go to OUT.patches.json.
    Cut(CutArgs),
}

/// The arguments of `isar-clutter run`.
#[derive(Args)]
pub struct RunArgs {
    /// The experiment spec (YAML).
    pub spec: PathBuf,
    /// Output folder (default: outputs/<name>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Worker threads (default: RAYON_NUM_THREADS, else all cores). Results do not
    /// depend on it.
    #[arg(long, value_parser = jobs)]
    pub jobs: Option<usize>,
    /// Print the job table and exit without running anything.
    #[arg(long)]
    pub dry_run: bool,
    /// No progress output.
    #[arg(long, short)]
    pub quiet: bool,
    /// Do not build figures/ and report.html at the end. An earlier report in the folder
    /// goes with the run's other stale files (it would not follow the new tables);
    /// `isar-clutter report DIR` builds it again.
    #[arg(long)]
    pub no_report: bool,
    /// Redo every job, even those whose result the job store (OUT/jobs/) already holds.
    #[arg(long)]
    pub fresh: bool,
    /// Split the jobs into N shards (balanced by estimated work) and run one of them:
    /// `--shard I`, or SLURM_ARRAY_TASK_ID / JOB_COMPLETION_INDEX when omitted. A shard
    /// writes only into the job store; `merge OUT` assembles the tables.
    #[arg(long, value_name = "N")]
    pub shards: Option<usize>,
    /// The shard to run, 0 <= I < N (with --shards).
    #[arg(long, value_name = "I", requires = "shards")]
    pub shard: Option<usize>,
    /// Refuse a job whose estimated peak memory exceeds SIZE (bytes, or e.g. 512M, 8G;
    /// default: the machine's memory).
    #[arg(long, value_name = "SIZE", value_parser = isar_clutter::run::estimate::parse_size)]
    pub max_memory: Option<u64>,
    /// Master seed in place of the spec's `seed`: the same experiment with other random
    /// numbers (a repeat). Recorded in the folder; `merge`, `status` and `report` use it.
    #[arg(long, value_name = "N")]
    pub seed: Option<u64>,
    /// Where the CNN trainings run, in place of every section's `training.device`: `cpu`,
    /// `cuda` (an NVIDIA GPU, in a binary built with the `cuda` feature; an error without
    /// one) or `auto` (the GPU where one can be used, else the CPU, saying why). The manifest
    /// records the device and GPU.
    #[arg(long, value_name = "cpu|cuda|auto", value_parser = device)]
    pub device: Option<isar_clutter::apps::cnn::train::Device>,
}

/// `--device`'s value.
fn device(s: &str) -> Result<isar_clutter::apps::cnn::train::Device, String> {
    use isar_clutter::apps::cnn::train::Device;
    match s {
        "cpu" => Ok(Device::Cpu),
        "cuda" => Ok(Device::Cuda),
        "auto" => Ok(Device::Auto),
        _ => Err(format!("expected cpu, cuda or auto, got {s:?}")),
    }
}

/// The arguments of `isar-clutter reproduce`.
#[derive(Args)]
pub struct ReproduceArgs {
    /// Where the runs go.
    #[arg(long, default_value = "outputs/reproduction")]
    pub out: PathBuf,
    /// The folder of the specs.
    #[arg(long, default_value = "experiments")]
    pub specs: PathBuf,
    /// The document to write.
    #[arg(long, default_value = "docs/reproduction.md")]
    pub doc: PathBuf,
    /// Runs of each spec with random statistics (the first with the spec's own seed).
    #[arg(long, default_value_t = 5)]
    pub repeats: usize,
    /// Runs of each repeated spec that trains networks (`cnn_*`; default: --repeats): each
    /// repeat trains dozens of networks, most of a reproduction's time.
    #[arg(long)]
    pub cnn_repeats: Option<usize>,
    /// Worker threads of each run (default: RAYON_NUM_THREADS, else all cores).
    #[arg(long, value_parser = jobs)]
    pub jobs: Option<usize>,
    /// Write the document from the folders in OUT without running anything.
    #[arg(long)]
    pub write_only: bool,
    /// Run only this spec (a file stem the document needs, e.g. `similarity_plants`; repeat
    /// the option for several), with its repeats, and write no document.
    #[arg(long, value_name = "SPEC", conflicts_with = "write_only")]
    pub only: Vec<String>,
    /// No progress output.
    #[arg(short, long)]
    pub quiet: bool,
    /// Where the CNN trainings run, as `run --device`: `cpu`, `cuda` or `auto`. The job
    /// store keeps each device's results apart, but the document reads the folders' last
    /// runs: give the GPU's runs their own `--out` (and `--doc`).
    #[arg(long, value_name = "cpu|cuda|auto", value_parser = device)]
    pub device: Option<isar_clutter::apps::cnn::train::Device>,
}

/// The arguments of `isar-clutter calibrate-plants`.
#[derive(Args)]
pub struct CalibratePlantsArgs {
    /// Samples per simulation.
    #[arg(long, default_value_t = 100)]
    pub samples: usize,
    /// Seed of the simulations.
    #[arg(long, default_value_t = 16)]
    pub seed: u64,
    /// Plants A-C: simulations averaged per evaluation (the first from `--seed`, the others
    /// derived from it), so that the fit matches Table 16 in expectation over seeds, not at
    /// one draw.
    #[arg(long, default_value_t = 5)]
    pub seeds: usize,
    /// Which plants to fit: `variance` (A-C to Table 16), `similarity` (D-E to Tables 29-36)
    /// or `all`; the other part of the record is kept.
    #[arg(long, default_value = "all", value_parser = ["variance", "similarity", "all"])]
    pub part: String,
    /// Plants D and E: also fit the KL divergence tables of their measurements (Tables 13-15),
    /// per pixel and per 8x8 area, beside Tables 29-36.
    #[arg(long)]
    pub kl: bool,
    /// The record to write.
    #[arg(long, default_value = "reproduction/plant_calibration.json")]
    pub out: PathBuf,
}

/// The arguments of `isar-clutter report`.
#[derive(Args)]
pub struct ReportArgs {
    /// The results folder of a run (outputs/<name>).
    pub results: PathBuf,
    /// Worker threads (default: RAYON_NUM_THREADS, else all cores).
    #[arg(long, value_parser = jobs)]
    pub jobs: Option<usize>,
    /// Read a folder whose run is in progress, was interrupted, or whose files changed
    /// since its manifest (refused otherwise).
    #[arg(long)]
    pub allow_incomplete: bool,
    /// Per-job figures for at most N jobs (spread evenly over the plan order, the first
    /// and the last included), or `all`; a run with at most N jobs with figures gets them
    /// for every job.
    #[arg(long, value_name = "N|all", default_value_t)]
    pub figures_for: isar_clutter::report::select::FiguresFor,
}

/// The layouts of `isar-clutter table`, named for the command line (the report's
/// [`isar_clutter::report::table::Format`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum TableFormat {
    /// Aligned columns.
    Text,
    /// GitHub-flavoured Markdown.
    Md,
    /// An HTML `<table>` with a caption.
    Html,
}

impl From<TableFormat> for isar_clutter::report::table::Format {
    fn from(f: TableFormat) -> Self {
        use isar_clutter::report::table::Format;
        match f {
            TableFormat::Text => Format::Text,
            TableFormat::Md => Format::Md,
            TableFormat::Html => Format::Html,
        }
    }
}

/// The arguments of `isar-clutter table`.
#[derive(Args)]
pub struct TableArgs {
    /// The results folder of a run (outputs/<name>).
    pub results: PathBuf,
    /// One table: rmse, cmd, kl, model_order, hypotheses, calibration, summary,
    /// classification, classification_detail or location (default: every table with rows).
    #[arg(long)]
    pub table: Option<String>,
    /// text (aligned columns) or md (Markdown).
    #[arg(long, value_enum, default_value = "text")]
    pub format: TableFormat,
    /// Column spread across the page (default: method; model_order for model_order;
    /// source for summary), e.g. `--pivot dataset`.
    #[arg(long)]
    pub pivot: Option<String>,
    /// Keep rows whose column has one of the values: `--filter dataset=exp,dyadic`
    /// (repeatable).
    #[arg(long, value_parser = isar_clutter::report::table::parse_filter)]
    pub filter: Vec<(String, Vec<String>)>,
    /// Read a folder whose run is in progress, was interrupted, or whose files changed
    /// since its manifest (refused otherwise).
    #[arg(long)]
    pub allow_incomplete: bool,
}

/// The arguments of `isar-clutter merge`.
#[derive(Args)]
pub struct MergeArgs {
    /// The output folder the shards wrote into.
    pub results: PathBuf,
    /// Merge even when jobs are missing (they are listed as failed; the folder stays
    /// marked incomplete).
    #[arg(long)]
    pub partial: bool,
    /// Do not build figures/ and report.html.
    #[arg(long)]
    pub no_report: bool,
    /// Worker threads (default: RAYON_NUM_THREADS, else all cores).
    #[arg(long, value_parser = jobs)]
    pub jobs: Option<usize>,
    /// No progress output.
    #[arg(long, short)]
    pub quiet: bool,
}

/// The arguments of `isar-clutter status`.
#[derive(Args)]
pub struct StatusArgs {
    /// The output folder.
    pub results: PathBuf,
}

/// The arguments of `isar-clutter validate`.
#[derive(Args)]
pub struct ValidateArgs {
    /// The experiment spec (YAML).
    pub spec: PathBuf,
    /// Refuse a job whose estimated peak memory exceeds SIZE (bytes, or e.g. 512M, 8G;
    /// default: the machine's memory).
    #[arg(long, value_name = "SIZE", value_parser = isar_clutter::run::estimate::parse_size)]
    pub max_memory: Option<u64>,
}

/// The arguments of `isar-clutter slurm`.
#[derive(Args)]
pub struct SlurmArgs {
    /// The experiment spec (YAML).
    pub spec: PathBuf,
    /// Number of shards: array tasks, each running its share of the jobs.
    #[arg(long)]
    pub shards: usize,
    /// Output folder (default: outputs/<name>); the scripts go to OUT/slurm/.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Slurm partition of both jobs.
    #[arg(long)]
    pub partition: Option<String>,
    /// Time limit of each job (sbatch --time, e.g. 2:00:00).
    #[arg(long, value_parser = isar_clutter::run::slurm_values::time)]
    pub time: Option<String>,
    /// CPUs per array task (and the worker threads of each shard).
    #[arg(long, default_value_t = 1)]
    pub cpus: usize,
    /// Memory of each job (sbatch --mem, e.g. 8G).
    #[arg(long, value_parser = isar_clutter::run::slurm_values::mem)]
    pub mem: Option<String>,
    /// Submit both jobs with sbatch (the merge job with --dependency=afterok).
    #[arg(long)]
    pub submit: bool,
}

/// The arguments of `isar-clutter fit`.
#[derive(Args)]
pub struct FitArgs {
    /// The stack: .npy of complex64, complex128 or real values, [N, H, W]; or a MATLAB
    /// .mat file (v5, or v7.3 in a build with the mat73 feature) holding a numeric 3-D
    /// array, H x W x N.
    #[arg(long)]
    pub input: PathBuf,
    /// .mat input: the variable to read (default: the file's only numeric 3-D array).
    #[arg(long, value_name = "NAME")]
    pub var: Option<String>,
    /// Axis order of the input: nhw or hwn (default: nhw for .npy, hwn, MATLAB's
    /// H x W x N, for .mat).
    #[arg(long)]
    pub layout: Option<String>,
    /// method1, method2, full_covariance, uncorrelated or fourth_order.
    #[arg(long)]
    pub method: String,
    /// The model folder to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Filter half-width K of Methods 1 and 2.
    #[arg(long, default_value_t = 8)]
    pub half_width: usize,
    /// Dyadic parameters L of Method 2.
    #[arg(long, default_value_t = 3)]
    pub levels: usize,
    /// Method 1's signs of a negative correlation's filter: multiscale (dissertation
    /// §4.2.4) or alternating.
    #[arg(long, default_value = "multiscale")]
    pub negative_signs: String,
    /// Worker threads (default: RAYON_NUM_THREADS, else all cores).
    #[arg(long, value_parser = jobs)]
    pub jobs: Option<usize>,
}

/// The arguments of `isar-clutter generate`.
#[derive(Args)]
pub struct GenerateArgs {
    /// The model folder (from `fit` or a run's models/<job>).
    #[arg(long)]
    pub model: PathBuf,
    /// Number of samples M.
    #[arg(long)]
    pub samples: usize,
    /// Seed of the generation (sample s draws from stream s of the seed).
    #[arg(long)]
    pub seed: u64,
    /// How samples are drawn from the seed: 2 (ChaCha8 and f32, the format of models fitted
    /// by this version) or 1 (ChaCha20 and f64, earlier models). Default: the model's.
    #[arg(long, value_name = "FORMAT", value_parser = clap::value_parser!(u32).range(1..=2))]
    pub sample_format: Option<u32>,
    /// The .npy or .mat (by its extension) to write. A .npy gets NAME.npy.json beside
    /// it: the model, seed and sample format that write it again. An existing file is
    /// replaced only if the tool wrote it and it holds nothing the tool did not write.
    #[arg(long)]
    pub out: PathBuf,
    /// .mat output: the MAT version, 7.3 (default: HDF5, any size; needs the mat73
    /// feature) or 5 (at most 2 GB).
    #[arg(long, value_name = "VERSION", value_parser = ["7.3", "5"])]
    pub mat_version: Option<String>,
    /// .mat output: the class of the values (default single).
    #[arg(long, value_name = "CLASS", value_parser = {
        use clap::builder::TypedValueParser;
        clap::builder::PossibleValuesParser::new(MatClass::NAMES)
            .map(|s| s.parse::<MatClass>().expect("a name of MatClass::NAMES"))
    })]
    pub mat_class: Option<MatClass>,
    /// .mat output: the name of the variable (default samples).
    #[arg(long, value_name = "NAME")]
    pub var: Option<String>,
    /// Samples generated per block (memory: two blocks, one generated while the other is
    /// written).
    #[arg(long, default_value_t = 256)]
    pub chunk: usize,
    /// .npy output: write through the page cache instead of with direct I/O (O_DIRECT,
    /// used where the file system allows it: the bytes go to the disk without a copy).
    #[arg(long)]
    pub buffered: bool,
    /// Worker threads (default: RAYON_NUM_THREADS, else all cores). The file does not
    /// depend on it.
    #[arg(long, value_parser = jobs)]
    pub jobs: Option<usize>,
}

/// `isar-clutter cut`.
#[derive(Args)]
pub struct CutArgs {
    /// The scene: an .npy of shape [H, W] or [T, H, W] (complex64/128 or float32/64), or a
    /// complex GeoTIFF (.tif, .tiff), SICD (.nitf, .ntf), UAVSAR (.slc, its .ann beside it)
    /// or HDF5 scene (.h5, .hdf5, .he5, with --dataset); give those once per scene of a time
    /// stack (coregistered, in order).
    #[arg(long, required = true)]
    pub input: Vec<PathBuf>,
    /// Patch size: N (square) or ROWSxCOLS.
    #[arg(long)]
    pub patch: isar_clutter::io::cut::Size2,
    /// Step between patches: N or ROWSxCOLS (default: the patch size).
    #[arg(long)]
    pub stride: Option<isar_clutter::io::cut::Size2>,
    /// Where patches may lie: r0:r1,c0:c1 in pixels from 0, ends excluded (default: the scene).
    #[arg(long)]
    pub window: Option<isar_clutter::io::cut::Window>,
    /// A box no patch may overlap (a target): r0:r1,c0:c1; give it once per box.
    #[arg(long)]
    pub avoid: Vec<isar_clutter::io::cut::Window>,
    /// A region (r0,c0;r1,c1;r2,c2;... in pixels) patches must lie wholly inside.
    #[arg(long)]
    pub polygon: Option<isar_clutter::io::polygon::Polygon>,
    /// Where patches may lie as a box of map coordinates, X0,X1,Y0,Y1 (GeoTIFF scenes: the
    /// files' map transform or ground control points, longitude and latitude for
    /// Sentinel-1; SICD images: longitude and latitude through SICD's projection at the scene
    /// centre's height; HDF5 scenes: the coordinate vectors beside them, e.g. OPERA's
    /// x_coordinates/y_coordinates; UAVSAR scenes: longitude and latitude through the flight
    /// line's .llh grid, a point a block of looks; a box starting with a minus sign is written
    /// --map-box=X0,...), instead of --window.
    #[arg(long, value_name = "X0,X1,Y0,Y1", conflicts_with = "window", value_parser = map_box)]
    pub map_box: Option<([f64; 2], [f64; 2])>,
    /// The region of --polygon by its vertices in map coordinates: x0,y0;x1,y1;x2,y2;...
    #[arg(long, value_name = "X0,Y0;X1,Y1;...", conflicts_with = "polygon")]
    pub map_polygon: Option<isar_clutter::io::polygon::Polygon>,
    /// For HDF5 scenes (.h5, .hdf5, .he5: an OPERA CSLC or NISAR RSLC frame): the scene's
    /// dataset in each file, e.g. /data/VV.
    #[arg(long)]
    pub dataset: Option<String>,
    /// Calibrate the values so that |value|^2 is this quantity (sigma0, beta0, gamma0; rcs for
    /// SICD) with the files' own scale factors: SICD's Radiometric polynomials, NISAR's
    /// calibration tables (RSLC, GSLC), ICEYE's calibration_factor (beta0).
    #[arg(long, value_name = "QUANTITY")]
    pub calibration: Option<String>,
    /// A mask of the scene (.npy [H, W], bool or uint8): no patch covers a non-zero pixel.
    #[arg(long, value_name = "MASK.npy")]
    pub avoid_mask: Option<PathBuf>,
    /// The stack to write (.npy); an existing file is replaced only if `cut` wrote it.
    #[arg(long)]
    pub out: PathBuf,
    /// Patches per block (memory: two blocks); at least the patches of one band of rows as tall
    /// as the scenes' storage blocks (HDF5 chunks, GeoTIFF tiles).
    #[arg(long, default_value_t = 256)]
    pub chunk: usize,
}

/// Parses `--map-box X0,X1,Y0,Y1`.
fn map_box(text: &str) -> Result<([f64; 2], [f64; 2]), String> {
    let v: Vec<f64> = text
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("{text:?} is not X0,X1,Y0,Y1"))?;
    match v[..] {
        [x0, x1, y0, y1] if v.iter().all(|f| f.is_finite()) && x0 != x1 && y0 != y1 => {
            Ok(([x0, x1], [y0, y1]))
        }
        _ => Err(format!(
            "{text:?} is not X0,X1,Y0,Y1 (four finite numbers, a box)"
        )),
    }
}

/// Parses `--jobs`: at least 1, capped at what the machine can use
/// ([`isar_clutter::resources::cap_threads`]) with a note on stderr.
fn jobs(text: &str) -> Result<usize, String> {
    let n: usize = text
        .trim()
        .parse()
        .map_err(|_| format!("{text:?} is not a number of threads"))?;
    if n == 0 {
        return Err("at least 1 thread".into());
    }
    let (n, note) = isar_clutter::resources::cap_threads(n, "--jobs");
    if let Some(note) = note {
        eprintln!("note: {note}");
    }
    Ok(n)
}
