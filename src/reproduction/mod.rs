//! The reproduction of the dissertation, number by number: `isar-clutter reproduce` runs the
//! specs under `experiments/` that the covered tables need, each repeated with other master
//! seeds (the spread of a random statistic is measured, not assumed), into
//! `outputs/reproduction/<spec>/seed-<seed>/`, and writes `docs/reproduction.md` from those
//! folders: every table of the dissertation with each cell's printed value, the tool's mean
//! and spread, the difference and a verdict ([`compare`]); the tables it does not cover yet
//! with the reason. The reference values are [`reference`] (transcribed once, compiled in);
//! where each cell is found in the outputs is [`extract`]; the page is [`render`], with
//! [`sections`] (the constructions the text leaves open, the stand-in's calibration) and
//! [`solver`] (4.3.1's worked example, computed rather than run).
//!
//! The runs go through the job store, so an interrupted reproduction resumes; the document is
//! written only when every folder it reads is a complete run (checked against its manifest),
//! and atomically.

pub mod calibrate;
pub mod claims;
pub mod cnn;
pub mod compare;
pub mod evaluated;
pub mod extract;
pub mod floors;
pub mod held_out;
pub mod ranking;
pub mod reference;
pub mod render;
pub mod sections;
pub mod solver;

use crate::run::{driver, options::RunOptions, plan};
use anyhow::{Context, Result};
use compare::{Spread, Summary, Verdict};
use evaluated::{Cell, Evaluated, Stated};
use extract::{Recipe, Tables};
use std::collections::BTreeMap;
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// What `reproduce` does.
#[derive(Debug, Clone)]
pub struct Options {
    /// Where the runs go (`outputs/reproduction`).
    pub out: PathBuf,
    /// The folder of the specs (`experiments`).
    pub specs: PathBuf,
    /// Runs of each spec whose statistics are random (the first with the spec's own seed).
    pub repeats: usize,
    /// Runs of each such spec that trains networks ([`trains_networks`]; `None`: `repeats`).
    pub cnn_repeats: Option<usize>,
    /// Worker threads of each run.
    pub threads: usize,
    /// Only write the document from the folders there (run nothing).
    pub write_only: bool,
    /// Run only these specs (file stems; empty: every spec the coverage needs).
    pub only: Vec<String>,
    /// No progress output.
    pub quiet: bool,
}

/// What the reproduction covers: the tables' recipes and the computed statements.
#[derive(Debug, Clone)]
pub struct Coverage {
    /// Tables, cell by cell.
    pub recipes: Vec<Recipe>,
    /// Numbers the text states.
    pub statements: Vec<extract::Statement>,
    /// Whether the worked example of Method 2's solver (4.3.1, [`solver`]) is computed.
    pub solver: bool,
}

impl Coverage {
    /// Everything [`extract`] and [`cnn`] know.
    pub fn all() -> Coverage {
        Coverage {
            recipes: all_recipes(),
            statements: cnn::gain_statements()
                .into_iter()
                .chain(extract::statements())
                .chain(cnn::stochastic_location())
                .collect(),
            solver: true,
        }
    }

    /// Only the tables `numbers` (no statements): a quick check.
    pub fn tables(numbers: &[u32]) -> Coverage {
        Coverage {
            recipes: all_recipes()
                .into_iter()
                .filter(|r| numbers.contains(&r.number))
                .collect(),
            statements: Vec::new(),
            solver: false,
        }
    }
}

/// Every table's recipes: [`extract`]'s, then the CNN tables'.
fn all_recipes() -> Vec<Recipe> {
    let mut r = extract::recipes();
    r.extend(cnn::recipes());
    r
}

/// The master seed of repeat `k` of a spec whose own seed is `seed`: the spec's for the first,
/// then seeds derived from it (recorded in each run's manifest).
pub fn repeat_seed(seed: u64, k: usize) -> u64 {
    if k == 0 {
        seed
    } else {
        crate::seeds::derive_seed(seed, "repeat", &k.to_string())
    }
}

