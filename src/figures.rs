//! Scientific figures (PNG and SVG) for the radar-clutter analysis: grids of heat maps with one
//! shared colour bar, overlaid histograms and named curves. Each figure is drawn twice with
//! `plotters` (bitmap and SVG backends) using an embedded DejaVu Sans font, so nothing depends on
//! system fonts. Heat-map cells are resampled to the panel's pixel size and blitted into the
//! bitmap, or embedded in the SVG as a base64 PNG `<image>`. Both files are written atomically
//! (temporary name in the same folder, then rename).

use std::error::Error;
use std::fmt::Write as _;
use std::fs;
use std::io::{self, Write as _};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

use ab_glyph::{point, Font, FontRef, PxScale, ScaleFont};
use ndarray::ArrayView2;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters_backend::{
    self as pb, BackendColor, BackendCoord, BackendTextStyle, DrawingErrorKind,
};

/// DejaVu Sans (Bitstream Vera licence, see `assets/fonts/DejaVuSans-LICENSE.txt`).
const FONT_BYTES: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");
/// Family name used for all text; SVG viewers get DejaVu Sans or fall back to their sans-serif.
const FAMILY: &str = "DejaVu Sans, sans-serif";

/// Colour of NaN cells in heat maps (neutral grey, absent from both colour scales).
pub const NAN_RGB: (u8, u8, u8) = (150, 150, 150);

/// Error of a figure function; every variant names the file (or `<stem>.{png,svg}`) concerned.
#[derive(Debug, thiserror::Error)]
pub enum FigureError {
    /// The inputs cannot make a figure (no panels, empty map, bad limits, bad stem, ...).
    #[error("{}: invalid figure input: {msg}", .path.display())]
    Input {
        /// The figure concerned, as `<dir>/<stem>.{png,svg}`.
        path: PathBuf,
        /// What is wrong with the input.
        msg: String,
    },
    /// The embedded font could not be parsed or registered with plotters.
    #[error("{}: the embedded font could not be registered", .path.display())]
    Font {
        /// The file that was to be drawn.
        path: PathBuf,
    },
    /// plotters failed while drawing.
    #[error("{}: drawing failed: {msg}", .path.display())]
    Draw {
        /// The file being drawn.
        path: PathBuf,
        /// plotters' message.
        msg: String,
    },
    /// PNG encoding failed.
    #[error("{}: PNG encoding failed: {source}", .path.display())]
    Encode {
        /// The file being encoded.
        path: PathBuf,
        /// The encoder's error.
        #[source]
        source: png::EncodingError,
    },
    /// Creating the folder, writing or renaming the file failed.
    #[error("{}: {source}", .path.display())]
    Io {
        /// The folder or file concerned.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: io::Error,
    },
}

/// Colour scale of a heat-map grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Scale {
    /// Blue-white-red (RdBu reversed) between fixed limits: `lo` is blue, `hi` red, the
    /// midpoint white; values outside are clamped. Correlations use `lo = -1, hi = 1`.
    Diverging {
        /// Value drawn in the blue end colour.
        lo: f64,
        /// Value drawn in the red end colour.
        hi: f64,
    },
    /// Viridis over the finite minimum..maximum of all panels' values.
    Perceptual,
}

/// One heat-map panel: a title and a map whose row 0 is drawn at the top, like an image.
#[derive(Debug, Clone)]
pub struct Panel<'a> {
    /// Title drawn above the panel.
    pub title: String,
    /// Values, indexed `[row, column]`; NaN cells are drawn in [`NAN_RGB`].
    pub map: ArrayView2<'a, f64>,
}

// ---------------------------------------------------------------- colour scales

/// RdBu reversed (ColorBrewer 11 classes, as in matplotlib): blue, white, red.
const RDBU_R: [u8; 33] = [
    5, 48, 97, 33, 102, 172, 67, 147, 195, 146, 197, 222, 209, 229, 240, 247, 247, 247, 253, 219,
    199, 244, 165, 130, 214, 96, 77, 178, 24, 43, 103, 0, 31,
];

/// Viridis (matplotlib), every fifth of its 256 entries: 52 anchors, RGB flattened.
const VIRIDIS: [u8; 156] = [
    68, 1, 84, 70, 8, 92, 71, 16, 99, 72, 23, 105, 72, 29, 111, 72, 36, 117, 71, 42, 122, 70, 48,
    126, 69, 55, 129, 67, 61, 132, 65, 66, 135, 63, 72, 137, 61, 78, 138, 58, 83, 139, 56, 89, 140,
    53, 94, 141, 51, 99, 141, 49, 104, 142, 46, 109, 142, 44, 113, 142, 42, 118, 142, 41, 123, 142,
    39, 128, 142, 37, 132, 142, 35, 137, 142, 33, 142, 141, 32, 146, 140, 31, 151, 139, 30, 156,
    137, 31, 161, 136, 33, 165, 133, 36, 170, 131, 40, 174, 128, 46, 179, 124, 53, 183, 121, 61,
    188, 116, 70, 192, 111, 80, 196, 106, 90, 200, 100, 101, 203, 94, 112, 207, 87, 124, 210, 80,
    137, 213, 72, 149, 216, 64, 162, 218, 55, 176, 221, 47, 189, 223, 38, 202, 225, 31, 216, 226,
    25, 229, 228, 25, 241, 229, 29, 253, 231, 37,
];

/// Linear interpolation in a flattened RGB table at `t` in [0, 1] (clamped); NaN gives grey.
fn lerp_table(table: &[u8], t: f64) -> (u8, u8, u8) {
    if t.is_nan() {
        return NAN_RGB;
    }
    let n = table.len() / 3;
    let x = t.clamp(0.0, 1.0) * (n - 1) as f64;
    let i = (x.floor() as usize).min(n - 2);
    let f = x - i as f64;
    let c = |k: usize| {
        (f64::from(table[3 * i + k]) * (1.0 - f) + f64::from(table[3 * i + 3 + k]) * f).round()
            as u8
    };
    (c(0), c(1), c(2))
}

/// Diverging colour of `v` on `[lo, hi]` (needs `lo < hi`): blue `#053061` at `lo`, near-white
/// `#f7f7f7` at the midpoint, red `#67001f` at `hi`; clamped outside, [`NAN_RGB`] for NaN.
pub fn diverging_rgb(v: f64, lo: f64, hi: f64) -> (u8, u8, u8) {
    lerp_table(&RDBU_R, (v - lo) / (hi - lo))
}

/// Viridis colour at `t` in [0, 1] (clamped): `#440154` at 0, `#fde725` at 1; NaN gives [`NAN_RGB`].
pub fn viridis_rgb(t: f64) -> (u8, u8, u8) {
    lerp_table(&VIRIDIS, t)
}

