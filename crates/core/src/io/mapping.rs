//! From map coordinates to pixels: a scene's georeferencing ([`Georeference`]: an affine
//! transform, or ground control points as Sentinel-1 SLC files carry them) and the pixel
//! window that covers a box of map coordinates ([`map_window`]). Ground control points are
//! turned into pixels as GDAL's GCP transformer does by default (`GDALCreateGCPTransformer`
//! with order 0): a least-squares polynomial from map coordinates to pixel coordinates, of
//! order 2 from 6 points on, order 1 from 3; the fit's largest residual at the points is
//! reported with the window. A SICD image's pixels are placed by SICD's own projection
//! ([`super::projection`]) at the scene centre's height. A grid of map points sampling the
//! image in blocks of pixels (UAVSAR's `.llh` files: a latitude and longitude every 8 rows and
//! 2 columns) places a box exactly at the grid's resolution: the window covers the blocks
//! whose points lie in the box. Map coordinates at the nodes of a grid over the pixels (a NISAR
//! RSLC's geolocation grid) place a point by inverting the grid's bilinear map
//! ([`super::geogrid`]).

use super::cut::Window;
use super::projection::Projection;

/// One ground control point: the pixel position `(row, col)` (of the pixel grid's corners:
/// pixel `(r, c)` covers `[r, r + 1) x [c, c + 1)`) and its map coordinates `(x, y)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gcp {
    /// Row position.
    pub row: f64,
    /// Column position.
    pub col: f64,
    /// Map x (longitude in a geographic system).
    pub x: f64,
    /// Map y (latitude in a geographic system).
    pub y: f64,
}

/// How a scene's pixels lie in its map coordinates.
#[derive(Debug, Clone, PartialEq)]
pub enum Georeference {
    /// `[x0, dx/dcol, dx/drow, y0, dy/dcol, dy/drow]` (GDAL's `GeoTransform` order: pixel
    /// `(row, col)`'s top-left corner at `x = x0 + col dx/dcol + row dx/drow`, ...).
    Affine([f64; 6]),
    /// Ground control points.
    Gcps(Vec<Gcp>),
    /// SICD's image projection, map coordinates being longitude (`x`) and latitude (`y`) in
    /// degrees on the WGS-84 ellipsoid at `height` (m above it; the scene centre's).
    Sicd {
        /// The image's projection.
        projection: Box<Projection>,
        /// Height of the mapped points above the ellipsoid (m).
        height: f64,
    },
    /// A map point for every block of pixels.
    Grid(Box<PointGrid>),
    /// Map coordinates at the nodes of a grid over the pixels, bilinear between them.
    Nodes(Box<super::geogrid::NodeGrid>),
}

/// Map points sampling an image in blocks: point `(i, j)` (row-major, `rows x cols` of them)
/// stands for the pixels `[i b_r, (i + 1) b_r) x [j b_c, (j + 1) b_c)` (`block = [b_r, b_c]`),
/// clipped to the image's `dims`. A point that is not finite stands for nothing.
#[derive(Debug, Clone, PartialEq)]
pub struct PointGrid {
    /// Points down.
    pub rows: usize,
    /// Points across.
    pub cols: usize,
    /// Pixels a point stands for, `[rows, columns]`.
    pub block: [usize; 2],
    /// The image's `(rows, columns)`.
    pub dims: (usize, usize),
    /// Map x of each point (longitude).
    pub x: Vec<f32>,
    /// Map y of each point (latitude).
    pub y: Vec<f32>,
}

