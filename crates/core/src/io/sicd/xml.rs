//! SICD's XML metadata: the image's size and pixel type (`ImageData`), which the reader
//! needs, and what a clutter study records beside its data (collector and mode, collection
//! time, polarisation, the image grid's plane, type, sample spacings and resolutions, the
//! scene centre point, and the radiometric scale factors that calibrate amplitudes to
//! sigma-0 or beta-0), and what projects ground points into the image (the scene centre, the
//! grid's vectors, the aperture's track and centre-of-aperture times, the image formation's
//! R/Rdot model: [`crate::io::projection`]). Elements are found by their local names, whatever
//! the namespace prefix of the SICD version.

use num_complex::Complex32;
use serde::Serialize;

/// SICD's pixel types.
#[derive(Debug, Clone, PartialEq)]
pub enum Pixel {
    /// Real and imaginary float32.
    Re32fIm32f,
    /// Real and imaginary int16.
    Re16iIm16i,
    /// Amplitude and phase bytes: amplitude through the table (`None`: the byte itself),
    /// phase `p / 256` of a turn.
    Amp8iPhs8i(Option<Vec<f32>>),
}

impl Pixel {
    /// Bytes of one pixel.
    pub fn size(&self) -> usize {
        match self {
            Pixel::Re32fIm32f => 8,
            Pixel::Re16iIm16i => 4,
            Pixel::Amp8iPhs8i(_) => 2,
        }
    }

    /// SICD's name.
    pub fn name(&self) -> &'static str {
        match self {
            Pixel::Re32fIm32f => "RE32F_IM32F",
            Pixel::Re16iIm16i => "RE16I_IM16I",
            Pixel::Amp8iPhs8i(_) => "AMP8I_PHS8I",
        }
    }

    /// NITF's `PVTYPE` and `NBPP` for it.
    pub fn nitf(&self) -> (&'static str, usize) {
        match self {
            Pixel::Re32fIm32f => ("R", 32),
            Pixel::Re16iIm16i => ("SI", 16),
            Pixel::Amp8iPhs8i(_) => ("INT", 8),
        }
    }

    /// The pixel stored (big-endian) in `b`.
    #[inline]
    pub fn value(&self, b: &[u8]) -> Complex32 {
        match self {
            Pixel::Re32fIm32f => Complex32::new(
                f32::from_be_bytes([b[0], b[1], b[2], b[3]]),
                f32::from_be_bytes([b[4], b[5], b[6], b[7]]),
            ),
            Pixel::Re16iIm16i => Complex32::new(
                f32::from(i16::from_be_bytes([b[0], b[1]])),
                f32::from(i16::from_be_bytes([b[2], b[3]])),
            ),
            Pixel::Amp8iPhs8i(table) => {
                let a = table.as_ref().map_or(f32::from(b[0]), |t| t[b[0] as usize]);
                let phase = std::f32::consts::TAU * f32::from(b[1]) / 256.0;
                Complex32::from_polar(a, phase)
            }
        }
    }
}

/// One direction of the image grid (`Grid/Row`, `Grid/Col`).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Direction {
    /// Sample spacing (m).
    pub ss: Option<f64>,
    /// Impulse response width, the resolution (m).
    pub imp_resp_wid: Option<f64>,
    /// Impulse response bandwidth (cycles/m).
    pub imp_resp_bw: Option<f64>,
}

/// The metadata a run's manifest records of a SICD.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Metadata {
    /// The SICD version's namespace (`urn:SICD:1.3.0`).
    pub namespace: Option<String>,
    /// `CollectionInfo/CollectorName`.
    pub collector: Option<String>,
    /// `CollectionInfo/CoreName`.
    pub core_name: Option<String>,
    /// `CollectionInfo/RadarMode/ModeType`.
    pub mode: Option<String>,
    /// `Timeline/CollectStart`.
    pub collect_start: Option<String>,
    /// `Timeline/CollectDuration` (s).
    pub collect_duration_s: Option<f64>,
    /// `ImageFormation/TxRcvPolarizationProc` (`V:V`).
    pub polarization: Option<String>,
    /// `Grid/ImagePlane` (`SLANT`, `GROUND`).
    pub image_plane: Option<String>,
    /// `Grid/Type` (`RGAZIM`, `RGZERO`, `XRGYCR`, ...).
    pub grid_type: Option<String>,
    /// `Grid/Row`.
    pub row: Direction,
    /// `Grid/Col`.
    pub col: Direction,
    /// `GeoData/SCP/LLH`: the scene centre point's latitude, longitude (degrees) and height
    /// above the ellipsoid (m).
    pub scp_llh: Option<[f64; 3]>,
    /// The constant terms of `Radiometric`'s `SigmaZeroSFPoly`, `BetaZeroSFPoly`,
    /// `GammaZeroSFPoly` and `RCSSFPoly` (the factor that turns `|pixel|^2` into sigma-0, ...
    /// at the scene centre), where given.
    pub radiometric: std::collections::BTreeMap<String, f64>,
    /// What calibrates a pixel (not recorded: its polynomials' constants are above).
    #[serde(skip)]
    pub calibration: Geometry,
    /// What projects ground points into the image, or which element of the XML it lacks.
    #[serde(skip)]
    pub projection: Result<Projection, String>,
}

