//! A job's table fragments as the job store keeps them: a plain columnar copy of a DataFrame
//! (little-endian values, a validity byte per row where a column has nulls), written and read
//! without Parquet's encoders. A fragment is written once by its job and read once by the
//! merge, which writes the tables in Parquet; a Parquet fragment cost a dictionary attempt
//! (with a cardinality estimate) on every column at write and a page decode at read, about an
//! eighth of the CPU of a sweep of tiny jobs (`perf`: the cardinality estimates and the
//! dictionary's value map). Columns of other types than these (String, Int64, UInt64,
//! Float64, Boolean) make [`encode`] answer `None`, and the caller keeps Parquet; [`is_frame`]
//! tells the two apart by the leading magic bytes.
//!
//! Layout: `MAGIC`, the row and column counts (`u64`, `u32`), then per column its name
//! (`u32` length and UTF-8 bytes), its type (`u8`), whether it has a validity part (`u8`),
//! the validity (one byte per row, 1 = present), and its values (a null row's value is the
//! first, or zero): strings as their distinct values (`u32` count, `u64` end offsets, bytes)
//! and a row's index into them, integers as the smallest value (8 bytes) and each row's
//! difference from it; indices and differences in the fewest bytes (1, 2, 4 or 8, a width
//! byte first; 0 when every row is the same) that hold the largest. Floats are 8 bytes a row,
//! booleans a byte. A tiny job's fragments take a little less than their uncompressed Parquet
//! took (149 against 165 MB for 2,000 jobs).

use anyhow::{bail, ensure, Context, Result};
use polars::prelude::*;

/// The first bytes of a fragment in this format.
pub const MAGIC: &[u8; 8] = b"ICFRAME1";

/// The column types of the format.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[repr(u8)]
enum Kind {
    Str = 1,
    I64 = 2,
    U64 = 3,
    F64 = 4,
    Bool = 5,
}

impl Kind {
    fn of(dtype: &DataType) -> Option<Kind> {
        Some(match dtype {
            DataType::String => Kind::Str,
            DataType::Int64 => Kind::I64,
            DataType::UInt64 => Kind::U64,
            DataType::Float64 => Kind::F64,
            DataType::Boolean => Kind::Bool,
            _ => return None,
        })
    }

    fn from_byte(b: u8) -> Option<Kind> {
        [Kind::Str, Kind::I64, Kind::U64, Kind::F64, Kind::Bool]
            .into_iter()
            .find(|k| *k as u8 == b)
    }
}

/// A string column: its distinct values (their count, their end offsets, their bytes), then
/// each row's index into them, packed; a null reads as `""` (its validity is written apart).
fn strings(values: &StringChunked, out: &mut Vec<u8>) {
    let mut distinct: Vec<&str> = vec![];
    let mut index = std::collections::HashMap::new();
    // A row repeats the row before it more often than not (a job's id on each of its rows):
    // compared before it is hashed.
    let mut last: Option<(&str, u64)> = None;
    let rows: Vec<u64> = values
        .iter()
        .map(|v| {
            let v = v.unwrap_or("");
            if let Some((l, at)) = last {
                if l == v {
                    return at;
                }
            }
            let at = *index.entry(v).or_insert_with(|| {
                distinct.push(v);
                distinct.len() as u64 - 1
            });
            last = Some((v, at));
            at
        })
        .collect();
    out.extend_from_slice(&(distinct.len() as u32).to_le_bytes());
    let mut end = 0u64;
    for v in &distinct {
        end += v.len() as u64;
        out.extend_from_slice(&end.to_le_bytes());
    }
    for v in &distinct {
        out.extend_from_slice(v.as_bytes());
    }
    packed(out, &rows);
}

/// Whether `bytes` are a fragment in this format (rather than Parquet).
pub fn is_frame(bytes: &[u8]) -> bool {
    bytes.starts_with(MAGIC)
}