impl PointGrid {
    /// Every finite point, `(index, x, y)` (row-major index).
    fn points(&self) -> impl Iterator<Item = (usize, f64, f64)> + '_ {
        self.x
            .iter()
            .zip(&self.y)
            .enumerate()
            .map(|(k, (&x, &y))| (k, f64::from(x), f64::from(y)))
            .filter(|(_, x, y)| x.is_finite() && y.is_finite())
    }

    /// `[[x0, x1], [y0, y1]]` spanned by the finite points.
    fn extent(&self) -> [[f64; 2]; 2] {
        let empty = [f64::INFINITY, f64::NEG_INFINITY];
        self.points().fold([empty, empty], |[ex, ey], (_, x, y)| {
            [[ex[0].min(x), ex[1].max(x)], [ey[0].min(y), ey[1].max(y)]]
        })
    }

    /// The pixel window of the blocks whose points lie in the box `x` x `y` (edges included).
    ///
    /// # Errors
    /// If no point lies in the box, naming the grid's extent.
    pub fn window(&self, x: [f64; 2], y: [f64; 2]) -> Result<Window, String> {
        let (mut rows, mut cols) = ([usize::MAX, 0], [usize::MAX, 0]);
        for (k, px, py) in self.points() {
            if (x[0]..=x[1]).contains(&px) && (y[0]..=y[1]).contains(&py) {
                let (i, j) = (k / self.cols, k % self.cols);
                rows = [rows[0].min(i), rows[1].max(i)];
                cols = [cols[0].min(j), cols[1].max(j)];
            }
        }
        if rows[0] == usize::MAX {
            let [ex, ey] = self.extent();
            return Err(format!(
                "the box x {x:?}, y {y:?} holds none of the {} x {} grid points (x {ex:?}, y {ey:?})",
                self.rows, self.cols,
            ));
        }
        let [br, bc] = self.block;
        Ok(Window {
            r0: rows[0] * br,
            r1: ((rows[1] + 1) * br).min(self.dims.0),
            c0: cols[0] * bc,
            c1: ((cols[1] + 1) * bc).min(self.dims.1),
        })
    }

    /// The pixel position of map point `(x, y)`: the centre of the block of the nearest grid
    /// point (distances in `x` scaled by `cos y`, as for longitude and latitude), `None` outside
    /// the grid points' extent.
    pub fn pixel(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        let [ex, ey] = self.extent();
        if !((ex[0]..=ex[1]).contains(&x) && (ey[0]..=ey[1]).contains(&y)) {
            return None;
        }
        let scale = y.to_radians().cos().abs().max(1e-9);
        let distance = |px: f64, py: f64| ((px - x) * scale).powi(2) + (py - y).powi(2);
        let (k, _, _) = self
            .points()
            .min_by(|a, b| distance(a.1, a.2).total_cmp(&distance(b.1, b.2)))?;
        let [br, bc] = self.block;
        let (i, j) = (k / self.cols, k % self.cols);
        let r = ((i as f64 + 0.5) * br as f64).min(self.dims.0 as f64);
        let c = ((j as f64 + 0.5) * bc as f64).min(self.dims.1 as f64);
        Some((r, c))
    }
}

/// The pixel window that covers a map box, and how exactly the georeferencing placed it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapWindow {
    /// The pixels.
    pub window: Window,
    /// For ground control points: the fit's order and its largest residual at the points
    /// (pixels); `None` for an affine transform (exact).
    pub fit: Option<(usize, f64)>,
}

/// A GCP fit's order and largest residual at its points (pixels).
pub type Fit = (usize, f64);

/// `(row, col)` of a map point.
type ToPixel<'a> = Box<dyn Fn(f64, f64) -> Option<(f64, f64)> + 'a>;

/// Points mapped along each edge of a box (its corners included): a polynomial map bends the
/// box's edges, so the corners alone may miss pixels the box covers.
const EDGE_POINTS: usize = 17;

