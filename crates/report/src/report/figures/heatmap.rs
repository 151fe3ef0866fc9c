//! Grids of heat maps (levels x directions, or any panels) that share one colour scale and
//! one colour bar; NaN cells are grey.

use super::{
    cache, check_stem, finite_range, fmt_tick, input_err, nice_step, render, resample, text, vtext,
    ColourMap, DrawResult, Figure, FigureError, Panel, Raster, Scale, NAN_RGB,
};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Side of a panel's plot square in pixels (divisible by 32, 16 and 8: crisp level maps).
pub(super) const PANEL: u32 = 224;
pub(super) const PAD_L: u32 = 64;
const PAD_R: u32 = 14;
pub(super) const PAD_T: u32 = 30;
const PAD_B: u32 = 50;
pub(super) const CELL_W: u32 = PAD_L + PANEL + PAD_R;
pub(super) const CELL_H: u32 = PAD_T + PANEL + PAD_B;
/// Height of the figure title band, and width of the colour-bar band on the right.
pub(super) const HEAD: u32 = 44;
const BAR_AREA: u32 = 140;
const BAR_W: u32 = 18;

/// Pixel size of a heat-map grid with `nrows` x `ncols` panels.
pub(super) fn grid_size(nrows: usize, ncols: usize) -> (u32, u32) {
    (
        ncols as u32 * CELL_W + BAR_AREA,
        HEAD + nrows as u32 * CELL_H,
    )
}

/// Image size of a `rows` x `cols` map fitted into the panel square, aspect ratio preserved.
pub(super) fn fit(rows: usize, cols: usize) -> (u32, u32) {
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

/// Options of [`heatmap_grid_with`] beyond the panels and the scale.
#[derive(Debug, Clone)]
pub struct GridOptions<'o> {
    /// Label under the panels of the bottom row (`"column"` in [`heatmap_grid`]).
    pub x_label: &'o str,
    /// Label left of the panels of the first column (`"row"` in [`heatmap_grid`]).
    pub y_label: &'o str,
    /// Write each cell's value in it (rounded to an integer; only for maps of at most 12 x 12
    /// cells), e.g. the counts of a confusion matrix.
    pub annotate: bool,
    /// Rectangles outlined over the panels, by panel in row-major order (missing entries: none):
    /// `[first row, first column, rows, columns]` in cells, e.g. a target's footprint.
    pub boxes: Vec<Vec<[usize; 4]>>,
}

impl Default for GridOptions<'_> {
    fn default() -> Self {
        Self {
            x_label: "column",
            y_label: "row",
            annotate: false,
            boxes: vec![],
        }
    }
}

/// Largest map side whose cells [`GridOptions::annotate`] writes values into.
const ANNOTATE_MAX: usize = 12;

struct HeatGrid<'p, 'a> {
    title: &'p str,
    options: &'p GridOptions<'p>,
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

impl HeatGrid<'_, '_> {
    /// Draws panel `i`'s boxes and, when asked, its cell values.
    fn overlay<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        i: usize,
        g: &PanelGeo,
    ) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let (rows, cols) = g.panel.map.dim();
        let px =
            |c: usize, n: usize, len: u32| (c as f64 * f64::from(len) / n as f64).round() as i32;
        let (x, y) = (g.x as i32, g.y as i32);
        for b in self.options.boxes.get(i).into_iter().flatten() {
            let (r0, c0) = (b[0].min(rows), b[1].min(cols));
            let (r1, c1) = ((b[0] + b[2]).min(rows), (b[1] + b[3]).min(cols));
            let corner = |r: usize, c: usize| (x + px(c, cols, g.w), y + px(r, rows, g.h));
            let (a, z) = (corner(r0, c0), corner(r1, c1));
            for (width, colour) in [(3, WHITE), (1, BLACK)] {
                root.draw(&Rectangle::new(
                    [a, (z.0 - 1, z.1 - 1)],
                    colour.stroke_width(width),
                ))?;
            }
        }
        if !self.options.annotate || rows > ANNOTATE_MAX || cols > ANNOTATE_MAX {
            return Ok(());
        }
        for ((r, c), &v) in g.panel.map.indexed_iter() {
            if !v.is_finite() {
                continue;
            }
            let (cr, cg, cb) = self.cmap.rgb(v);
            let light = 0.299 * f64::from(cr) + 0.587 * f64::from(cg) + 0.114 * f64::from(cb);
            let colour = if light > 140.0 { BLACK } else { WHITE };
            let centre = (
                x + (px(2 * c + 1, 2 * cols, g.w)),
                y + (px(2 * r + 1, 2 * rows, g.h)),
            );
            root.draw(&Text::new(
                format!("{v:.0}"),
                centre,
                text(14.0, HPos::Center, VPos::Center).color(&colour),
            ))?;
        }
        Ok(())
    }
}