/// A colour scale with resolved limits.
#[derive(Debug, Clone, Copy)]
struct ColourMap {
    lo: f64,
    hi: f64,
    diverging: bool,
}

impl ColourMap {
    fn rgb(&self, v: f64) -> (u8, u8, u8) {
        if self.diverging {
            diverging_rgb(v, self.lo, self.hi)
        } else {
            viridis_rgb((v - self.lo) / (self.hi - self.lo))
        }
    }
}

// ---------------------------------------------------------------- rendering machinery

type DrawResult = Result<(), Box<dyn Error>>;

/// A pre-rendered RGB raster placed at `(x, y)` in figure pixels.
struct Raster {
    x: u32,
    y: u32,
    w: u32,
    h: u32,
    rgb: Vec<u8>,
}

/// A figure drawable on any plotters backend, plus rasters laid under the vector drawing.
trait Figure {
    fn size(&self) -> (u32, u32);
    fn rasters(&self) -> Vec<Raster> {
        Vec::new()
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static;
}

/// The embedded font, parsed and registered with plotters once; `None` if it cannot be parsed.
fn face() -> Option<&'static FontRef<'static>> {
    static FACE: OnceLock<Option<FontRef<'static>>> = OnceLock::new();
    FACE.get_or_init(|| {
        let ok = ["sans-serif", FAMILY].iter().all(|name| {
            plotters::style::register_font(name, FontStyle::Normal, FONT_BYTES).is_ok()
        });
        FontRef::try_from_slice(FONT_BYTES).ok().filter(|_| ok)
    })
    .as_ref()
}

/// x-height of DejaVu Sans in em, which SVG viewers use for the `0.5ex` offsets plotters writes.
const EX: f32 = 0.547;

/// Text metrics at a plotters font size, whose em is `size / 1.24` pixels as in plotters' SVG.
struct Metrics {
    font: &'static FontRef<'static>,
    scale: PxScale,
    em: f32,
}

impl Metrics {
    fn new(size: f64) -> Option<Self> {
        let font = face()?;
        let em = (size / 1.24) as f32;
        let scale = PxScale::from(em * font.height_unscaled() / font.units_per_em()?);
        Some(Self { font, scale, em })
    }

    /// Pen positions of the glyphs of `text` (kerned) and the total advance.
    fn layout(&self, text: &str) -> (Vec<(ab_glyph::GlyphId, f32)>, f32) {
        let sf = self.font.as_scaled(self.scale);
        let (mut caret, mut prev, mut out) = (0.0, None, Vec::new());
        for id in text.chars().map(|c| sf.glyph_id(c)) {
            caret += prev.map_or(0.0, |p| sf.kern(p, id));
            out.push((id, caret));
            caret += sf.h_advance(id);
            prev = Some(id);
        }
        (out, caret)
    }
}

/// Delegates to a plotters backend but measures text with the embedded font's real metrics and,
/// for bitmaps (`raster`), draws it itself: plotters 0.3.7's ab_glyph path drops the glyphs'
/// side bearings (so "10" reads "1 0") and places text lower than its SVG backend does.
struct Typeset<B> {
    inner: B,
    raster: bool,
}

type BackendResult<B> = Result<(), DrawingErrorKind<<B as DrawingBackend>::ErrorType>>;

impl<B: DrawingBackend> DrawingBackend for Typeset<B> {
    type ErrorType = B::ErrorType;
    fn get_size(&self) -> (u32, u32) {
        self.inner.get_size()
    }
    fn ensure_prepared(&mut self) -> BackendResult<B> {
        self.inner.ensure_prepared()
    }
    fn present(&mut self) -> BackendResult<B> {
        self.inner.present()
    }
    fn draw_pixel(&mut self, p: BackendCoord, c: BackendColor) -> BackendResult<B> {
        self.inner.draw_pixel(p, c)
    }
    fn draw_line<S: pb::BackendStyle>(
        &mut self,
        a: BackendCoord,
        b: BackendCoord,
        s: &S,
    ) -> BackendResult<B> {
        self.inner.draw_line(a, b, s)
    }
    fn draw_rect<S: pb::BackendStyle>(
        &mut self,
        a: BackendCoord,
        b: BackendCoord,
        s: &S,
        fill: bool,
    ) -> BackendResult<B> {
        self.inner.draw_rect(a, b, s, fill)
    }
    fn draw_path<S: pb::BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        s: &S,
    ) -> BackendResult<B> {
        self.inner.draw_path(path, s)
    }
    fn draw_circle<S: pb::BackendStyle>(
        &mut self,
        c: BackendCoord,
        r: u32,
        s: &S,
        fill: bool,
    ) -> BackendResult<B> {
        self.inner.draw_circle(c, r, s, fill)
    }
    fn fill_polygon<S: pb::BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        s: &S,
    ) -> BackendResult<B> {
        self.inner.fill_polygon(vert, s)
    }
    fn blit_bitmap(&mut self, pos: BackendCoord, size: (u32, u32), src: &[u8]) -> BackendResult<B> {
        self.inner.blit_bitmap(pos, size, src)
    }

    fn estimate_text_size<T: BackendTextStyle>(
        &self,
        text: &str,
        style: &T,
    ) -> Result<(u32, u32), DrawingErrorKind<B::ErrorType>> {
        match Metrics::new(style.size()) {
            Some(m) => Ok((
                m.layout(text).1.ceil() as u32,
                m.font.as_scaled(m.scale).height().ceil() as u32,
            )),
            None => self.inner.estimate_text_size(text, style),
        }
    }

    /// Same placement as plotters' SVG text: anchor `Top` puts the baseline 0.76 em below the
    /// anchor, `Center` 0.5 ex below and `Bottom` 0.5 ex above; rotation is about the anchor.
    fn draw_text<T: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &T,
        pos: BackendCoord,
    ) -> BackendResult<B> {
        let metrics = Metrics::new(style.size()).filter(|_| self.raster);
        let Some(m) = metrics else {
            return self.inner.draw_text(text, style, pos);
        };
        let (glyphs, width) = m.layout(text);
        let dx = match style.anchor().h_pos {
            HPos::Left => 0.0,
            HPos::Center => -width / 2.0,
            HPos::Right => -width,
        };
        let base = match style.anchor().v_pos {
            VPos::Top => 0.76 * m.em,
            VPos::Center => 0.5 * EX * m.em,
            VPos::Bottom => -0.5 * EX * m.em,
        };
        let (colour, trans, (w, h)) = (style.color(), style.transform(), self.get_size());
        for (id, x) in glyphs {
            let Some(outline) = m
                .font
                .outline_glyph(id.with_scale_and_position(m.scale, point(dx + x, base)))
            else {
                continue;
            };
            let b = outline.px_bounds();
            let mut res = Ok(());
            outline.draw(|gx, gy, cov| {
                let (x, y) =
                    trans.transform(b.min.x as i32 + gx as i32, b.min.y as i32 + gy as i32);
                let (x, y) = (pos.0 + x, pos.1 + y);
                if res.is_ok()
                    && cov > 0.0
                    && (0..w as i32).contains(&x)
                    && (0..h as i32).contains(&y)
                {
                    res = self
                        .inner
                        .draw_pixel((x, y), colour.mix(f64::from(cov.min(1.0))));
                }
            });
            res?;
        }
        Ok(())
    }
}