/// The fragment `df` in this format; `None` when a column's type is not one of the format's.
pub fn encode(df: &DataFrame) -> Option<Vec<u8>> {
    let kinds: Vec<Kind> = df
        .columns()
        .iter()
        .map(|c| Kind::of(c.dtype()))
        .collect::<Option<_>>()?;
    let rows = df.height();
    let mut out = Vec::with_capacity(64 + rows * 9 * kinds.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&(rows as u64).to_le_bytes());
    out.extend_from_slice(&(kinds.len() as u32).to_le_bytes());
    for (column, kind) in df.columns().iter().zip(kinds) {
        let name = column.name().as_bytes();
        out.extend_from_slice(&(name.len() as u32).to_le_bytes());
        out.extend_from_slice(name);
        out.push(kind as u8);
        let nulls = column.null_count() > 0;
        out.push(u8::from(nulls));
        let series = column.as_materialized_series();
        if nulls {
            out.extend(
                series
                    .is_not_null()
                    .iter()
                    .map(|v| u8::from(v == Some(true))),
            );
        }
        match kind {
            Kind::Str => strings(series.str().expect("a String column"), &mut out),
            Kind::I64 => {
                let values: Vec<i64> = series
                    .i64()
                    .expect("an Int64 column")
                    .iter()
                    .map(|v| v.unwrap_or(0))
                    .collect();
                let base = values.iter().copied().min().unwrap_or(0);
                out.extend_from_slice(&base.to_le_bytes());
                let d: Vec<u64> = values
                    .iter()
                    .map(|&v| v.wrapping_sub(base) as u64)
                    .collect();
                packed(&mut out, &d);
            }
            Kind::U64 => {
                let values: Vec<u64> = series
                    .u64()
                    .expect("a UInt64 column")
                    .iter()
                    .map(|v| v.unwrap_or(0))
                    .collect();
                let base = values.iter().copied().min().unwrap_or(0);
                out.extend_from_slice(&base.to_le_bytes());
                let d: Vec<u64> = values.iter().map(|&v| v - base).collect();
                packed(&mut out, &d);
            }
            Kind::F64 => {
                for v in series.f64().expect("a Float64 column").iter() {
                    out.extend_from_slice(&v.unwrap_or(0.0).to_bits().to_le_bytes());
                }
            }
            Kind::Bool => {
                out.extend(
                    series
                        .bool()
                        .expect("a Boolean column")
                        .iter()
                        .map(|v| u8::from(v == Some(true))),
                );
            }
        }
    }
    Some(out)
}

/// Writes `values` in the fewest bytes that hold the largest (a width byte, then the values;
/// width 0 when every value is 0).
fn packed(out: &mut Vec<u8>, values: &[u64]) {
    let max = values.iter().copied().max().unwrap_or(0);
    let width: usize = match max {
        0 => 0,
        1..=0xff => 1,
        0x100..=0xffff => 2,
        0x1_0000..=0xffff_ffff => 4,
        _ => 8,
    };
    out.push(width as u8);
    for v in values {
        out.extend_from_slice(&v.to_le_bytes()[..width]);
    }
}

/// Reads the parts of a fragment in order, refusing to read past its end.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8]> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let Some(end) = end else {
            bail!(
                "the fragment ends at byte {} where {} more were expected",
                self.bytes.len(),
                n
            );
        };
        let part = &self.bytes[self.at..end];
        self.at = end;
        Ok(part)
    }

    fn u64(&mut self) -> Result<u64> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }

    fn u32(&mut self) -> Result<u32> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }

    fn u8(&mut self) -> Result<u8> {
        Ok(self.take(1)?[0])
    }

    /// `rows` values written by [`packed`].
    fn unpacked(&mut self, rows: usize) -> Result<Vec<u64>> {
        let width = self.u8()? as usize;
        ensure!(
            matches!(width, 0 | 1 | 2 | 4 | 8),
            "bad value width {width}"
        );
        if width == 0 {
            return Ok(vec![0; rows]);
        }
        let bytes = self.take(rows.checked_mul(width).context("too many rows")?)?;
        Ok(bytes
            .chunks_exact(width)
            .map(|b| {
                let mut word = [0u8; 8];
                word[..width].copy_from_slice(b);
                u64::from_le_bytes(word)
            })
            .collect())
    }

    /// `rows` values of 8 bytes.
    fn words(&mut self, rows: usize) -> Result<impl Iterator<Item = [u8; 8]> + 'a> {
        let bytes = self.take(rows.checked_mul(8).context("too many rows")?)?;
        Ok(bytes
            .chunks_exact(8)
            .map(|b| b.try_into().expect("8 bytes")))
    }
}

/// The DataFrame of a fragment written by [`encode`].
///
/// # Errors
/// If the bytes are not such a fragment, or are cut short or damaged.
pub fn decode(bytes: &[u8]) -> Result<DataFrame> {
    ensure!(
        is_frame(bytes),
        "not a fragment of this format (no magic bytes)"
    );
    let mut r = Reader {
        bytes,
        at: MAGIC.len(),
    };
    let rows = usize::try_from(r.u64()?).context("too many rows")?;
    let columns = r.u32()? as usize;
    ensure!(
        rows <= bytes.len() && columns <= bytes.len(),
        "the fragment's header claims {rows} rows and {columns} columns in {} bytes",
        bytes.len()
    );
    let mut out = Vec::with_capacity(columns);
    for _ in 0..columns {
        out.push(read_column(&mut r, rows)?);
    }
    ensure!(
        r.at == bytes.len(),
        "{} bytes after the last column",
        bytes.len() - r.at
    );
    Ok(DataFrame::new(rows, out)?)
}

