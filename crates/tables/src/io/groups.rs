//! A Parquet file written one row group at a time in memory that does not grow with its
//! pages: the bytes polars' own batched writer gives for the same row groups, without the
//! per-page records that writer keeps until its footer.
//!
//! Why: polars' writer keeps, for every column chunk it has written, the records of its pages
//! (headers and statistics, about 2.4 KB a chunk) until the file's end, where it writes the
//! page indexes. A table of 100 million rows in row groups of 65,536 rows has about 15,000
//! column chunks, so the merge of a 100,000-job sweep held about 94 MB of them. Here each row
//! group is encoded by polars into a small Parquet file of its own (the same encoder, options
//! and schema), whose pages are copied into the big file with their offsets moved; what is
//! kept of each chunk until the end is its footer entry and its two page indexes, serialized
//! (a few hundred bytes). The layout follows polars-parquet 0.55's writer exactly (pages, then
//! each chunk's metadata; after the last group every column index, then every offset index,
//! then the footer), so the file is byte for byte the one polars writes, which the tests check.

use anyhow::{bail, ensure, Context, Result};
use polars::prelude::{DataFrame, ParquetCompression, ParquetWriter, SchemaRef};
use polars_parquet_format::thrift::protocol::{TCompactInputProtocol, TCompactOutputProtocol};
use polars_parquet_format::{ColumnChunk, FileMetaData, OffsetIndex, RowGroup};
use std::io::Write;

/// How the row groups are encoded: the options of polars' `ParquetWriter` this writer passes on.
#[derive(Debug, Clone, Copy)]
pub struct Encoding {
    /// The compression of every page.
    pub compression: ParquetCompression,
}

/// A column chunk's page indexes, serialized: its column index (`None` where polars wrote
/// none) and its offset index.
type Indexes = (Option<Vec<u8>>, Vec<u8>);

/// A Parquet file being written a row group at a time; [`GroupWriter::finish`] writes the
/// page indexes and the footer.
pub struct GroupWriter<W: Write> {
    out: W,
    /// Bytes written to `out`.
    offset: u64,
    schema: SchemaRef,
    encoding: Encoding,
    /// The footer of the first row group's own file: everything but the row groups and the
    /// row count is the same for the whole file.
    head: Option<FileMetaData>,
    groups: Vec<RowGroup>,
    /// Each chunk's page indexes, by group and column.
    indexes: Vec<Vec<Indexes>>,
    /// The last row group's own file (reused).
    scratch: Vec<u8>,
}

impl<W: Write> GroupWriter<W> {
    /// A writer of a file of `schema` into `out`.
    pub fn new(out: W, schema: SchemaRef, encoding: Encoding) -> Self {
        GroupWriter {
            out,
            offset: 0,
            schema,
            encoding,
            head: None,
            groups: Vec::new(),
            indexes: Vec::new(),
            scratch: Vec::new(),
        }
    }

    /// polars' file of `batches` (each a row group; none: a file without rows) in `scratch`.
    fn encode(&mut self, batches: &[&DataFrame]) -> Result<()> {
        self.scratch.clear();
        let mut writer = ParquetWriter::new(&mut self.scratch)
            .with_compression(self.encoding.compression)
            .set_parallel(false)
            .batched(&self.schema)
            .with_context(|| "starting a row group's encoder")?;
        for b in batches {
            writer
                .write_batch(b)
                .with_context(|| "encoding a row group")?;
        }
        writer
            .finish()
            .with_context(|| "finishing a row group's file")?;
        Ok(())
    }

    /// Appends `group` as one row group (its columns must be of one chunk each, as polars'
    /// batched writer requires; an empty frame writes nothing).
    ///
    /// # Errors
    /// If the encoding fails, the group's columns are not the file's, or `out` cannot be
    /// written.
    pub fn write(&mut self, group: &DataFrame) -> Result<()> {
        if group.height() == 0 {
            return Ok(());
        }
        ensure!(
            group.schema().as_ref() == self.schema.as_ref(),
            "a row group's columns differ from the file's"
        );
        self.encode(&[group])?;
        let mut meta = footer(&self.scratch)?;
        ensure!(
            meta.row_groups.len() == 1,
            "a row group's own file has {} row groups",
            meta.row_groups.len()
        );
        if self.offset == 0 {
            self.out.write_all(b"PAR1")?;
            self.offset = 4;
        }
        let mut rg = meta.row_groups.pop().expect("one row group");
        let mut indexes = Vec::with_capacity(rg.columns.len());
        let mut first_shift = None;
        for cc in rg.columns.iter_mut() {
            let shift = self.copy_chunk(cc)?;
            first_shift.get_or_insert(shift);
            indexes.push(self.take_indexes(cc, shift)?);
        }
        rg.file_offset = rg.file_offset.map(|o| o + first_shift.unwrap_or(0));
        rg.ordinal = i16::try_from(self.groups.len()).ok();
        self.groups.push(rg);
        self.indexes.push(indexes);
        meta.row_groups.clear();
        meta.num_rows = 0;
        if self.head.is_none() {
            self.head = Some(meta);
        }
        Ok(())
    }