fn input_err(dir: &Path, stem: &str, msg: impl Into<String>) -> FigureError {
    let path = dir.join(format!("{stem}.{{png,svg}}"));
    FigureError::Input {
        path,
        msg: msg.into(),
    }
}

fn check_stem(dir: &Path, stem: &str) -> Result<(), FigureError> {
    if stem.is_empty() || stem == "." || stem == ".." || stem.contains(['/', '\\']) {
        return Err(input_err(dir, stem, "the stem must be a plain file name"));
    }
    Ok(())
}

/// Draws `fig` to `<dir>/<stem>.png` and `<dir>/<stem>.svg`.
fn render(dir: &Path, stem: &str, fig: &impl Figure) -> Result<[PathBuf; 2], FigureError> {
    check_stem(dir, stem)?;
    let png_path = dir.join(format!("{stem}.png"));
    let svg_path = dir.join(format!("{stem}.svg"));
    if face().is_none() {
        return Err(FigureError::Font { path: png_path });
    }
    let draw_err = |path: &Path, e: Box<dyn Error>| FigureError::Draw {
        path: path.to_path_buf(),
        msg: e.to_string(),
    };
    let (w, h) = fig.size();
    let rasters = fig.rasters();

    let mut buf = vec![255u8; 3 * w as usize * h as usize];
    for r in &rasters {
        blit(&mut buf, w, r);
    }
    {
        let root = Typeset {
            inner: BitMapBackend::with_buffer(&mut buf, (w, h)),
            raster: true,
        }
        .into_drawing_area();
        fig.draw(&root)
            .and_then(|()| Ok(root.present()?))
            .map_err(|e| draw_err(&png_path, e))?;
    }
    let png = encode_png(&buf, w, h).map_err(|source| FigureError::Encode {
        path: png_path.clone(),
        source,
    })?;

    let mut svg = String::new();
    {
        let root = Typeset {
            inner: SVGBackend::with_string(&mut svg, (w, h)),
            raster: false,
        }
        .into_drawing_area();
        fig.draw(&root)
            .and_then(|()| Ok(root.present()?))
            .map_err(|e| draw_err(&svg_path, e))?;
    }
    let svg = embed_rasters(&svg, w, h, &rasters).map_err(|source| FigureError::Encode {
        path: svg_path.clone(),
        source,
    })?;

    fs::create_dir_all(dir).map_err(|source| FigureError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    write_atomic(&png_path, &png)?;
    write_atomic(&svg_path, svg.as_bytes())?;
    Ok([png_path, svg_path])
}

/// Writes `bytes` to a unique temporary file beside `path`, syncs it and renames it over `path`.
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), FigureError> {
    static SEQ: AtomicU64 = AtomicU64::new(0);
    let name = path.file_name().unwrap_or_default().to_string_lossy();
    let seq = SEQ.fetch_add(1, Ordering::Relaxed);
    let tmp = path.with_file_name(format!(".{name}.{}-{seq}.tmp", std::process::id()));
    let res = (|| -> io::Result<()> {
        let mut f = fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        fs::rename(&tmp, path)
    })();
    if res.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    res.map_err(|source| FigureError::Io {
        path: path.to_path_buf(),
        source,
    })
}

fn blit(buf: &mut [u8], width: u32, r: &Raster) {
    let (row_len, x) = (3 * r.w as usize, 3 * r.x as usize);
    for (i, src) in r.rgb.chunks_exact(row_len).enumerate() {
        let at = (r.y as usize + i) * 3 * width as usize + x;
        buf[at..at + row_len].copy_from_slice(src);
    }
}

fn encode_png(rgb: &[u8], w: u32, h: u32) -> Result<Vec<u8>, png::EncodingError> {
    let mut out = Vec::new();
    let mut enc = png::Encoder::new(&mut out, w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header()?;
    writer.write_image_data(rgb)?;
    writer.finish()?;
    Ok(out)
}

fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for c in bytes.chunks(3) {
        let b = |i: usize| u32::from(c.get(i).copied().unwrap_or(0));
        let n = b(0) << 16 | b(1) << 8 | b(2);
        for k in 0..4 {
            s.push(if k <= c.len() {
                char::from(ALPHABET[(n >> (18 - 6 * k)) as usize & 63])
            } else {
                '='
            });
        }
    }
    s
}

/// Puts a white background and the rasters (as PNG data URIs) under everything plotters drew.
fn embed_rasters(
    svg: &str,
    w: u32,
    h: u32,
    rasters: &[Raster],
) -> Result<String, png::EncodingError> {
    let mut under =
        format!("\n<rect x=\"0\" y=\"0\" width=\"{w}\" height=\"{h}\" fill=\"#FFFFFF\"/>\n");
    for r in rasters {
        let data = base64(&encode_png(&r.rgb, r.w, r.h)?);
        let _ = writeln!(
            under,
            "<image x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" preserveAspectRatio=\"none\" \
             image-rendering=\"optimizeSpeed\" style=\"image-rendering:pixelated\" \
             href=\"data:image/png;base64,{data}\"/>",
            r.x, r.y, r.w, r.h
        );
    }
    let at = svg
        .find("<svg")
        .and_then(|s| svg[s..].find('>').map(|e| s + e + 1))
        .unwrap_or(0);
    Ok(format!("{}{under}{}", &svg[..at], &svg[at..]))
}

fn text(size: f64, h: HPos, v: VPos) -> TextStyle<'static> {
    TextStyle::from((FAMILY, size).into_font())
        .color(&BLACK)
        .pos(Pos::new(h, v))
}

/// Text read bottom to top, centred on its position.
fn vtext(size: f64) -> TextStyle<'static> {
    TextStyle::from(
        (FAMILY, size)
            .into_font()
            .transform(FontTransform::Rotate270),
    )
    .color(&BLACK)
    .pos(Pos::new(HPos::Center, VPos::Center))
}

/// Smallest step of 1, 2 or 5 times a power of ten that cuts `span` into at most `max` steps.
fn nice_step(span: f64, max: f64) -> f64 {
    let base = 10f64.powf((span / max).log10().floor());
    [1.0, 2.0, 5.0]
        .into_iter()
        .map(|m| m * base)
        .find(|s| span / s <= max)
        .unwrap_or(10.0 * base)
}