/// A column of `name` from the values of every row and the validity, if any: without nulls
/// straight from a vector of values (no per-row builder).
macro_rules! nullable {
    ($name:expr, $values:expr, $valid:expr, $t:ty) => {
        match &$valid {
            None => Column::new($name, $values.collect::<Vec<$t>>()),
            Some(ok) => Column::new(
                $name,
                $values
                    .zip(ok)
                    .map(|(x, &k)| k.then_some(x))
                    .collect::<Vec<Option<$t>>>(),
            ),
        }
    };
}

/// One column of a fragment, after the columns before it.
fn read_column(r: &mut Reader, rows: usize) -> Result<Column> {
    let n = r.u32()? as usize;
    let name = std::str::from_utf8(r.take(n)?).context("a column name is not UTF-8")?;
    let kind = r.u8()?;
    let kind =
        Kind::from_byte(kind).with_context(|| format!("column {name:?}: unknown type {kind}"))?;
    let valid: Option<Vec<bool>> = match r.u8()? {
        0 => None,
        1 => Some(r.take(rows)?.iter().map(|&b| b != 0).collect()),
        b => bail!("column {name:?}: bad validity flag {b}"),
    };
    let present = |i: usize| valid.as_ref().is_none_or(|v| v[i]);
    let name = PlSmallStr::from_str(name);
    let column = match kind {
        Kind::Str => read_strings(r, rows, name, &present)?,
        Kind::I64 => {
            let base = i64::from_le_bytes(r.take(8)?.try_into().expect("8 bytes"));
            let v = r.unpacked(rows)?.into_iter();
            nullable!(name, v.map(|d| base.wrapping_add(d as i64)), valid, i64)
        }
        Kind::U64 => {
            let base = r.u64()?;
            let v = r.unpacked(rows)?.into_iter();
            nullable!(name, v.map(|d| base.wrapping_add(d)), valid, u64)
        }
        Kind::F64 => {
            let v = r.words(rows)?;
            nullable!(
                name,
                v.map(|b| f64::from_bits(u64::from_le_bytes(b))),
                valid,
                f64
            )
        }
        Kind::Bool => {
            let v = r.take(rows)?.iter();
            nullable!(name, v.map(|&b| b != 0), valid, bool)
        }
    };
    Ok(column)
}