/// The runs of one spec: `(seed, folder)` per repeat.
#[derive(Debug, Clone)]
pub struct SpecRuns {
    /// The spec's name (file stem).
    pub spec: &'static str,
    /// One per repeat.
    pub runs: Vec<(u64, PathBuf)>,
}

/// Whether `spec` trains networks (the CNN specs, `cnn_*`): a repeat of one trains dozens,
/// and they dominate a reproduction's time.
pub fn trains_networks(spec: &str) -> bool {
    spec.starts_with("cnn_")
}

/// The specs the recipes need, each with its number of repeats (1 where every table reading
/// it is exact; `cnn_repeats`, where given, for the specs that train networks and repeat).
pub fn needed(
    coverage: &Coverage,
    repeats: usize,
    cnn_repeats: Option<usize>,
) -> BTreeMap<&'static str, usize> {
    let mut specs = needed_at(coverage, repeats);
    if let Some(c) = cnn_repeats {
        for (spec, n) in specs.iter_mut() {
            if trains_networks(spec) && *n > 1 {
                *n = c.max(1);
            }
        }
    }
    specs
}

/// [`needed`] with one number of repeats for every spec that repeats.
fn needed_at(coverage: &Coverage, repeats: usize) -> BTreeMap<&'static str, usize> {
    let mut specs = BTreeMap::new();
    for s in &coverage.statements {
        for (a, b) in &s.terms {
            for spec in [a.spec, b.spec] {
                specs.insert(spec, repeats.max(1));
            }
        }
    }
    for r in &coverage.recipes {
        let n = match r.spread {
            Spread::Exact => 1,
            _ if r.runs_once() => 1,
            Spread::Random | Spread::Conclusion => repeats.max(1),
        };
        for s in extract::specs_of(r) {
            let e = specs.entry(s).or_insert(1);
            *e = (*e).max(n);
        }
    }
    specs
}

/// Runs (or resumes) every repeat of every needed spec; the folders.
///
/// # Errors
/// If a spec cannot be loaded or a run fails as a whole (a failed job is reported by the
/// document writer, which refuses the folder), or `only` names a spec the coverage does not
/// need.
pub fn run_all(opts: &Options, coverage: &Coverage) -> Result<Vec<SpecRuns>> {
    let needed = needed(coverage, opts.repeats, opts.cnn_repeats);
    if let Some(o) = opts.only.iter().find(|o| !needed.contains_key(o.as_str())) {
        let names: Vec<&str> = needed.keys().copied().collect();
        anyhow::bail!(
            "--only {o}: not a spec the document needs (it needs {})",
            names.join(", ")
        );
    }
    let mut all = Vec::new();
    for (spec, repeats) in needed {
        if !opts.only.is_empty() && !opts.only.iter().any(|o| o == spec) {
            continue;
        }
        let file = opts.specs.join(format!("{spec}.yaml"));
        let base = plan::load(&file)?.spec.seed;
        let mut runs = Vec::new();
        for k in 0..repeats {
            let seed = repeat_seed(base, k);
            let dir = opts.out.join(spec).join(format!("seed-{seed}"));
            if !opts.write_only {
                let plan = plan::load_seeded(&file, (k > 0).then_some(seed))?;
                let mut ro = RunOptions::new(dir.clone(), opts.threads);
                ro.quiet = opts.quiet;
                ro.report_follows = false;
                let summary = driver::run(&plan, &ro)
                    .with_context(|| format!("running {} (seed {seed})", file.display()))?;
                if !opts.quiet {
                    eprintln!(
                        "{spec} seed {seed}: {}/{} job(s) ok in {:.1} s",
                        summary.total - summary.failed.len(),
                        summary.total,
                        summary.elapsed_s
                    );
                }
            }
            runs.push((seed, dir));
        }
        all.push(SpecRuns { spec, runs });
    }
    Ok(all)
}