/// The pixel window that covers the box `x` x `y` of map coordinates under `georef`: the
/// box's edges in pixel coordinates (corners, and [`EDGE_POINTS`] points an edge for ground
/// control points and node grids), rounded outwards (a coordinate within 1e-6 of a whole pixel taken as that
/// pixel).
///
/// # Errors
/// If the transform is singular, too few or degenerate ground control points, or the box
/// lies above or left of the image.
pub fn map_window(georef: &Georeference, x: [f64; 2], y: [f64; 2]) -> Result<MapWindow, String> {
    if let Georeference::Grid(g) = georef {
        let window = g.window(x, y)?;
        return Ok(MapWindow { window, fit: None });
    }
    let (to_pixel, fit) = transform(georef)?;
    let bends = fit.is_some() || matches!(georef, Georeference::Nodes(_));
    let steps = if bends { EDGE_POINTS - 1 } else { 1 };
    let (mut rows, mut cols) = (
        [f64::INFINITY, f64::NEG_INFINITY],
        [f64::INFINITY, f64::NEG_INFINITY],
    );
    let at = |t: usize, [a, b]: [f64; 2]| a + (b - a) * t as f64 / steps as f64;
    for t in 0..=steps {
        for (xx, yy) in [
            (at(t, x), y[0]),
            (at(t, x), y[1]),
            (x[0], at(t, y)),
            (x[1], at(t, y)),
        ] {
            // No pixel: NaN, refused below as no finite pixels.
            let (row, col) = to_pixel(xx, yy).unwrap_or((f64::NAN, f64::NAN));
            rows = [rows[0].min(row), rows[1].max(row)];
            cols = [cols[0].min(col), cols[1].max(col)];
        }
    }
    let snap = |v: f64| {
        if (v - v.round()).abs() < 1e-6 {
            v.round()
        } else {
            v
        }
    };
    let (r0, r1) = (snap(rows[0]).floor(), snap(rows[1]).ceil());
    let (c0, c1) = (snap(cols[0]).floor(), snap(cols[1]).ceil());
    if !(r0.is_finite() && c0.is_finite() && r1.is_finite() && c1.is_finite()) {
        return Err(format!("the box x {x:?}, y {y:?} maps to no finite pixels"));
    }
    if r0 < 0.0 || c0 < 0.0 {
        return Err(format!(
            "the box x {x:?}, y {y:?} starts at pixel row {r0}, column {c0}: outside the image"
        ));
    }
    Ok(MapWindow {
        window: Window {
            r0: r0 as usize,
            r1: r1 as usize,
            c0: c0 as usize,
            c1: c1 as usize,
        },
        fit,
    })
}

/// The pixel positions `[row, col]` of the map points `[x, y]` under `georef`, and for ground
/// control points the fit's order and largest residual (as [`MapWindow::fit`]).
///
/// # Errors
/// As [`map_window`]'s, for the georeferencing.
pub fn map_points(
    georef: &Georeference,
    points: &[[f64; 2]],
) -> Result<(Vec<[f64; 2]>, Option<Fit>), String> {
    let (to_pixel, fit) = transform(georef)?;
    let pixels = points
        .iter()
        .map(|&[x, y]| {
            let (r, c) = to_pixel(x, y).ok_or_else(|| {
                format!("the point ({x}, {y}) lies outside the grid points' extent")
            })?;
            Ok([r, c])
        })
        .collect::<Result<Vec<_>, String>>()?;
    Ok((pixels, fit))
}

/// The map from map coordinates to pixel positions, and the GCP fit's order and residual.
fn transform(georef: &Georeference) -> Result<(ToPixel<'_>, Option<Fit>), String> {
    Ok(match georef {
        Georeference::Affine(affine) => {
            let [x0, a, b, y0, d, e] = *affine;
            let det = a * e - b * d;
            if det == 0.0 || !det.is_finite() {
                return Err(format!("its affine transform {affine:?} is singular"));
            }
            let f = move |xx: f64, yy: f64| {
                let (u, v) = (xx - x0, yy - y0);
                Some(((a * v - d * u) / det, (e * u - b * v) / det))
            };
            (Box::new(f), None)
        }
        Georeference::Sicd { projection, height } => {
            let h = *height;
            // SICD places pixel centres at whole numbers; this module, their corners.
            let f = move |lon: f64, lat: f64| {
                let ([r, c], _) = projection.geodetic_to_image(lat, lon, h);
                Some((r + 0.5, c + 0.5))
            };
            (Box::new(f), None)
        }
        Georeference::Gcps(points) => {
            let p = GcpFit::new(points)?;
            let fit = Some((p.order, p.max_residual(points)));
            (Box::new(move |xx, yy| Some(p.pixel(xx, yy))), fit)
        }
        Georeference::Grid(g) => (Box::new(|xx, yy| g.pixel(xx, yy)), None),
        Georeference::Nodes(g) => (Box::new(|xx, yy| g.pixel(xx, yy)), None),
    })
}