    /// Copies the pages of chunk `cc` from the row group's file to `out`, moved by the
    /// returned shift, and writes its metadata after them as polars does.
    fn copy_chunk(&mut self, cc: &mut ColumnChunk) -> Result<i64> {
        let md = cc
            .meta_data
            .as_mut()
            .context("a column chunk without metadata")?;
        let start = md
            .dictionary_page_offset
            .filter(|o| *o > 0)
            .unwrap_or(md.data_page_offset);
        let len = md.total_compressed_size;
        let (s, e) = (to_usize(start)?, to_usize(start + len)?);
        ensure!(
            e <= self.scratch.len(),
            "a column chunk runs past its row group's file"
        );
        // The chunk's metadata follows its pages in the row group's file: check that the
        // layout is the one this writer copies (an older or newer polars may differ).
        let mut inline = Vec::new();
        md.write_to_out_protocol(&mut TCompactOutputProtocol::new(&mut inline))?;
        ensure!(
            self.scratch.get(e..e + inline.len()) == Some(&inline[..]),
            "a column chunk's metadata is not where polars-parquet 0.55 writes it"
        );
        let shift = self.offset as i64 - start;
        md.data_page_offset += shift;
        md.dictionary_page_offset = md.dictionary_page_offset.map(|o| o + shift);
        md.index_page_offset = md.index_page_offset.map(|o| o + shift);
        cc.file_offset += shift;
        self.out.write_all(&self.scratch[s..e])?;
        let mut moved = Vec::with_capacity(inline.len() + 4);
        md.write_to_out_protocol(&mut TCompactOutputProtocol::new(&mut moved))?;
        self.out.write_all(&moved)?;
        self.offset += (e - s + moved.len()) as u64;
        Ok(shift)
    }

    /// The chunk's column index as polars wrote it and its offset index moved by `shift`,
    /// both serialized; the chunk's index fields cleared until [`GroupWriter::finish`].
    fn take_indexes(&self, cc: &mut ColumnChunk, shift: i64) -> Result<Indexes> {
        let column = match (cc.column_index_offset.take(), cc.column_index_length.take()) {
            (Some(o), Some(l)) => Some(self.slice(o, l)?.to_vec()),
            _ => None,
        };
        let (Some(o), Some(l)) = (cc.offset_index_offset.take(), cc.offset_index_length.take())
        else {
            bail!("a column chunk without an offset index");
        };
        let bytes = self.slice(o, l)?;
        let mut index = OffsetIndex::read_from_in_protocol(&mut TCompactInputProtocol::new(
            bytes,
            THRIFT_LIMIT,
        ))?;
        for p in &mut index.page_locations {
            p.offset += shift;
        }
        let mut offsets = Vec::with_capacity(bytes.len() + 4);
        index.write_to_out_protocol(&mut TCompactOutputProtocol::new(&mut offsets))?;
        Ok((column, offsets))
    }

    /// `len` bytes at `offset` of the row group's file.
    fn slice(&self, offset: i64, len: i32) -> Result<&[u8]> {
        let s = to_usize(offset)?;
        self.scratch
            .get(s..s + to_usize(len as i64)?)
            .context("an index runs past its row group's file")
    }

    /// Writes the page indexes and the footer; returns `out`.
    ///
    /// # Errors
    /// If `out` cannot be written.
    pub fn finish(mut self) -> Result<W> {
        let Some(mut meta) = self.head.take() else {
            // No rows: polars' file without row groups, as it is.
            self.encode(&[])?;
            self.out.write_all(&self.scratch)?;
            return Ok(self.out);
        };
        for (rg, idx) in self.groups.iter_mut().zip(&self.indexes) {
            for (cc, (column, _)) in rg.columns.iter_mut().zip(idx) {
                if let Some(c) = column {
                    cc.column_index_offset = Some(self.offset as i64);
                    cc.column_index_length = Some(c.len() as i32);
                    self.out.write_all(c)?;
                    self.offset += c.len() as u64;
                }
            }
        }
        for (rg, idx) in self.groups.iter_mut().zip(&self.indexes) {
            for (cc, (_, offsets)) in rg.columns.iter_mut().zip(idx) {
                cc.offset_index_offset = Some(self.offset as i64);
                cc.offset_index_length = Some(offsets.len() as i32);
                self.out.write_all(offsets)?;
                self.offset += offsets.len() as u64;
            }
        }
        meta.num_rows = self.groups.iter().map(|g| g.num_rows).sum();
        meta.row_groups = std::mem::take(&mut self.groups);
        let mut tail = Vec::new();
        let n = meta.write_to_out_protocol(&mut TCompactOutputProtocol::new(&mut tail))?;
        tail.extend_from_slice(&(n as i32).to_le_bytes());
        tail.extend_from_slice(b"PAR1");
        self.out.write_all(&tail)?;
        self.out.flush()?;
        Ok(self.out)
    }
}