/// Evaluates `recipe` against the printed `table` over the runs in `runs`.
///
/// # Errors
/// If a folder is not a complete run, or a cell's query selects no single row (the file and
/// the query are named).
pub fn evaluate(
    recipe: &Recipe,
    table: &reference::Table,
    runs: &[SpecRuns],
    tables: &mut Tables,
) -> Result<Evaluated> {
    let mut cells = Vec::new();
    for (r, row) in recipe.cells.iter().enumerate() {
        let mut out = Vec::new();
        for (c, query) in row.iter().enumerate() {
            let printed = match recipe.spread {
                Spread::Conclusion => table.conclusion_at(r, c),
                _ => table.number_at(r, c),
            };
            let mut first = None;
            let tool = match query {
                None => None,
                Some(q) => {
                    let values = folders(runs, q.spec)
                        .into_iter()
                        .map(|d| tables.values(d, q))
                        .collect::<Result<Vec<Vec<f64>>>>()
                        .with_context(|| {
                            format!("Table {}, row {}, column {}", table.number, r + 1, c + 1)
                        })?
                        .concat();
                    first = values.first().copied();
                    (!values.is_empty()).then(|| Summary::of(&values))
                }
            };
            let (difference, tolerance, verdict) = match (printed, tool) {
                (Some(p), Some(t)) => {
                    let tol = compare::tolerance(recipe.spread, &t, table.decimals(c));
                    (
                        Some(t.mean - p),
                        Some(tol),
                        Some(compare::verdict(p, t.mean, tol)),
                    )
                }
                _ => (None, None, None),
            };
            out.push(Cell {
                printed,
                tool,
                difference,
                verdict,
                tolerance,
                first,
            });
        }
        cells.push(out);
    }
    let sources = extract::specs_of(recipe)
        .into_iter()
        .map(|s| (s.to_string(), folders(runs, s).len()))
        .collect();
    Ok(Evaluated {
        number: recipe.number,
        sources,
        cells,
        differs_because: recipe.differs_because,
        spread: recipe.spread,
        protocol: recipe.protocol,
        floor: None,
        missing: Vec::new(),
    })
}

/// The folders of `spec`'s repeats, in repeat order.
fn folders<'a>(runs: &'a [SpecRuns], spec: &str) -> Vec<&'a Path> {
    runs.iter()
        .filter(|r| r.spec == spec)
        .flat_map(|r| r.runs.iter().map(|(_, d)| d.as_path()))
        .collect()
}

/// A run folder the document would read but cannot: not run yet, or its run incomplete.
#[derive(Debug, Clone)]
pub struct Missing {
    /// The spec (file stem).
    pub spec: &'static str,
    /// The folder.
    pub dir: PathBuf,
    /// Why it cannot be read, in words.
    pub why: String,
}

impl Missing {
    /// `OUT/spec/seed-N (why)`, for the document.
    pub fn show(&self) -> String {
        format!("{} ({})", self.dir.display(), self.why)
    }
}

