//! A scene's map coordinates given at the nodes of a coarse grid over its pixels, as a NISAR
//! RSLC frame's `metadata/geolocationGrid` gives them (longitude and latitude, or the
//! product's EPSG coordinates, at each zero-Doppler time and slant range of the grid, for
//! a stack of heights above the ellipsoid, the nodes about 500 m apart): between the nodes
//! the map coordinates are bilinear in the grid's indices, and the grid's indices are linear
//! in pixel positions between the nodes' own ([`NodeGrid`]). A map point is placed on the
//! scene by inverting that bilinear map (Newton's method in the grid cell that holds the
//! point, [`NodeGrid::pixel`]), so a map box or polygon lands on the pixels that the
//! product's own grid puts it on, not on a polynomial fitted to it.

/// Map coordinates at the nodes of a grid over a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeGrid {
    /// Pixel row position (pixel `(r, c)` covering `[r, r + 1) x [c, c + 1)`) of each row
    /// of nodes, strictly increasing or decreasing.
    rows: Vec<f64>,
    /// Pixel column position of each column of nodes, likewise.
    cols: Vec<f64>,
    /// Map x at each node, row after row.
    x: Vec<f64>,
    /// Map y at each node.
    y: Vec<f64>,
}

/// Largest step (in grid indices) Newton's method may still take when it stops.
const CONVERGED: f64 = 1e-10;

/// Newton's steps at most.
const STEPS: usize = 60;

impl NodeGrid {
    /// The nodes at pixel rows `rows` and columns `cols` with map coordinates `x` and `y`
    /// (`rows.len()` x `cols.len()`, row after row).
    ///
    /// # Errors
    /// If the sizes disagree, there are fewer than 2 node rows or columns, the positions are
    /// not strictly monotonic, or a coordinate is not finite.
    pub fn new(rows: Vec<f64>, cols: Vec<f64>, x: Vec<f64>, y: Vec<f64>) -> Result<Self, String> {
        let n = rows.len() * cols.len();
        if x.len() != n || y.len() != n {
            return Err(format!(
                "{} and {} map coordinates for {} x {} nodes",
                x.len(),
                y.len(),
                rows.len(),
                cols.len()
            ));
        }
        for (v, name) in [(&rows, "rows"), (&cols, "columns")] {
            if v.len() < 2 || crate::io::lut::monotonic(v).is_err() {
                return Err(format!(
                    "its node {name} are not 2 or more strictly monotonic pixel positions"
                ));
            }
        }
        if let Some(k) = x
            .iter()
            .zip(&y)
            .position(|(a, b)| !(a.is_finite() && b.is_finite()))
        {
            return Err(format!(
                "its node [{}, {}] has no finite map coordinates",
                k / cols.len(),
                k % cols.len()
            ));
        }
        Ok(NodeGrid { rows, cols, x, y })
    }

    /// `(x, y)` at the fractional grid indices `(a, b)` (bilinear in the cell they fall in,
    /// extended linearly beyond the edge cells) and its derivatives along `a` and `b`.
    fn at(&self, a: f64, b: f64) -> ([f64; 2], [f64; 2], [f64; 2]) {
        let (m, n) = (self.rows.len(), self.cols.len());
        let i = (a.floor().max(0.0) as usize).min(m - 2);
        let j = (b.floor().max(0.0) as usize).min(n - 2);
        let (u, v) = (a - i as f64, b - j as f64);
        let node = |k: usize, l: usize| [self.x[k * n + l], self.y[k * n + l]];
        let (p00, p01, p10, p11) = (
            node(i, j),
            node(i, j + 1),
            node(i + 1, j),
            node(i + 1, j + 1),
        );
        let mut f = [0.0; 2];
        let (mut da, mut db) = ([0.0; 2], [0.0; 2]);
        for d in 0..2 {
            f[d] = p00[d] * (1.0 - u) * (1.0 - v)
                + p01[d] * (1.0 - u) * v
                + p10[d] * u * (1.0 - v)
                + p11[d] * u * v;
            da[d] = (p10[d] - p00[d]) * (1.0 - v) + (p11[d] - p01[d]) * v;
            db[d] = (p01[d] - p00[d]) * (1.0 - u) + (p11[d] - p10[d]) * u;
        }
        (f, da, db)
    }

    /// A fractional node index `a` along `nodes` (the nodes' pixel positions) as a pixel
    /// position: linear between the nodes, extended from the end pairs beyond them.
    fn position(nodes: &[f64], a: f64) -> f64 {
        let i = (a.floor().max(0.0) as usize).min(nodes.len() - 2);
        nodes[i] + (a - i as f64) * (nodes[i + 1] - nodes[i])
    }