impl Figure for HeatGrid<'_, '_> {
    fn size(&self) -> (u32, u32) {
        grid_size(self.nrows, self.ncols)
    }

    fn key(&self, k: &mut cache::Key) {
        let o = self.options;
        k.str("heatmap")
            .str(self.title)
            .str(self.bar_label)
            .str(o.x_label)
            .str(o.y_label)
            .u64(u64::from(o.annotate))
            .u64(o.boxes.len() as u64);
        for b in &o.boxes {
            k.u64(b.len() as u64);
            for &v in b.iter().flatten() {
                k.u64(v as u64);
            }
        }
        k.u64(self.nrows as u64)
            .u64(self.ncols as u64)
            .f64(self.cmap.lo)
            .f64(self.cmap.hi)
            .u64(u64::from(self.cmap.diverging))
            .u64(u64::from(self.has_nan))
            .u64(self.geo.len() as u64);
        for g in &self.geo {
            let (rows, cols) = g.panel.map.dim();
            k.str(&g.panel.title)
                .u64(rows as u64)
                .u64(cols as u64)
                .f64s(g.panel.map.iter().copied())
                .u64(u64::from(g.x))
                .u64(u64::from(g.y))
                .u64(u64::from(g.w))
                .u64(u64::from(g.h))
                .u64(u64::from(g.x_label))
                .u64(u64::from(g.y_label));
        }
    }

    fn rasters(&self) -> Vec<Raster> {
        // Neighbouring pixels mostly show the same cell: its colour is looked up once.
        let colour = |vals: &mut dyn Iterator<Item = f64>| -> Vec<u8> {
            let mut last: Option<(u64, [u8; 3])> = None;
            let mut out = Vec::with_capacity(3 * vals.size_hint().0);
            for v in vals {
                let rgb = match last {
                    Some((bits, rgb)) if bits == v.to_bits() => rgb,
                    _ => {
                        let (r, g, b) = self.cmap.rgb(v);
                        last = Some((v.to_bits(), [r, g, b]));
                        [r, g, b]
                    }
                };
                out.extend_from_slice(&rgb);
            }
            out
        };
        // Panels coloured on the rayon pool (each its own raster).
        let mut out: Vec<Raster> = self
            .geo
            .par_iter()
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

    /// Draws the panels, their axes and labels and the colour bar onto `root`.
    ///
    /// Long because plotters draws each part (panels, axes, labels, colour bar) through its own
    /// chart context, a few lines each.
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
        for (i, g) in self.geo.iter().enumerate() {
            let (x, y, w, h) = (g.x as i32, g.y as i32, g.w as i32, g.h as i32);
            root.draw(&Text::new(
                g.panel.title.as_str(),
                (x + w / 2, y - 8),
                text(17.0, HPos::Center, VPos::Bottom),
            ))?;
            root.draw(&frame(x, y, w, h))?;
            self.overlay(root, i, g)?;
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
                    self.options.x_label,
                    (x + w / 2, y + h + 24),
                    text(16.0, HPos::Center, VPos::Top),
                ))?;
            }
            if g.y_label {
                root.draw(&Text::new(
                    self.options.y_label,
                    (x - 46, y + h / 2),
                    vtext(16.0),
                ))?;
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
    let options = GridOptions::default();
    heatmap_grid_with(dir, stem, title, panels, (scale, bar_label), &options)
}

/// [`heatmap_grid`] with axis labels of one's own, cell values written in (confusion
/// matrices) and rectangles outlined over the panels (a target's footprint, Fig. 72): see
/// [`GridOptions`]. Boxes are drawn white with a black core, so they show on every colour.
pub fn heatmap_grid_with(
    dir: &Path,
    stem: &str,
    title: &str,
    panels: &[Vec<Panel>],
    (scale, bar_label): (Scale, &str),
    options: &GridOptions,
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
            options,
            bar_label,
            geo,
            nrows,
            ncols,
            cmap,
            has_nan,
        },
    )
}