/// Splits `runs` into the complete folders and the missing ones: a folder that does not exist,
/// has no manifest or holds a run in progress is missing (its cells and claims are then not
/// decidable, naming it); a finished folder whose files changed since is damaged, and refused.
///
/// # Errors
/// Naming the first damaged folder.
pub fn complete_folders(runs: &[SpecRuns]) -> Result<(Vec<SpecRuns>, Vec<Missing>)> {
    let mut complete = Vec::new();
    let mut missing = Vec::new();
    for r in runs {
        let mut kept = Vec::new();
        for (seed, dir) in &r.runs {
            let Err(e) = crate::io::outdir::check_complete(dir) else {
                kept.push((*seed, dir.clone()));
                continue;
            };
            let absent = !dir.is_dir()
                || !dir.join("manifest.json").is_file()
                || dir
                    .join(crate::io::outdir::STATE)
                    .join("in-progress")
                    .exists();
            if !absent {
                return Err(e).with_context(|| {
                    format!(
                        "the reproduction reads {}: run `isar-clutter reproduce` again to redo it",
                        dir.display()
                    )
                });
            }
            let why = if dir.is_dir() {
                let text = format!("{e:#}");
                let text = text
                    .strip_prefix(&format!("{} ", dir.display()))
                    .unwrap_or(&text)
                    .to_string();
                text.split("; ").next().unwrap_or_default().to_string()
            } else {
                "not run".to_string()
            };
            missing.push(Missing {
                spec: r.spec,
                dir: dir.clone(),
                why,
            });
        }
        complete.push(SpecRuns {
            spec: r.spec,
            runs: kept,
        });
    }
    Ok((complete, missing))
}

/// Evaluates every recipe and writes the document to `doc` (atomically); the counts of
/// verdicts, and the folders it names as missing or incomplete ([`complete_folders`]).
///
/// # Errors
/// If a folder is damaged (nothing is written then), or the document cannot be written.
pub fn write(
    coverage: &Coverage,
    runs: &[SpecRuns],
    doc: &Path,
    header: &render::Header,
) -> Result<(BTreeMap<Verdict, usize>, Vec<Missing>)> {
    let (complete, missing) = complete_folders(runs)?;
    let runs = complete.as_slice();
    let dissertation = reference::Dissertation::load()?;
    let mut tables = Tables::default();
    let mut evaluated = Vec::new();
    for recipe in &coverage.recipes {
        let table = dissertation
            .table(recipe.number)
            .with_context(|| format!("Table {} is not in the reference", recipe.number))?;
        let mut e = evaluate(recipe, table, runs, &mut tables)?;
        e.missing = missing_of(&missing, extract::specs_of(recipe));
        evaluated.push(e);
    }
    let mut stated = coverage
        .statements
        .iter()
        .map(|st| {
            let mut specs: Vec<&str> = st
                .terms
                .iter()
                .flat_map(|(a, b)| [a.spec, b.spec])
                .collect();
            specs.sort_unstable();
            specs.dedup();
            let absent = missing_of(&missing, specs.iter().copied());
            if absent.is_empty() || specs.len() == 1 {
                let mut out = evaluate_statement(st, &dissertation, runs, &mut tables)?;
                out.missing = absent;
                Ok(out)
            } else {
                // Repeats of several specs pair by their order: with a folder missing the
                // pairs would shift, so the statement waits for every folder.
                unpaired_statement(st, &dissertation, absent)
            }
        })
        .collect::<Result<Vec<_>>>()?;
    if coverage.solver {
        stated.extend(solver::method2_example(&dissertation)?);
    }
    let header = render::Header {
        builds: builds(runs),
        missing: missing.iter().map(Missing::show).collect(),
        ..header.clone()
    };
    let floors = floors::kl_floors(&mut tables, &|spec| folders(runs, spec))?;
    for e in &mut evaluated {
        e.floor = floors.get(&e.number).cloned();
    }
    let claims = claims::Claims::load(&dissertation)?;
    let judged: Vec<(claims::Claim, claims::Judged)> = claims
        .claims
        .iter()
        .cloned()
        .zip(claims::judge_all(
            &dissertation,
            &claims,
            &evaluated,
            &stated,
        ))
        .collect();
    let (mut text, counts) = render::document(&dissertation, &evaluated, &stated, &judged, &header);
    if let Some(block) = held_out::block(&mut tables, &|spec| folders(runs, spec))? {
        text.push('\n');
        text.push_str(&block);
    }
    if let Some(block) = ranking::block(&mut tables, &|spec| folders(runs, spec))? {
        text.push('\n');
        text.push_str(&block);
    }
    let values = doc.with_extension("json");
    crate::io::atomic::atomic_write(&values, |w| {
        serde_json::to_writer_pretty(&mut *w, &tool_values(&evaluated))?;
        w.write_all(b"\n")?;
        Ok(())
    })
    .with_context(|| format!("writing {}", values.display()))?;
    crate::io::atomic::atomic_write(doc, |w| {
        w.write_all(text.as_bytes())?;
        Ok(())
    })
    .with_context(|| format!("writing {}", doc.display()))?;
    Ok((counts, missing))
}