fn fmt_tick(v: f64, step: f64) -> String {
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    let v = if v.abs() < step * 1e-9 { 0.0 } else { v };
    format!("{v:.decimals$}")
}

/// Finite min..max of `values`; (0, 1) if none, widened by 0.5 each way if min == max.
fn finite_range(values: impl IntoIterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    match (lo, hi) {
        _ if lo > hi => (0.0, 1.0),
        _ if lo == hi => (lo - 0.5, hi + 0.5),
        _ => (lo, hi),
    }
}

/// Cell index range of output pixel `i` when `n` cells map onto `m` pixels.
fn span(i: usize, n: usize, m: usize) -> Range<usize> {
    let a = i * n / m;
    a..((i + 1) * n / m).max(a + 1)
}

/// Resamples `map` to `w` x `h` pixels (row-major): nearest cell when enlarging, mean of the
/// non-NaN cells under a pixel when shrinking (NaN only if all of them are NaN).
fn resample(map: ArrayView2<f64>, w: usize, h: usize) -> Vec<f64> {
    let (rows, cols) = map.dim();
    let xs: Vec<Range<usize>> = (0..w).map(|x| span(x, cols, w)).collect();
    let mut out = Vec::with_capacity(w * h);
    for y in 0..h {
        let block = map.slice(ndarray::s![span(y, rows, h), ..]);
        for xr in &xs {
            let (sum, n) = block
                .slice(ndarray::s![.., xr.clone()])
                .iter()
                .filter(|v| !v.is_nan())
                .fold((0.0, 0u32), |(s, n), v| (s + v, n + 1));
            out.push(if n > 0 { sum / f64::from(n) } else { f64::NAN });
        }
    }
    out
}

// ---------------------------------------------------------------- heat-map grid

/// Side of a panel's plot square in pixels (divisible by 32, 16 and 8: crisp level maps).
const PANEL: u32 = 224;
const PAD_L: u32 = 64;
const PAD_R: u32 = 14;
const PAD_T: u32 = 30;
const PAD_B: u32 = 50;
const CELL_W: u32 = PAD_L + PANEL + PAD_R;
const CELL_H: u32 = PAD_T + PANEL + PAD_B;
/// Height of the figure title band, and width of the colour-bar band on the right.
const HEAD: u32 = 44;
const BAR_AREA: u32 = 140;
const BAR_W: u32 = 18;

/// Pixel size of a heat-map grid with `nrows` x `ncols` panels.
fn grid_size(nrows: usize, ncols: usize) -> (u32, u32) {
    (
        ncols as u32 * CELL_W + BAR_AREA,
        HEAD + nrows as u32 * CELL_H,
    )
}

/// Image size of a `rows` x `cols` map fitted into the panel square, aspect ratio preserved.
fn fit(rows: usize, cols: usize) -> (u32, u32) {
    let s = f64::from(PANEL) / rows.max(cols) as f64;
    let px = |n: usize| ((n as f64 * s).round() as u32).clamp(1, PANEL);
    (px(cols), px(rows))
}

/// Where a panel's image goes (centred in its plot square) and which axis labels it carries.
struct PanelGeo<'p, 'a> {
    panel: &'p Panel<'a>,
    x: u32,
    y: u32,
    w: u32,
    h: u32,
    x_label: bool,
    y_label: bool,
}

struct HeatGrid<'p, 'a> {
    title: &'p str,
    bar_label: &'p str,
    geo: Vec<PanelGeo<'p, 'a>>,
    nrows: usize,
    ncols: usize,
    cmap: ColourMap,
    has_nan: bool,
}

impl HeatGrid<'_, '_> {
    /// Colour bar: left, top, height.
    fn bar(&self) -> (u32, u32, u32) {
        (
            self.ncols as u32 * CELL_W + 16,
            HEAD + PAD_T,
            self.nrows as u32 * CELL_H - PAD_T - PAD_B,
        )
    }
}

impl Figure for HeatGrid<'_, '_> {
    fn size(&self) -> (u32, u32) {
        grid_size(self.nrows, self.ncols)
    }

    fn rasters(&self) -> Vec<Raster> {
        let colour = |vals: &mut dyn Iterator<Item = f64>| -> Vec<u8> {
            vals.flat_map(|v| {
                let (r, g, b) = self.cmap.rgb(v);
                [r, g, b]
            })
            .collect()
        };
        let mut out: Vec<Raster> = self
            .geo
            .iter()
            .map(|g| {
                let vals = resample(g.panel.map, g.w as usize, g.h as usize);
                Raster {
                    x: g.x,
                    y: g.y,
                    w: g.w,
                    h: g.h,
                    rgb: colour(&mut vals.into_iter()),
                }
            })
            .collect();
        let (bx, by, bh) = self.bar();
        let (lo, hi) = (self.cmap.lo, self.cmap.hi);
        let mut vals = (0..bh).flat_map(|y| {
            let v = hi - (f64::from(y) + 0.5) / f64::from(bh) * (hi - lo);
            std::iter::repeat_n(v, BAR_W as usize)
        });
        out.push(Raster {
            x: bx,
            y: by,
            w: BAR_W,
            h: bh,
            rgb: colour(&mut vals),
        });
        out
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let (fig_w, _) = self.size();
        root.draw(&Text::new(
            self.title,
            (fig_w as i32 / 2, 12),
            text(24.0, HPos::Center, VPos::Top),
        ))?;
        let frame = |x: i32, y: i32, w: i32, h: i32| {
            Rectangle::new([(x - 1, y - 1), (x + w, y + h)], BLACK)
        };
        for g in &self.geo {
            let (x, y, w, h) = (g.x as i32, g.y as i32, g.w as i32, g.h as i32);
            root.draw(&Text::new(
                g.panel.title.as_str(),
                (x + w / 2, y - 8),
                text(17.0, HPos::Center, VPos::Bottom),
            ))?;
            root.draw(&frame(x, y, w, h))?;
            let (rows, cols) = g.panel.map.dim();
            let centre = |i: usize, n: usize, len: i32| {
                ((i as f64 + 0.5) * f64::from(len) / n as f64) as i32
            };
            for i in (0..cols).step_by(nice_step(cols as f64, 6.0).max(1.0) as usize) {
                let tx = x + centre(i, cols, w);
                root.draw(&PathElement::new(vec![(tx, y + h), (tx, y + h + 4)], BLACK))?;
                root.draw(&Text::new(
                    i.to_string(),
                    (tx, y + h + 6),
                    text(14.0, HPos::Center, VPos::Top),
                ))?;
            }
            for i in (0..rows).step_by(nice_step(rows as f64, 6.0).max(1.0) as usize) {
                let ty = y + centre(i, rows, h);
                root.draw(&PathElement::new(vec![(x - 5, ty), (x - 1, ty)], BLACK))?;
                root.draw(&Text::new(
                    i.to_string(),
                    (x - 7, ty),
                    text(14.0, HPos::Right, VPos::Center),
                ))?;
            }
            if g.x_label {
                root.draw(&Text::new(
                    "column",
                    (x + w / 2, y + h + 24),
                    text(16.0, HPos::Center, VPos::Top),
                ))?;
            }
            if g.y_label {
                root.draw(&Text::new("row", (x - 46, y + h / 2), vtext(16.0)))?;
            }
        }
        let (bx, by, bh) = self.bar();
        let (bx, by, bh, bw) = (bx as i32, by as i32, bh as i32, BAR_W as i32);
        root.draw(&frame(bx, by, bw, bh))?;
        let (lo, hi) = (self.cmap.lo, self.cmap.hi);
        let step = nice_step(hi - lo, 5.0);
        let mut v = (lo / step).ceil() * step;
        while v <= hi + step * 1e-9 {
            let ty = by
                + (((hi - v) / (hi - lo)) * f64::from(bh))
                    .round()
                    .clamp(0.0, f64::from(bh - 1)) as i32;
            root.draw(&PathElement::new(
                vec![(bx + bw, ty), (bx + bw + 4, ty)],
                BLACK,
            ))?;
            root.draw(&Text::new(
                fmt_tick(v, step),
                (bx + bw + 7, ty),
                text(14.0, HPos::Left, VPos::Center),
            ))?;
            v += step;
        }
        root.draw(&Text::new(
            self.bar_label,
            (bx + bw + 80, by + bh / 2),
            vtext(16.0),
        ))?;
        if self.has_nan {
            let (r, g, b) = NAN_RGB;
            let top = by + bh + 14;
            root.draw(&Rectangle::new(
                [(bx, top), (bx + bw - 1, top + 13)],
                RGBColor(r, g, b).filled(),
            ))?;
            root.draw(&frame(bx, top, bw, 14))?;
            root.draw(&Text::new(
                "NaN",
                (bx + bw + 7, top + 7),
                text(14.0, HPos::Left, VPos::Center),
            ))?;
        }
        Ok(())
    }
}