pub use crate::io::projection::Poly2;
use crate::io::projection::{
    ellipsoid_normal, image_coordinates, poly2, Formation, Projection, Vec3,
};

/// What turns a pixel's place into the image coordinates of SICD's polynomials: the scene
/// centre pixel and the first row and column of the image in the full image (`ImageData`),
/// the sample spacings (`Grid/Row/SS`, `Grid/Col/SS`), and the radiometric polynomials by
/// name (`SigmaZeroSFPoly`, ...).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Geometry {
    /// `ImageData/SCPPixel` (row, column).
    pub scp_pixel: Option<[f64; 2]>,
    /// `ImageData/FirstRow`, `FirstCol`.
    pub first: [f64; 2],
    /// Row and column sample spacing (m).
    pub ss: Option<[f64; 2]>,
    /// `Radiometric`'s polynomials.
    pub polys: std::collections::BTreeMap<String, Poly2>,
}

impl Geometry {
    /// The amplitude factor of `poly` (`SigmaZeroSFPoly`, ...) at pixel `(row, col)` of the
    /// image: the square root of the polynomial at `xrow = (FirstRow + row - SCPPixel.Row)
    /// Row.SS`, `ycol = (FirstCol + col - SCPPixel.Col) Col.SS` (SICD Vol. 1, image
    /// coordinates), so that `|factor pixel|^2` is sigma-0 (beta-0, ...).
    pub fn factor(&self, poly: &Poly2, row: usize, col: usize) -> f32 {
        let (Some(scp), Some(ss)) = (self.scp_pixel, self.ss) else {
            return f32::NAN;
        };
        let (x, y) = image_coordinates((self.first, scp, ss), row as f64, col as f64);
        poly2(poly, x, y).sqrt() as f32
    }
}

/// The first child of `node` named `name` (any namespace).
fn child<'a, 'i>(node: roxmltree::Node<'a, 'i>, name: &str) -> Option<roxmltree::Node<'a, 'i>> {
    node.children()
        .find(|c| c.is_element() && c.tag_name().name() == name)
}

/// The node at the `/`-separated `path` below `node`.
fn at<'a, 'i>(node: roxmltree::Node<'a, 'i>, path: &str) -> Option<roxmltree::Node<'a, 'i>> {
    path.split('/').try_fold(node, child)
}

/// The trimmed text at `path` below `node`.
fn text(node: roxmltree::Node, path: &str) -> Option<String> {
    at(node, path)
        .and_then(|n| n.text())
        .map(|t| t.trim().to_string())
}

/// The number at `path` below `node`.
fn number(node: roxmltree::Node, path: &str) -> Option<f64> {
    text(node, path).and_then(|t| t.parse().ok())
}

/// The terms of the 2-D polynomial (`Poly2DType`) `node`.
fn terms2(node: roxmltree::Node) -> Result<Poly2, String> {
    let mut terms: Poly2 = vec![];
    for c in node.children().filter(|c| c.is_element()) {
        let e = |k: &str| c.attribute(k).and_then(|v| v.parse::<i32>().ok());
        let v = c.text().and_then(|t| t.trim().parse::<f64>().ok());
        match (e("exponent1"), e("exponent2"), v) {
            (Some(i), Some(j), Some(v)) if i >= 0 && j >= 0 => terms.push((i, j, v)),
            _ => return Err("has a term without exponents or a number".into()),
        }
    }
    Ok(terms)
}

/// The coefficients of the 1-D polynomial (`Poly1DType`) `node`, by exponent.
fn terms1(node: roxmltree::Node) -> Result<Vec<f64>, String> {
    let mut c = vec![];
    for t in node.children().filter(|c| c.is_element()) {
        let e = t
            .attribute("exponent1")
            .and_then(|v| v.parse::<usize>().ok());
        let v = t.text().and_then(|t| t.trim().parse::<f64>().ok());
        let (Some(e), Some(v)) = (e, v) else {
            return Err("has a term without an exponent or a number".into());
        };
        if c.len() <= e {
            c.resize(e + 1, 0.0);
        }
        c[e] += v;
    }
    Ok(c)
}