/// Row and column as polynomials of the map coordinates, fitted to ground control points by
/// least squares (GDAL's reverse GCP transform: terms `1, x, y` and, at order 2, `x^2, x y,
/// y^2`, in coordinates centred on the points' mean and scaled by their spread, which leaves
/// the fitted polynomial the same and the equations well conditioned).
struct GcpFit {
    order: usize,
    centre: [f64; 2],
    scale: [f64; 2],
    row: Vec<f64>,
    col: Vec<f64>,
}

impl GcpFit {
    fn new(points: &[Gcp]) -> Result<GcpFit, String> {
        let order = match points.len() {
            n if n >= 6 => 2,
            n if n >= 3 => 1,
            n => {
                return Err(format!(
                    "{n} ground control point(s): a map box needs 3 or more"
                ))
            }
        };
        let n = points.len() as f64;
        let centre = [
            points.iter().map(|p| p.x).sum::<f64>() / n,
            points.iter().map(|p| p.y).sum::<f64>() / n,
        ];
        let spread = |f: fn(&Gcp) -> f64, m: f64| {
            let s = points.iter().map(|p| (f(p) - m).abs()).fold(0.0, f64::max);
            if s > 0.0 {
                s
            } else {
                1.0
            }
        };
        let scale = [spread(|p| p.x, centre[0]), spread(|p| p.y, centre[1])];
        let mut fit = GcpFit {
            order,
            centre,
            scale,
            row: Vec::new(),
            col: Vec::new(),
        };
        let terms: Vec<Vec<f64>> = points.iter().map(|p| fit.terms(p.x, p.y)).collect();
        let solve = |target: fn(&Gcp) -> f64| {
            let values: Vec<f64> = points.iter().map(target).collect();
            least_squares(&terms, &values).ok_or_else(|| {
                format!(
                    "its {} ground control points are degenerate (on a line?): no order-{order} \
                     map from map to pixel coordinates",
                    points.len()
                )
            })
        };
        fit.row = solve(|p| p.row)?;
        fit.col = solve(|p| p.col)?;
        Ok(fit)
    }

    /// The polynomial's terms at `(x, y)`.
    fn terms(&self, x: f64, y: f64) -> Vec<f64> {
        let u = (x - self.centre[0]) / self.scale[0];
        let v = (y - self.centre[1]) / self.scale[1];
        if self.order == 1 {
            vec![1.0, u, v]
        } else {
            vec![1.0, u, v, u * u, u * v, v * v]
        }
    }

    /// `(row, col)` of the map point `(x, y)`.
    fn pixel(&self, x: f64, y: f64) -> (f64, f64) {
        let t = self.terms(x, y);
        let dot = |c: &[f64]| c.iter().zip(&t).map(|(a, b)| a * b).sum::<f64>();
        (dot(&self.row), dot(&self.col))
    }

    /// The largest distance (pixels) between a point's position and the fit's.
    fn max_residual(&self, points: &[Gcp]) -> f64 {
        points
            .iter()
            .map(|p| {
                let (r, c) = self.pixel(p.x, p.y);
                (r - p.row).hypot(c - p.col)
            })
            .fold(0.0, f64::max)
    }
}

