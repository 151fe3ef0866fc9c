//! Where an HDF5 scene's pixels lie on the map: the vectors of its columns' and rows' centre
//! coordinates stored beside it in its group, as OPERA's CSLC (`x_coordinates`,
//! `y_coordinates`, in the product's projection: UTM metres) and NISAR's geocoded products
//! (`xCoordinates`, `yCoordinates`) store them, or CF's plain `x` and `y`; evenly spaced, they
//! make the scene's affine transform ([`affine`]), and a map window or polygon is placed
//! through it as a GeoTIFF's is ([`crate::io::mapping`]).

/// The names of the `(x, y)` coordinate vectors looked for beside a scene, in this order.
pub const NAMES: [(&str, &str); 3] = [
    ("x_coordinates", "y_coordinates"),
    ("xCoordinates", "yCoordinates"),
    ("x", "y"),
];

/// Largest departure of a coordinate from an even grid, as a share of the spacing.
const EVEN: f64 = 1e-6;

/// The affine transform (GDAL's order: `[x0, dx/dcol, dx/drow, y0, dy/dcol, dy/drow]`, of the
/// pixels' top-left corners) of a scene of `rows` x `cols` pixels whose column centres are at
/// `x` and row centres at `y`.
///
/// # Errors
/// If a vector's length is not the scene's, it has fewer than 2 values, or its values are
/// not evenly spaced (or not finite, or constant).
pub fn affine(x: &[f64], y: &[f64], (rows, cols): (usize, usize)) -> Result<[f64; 6], String> {
    let step = |v: &[f64], n: usize, name: &str, axis: &str| -> Result<f64, String> {
        if v.len() != n || n < 2 {
            return Err(format!(
                "its {name} coordinates hold {} values for {n} {axis}",
                v.len()
            ));
        }
        let d = (v[n - 1] - v[0]) / (n - 1) as f64;
        let uneven = v
            .iter()
            .enumerate()
            .any(|(i, &c)| (c - (v[0] + i as f64 * d)).abs() > EVEN * d.abs() || !c.is_finite());
        if d == 0.0 || !d.is_finite() || uneven {
            return Err(format!(
                "its {name} coordinates are not evenly spaced (an affine grid is needed)"
            ));
        }
        Ok(d)
    };
    let dx = step(x, cols, "x", "columns")?;
    let dy = step(y, rows, "y", "rows")?;
    Ok([x[0] - dx / 2.0, dx, 0.0, y[0] - dy / 2.0, 0.0, dy])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centres_become_the_corners_transform() {
        let x: Vec<f64> = (0..4).map(|j| 500_000.0 + 5.0 * (j as f64 + 0.5)).collect();
        let y: Vec<f64> = (0..3)
            .map(|i| 4_200_000.0 - 10.0 * (i as f64 + 0.5))
            .collect();
        let a = affine(&x, &y, (3, 4)).unwrap();
        assert_eq!(a, [500_000.0, 5.0, 0.0, 4_200_000.0, 0.0, -10.0]);
        let e = affine(&x, &y, (4, 4)).unwrap_err();
        assert!(e.contains("y coordinates hold 3 values for 4 rows"), "{e}");
        let mut bent = x.clone();
        bent[2] += 0.01;
        let e = affine(&bent, &y, (3, 4)).unwrap_err();
        assert!(e.contains("x coordinates are not evenly spaced"), "{e}");
    }
}
