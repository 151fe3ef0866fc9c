//! The parts of a NITF 2.1 file (MIL-STD-2500C) that a SICD reader needs: the file header's
//! segment lengths, each image segment's subheader fields (size, pixel value type, bands,
//! compression, blocking) and where its pixels lie, and the data extension segments' headers
//! and data (SICD's XML metadata is one). Every field is a fixed-width ASCII field at a
//! position the standard fixes; a file that ends before a segment it declares is refused.

use std::os::unix::fs::FileExt;

/// A segment's place in the file: its subheader's and its data's offsets and lengths.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Segment {
    /// Subheader offset.
    pub header_at: u64,
    /// Subheader length.
    pub header_len: u64,
    /// Data offset.
    pub data_at: u64,
    /// Data length.
    pub data_len: u64,
}

/// An image segment's fields.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image {
    /// Its place in the file.
    pub segment: Segment,
    /// `IID1` (SICD: `SICD000`, `SICD001`, ...).
    pub iid1: String,
    /// `NROWS`.
    pub rows: usize,
    /// `NCOLS`.
    pub cols: usize,
    /// `PVTYPE` (`R`, `SI`, `INT`).
    pub pvtype: String,
    /// `NBPP`: bits of one band's value.
    pub nbpp: usize,
    /// Each band's `ISUBCAT` (SICD: `I`, `Q`, or `M`, `P`).
    pub subcats: Vec<String>,
    /// `IC`: compression (`NC`, `NM`: none).
    pub ic: String,
    /// `IMODE`: band interleaving (`P`: by pixel).
    pub imode: String,
    /// `NBPR` x `NBPC`: blocks per row and per column.
    pub blocks: (usize, usize),
}

/// A data extension segment: its identifier and place.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Des {
    /// `DESID` (trimmed; SICD: `XML_DATA_CONTENT`).
    pub id: String,
    /// Its place in the file.
    pub segment: Segment,
}

/// The segments of a NITF file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Nitf {
    /// Image segments, in file order.
    pub images: Vec<Image>,
    /// Data extension segments, in file order.
    pub des: Vec<Des>,
}

/// Reads `len` bytes at `at` of `file`.
pub fn bytes_at(file: &std::fs::File, at: u64, len: usize) -> Result<Vec<u8>, String> {
    let mut b = vec![0u8; len];
    file.read_exact_at(&mut b, at)
        .map_err(|e| format!("{len} bytes at offset {at}: {e} (truncated?)"))?;
    Ok(b)
}

/// A cursor over a header's fixed-width ASCII fields.
struct Fields<'a> {
    b: &'a [u8],
    at: usize,
    what: &'static str,
}

impl Fields<'_> {
    /// The next `n` bytes as text (`name` for the message if the header ends first).
    fn text(&mut self, n: usize, name: &str) -> Result<String, String> {
        let f = self
            .b
            .get(self.at..self.at + n)
            .ok_or_else(|| format!("the {} ends before its field {name}", self.what))?;
        self.at += n;
        Ok(String::from_utf8_lossy(f).trim().to_string())
    }

    /// The next `n` bytes as a decimal number.
    fn num(&mut self, n: usize, name: &str) -> Result<u64, String> {
        let t = self.text(n, name)?;
        t.parse()
            .map_err(|_| format!("the {}'s field {name} is {t:?}, not a number", self.what))
    }

    /// Skips `n` bytes.
    fn skip(&mut self, n: usize) {
        self.at += n;
    }
}

