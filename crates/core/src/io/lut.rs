//! Radiometric calibration by a 2-D look-up table: a table of scale values on a coarse grid
//! of a scene's own axes, as NISAR's RSLC and GSLC products carry them
//! (`metadata/calibrationInformation/geometry/{beta0, sigma0, gamma0}` over zero-Doppler time
//! and slant range, or map x and y) and Sentinel-1's calibration annotations (`sigmaNought`,
//! `betaNought`, `gamma` over image lines and pixels). The table's value at a pixel is read
//! bilinearly between its grid points, clamped to the grid's edges (the mission's `isce3`
//! `LUT2d` reads NISAR's tables so), and the quantity is `|value|^2 / table^2` (ASF's NISAR
//! documentation, *GSLC: backscatter*: "divide [beta0] by the square of the values provided in
//! either the sigma0 or gamma0 LUT", the beta0 table holding 1 where the data are valid; ESA's
//! *Radiometric Calibration of Sentinel-1 Level-1 Products*: `|DN|^2 / A^2`). So a calibrated
//! read divides each value by the table at its pixel ([`GridLut::apply`]).

use crate::io::cut::Window;
use num_complex::Complex32;

/// A scene's calibration: the quantity `|value|^2` is made, where its scale comes from, and
/// the scale (HDF5 scenes: NISAR's tables, ICEYE's factor; Sentinel-1 measurements: their
/// SAFE annotation's tables).
#[derive(Debug, Clone, PartialEq)]
pub struct Calibrated {
    /// `beta0`, `sigma0` or `gamma0`.
    pub quantity: String,
    /// What gives the scale: a dataset of the file (`/calibration_factor`, NISAR's table) or
    /// an annotation file.
    pub source: String,
    /// The scale.
    pub scale: Scale,
}

/// How a calibrated read scales the stored values.
#[derive(Debug, Clone, PartialEq)]
pub enum Scale {
    /// Every value times one factor (ICEYE's: the root of its `calibration_factor`).
    Factor(f32),
    /// Every value divided by the table at its pixel.
    Table(Box<GridLut>),
}

impl Calibrated {
    /// Calibrates `out`, the values of the scene's `window` row after row.
    pub fn apply(&self, window: &Window, out: &mut [Complex32]) {
        match &self.scale {
            Scale::Factor(k) => out.iter_mut().for_each(|v| *v *= *k),
            Scale::Table(t) => t.apply(window, out),
        }
    }
}

/// Where a coordinate falls on a table's axis: the grid point before it and the share of the
/// way to the next (`0 <= share <= 1`; clamped at the ends).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Place {
    /// Index of the grid point at or before the coordinate.
    i: usize,
    /// Share of the way from point `i` to point `i + 1`.
    u: f64,
}

/// Where `x` falls on `axis` (strictly increasing or strictly decreasing, at least one
/// point): a coordinate outside it takes the nearest end's value.
fn place(axis: &[f64], x: f64) -> Place {
    let n = axis.len();
    if n == 1 {
        return Place { i: 0, u: 0.0 };
    }
    let rising = axis[n - 1] > axis[0];
    // The points at or before x along the axis's direction.
    let before = axis.partition_point(|&a| if rising { a <= x } else { a >= x });
    let i = before.clamp(1, n - 1) - 1;
    let u = ((x - axis[i]) / (axis[i + 1] - axis[i])).clamp(0.0, 1.0);
    Place { i, u }
}

/// A calibration table placed on a scene: the table and, for each of the scene's rows and
/// columns, where its coordinate falls on the table's axes.
#[derive(Debug, Clone, PartialEq)]
pub struct GridLut {
    /// The table's values, row after row (`row_places` index its rows).
    values: Vec<f64>,
    /// Columns of the table.
    width: usize,
    /// Where each scene row falls on the table's row axis.
    row_places: Vec<Place>,
    /// Where each scene column falls on the table's column axis.
    col_places: Vec<Place>,
}

