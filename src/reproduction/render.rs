//! The Markdown of `docs/reproduction.md`: the run's wall time and machine at the top, the
//! text's claims judged, the count of verdicts by what an agreement can show and the largest
//! differences, then one block per dissertation table (each
//! cell's printed value, the tool's mean and spread, the difference and the verdict), and a
//! line for every table the reproduction does not cover, saying why.

use super::claims::{self, Claim, Judged};
use super::compare::{evidence, num, printed_num, Evidence, Verdict, REPEATS};
use super::evaluated::{Cell, Evaluated, Stated};
use super::reference::Dissertation;
use super::sections;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// What the top of the document states about the run that produced it.
#[derive(Debug, Clone)]
pub struct Header {
    /// The command that regenerates the document.
    pub command: String,
    /// Wall time of the last `reproduce` that ran into the folders, in seconds (`None`: not
    /// recorded). A resumed run's time is what it took to finish, not the whole.
    pub wall_s: Option<f64>,
    /// The machine, in words.
    pub machine: String,
    /// The tool's version and git state.
    pub tool: String,
    /// Repeats of the random statistics.
    pub repeats: usize,
    /// Repeats of the specs that train networks, where not `repeats`.
    pub cnn_repeats: Option<usize>,
    /// The builds that computed the results the document reads, with their job counts (from
    /// the run folders' manifests, `computed_by`; filled by [`super::write`]): the job store
    /// reuses a result whatever the tool's version, so these can differ from `tool`.
    pub builds: Vec<(String, usize)>,
    /// The plants' calibration records the run folders were computed with (first 12 hex
    /// digits of the manifests' SHA-256, or `not recorded`), with their run counts (filled by
    /// [`super::write`]): the stand-in plants' presets come from the record compiled in.
    pub plant_records: Vec<(String, usize)>,
    /// The run folders the document would read that are missing or incomplete, each with
    /// why (filled by [`super::write`]): the cells and claims that need them are not
    /// decidable.
    pub missing: Vec<String>,
    /// Per spec: its run folders, their jobs, and the jobs' own elapsed seconds summed and
    /// divided by each run's worker threads (filled by [`super::write`] from the manifests,
    /// [`super::runs::job_time`]).
    pub job_time: Vec<super::runs::JobTime>,
}

/// The machine this process runs on: CPU model, cores and memory (Linux; else the
/// architecture).
pub fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mem = std::fs::read_to_string("/proc/meminfo").ok().and_then(|t| {
        t.lines()
            .find(|l| l.starts_with("MemTotal:"))
            .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
    });
    match mem {
        Some(kb) => format!("{cpu}, {cores} cores, {:.0} GiB", kb / 1024.0 / 1024.0),
        None => format!("{cpu}, {cores} cores"),
    }
}

/// Why a table that has no recipe is not in the document.
fn not_covered(kind: &str) -> &'static str {
    if kind == "description" {
        "a description of data or settings, not a result: nothing to reproduce (the settings \
         it lists are those of the specs that use them)"
    } else {
        "not yet covered by `reproduce`"
    }
}

/// The document and the count of verdicts in it: the header, the summary (claims judged,
/// cells by what their agreement can show, the largest differences), the text's claims, the
/// constructions and calibration, then every table and the figures' statements.
pub fn document(
    dissertation: &Dissertation,
    evaluated: &[Evaluated],
    stated: &[Stated],
    judged: &[(Claim, Judged)],
    header: &Header,
) -> (String, BTreeMap<Verdict, usize>) {
    let mut s = String::new();
    top(&mut s, header);
    let _ = writeln!(s, "## Summary\n");
    claims::summary(&mut s, judged);
    let counts = cell_counts(&mut s, evaluated);
    largest(&mut s, dissertation, evaluated);
    claims::section(&mut s, judged);
    sections::constructions(&mut s);
    sections::calibration(&mut s);
    for t in &dissertation.tables {
        table_block(&mut s, t, evaluated);
    }
    figures(&mut s, dissertation, stated);
    (s, counts)
}

