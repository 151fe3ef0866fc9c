//! The reproduction of the dissertation, number by number: `isar-clutter reproduce` runs the
//! specs under `experiments/` that the covered tables need, each repeated with other master
//! seeds (the spread of a random statistic is measured, not assumed), into
//! `outputs/reproduction/<spec>/seed-<seed>/`, and writes `docs/reproduction.md` from those
//! folders: every table of the dissertation with each cell's printed value, the tool's mean
//! and spread, the difference and a verdict ([`compare`]); the tables it does not cover yet
//! with the reason. What runs, and which folders are complete, is [`runs`]. The reference values are [`reference`] (transcribed once, compiled in);
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
pub mod runs;
pub mod sections;
pub mod solver;

use anyhow::{Context, Result};
use compare::{Spread, Summary, Verdict};
use evaluated::{Cell, Evaluated, Stated};
use extract::{Recipe, Tables};
use runs::{builds, complete_folders, folders, Coverage, Missing, SpecRuns};
use std::collections::BTreeMap;
use std::io::Write as _;
use std::path::Path;

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
        plant_records: runs::plant_records(runs),
        missing: missing.iter().map(Missing::show).collect(),
        job_time: runs::job_time(runs),
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
            let mut high = tables.value(folders(runs, a.spec)[k], a)?;
            if let Some(c) = st.censor.get(i) {
                bound |= low == tables.value(folders(runs, c.spec)[k], c)?;
            }
            if let Some(c) = st
                .censor_above
                .get(i)
                .filter(|_| high.is_nan() && low.is_finite())
            {
                high = tables.value(folders(runs, c.spec)[k], c)?;
                bound = true;
            }
            sum += high - low;
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