impl Nitf {
    /// Reads the file header and the image and data extension subheaders of `file` (`len`
    /// bytes long).
    ///
    /// # Errors
    /// What is wrong, naming the field: not NITF 2.1, a field not a number, a segment past the
    /// end of the file.
    pub fn read(file: &std::fs::File, len: u64) -> Result<Nitf, String> {
        let head = bytes_at(file, 0, 363.min(len as usize))?;
        if !head.starts_with(b"NITF02.10") {
            return Err(format!(
                "not a NITF 2.1 file (it starts with {:?}; SICD files start with NITF02.10)",
                String::from_utf8_lossy(&head[..head.len().min(9)])
            ));
        }
        let mut f = Fields {
            b: &head,
            at: 342,
            what: "file header",
        };
        let fl = f.num(12, "FL")?;
        let hl = f.num(6, "HL")?;
        if fl > len {
            return Err(format!(
                "its header's FL gives {fl} bytes; the file holds {len} (truncated)"
            ));
        }
        let header = bytes_at(file, 0, hl as usize)?;
        let mut f = Fields {
            b: &header,
            at: 360,
            what: "file header",
        };
        let mut lengths = |count: usize, sub: usize, data: usize, name: &str| {
            let n = f.num(count, name)? as usize;
            (0..n)
                .map(|_| Ok((f.num(sub, name)?, f.num(data, name)?)))
                .collect::<Result<Vec<(u64, u64)>, String>>()
        };
        let images = lengths(3, 6, 10, "NUMI")?;
        let graphics = lengths(3, 4, 6, "NUMS")?;
        let _reserved = lengths(3, 0, 0, "NUMX")?;
        let texts = lengths(3, 4, 5, "NUMT")?;
        let des = lengths(3, 4, 9, "NUMDES")?;
        let mut at = hl;
        let mut place = |(h, d): (u64, u64)| {
            let s = Segment {
                header_at: at,
                header_len: h,
                data_at: at + h,
                data_len: d,
            };
            at += h + d;
            s
        };
        let image_segments: Vec<Segment> = images.into_iter().map(&mut place).collect();
        graphics.into_iter().chain(texts).for_each(|s| {
            place(s);
        });
        let des_segments: Vec<Segment> = des.into_iter().map(&mut place).collect();
        if at > len {
            return Err(format!(
                "its segments end at byte {at}; the file holds {len} (truncated)"
            ));
        }
        let images = image_segments
            .into_iter()
            .map(|s| image(file, s))
            .collect::<Result<Vec<_>, _>>()?;
        let des = des_segments
            .into_iter()
            .map(|s| {
                let h = bytes_at(file, s.header_at, s.header_len as usize)?;
                let id = String::from_utf8_lossy(h.get(2..27).unwrap_or(&[]))
                    .trim()
                    .to_string();
                Ok(Des { id, segment: s })
            })
            .collect::<Result<Vec<_>, String>>()?;
        Ok(Nitf { images, des })
    }
}

/// The fields of the image subheader of `s`.
fn image(file: &std::fs::File, s: Segment) -> Result<Image, String> {
    let b = bytes_at(file, s.header_at, s.header_len as usize)?;
    if !b.starts_with(b"IM") {
        return Err(format!(
            "the image subheader at offset {} does not start with IM",
            s.header_at
        ));
    }
    let mut f = Fields {
        b: &b,
        at: 2,
        what: "image subheader",
    };
    let iid1 = f.text(10, "IID1")?;
    f.skip(333 - 12);
    let rows = f.num(8, "NROWS")? as usize;
    let cols = f.num(8, "NCOLS")? as usize;
    let pvtype = f.text(3, "PVTYPE")?;
    f.skip(8 + 8 + 2 + 1); // IREP, ICAT, ABPP, PJUST
    if !f.text(1, "ICORDS")?.is_empty() {
        f.skip(60); // IGEOLO
    }
    let nicom = f.num(1, "NICOM")? as usize;
    f.skip(80 * nicom);
    let ic = f.text(2, "IC")?;
    if ic != "NC" && ic != "NM" {
        f.skip(4); // COMRAT
    }
    let mut bands = f.num(1, "NBANDS")? as usize;
    if bands == 0 {
        bands = f.num(5, "XBANDS")? as usize;
    }
    let mut subcats = vec![];
    for _ in 0..bands {
        f.skip(2); // IREPBAND
        subcats.push(f.text(6, "ISUBCAT")?);
        f.skip(1 + 3); // IFC, IMFLT
        let luts = f.num(1, "NLUTS")? as usize;
        if luts > 0 {
            let entries = f.num(5, "NELUT")? as usize;
            f.skip(luts * entries);
        }
    }
    f.skip(1); // ISYNC
    let imode = f.text(1, "IMODE")?;
    let nbpr = f.num(4, "NBPR")? as usize;
    let nbpc = f.num(4, "NBPC")? as usize;
    f.skip(4 + 4); // NPPBH, NPPBV
    let nbpp = f.num(2, "NBPP")? as usize;
    Ok(Image {
        segment: s,
        iid1,
        rows,
        cols,
        pvtype,
        nbpp,
        subcats,
        ic,
        imode,
        blocks: (nbpr, nbpc),
    })
}