/// The least-squares solution of `terms c = values` (one row of terms a point), by the normal
/// equations and Gaussian elimination with partial pivoting; `None` if they are singular.
fn least_squares(terms: &[Vec<f64>], values: &[f64]) -> Option<Vec<f64>> {
    let k = terms.first()?.len();
    let mut a = vec![vec![0.0; k + 1]; k];
    for (t, v) in terms.iter().zip(values) {
        for (row, &ti) in a.iter_mut().zip(t) {
            for (cell, &tj) in row.iter_mut().zip(t) {
                *cell += ti * tj;
            }
            row[k] += ti * v;
        }
    }
    let norm = a
        .iter()
        .flat_map(|r| r[..k].iter())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    for col in 0..k {
        let pivot = (col..k).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[pivot][col].abs() <= 1e-12 * norm {
            return None;
        }
        a.swap(col, pivot);
        let (top, below) = a.split_at_mut(col + 1);
        let pivot_row = &top[col];
        for row in below {
            let f = row[col] / pivot_row[col];
            for (x, p) in row[col..].iter_mut().zip(&pivot_row[col..]) {
                *x -= f * p;
            }
        }
    }
    let mut c = vec![0.0; k];
    for i in (0..k).rev() {
        let s: f64 = (i + 1..k).map(|j| a[i][j] * c[j]).sum();
        c[i] = (a[i][k] - s) / a[i][i];
    }
    Some(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn window(g: &Georeference, x: [f64; 2], y: [f64; 2]) -> Window {
        map_window(g, x, y).unwrap().window
    }

    #[test]
    fn a_map_box_is_the_pixels_that_cover_it() {
        // 2.5 m columns east, 5 m rows south from (500000, 5300000).
        let north_up = Georeference::Affine([500000.0, 2.5, 0.0, 5300000.0, 0.0, -5.0]);
        let w = window(&north_up, [500017.5, 500057.5], [5299895.0, 5299975.0]);
        assert_eq!(w, Window::at(5, 7, 16, 16));
        // Partly covered pixels are in.
        let w = window(&north_up, [500018.0, 500057.0], [5299896.0, 5299974.0]);
        assert_eq!(w, Window::at(5, 7, 16, 16));
        // A rotated grid: x along rows, y along columns.
        let rotated = Georeference::Affine([10.0, 0.0, 2.0, 20.0, 3.0, 0.0]);
        assert_eq!(
            window(&rotated, [14.0, 20.0], [26.0, 41.0]),
            Window::at(2, 2, 3, 5)
        );
        assert!(
            map_window(&north_up, [499990.0, 500010.0], [5299900.0, 5299950.0])
                .unwrap_err()
                .contains("outside the image")
        );
    }

    /// A grid of points (4 x 5, blocks of 8 x 2 pixels of a 30 x 9 image) places a box on the
    /// blocks whose points lie in it, the last block clipped to the image; a point maps to its
    /// nearest grid point's block centre; a box with no point and a point outside are refused.
    #[test]
    fn a_point_grid_gives_the_blocks_of_the_points_in_the_box() {
        let (rows, cols) = (4, 5);
        let (mut x, mut y) = (vec![], vec![]);
        for i in 0..rows {
            for j in 0..cols {
                // Rotated: x grows across and a little down, y falls down.
                x.push((10.0 + 0.01 * j as f64 + 0.002 * i as f64) as f32);
                y.push((50.0 - 0.01 * i as f64) as f32);
            }
        }
        let g = Georeference::Grid(Box::new(PointGrid {
            rows,
            cols,
            block: [8, 2],
            dims: (30, 9),
            x,
            y,
        }));
        // Points (1, 1), (1, 2), (2, 1), (2, 2): x 10.012-10.024, y 49.98-49.99.
        assert_eq!(
            window(&g, [10.011, 10.0245], [49.975, 49.995]),
            Window {
                r0: 8,
                r1: 24,
                c0: 2,
                c1: 6
            }
        );
        // The last row and column of blocks, clipped: rows 24..30, columns 8..9.
        assert_eq!(
            window(&g, [10.045, 10.05], [49.965, 49.975]),
            Window {
                r0: 24,
                r1: 30,
                c0: 8,
                c1: 9
            }
        );
        assert!(map_window(&g, [11.0, 12.0], [49.0, 50.0])
            .unwrap_err()
            .contains("holds none of the 4 x 5 grid points"));
        let (px, _) = map_points(&g, &[[10.0121, 49.9799]]).unwrap();
        assert_eq!(px, vec![[20.0, 3.0]]);
        assert!(map_points(&g, &[[9.0, 49.98]]).is_err());
    }

    /// Ground control points of an affine grid give its window (order 1 from 4 points, order 2
    /// from a grid: the fit is exact for a map that is a polynomial of its order), and points
    /// of a bent map give, at order 2, what a dense search over the fitted map finds.
    #[test]
    fn ground_control_points_give_the_window_their_fit_maps_the_box_to() {
        let affine = |r: f64, c: f64| (11.0 + c * 1e-4, 48.0 - r * 1e-4);
        let grid = |rows: &[f64], cols: &[f64], f: &dyn Fn(f64, f64) -> (f64, f64)| {
            let mut g = vec![];
            for &row in rows {
                for &col in cols {
                    let (x, y) = f(row, col);
                    g.push(Gcp { row, col, x, y });
                }
            }
            g
        };
        let box_x = [11.0 + 7.0e-4, 11.0 + 23.0e-4];
        let box_y = [48.0 - 21.0e-4, 48.0 - 5.0e-4];
        for points in [
            grid(&[0.0, 40.0], &[0.0, 30.0], &affine),
            grid(&[0.0, 10.0, 20.0, 40.0], &[0.0, 15.0, 30.0], &affine),
        ] {
            let m = map_window(&Georeference::Gcps(points.clone()), box_x, box_y).unwrap();
            assert_eq!(
                m.window,
                Window::at(5, 7, 16, 16),
                "{} points",
                points.len()
            );
            assert!(m.fit.unwrap().1 < 1e-6, "{m:?}");
        }
        // A bent map: the slow oracle is the whole box, on a fine grid of map points, run
        // through the fitted map, and the window the smallest holding every pixel it reaches.
        let bent = |r: f64, c: f64| {
            (
                11.0 + c * 1e-4 + r * c * 2e-7,
                48.0 - r * 1e-4 + c * c * 3e-8,
            )
        };
        let points = grid(
            &[0.0, 10.0, 20.0, 30.0, 40.0],
            &[0.0, 10.0, 20.0, 30.0],
            &bent,
        );
        let m = map_window(&Georeference::Gcps(points.clone()), box_x, box_y).unwrap();
        let (order, residual) = m.fit.unwrap();
        assert_eq!(order, 2);
        assert!(residual > 1e-6 && residual < 0.5, "{residual}");
        let fit = GcpFit::new(&points).unwrap();
        let (mut rows, mut cols) = ([f64::MAX, f64::MIN], [f64::MAX, f64::MIN]);
        let n = 320;
        for i in 0..=n {
            for j in 0..=n {
                let x = box_x[0] + (box_x[1] - box_x[0]) * i as f64 / n as f64;
                let y = box_y[0] + (box_y[1] - box_y[0]) * j as f64 / n as f64;
                let (r, c) = fit.pixel(x, y);
                rows = [rows[0].min(r), rows[1].max(r)];
                cols = [cols[0].min(c), cols[1].max(c)];
            }
        }
        let oracle = Window {
            r0: rows[0].floor() as usize,
            r1: rows[1].ceil() as usize,
            c0: cols[0].floor() as usize,
            c1: cols[1].ceil() as usize,
        };
        assert_eq!(m.window, oracle);
        assert_ne!(
            m.window,
            Window::at(5, 7, 16, 16),
            "the bend moves the window"
        );
        let few = grid(&[0.0], &[0.0, 30.0], &affine);
        assert!(map_window(&Georeference::Gcps(few), box_x, box_y)
            .unwrap_err()
            .contains("3 or more"));
        let line = grid(&[0.0, 10.0, 20.0, 30.0], &[5.0], &affine);
        assert!(map_window(&Georeference::Gcps(line), box_x, box_y)
            .unwrap_err()
            .contains("degenerate"));
    }
}
