//! A GeoTIFF's georeferencing as its tags give it (OGC GeoTIFF 1.1): the model tie points
//! (one for an affine grid, many ground control points for a Sentinel-1 SLC), the pixel
//! scale or the full model transformation, and the GeoKeys that name the reference system;
//! with the affine transform they make, in GDAL's order, where they make one. Recorded in a
//! run's manifest beside the dataset that read the file.

use super::ifd::Ifd;
use serde::Serialize;

/// `ModelPixelScaleTag`.
pub const MODEL_PIXEL_SCALE: u16 = 33550;
/// `ModelTiepointTag`.
pub const MODEL_TIEPOINT: u16 = 33922;
/// `ModelTransformationTag`.
pub const MODEL_TRANSFORMATION: u16 = 34264;
/// `GeoKeyDirectoryTag`.
pub const GEO_KEY_DIRECTORY: u16 = 34735;
/// `GeoDoubleParamsTag`.
pub const GEO_DOUBLE_PARAMS: u16 = 34736;
/// `GeoAsciiParamsTag`.
pub const GEO_ASCII_PARAMS: u16 = 34737;
/// GDAL's metadata (XML).
pub const GDAL_METADATA: u16 = 42112;
/// GDAL's no-data value (text).
pub const GDAL_NODATA: u16 = 42113;

/// One GeoKey's value.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum KeyValue {
    /// Integers (inline, or a list from another tag).
    Ints(Vec<u64>),
    /// Doubles (`GeoDoubleParamsTag`).
    Doubles(Vec<f64>),
    /// Text (`GeoAsciiParamsTag`).
    Text(String),
}

/// The georeferencing of a GeoTIFF (every field absent in a plain TIFF).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Georef {
    /// `ModelPixelScaleTag`: `[sx, sy, sz]`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pixel_scale: Option<Vec<f64>>,
    /// `ModelTiepointTag`: `(column, row, k, x, y, z)` per point.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub tiepoints: Vec<[f64; 6]>,
    /// `ModelTransformationTag`: the 4 x 4 matrix, row by row.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub transformation: Option<Vec<f64>>,
    /// The affine transform `[x0, dx/dcol, dx/drow, y0, dy/dcol, dy/drow]` (GDAL's
    /// `GeoTransform` order) from the transformation, or from one tie point and the pixel
    /// scale; absent for ground control points. Its raster space is `raster_type`'s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub affine: Option<[f64; 6]>,
    /// The GeoKeys by their numbers (`1024` model type, `1025` raster type, `2048` the
    /// geographic and `3072` the projected reference system's EPSG code, ...).
    #[serde(skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub geokeys: std::collections::BTreeMap<u16, KeyValue>,
    /// GDAL's metadata (`GDAL_METADATA`, XML), as stored.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gdal_metadata: Option<String>,
    /// GDAL's no-data value, as stored.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nodata: Option<String>,
}

impl Georef {
    /// The georeferencing tags of `ifd`.
    pub fn read(ifd: &Ifd) -> Georef {
        let tiepoints = ifd
            .floats(MODEL_TIEPOINT)
            .unwrap_or_default()
            .chunks_exact(6)
            .map(|c| [c[0], c[1], c[2], c[3], c[4], c[5]])
            .collect::<Vec<_>>();
        let pixel_scale = ifd.floats(MODEL_PIXEL_SCALE);
        let transformation = ifd.floats(MODEL_TRANSFORMATION).filter(|t| t.len() == 16);
        let affine = match (&transformation, &tiepoints[..], &pixel_scale) {
            (Some(t), _, _) => Some([t[3], t[0], t[1], t[7], t[4], t[5]]),
            (None, [p], Some(s)) if s.len() >= 2 => Some([
                p[3] - p[0] * s[0],
                s[0],
                0.0,
                p[4] + p[1] * s[1],
                0.0,
                -s[1],
            ]),
            _ => None,
        };
        Georef {
            pixel_scale,
            tiepoints,
            transformation,
            affine,
            geokeys: geokeys(ifd),
            gdal_metadata: ifd.text(GDAL_METADATA).map(str::to_string),
            nodata: ifd.text(GDAL_NODATA).map(str::to_string),
        }
    }
}

/// The GeoKeys of `ifd`'s directory (empty without one; a key whose value lies outside its
/// parameter tag is left out).
fn geokeys(ifd: &Ifd) -> std::collections::BTreeMap<u16, KeyValue> {
    let mut keys = std::collections::BTreeMap::new();
    let Some(dir) = ifd.ints(GEO_KEY_DIRECTORY) else {
        return keys;
    };
    let doubles = ifd.floats(GEO_DOUBLE_PARAMS).unwrap_or_default();
    let text = ifd.text(GEO_ASCII_PARAMS).unwrap_or("");
    let n = dir.get(3).copied().unwrap_or(0) as usize;
    for k in dir.get(4..).unwrap_or(&[]).chunks_exact(4).take(n) {
        let (id, location, count, at) = (k[0] as u16, k[1] as u16, k[2] as usize, k[3] as usize);
        let value = match location {
            0 => Some(KeyValue::Ints(vec![k[3]])),
            GEO_DOUBLE_PARAMS => doubles
                .get(at..at + count)
                .map(|v| KeyValue::Doubles(v.to_vec())),
            GEO_ASCII_PARAMS => text
                .get(at..at + count)
                .map(|s| KeyValue::Text(s.trim_end_matches(['|', '\0']).to_string())),
            GEO_KEY_DIRECTORY => dir.get(at..at + count).map(|v| KeyValue::Ints(v.to_vec())),
            _ => None,
        };
        if let Some(v) = value {
            keys.insert(id, v);
        }
    }
    keys
}