/// The title, how to read the verdicts, and the run's machine, tool, builds and wall time.
fn top(s: &mut String, header: &Header) {
    let _ = writeln!(s, "# Reproduction of the dissertation, number by number\n");
    let _ = writeln!(
        s,
        "Written by `{}` from the run folders it names; do not edit by hand. The reference \
         values are the dissertation's tables as printed (`reproduction/dissertation.yaml`); the \
         verdict rules are in `src/reproduction/compare.rs`: a random statistic `matches` when \
         the printed value lies within `2 sd sqrt(1 + 1/n)` of the mean of the tool's `n` \
         repeats (`sd` of one repeat, the printed value being one draw) plus half a unit of \
         the last printed digit; an exact one when it rounds to the printed value; else it \
         `differs`. Orderings are not judged cell by cell: the text's own claims are, across \
         methods and with a tie margin from the spread (`reproduction/claims.yaml`, \
         `src/reproduction/claims.rs`).\n",
        header.command
    );
    let _ = writeln!(s, "- Machine: {}", header.machine);
    let _ = writeln!(s, "- Tool: {}", header.tool);
    if !header.builds.is_empty() {
        let builds: Vec<String> = header
            .builds
            .iter()
            .map(|(b, n)| format!("{b} ({n} job(s))"))
            .collect();
        let _ = writeln!(s, "- Results computed by: {}", builds.join(", "));
    }
    if !header.plant_records.is_empty() {
        let compiled =
            crate::seeds::sha256_hex(crate::physics::vegetation::calibration::RECORD.as_bytes());
        let records: Vec<String> = header
            .plant_records
            .iter()
            .map(|(r, n)| format!("{r} ({n} run(s))"))
            .collect();
        let _ = writeln!(
            s,
            "- Plants' calibration record of the folders (SHA-256 of \
             reproduction/plant_calibration.json, recorded since 2026-11-29): {}; this build's: {}",
            records.join(", "),
            &compiled[..12]
        );
    }
    if !header.missing.is_empty() {
        let _ = writeln!(
            s,
            "- Run folders missing or incomplete ({}; the cells and claims that read them use \
             the other repeats, and are not decidable where none is left): {}",
            header.missing.len(),
            header.missing.join("; ")
        );
    }
    let _ = match header.wall_s {
        Some(w) => writeln!(
            s,
            "- Wall time of the last `reproduce` that ran into the folders: {w:.0} s"
        ),
        None => writeln!(s, "- Wall time of the runs: not recorded in the folders"),
    };
    job_time(s, &header.job_time);
    let cnn = match header.cnn_repeats {
        Some(c) if c != header.repeats => {
            format!(" ({c} for the specs that train networks, `--cnn-repeats {c}`)")
        }
        _ => String::new(),
    };
    let _ = writeln!(
        s,
        "- Repeats of each random statistic: {}{cnn}\n",
        header.repeats
    );
}

/// The count of cells by verdict and by what their agreement can show ([`Evidence`]); the
/// cells of tables that repeat another's ([`REPEATS`]) are counted once, at their source.
fn cell_counts(s: &mut String, evaluated: &[Evaluated]) -> BTreeMap<Verdict, usize> {
    let mut counts: BTreeMap<Verdict, usize> = BTreeMap::new();
    let mut by: BTreeMap<Evidence, (usize, usize)> = BTreeMap::new();
    for e in evaluated {
        if REPEATS.iter().any(|(n, _)| *n == e.number) {
            continue;
        }
        let kind = evidence(e.number, e.spread);
        for v in e.cells.iter().flatten().filter_map(|c| c.verdict) {
            *counts.entry(v).or_default() += 1;
            let entry = by.entry(kind).or_default();
            entry.1 += 1;
            if v == Verdict::Matches {
                entry.0 += 1;
            }
        }
    }
    let mut covered: Vec<u32> = evaluated.iter().map(|e| e.number).collect();
    covered.dedup();
    let _ = writeln!(
        s,
        "{} of the dissertation's 36 tables are compared cell by cell: {} cell(s) `matches`, \
         {} `differs` (Tables {} repeat other tables' cells and are counted there). What an \
         agreement shows depends on the cell:\n",
        covered.len(),
        counts.get(&Verdict::Matches).copied().unwrap_or(0),
        counts.get(&Verdict::Differs).copied().unwrap_or(0),
        REPEATS.map(|(n, _)| n.to_string()).join(" and ")
    );
    let _ = writeln!(s, "| cells | compared | matches |\n|---|---:|---:|");
    for (kind, (m, n)) in &by {
        let _ = writeln!(s, "| {} | {n} | {m} |", kind.as_str());
    }
    let _ = writeln!(s);
    counts
}