/// What projects ground points into the image (SICD's image projection model,
/// [`crate::io::projection`]), or the element it lacks.
fn projection(root: roxmltree::Node) -> Result<Projection, String> {
    let missing = |path: &str| format!("its SICD XML lacks {path}, which the projection needs");
    let num = |path: &str| number(root, path).ok_or_else(|| missing(path));
    let xyz = |path: &str| -> Result<Vec3, String> {
        Ok([
            num(&format!("{path}/X"))?,
            num(&format!("{path}/Y"))?,
            num(&format!("{path}/Z"))?,
        ])
    };
    let node = |path: &str| at(root, path).ok_or_else(|| missing(path));
    let p1 = |path: &str| terms1(node(path)?).map_err(|m| format!("its SICD XML's {path} {m}"));
    let p2 = |path: &str| terms2(node(path)?).map_err(|m| format!("its SICD XML's {path} {m}"));
    let scp = xyz("GeoData/SCP/ECF")?;
    let algo = text(root, "ImageFormation/ImageFormAlgo");
    let grid = text(root, "Grid/Type").ok_or_else(|| missing("Grid/Type"))?;
    let formation = match (grid.as_str(), algo.as_deref()) {
        ("RGAZIM", Some("PFA")) => Formation::Pfa {
            polar_angle: p1("PFA/PolarAngPoly")?,
            ksf: p1("PFA/SpatialFreqSFPoly")?,
        },
        ("RGAZIM", Some("RGAZCOMP")) => Formation::RgAzComp {
            az_sf: num("RgAzComp/AzSF")?,
        },
        ("RGZERO", _) => Formation::Inca {
            r_ca_scp: num("RMA/INCA/R_CA_SCP")?,
            time_ca: p1("RMA/INCA/TimeCAPoly")?,
            drate_sf: p2("RMA/INCA/DRateSFPoly")?,
        },
        ("XRGYCR" | "XCTYAT" | "PLANE", _) => Formation::Plane,
        ("RGAZIM", None) => return Err(missing("ImageFormation/ImageFormAlgo")),
        (g, a) => {
            return Err(format!(
                "its Grid/Type {g} with ImageFormation/ImageFormAlgo {a:?} has no projection \
                 model (RGAZIM with PFA or RGAZCOMP, RGZERO, XRGYCR, XCTYAT, PLANE)"
            ))
        }
    };
    let look = match text(root, "SCPCOA/SideOfTrack").as_deref() {
        Some("L") => 1.0,
        Some("R") => -1.0,
        _ => return Err(missing("SCPCOA/SideOfTrack (L or R)")),
    };
    Ok(Projection {
        scp,
        scp_pixel: [
            num("ImageData/SCPPixel/Row")?,
            num("ImageData/SCPPixel/Col")?,
        ],
        first: [
            number(root, "ImageData/FirstRow").unwrap_or(0.0),
            number(root, "ImageData/FirstCol").unwrap_or(0.0),
        ],
        ss: [num("Grid/Row/SS")?, num("Grid/Col/SS")?],
        u_row: xyz("Grid/Row/UVectECF")?,
        u_col: xyz("Grid/Col/UVectECF")?,
        time_coa: p2("Grid/TimeCOAPoly")?,
        arp: [
            p1("Position/ARPPoly/X")?,
            p1("Position/ARPPoly/Y")?,
            p1("Position/ARPPoly/Z")?,
        ],
        arp_scp: xyz("SCPCOA/ARPPos")?,
        varp_scp: xyz("SCPCOA/ARPVel")?,
        look,
        ground_normal: if matches!(formation, Formation::Pfa { .. }) {
            xyz("PFA/FPN")?
        } else {
            ellipsoid_normal(scp)
        },
        formation,
    })
}

