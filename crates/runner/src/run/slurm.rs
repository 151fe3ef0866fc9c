//! Running a spec on a Slurm cluster: [`write_scripts`] writes `OUT/slurm/array.sbatch`, an
//! array job whose task `i` runs shard `i` of the spec (`isar-clutter run SPEC --out OUT
//! --shards N`, the shard index taken from `SLURM_ARRAY_TASK_ID`) into the job store, and
//! `OUT/slurm/merge.sbatch`, which assembles the tables, manifest and report (`isar-clutter
//! merge OUT`); [`submit`] hands both to `sbatch`, the merge job depending on the whole array
//! (`--dependency=afterok`). Every path in the scripts is absolute, so they run from any
//! working directory and may also be submitted by hand.

use crate::run::plan;
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use std::process::Command;

/// What the generated scripts run and ask Slurm for.
#[derive(Clone, Debug)]
pub struct SlurmOptions {
    /// Number of shards, one array task each (at least 1).
    pub shards: usize,
    /// `--partition` of both jobs (default: the cluster's default partition).
    pub partition: Option<String>,
    /// `--time` limit of each job, in any format sbatch accepts (e.g. `2:00:00`).
    pub time: Option<String>,
    /// `--cpus-per-task` of each job, and the worker threads of each shard (at least 1).
    pub cpus: usize,
    /// `--mem` of each job (e.g. `8G`; default: the partition's default).
    pub mem: Option<String>,
    /// The results folder (made absolute by [`write_scripts`]).
    pub out: PathBuf,
    /// The experiment spec (made absolute by [`write_scripts`]).
    pub spec: PathBuf,
    /// The `isar-clutter` executable the jobs run (default: the running one).
    pub binary: PathBuf,
}

impl SlurmOptions {
    /// Options for `shards` shards of `spec` into `out`: one CPU per task, no partition, time
    /// or memory request, and the running executable as the binary.
    pub fn new(spec: PathBuf, out: PathBuf, shards: usize) -> Result<Self> {
        let binary = std::env::current_exe()
            .context("cannot find the path of the running isar-clutter executable")?;
        Ok(Self {
            shards,
            partition: None,
            time: None,
            cpus: 1,
            mem: None,
            out,
            spec,
            binary,
        })
    }
}

/// The scripts [`write_scripts`] wrote.
#[derive(Clone, Debug)]
pub struct Scripts {
    /// `OUT/slurm/array.sbatch`: the array job, one task per shard.
    pub array: PathBuf,
    /// `OUT/slurm/merge.sbatch`: the merge job, to run after the whole array succeeded.
    pub merge: PathBuf,
    /// Number of shards (array tasks).
    pub shards: usize,
    /// Number of jobs of the spec (a shard may have none when `shards` exceeds it).
    pub jobs: usize,
    /// The absolute results folder.
    pub out: PathBuf,
}

/// Validates the spec (as `run` would), marks OUT as the experiment's output folder, then
/// writes `OUT/slurm/array.sbatch` and `OUT/slurm/merge.sbatch` (replacing earlier ones).
/// Refuses zero shards or CPUs, a spec that does not load, an OUT that `run` would refuse
/// (another experiment's, or not empty and not the tool's), paths that are not UTF-8 or hold
/// a line break (or, for OUT, a backslash), and Slurm values with whitespace or quotes.
pub fn write_scripts(opts: &SlurmOptions) -> Result<Scripts> {
    if opts.shards == 0 {
        bail!("--shards must be at least 1");
    }
    if opts.cpus == 0 {
        bail!("--cpus must be at least 1");
    }
    for (flag, value) in [
        ("--partition", &opts.partition),
        ("--time", &opts.time),
        ("--mem", &opts.mem),
    ] {
        if let Some(v) = value {
            if v.is_empty()
                || v.chars()
                    .any(|c| c.is_whitespace() || c == '"' || c == '\'')
            {
                bail!("{flag} {v:?}: expected a non-empty Slurm value without spaces or quotes");
            }
        }
    }
    let spec = std::fs::canonicalize(&opts.spec)
        .with_context(|| format!("cannot read the spec {}", opts.spec.display()))?;
    let plan = plan::load(&spec)?;
    let out = std::path::absolute(&opts.out)
        .with_context(|| format!("cannot make {} absolute", opts.out.display()))?;
    let binary = std::path::absolute(&opts.binary)
        .with_context(|| format!("cannot make {} absolute", opts.binary.display()))?;
    let dir = out.join("slurm");
    let name = job_name(&plan.spec.name);
    let common = Common {
        binary: text(&binary, "the isar-clutter executable")?,
        spec: text(&spec, "the spec")?,
        out: text(&out, "the results folder")?,
        dir: text(&dir, "the results folder")?,
        opts,
    };
    if common.dir.contains('\\') {
        bail!(
            "the results folder {} holds a backslash, which turns off Slurm's %a in --output: \
             choose another --out",
            common.dir
        );
    }
    let array_text = array_script(&common, &name);
    let merge_text = merge_script(&common, &name);
    // Marked as the experiment's folder, so that the shards accept the scripts in it.
    crate::io::outdir::mark(&out, &plan.spec.name)?;
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let array = dir.join("array.sbatch");
    let merge = dir.join("merge.sbatch");
    write_script(&array, &array_text)?;
    write_script(&merge, &merge_text)?;
    Ok(Scripts {
        array,
        merge,
        shards: opts.shards,
        jobs: plan.jobs.len(),
        out,
    })
}