/// Draws a grid of heat-map panels (`panels[row][column]`, e.g. rows = levels, columns =
/// directions H, V, D) sharing one colour `scale` and one colour bar labelled `bar_label`, with
/// a figure `title`, per-panel titles and axis labels "column" / "row". Each map is scaled to
/// fill its 224-pixel panel square with its aspect ratio preserved (large maps are averaged
/// down to the panel's pixels); NaN cells are grey and listed as "NaN" under the colour bar.
/// Rows may hold different numbers of panels. The size depends only on the grid shape:
/// `302 * columns + 140` by `44 + 304 * rows` pixels. Writes `<dir>/<stem>.png` and `.svg`.
pub fn heatmap_grid(
    dir: &Path,
    stem: &str,
    title: &str,
    panels: &[Vec<Panel>],
    scale: Scale,
    bar_label: &str,
) -> Result<[PathBuf; 2], FigureError> {
    check_stem(dir, stem)?;
    let (nrows, ncols) = (panels.len(), panels.iter().map(Vec::len).max().unwrap_or(0));
    if ncols == 0 {
        return Err(input_err(dir, stem, "no panels"));
    }
    if let Some(p) = panels.iter().flatten().find(|p| p.map.is_empty()) {
        return Err(input_err(
            dir,
            stem,
            format!("panel {:?} has an empty map", p.title),
        ));
    }
    let all = || panels.iter().flatten().flat_map(|p| p.map.iter().copied());
    let cmap = match scale {
        Scale::Diverging { lo, hi } if lo.is_finite() && hi.is_finite() && lo < hi => ColourMap {
            lo,
            hi,
            diverging: true,
        },
        Scale::Diverging { .. } => {
            return Err(input_err(
                dir,
                stem,
                "diverging limits must be finite with lo < hi",
            ))
        }
        Scale::Perceptual => {
            let (lo, hi) = finite_range(all());
            ColourMap {
                lo,
                hi,
                diverging: false,
            }
        }
    };
    let mut geo = Vec::new();
    for (r, row) in panels.iter().enumerate() {
        for (c, panel) in row.iter().enumerate() {
            let (w, h) = fit(panel.map.nrows(), panel.map.ncols());
            let sq = (c as u32 * CELL_W + PAD_L, HEAD + r as u32 * CELL_H + PAD_T);
            let (x, y) = (sq.0 + (PANEL - w) / 2, sq.1 + (PANEL - h) / 2);
            let x_label = panels.get(r + 1).is_none_or(|below| below.len() <= c);
            geo.push(PanelGeo {
                panel,
                x,
                y,
                w,
                h,
                x_label,
                y_label: c == 0,
            });
        }
    }
    let has_nan = all().any(f64::is_nan);
    render(
        dir,
        stem,
        &HeatGrid {
            title,
            bar_label,
            geo,
            nrows,
            ncols,
            cmap,
            has_nan,
        },
    )
}

// ---------------------------------------------------------------- histograms and curves

/// Pixel size of histogram and curve figures.
const CHART_SIZE: (u32, u32) = (800, 520);

/// Matplotlib's "tab10" palette.
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Chart on the whole figure with title, mesh, axis descriptions and the given ranges.
fn chart<'a, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    title: &str,
    (x, x_label): (Range<f64>, &str),
    (y, y_label): (Range<f64>, &str),
    y_fmt: Option<&dyn Fn(&f64) -> String>,
) -> Result<ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>, Box<dyn Error>>
where
    DB::ErrorType: 'static,
{
    let mut chart = ChartBuilder::on(root)
        .caption(title, text(24.0, HPos::Center, VPos::Top))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(70)
        .build_cartesian_2d(x, y)?;
    let mut mesh = chart.configure_mesh();
    mesh.light_line_style(TRANSPARENT)
        .bold_line_style(BLACK.mix(0.1))
        .label_style(text(15.0, HPos::Center, VPos::Center))
        .axis_desc_style(text(17.0, HPos::Center, VPos::Center))
        .x_desc(x_label)
        .y_desc(y_label);
    if let Some(f) = y_fmt {
        mesh.y_label_formatter(f);
    }
    mesh.draw()?;
    Ok(chart)
}

/// Draws the legend at `position` inside the plot.
fn legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    position: SeriesLabelPosition,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .label_font(text(16.0, HPos::Left, VPos::Center))
        .draw()?;
    Ok(())
}

struct Hist<'s> {
    title: &'s str,
    x_label: &'s str,
    names: Vec<String>,
    counts: Vec<Vec<u64>>,
    edges: Vec<f64>,
}

