//! SICD's image projection: from a point on the ground (latitude, longitude, height above the
//! WGS-84 ellipsoid) to the pixel of a SICD image that holds it, by the SICD Image Projections
//! Description (NGA.STND.0024-3): every pixel maps to a range `R` and range rate `Rdot` from
//! the aperture reference point at its centre-of-aperture time, through the image formation's
//! own model (polar format `PFA`, range/azimuth compression `RGAZCOMP`, the range-Doppler
//! `INCA` of RMA and of most stripmap and spotlight products of Umbra and Capella, or a plane
//! grid); the ground point is found on the plane through it tangent to the ellipsoid where
//! that R/Rdot contour meets it, and the image point by the description's iteration
//! ("scene to image", section 6), which converges to the pixel whose contour passes through
//! the point. Written after sarpy's `point_projection` (its `ground_to_image` is the test's
//! oracle), with one difference: pixel places are of the stored image (`ImageData/FirstRow`
//! and `FirstCol` subtracted), where sarpy mixes full-image and stored places when they are
//! not 0.

/// A point or vector in Earth-centred, Earth-fixed coordinates (m).
pub type Vec3 = [f64; 3];

/// A 2-D polynomial of SICD (`Poly2DType`): `(exponent1, exponent2, coefficient)` terms.
pub type Poly2 = Vec<(i32, i32, f64)>;

/// WGS-84's semi-major axis (m).
const WGS84_A: f64 = 6_378_137.0;
/// WGS-84's flattening.
const WGS84_F: f64 = 1.0 / 298.257_223_563;

/// The image formation's model from a pixel to its range and range rate (SICD's
/// `ImageFormation/ImageFormAlgo` and `Grid/Type`).
#[derive(Debug, Clone, PartialEq)]
pub enum Formation {
    /// Polar format (`PFA`, grid `RGAZIM`): the polar angle of time and the spatial frequency
    /// scale factor of the polar angle (`PFA/PolarAngPoly`, `PFA/SpatialFreqSFPoly`).
    Pfa {
        /// `PolarAngPoly` (radians of seconds).
        polar_angle: Vec<f64>,
        /// `SpatialFreqSFPoly` (of the polar angle).
        ksf: Vec<f64>,
    },
    /// Range/azimuth compression (`RGAZCOMP`, grid `RGAZIM`): `RgAzComp/AzSF`.
    RgAzComp {
        /// Azimuth scale factor.
        az_sf: f64,
    },
    /// Range-Doppler (`RMA/INCA`, grid `RGZERO`): range at closest approach of the scene
    /// centre, time of closest approach of the column, Doppler rate scale factor.
    Inca {
        /// `R_CA_SCP` (m).
        r_ca_scp: f64,
        /// `TimeCAPoly` (s of the column coordinate).
        time_ca: Vec<f64>,
        /// `DRateSFPoly`.
        drate_sf: Poly2,
    },
    /// A plane grid (`XRGYCR`, `XCTYAT`, `PLANE`): pixels lie on the plane of the grid's unit
    /// vectors through the scene centre.
    Plane,
}

impl Formation {
    /// Its name in SICD's terms (`PFA`, `RGAZCOMP`, `INCA`, `PLANE`).
    pub fn name(&self) -> &'static str {
        match self {
            Formation::Pfa { .. } => "PFA",
            Formation::RgAzComp { .. } => "RGAZCOMP",
            Formation::Inca { .. } => "INCA",
            Formation::Plane => "PLANE",
        }
    }
}

/// What projects ground points into one SICD image.
#[derive(Debug, Clone, PartialEq)]
pub struct Projection {
    /// The scene centre point (`GeoData/SCP/ECF`).
    pub scp: Vec3,
    /// Its pixel in the full image (`ImageData/SCPPixel`: row, column).
    pub scp_pixel: [f64; 2],
    /// The stored image's first row and column in the full image (`ImageData/FirstRow`,
    /// `FirstCol`).
    pub first: [f64; 2],
    /// Row and column sample spacing (`Grid/Row/SS`, `Grid/Col/SS`, m).
    pub ss: [f64; 2],
    /// Unit vectors of increasing row and column (`Grid/Row/UVectECF`, `Grid/Col/UVectECF`).
    pub u_row: Vec3,
    /// See `u_row`.
    pub u_col: Vec3,
    /// Centre-of-aperture time of the image coordinates (`Grid/TimeCOAPoly`, s).
    pub time_coa: Poly2,
    /// Aperture reference position's `X`, `Y`, `Z` polynomials of time (`Position/ARPPoly`).
    pub arp: [Vec<f64>; 3],
    /// The aperture reference position and velocity at the scene centre's COA time
    /// (`SCPCOA/ARPPos`, `SCPCOA/ARPVel`).
    pub arp_scp: Vec3,
    /// See `arp_scp`.
    pub varp_scp: Vec3,
    /// `+1` for a left-looking collection, `-1` for right (`SCPCOA/SideOfTrack` `L`, `R`).
    pub look: f64,
    /// The ground plane's normal for the iteration: `PFA/FPN` for polar format, else the
    /// ellipsoid's normal at the scene centre.
    pub ground_normal: Vec3,
    /// The image formation's model.
    pub formation: Formation,
}

fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn scale(s: f64, a: Vec3) -> Vec3 {
    [s * a[0], s * a[1], s * a[2]]
}

fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn norm(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}

fn unit(a: Vec3) -> Vec3 {
    scale(1.0 / norm(a), a)
}

/// SICD's image coordinates `(xrow, ycol)` (m from the scene centre along the grid's row and
/// column) of the stored image's pixel place `(row, col)`: `xrow = (FirstRow + row -
/// SCPPixel.Row) Row.SS`, `ycol` likewise (SICD Vol. 1), with `first`, `scp_pixel` and `ss` the
/// row and column pairs of `ImageData/FirstRow`, `FirstCol`, `ImageData/SCPPixel` and the grid's
/// sample spacings.
pub fn image_coordinates(
    (first, scp_pixel, ss): ([f64; 2], [f64; 2], [f64; 2]),
    row: f64,
    col: f64,
) -> (f64, f64) {
    (
        (first[0] + row - scp_pixel[0]) * ss[0],
        (first[1] + col - scp_pixel[1]) * ss[1],
    )
}

/// `sum c[i] t^i`.
pub fn poly1(c: &[f64], t: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &k| acc * t + k)
}

/// The derivative's coefficients of `c`.
fn derivative(c: &[f64]) -> Vec<f64> {
    c.iter()
        .enumerate()
        .skip(1)
        .map(|(i, &k)| i as f64 * k)
        .collect()
}

/// `sum c x^i y^j` over the terms `(i, j, c)`.
pub fn poly2(p: &Poly2, x: f64, y: f64) -> f64 {
    p.iter().map(|&(i, j, c)| c * x.powi(i) * y.powi(j)).sum()
}

/// The point at geodetic latitude and longitude (degrees) and height above the WGS-84
/// ellipsoid (m), in ECF coordinates.
pub fn geodetic_to_ecf(lat: f64, lon: f64, height: f64) -> Vec3 {
    let e2 = WGS84_F * (2.0 - WGS84_F);
    let (sl, cl) = lat.to_radians().sin_cos();
    let (so, co) = lon.to_radians().sin_cos();
    let n = WGS84_A / (1.0 - e2 * sl * sl).sqrt();
    [
        (n + height) * cl * co,
        (n + height) * cl * so,
        (n * (1.0 - e2) + height) * sl,
    ]
}

/// The outward unit normal of the WGS-84 ellipsoid through the ECF point `p` (of the
/// ellipsoid scaled to pass through it).
pub fn ellipsoid_normal(p: Vec3) -> Vec3 {
    let b = WGS84_A * (1.0 - WGS84_F);
    let a2 = WGS84_A * WGS84_A;
    unit([p[0] / a2, p[1] / a2, p[2] / (b * b)])
}

/// What the R/Rdot model gives for one image point: range and range rate, the aperture
/// reference position and velocity at its COA time.
struct Contour {
    r: f64,
    rdot: f64,
    arp: Vec3,
    varp: Vec3,
}

/// The iteration's tolerance on the ground (m) and its most iterations.
const TOLERANCE_M: f64 = 1e-8;
const MAX_ITERATIONS: usize = 50;

impl Projection {
    fn position(&self, t: f64) -> Vec3 {
        [0, 1, 2].map(|k| poly1(&self.arp[k], t))
    }

    fn velocity(&self, t: f64) -> Vec3 {
        [0, 1, 2].map(|k| poly1(&derivative(&self.arp[k]), t))
    }