/// A string column's values: its distinct values, then a row's index into them.
fn read_strings(
    r: &mut Reader,
    rows: usize,
    name: PlSmallStr,
    present: &dyn Fn(usize) -> bool,
) -> Result<Column> {
    let count = r.u32()? as usize;
    ensure!(
        count <= r.bytes.len(),
        "column {name:?}: {count} distinct values"
    );
    let ends: Vec<u64> = r.words(count)?.map(u64::from_le_bytes).collect();
    let total = ends.last().copied().unwrap_or(0);
    let text = r.take(usize::try_from(total).context("too many bytes")?)?;
    let mut start = 0usize;
    let mut distinct = Vec::with_capacity(count);
    for &end in &ends {
        let end = usize::try_from(end).context("too many bytes")?;
        ensure!(
            start <= end && end <= text.len(),
            "column {name:?}: bad string offsets"
        );
        distinct.push(
            std::str::from_utf8(&text[start..end])
                .with_context(|| format!("column {name:?}: a value is not UTF-8"))?,
        );
        start = end;
    }
    // Each row's value gathered from the distinct values: the rows' views point at one copy of
    // each value (a job id in every row of its fragment is not copied row by row).
    let index = r.unpacked(rows)?;
    let index: IdxCa = index
        .iter()
        .enumerate()
        .map(|(i, &k)| {
            if !present(i) {
                return Ok(None);
            }
            ensure!((k as usize) < count, "column {name:?}: bad index {k}");
            Ok(Some(k as IdxSize))
        })
        .collect::<Result<Vec<Option<IdxSize>>>>()?
        .into_iter()
        .collect();
    let distinct = StringChunked::from_iter_values(name.clone(), distinct.into_iter());
    let values = anyhow::Context::with_context(distinct.take(&index), || {
        format!("column {name:?}: gathering its values")
    })?;
    Ok(values.into_column())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A random frame of every type, with and without nulls, `rows` rows.
    fn random_frame(rng: &mut ChaCha8Rng, rows: usize) -> DataFrame {
        let maybe = |rng: &mut ChaCha8Rng, nulls: bool| !nulls || rng.random_bool(0.8);
        let mut columns = vec![];
        for nulls in [false, true] {
            let s: Vec<Option<String>> = (0..rows)
                .map(|_| {
                    maybe(rng, nulls).then(|| {
                        let n = rng.random_range(0..12);
                        (0..n)
                            .map(|_| rng.random_range('a'..='z'))
                            .chain(['é'])
                            .collect()
                    })
                })
                .collect();
            let i: Vec<Option<i64>> = (0..rows)
                .map(|_| maybe(rng, nulls).then(|| rng.random()))
                .collect();
            let u: Vec<Option<u64>> = (0..rows)
                .map(|_| maybe(rng, nulls).then(|| rng.random()))
                .collect();
            let f: Vec<Option<f64>> = (0..rows)
                .map(|_| {
                    maybe(rng, nulls).then(|| match rng.random_range(0..4) {
                        0 => f64::NAN,
                        1 => -0.0,
                        _ => rng.random::<f64>() * 1e6 - 5e5,
                    })
                })
                .collect();
            let b: Vec<Option<bool>> = (0..rows)
                .map(|_| maybe(rng, nulls).then(|| rng.random()))
                .collect();
            // Few distinct strings and small or constant integers take the narrow widths.
            let few: Vec<Option<&str>> = (0..rows)
                .map(|_| maybe(rng, nulls).then(|| ["h", "v", "d"][rng.random_range(0..3)]))
                .collect();
            let small: Vec<Option<i64>> = (0..rows)
                .map(|_| maybe(rng, nulls).then(|| rng.random_range(-3..300)))
                .collect();
            let wide: Vec<Option<i64>> = (0..rows)
                .map(|_| maybe(rng, nulls).then(|| rng.random_range(-70_000..70_000)))
                .collect();
            let same: Vec<Option<u64>> =
                (0..rows).map(|_| maybe(rng, nulls).then_some(7)).collect();
            let tag = if nulls { "_nulls" } else { "" };
            columns.push(Column::new(format!("few{tag}").into(), few));
            columns.push(Column::new(format!("small{tag}").into(), small));
            columns.push(Column::new(format!("wide{tag}").into(), wide));
            columns.push(Column::new(format!("same{tag}").into(), same));
            columns.push(Column::new(format!("s{tag}").into(), s));
            columns.push(Column::new(format!("i{tag}").into(), i));
            columns.push(Column::new(format!("u{tag}").into(), u));
            columns.push(Column::new(format!("f{tag}").into(), f));
            columns.push(Column::new(format!("b{tag}").into(), b));
        }
        DataFrame::new(rows, columns).unwrap()
    }

    /// The oracle: Parquet, the format the fragments had, read back through polars.
    fn through_parquet(df: &DataFrame) -> DataFrame {
        let mut bytes = Vec::new();
        ParquetWriter::new(&mut bytes)
            .finish(&mut df.clone())
            .unwrap();
        ParquetReader::new(std::io::Cursor::new(bytes))
            .finish()
            .unwrap()
    }

    #[test]
    fn random_frames_read_back_as_parquet_reads_them() {
        let mut rng = ChaCha8Rng::seed_from_u64(31);
        for rows in [0, 1, 2, 7, 300] {
            let df = random_frame(&mut rng, rows);
            let bytes = encode(&df).expect("every type is supported");
            assert!(is_frame(&bytes));
            let back = decode(&bytes).unwrap();
            let oracle = through_parquet(&df);
            assert_eq!(back.schema(), oracle.schema(), "{rows} rows");
            assert!(back.equals_missing(&oracle), "{rows} rows");
            // Bit for bit, NaN and -0.0 included.
            for name in ["f", "f_nulls"] {
                let bits = |d: &DataFrame| -> Vec<Option<u64>> {
                    d.column(name)
                        .unwrap()
                        .as_materialized_series()
                        .f64()
                        .unwrap()
                        .iter()
                        .map(|v| v.map(f64::to_bits))
                        .collect()
                };
                assert_eq!(bits(&back), bits(&df));
            }
        }
    }

    #[test]
    fn other_types_are_left_to_parquet() {
        let df = DataFrame::new(2, vec![Column::new("x".into(), [1i32, 2])]).unwrap();
        assert!(encode(&df).is_none());
    }

    #[test]
    fn damaged_fragments_are_refused_not_misread() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let df = random_frame(&mut rng, 20);
        let bytes = encode(&df).unwrap();
        for cut in [0, 8, 19, bytes.len() / 2, bytes.len() - 1] {
            assert!(decode(&bytes[..cut]).is_err(), "cut at {cut}");
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(decode(&longer).is_err());
        let mut bad_type = bytes.clone();
        // The first column's type byte: after the magic, the counts, and its name.
        bad_type[8 + 8 + 4 + 4 + df.columns()[0].name().len()] = 99;
        assert!(decode(&bad_type).is_err());
    }
}
