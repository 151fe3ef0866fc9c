//! A NISAR RSLC frame's place on the map (the `mat73` feature): its product's
//! `metadata/geolocationGrid` gives map coordinates (`coordinateX`, `coordinateY`: longitude
//! and latitude for EPSG 4326, else the `epsg` dataset's system) at each node of a grid of
//! zero-Doppler times and slant ranges (`zeroDopplerTime`, `slantRange`), for several heights
//! above the ellipsoid (`heightAboveEllipsoid`). The grid is taken at the frame's reference
//! terrain height (the mean of the product's
//! `metadata/processingInformation/parameters/referenceTerrainHeight`, the heights its
//! processor used; 0 m where it has none), linear between the two layers around it (only those
//! two are read), and its nodes placed on the scene's pixels by the scene's own times and
//! ranges stored beside it: a [`NodeGrid`].

use super::product::{axis, h5, same_units, Product};
use super::types::H5Stack;
use crate::io::geogrid::NodeGrid;

/// The group of a product that holds its geolocation grid, below the product's group.
const GRID: &str = "metadata/geolocationGrid";

/// The group of a product holding the terrain heights its processor used.
const TERRAIN: &str = "metadata/processingInformation/parameters/referenceTerrainHeight";

/// Where `t` falls among the scene's axis `v` (pixel centres at whole indices, evenly or not):
/// a fractional index, linear between neighbours and extended from the end pairs.
fn index(v: &[f64], t: f64) -> f64 {
    let rising = v[v.len() - 1] > v[0];
    let k = v.partition_point(|&a| if rising { a <= t } else { a >= t });
    let i = k.clamp(1, v.len() - 1) - 1;
    i as f64 + (t - v[i]) / (v[i + 1] - v[i])
}

