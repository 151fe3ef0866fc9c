//! The run's tables assembled by streaming: every table's fragments (the job store's packs and
//! the jobs' status rows) are appended in plan order to a Parquet writer, a row group at a time,
//! so that a merge holds at most one row group per table and the fragments of the jobs in
//! flight, however many jobs the plan has (and of the rows written, only each column chunk's
//! footer entry: [`GroupWriter`]).
//!
//! The result is, byte for byte, the file that concatenating every fragment in memory and
//! writing it with polars' writer a row group of [`ROW_GROUP`] rows at a time gives (the oracle
//! in this module's tests): the same columns (those of the widest fragment, nulls where a
//! fragment lacks one), the same rows, and row groups of [`ROW_GROUP`] rows (the last one
//! takes the remainder), because the records tell each table's height before any fragment is
//! read. The values are those of the tool up to store schema 2, which wrote with polars'
//! default of 262,144 rows a group: a merge holds up to a group of every table at once (all of
//! them at its end), and with that default a 100,000-job merge peaked at 850 MB. Groups of
//! fixed height (not polars' split of a whole table into equal groups, up to twice as high)
//! keep what a table holds bounded whatever its height: the one-row-a-job `jobs` table of
//! 100,000 jobs waited whole for its single group.

use crate::io::atomic::Staged;
use crate::io::groups::{Encoding, GroupWriter};
use anyhow::{bail, Context, Result};
use polars::prelude::{
    Column, DataFrame, DataType, IntoColumn, ParquetCompression, PlSmallStr, StringChunked,
};
use std::path::Path;

/// The row-group size the tables are written with (polars' default is `512 * 512`; see the
/// module's note). 65,536 rows of the largest table, `analysis_maps`, are about 1 MB of
/// Parquet, a usual size for readers (DuckDB writes 122,880 rows a group). Smaller is not
/// leaner: the writer keeps every group's footer entry (a few hundred bytes a column; polars'
/// own writer kept about 2.4 KB more, see [`GroupWriter`]) until the end, and larger groups
/// cost more in flight (with polars' writer, a 30,000-job merge peaked at 158 MB with 32,768
/// rows, 157 MB with 65,536, 271 MB with 262,144).
pub const ROW_GROUP: usize = 65_536;

/// What the records say of one table before any fragment is read.
#[derive(Debug, Clone)]
pub struct TableLayout {
    /// The table's name (its file is `<name>.parquet`).
    pub name: String,
    /// Fragments seen.
    pub parts: usize,
    /// Rows in all of them.
    pub rows: usize,
    /// Columns of the widest fragment so far.
    pub columns: usize,
    /// Where the widest fragment is (the last of equal width, in plan order).
    pub widest: Option<Widest>,
}

/// Where a table's widest fragment is.
#[derive(Debug, Clone)]
pub enum Widest {
    /// Fragment `index` of the pack of job `job` (plan order).
    Stored {
        /// The job's index in the plan.
        job: usize,
        /// The fragment's index in the job's record.
        index: usize,
    },
    /// A fragment made by the merge itself (a job's status row), kept with its rows dropped.
    Made(DataFrame),
}

/// Every table of a run, in the order of first appearance.
#[derive(Debug, Clone, Default)]
pub struct Layout {
    /// The tables.
    pub tables: Vec<TableLayout>,
}

impl Layout {
    /// A layout with `names` (the standard tables, present even when empty) first.
    pub fn new<'a>(names: impl IntoIterator<Item = &'a str>) -> Self {
        let mut layout = Layout::default();
        for n in names {
            layout.table(n);
        }
        layout
    }

    /// The entry of `name`, made when new. Names starting with `_` are intermediate rows and
    /// never become tables: `None`.
    fn table(&mut self, name: &str) -> Option<&mut TableLayout> {
        if name.starts_with('_') {
            return None;
        }
        let at = match self.tables.iter().position(|t| t.name == name) {
            Some(at) => at,
            None => {
                self.tables.push(TableLayout {
                    name: name.to_string(),
                    parts: 0,
                    rows: 0,
                    columns: 0,
                    widest: None,
                });
                self.tables.len() - 1
            }
        };
        Some(&mut self.tables[at])
    }

    /// Counts a stored fragment: `(job, index)` in the plan and its record.
    pub fn stored(&mut self, table: &str, columns: usize, rows: usize, job: usize, index: usize) {
        if let Some(t) = self.table(table) {
            t.parts += 1;
            t.rows += rows;
            if t.widest.is_none() || columns >= t.columns {
                t.columns = columns;
                t.widest = Some(Widest::Stored { job, index });
            }
        }
    }

    /// Counts a fragment the merge makes itself (a status row).
    pub fn made(&mut self, table: &str, df: &DataFrame) {
        if let Some(t) = self.table(table) {
            t.parts += 1;
            t.rows += df.height();
            if t.widest.is_none() || df.width() >= t.columns {
                t.columns = df.width();
                t.widest = Some(Widest::Made(df.clear()));
            }
        }
    }
}