/// Submits the array job, then the merge job with `--dependency=afterok:<array id>`; returns
/// both job ids (without a cluster name). `sbatch` runs in the current working directory.
pub fn submit(scripts: &Scripts) -> Result<(String, String)> {
    submit_with(Path::new("sbatch"), scripts)
}

/// [`submit`] with another `sbatch` program (the unit tests use a fake one).
fn submit_with(program: &Path, scripts: &Scripts) -> Result<(String, String)> {
    let array = sbatch(program, &[], &scripts.array)?;
    let merge = sbatch(
        program,
        &[format!("--dependency=afterok:{array}")],
        &scripts.merge,
    )
    .with_context(|| {
        format!(
            "the array job {array} is submitted but its merge job is not: cancel it with \
                 `scancel {array}`, or submit the merge by hand: \
                 sbatch --dependency=afterok:{array} {}",
            scripts.merge.display()
        )
    })?;
    Ok((array, merge))
}

/// Runs `sbatch --parsable EXTRA SCRIPT` and returns the job id it printed.
fn sbatch(program: &Path, extra: &[String], script: &Path) -> Result<String> {
    let output = Command::new(program)
        .arg("--parsable")
        .args(extra)
        .arg(script)
        .output()
        .map_err(|e| {
            if e.kind() == std::io::ErrorKind::NotFound {
                anyhow::anyhow!(
                    "{} not found (is this a Slurm login node?): submit {} from one by hand, \
                     or run isar-clutter slurm --submit there",
                    program.display(),
                    script.display()
                )
            } else {
                anyhow::anyhow!("cannot run sbatch: {e}")
            }
        })?;
    let stderr = String::from_utf8_lossy(&output.stderr);
    if !output.status.success() {
        bail!(
            "sbatch {} failed ({}): {}",
            script.display(),
            output.status,
            stderr.trim()
        );
    }
    let stdout = String::from_utf8_lossy(&output.stdout);
    parse_job_id(&stdout).with_context(|| {
        format!(
            "sbatch {} printed no job id (stdout {:?}, stderr {:?})",
            script.display(),
            stdout.trim(),
            stderr.trim()
        )
    })
}

/// The job id of `sbatch --parsable`'s output: `ID` or `ID;CLUSTER` on its last non-empty line.
pub fn parse_job_id(stdout: &str) -> Option<String> {
    let line = stdout.lines().map(str::trim).rfind(|l| !l.is_empty())?;
    let id = line.split(';').next()?.trim();
    (!id.is_empty() && id.bytes().all(|b| b.is_ascii_digit())).then(|| id.to_string())
}

/// The paths and options both scripts share, as text.
struct Common<'a> {
    binary: &'a str,
    spec: &'a str,
    out: &'a str,
    dir: &'a str,
    opts: &'a SlurmOptions,
}

