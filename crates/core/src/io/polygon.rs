//! Polygons in pixel coordinates (a cut's region of interest): whether a patch's rectangle
//! lies wholly inside a simple polygon, by its corners and the polygon's edges.

/// A simple polygon, its vertices `(row, column)` in pixel coordinates (pixel `(r, c)` covers
/// `[r, r + 1) x [c, c + 1)`), in order, closed implicitly.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Polygon(pub Vec<[f64; 2]>);

impl Polygon {
    /// Whether the point `p` lies inside (even-odd rule; a point on an edge may go either
    /// way, which [`Polygon::holds`] avoids by testing points off the edges).
    pub fn contains(&self, p: [f64; 2]) -> bool {
        let v = &self.0;
        let mut inside = false;
        let mut j = v.len() - 1;
        for i in 0..v.len() {
            let (a, b) = (v[i], v[j]);
            if (a[0] > p[0]) != (b[0] > p[0]) {
                let c = a[1] + (p[0] - a[0]) * (b[1] - a[1]) / (b[0] - a[0]);
                if p[1] < c {
                    inside = !inside;
                }
            }
            j = i;
        }
        inside
    }

    /// Whether the rectangle of rows `r0..r1` and columns `c0..c1` (pixel edges) lies inside:
    /// its corners, pulled in by a hair, are inside and no edge of the polygon passes through
    /// its interior.
    pub fn holds(&self, (r0, r1): (f64, f64), (c0, c1): (f64, f64)) -> bool {
        let e = 1e-7;
        let corners = [
            [r0 + e, c0 + e],
            [r0 + e, c1 - e],
            [r1 - e, c0 + e],
            [r1 - e, c1 - e],
        ];
        if !corners.iter().all(|&p| self.contains(p)) {
            return false;
        }
        let v = &self.0;
        (0..v.len()).all(|i| {
            let (a, b) = (v[i], v[(i + 1) % v.len()]);
            !crosses_open(a, b, (r0, r1), (c0, c1))
        })
    }
}

/// Whether the segment `a`-`b` meets the open rectangle `(r0, r1) x (c0, c1)` (Liang-Barsky).
fn crosses_open(a: [f64; 2], b: [f64; 2], (r0, r1): (f64, f64), (c0, c1): (f64, f64)) -> bool {
    let d = [b[0] - a[0], b[1] - a[1]];
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-d[0], a[0] - r0),
        (d[0], r1 - a[0]),
        (-d[1], a[1] - c0),
        (d[1], c1 - a[1]),
    ] {
        if p == 0.0 {
            if q <= 0.0 {
                return false;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    // Strictly inside the open rectangle for some t: a positive-length overlap, or a
    // single point that is not on the boundary.
    t0 < t1 && {
        let m = (t0 + t1) / 2.0;
        let p = [a[0] + m * d[0], a[1] + m * d[1]];
        p[0] > r0 && p[0] < r1 && p[1] > c0 && p[1] < c1
    }
}

impl std::str::FromStr for Polygon {
    type Err = String;

    /// `r0,c0;r1,c1;r2,c2;...` (at least 3 vertices, pixel coordinates).
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("{s:?} is not a polygon r0,c0;r1,c1;r2,c2;... (3 vertices or more)");
        let v = s
            .split(';')
            .map(|p| {
                let (r, c) = p.split_once(',').ok_or_else(bad)?;
                Ok([
                    r.trim().parse().map_err(|_| bad())?,
                    c.trim().parse().map_err(|_| bad())?,
                ])
            })
            .collect::<Result<Vec<[f64; 2]>, String>>()?;
        Polygon::new(v).ok_or_else(bad)
    }
}

impl Polygon {
    /// The polygon of `vertices`, if there are at least 3, all finite.
    pub fn new(vertices: Vec<[f64; 2]>) -> Option<Polygon> {
        let finite = vertices.iter().flatten().all(|x| x.is_finite());
        (vertices.len() >= 3 && finite).then_some(Polygon(vertices))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// The slow oracle: the rectangle is inside when no vertex of the polygon lies strictly
    /// inside it and a dense grid of its points (every 1/64 of its sides, edges pulled in by
    /// a hair) lies inside.
    fn oracle(p: &Polygon, (r0, r1): (f64, f64), (c0, c1): (f64, f64)) -> bool {
        let strictly = |v: &[f64; 2]| v[0] > r0 && v[0] < r1 && v[1] > c0 && v[1] < c1;
        if p.0.iter().any(strictly) {
            return false;
        }
        let e = 1e-7;
        (0..=64).all(|i| {
            (0..=64).all(|j| {
                let r = r0 + e + (r1 - r0 - 2.0 * e) * i as f64 / 64.0;
                let c = c0 + e + (c1 - c0 - 2.0 * e) * j as f64 / 64.0;
                p.contains([r, c])
            })
        })
    }

    #[test]
    fn rectangles_inside_star_polygons_agree_with_a_dense_grid() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut inside = 0;
        for _ in 0..300 {
            // A star-shaped polygon (simple): 5-9 vertices round (30, 30) at sorted angles.
            let n = rng.random_range(5..10);
            let mut angles: Vec<f64> = (0..n)
                .map(|_| rng.random_range(0.0..std::f64::consts::TAU))
                .collect();
            angles.sort_by(f64::total_cmp);
            let v = angles
                .iter()
                .map(|a| {
                    let rad = rng.random_range(8.0..28.0);
                    [30.0 + rad * a.sin(), 30.0 + rad * a.cos()]
                })
                .collect();
            let p = Polygon(v);
            for _ in 0..20 {
                let (r, c) = (
                    rng.random_range(0..55) as f64,
                    rng.random_range(0..55) as f64,
                );
                let (h, w) = (
                    rng.random_range(1..12) as f64,
                    rng.random_range(1..12) as f64,
                );
                let want = oracle(&p, (r, r + h), (c, c + w));
                assert_eq!(
                    p.holds((r, r + h), (c, c + w)),
                    want,
                    "{p:?} at {r}, {c}, {h} x {w}"
                );
                inside += usize::from(want);
            }
        }
        // Both answers occur often enough to test something.
        assert!(inside > 500 && inside < 5500, "{inside} of 6000 inside");
    }

    #[test]
    fn polygons_parse_or_are_refused() {
        let p: Polygon = "0,0; 0,10; 10,10".parse().unwrap();
        assert_eq!(p.0, vec![[0.0, 0.0], [0.0, 10.0], [10.0, 10.0]]);
        for bad in ["0,0;1,1", "0,0;1;2,2", "a,b;1,1;2,2", "0,0;1,1;inf,2"] {
            assert!(bad.parse::<Polygon>().is_err(), "{bad}");
        }
        // A square's inside and its edge.
        let sq: Polygon = "0,0;0,8;8,8;8,0".parse().unwrap();
        assert!(sq.holds((0.0, 8.0), (0.0, 8.0)));
        assert!(!sq.holds((1.0, 9.0), (0.0, 8.0)));
    }
}
