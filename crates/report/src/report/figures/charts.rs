//! Line charts: overlaid histograms and named curves over a swept parameter, with a legend
//! placed in the emptiest corner.

use super::{
    cache, check_stem, finite_range, input_err, render, text, DrawResult, Figure, FigureError,
};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};
use std::error::Error;
use std::ops::Range;
use std::path::{Path, PathBuf};
/// Pixel size of histogram and curve figures.
pub(super) const CHART_SIZE: (u32, u32) = (800, 520);

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
pub(super) fn legend<'a, DB: DrawingBackend + 'a>(
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

    fn key(&self, k: &mut cache::Key) {
        k.str("histograms")
            .str(self.title)
            .str(self.x_label)
            .u64(self.names.len() as u64);
        for (name, counts) in self.names.iter().zip(&self.counts) {
            k.str(name).u64(counts.len() as u64);
            for &c in counts {
                k.u64(c);
            }
        }
        k.f64s(self.edges.iter().copied());
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

/// A curve's point: x, y and the half-length of its error bar (0: none).
pub type Point = (f64, f64, f64);

struct Curves<'s> {
    title: &'s str,
    x_label: &'s str,
    y_label: &'s str,
    series: Vec<(&'s str, Vec<Point>)>,
    /// Fixed y range (e.g. 0..100 %), else the points' range padded.
    y_range: Option<Range<f64>>,
}

impl Figure for Curves<'_> {
    fn size(&self) -> (u32, u32) {
        CHART_SIZE
    }

    fn key(&self, k: &mut cache::Key) {
        k.str("curves")
            .str(self.title)
            .str(self.x_label)
            .str(self.y_label)
            .u64(self.series.len() as u64);
        for (name, points) in &self.series {
            k.str(name).u64(points.len() as u64);
            for &(x, y, e) in points {
                k.f64(x).f64(y).f64(e);
            }
        }
        match &self.y_range {
            Some(r) => k.u64(1).f64(r.start).f64(r.end),
            None => k.u64(0),
        };
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let padded = |(lo, hi): (f64, f64), f: f64| (lo - f * (hi - lo))..(hi + f * (hi - lo));
        let points = || self.series.iter().flat_map(|(_, p)| p.iter());
        let x = padded(finite_range(points().map(|p| p.0)), 0.04);
        let y = self.y_range.clone().unwrap_or_else(|| {
            padded(
                finite_range(points().flat_map(|p| [p.1 - p.2, p.1 + p.2])),
                0.06,
            )
        });
        let mut chart = chart(root, self.title, (x, self.x_label), (y, self.y_label), None)?;
        let mut occupied = Vec::new();
        for (k, (name, pts)) in self.series.iter().enumerate() {
            let c = PALETTE[k % PALETTE.len()];
            let xy = || pts.iter().map(|p| (p.0, p.1));
            chart
                .draw_series(LineSeries::new(xy(), c.stroke_width(2)))?
                .label(*name)
                .legend(move |(x, y)| {
                    EmptyElement::at((x, y))
                        + PathElement::new(vec![(0, 0), (20, 0)], c.stroke_width(2))
                        + Circle::new((10, 0), 4, c.filled())
                });
            chart.draw_series(xy().map(|p| Circle::new(p, 4, c.filled())))?;
            // Error bars: a vertical line with 10-pixel caps.
            let bars = || pts.iter().filter(|p| p.2 > 0.0);
            chart.draw_series(bars().map(|&(x, y, e)| {
                PathElement::new(vec![(x, y - e), (x, y + e)], c.stroke_width(2))
            }))?;
            chart.draw_series(bars().flat_map(|&(x, y, e)| {
                [y - e, y + e].map(|v| {
                    EmptyElement::at((x, v))
                        + PathElement::new(vec![(-5, 0), (5, 0)], c.stroke_width(2))
                })
            }))?;
            occupied.extend(
                pts.iter()
                    .filter(|p| p.2 > 0.0)
                    .flat_map(|p| [(p.0, p.1 - p.2), (p.0, p.1 + p.2)]),
            );
            let pts: Vec<(f64, f64)> = xy().collect();
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
    let series: Vec<(&str, Vec<Point>)> = series
        .iter()
        .map(|&(name, pts)| (name, pts.iter().map(|&(x, y)| (x, y, 0.0)).collect()))
        .collect();
    let refs: Vec<(&str, &[Point])> = series.iter().map(|(n, p)| (*n, p.as_slice())).collect();
    error_curves(dir, stem, title, &refs, (x_label, y_label), None)
}

/// Like [`curves`], with an error bar on every point: `series` holds `(x, y, e)` and the bar
/// runs from `y - e` to `y + e` (none where `e` is 0 or not finite), as for a mean and its
/// standard deviation over repeats (Figs. 66-67). `y_range` fixes the y axis (e.g. `0.0..100.0`
/// for accuracies in %); without it the axis spans the points and their bars. Points are sorted
/// by x and those with a non-finite x or y dropped. Writes `<dir>/<stem>.png` and `.svg`.
pub fn error_curves(
    dir: &Path,
    stem: &str,
    title: &str,
    series: &[(&str, &[Point])],
    (x_label, y_label): (&str, &str),
    y_range: Option<Range<f64>>,
) -> Result<[PathBuf; 2], FigureError> {
    check_stem(dir, stem)?;
    if series.is_empty() {
        return Err(input_err(dir, stem, "no series"));
    }
    if let Some(r) = &y_range {
        if !(r.start.is_finite() && r.end.is_finite() && r.start < r.end) {
            return Err(input_err(
                dir,
                stem,
                "the y range must be finite and increasing",
            ));
        }
    }
    let series = series
        .iter()
        .map(|&(name, pts)| {
            let mut p: Vec<Point> = pts
                .iter()
                .filter(|(x, y, _)| x.is_finite() && y.is_finite())
                .map(|&(x, y, e)| (x, y, if e.is_finite() { e.abs() } else { 0.0 }))
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
            y_range,
        },
    )
}