impl GridLut {
    /// The table `values` (`row_axis.len()` x `col_axis.len()`, row after row) over the
    /// coordinates `row_axis` and `col_axis`, placed on a scene whose rows lie at `rows` and
    /// columns at `cols` (in the same units as the axes).
    ///
    /// # Errors
    /// If the table's size is not its axes', an axis is empty, not finite or not strictly
    /// monotonic, a scene coordinate is not finite, or a table value is not a positive
    /// number (the message says which, and where).
    pub fn new(
        values: Vec<f64>,
        (row_axis, col_axis): (&[f64], &[f64]),
        (rows, cols): (&[f64], &[f64]),
    ) -> Result<GridLut, String> {
        let (h, w) = (row_axis.len(), col_axis.len());
        if values.len() != h * w {
            return Err(format!(
                "the table holds {} values for its axes' {h} x {w}",
                values.len()
            ));
        }
        for (axis, name) in [(row_axis, "row"), (col_axis, "column")] {
            monotonic(axis).map_err(|m| format!("the table's {name} axis {m}"))?;
        }
        for (coords, name) in [(rows, "row"), (cols, "column")] {
            if let Some(k) = coords.iter().position(|c| !c.is_finite()) {
                return Err(format!("the scene's {name} coordinate {k} is not finite"));
            }
        }
        if let Some(k) = values.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(format!(
                "the table's value at [{}, {}] is {}, not a positive number",
                k / w,
                k % w,
                values[k]
            ));
        }
        Ok(GridLut {
            values,
            width: w,
            row_places: rows.iter().map(|&y| place(row_axis, y)).collect(),
            col_places: cols.iter().map(|&x| place(col_axis, x)).collect(),
        })
    }

    /// The table's value at its row `i` (clamped to the last) and column `j` (likewise).
    fn value(&self, i: usize, j: usize) -> f64 {
        let i = i.min(self.values.len() / self.width - 1);
        self.values[i * self.width + j.min(self.width - 1)]
    }

    /// The table's value at the scene's pixel `(r, c)`: bilinear between the four grid
    /// points around it (first along the rows, then across: the order [`GridLut::apply`]
    /// keeps, value for value).
    pub fn at(&self, r: usize, c: usize) -> f64 {
        let (p, q) = (self.row_places[r], self.col_places[c]);
        let down = |j: usize| self.value(p.i, j) * (1.0 - p.u) + self.value(p.i + 1, j) * p.u;
        down(q.i) * (1.0 - q.u) + down(q.i + 1) * q.u
    }

    /// Calibrates `out`, the values of the scene's `window` row after row: each divided by
    /// the table at its pixel ([`GridLut::at`], rounded to a `f32`), as numpy divides a
    /// complex64 by a float32 (both parts times the float32 reciprocal). Rows on
    /// every core, each with the table first read down to its row at every table column.
    pub fn apply(&self, window: &Window, out: &mut [Complex32]) {
        use rayon::prelude::*;
        let width = window.c1 - window.c0;
        let cols = &self.col_places[window.c0..window.c1];
        let rows = out.par_chunks_mut(width).enumerate();
        rows.for_each_init(Vec::new, |line, (k, row)| {
            let p = self.row_places[window.r0 + k];
            line.clear();
            line.extend(
                (0..=self.width)
                    .map(|j| self.value(p.i, j) * (1.0 - p.u) + self.value(p.i + 1, j) * p.u),
            );
            for (z, q) in row.iter_mut().zip(cols) {
                let v = line[q.i] * (1.0 - q.u) + line[q.i + 1] * q.u;
                *z *= 1.0 / v as f32;
            }
        });
    }
}

