//! Where an HDF5 scene's radiometric calibration comes from (the `mat73` feature): NISAR's
//! tables (`<product>/metadata/calibrationInformation/geometry/{beta0, sigma0, gamma0}`, over
//! `zeroDopplerTime` and `slantRange` in an RSLC, `yCoordinates` and `xCoordinates` in a
//! GSLC), placed on the scene's pixels by the same axes stored beside the scene (an RSLC's
//! `swaths/zeroDopplerTime` and `swaths/frequencyA/slantRange`), read into a [`GridLut`]; or
//! ICEYE's scalar `/calibration_factor`.

use super::product::{axis, h5, same_units, Product};
use super::types::H5Stack;
use crate::io::lut::GridLut;

/// The group of a product that holds its calibration tables, below the product's group.
const TABLES: &str = "metadata/calibrationInformation/geometry";

/// The names of a table's `(row, column)` axes, in the order looked for: an RSLC's
/// (zero-Doppler time in seconds, slant range in metres), a GSLC's (map y and x).
const AXES: [(&str, &str); 2] = [
    ("zeroDopplerTime", "slantRange"),
    ("yCoordinates", "xCoordinates"),
];

/// NISAR's calibration table of `quantity` for the scene `st`, placed on its pixels, with its
/// dataset's path; `None` where no group above the scene holds [`TABLES`].
///
/// # Errors
/// Naming the file and the dataset at fault: no table of that quantity (those there listed),
/// no axes of a kind read (`AXES`), a table of another size than its axes, an axis missing
/// beside the scene or of another length than the scene's side, axes in different units (the
/// epochs of two zero-Doppler times), a table value that is not a positive number.
pub(super) fn nisar_table(
    st: &H5Stack,
    quantity: &str,
) -> Result<Option<(String, GridLut)>, String> {
    let at = |what: String| format!("{}: {what}", st.path.display());
    let file = hdf5_metno::File::open(&st.path).map_err(|e| at(h5(e)))?;
    let Some(product) = Product::find(&file, &st.dataset, TABLES) else {
        return Ok(None);
    };
    let tables = product.join(TABLES);
    let join = |name: &str| format!("{tables}/{name}");
    let g = file.group(&tables).map_err(|e| at(h5(e)))?;
    if !g.link_exists(quantity) {
        let names = g.member_names().map_err(|e| at(h5(e)))?;
        let held: Vec<&String> = names
            .iter()
            .filter(|n| ["beta0", "sigma0", "gamma0"].contains(&n.as_str()))
            .collect();
        return Err(at(format!(
            "{tables} holds no {quantity} table (it holds {held:?})"
        )));
    }
    let Some((rn, cn)) = AXES
        .into_iter()
        .find(|(r, c)| g.link_exists(r) && g.link_exists(c))
    else {
        return Err(at(format!(
            "{tables} has no axes for its tables (zeroDopplerTime and slantRange, or \
             yCoordinates and xCoordinates)"
        )));
    };
    let read_axis = |g: &hdf5_metno::Group, place: &str, n: &str| {
        axis(g, n).map_err(|m| at(format!("{place}/{n}: {m}")))
    };
    let (row_axis, row_units) = read_axis(&g, &tables, rn)?;
    let (col_axis, col_units) = read_axis(&g, &tables, cn)?;
    let table = g.dataset(quantity).map_err(|e| at(h5(e)))?;
    let shape = table.shape();
    if shape != [row_axis.len(), col_axis.len()] {
        return Err(at(format!(
            "{} has dimensions {shape:?}, its axes {rn} and {cn} {} and {}",
            join(quantity),
            row_axis.len(),
            col_axis.len()
        )));
    }
    let source = join(quantity);
    let values = table
        .read_raw::<f64>()
        .map_err(|e| at(format!("{source}: {}", h5(e))))?;
    let because = format!("to place {source} on its pixels");
    let beside = |name: &str, len: usize, side: &str| {
        product
            .beside(&file, st, (name, len, side), &because)
            .map_err(at)
    };
    let (rows, row_scene_units, rp) = beside(rn, st.dims[1], "rows")?;
    let (cols, col_scene_units, cp) = beside(cn, st.dims[2], "columns")?;
    same_units((&join(rn), &row_units), (&rp, &row_scene_units)).map_err(at)?;
    same_units((&join(cn), &col_units), (&cp, &col_scene_units)).map_err(at)?;
    GridLut::new(values, (&row_axis, &col_axis), (&rows, &cols))
        .map(|t| Some((source.clone(), t)))
        .map_err(|m| at(format!("{source}: {m}")))
}

/// ICEYE's `calibration_factor` (a scalar at the file's root: `beta0 = factor |value|^2`).
///
/// # Errors
/// Naming the file: no such dataset (nor NISAR's tables), not one positive number.
pub(super) fn iceye_factor(st: &H5Stack) -> Result<f64, String> {
    let at = |what: String| format!("{}: {what}", st.path.display());
    let file = hdf5_metno::File::open(&st.path).map_err(|e| at(h5(e)))?;
    let ds = file.dataset("calibration_factor").map_err(|_| {
        at(format!(
            "its HDF5 holds no /calibration_factor (ICEYE's beta0 scale factor) and no group \
             above {} holds NISAR's {TABLES}",
            st.dataset
        ))
    })?;
    let v: f64 = ds
        .read_scalar()
        .map_err(|e| at(format!("/calibration_factor is not one number: {}", h5(e))))?;
    if !(v.is_finite() && v > 0.0) {
        return Err(at(format!(
            "/calibration_factor is {v}, not a positive number"
        )));
    }
    Ok(v)
}