/// The frame's geolocation grid at its reference terrain height, on its pixels, and what it
/// is in words (the grid and the height); `None` where no group above the scene holds
/// [`GRID`].
///
/// # Errors
/// Naming the file and the dataset: a grid dataset missing or of another shape than its
/// axes, fewer than two heights, times or ranges; the scene's times or ranges missing beside
/// it, of another length than its side, or in other units than the grid's.
pub(super) fn nisar_grid(st: &H5Stack) -> Result<Option<(NodeGrid, String)>, String> {
    let at = |what: String| format!("{}: {what}", st.path.display());
    let file = hdf5_metno::File::open(&st.path).map_err(|e| at(h5(e)))?;
    let Some(product) = Product::find(&file, &st.dataset, &format!("{GRID}/coordinateX")) else {
        return Ok(None);
    };
    let grid = product.join(GRID);
    let g = file.group(&grid).map_err(|e| at(h5(e)))?;
    let read = |name: &str| {
        axis(&g, name).map_err(|m| at(format!("{grid}/{name}: {m} (a geolocation grid axis)")))
    };
    let (times, time_units) = read("zeroDopplerTime")?;
    let (ranges, range_units) = read("slantRange")?;
    let (heights, _) = read("heightAboveEllipsoid")?;
    let (nh, nt, nr) = (heights.len(), times.len(), ranges.len());
    if heights.windows(2).any(|p| p[1] <= p[0]) {
        return Err(at(format!(
            "{grid}/heightAboveEllipsoid does not rise strictly"
        )));
    }
    if nh == 0 || nt < 2 || nr < 2 {
        return Err(at(format!(
            "{grid} has {nh} heights, {nt} times and {nr} ranges: a grid needs 1, 2 and 2 or more"
        )));
    }
    let (height, from) = terrain_height(&file, &product).map_err(at)?;
    // The layers around the height (the nearest end layer beyond them).
    let k = heights
        .partition_point(|&h| h <= height)
        .clamp(1, nh.max(2) - 1)
        - 1;
    let (k1, w) = if nh == 1 {
        (0, 0.0)
    } else {
        let w = ((height - heights[k]) / (heights[k + 1] - heights[k])).clamp(0.0, 1.0);
        (k + 1, w)
    };
    // Those two layers of a cube (only they are read), mixed at the height.
    let layer = |name: &str| -> Result<Vec<f64>, String> {
        let fail = |e: hdf5_metno::Error| at(format!("{grid}/{name}: {}", h5(e)));
        let d = g.dataset(name).map_err(fail)?;
        if d.shape() != [nh, nt, nr] {
            return Err(at(format!(
                "{grid}/{name} has dimensions {:?}, its axes [{nh}, {nt}, {nr}] \
                 (heightAboveEllipsoid, zeroDopplerTime, slantRange)",
                d.shape()
            )));
        }
        let two: ndarray::Array3<f64> = d.read_slice(ndarray::s![k..=k1, .., ..]).map_err(fail)?;
        let (a, b) = (
            two.index_axis(ndarray::Axis(0), 0),
            two.index_axis(ndarray::Axis(0), k1 - k),
        );
        Ok(a.iter()
            .zip(b.iter())
            .map(|(p, q)| p * (1.0 - w) + q * w)
            .collect())
    };
    let (xs, ys) = (layer("coordinateX")?, layer("coordinateY")?);
    let why = format!("to place {grid} on its pixels");
    let (rows, row_units, rp) = product
        .beside(&file, st, ("zeroDopplerTime", st.dims[1], "rows"), &why)
        .map_err(at)?;
    let (cols, col_units, cp) = product
        .beside(&file, st, ("slantRange", st.dims[2], "columns"), &why)
        .map_err(at)?;
    let join = |name: &str| format!("{grid}/{name}");
    same_units((&join("zeroDopplerTime"), &time_units), (&rp, &row_units)).map_err(at)?;
    same_units((&join("slantRange"), &range_units), (&cp, &col_units)).map_err(at)?;
    for (v, p) in [(&rows, &rp), (&cols, &cp)] {
        match crate::io::lut::monotonic(v) {
            Ok(()) if v.len() >= 2 => {}
            Ok(()) => return Err(at(format!("{p} holds one value: no axis"))),
            Err(m) => return Err(at(format!("{p} {m}"))),
        }
    }
    // Pixel centres sit at whole indices; the grid's pixel positions count from corners.
    let node_rows = times.iter().map(|&t| index(&rows, t) + 0.5).collect();
    let node_cols = ranges.iter().map(|&r| index(&cols, r) + 0.5).collect();
    let nodes =
        NodeGrid::new(node_rows, node_cols, xs, ys).map_err(|m| at(format!("{grid}: {m}")))?;
    let by = format!("geolocation grid {grid} at {height} m above the ellipsoid ({from})");
    Ok(Some((nodes, by)))
}

/// The mean of the product's reference terrain heights (finite ones), 0 m where it has none;
/// and where it came from, in words.
fn terrain_height(file: &hdf5_metno::File, product: &Product) -> Result<(f64, String), String> {
    let path = product.join(TERRAIN);
    let none = || (0.0, format!("no {path}: the ellipsoid"));
    if !file.link_exists(&path) {
        return Ok(none());
    }
    let v: Vec<f64> = file
        .dataset(&path)
        .and_then(|d| d.read_raw::<f64>())
        .map_err(|e| format!("{path}: {}", h5(e)))?;
    let finite: Vec<f64> = v.into_iter().filter(|h| h.is_finite()).collect();
    Ok(if finite.is_empty() {
        none()
    } else {
        let mean = finite.iter().sum::<f64>() / finite.len() as f64;
        (mean, format!("the mean of {path}"))
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn index_is_linear_between_and_beyond_the_axis_values() {
        let v = [10.0, 12.0, 16.0];
        assert_eq!(super::index(&v, 11.0), 0.5);
        assert_eq!(super::index(&v, 14.0), 1.5);
        assert_eq!(super::index(&v, 20.0), 3.0);
        assert_eq!(super::index(&v, 9.0), -0.5);
        assert_eq!(super::index(&[5.0, 3.0, 1.0], 2.0), 1.5);
    }
}