    /// The R/Rdot contour of the image coordinates `(xrow, ycol)` (m from the scene centre
    /// along the grid's row and column).
    fn contour(&self, xrow: f64, ycol: f64) -> Contour {
        let t = poly2(&self.time_coa, xrow, ycol);
        let (arp, varp) = (self.position(t), self.velocity(t));
        let from_scp = || {
            let d = sub(arp, self.scp);
            let r = norm(d);
            (r, dot(varp, d) / r)
        };
        let (r, rdot) = match &self.formation {
            Formation::Pfa { polar_angle, ksf } => {
                let (r0, rdot0) = from_scp();
                let theta = poly1(polar_angle, t);
                let dtheta = poly1(&derivative(polar_angle), t);
                let k = poly1(ksf, theta);
                let dk = poly1(&derivative(ksf), theta);
                let (s, c) = theta.sin_cos();
                let along = xrow * c + ycol * s;
                let across = -xrow * s + ycol * c;
                (r0 + k * along, rdot0 + (dk * along + k * across) * dtheta)
            }
            Formation::RgAzComp { az_sf } => {
                let (r0, rdot0) = from_scp();
                (r0 + xrow, rdot0 - norm(varp) * az_sf * ycol)
            }
            Formation::Inca {
                r_ca_scp,
                time_ca,
                drate_sf,
            } => {
                let r_ca = r_ca_scp + xrow;
                let t_ca = poly1(time_ca, ycol);
                let v = self.velocity(t_ca);
                let v2 = dot(v, v);
                let drsf = poly2(drate_sf, xrow, ycol);
                let dt = t - t_ca;
                let r = (r_ca * r_ca + drsf * v2 * dt * dt).sqrt();
                (r, drsf / r * v2 * dt)
            }
            Formation::Plane => {
                let p = add(
                    self.scp,
                    add(scale(xrow, self.u_row), scale(ycol, self.u_col)),
                );
                let d = sub(arp, p);
                let r = norm(d);
                (r, dot(varp, d) / r)
            }
        };
        Contour { r, rdot, arp, varp }
    }

    /// Where the contour meets the plane through `gref` with unit normal `uz` (NaNs where it
    /// does not).
    fn on_plane(c: &Contour, gref: Vec3, uz: Vec3) -> Vec3 {
        let arp_z = dot(sub(c.arp, gref), uz);
        if arp_z > c.r {
            return [f64::NAN; 3];
        }
        let nadir = sub(c.arp, scale(arp_z, uz));
        let gd = (c.r * c.r - arp_z * arp_z).sqrt();
        let (cos_graz, sin_graz) = (gd / c.r, arp_z / c.r);
        let vz = dot(c.varp, uz);
        let vx = (dot(c.varp, c.varp) - vz * vz).sqrt();
        let ux = scale(1.0 / vx, sub(c.varp, scale(vz, uz)));
        let uy = cross(uz, ux);
        let cos_az = (-c.rdot + vz * sin_graz) / (vx * cos_graz);
        if cos_az.abs() > 1.0 {
            return [f64::NAN; 3];
        }
        let look = dot(cross(sub(c.arp, gref), c.varp), uz).signum();
        let sin_az = look * (1.0 - cos_az * cos_az).sqrt();
        add(nadir, add(scale(gd * cos_az, ux), scale(gd * sin_az, uy)))
    }

    /// The ground point of the stored image's pixel place `(row, col)` on the plane through
    /// `gref` with unit normal `uz` (the image-to-ground projection; NaNs where the pixel's
    /// contour does not meet that plane).
    pub fn image_to_plane(&self, row: f64, col: f64, gref: Vec3, uz: Vec3) -> Vec3 {
        let (xrow, ycol) = image_coordinates((self.first, self.scp_pixel, self.ss), row, col);
        Self::on_plane(&self.contour(xrow, ycol), gref, uz)
    }

    /// The stored image's pixel place `(row, col)` of the ECF point `p` (pixel centres at
    /// whole numbers, as SICD places them), and the ground distance (m) left between the point
    /// and the projection of that place when the iteration stopped.
    pub fn ground_to_image(&self, p: Vec3) -> ([f64; 2], f64) {
        let ipn = unit(cross(self.u_row, self.u_col));
        let cos_t = dot(self.u_row, self.u_col);
        let sin2 = 1.0 - cos_t * cos_t;
        let spn = unit(scale(
            self.look,
            cross(self.varp_scp, sub(self.scp, self.arp_scp)),
        ));
        let sf = dot(spn, ipn);
        let mut g = p;
        let mut place = [f64::NAN; 2];
        let mut left = f64::INFINITY;
        for _ in 0..MAX_ITERATIONS {
            // The ground point along the slant plane's normal into the image plane, and its
            // image coordinates along the (possibly skewed) row and column vectors.
            let dist = dot(sub(self.scp, g), ipn) / sf;
            let d = sub(add(g, scale(dist, spn)), self.scp);
            let (a, b) = (dot(d, self.u_row), dot(d, self.u_col));
            let (xrow, ycol) = ((a - cos_t * b) / sin2, (b - cos_t * a) / sin2);
            place = [
                xrow / self.ss[0] + self.scp_pixel[0] - self.first[0],
                ycol / self.ss[1] + self.scp_pixel[1] - self.first[1],
            ];
            let on = Self::on_plane(&self.contour(xrow, ycol), g, self.ground_normal);
            let diff = sub(p, on);
            left = norm(diff);
            g = add(g, diff);
            if left.is_nan() || left <= TOLERANCE_M {
                break;
            }
        }
        (place, left)
    }