/// The tool's numbers of every evaluated table, for the file beside the document
/// (`docs/reproduction.json`) that the quick tests compare a fresh run with: per table (and
/// reading, `protocol`), rows of cells, each `null` (not computed) or `{first, mean, sd, n}` (`first`: the repeat of the
/// spec's own seed).
pub fn tool_values(evaluated: &[Evaluated]) -> serde_json::Value {
    let tables: Vec<serde_json::Value> = evaluated
        .iter()
        .map(|e| {
            let rows: Vec<Vec<serde_json::Value>> = e
                .cells
                .iter()
                .map(|row| {
                    row.iter()
                        .map(|c| match (c.tool, c.first) {
                            (Some(t), Some(first)) => serde_json::json!({
                                "first": first,
                                "mean": t.mean,
                                "sd": t.sd,
                                "n": t.n,
                            }),
                            _ => serde_json::Value::Null,
                        })
                        .collect()
                })
                .collect();
            serde_json::json!({ "number": e.number, "protocol": e.protocol, "cells": rows })
        })
        .collect();
    serde_json::json!({ "format": "isar-clutter-reproduction-values/1", "tables": tables })
}

/// Records the wall time of the runs that filled `out` (`out/reproduce-run.json`), so that a
/// document written later from the same folders (`--write-only`) states it.
///
/// # Errors
/// If the record cannot be written.
pub fn record_wall(out: &Path, wall_s: f64, repeats: usize) -> Result<()> {
    let record = serde_json::json!({ "wall_s": wall_s, "repeats": repeats });
    crate::io::atomic::atomic_write(&out.join("reproduce-run.json"), |w| {
        serde_json::to_writer_pretty(&mut *w, &record)?;
        Ok(())
    })
}

/// The builds of the tool that computed the jobs of every run folder in `runs` (the manifests'
/// `computed_by`; `not recorded` for a job without it), with their job counts.
pub fn builds(runs: &[SpecRuns]) -> Vec<(String, usize)> {
    let mut count: BTreeMap<String, usize> = BTreeMap::new();
    for (_, dir) in runs.iter().flat_map(|r| &r.runs) {
        let Ok(m) = crate::io::manifest::Manifest::read(dir) else {
            continue;
        };
        for job in &m.jobs {
            let b = job.computed_by.as_deref().unwrap_or("not recorded");
            *count.entry(b.to_string()).or_default() += 1;
        }
    }
    count.into_iter().collect()
}

/// The wall time [`record_wall`] recorded in `out`, if any.
pub fn recorded_wall(out: &Path) -> Option<f64> {
    let text = std::fs::read(out.join("reproduce-run.json")).ok()?;
    serde_json::from_slice::<serde_json::Value>(&text).ok()?["wall_s"].as_f64()
}