impl Figure for Hist<'_> {
    fn size(&self) -> (u32, u32) {
        CHART_SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let e = &self.edges;
        // Legend in the upper corner with the lower bars (outer quarter of the bins); the y
        // range grows so that the legend (about 20 px a line of a 400 px plot) clears them.
        let peak = |bins: &mut dyn Iterator<Item = usize>| {
            bins.flat_map(|b| self.counts.iter().map(move |c| c[b]))
                .max()
                .unwrap_or(0)
        };
        let n = e.len() - 1;
        let (left, right) = (
            peak(&mut (0..n.div_ceil(4))),
            peak(&mut (n - n.div_ceil(4)..n)),
        );
        let clear = 1.0 - (self.names.len() as f64 * 20.0 + 24.0) / 400.0;
        let all = self
            .counts
            .iter()
            .flatten()
            .copied()
            .max()
            .unwrap_or(0)
            .max(1) as f64;
        let top = (all * 1.1).max(left.min(right) as f64 / clear);
        let position = if right <= left {
            SeriesLabelPosition::UpperRight
        } else {
            SeriesLabelPosition::UpperLeft
        };
        let int = |v: &f64| match v.fract() {
            0.0 => format!("{v:.0}"),
            _ => format!("{v:.1}"),
        };
        let mut chart = chart(
            root,
            self.title,
            (e[0]..e[n], self.x_label),
            (0.0..top, "count"),
            Some(&int),
        )?;
        for (k, (name, counts)) in self.names.iter().zip(&self.counts).enumerate() {
            let c = PALETTE[k % PALETTE.len()];
            let bars = counts.iter().enumerate().filter(|(_, &n)| n > 0);
            chart.draw_series(bars.map(|(b, &n)| {
                Rectangle::new([(e[b], 0.0), (e[b + 1], n as f64)], c.mix(0.25).filled())
            }))?;
            let mut outline = vec![(e[0], 0.0)];
            for (b, &n) in counts.iter().enumerate() {
                outline.extend([(e[b], n as f64), (e[b + 1], n as f64)]);
            }
            outline.push((e[e.len() - 1], 0.0));
            chart
                .draw_series(std::iter::once(PathElement::new(
                    outline,
                    c.stroke_width(2),
                )))?
                .label(name.as_str())
                .legend(move |(x, y)| {
                    EmptyElement::at((x, y))
                        + Rectangle::new([(0, -6), (16, 6)], c.mix(0.25).filled())
                        + Rectangle::new([(0, -6), (16, 6)], c.stroke_width(2))
                });
        }
        legend(&mut chart, position)
    }
}

/// Draws histograms of several named value sets on shared bin edges (`bins` equal bins over
/// the finite min..max of all sets) as semi-transparent bars with solid outlines, y label
/// "count" and a legend; non-finite values are skipped and their number noted in the legend.
/// The figure is 800 x 520 pixels. Writes `<dir>/<stem>.png` and `<dir>/<stem>.svg`.
pub fn histograms(
    dir: &Path,
    stem: &str,
    title: &str,
    sets: &[(&str, &[f64])],
    bins: usize,
    x_label: &str,
) -> Result<[PathBuf; 2], FigureError> {
    check_stem(dir, stem)?;
    if sets.is_empty() || bins == 0 {
        return Err(input_err(
            dir,
            stem,
            "need at least one value set and one bin",
        ));
    }
    let (lo, hi) = finite_range(sets.iter().flat_map(|(_, v)| v.iter().copied()));
    let edges: Vec<f64> = (0..=bins)
        .map(|i| lo + (hi - lo) * i as f64 / bins as f64)
        .collect();
    let mut names = Vec::new();
    let mut counts = Vec::new();
    for (name, values) in sets {
        let mut c = vec![0u64; bins];
        for v in values.iter().filter(|v| v.is_finite()) {
            c[(((v - lo) / (hi - lo) * bins as f64) as usize).min(bins - 1)] += 1;
        }
        let skipped = values.len() as u64 - c.iter().sum::<u64>();
        names.push(if skipped > 0 {
            format!("{name} ({skipped} non-finite)")
        } else {
            name.to_string()
        });
        counts.push(c);
    }
    render(
        dir,
        stem,
        &Hist {
            title,
            x_label,
            names,
            counts,
            edges,
        },
    )
}

/// The plot corner (upper right, upper left, lower right, lower left) holding fewest of `pts`.
fn emptiest_corner(pts: &[(f64, f64)], x: Range<f64>, y: Range<f64>) -> SeriesLabelPosition {
    let uv = |&(px, py): &(f64, f64)| {
        (
            (px - x.start) / (x.end - x.start),
            (py - y.start) / (y.end - y.start),
        )
    };
    let inside = |right: bool, upper: bool, (u, v): (f64, f64)| {
        (if right { u > 0.6 } else { u < 0.4 }) && (if upper { v > 0.7 } else { v < 0.3 })
    };
    [
        (SeriesLabelPosition::UpperRight, true, true),
        (SeriesLabelPosition::UpperLeft, false, true),
        (SeriesLabelPosition::LowerRight, true, false),
        (SeriesLabelPosition::LowerLeft, false, false),
    ]
    .into_iter()
    .min_by_key(|&(_, right, upper)| {
        pts.iter()
            .map(uv)
            .filter(|&p| inside(right, upper, p))
            .count()
    })
    .map_or(SeriesLabelPosition::UpperRight, |c| c.0)
}

struct Curves<'s> {
    title: &'s str,
    x_label: &'s str,
    y_label: &'s str,
    series: Vec<(&'s str, Vec<(f64, f64)>)>,
}

impl Figure for Curves<'_> {
    fn size(&self) -> (u32, u32) {
        CHART_SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let padded = |(lo, hi): (f64, f64), f: f64| (lo - f * (hi - lo))..(hi + f * (hi - lo));
        let points = || self.series.iter().flat_map(|(_, p)| p.iter());
        let x = padded(finite_range(points().map(|p| p.0)), 0.04);
        let y = padded(finite_range(points().map(|p| p.1)), 0.06);
        let mut chart = chart(root, self.title, (x, self.x_label), (y, self.y_label), None)?;
        let mut occupied = Vec::new();
        for (k, (name, pts)) in self.series.iter().enumerate() {
            let c = PALETTE[k % PALETTE.len()];
            chart
                .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(2)))?
                .label(*name)
                .legend(move |(x, y)| {
                    EmptyElement::at((x, y))
                        + PathElement::new(vec![(0, 0), (20, 0)], c.stroke_width(2))
                        + Circle::new((10, 0), 4, c.filled())
                });
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled())))?;
            for w in pts.windows(2) {
                occupied.extend((0..8).map(|k| {
                    let f = f64::from(k) / 8.0;
                    (
                        w[0].0 + f * (w[1].0 - w[0].0),
                        w[0].1 + f * (w[1].1 - w[0].1),
                    )
                }));
            }
            occupied.extend(pts.last());
        }
        let corner = emptiest_corner(&occupied, chart.x_range(), chart.y_range());
        legend(&mut chart, corner)
    }
}