    /// The map coordinates at the pixel position `(row, col)` (for checks and tests; the
    /// inverse of [`NodeGrid::pixel`] inside the grid).
    pub fn map(&self, row: f64, col: f64) -> (f64, f64) {
        let index = |nodes: &[f64], p: f64| {
            let rising = nodes[1] > nodes[0];
            let k = nodes.partition_point(|&q| if rising { q <= p } else { q >= p });
            let i = k.clamp(1, nodes.len() - 1) - 1;
            i as f64 + (p - nodes[i]) / (nodes[i + 1] - nodes[i])
        };
        let (f, _, _) = self.at(index(&self.rows, row), index(&self.cols, col));
        (f[0], f[1])
    }

    /// The pixel position `(row, col)` of the map point `(x, y)`: the grid indices where the
    /// bilinear map gives it (Newton's method from the nearest node), then pixel positions;
    /// `None` where it lies outside the grid's nodes or the iteration does not settle.
    pub fn pixel(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        let (m, n) = (self.rows.len(), self.cols.len());
        let scale = if y.abs() <= 90.0 {
            y.to_radians().cos().abs().max(1e-9)
        } else {
            1.0
        };
        let nearest = (0..m * n).min_by(|&p, &q| {
            let d = |k: usize| ((self.x[k] - x) * scale).powi(2) + (self.y[k] - y).powi(2);
            d(p).total_cmp(&d(q))
        })?;
        let (mut a, mut b) = ((nearest / n) as f64, (nearest % n) as f64);
        for _ in 0..STEPS {
            let (f, da, db) = self.at(a, b);
            let (rx, ry) = (x - f[0], y - f[1]);
            let det = da[0] * db[1] - db[0] * da[1];
            if det == 0.0 || !det.is_finite() {
                return None;
            }
            let step_a = (rx * db[1] - db[0] * ry) / det;
            let step_b = (da[0] * ry - rx * da[1]) / det;
            a += step_a;
            b += step_b;
            if step_a.abs().max(step_b.abs()) < CONVERGED {
                let inside = |t: f64, len: usize| (-1e-9..=(len - 1) as f64 + 1e-9).contains(&t);
                if !(inside(a, m) && inside(b, n)) {
                    return None;
                }
                return Some((Self::position(&self.rows, a), Self::position(&self.cols, b)));
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// A curved, rotated grid: nodes every 40 rows (from -5) and 30 columns (from 3), map
    /// coordinates a smooth function of the node's pixel place.
    fn grid() -> NodeGrid {
        let rows: Vec<f64> = (0..9).map(|k| -5.0 + 40.0 * k as f64).collect();
        let cols: Vec<f64> = (0..7).map(|k| 3.0 + 30.0 * k as f64).collect();
        let (mut x, mut y) = (vec![], vec![]);
        for &r in &rows {
            for &c in &cols {
                x.push(-121.5 + 1e-4 * c + 2e-5 * r + 1e-8 * c * c);
                y.push(37.2 - 9e-5 * r + 1.5e-5 * c - 5e-9 * r * c);
            }
        }
        NodeGrid::new(rows, cols, x, y).unwrap()
    }

    #[test]
    fn pixel_inverts_the_bilinear_map_inside_the_grid() {
        let g = grid();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(51);
        for _ in 0..2000 {
            let (r, c) = (rng.random_range(-5.0..315.0), rng.random_range(3.0..183.0));
            let (x, y) = g.map(r, c);
            let (rr, cc) = g.pixel(x, y).expect("inside");
            assert!(
                (rr - r).abs() < 1e-6 && (cc - c).abs() < 1e-6,
                "{r} {c}: {rr} {cc}"
            );
        }
        // Beyond the nodes: no pixel.
        let (x, y) = g.map(-5.0, 3.0);
        assert_eq!(g.pixel(x - 0.01, y + 0.01), None);
    }

    #[test]
    fn nodes_of_another_size_or_order_are_refused() {
        let e = NodeGrid::new(vec![0.0, 1.0], vec![0.0, 1.0], vec![0.0; 3], vec![0.0; 4]);
        assert!(e
            .unwrap_err()
            .contains("3 and 4 map coordinates for 2 x 2 nodes"));
        let e = NodeGrid::new(vec![0.0, 0.0], vec![0.0, 1.0], vec![0.0; 4], vec![0.0; 4]);
        assert!(e
            .unwrap_err()
            .contains("node rows are not 2 or more strictly monotonic"));
        let mut x = vec![0.0; 4];
        x[3] = f64::NAN;
        let e = NodeGrid::new(vec![0.0, 1.0], vec![0.0, 1.0], x, vec![0.0; 4]);
        assert!(e
            .unwrap_err()
            .contains("node [1, 1] has no finite map coordinates"));
    }
}