/// The array script: one task per shard.
fn array_script(c: &Common, name: &str) -> String {
    let n = c.opts.shards;
    let cpus = c.opts.cpus;
    let array = format!("--array=0-{}", n - 1);
    let mut s = header(c, name, &format!("{}/shard-%a.log", c.dir), Some(&array));
    s.push_str(&format!(
        "# Task i runs shard i of {n}; `run` reads the shard index from SLURM_ARRAY_TASK_ID.\n\
         : \"${{SLURM_ARRAY_TASK_ID:?not a Slurm array task: submit this script with sbatch}}\"\n\
         exec \"$BINARY\" run \"$SPEC\" --out \"$OUT\" --shards {n} --jobs \"${{SLURM_CPUS_PER_TASK:-{cpus}}}\" --quiet\n"
    ));
    s
}

/// The merge script: assembles the results from the job store.
fn merge_script(c: &Common, name: &str) -> String {
    let mut s = header(
        c,
        &format!("{name}-merge"),
        &format!("{}/merge.log", c.dir),
        None,
    );
    s.push_str(&format!(
        "exec \"$BINARY\" merge \"$OUT\" --jobs \"${{SLURM_CPUS_PER_TASK:-{}}}\"\n",
        c.opts.cpus
    ));
    s
}

/// Shebang, `#SBATCH` lines (`first`, then the common ones) and the shell variables of a
/// script.
fn header(c: &Common, name: &str, log: &str, first: Option<&str>) -> String {
    let mut s = String::from("#!/usr/bin/env bash\n");
    if let Some(line) = first {
        s.push_str(&format!("#SBATCH {line}\n"));
    }
    s.push_str(&format!("#SBATCH --job-name={name}\n"));
    s.push_str(&format!("#SBATCH --cpus-per-task={}\n", c.opts.cpus));
    s.push_str(&format!("#SBATCH --output={}\n", sbatch_value(log)));
    for (flag, value) in [
        ("partition", &c.opts.partition),
        ("time", &c.opts.time),
        ("mem", &c.opts.mem),
    ] {
        if let Some(v) = value {
            s.push_str(&format!("#SBATCH --{flag}={v}\n"));
        }
    }
    s.push_str(&format!(
        "# Written by `isar-clutter slurm`; its --submit submits array.sbatch, then merge.sbatch\n\
         # to run once every array task succeeded (afterok).\n\
         set -euo pipefail\n\
         BINARY={}\n\
         SPEC={}\n\
         OUT={}\n",
        shell_quote(c.binary),
        shell_quote(c.spec),
        shell_quote(c.out)
    ));
    s
}

/// `value` single-quoted for the shell: `'` becomes `'\''`.
pub fn shell_quote(value: &str) -> String {
    format!("'{}'", value.replace('\'', r"'\''"))
}

/// A file name for an `#SBATCH` line: `%` doubled (Slurm expands `%a`, `%j`, ... in names;
/// `%%` is a literal `%`) except in the `%a` of the pattern itself, and double-quoted when it
/// holds whitespace or a quote (sbatch strips the quotes).
fn sbatch_value(pattern: &str) -> String {
    let (base, tail) = match pattern.rfind('/') {
        Some(i) => pattern.split_at(i),
        None => ("", pattern),
    };
    let value = format!("{}{tail}", base.replace('%', "%%"));
    if value
        .chars()
        .any(|c| c.is_whitespace() || c == '"' || c == '\'')
    {
        format!("\"{}\"", value.replace('"', "\\\""))
    } else {
        value
    }
}

/// A Slurm job name from the spec's name: letters, digits, `-`, `_` and `.` kept, anything
/// else replaced by `_`.
fn job_name(spec_name: &str) -> String {
    let name: String = spec_name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    format!("isar-{name}")
}

/// `path` as UTF-8 text without line breaks (refused otherwise: a script cannot hold it).
fn text<'a>(path: &'a Path, what: &str) -> Result<&'a str> {
    let s = path.to_str().with_context(|| {
        format!(
            "the path of {what} ({}) is not UTF-8: a Slurm script cannot name it",
            path.display()
        )
    })?;
    if s.contains(['\n', '\r']) {
        bail!("the path of {what} ({s:?}) holds a line break: a Slurm script cannot name it");
    }
    Ok(s)
}