/// Evaluates `st`: per repeat `k`, the mean over its terms of `a - b`, each read from repeat
/// `k` of its spec.
///
/// # Errors
/// If a query selects no single row, or the specs have unequal repeats.
pub fn evaluate_statement(
    st: &extract::Statement,
    dissertation: &reference::Dissertation,
    runs: &[SpecRuns],
    tables: &mut Tables,
) -> Result<Stated> {
    let repeats = st
        .terms
        .iter()
        .flat_map(|(a, b)| [folders(runs, a.spec).len(), folders(runs, b.spec).len()])
        .min()
        .unwrap_or(0);
    if repeats == 0 {
        return unpaired_statement(st, dissertation, Vec::new());
    }
    let mut values = Vec::new();
    let mut bounded = 0;
    for k in 0..repeats {
        let mut sum = 0.0;
        let mut bound = false;
        for (i, (a, b)) in st.terms.iter().enumerate() {
            let low = tables.value(folders(runs, b.spec)[k], b)?;
            sum += tables.value(folders(runs, a.spec)[k], a)? - low;
            if let Some(c) = st.censor.get(i) {
                bound |= low == tables.value(folders(runs, c.spec)[k], c)?;
            }
        }
        let v = sum / st.terms.len() as f64;
        bounded += usize::from(bound && v.is_finite());
        values.push(v);
    }
    // A repeat without a value (a level never reached in the range swept) is counted, not
    // averaged.
    let repeats = values.len();
    values.retain(|v| v.is_finite());
    let given = values.len();
    if values.is_empty() {
        values.push(f64::NAN);
    }
    let reference = stated_reference(st, dissertation)?;
    let (quantity, printed) = (reference.quantity.clone(), reference.number());
    // A bound (`< 1`): the tool's mean below it matches.
    let bound = reference
        .value
        .as_ref()
        .and_then(serde_yaml_ng::Value::as_str)
        .and_then(|t| t.trim().strip_prefix('<'))
        .and_then(|b| b.trim().parse::<f64>().ok());
    let tool = Summary::of(&values);
    let verdict = match (printed, bound) {
        // A lower bound below the stated number does not tell.
        (Some(p), _) if bounded > 0 && tool.mean < p => None,
        (Some(p), _) => {
            let tol =
                compare::tolerance(Spread::Random, &tool, compare::decimals_of(&format!("{p}")));
            Some(compare::verdict(p, tool.mean, tol))
        }
        (None, Some(b)) if tool.mean < b => Some(Verdict::Matches),
        (None, Some(_)) => Some(Verdict::Differs),
        (None, None) if st.ordering && tool.mean > 0.0 => Some(Verdict::OrderingHolds),
        (None, None) if st.ordering => Some(Verdict::Differs),
        (None, None) => None,
    };
    Ok(Stated {
        quantity,
        tool,
        printed,
        verdict,
        computed: st.computed.to_string(),
        differs_because: st.differs_because.to_string(),
        unit: st.unit,
        repeats,
        given,
        bounded,
        exact: false,
        missing: Vec::new(),
    })
}

/// The reference's statement of `st`'s quantity.
fn stated_reference<'a>(
    st: &extract::Statement,
    dissertation: &'a reference::Dissertation,
) -> Result<&'a reference::FigureStatement> {
    dissertation
        .figures
        .iter()
        .find(|f| f.quantity.starts_with(st.quantity))
        .with_context(|| format!("no statement {:?} in the reference", st.quantity))
}

/// `st` without a value: the folders in `missing` that it reads are not complete runs.
fn unpaired_statement(
    st: &extract::Statement,
    dissertation: &reference::Dissertation,
    missing: Vec<String>,
) -> Result<Stated> {
    let reference = stated_reference(st, dissertation)?;
    Ok(Stated {
        quantity: reference.quantity.clone(),
        tool: Summary::of(&[f64::NAN]),
        printed: reference.number(),
        verdict: None,
        computed: st.computed.to_string(),
        differs_because: st.differs_because.to_string(),
        unit: st.unit,
        repeats: 0,
        given: 0,
        bounded: 0,
        exact: false,
        missing,
    })
}

/// The folders of `missing` that belong to one of `specs`, as the document names them.
fn missing_of<'a>(missing: &[Missing], specs: impl IntoIterator<Item = &'a str>) -> Vec<String> {
    let specs: Vec<&str> = specs.into_iter().collect();
    missing
        .iter()
        .filter(|m| specs.contains(&m.spec))
        .map(Missing::show)
        .collect()
}