/// The compute time of the folders by spec, largest first: what a `make reproduce` from a clean
/// checkout takes on the machine that computed them, however many invocations filled them.
fn job_time(s: &mut String, time: &[super::runs::JobTime]) {
    if time.is_empty() {
        return;
    }
    let total: f64 = time.iter().map(|t| t.seconds).sum();
    let mut by: Vec<&super::runs::JobTime> = time.iter().collect();
    by.sort_by(|a, b| b.seconds.total_cmp(&a.seconds));
    let parts: Vec<String> = by
        .iter()
        .map(|t| {
            format!(
                "{} {:.0} s ({} run(s), {} job(s))",
                t.spec, t.seconds, t.runs, t.jobs
            )
        })
        .collect();
    let _ = writeln!(
        s,
        "- Compute time of the folders (each job's own elapsed time, summed and divided by its \
         run's worker threads; resumed runs counted whole): {total:.0} s; by spec: {}",
        parts.join(", ")
    );
}

/// The ten largest relative differences of the cells that do not match, then why, once for
/// each reason among them (the tables' own notes).
fn largest(s: &mut String, dissertation: &Dissertation, evaluated: &[Evaluated]) {
    let mut all: Vec<(f64, u32, String, String, f64, f64)> = Vec::new();
    for e in evaluated {
        let t = dissertation
            .table(e.number)
            .expect("evaluated from the reference");
        for (r, row) in e.cells.iter().enumerate() {
            for (c, cell) in row.iter().enumerate() {
                if cell.verdict != Some(Verdict::Differs) {
                    continue;
                }
                let (p, m) = (
                    cell.printed.unwrap_or(0.0),
                    cell.tool.map_or(0.0, |x| x.mean),
                );
                let rel = (m - p).abs() / p.abs().max(f64::MIN_POSITIVE);
                all.push((rel, e.number, t.rows[r].clone(), t.columns[c].clone(), p, m));
            }
        }
    }
    if all.is_empty() {
        return;
    }
    all.sort_by(|a, b| b.0.total_cmp(&a.0));
    let _ = writeln!(s, "The ten largest relative differences:\n");
    let _ = writeln!(s, "| table | row | column | printed | tool |");
    let _ = writeln!(s, "|---:|---|---|---:|---:|");
    for (_, n, row, col, p, m) in all.iter().take(10) {
        let _ = writeln!(s, "| {n} | {row} | {col} | {} | {} |", num(*p), num(*m));
    }
    let _ = writeln!(s);
    let mut reasons: Vec<(Vec<u32>, &str)> = Vec::new();
    for &(_, n, ..) in all.iter().take(10) {
        let Some(e) = evaluated.iter().find(|e| e.number == n) else {
            continue;
        };
        match reasons.iter_mut().find(|(_, r)| *r == e.differs_because) {
            Some((tables, _)) if tables.contains(&n) => {}
            Some((tables, _)) => tables.push(n),
            None => reasons.push((vec![n], e.differs_because)),
        }
    }
    for (tables, why) in reasons.iter().filter(|(_, r)| !r.is_empty()) {
        let names: Vec<String> = tables.iter().map(u32::to_string).collect();
        let _ = writeln!(s, "Why (Tables {}): {why}.\n", names.join(", "));
    }
}

/// The block of table `t`: its setting, then each cell beside the tool's, or why it is not
/// covered.
fn table_block(s: &mut String, t: &super::reference::Table, evaluated: &[Evaluated]) {
    let _ = writeln!(s, "## Table {}: {}\n", t.number, t.title);
    let _ = writeln!(s, "Dissertation §{}. {}\n", t.section, t.setting.trim());
    if let Some((_, source)) = REPEATS.iter().find(|(n, _)| *n == t.number) {
        let _ = writeln!(
            s,
            "Its cells repeat those of {source}: the same numbers, compared there too and \
             counted once in the summary.\n"
        );
    }
    let readings: Vec<&Evaluated> = evaluated.iter().filter(|e| e.number == t.number).collect();
    if readings.is_empty() {
        let _ = writeln!(s, "*{}.*\n", not_covered(&t.kind));
    }
    for e in readings {
        reading(s, t, e);
    }
}