/// The footer of a whole Parquet file in memory.
fn footer(file: &[u8]) -> Result<FileMetaData> {
    let n = file.len();
    ensure!(
        n >= 12 && &file[n - 4..] == b"PAR1",
        "a row group's file has no footer"
    );
    let len = i32::from_le_bytes(file[n - 8..n - 4].try_into().expect("4 bytes"));
    let start = (n - 8)
        .checked_sub(to_usize(len as i64)?)
        .context("a footer longer than its file")?;
    let bytes = &file[start..n - 8];
    Ok(FileMetaData::read_from_in_protocol(
        &mut TCompactInputProtocol::new(bytes, THRIFT_LIMIT),
    )?)
}

/// The Thrift reader's bound on what a message may allocate (it counts each list's elements
/// at their size in memory, so a footer needs several times its bytes): the files read here
/// are the ones polars has just written in memory, so the bound only guards against a bug.
const THRIFT_LIMIT: usize = 1 << 30;

fn to_usize(v: i64) -> Result<usize> {
    usize::try_from(v).context("a negative offset in a row group's file")
}

#[cfg(test)]
mod tests {
    use super::*;
    use polars::prelude::{Column, DataType, ParquetReader, SerReader};
    use rand::{RngExt, SeedableRng};

    /// `groups` seeded random row groups of mixed columns: integers, floats with nulls,
    /// repeated strings (dictionary pages), booleans, a column of nulls only.
    fn frames(seed: u64, groups: usize) -> Vec<DataFrame> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..groups)
            .map(|g| {
                let h = rng.random_range(1..3000);
                let a: Vec<i64> = (0..h).map(|_| rng.random_range(-5..1_000_000)).collect();
                let b: Vec<Option<f64>> = (0..h)
                    .map(|_| rng.random_bool(0.8).then(|| rng.random::<f64>()))
                    .collect();
                let s: Vec<String> = (0..h).map(|j| format!("job{g}.{}", j % 13)).collect();
                let t: Vec<bool> = (0..h).map(|_| rng.random_bool(0.3)).collect();
                let u: Vec<u32> = (0..h).map(|j| (j % 4) as u32).collect();
                DataFrame::new_infer_height(vec![
                    Column::new("a".into(), a),
                    Column::new("b".into(), b),
                    Column::new("s".into(), s),
                    Column::new("t".into(), t),
                    Column::new("u".into(), u),
                    Column::full_null("n".into(), h, &DataType::Float64),
                ])
                .unwrap()
            })
            .collect()
    }

    /// The oracle: polars' batched writer, one `write_batch` a row group.
    fn polars_bytes(
        schema: &SchemaRef,
        groups: &[DataFrame],
        compression: ParquetCompression,
    ) -> Vec<u8> {
        let mut bytes = Vec::new();
        let mut w = ParquetWriter::new(&mut bytes)
            .with_compression(compression)
            .set_parallel(false)
            .batched(schema)
            .unwrap();
        for g in groups {
            w.write_batch(g).unwrap();
        }
        w.finish().unwrap();
        drop(w);
        bytes
    }

    fn ours(schema: &SchemaRef, groups: &[DataFrame], compression: ParquetCompression) -> Vec<u8> {
        let mut w = GroupWriter::new(Vec::new(), schema.clone(), Encoding { compression });
        for g in groups {
            w.write(g).unwrap();
        }
        w.finish().unwrap()
    }

    #[test]
    fn gives_polars_bytes_for_seeded_random_row_groups() {
        for (seed, n) in [(1, 1), (2, 5), (3, 17)] {
            let groups = frames(seed, n);
            let schema = groups[0].schema().clone();
            for c in [ParquetCompression::Snappy, ParquetCompression::Uncompressed] {
                let (a, b) = (polars_bytes(&schema, &groups, c), ours(&schema, &groups, c));
                assert_eq!(a.len(), b.len(), "seed {seed}, {n} groups, {c:?}");
                assert!(a == b, "seed {seed}, {n} groups, {c:?}: bytes differ");
                let back = ParquetReader::new(std::io::Cursor::new(b))
                    .finish()
                    .unwrap();
                let mut all = groups[0].clone();
                for g in &groups[1..] {
                    all.vstack_mut(g).unwrap();
                }
                assert!(back.equals_missing(&all));
            }
        }
    }

    #[test]
    fn a_file_without_rows_is_polars_one() {
        let schema = frames(4, 1)[0].schema().clone();
        let c = ParquetCompression::Snappy;
        assert_eq!(polars_bytes(&schema, &[], c), ours(&schema, &[], c));
    }

    #[test]
    fn a_group_of_other_columns_is_refused() {
        let g = frames(5, 2);
        let other = g[1].drop("a").unwrap();
        let mut w = GroupWriter::new(
            Vec::new(),
            g[0].schema().clone(),
            Encoding {
                compression: ParquetCompression::Snappy,
            },
        );
        w.write(&g[0]).unwrap();
        assert!(w.write(&other).is_err());
    }
}