    /// The stored image's pixel place of geodetic `(lat, lon, height)`
    /// ([`Projection::ground_to_image`] of its ECF point).
    pub fn geodetic_to_image(&self, lat: f64, lon: f64, height: f64) -> ([f64; 2], f64) {
        self.ground_to_image(geodetic_to_ecf(lat, lon, height))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A right-looking straight pass over a scene centre at 48 N, 11 E, 500 m, with the
    /// range-Doppler model of its zero-Doppler geometry.
    fn inca(first: [f64; 2]) -> Projection {
        let scp = geodetic_to_ecf(48.0, 11.0, 500.0);
        let up = ellipsoid_normal(scp);
        let north = unit(cross(cross(up, [0.0, 0.0, 1.0]), up));
        let east = cross(north, up);
        let v = scale(200.0, north);
        let p0 = add(add(scp, scale(10_000.0, up)), scale(-15_000.0, east));
        let (t_ca, speed) = (dot(sub(scp, p0), v) / dot(v, v), norm(v));
        let arp_ca = add(p0, scale(t_ca, v));
        let u_row = unit(sub(scp, arp_ca));
        Projection {
            scp,
            scp_pixel: [100.0, 80.0],
            first,
            ss: [0.5, 0.4],
            u_row,
            u_col: unit(v),
            time_coa: vec![(0, 0, t_ca), (0, 1, 1.0 / speed)],
            arp: [0, 1, 2].map(|k| vec![p0[k], v[k]]),
            arp_scp: arp_ca,
            varp_scp: v,
            look: -1.0,
            ground_normal: up,
            formation: Formation::Inca {
                r_ca_scp: norm(sub(scp, arp_ca)),
                time_ca: vec![t_ca, 1.0 / speed],
                drate_sf: vec![(0, 0, 1.0)],
            },
        }
    }

    #[test]
    fn the_scene_centre_projects_to_its_pixel() {
        let p = inca([0.0, 0.0]);
        let ([r, c], left) = p.ground_to_image(p.scp);
        assert!(
            (r - 100.0).abs() < 1e-6 && (c - 80.0).abs() < 1e-6,
            "{r} {c}"
        );
        assert!(left <= TOLERANCE_M);
    }

    /// Image to ground and back: a pixel place projected onto the ellipsoid's tangent plane at
    /// the scene centre, then that ground point into the image, gives the place again, also
    /// for a stored image that starts inside the full image.
    #[test]
    fn ground_to_image_inverts_image_to_ground() {
        for first in [[0.0, 0.0], [30.0, 12.0]] {
            let p = inca(first);
            for &(row, col) in &[(3.0, 7.0), (150.5, 20.25), (60.0, 140.0)] {
                let g = p.image_to_plane(row, col, p.scp, p.ground_normal);
                let ([r, c], _) = p.ground_to_image(g);
                assert!(
                    (r - row).abs() < 1e-6 && (c - col).abs() < 1e-6,
                    "{first:?}: ({row}, {col}) -> ({r}, {c})"
                );
            }
        }
    }

    #[test]
    fn polynomials_evaluate_as_written() {
        assert_eq!(poly1(&[1.0, 2.0, 3.0], 2.0), 1.0 + 4.0 + 12.0);
        assert_eq!(derivative(&[1.0, 2.0, 3.0]), vec![2.0, 6.0]);
        assert_eq!(poly2(&vec![(0, 0, 1.0), (1, 2, 2.0)], 3.0, 2.0), 1.0 + 24.0);
    }

    /// The equator at the prime meridian, and the pole, of WGS-84.
    #[test]
    fn geodetic_points_lie_on_the_ellipsoid() {
        let e = geodetic_to_ecf(0.0, 0.0, 0.0);
        assert!((e[0] - WGS84_A).abs() < 1e-6 && e[1].abs() < 1e-9 && e[2].abs() < 1e-9);
        let n = geodetic_to_ecf(90.0, 0.0, 0.0);
        assert!((n[2] - WGS84_A * (1.0 - WGS84_F)).abs() < 1e-6);
        let u = ellipsoid_normal(geodetic_to_ecf(48.0, 11.0, 0.0));
        let lat = u[2].asin().to_degrees();
        assert!((lat - 48.0).abs() < 1e-9, "{lat}");
    }
}
