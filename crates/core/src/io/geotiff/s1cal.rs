//! Sentinel-1's radiometric calibration of a measurement GeoTIFF: the SAFE product beside it
//! holds, for `<SAFE>/measurement/<name>.tiff`, the calibration annotation
//! `<SAFE>/annotation/calibration/calibration-<name>.xml`, whose `calibrationVector`s give the
//! look-up tables `sigmaNought`, `betaNought` and `gamma` at image lines (`line`) and pixels
//! (`pixel`). ESA's *Radiometric Calibration of Sentinel-1 Level-1 Products* defines the
//! calibrated value as `|DN|^2 / A^2`, the table `A` interpolated bilinearly at the pixel; so
//! a calibrated read divides each value by the table there ([`crate::io::lut::GridLut`]; xarray-sentinel's
//! `calibrate_amplitude` does the same). Every vector must give the same pixels (as
//! xarray-sentinel also requires: a regular line-pixel grid).

use crate::io::lut::{Calibrated, GridLut, Scale};
use std::path::{Path, PathBuf};

/// The calibration annotation of the measurement `tiff` in its SAFE folder.
pub fn annotation_of(tiff: &Path) -> Option<PathBuf> {
    let stem = tiff.file_stem()?.to_str()?;
    let measurement = tiff.parent()?;
    let safe = measurement.parent()?;
    Some(
        safe.join("annotation")
            .join("calibration")
            .join(format!("calibration-{stem}.xml")),
    )
}

/// The vector element of `quantity`.
fn element(quantity: &str) -> Option<&'static str> {
    match quantity {
        "sigma0" => Some("sigmaNought"),
        "beta0" => Some("betaNought"),
        "gamma0" => Some("gamma"),
        _ => None,
    }
}

/// The numbers of the element `name` of the vector `v` (`k`-th of the list).
fn numbers(v: roxmltree::Node, name: &str, k: usize) -> Result<Vec<f64>, String> {
    let node = v
        .children()
        .find(|c| c.has_tag_name(name))
        .ok_or_else(|| format!("calibrationVector {k} has no {name}"))?;
    node.text()
        .unwrap_or("")
        .split_whitespace()
        .map(|t| {
            t.parse::<f64>()
                .map_err(|_| format!("calibrationVector {k}/{name}: {t:?} is not a number"))
        })
        .collect()
}

/// The calibration of the measurement `tiff` (`rows` x `cols`) to `quantity` from its SAFE
/// product's calibration annotation.
///
/// # Errors
/// Naming the files: a quantity the annotation has no table of, the annotation missing (where
/// it was looked for), not XML, no vectors, vectors with other pixels than the first, lines
/// not rising, a table of another length than its pixels, a value that is not a positive number.
pub fn sentinel1(
    tiff: &Path,
    quantity: &str,
    (rows, cols): (usize, usize),
) -> Result<Calibrated, String> {
    let name = element(quantity).ok_or_else(|| {
        format!(
            "{}: Sentinel-1's calibration annotation gives sigma0, beta0 and gamma0 (asked for \
             {quantity})",
            tiff.display()
        )
    })?;
    let xml = annotation_of(tiff).filter(|p| p.is_file()).ok_or_else(|| {
        format!(
            "{}: its format gives no radiometric scale factors, and no Sentinel-1 \
                 calibration annotation lies beside it in its SAFE product ({})",
            tiff.display(),
            annotation_of(tiff).map_or("no SAFE folder".into(), |p| p.display().to_string())
        )
    })?;
    let at = |m: String| format!("{}: {m}", xml.display());
    let text = std::fs::read_to_string(&xml).map_err(|e| at(e.to_string()))?;
    let doc = roxmltree::Document::parse(&text).map_err(|e| at(format!("not XML: {e}")))?;
    let vectors: Vec<roxmltree::Node> = doc
        .descendants()
        .filter(|n| n.has_tag_name("calibrationVector"))
        .collect();
    if vectors.is_empty() {
        return Err(at("no calibrationVector".into()));
    }
    let (mut lines, mut values) = (Vec::new(), Vec::new());
    let mut pixels: Option<Vec<f64>> = None;
    for (k, v) in vectors.iter().enumerate() {
        let line = numbers(*v, "line", k).map_err(at)?;
        let pixel = numbers(*v, "pixel", k).map_err(at)?;
        let table = numbers(*v, name, k).map_err(at)?;
        if line.len() != 1 {
            return Err(at(format!("calibrationVector {k}/line is not one number")));
        }
        if table.len() != pixel.len() {
            return Err(at(format!(
                "calibrationVector {k}/{name} holds {} values for {} pixels",
                table.len(),
                pixel.len()
            )));
        }
        match &pixels {
            Some(first) if *first != pixel => {
                return Err(at(format!(
                    "calibrationVector {k} gives other pixels than the first: the vectors do \
                     not make a regular line-pixel grid"
                )))
            }
            Some(_) => {}
            None => pixels = Some(pixel),
        }
        lines.push(line[0]);
        values.extend(table);
    }
    let pixels = pixels.expect("one vector at least");
    let scene_rows: Vec<f64> = (0..rows).map(|r| r as f64).collect();
    let scene_cols: Vec<f64> = (0..cols).map(|c| c as f64).collect();
    let table = GridLut::new(values, (&lines, &pixels), (&scene_rows, &scene_cols))
        .map_err(|m| at(format!("{name}: {m}")))?;
    Ok(Calibrated {
        quantity: quantity.to_string(),
        source: xml.display().to_string(),
        scale: Scale::Table(Box::new(table)),
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_annotation_lies_in_the_safe_beside_the_measurement() {
        let tiff = std::path::Path::new("/d/S1A.SAFE/measurement/s1a-iw1-slc-vv-001.tiff");
        assert_eq!(
            super::annotation_of(tiff).unwrap(),
            std::path::Path::new(
                "/d/S1A.SAFE/annotation/calibration/calibration-s1a-iw1-slc-vv-001.xml"
            )
        );
    }
}