/// One reading of table `t` (its protocol, where it has several): the sources, then each cell
/// beside the tool's.
fn reading(s: &mut String, t: &super::reference::Table, e: &Evaluated) {
    if let Some(p) = e.protocol {
        let title = p.split(':').next().unwrap_or(p);
        let _ = writeln!(s, "### {}\n", upper_first(title));
        let _ = writeln!(s, "{}.\n", upper_first(p));
    }
    let sources: Vec<String> = e
        .sources
        .iter()
        .map(|(spec, n)| format!("`experiments/{spec}.yaml` ({n} run(s))"))
        .collect();
    let _ = writeln!(s, "Tool: {}.", sources.join(", "));
    if !e.missing.is_empty() {
        let _ = writeln!(
            s,
            "Not read (missing or incomplete): {}.",
            e.missing.join("; ")
        );
    }
    if !e.differs_because.is_empty() {
        let _ = writeln!(s, "Where it differs: {}.", e.differs_because);
    }
    if let Some(note) = super::compare::fitted_note(e.number) {
        let _ = writeln!(s, "{note}.");
    }
    if let Some(floor) = &e.floor {
        let _ = writeln!(s, "\n{floor}.");
    }
    let _ = writeln!(s);
    let unit = if t.unit.is_empty() {
        String::new()
    } else {
        format!(" ({})", t.unit)
    };
    let _ = writeln!(
        s,
        "| row | column | printed{unit} | tool mean ± sd | difference | verdict |"
    );
    let _ = writeln!(s, "|---|---|---:|---:|---:|---|");
    for (r, row) in e.cells.iter().enumerate() {
        for (c, cell) in row.iter().enumerate() {
            let conclusion = e.spread == super::compare::Spread::Conclusion;
            let printed = match cell.printed {
                Some(p) if conclusion => if p > 0.5 { "verified" } else { "not verified" }.into(),
                p => p.map_or("-".into(), |v| printed_num(v, t.decimals(c))),
            };
            let tool = match cell.tool {
                Some(x) if conclusion => {
                    format!("verified in {} of {}", (x.mean * x.n as f64).round(), x.n)
                }
                None => "not computed".to_string(),
                Some(x) => x.show(),
            };
            let diff = cell.difference.map_or("-".into(), num);
            let verdict = cell.verdict.map_or("-", Verdict::as_str);
            let _ = writeln!(
                s,
                "| {} | {} | {printed} | {tool} | {diff} | {verdict} |",
                t.rows[r], t.columns[c]
            );
        }
    }
    let _ = writeln!(s);
    if e.protocol.is_some() {
        headline(s, t, e);
    }
}

/// The first training size whose accuracy is above the originals': `None` without a baseline,
/// `Some(None)` never.
type First = Option<Option<i64>>;