/// Writes an executable script (mode 0755).
fn write_script(path: &Path, text: &str) -> Result<()> {
    use std::os::unix::fs::PermissionsExt;
    crate::io::atomic::atomic_write(path, |w| Ok(std::io::Write::write_all(w, text.as_bytes())?))
        .with_context(|| format!("cannot write {}", path.display()))?;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755))
        .with_context(|| format!("cannot make {} executable", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    const SPEC: &str = "name: s\nseed: 3\ndatasets:\n  - id: d\n    kind: filtered_noise\n    \
        family: exponential\n    alpha_h: 1\n    alpha_v: 1\n    size: [8, 8]\n    samples: 20\n    \
        half_width: 3\nanalysis:\n  levels: 1\nsweep:\n  grid:\n    datasets.d.mean_im: [0.5, 2]\n";

    /// A folder with the spec `s.yaml` and options for `shards` shards into `out`.
    fn setup(out: &str, shards: usize) -> (tempfile::TempDir, SlurmOptions) {
        let dir = tempfile::tempdir().unwrap();
        let spec = dir.path().join("s.yaml");
        std::fs::write(&spec, SPEC).unwrap();
        let mut opts = SlurmOptions::new(spec, dir.path().join(out), shards).unwrap();
        opts.binary = dir.path().join("bin/isar-clutter");
        (dir, opts)
    }

    fn read(path: &Path) -> String {
        std::fs::read_to_string(path).unwrap()
    }

    /// Writes an executable shell script.
    fn script(path: &Path, body: &str) {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        write_script(path, &format!("#!/bin/sh\n{body}")).unwrap();
    }

    /// [`submit_with`] the fake `sbatch` just written, tried again while running it fails
    /// with "Text file busy": another test thread's child, forked while the script was open
    /// for writing, holds that descriptor until it executes its own program (a few
    /// milliseconds), and Linux refuses to run a file open for writing.
    fn submit_fake(fake: &Path, s: &Scripts) -> Result<(String, String)> {
        for _ in 0..200 {
            match submit_with(fake, s) {
                Err(e) if format!("{e:#}").contains("Text file busy") => {
                    std::thread::sleep(std::time::Duration::from_millis(10))
                }
                done => return done,
            }
        }
        submit_with(fake, s)
    }

    #[test]
    fn array_script_asks_for_one_task_per_shard_and_runs_the_shard() {
        let (dir, mut opts) = setup("out", 3);
        opts.cpus = 4;
        let s = write_scripts(&opts).unwrap();
        assert_eq!((s.shards, s.jobs), (3, 2));
        let out = dir.path().join("out");
        assert_eq!(s.array, out.join("slurm/array.sbatch"));
        let text = read(&s.array);
        assert!(
            text.starts_with("#!/usr/bin/env bash\n#SBATCH --array=0-2\n"),
            "{text}"
        );
        assert!(text.contains("#SBATCH --cpus-per-task=4\n"), "{text}");
        assert!(text.contains("#SBATCH --job-name=isar-s\n"), "{text}");
        let log = format!("#SBATCH --output={}/slurm/shard-%a.log\n", out.display());
        assert!(text.contains(&log), "{text}");
        assert!(text.contains("set -euo pipefail\n"), "{text}");
        assert!(
            text.contains(
                "exec \"$BINARY\" run \"$SPEC\" --out \"$OUT\" --shards 3 \
                 --jobs \"${SLURM_CPUS_PER_TASK:-4}\" --quiet\n"
            ),
            "{text}"
        );
        for absent in ["--partition", "--time", "--mem", "--dependency"] {
            assert!(!text.contains(absent), "{absent} in {text}");
        }
        let merge = read(&s.merge);
        assert!(
            merge.contains("#SBATCH --job-name=isar-s-merge\n"),
            "{merge}"
        );
        let log = format!("#SBATCH --output={}/slurm/merge.log\n", out.display());
        assert!(merge.contains(&log), "{merge}");
        assert!(
            merge
                .contains("exec \"$BINARY\" merge \"$OUT\" --jobs \"${SLURM_CPUS_PER_TASK:-4}\"\n"),
            "{merge}"
        );
        assert!(!merge.contains("--array"), "{merge}");
    }

    #[test]
    fn partition_time_and_memory_go_to_both_scripts() {
        let (_dir, mut opts) = setup("out", 1);
        opts.partition = Some("short".into());
        opts.time = Some("1:30:00".into());
        opts.mem = Some("8G".into());
        let s = write_scripts(&opts).unwrap();
        for path in [&s.array, &s.merge] {
            let text = read(path);
            for line in [
                "#SBATCH --partition=short\n",
                "#SBATCH --time=1:30:00\n",
                "#SBATCH --mem=8G\n",
            ] {
                assert!(text.contains(line), "{line} not in {text}");
            }
        }
        assert!(read(&s.array).contains("#SBATCH --array=0-0\n"));
    }

    /// Runs `script` with bash and a fake binary that writes its arguments, one a line.
    fn run_with_fake_binary(opts: &SlurmOptions, script: &Path, env: &[(&str, &str)]) -> String {
        let args = opts.binary.with_file_name("args.txt");
        script_file_args(&opts.binary, &args);
        let mut cmd = Command::new("bash");
        cmd.arg(script)
            .env_remove("SLURM_ARRAY_TASK_ID")
            .env_remove("SLURM_CPUS_PER_TASK");
        for (k, v) in env {
            cmd.env(k, v);
        }
        let o = cmd.output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        read(&args)
    }

    fn script_file_args(binary: &Path, args: &Path) {
        let quoted = shell_quote(args.to_str().unwrap());
        script(binary, &format!("printf '%s\\n' \"$@\" > {quoted}\n"));
    }

    #[test]
    fn paths_with_spaces_and_quotes_reach_the_binary_unchanged() {
        let (dir, mut opts) = setup("it's a \"results\" $HOME `x` folder", 2);
        opts.binary = dir.path().join("my bin's/isar-clutter");
        opts.cpus = 2;
        let s = write_scripts(&opts).unwrap();
        let out = dir.path().join("it's a \"results\" $HOME `x` folder");
        let spec = std::fs::canonicalize(dir.path().join("s.yaml")).unwrap();
        let args = run_with_fake_binary(&opts, &s.array, &[("SLURM_ARRAY_TASK_ID", "1")]);
        let want = format!(
            "run\n{}\n--out\n{}\n--shards\n2\n--jobs\n2\n--quiet\n",
            spec.display(),
            out.display()
        );
        assert_eq!(args, want);
        // Slurm's CPU count wins over the default.
        let args = run_with_fake_binary(
            &opts,
            &s.array,
            &[("SLURM_ARRAY_TASK_ID", "0"), ("SLURM_CPUS_PER_TASK", "7")],
        );
        assert!(args.contains("--jobs\n7\n"), "{args}");
        let args = run_with_fake_binary(&opts, &s.merge, &[]);
        assert_eq!(args, format!("merge\n{}\n--jobs\n2\n", out.display()));
        // The #SBATCH line double-quotes the log path, escaping its double quotes.
        let log = format!(
            "#SBATCH --output=\"{}/slurm/shard-%a.log\"\n",
            out.display().to_string().replace('"', "\\\"")
        );
        assert!(read(&s.array).contains(&log), "{}", read(&s.array));
    }

    #[test]
    fn the_array_script_refuses_to_run_outside_an_array_task() {
        let (_dir, opts) = setup("out", 2);
        let s = write_scripts(&opts).unwrap();
        script_file_args(&opts.binary, &opts.binary.with_file_name("args.txt"));
        let o = Command::new("bash")
            .arg(&s.array)
            .env_remove("SLURM_ARRAY_TASK_ID")
            .output()
            .unwrap();
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("not a Slurm array task"), "{err}");
        assert!(!opts.binary.with_file_name("args.txt").exists());
    }

    #[test]
    fn percent_signs_in_the_folder_are_not_slurm_patterns() {
        let (dir, opts) = setup("run%j", 1);
        let s = write_scripts(&opts).unwrap();
        let log = format!(
            "#SBATCH --output={}/run%%j/slurm/shard-%a.log\n",
            dir.path().display()
        );
        assert!(read(&s.array).contains(&log), "{}", read(&s.array));
    }

    #[test]
    fn bad_input_is_refused() {
        let (dir, mut opts) = setup("out", 0);
        let err = write_scripts(&opts).unwrap_err().to_string();
        assert!(err.contains("--shards must be at least 1"), "{err}");
        opts.shards = 2;
        opts.cpus = 0;
        let err = write_scripts(&opts).unwrap_err().to_string();
        assert!(err.contains("--cpus must be at least 1"), "{err}");
        opts.cpus = 1;
        opts.partition = Some("a b".into());
        let err = write_scripts(&opts).unwrap_err().to_string();
        assert!(err.contains("--partition \"a b\""), "{err}");
        opts.partition = None;
        std::fs::write(&opts.spec, SPEC.replace("samples: 20", "samples: many")).unwrap();
        let err = format!("{:#}", write_scripts(&opts).unwrap_err());
        assert!(err.contains("samples"), "{err}");
        opts.spec = dir.path().join("missing.yaml");
        let err = format!("{:#}", write_scripts(&opts).unwrap_err());
        assert!(err.contains("missing.yaml"), "{err}");
        assert!(
            !dir.path().join("out").exists(),
            "nothing written for bad input"
        );
    }

    #[test]
    fn the_folder_is_marked_and_a_foreign_one_refused() {
        let (dir, opts) = setup("out", 2);
        write_scripts(&opts).unwrap();
        let marker = read(&dir.path().join("out/.isar-clutter/owner.json"));
        assert!(marker.contains("\"name\": \"s\""), "{marker}");
        // Again (resubmitting): the folder is the experiment's now.
        write_scripts(&opts).unwrap();
        let (dir, opts) = setup("out", 2);
        std::fs::create_dir_all(dir.path().join("out")).unwrap();
        std::fs::write(dir.path().join("out/notes.txt"), "mine").unwrap();
        let err = format!("{:#}", write_scripts(&opts).unwrap_err());
        assert!(err.contains("not written by isar-clutter"), "{err}");
        assert!(!dir.path().join("out/slurm").exists());
        assert!(!dir.path().join("out/.isar-clutter").exists());
    }

    #[test]
    fn submit_chains_the_merge_job_after_the_array() {
        let (dir, opts) = setup("out", 3);
        let s = write_scripts(&opts).unwrap();
        let calls = dir.path().join("calls.txt");
        let fake = dir.path().join("fake/sbatch");
        let quoted = shell_quote(calls.to_str().unwrap());
        // The first call prints a cluster name after the id, the second not.
        script(
            &fake,
            &format!(
                "echo \"$*\" >> {quoted}\nif [ $(wc -l < {quoted}) = 1 ]; then echo '41;main'; \
                 else echo 42; fi\n"
            ),
        );
        assert_eq!(
            submit_fake(&fake, &s).unwrap(),
            ("41".to_string(), "42".to_string())
        );
        let want = format!(
            "--parsable {}\n--parsable --dependency=afterok:41 {}\n",
            s.array.display(),
            s.merge.display()
        );
        assert_eq!(read(&calls), want);
    }

    #[test]
    fn sbatch_failures_are_reported_with_their_stderr() {
        let (dir, opts) = setup("out", 3);
        let s = write_scripts(&opts).unwrap();
        let fake = dir.path().join("fake/sbatch");
        script(
            &fake,
            "echo 'sbatch: error: invalid partition specified: gpu' >&2\nexit 1\n",
        );
        let err = format!("{:#}", submit_fake(&fake, &s).unwrap_err());
        assert!(err.contains("invalid partition specified: gpu"), "{err}");
        assert!(err.contains("array.sbatch"), "{err}");
        // The merge submission fails after the array was accepted: say which job to cancel.
        let calls = dir.path().join("calls.txt");
        let quoted = shell_quote(calls.to_str().unwrap());
        script(
            &fake,
            &format!(
                "echo x >> {quoted}\nif [ $(wc -l < {quoted}) = 1 ]; then echo 7; \
                 else echo 'sbatch: error: busy' >&2; exit 1; fi\n"
            ),
        );
        let err = format!("{:#}", submit_fake(&fake, &s).unwrap_err());
        assert!(err.contains("scancel 7") && err.contains("busy"), "{err}");
        let missing = dir.path().join("no/sbatch");
        let err = format!("{:#}", submit_with(&missing, &s).unwrap_err());
        assert!(err.contains("not found"), "{err}");
    }

    #[test]
    fn job_ids_are_parsed_with_or_without_a_cluster() {
        assert_eq!(parse_job_id("123\n").as_deref(), Some("123"));
        assert_eq!(parse_job_id("123;cluster\n").as_deref(), Some("123"));
        assert_eq!(parse_job_id("warning\n77\n\n").as_deref(), Some("77"));
        assert_eq!(parse_job_id(""), None);
        assert_eq!(parse_job_id("Submitted batch job 5\n"), None);
    }
}