/// Why `axis` is not a table's axis (or any axis of positions): empty, not finite, or not
/// strictly monotonic.
///
/// # Errors
/// Saying which, and where.
pub(crate) fn monotonic(axis: &[f64]) -> Result<(), String> {
    if axis.is_empty() {
        return Err("is empty".into());
    }
    if let Some(k) = axis.iter().position(|a| !a.is_finite()) {
        return Err(format!("value {k} is not finite"));
    }
    let rising = axis.len() < 2 || axis[1] > axis[0];
    match axis
        .windows(2)
        .position(|p| if rising { p[1] <= p[0] } else { p[1] >= p[0] })
    {
        Some(k) => Err(format!(
            "is not strictly monotonic (values {k} and {})",
            k + 1
        )),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// A plane `a + b y + c x` sampled on the axes: bilinear reading reproduces it exactly
    /// inside the grid, whichever way the axes run.
    fn plane(y: f64, x: f64) -> f64 {
        3.0 + 0.25 * y - 0.125 * x
    }

    #[test]
    fn a_plane_is_read_back_inside_and_clamped_outside() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(49);
        for (rise_r, rise_c) in [(true, true), (false, true), (true, false), (false, false)] {
            let axis = |n: usize, step: f64, rising: bool| -> Vec<f64> {
                let v: Vec<f64> = (0..n).map(|k| 10.0 + step * k as f64).collect();
                if rising {
                    v
                } else {
                    v.into_iter().rev().collect()
                }
            };
            let (ra, ca) = (axis(5, 2.0, rise_r), axis(4, 3.0, rise_c));
            let values: Vec<f64> = ra
                .iter()
                .flat_map(|&y| ca.iter().map(move |&x| 100.0 + plane(y, x)))
                .collect();
            let rows: Vec<f64> = (0..40).map(|_| rng.random_range(6.0..22.0)).collect();
            let cols: Vec<f64> = (0..30).map(|_| rng.random_range(6.0..23.0)).collect();
            let lut = GridLut::new(values, (&ra, &ca), (&rows, &cols)).unwrap();
            for (r, &y) in rows.iter().enumerate() {
                for (c, &x) in cols.iter().enumerate() {
                    // Outside the axes' span (10..18 rows, 10..19 columns) the edge's value.
                    let want = 100.0 + plane(y.clamp(10.0, 18.0), x.clamp(10.0, 19.0));
                    let got = lut.at(r, c);
                    assert!((got - want).abs() < 1e-12, "{y} {x}: {got} vs {want}");
                }
            }
        }
    }

    #[test]
    fn apply_divides_each_value_by_the_table_at_its_pixel() {
        let (ra, ca) = ([0.0, 10.0], [0.0, 10.0]);
        let values = vec![1.0, 2.0, 3.0, 4.0];
        let (rows, cols) = ([0.0, 5.0, 10.0], [0.0, 10.0]);
        let lut = GridLut::new(values, (&ra, &ca), (&rows, &cols)).unwrap();
        let win = Window {
            r0: 1,
            r1: 3,
            c0: 0,
            c1: 2,
        };
        let mut out = vec![Complex32::new(6.0, -6.0); 4];
        lut.apply(&win, &mut out);
        // Row 1 is half way: 2 and 3; row 2 the last: 3 and 4.
        let want = [2.0, 3.0, 3.0, 4.0].map(|t: f32| Complex32::new(6.0 / t, -6.0 / t));
        assert_eq!(out, want);
    }

    #[test]
    fn apply_is_the_pixel_by_pixel_definition_value_for_value() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(50);
        let ra: Vec<f64> = (0..7).map(|k| 100.0 + 50.0 * k as f64).collect();
        let ca: Vec<f64> = (0..5).map(|k| 900.0 - 40.0 * k as f64).collect();
        let values: Vec<f64> = (0..35).map(|_| rng.random_range(0.5..2.0)).collect();
        let rows: Vec<f64> = (0..90).map(|k| 80.0 + 4.0 * k as f64).collect();
        let cols: Vec<f64> = (0..70).map(|k| 600.0 + 4.7 * k as f64).collect();
        let lut = GridLut::new(values, (&ra, &ca), (&rows, &cols)).unwrap();
        let win = Window {
            r0: 3,
            r1: 88,
            c0: 5,
            c1: 69,
        };
        let data: Vec<Complex32> = (0..win.rows() * win.cols())
            .map(|_| Complex32::new(rng.random_range(-9.0..9.0), rng.random_range(-9.0..9.0)))
            .collect();
        let mut fast = data.clone();
        lut.apply(&win, &mut fast);
        for (k, (z, f)) in data.iter().zip(&fast).enumerate() {
            let (r, c) = (win.r0 + k / win.cols(), win.c0 + k % win.cols());
            assert_eq!(*f, *z * (1.0 / lut.at(r, c) as f32), "pixel ({r}, {c})");
        }
    }

    #[test]
    fn bad_tables_are_refused_saying_where() {
        let (ra, ca, s) = ([0.0, 1.0], [0.0, 1.0], [0.5]);
        let e = GridLut::new(vec![1.0; 3], (&ra, &ca), (&s, &s)).unwrap_err();
        assert!(e.contains("holds 3 values for its axes' 2 x 2"), "{e}");
        let e = GridLut::new(vec![1.0, 1.0, 0.0, 1.0], (&ra, &ca), (&s, &s)).unwrap_err();
        assert!(e.contains("value at [1, 0] is 0, not a positive"), "{e}");
        let e = GridLut::new(vec![1.0; 4], (&[0.0, 0.0], &ca), (&s, &s)).unwrap_err();
        assert!(e.contains("row axis is not strictly monotonic"), "{e}");
        let e = GridLut::new(vec![1.0; 4], (&ra, &ca), (&s, &[f64::NAN])).unwrap_err();
        assert!(e.contains("column coordinate 0 is not finite"), "{e}");
    }
}