/// The CNN tables' headline (5.3.6-5.3.7: from some training size on, the generated data beat
/// the 100 originals), printed and by the tool: per generation method (rows 1-3), the first
/// training size whose mean accuracy exceeds the originals' (the last row's one cell), and
/// where Method 2 lies above Method 1.
fn headline(s: &mut String, t: &super::reference::Table, e: &Evaluated) {
    let (Some(original), true) = (e.cells.get(3).and_then(|r| r.first()), e.cells.len() == 4)
    else {
        return;
    };
    let sizes = super::cnn::SIZES;
    let printed = |c: &Cell| c.printed;
    let tool = |c: &Cell| c.tool.map(|x| x.mean);
    let first = |row: &[Cell], base: Option<f64>, v: &dyn Fn(&Cell) -> Option<f64>| {
        base.map(|base| {
            row.iter()
                .zip(sizes)
                .find(|(c, _)| v(c).is_some_and(|x| x > base))
                .map(|(_, n)| n)
        })
    };
    let words = |f: First| match f {
        None => "-".to_string(),
        Some(None) => "never".to_string(),
        Some(Some(n)) => format!("N = {n}"),
    };
    let first_above = |row: &[Cell], base: Option<f64>, v: &dyn Fn(&Cell) -> Option<f64>| {
        words(first(row, base, v))
    };
    let _ = writeln!(
        s,
        "Headline: the first training size at which a generation method's mean accuracy exceeds \
         the originals' ({} printed, {} here):\n",
        printed(original).map_or("-".into(), num),
        tool(original).map_or("-".into(), num)
    );
    for r in 0..3 {
        let row = &e.cells[r];
        let _ = writeln!(
            s,
            "- {}: printed {}, tool {}",
            t.rows[r],
            first_above(row, printed(original), &printed),
            first_above(row, tool(original), &tool)
        );
    }
    let above = |v: &dyn Fn(&Cell) -> Option<f64>| -> String {
        let sizes: Vec<String> = e.cells[1]
            .iter()
            .zip(&e.cells[0])
            .zip(sizes)
            .filter(|((m2, m1), _)| matches!((v(m2), v(m1)), (Some(a), Some(b)) if a > b))
            .map(|(_, n)| n.to_string())
            .collect();
        if sizes.is_empty() {
            "at no size".into()
        } else {
            format!("at N = {}", sizes.join(", "))
        }
    };
    let _ = writeln!(
        s,
        "- Method 2 above Method 1: printed {}, tool {}\n",
        above(&printed),
        above(&tool)
    );
    // The headline in plain words: for how many methods it holds here, and from which sizes.
    let firsts: Vec<(First, First)> = (0..3)
        .map(|r| {
            (
                first(&e.cells[r], printed(original), &printed),
                first(&e.cells[r], tool(original), &tool),
            )
        })
        .collect();
    plain_words(s, &firsts);
}

/// The headline in plain words, from each method's first size above the originals (printed,
/// tool): for how many methods it holds here, and from which sizes.
fn plain_words(s: &mut String, firsts: &[(First, First)]) {
    let held: Vec<i64> = firsts.iter().filter_map(|(_, t)| t.flatten()).collect();
    let printed_n: Vec<i64> = firsts.iter().filter_map(|(p, _)| p.flatten()).collect();
    if firsts.iter().any(|(_, t)| t.is_none()) {
        return;
    }
    let range = |v: &[i64]| {
        let (lo, hi) = (v.iter().min(), v.iter().max());
        match (lo, hi) {
            (Some(lo), Some(hi)) if lo == hi => format!("N = {lo}"),
            (Some(lo), Some(hi)) => format!("N = {lo}-{hi}"),
            _ => "no size".to_string(),
        }
    };
    let when = if firsts.iter().all(|(p, t)| p == t) {
        "at the printed sizes".to_string()
    } else if firsts
        .iter()
        .all(|(p, t)| matches!((p, t), (Some(Some(p)), Some(Some(t))) if t >= p))
    {
        format!(
            "no earlier than printed: from {} (the dissertation: {})",
            range(&held),
            range(&printed_n)
        )
    } else {
        format!(
            "from {} (the dissertation: {})",
            range(&held),
            range(&printed_n)
        )
    };
    if held.is_empty() {
        let _ = writeln!(
            s,
            "In plain words: the headline (generated data beat the originals from some \
             training size on) does not hold here: no method's networks beat the originals' at \
             any size.\n"
        );
        return;
    }
    let _ = writeln!(
        s,
        "In plain words: the headline (generated data beat the originals from some training \
         size on) holds here for {} of the 3 methods, {when}.\n",
        held.len()
    );
}

/// `p` with its first letter upper case.
fn upper_first(p: &str) -> String {
    let mut c = p.chars();
    c.next().map_or(String::new(), |f| {
        f.to_uppercase().collect::<String>() + c.as_str()
    })
}