/// The heights of the row groups of a table of `rows` rows: [`ROW_GROUP`] rows each, the last
/// one the remainder (one empty group for an empty table).
pub fn row_groups(rows: usize) -> Vec<usize> {
    let mut groups = vec![ROW_GROUP; rows / ROW_GROUP];
    if !rows.is_multiple_of(ROW_GROUP) || rows == 0 {
        groups.push(rows % ROW_GROUP);
    }
    groups
}

/// Fragments waiting for their row group are stacked into one every this many: a decoded
/// fragment's strings sit in a buffer of at least a few kilobytes however few they are (a
/// tiny job's one-row status used 16 KB), and a small table's fragments all wait until the
/// end, so 100,000 jobs held gigabytes of nearly empty buffers.
const COMPACT: usize = 256;

/// `parts` stacked into one fragment of one chunk, each string column copied into a fresh
/// array (one buffer, the strings alone), so that the parts' buffers are freed.
fn compact(parts: Vec<DataFrame>) -> Result<DataFrame> {
    let mut parts = parts.into_iter();
    let Some(mut df) = parts.next() else {
        return Ok(DataFrame::empty());
    };
    for p in parts {
        df.vstack_mut_owned(p)?;
    }
    df.rechunk_mut();
    let columns = df
        .columns()
        .iter()
        .map(|c| {
            Ok(match c.dtype() {
                DataType::String => {
                    let ca = c.str()?;
                    let fresh: StringChunked = ca.iter().collect();
                    fresh.with_name(c.name().clone()).into_column()
                }
                _ => c.clone(),
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(DataFrame::new_infer_height(columns)?)
}

/// One table being written: its columns, the rows not written yet, the heights of the row
/// groups still to come.
pub struct Sink {
    name: String,
    columns: Vec<(PlSmallStr, DataType)>,
    /// Fragments (aligned) not written yet, and their rows. Kept apart, not stacked: a
    /// stacked string column keeps every fragment's buffers, and slicing a row group off it
    /// freed none of them, so memory grew with the jobs (45 KB a tiny job).
    pending: std::collections::VecDeque<DataFrame>,
    pending_rows: usize,
    /// Fragments pushed since the last [`compact`].
    uncompacted: usize,
    groups: std::collections::VecDeque<usize>,
    writer: GroupWriter<Staged>,
}

impl Sink {
    /// Starts `<name>.parquet` in `out` with the columns of `widest` and the row groups of a
    /// table of `rows` rows.
    ///
    /// # Errors
    /// If the writer cannot be made for these columns.
    pub fn new(out: &Path, name: &str, widest: &DataFrame, rows: usize) -> Result<Sink> {
        let writer = GroupWriter::new(
            Staged::hashed(&out.join(format!("{name}.parquet"))),
            widest.schema().clone(),
            Encoding {
                compression: ParquetCompression::Snappy,
            },
        );
        Ok(Sink {
            name: name.to_string(),
            columns: widest
                .columns()
                .iter()
                .map(|c| (c.name().clone(), c.dtype().clone()))
                .collect(),
            pending: Default::default(),
            pending_rows: 0,
            uncompacted: 0,
            groups: row_groups(rows).into(),
            writer,
        })
    }

    /// Appends a fragment: its columns aligned on the widest fragment's (nulls where it lacks
    /// one); every row group that is complete now is written.
    ///
    /// # Errors
    /// If the fragment has a column the widest one lacks, or types that do not fit.
    pub fn push(&mut self, part: &DataFrame) -> Result<()> {
        if let Some(c) = part
            .columns()
            .iter()
            .find(|c| !self.columns.iter().any(|(n, _)| n == c.name()))
        {
            bail!(
                "assembling {}: a fragment has column {} that the widest one lacks",
                self.name,
                c.name()
            );
        }
        let aligned = DataFrame::new_infer_height(
            self.columns
                .iter()
                .map(|(name, dtype)| match part.column(name) {
                    Ok(c) if c.dtype() != dtype => bail!(
                        "assembling {}: column {name} is {} in a fragment and {dtype} in the \
                         widest one",
                        self.name,
                        c.dtype()
                    ),
                    Ok(c) => Ok(c.clone()),
                    Err(_) => Ok(Column::full_null(name.clone(), part.height(), dtype)),
                })
                .collect::<Result<_>>()?,
        )?;
        self.pending_rows += aligned.height();
        self.pending.push_back(aligned);
        self.uncompacted += 1;
        if self.uncompacted >= COMPACT {
            // The last COMPACT fragments become one, their strings copied into one buffer.
            let at = self.pending.len() - self.uncompacted.min(self.pending.len());
            let parts: Vec<DataFrame> = self.pending.drain(at..).collect();
            self.pending
                .push_back(compact(parts).with_context(|| format!("assembling {}", self.name))?);
            self.uncompacted = 0;
        }
        self.write_full_groups()
    }

    /// Writes the row groups the pending fragments fill: each group stacked from whole
    /// fragments and the head of the last one (its tail waits for the next group), as one
    /// chunk (the writer makes a row group of each chunk).
    fn write_full_groups(&mut self) -> Result<()> {
        while let Some(&size) = self.groups.front() {
            if size == 0 || self.pending_rows < size {
                break;
            }
            let mut group: Option<DataFrame> = None;
            let mut need = size;
            while need > 0 {
                let part = self.pending.pop_front().expect("rows are pending");
                let h = part.height();
                let head = if h <= need {
                    part
                } else {
                    self.pending.push_front(part.slice(need as i64, h - need));
                    part.slice(0, need)
                };
                need -= head.height();
                match &mut group {
                    None => group = Some(head),
                    Some(g) => {
                        g.vstack_mut_owned(head)
                            .with_context(|| format!("assembling {}", self.name))?;
                    }
                }
            }
            let mut group = group.expect("a group of at least one row");
            group.rechunk_mut();
            self.writer
                .write(&group)
                .with_context(|| format!("writing {}.parquet", self.name))?;
            self.pending_rows -= size;
            self.groups.pop_front();
        }
        Ok(())
    }

    /// Writes the footer and puts the file in place; its SHA-256 (lower-case hex), computed as
    /// it was written.
    ///
    /// # Errors
    /// If rows are left over or missing (the records and the fragments disagree), or the
    /// file cannot be written.
    pub fn finish(self) -> Result<Option<String>> {
        let left = self.pending_rows;
        let due: usize = self.groups.iter().sum();
        if left != 0 || due != 0 {
            bail!(
                "assembling {}: the fragments hold {} rows more than their records say",
                self.name,
                left as i64 - due as i64
            );
        }
        self.writer
            .finish()
            .with_context(|| format!("writing {}.parquet", self.name))?
            .commit_hashed()
    }
}

/// Fragments a table's thread may hold before the merge waits for it: with a tiny job's
/// fragments of about 40 KB, a few megabytes a table.
const QUEUE: usize = 64;

/// Every table of a merge, written inline (one thread) or each on a thread of its own.
///
/// Encoding the row groups (Parquet's dictionaries, compression) is most of a merge's CPU,
/// and it falls on the tables in bursts (a group of `pixel_stats`, then one of
/// `analysis_maps`): on one thread, beside the pool reading the next packs, a merge kept 1.2
/// of 2 cores busy. A thread per table, fed in plan order through a bounded queue, writes the
/// same bytes (each table sees the same fragments in the same order) while the reading goes
/// on.
pub enum Sinks {
    /// Written by the caller's thread.
    Inline(std::collections::BTreeMap<String, Sink>),
    /// Each table on its own thread: its queue and the thread's result.
    Threaded(std::collections::BTreeMap<String, Worker>),
}

/// A table written on a thread of its own: fragments in plan order, then `None` to finish
/// it. A queue closed without `None` (the merge failed and dropped its tables) leaves nothing
/// in place, as a [`Sink`] dropped without [`Sink::finish`] does.
pub struct Worker {
    queue: Option<std::sync::mpsc::SyncSender<Option<DataFrame>>>,
    thread: std::thread::JoinHandle<Result<Option<String>>>,
}

impl Worker {
    /// Closes the queue, after `None` when `finish`, and waits for the thread's result.
    fn join(mut self, finish: bool) -> Result<Option<String>> {
        if let Some(q) = self.queue.take() {
            if finish {
                // A thread that failed has closed its end: its error comes from the join.
                let _ = q.send(None);
            }
        }
        self.thread
            .join()
            .unwrap_or_else(|_| Err(anyhow::anyhow!("a table's writer panicked")))
    }

    /// The thread's error (it stopped taking fragments).
    fn failed(self) -> anyhow::Error {
        match self.join(false) {
            Err(e) => e,
            Ok(_) => anyhow::anyhow!("a table's writer stopped early"),
        }
    }
}

impl Sinks {
    /// `sinks`, each on a thread of its own when `threaded`.
    ///
    /// # Errors
    /// If a thread cannot be started.
    pub fn new(sinks: std::collections::BTreeMap<String, Sink>, threaded: bool) -> Result<Sinks> {
        if !threaded {
            return Ok(Sinks::Inline(sinks));
        }
        let mut workers = std::collections::BTreeMap::new();
        for (name, mut sink) in sinks {
            let (queue, parts) = std::sync::mpsc::sync_channel::<Option<DataFrame>>(QUEUE);
            let thread = std::thread::Builder::new()
                .name(format!("table {name}"))
                .spawn(move || -> Result<Option<String>> {
                    for part in parts {
                        match part {
                            Some(part) => sink.push(&part)?,
                            None => return sink.finish(),
                        }
                    }
                    // Abandoned: the staged file goes with the sink, nothing is put in place.
                    Ok(None)
                })
                .with_context(|| format!("starting the writer of {name}.parquet"))?;
            workers.insert(
                name,
                Worker {
                    queue: Some(queue),
                    thread,
                },
            );
        }
        Ok(Sinks::Threaded(workers))
    }

    /// Appends a fragment to `table` (nothing when the merge writes no such table).
    ///
    /// # Errors
    /// As [`Sink::push`]; a table's thread that failed gives its error here.
    pub fn push(&mut self, table: &str, part: DataFrame) -> Result<()> {
        match self {
            Sinks::Inline(sinks) => match sinks.get_mut(table) {
                Some(sink) => sink.push(&part),
                None => Ok(()),
            },
            Sinks::Threaded(workers) => {
                let Some(w) = workers.get_mut(table) else {
                    return Ok(());
                };
                let sent = w.queue.as_ref().map(|q| q.send(Some(part)));
                if let Some(Ok(())) = sent {
                    return Ok(());
                }
                let w = workers.remove(table).expect("the worker is there");
                Err(w.failed())
            }
        }
    }

    /// Writes every table's footer and puts the files in place; the SHA-256 of each (by
    /// table name), computed as it was written.
    ///
    /// # Errors
    /// The first table's error, in name order.
    pub fn finish(self) -> Result<std::collections::BTreeMap<String, String>> {
        let mut hashes = std::collections::BTreeMap::new();
        match self {
            Sinks::Inline(sinks) => {
                for (name, sink) in sinks {
                    if let Some(h) = sink.finish()? {
                        hashes.insert(name, h);
                    }
                }
                Ok(hashes)
            }
            Sinks::Threaded(workers) => {
                let mut first = None;
                for (name, w) in workers {
                    match (w.join(true), &first) {
                        (Err(e), None) => first = Some(e),
                        (Ok(Some(h)), _) => {
                            hashes.insert(name, h);
                        }
                        _ => {}
                    }
                }
                first.map_or(Ok(hashes), Err)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use polars::prelude::ParquetWriter;
    use rand::{RngExt, SeedableRng};

    /// The in-memory assembly the tables had up to store schema 2: fragments stacked in order,
    /// columns aligned on the widest fragment (the last of equal width).
    ///
    /// # Errors
    /// If a fragment has a column the widest lacks, or types that do not fit.
    fn concat(parts: &[&DataFrame]) -> Result<DataFrame> {
        let widest = parts.iter().max_by_key(|df| df.width()).expect("non-empty");
        let columns: Vec<(PlSmallStr, DataType)> = widest
            .columns()
            .iter()
            .map(|c| (c.name().clone(), c.dtype().clone()))
            .collect();
        let mut out: Option<DataFrame> = None;
        for part in parts {
            if let Some(c) = part
                .columns()
                .iter()
                .find(|c| widest.column(c.name()).is_err())
            {
                anyhow::bail!(
                    "a fragment has column {} that the widest one lacks",
                    c.name()
                );
            }
            let aligned = DataFrame::new_infer_height(
                columns
                    .iter()
                    .map(|(name, dtype)| match part.column(name) {
                        Ok(c) => c.clone(),
                        Err(_) => Column::full_null(name.clone(), part.height(), dtype),
                    })
                    .collect(),
            )?;
            match &mut out {
                None => out = Some(aligned),
                Some(df) => {
                    df.vstack_mut_owned(aligned)?;
                }
            }
        }
        let mut df = out.expect("non-empty");
        df.rechunk_mut();
        Ok(df)
    }

    /// Fragments of random heights, some without the optional column `c`, with nulls.
    fn parts(seed: u64, n: usize, rows: std::ops::Range<usize>) -> Vec<DataFrame> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|i| {
                let h = rng.random_range(rows.clone());
                let a: Vec<i64> = (0..h).map(|_| rng.random_range(0..1000)).collect();
                let b: Vec<Option<f64>> = (0..h)
                    .map(|_| rng.random_bool(0.9).then(|| rng.random::<f64>()))
                    .collect();
                let s: Vec<String> = (0..h).map(|j| format!("job{i}.{}", j % 7)).collect();
                let mut cols = vec![
                    Column::new("a".into(), a),
                    Column::new("b".into(), b),
                    Column::new("s".into(), s),
                ];
                if rng.random_bool(0.5) {
                    let c: Vec<Option<f64>> = (0..h).map(|j| Some(j as f64)).collect();
                    cols.push(Column::new("c".into(), c));
                }
                DataFrame::new_infer_height(cols).unwrap()
            })
            .collect()
    }

    /// The oracle: every fragment concatenated in memory, then written a slice of [`ROW_GROUP`]
    /// rows at a time (the in-memory assembly of store schema 2 but for the row groups).
    fn at_once(parts: &[DataFrame]) -> Vec<u8> {
        let refs: Vec<&DataFrame> = parts.iter().collect();
        let df = concat(&refs).unwrap();
        let mut bytes = Vec::new();
        let mut writer = ParquetWriter::new(&mut bytes)
            .with_row_group_size(Some(ROW_GROUP))
            .with_compression(ParquetCompression::Snappy)
            .set_parallel(false)
            .batched(df.schema())
            .unwrap();
        let mut at = 0;
        while at < df.height() {
            let n = ROW_GROUP.min(df.height() - at);
            writer.write_batch(&df.slice(at as i64, n)).unwrap();
            at += n;
        }
        writer.finish().unwrap();
        drop(writer);
        bytes
    }

    /// Streamed through a [`Sink`] with the layout the records would give.
    fn streamed(parts: &[DataFrame]) -> Vec<u8> {
        let dir = tempfile::tempdir().unwrap();
        let mut layout = Layout::new(["t"]);
        for p in parts {
            layout.made("t", p);
        }
        let t = &layout.tables[0];
        let Some(Widest::Made(widest)) = &t.widest else {
            panic!("a widest fragment")
        };
        let mut sink = Sink::new(dir.path(), "t", widest, t.rows).unwrap();
        for p in parts {
            sink.push(p).unwrap();
        }
        sink.finish().unwrap();
        std::fs::read(dir.path().join("t.parquet")).unwrap()
    }

    /// The streamed table is the in-memory one byte for byte: below one row group, at two and
    /// a half (the last group takes the remainder), and with empty fragments among them.
    #[test]
    fn streaming_gives_the_bytes_of_the_table_assembled_in_memory() {
        for (seed, n, rows) in [(1, 5, 0..40), (2, 40, 0..3000), (3, 13, 10_000..15_000)] {
            let parts = parts(seed, n, rows);
            let total: usize = parts.iter().map(DataFrame::height).sum();
            let (a, b) = (at_once(&parts), streamed(&parts));
            assert!(a == b, "seed {seed}: {total} rows: the bytes differ");
        }
    }

    /// Two tables through [`Sinks`], on the caller's thread and on a thread each, fragments
    /// interleaved as a merge pushes them: each table the in-memory one byte for byte.
    #[test]
    fn tables_on_threads_of_their_own_give_the_same_bytes() {
        let (t, u) = (parts(4, 30, 0..5000), parts(5, 30, 0..300));
        for threaded in [false, true] {
            let dir = tempfile::tempdir().unwrap();
            let mut layout = Layout::new(["t", "u"]);
            for (a, b) in t.iter().zip(&u) {
                layout.made("t", a);
                layout.made("u", b);
            }
            let mut sinks = std::collections::BTreeMap::new();
            for l in &layout.tables {
                let Some(Widest::Made(widest)) = &l.widest else {
                    panic!("a widest fragment")
                };
                let sink = Sink::new(dir.path(), &l.name, widest, l.rows).unwrap();
                sinks.insert(l.name.clone(), sink);
            }
            let mut sinks = Sinks::new(sinks, threaded).unwrap();
            for (a, b) in t.iter().zip(&u) {
                sinks.push("t", a.clone()).unwrap();
                sinks.push("nothing", b.clone()).unwrap();
                sinks.push("u", b.clone()).unwrap();
            }
            sinks.finish().unwrap();
            for (name, parts) in [("t", &t), ("u", &u)] {
                let bytes = std::fs::read(dir.path().join(format!("{name}.parquet"))).unwrap();
                assert!(bytes == at_once(parts), "{name}, threaded {threaded}");
            }
        }
    }

    /// A table's thread that fails gives its error to the merge (at a later push or at the
    /// end), and no file is put in place.
    #[test]
    fn a_failing_table_thread_reports_its_error() {
        let dir = tempfile::tempdir().unwrap();
        let narrow = DataFrame::new_infer_height(vec![Column::new("a".into(), [1i64])]).unwrap();
        let other = DataFrame::new_infer_height(vec![Column::new("z".into(), [1i64])]).unwrap();
        let sink = Sink::new(dir.path(), "t", &narrow.clear(), 2).unwrap();
        let mut sinks = Sinks::new([("t".to_string(), sink)].into(), true).unwrap();
        let mut err = None;
        for part in [narrow.clone(), other]
            .into_iter()
            .chain(std::iter::repeat_n(narrow, 2 * QUEUE))
        {
            if let Err(e) = sinks.push("t", part) {
                err = Some(e);
                break;
            }
        }
        let err = match err {
            Some(e) => e,
            None => sinks.finish().unwrap_err(),
        };
        assert!(
            format!("{err:#}").contains("t: a fragment has column z"),
            "{err:#}"
        );
        assert!(!dir.path().join("t.parquet").exists());
    }

    /// Tables dropped without `finish` (a merge that failed half-way) leave no file, on
    /// threads as inline.
    #[test]
    fn abandoned_tables_leave_nothing() {
        let t = parts(6, 5, 1..50);
        for threaded in [false, true] {
            let dir = tempfile::tempdir().unwrap();
            let mut layout = Layout::new(["t"]);
            for p in &t {
                layout.made("t", p);
            }
            let l = &layout.tables[0];
            let Some(Widest::Made(widest)) = &l.widest else {
                panic!("a widest fragment")
            };
            let sink = Sink::new(dir.path(), "t", widest, l.rows).unwrap();
            let mut sinks = Sinks::new([("t".to_string(), sink)].into(), threaded).unwrap();
            for p in &t {
                sinks.push("t", p.clone()).unwrap();
            }
            match sinks {
                Sinks::Inline(sinks) => drop(sinks),
                // As a drop does: the queues closed, then (here) the threads awaited.
                Sinks::Threaded(workers) => {
                    for (_, w) in workers {
                        w.join(false).unwrap();
                    }
                }
            }
            assert!(
                !dir.path().join("t.parquet").exists(),
                "threaded {threaded}"
            );
        }
    }

    /// Row groups of [`ROW_GROUP`] rows, the last one the remainder.
    #[test]
    fn row_groups_are_of_fixed_height() {
        assert_eq!(row_groups(0), [0]);
        assert_eq!(row_groups(ROW_GROUP - 1), [ROW_GROUP - 1]);
        assert_eq!(row_groups(ROW_GROUP), [ROW_GROUP]);
        assert_eq!(row_groups(2 * ROW_GROUP + 5), [ROW_GROUP, ROW_GROUP, 5]);
        let r = row_groups(10 * ROW_GROUP + 123);
        assert_eq!(r.len(), 11);
        assert_eq!(r.iter().sum::<usize>(), 10 * ROW_GROUP + 123);
    }

    /// A fragment with a column the widest lacks is refused, naming the table and the column.
    #[test]
    fn a_fragment_wider_than_its_record_said_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let narrow = DataFrame::new_infer_height(vec![Column::new("a".into(), [1i64])]).unwrap();
        let other = DataFrame::new_infer_height(vec![Column::new("z".into(), [1i64])]).unwrap();
        let mut sink = Sink::new(dir.path(), "t", &narrow.clear(), 2).unwrap();
        sink.push(&narrow).unwrap();
        let err = sink.push(&other).unwrap_err();
        assert!(
            format!("{err:#}").contains("t: a fragment has column z"),
            "{err:#}"
        );
    }
}