/// Draws named curves y(x) as lines with circle markers, a legend and axis labels (e.g.
/// accuracy or similarity over a swept parameter). Points are sorted by x and non-finite
/// points dropped. The figure is 800 x 520 pixels. Writes `<dir>/<stem>.png` and `.svg`.
pub fn curves(
    dir: &Path,
    stem: &str,
    title: &str,
    series: &[(&str, &[(f64, f64)])],
    x_label: &str,
    y_label: &str,
) -> Result<[PathBuf; 2], FigureError> {
    check_stem(dir, stem)?;
    if series.is_empty() {
        return Err(input_err(dir, stem, "no series"));
    }
    let series = series
        .iter()
        .map(|&(name, pts)| {
            let mut p: Vec<(f64, f64)> = pts
                .iter()
                .copied()
                .filter(|(x, y)| x.is_finite() && y.is_finite())
                .collect();
            p.sort_by(|a, b| a.0.total_cmp(&b.0));
            (name, p)
        })
        .collect();
    render(
        dir,
        stem,
        &Curves {
            title,
            x_label,
            y_label,
            series,
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array2;

    fn decode(path: &Path) -> (u32, u32, Vec<u8>) {
        let file = io::BufReader::new(fs::File::open(path).expect("open png"));
        let mut reader = png::Decoder::new(file).read_info().expect("png header");
        let mut buf = vec![0; reader.output_buffer_size().expect("buffer size")];
        let info = reader.next_frame(&mut buf).expect("png frame");
        assert_eq!(info.color_type, png::ColorType::Rgb);
        buf.truncate(info.buffer_size());
        (info.width, info.height, buf)
    }

    fn dist(a: (u8, u8, u8), b: (u8, u8, u8)) -> f64 {
        let d = |x: u8, y: u8| (f64::from(x) - f64::from(y)).powi(2);
        (d(a.0, b.0) + d(a.1, b.1) + d(a.2, b.2)).sqrt()
    }

    /// Pixels of the decoded image inside the rectangle `[x0, x1) x [y0, y1)`.
    fn pixels(img: &(u32, u32, Vec<u8>), x0: u32, y0: u32, x1: u32, y1: u32) -> Vec<(u8, u8, u8)> {
        let (w, _, buf) = img;
        let mut out = Vec::new();
        for y in y0..y1 {
            for x in x0..x1 {
                let i = 3 * (y * w + x) as usize;
                out.push((buf[i], buf[i + 1], buf[i + 2]));
            }
        }
        out
    }

    /// Renders a single-panel heat map of `map` on the [-1, 1] scale; returns the decoded PNG.
    fn one_panel(dir: &Path, map: &Array2<f64>) -> (u32, u32, Vec<u8>) {
        let panels = vec![vec![Panel {
            title: "p".into(),
            map: map.view(),
        }]];
        let [png, svg] = heatmap_grid(
            dir,
            "one",
            "One",
            &panels,
            Scale::Diverging { lo: -1.0, hi: 1.0 },
            "corr",
        )
        .expect("render");
        assert!(svg.exists());
        decode(&png)
    }

    fn panel_square() -> (u32, u32, u32, u32) {
        (PAD_L, HEAD + PAD_T, PAD_L + PANEL, HEAD + PAD_T + PANEL)
    }

    #[test]
    fn heatmap_grid_writes_png_and_svg() {
        let dir = tempfile::tempdir().expect("tempdir");
        let maps: Vec<Array2<f64>> = [32usize, 16, 8]
            .iter()
            .map(|&n| {
                Array2::from_shape_fn((n, n), |(r, c)| {
                    0.3 + 0.6 * ((r + c) as f64 / (2 * n) as f64)
                })
            })
            .collect();
        let panels: Vec<Vec<Panel>> = (0..3)
            .map(|l| {
                ["H", "V", "D"]
                    .iter()
                    .map(|d| Panel {
                        title: format!("level {} {d}", l + 1),
                        map: maps[l].view(),
                    })
                    .collect()
            })
            .collect();
        let [png, svg] = heatmap_grid(
            dir.path(),
            "grid",
            "Correlation grid",
            &panels,
            Scale::Diverging { lo: -1.0, hi: 1.0 },
            "correlation",
        )
        .expect("render");
        assert_eq!(png, dir.path().join("grid.png"));
        let img = decode(&png);
        assert_eq!((img.0, img.1), grid_size(3, 3));
        assert_eq!((img.0, img.1), (1046, 956));
        let text = fs::read_to_string(&svg).expect("svg");
        assert!(
            text.contains("<svg")
                && text.contains("Correlation grid")
                && text.contains("level 3 D")
        );
        assert!(text.contains("data:image/png;base64,") && text.contains("width=\"1046\""));
        // Every panel fills its square, whatever its cell count: corners are coloured.
        let bg = (255, 255, 255);
        for r in 0..3 {
            for c in 0..3 {
                let (x, y) = (c * CELL_W + PAD_L, HEAD + r * CELL_H + PAD_T);
                for (px, py) in [(x, y), (x + PANEL - 1, y + PANEL - 1)] {
                    assert!(
                        dist(pixels(&img, px, py, px + 1, py + 1)[0], bg) > 40.0,
                        "panel {r},{c} not filled"
                    );
                }
            }
        }
        let leftovers: Vec<_> = fs::read_dir(dir.path())
            .expect("ls")
            .map(|e| e.expect("entry").file_name())
            .collect();
        assert_eq!(leftovers.len(), 2, "temporary files left: {leftovers:?}");
    }

    #[test]
    fn heatmap_colours_span_the_scale() {
        let dir = tempfile::tempdir().expect("tempdir");
        let full = Array2::from_shape_fn((9, 9), |(r, c)| -1.0 + 2.0 * (9 * r + c) as f64 / 80.0);
        let img = one_panel(dir.path(), &full);
        let (x0, y0, x1, y1) = panel_square();
        let px = pixels(&img, x0, y0, x1, y1);
        let blue = diverging_rgb(-1.0, -1.0, 1.0);
        let red = diverging_rgb(1.0, -1.0, 1.0);
        let mid = diverging_rgb(0.0, -1.0, 1.0);
        for target in [blue, red, mid, (255, 255, 255)] {
            assert!(
                px.iter().any(|&p| dist(p, target) < 15.0),
                "no pixel near {target:?}"
            );
        }
        let half = Array2::from_shape_fn((9, 9), |(r, c)| 0.5 * (9 * r + c) as f64 / 80.0);
        let img = one_panel(dir.path(), &half);
        let px = pixels(&img, x0, y0, x1, y1);
        assert!(
            px.iter().all(|&p| dist(p, blue) > 60.0),
            "blue end colour drawn for values in [0, 0.5]"
        );
    }

    #[test]
    fn nan_cells_are_grey_and_listed() {
        let dir = tempfile::tempdir().expect("tempdir");
        let mut map = Array2::from_elem((4, 4), 0.8);
        map[[0, 3]] = f64::NAN;
        let img = one_panel(dir.path(), &map);
        let (x0, y0, ..) = panel_square();
        let cell = PANEL / 4;
        let at = |r: u32, c: u32| {
            pixels(
                &img,
                x0 + c * cell + cell / 2,
                y0 + r * cell + cell / 2,
                x0 + c * cell + cell / 2 + 1,
                y0 + r * cell + cell / 2 + 1,
            )[0]
        };
        assert_eq!(at(0, 3), NAN_RGB);
        assert_eq!(at(1, 3), diverging_rgb(0.8, -1.0, 1.0));
        let svg = fs::read_to_string(dir.path().join("one.svg")).expect("svg");
        assert!(
            svg.contains(">\nNaN\n<") || svg.contains(">NaN<"),
            "NaN legend missing"
        );
    }

    #[test]
    fn large_map_is_resampled() {
        let dir = tempfile::tempdir().expect("tempdir");
        let map = Array2::from_shape_fn((1024, 1024), |(r, c)| {
            ((r * 7 + c * 13) % 101) as f64 / 50.0 - 1.0
        });
        let panels = vec![vec![Panel {
            title: "big".into(),
            map: map.view(),
        }]];
        let [png, _] = heatmap_grid(
            dir.path(),
            "big",
            "Big",
            &panels,
            Scale::Perceptual,
            "value",
        )
        .expect("render");
        let (w, h, _) = decode(&png);
        assert_eq!((w, h), grid_size(1, 1));
    }

    #[test]
    fn histograms_and_curves_write_files() {
        let dir = tempfile::tempdir().expect("tempdir");
        let a: Vec<f64> = (0..500).map(|i| (i as f64 * 0.37).sin()).collect();
        let b: Vec<f64> = (0..300)
            .map(|i| 0.5 + (i as f64 * 0.11).cos() * 0.4)
            .chain([f64::NAN])
            .collect();
        let [png, svg] = histograms(
            dir.path(),
            "hist",
            "Value histograms",
            &[("real", &a), ("synthetic", &b)],
            30,
            "value",
        )
        .expect("hist");
        let (w, h, _) = decode(&png);
        assert_eq!((w, h), CHART_SIZE);
        let text = fs::read_to_string(&svg).expect("svg");
        assert!(
            text.contains("<svg")
                && text.contains("Value histograms")
                && text.contains("synthetic (1 non-finite)")
        );

        let s1: Vec<(f64, f64)> = (1..=8).map(|i| (i as f64, 1.0 - 0.5 / i as f64)).collect();
        let s2: Vec<(f64, f64)> = (1..=8).map(|i| (i as f64, 0.4 + 0.05 * i as f64)).collect();
        let [png, svg] = curves(
            dir.path(),
            "curves",
            "Accuracy vs levels",
            &[("svm", &s1), ("knn", &s2)],
            "levels",
            "accuracy",
        )
        .expect("curves");
        let (w, h, _) = decode(&png);
        assert_eq!((w, h), CHART_SIZE);
        let text = fs::read_to_string(&svg).expect("svg");
        assert!(
            text.contains("<svg") && text.contains("Accuracy vs levels") && text.contains("knn")
        );
    }

    #[test]
    fn bad_input_names_the_file() {
        let dir = tempfile::tempdir().expect("tempdir");
        let err = heatmap_grid(dir.path(), "empty", "t", &[], Scale::Perceptual, "v")
            .expect_err("no panels");
        assert!(
            matches!(err, FigureError::Input { .. }) && err.to_string().contains("empty.{png,svg}")
        );
        assert!(histograms(dir.path(), "a/b", "t", &[("x", &[1.0])], 5, "x").is_err());
        assert!(curves(dir.path(), "c", "t", &[], "x", "y").is_err());
    }

    #[test]
    fn colour_scales() {
        assert!(dist(diverging_rgb(0.0, -1.0, 1.0), (255, 255, 255)) < 15.0);
        assert_eq!(diverging_rgb(-1.0, -1.0, 1.0), (5, 48, 97));
        assert_eq!(diverging_rgb(1.0, -1.0, 1.0), (103, 0, 31));
        assert_eq!(diverging_rgb(-5.0, -1.0, 1.0), (5, 48, 97));
        assert_eq!(diverging_rgb(f64::NAN, -1.0, 1.0), NAN_RGB);
        // Lightness rises towards the midpoint and falls after it; blue side is blue, red side red.
        let luma = |(r, g, b): (u8, u8, u8)| {
            0.299 * f64::from(r) + 0.587 * f64::from(g) + 0.114 * f64::from(b)
        };
        let vs: Vec<f64> = (0..=200).map(|i| -1.0 + i as f64 / 100.0).collect();
        for w in vs.windows(2) {
            let (a, b) = (
                diverging_rgb(w[0], -1.0, 1.0),
                diverging_rgb(w[1], -1.0, 1.0),
            );
            if w[1] <= 0.0 {
                assert!(
                    luma(b) >= luma(a) - 1e-9 && a.2 >= a.0,
                    "not monotone at {}",
                    w[0]
                );
            } else if w[0] >= 0.0 {
                assert!(
                    luma(b) <= luma(a) + 1e-9 && b.0 >= b.2,
                    "not monotone at {}",
                    w[0]
                );
            }
        }
        assert_eq!(viridis_rgb(0.0), (0x44, 0x01, 0x54));
        assert_eq!(viridis_rgb(1.0), (0xfd, 0xe7, 0x25));
        assert!(dist(viridis_rgb(0.5), (33, 145, 140)) < 4.0);
    }

    #[test]
    fn helpers() {
        assert_eq!(base64(b"Man"), "TWFu");
        assert_eq!(base64(b"Ma"), "TWE=");
        assert_eq!(base64(b"M"), "TQ==");
        assert_eq!(nice_step(32.0, 6.0), 10.0);
        assert_eq!(nice_step(2.0, 5.0), 0.5);
        assert_eq!(fmt_tick(-1e-17, 0.5), "0.0");
        assert_eq!(
            resample(
                Array2::from_shape_vec((2, 2), vec![1.0, f64::NAN, 3.0, f64::NAN])
                    .expect("shape")
                    .view(),
                1,
                1
            ),
            vec![2.0]
        );
        assert_eq!(
            (fit(32, 32), fit(8, 8), fit(16, 64)),
            ((224, 224), (224, 224), (224, 56))
        );
        assert_eq!(span(6, 32, 224), 0..1);
        assert_eq!(span(7, 32, 224), 1..2);
    }
}