/// Where a statement of the figures list is compared as a table's cells (the hypotheses'
/// verdicts are Table 24's rows, the classification plots are Tables 20 and 22), or why it is
/// not a result to compare: a construction the tool's specs take as stated, or an example.
fn elsewhere(quantity: &str) -> Option<&'static str> {
    const AT: [(&str, &str); 9] = [
        (
            "Hypothesis ",
            "compared as its row of Table 24 above (the same verdicts, 6.4).",
        ),
        (
            "Zero-mean classification",
            "compared in Table 20 above, with the headline under each protocol.",
        ),
        (
            "Zero-mean, unit-variance classification",
            "compared in Table 22 above, with the headline under each protocol.",
        ),
        (
            "Data behind the estimated directional correlations",
            "a construction, not a result: experiments/table4_exponential.yaml and \
             similarity_exponential.yaml analyse 1000 samples of 64 x 64 at 3 levels, as stated.",
        ),
        (
            "Ocean current multiscale analysis",
            "the ocean-current data are public (OSCAR third-degree, the DOI the table prints) \
             but cannot be downloaded on the machine the reproduction runs on: \
             experiments/ocean_currents.yaml reads OSCAR's own file layout once a user has \
             downloaded it (docs/definitions.md section 11), and \
             experiments/surface_winds.yaml runs the same four-level analysis on NOAA surface \
             winds that a Debian package ships (132 months of 73 x 144), a substitute, not a \
             reproduction.",
        ),
        (
            "Target location grid",
            "a construction, not a result: the tool's location experiments use the same 5 x 5 \
             grid of 25 classes (docs/spec.md, \"Location per job\").",
        ),
        (
            "Variance of the simulated clutter for the location experiment",
            "a figure of inputs: the tool's location specs fit on 100 of 1000 simulated samples, \
             the sample counts of the two panels.",
        ),
        (
            "Example stochastic-target powers",
            "example images, not a result: the tool's SCRs are the location specs' `scr_db`.",
        ),
        (
            "Deep learning prediction accuracy improvement (location example)",
            "the conclusion's restatement of Fig. 74: see its links above (5.3.9.3).",
        ),
    ];
    AT.iter()
        .find(|(start, _)| quantity.starts_with(start))
        .map(|(_, at)| *at)
}