/// Reads the SICD XML `xml`: `(rows, columns, pixel type, metadata)`.
///
/// # Errors
/// `(element, reason)`: not XML, not a SICD, `ImageData` without a size or with a pixel type
/// SICD does not define, an `AmpTable` without its 256 values.
pub fn read(xml: &str) -> Result<(usize, usize, Pixel, Metadata), (&'static str, String)> {
    let doc = roxmltree::Document::parse(xml.trim_end_matches('\0'))
        .map_err(|e| ("XML", format!("the SICD XML does not parse: {e}")))?;
    let root = doc.root_element();
    if root.tag_name().name() != "SICD" {
        return Err((
            "XML",
            format!("its root element is {}, not SICD", root.tag_name().name()),
        ));
    }
    let size = |name: &'static str| -> Result<usize, (&'static str, String)> {
        text(root, &format!("ImageData/{name}"))
            .and_then(|t| t.parse().ok())
            .filter(|&n: &usize| n > 0)
            .ok_or((
                name,
                format!("ImageData/{name} is missing or not a positive integer"),
            ))
    };
    let (rows, cols) = (size("NumRows")?, size("NumCols")?);
    let pixel = match text(root, "ImageData/PixelType").as_deref() {
        Some("RE32F_IM32F") => Pixel::Re32fIm32f,
        Some("RE16I_IM16I") => Pixel::Re16iIm16i,
        Some("AMP8I_PHS8I") => Pixel::Amp8iPhs8i(amp_table(root)?),
        other => {
            return Err((
                "PixelType",
                format!(
                    "ImageData/PixelType is {other:?}; SICD's are RE32F_IM32F, RE16I_IM16I and \
                     AMP8I_PHS8I"
                ),
            ))
        }
    };
    let direction = |d: &str| Direction {
        ss: number(root, &format!("Grid/{d}/SS")),
        imp_resp_wid: number(root, &format!("Grid/{d}/ImpRespWid")),
        imp_resp_bw: number(root, &format!("Grid/{d}/ImpRespBW")),
    };
    let llh = ["Lat", "Lon", "HAE"].map(|k| number(root, &format!("GeoData/SCP/LLH/{k}")));
    let mut radiometric = std::collections::BTreeMap::new();
    let mut polys = std::collections::BTreeMap::new();
    for poly in [
        "SigmaZeroSFPoly",
        "BetaZeroSFPoly",
        "GammaZeroSFPoly",
        "RCSSFPoly",
    ] {
        let Some(node) = at(root, &format!("Radiometric/{poly}")) else {
            continue;
        };
        let terms = terms2(node).map_err(|m| ("Radiometric", format!("Radiometric/{poly} {m}")))?;
        if let Some(&(_, _, c)) = terms.iter().find(|t| (t.0, t.1) == (0, 0)) {
            radiometric.insert(poly.to_string(), c);
        }
        polys.insert(poly.to_string(), terms);
    }
    let pair = |a: &str, b: &str| match (number(root, a), number(root, b)) {
        (Some(x), Some(y)) => Some([x, y]),
        _ => None,
    };
    let metadata = Metadata {
        namespace: root.tag_name().namespace().map(str::to_string),
        collector: text(root, "CollectionInfo/CollectorName"),
        core_name: text(root, "CollectionInfo/CoreName"),
        mode: text(root, "CollectionInfo/RadarMode/ModeType"),
        collect_start: text(root, "Timeline/CollectStart"),
        collect_duration_s: number(root, "Timeline/CollectDuration"),
        polarization: text(root, "ImageFormation/TxRcvPolarizationProc"),
        image_plane: text(root, "Grid/ImagePlane"),
        grid_type: text(root, "Grid/Type"),
        row: direction("Row"),
        col: direction("Col"),
        scp_llh: match llh {
            [Some(a), Some(b), Some(c)] => Some([a, b, c]),
            _ => None,
        },
        radiometric,
        projection: projection(root),
        calibration: Geometry {
            scp_pixel: pair("ImageData/SCPPixel/Row", "ImageData/SCPPixel/Col"),
            first: pair("ImageData/FirstRow", "ImageData/FirstCol").unwrap_or([0.0, 0.0]),
            ss: pair("Grid/Row/SS", "Grid/Col/SS"),
            polys,
        },
    };
    Ok((rows, cols, pixel, metadata))
}

/// `ImageData/AmpTable`: the 256 amplitudes of `AMP8I_PHS8I` (`None`: absent, the byte is
/// the amplitude).
fn amp_table(root: roxmltree::Node) -> Result<Option<Vec<f32>>, (&'static str, String)> {
    let Some(table) = at(root, "ImageData/AmpTable") else {
        return Ok(None);
    };
    let mut amps = vec![f32::NAN; 256];
    for a in table.children().filter(|c| c.is_element()) {
        let i: Option<usize> = a.attribute("index").and_then(|i| i.parse().ok());
        let v: Option<f32> = a.text().and_then(|t| t.trim().parse().ok());
        match (i, v) {
            (Some(i), Some(v)) if i < 256 => amps[i] = v,
            _ => {
                return Err((
                    "AmpTable",
                    "an Amplitude without an index below 256 or a number".into(),
                ))
            }
        }
    }
    if amps.iter().any(|a| a.is_nan()) {
        return Err((
            "AmpTable",
            "ImageData/AmpTable lacks some of its 256 amplitudes".into(),
        ));
    }
    Ok(Some(amps))
}