/// The numbers the text states for figures, each with its quote.
fn figures(s: &mut String, dissertation: &Dissertation, stated: &[Stated]) {
    if !dissertation.figures.is_empty() {
        let _ = writeln!(s, "## Numbers the text states for figures\n");
        for f in &dissertation.figures {
            let value = f.value.as_ref().map_or("no number".into(), |v| {
                serde_yaml_ng::to_string(v)
                    .unwrap_or_default()
                    .trim()
                    .to_string()
            });
            let unit = f.unit.as_deref().unwrap_or("");
            let mine: Vec<&Stated> = stated
                .iter()
                .filter(|st| st.quantity == f.quantity)
                .collect();
            let tools: Vec<String> = mine
                .iter()
                .map(|st| {
                    if st.repeats == 0 {
                        return format!(
                            "the tool: not decidable: no complete run folder ({}; {}).",
                            if st.missing.is_empty() {
                                "none was given".to_string()
                            } else {
                                st.missing.join("; ")
                            },
                            st.computed
                        );
                    }
                    let mut over = if st.given == st.repeats {
                        format!("{} repeat(s)", st.repeats)
                    } else {
                        format!(
                            "the {} of {} repeats that give a value",
                            st.given, st.repeats
                        )
                    };
                    if st.bounded > 0 {
                        over = format!(
                            "{over}; a lower bound in {} of them: the level was already \
                             reached at the lowest point swept, or not yet at the highest by \
                             the network compared with",
                            st.bounded
                        );
                    }
                    let verdict = st.verdict.map_or(
                        if st.printed.is_some() {
                            "not decidable (a lower bound below the stated number)"
                        } else {
                            "no stated number to compare"
                        },
                        Verdict::as_str,
                    );
                    // A computed number (one evaluation, no spread) has no repeats to name.
                    let at_least = if st.bounded > 0 { "≥ " } else { "" };
                    let mut t = if st.exact {
                        let value = format!("{} {}", num(st.tool.mean), st.unit.unwrap_or(unit));
                        format!(
                            "the tool: {} (exact: {}): {verdict}.",
                            value.trim_end(),
                            st.computed,
                        )
                    } else {
                        let spread = if st.given == 1 {
                            " (one value: no spread yet)".to_string()
                        } else {
                            format!(" ± {}", num(st.tool.sd))
                        };
                        format!(
                            "the tool: {at_least}{}{spread} {} over {over} ({}): {verdict}.",
                            num(st.tool.mean),
                            st.unit.unwrap_or(unit),
                            st.computed,
                        )
                    };
                    if !st.differs_because.is_empty() {
                        t = format!("{t} {}.", st.differs_because);
                    }
                    t
                })
                .collect();
            let tool = if let (true, Some(at)) = (tools.is_empty(), elsewhere(&f.quantity)) {
                at.to_string()
            } else if tools.is_empty() {
                "not yet computed by `reproduce`.".to_string()
            } else {
                tools.join(" ")
            };
            let _ = writeln!(
                s,
                "- §{}: {}: {value} {unit} (\"{}\"); {tool}",
                f.section, f.quantity, f.quote
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The worked example of 4.3.1 is rendered as exact numbers (no spread, no repeats) with
    /// its verdicts, and its statements no longer read "not yet computed".
    #[test]
    fn the_solver_example_renders_as_exact_numbers() {
        let d = crate::reproduction::reference::Dissertation::load().unwrap();
        let stated = super::super::solver::method2_example(&d).unwrap();
        let mut s = String::new();
        figures(&mut s, &d, &stated);
        let line = |start: &str| {
            s.lines()
                .find(|l| l.contains(start))
                .unwrap_or_else(|| panic!("no line {start:?} in {s}"))
                .to_string()
        };
        let targets = line("Method 2 gradient descent");
        assert_eq!(targets.matches("(exact: ").count(), 6, "{targets}");
        assert_eq!(targets.matches(": matches.").count(), 6, "{targets}");
        let params = line("Method 2 filter shape parameters");
        assert_eq!(params.matches(": differs.").count(), 3, "{params}");
        assert!(params.contains("neither set of targets"), "{params}");
        assert!(!s.contains("± 0 "), "{s}");
    }

    /// The headline of Table 20 as printed (Methods 1 and 2 beat the originals' 83.3 % from
    /// 250 samples, full covariance from 100; Method 2 above Method 1 at every size) and of
    /// made-up tool values.
    #[test]
    fn the_cnn_headline_finds_the_first_size_above_the_originals() {
        use super::super::compare::{Spread, Summary};
        let d = crate::reproduction::reference::Dissertation::load().unwrap();
        let t = d.table(20).unwrap();
        let tool = [
            [50.0, 60.0, 90.0, 95.0],
            [55.0, 59.0, 91.0, 96.0],
            [85.0, 90.0, 95.0, 99.0],
            [80.0, f64::NAN, f64::NAN, f64::NAN],
        ];
        let cells = (0..4)
            .map(|r| {
                (0..4)
                    .map(|c| super::Cell {
                        printed: t.number_at(r, c),
                        tool: (r < 3 || c == 0).then(|| Summary::of(&[tool[r][c]])),
                        difference: None,
                        verdict: None,
                        tolerance: None,
                        first: None,
                    })
                    .collect()
            })
            .collect();
        let e = Evaluated {
            number: 20,
            sources: vec![],
            cells,
            spread: Spread::Random,
            differs_because: "",
            protocol: Some("test"),
            floor: None,
            missing: Vec::new(),
        };
        let mut s = String::new();
        headline(&mut s, t, &e);
        assert!(s.contains("(83.30 printed, 80.00 here)"), "{s}");
        let lines: Vec<&str> = s.lines().filter(|l| l.starts_with("- ")).collect();
        assert!(lines[0].ends_with("printed N = 250, tool N = 500"), "{s}");
        assert!(lines[1].ends_with("printed N = 250, tool N = 500"), "{s}");
        assert!(lines[2].ends_with("printed N = 100, tool N = 100"), "{s}");
        assert!(
            lines[3].ends_with("printed at N = 100, 250, 500, 1000, tool at N = 100, 500, 1000"),
            "{s}"
        );
        assert!(
            s.contains(
                "holds here for 3 of the 3 methods, no earlier than printed: from N = 100-500 (the \
                 dissertation: N = 100-250)."
            ),
            "{s}"
        );
    }

    #[test]
    fn numbers_print_with_four_significant_digits() {
        assert_eq!(num(0.648054), "0.6481");
        assert_eq!(num(21.5312), "21.53");
        assert_eq!(num(3.53e-6), "3.530e-6");
        assert_eq!(num(-0.0145), "-0.01450");
    }
}
