//! ISAR imaging chain: monostatic far-field forward model of point scatterers
//! and polar-format imaging from k-space data to a complex top-view image.
//!
//! Physics (docs/definitions.md §9). The radar looks at the scene from the
//! direction `r_hat(phi) = (cos phi, sin phi, 0)` (elevation 0, `phi` = azimuth).
//! The monostatic far-field response of point scatterers with complex
//! amplitudes `a_k` at positions `r_k` (metres) is
//!
//! `E(f, phi) = sum_k a_k exp(-j 2 k r_hat(phi) . r_k)`, with `k = 2 pi f / c`.
//!
//! Writing `kx = 2k cos(phi)`, `ky = 2k sin(phi)` this is
//! `E = sum_k a_k exp(-j (kx x_k + ky y_k))`: the data are samples of the 2-D
//! Fourier transform of the top-view (xy) reflectivity on a polar raster
//! (an annulus sector). [`image`] interpolates them onto a Cartesian
//! `(kx, ky)` grid (bicubic Catmull-Rom interpolation in the polar
//! coordinates `(f, phi)`, zero outside the measured annulus sector),
//! applies a separable window and takes a 2-D inverse FFT (with the shifts
//! that put zero offset at the image centre), giving a `size x size` complex
//! image.
//!
//! Conventions: image rows are `y` (cross-range at `phi = 0`), columns are `x`
//! (down-range at `phi = 0`, positive towards the radar); pixel `(row, col)`
//! is centred at `x = (col - size/2) dx`, `y = (row - size/2) dx`, with
//! `dx = extent / size`. The image is at baseband: it equals the exact
//! back-projection multiplied by the carrier `exp(-j (kxc x + kyc y))`, where
//! `(kxc, kyc)` is the centre of the Cartesian k-grid; magnitudes and
//! sample-to-sample statistics at a pixel are unaffected. It is normalised so
//! that a unit-amplitude point at a pixel centre images to a peak of
//! magnitude ~1 (exactly 1 at the origin), whatever the window.
//!
//! Default measurement ([`Measurement::default_full`]): 2-18 GHz in 256
//! steps (62.7 MHz) and azimuth -25.5..25.5 deg in 256 steps (0.2 deg).
//! Resolution: `c / (2 B) = 9.4 mm` in range; the k-space support spans
//! 679 rad/m in `kx` and 649 rad/m in `ky`, so the full-resolution 64 x 64
//! image has pixels of 9.26 mm and covers 0.593 m x 0.593 m. The unambiguous
//! extent of the raw data is `c / (2 df) = 2.39 m` in range and
//! `lambda_min / (2 dphi) = 2.39 m` in cross-range at 18 GHz: a factor ~4
//! above the image extent. The measurement is oversampled on purpose
//! (128 x 128 would already be alias-free over 1.2 m) so that interpolation
//! in the polar coordinates stays accurate (peak loss < a few percent) for
//! scatterers anywhere in the image. Scatterers outside the image extent
//! wrap around (the Cartesian grid spacing sets the image period).

use ndarray::{Array2, ArrayView2};
use num_complex::Complex64;
use rayon::prelude::*;
use rustfft::FftPlanner;

/// Speed of light in vacuum (m/s).
pub const C0: f64 = 299_792_458.0;

/// Errors from the imaging chain (bad parameters or inconsistent shapes).
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum IsarError {
    /// A parameter is out of its valid range; names the parameter.
    #[error("invalid parameter `{name}`: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Why it is invalid.
        reason: String,
    },
    /// The k-space data shape does not match the measurement.
    #[error("data shape {got:?} does not match measurement [n_f, n_phi] = {expected:?}")]
    Shape {
        /// Shape of the data passed in.
        got: [usize; 2],
        /// Shape required by the measurement.
        expected: [usize; 2],
    },
}

fn bad(name: &'static str, reason: impl Into<String>) -> IsarError {
    IsarError::InvalidParameter {
        name,
        reason: reason.into(),
    }
}

/// Measurement geometry: stepped frequencies (Hz) and azimuths (rad).
/// Both must be strictly increasing with at least two entries.
#[derive(Clone, Debug, PartialEq)]
pub struct Measurement {
    /// Frequencies in Hz, strictly increasing.
    pub freqs: Vec<f64>,
    /// Azimuth angles in radians, strictly increasing.
    pub azimuths: Vec<f64>,
}

impl Measurement {
    /// Uniform grid: `n_f` frequencies from `f_min` to `f_max` (Hz, inclusive)
    /// and `n_phi` azimuths spanning `span_rad` centred on 0 (inclusive).
    pub fn uniform(
        f_min: f64,
        f_max: f64,
        n_f: usize,
        span_rad: f64,
        n_phi: usize,
    ) -> Result<Self, IsarError> {
        if !(f_min > 0.0 && f_min.is_finite()) {
            return Err(bad("f_min", "must be positive and finite"));
        }
        if !(f_max > f_min && f_max.is_finite()) {
            return Err(bad("f_max", "must be finite and > f_min"));
        }
        if n_f < 4 {
            return Err(bad("n_f", "need at least 4 frequencies"));
        }
        if n_phi < 4 {
            return Err(bad("n_phi", "need at least 4 azimuths"));
        }
        if !(span_rad > 0.0 && span_rad < std::f64::consts::PI) {
            return Err(bad("span_rad", "must be in (0, pi)"));
        }
        let freqs = (0..n_f)
            .map(|i| f_min + (f_max - f_min) * i as f64 / (n_f - 1) as f64)
            .collect();
        let azimuths = (0..n_phi)
            .map(|i| -0.5 * span_rad + span_rad * i as f64 / (n_phi - 1) as f64)
            .collect();
        Ok(Measurement { freqs, azimuths })
    }

    /// The default full-resolution measurement: 2-18 GHz (16 GHz bandwidth)
    /// in 256 steps and azimuth -25.5..25.5 deg (51 deg) in 256 steps.
    /// Range resolution 9.4 mm; full-resolution 64 x 64 image extent 0.593 m;
    /// unambiguous extent of the raw data ~2.39 m (see the module docs).
    pub fn default_full() -> Self {
        Self::uniform(2e9, 18e9, 256, 51f64.to_radians(), 256).expect("valid constants")
    }

    /// Number of frequencies.
    pub fn n_f(&self) -> usize {
        self.freqs.len()
    }

    /// Number of azimuths.
    pub fn n_phi(&self) -> usize {
        self.azimuths.len()
    }

    /// Checks that both axes are finite, strictly increasing, with >= 2
    /// entries, frequencies positive and azimuth span < pi.
    pub fn validate(&self) -> Result<(), IsarError> {
        fn increasing(v: &[f64]) -> bool {
            v.len() >= 2 && v.iter().all(|x| x.is_finite()) && v.windows(2).all(|w| w[1] > w[0])
        }
        if !increasing(&self.freqs) || self.freqs[0] <= 0.0 {
            return Err(bad(
                "freqs",
                "need >= 2 positive, finite, strictly increasing frequencies",
            ));
        }
        if !increasing(&self.azimuths)
            || self.azimuths[self.azimuths.len() - 1] - self.azimuths[0] >= std::f64::consts::PI
        {
            return Err(bad(
                "azimuths",
                "need >= 2 finite, strictly increasing azimuths spanning < pi",
            ));
        }
        Ok(())
    }

    /// Bounding box of the k-space support `[kx_min, kx_max, ky_min, ky_max]`
    /// (rad/m) of the annulus sector `2k (cos phi, sin phi)`.
    pub fn k_bounds(&self) -> [f64; 4] {
        let k_lo = 4.0 * std::f64::consts::PI * self.freqs[0] / C0;
        let k_hi = 4.0 * std::f64::consts::PI * self.freqs[self.freqs.len() - 1] / C0;
        let (p0, p1) = (self.azimuths[0], self.azimuths[self.azimuths.len() - 1]);
        let mut kx = vec![];
        let mut ky = vec![];
        for &kk in &[k_lo, k_hi] {
            for &p in &[p0, p1] {
                kx.push(kk * p.cos());
                ky.push(kk * p.sin());
            }
        }
        // extremes of kx = K cos(phi) at phi = 0 (if inside), of ky at +-pi/2
        if p0 <= 0.0 && p1 >= 0.0 {
            kx.push(k_hi);
            kx.push(k_lo);
        }
        let mn = |v: &[f64]| v.iter().cloned().fold(f64::INFINITY, f64::min);
        let mx = |v: &[f64]| v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        [mn(&kx), mx(&kx), mn(&ky), mx(&ky)]
    }

    /// Extent (m) of a full-resolution image of `size` pixels: the Cartesian
    /// k-grid then exactly spans the larger side of the k-support bounding
    /// box, `extent = size * 2 pi / max(kx span, ky span)`.
    pub fn full_resolution_extent(&self, size: usize) -> f64 {
        let b = self.k_bounds();
        let span = (b[1] - b[0]).max(b[3] - b[2]);
        size as f64 * 2.0 * std::f64::consts::PI / span
    }
}

/// Window applied over the Cartesian k-grid (separable in kx and ky, spanning
/// the part of the grid inside the bounding box of the measured support).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
pub enum Window {
    /// `0.5 - 0.5 cos(2 pi t)`, `t` in [0, 1].
    Hann,
    /// `0.54 - 0.46 cos(2 pi t)`.
    Hamming,
    /// 4-term Taylor window, -35 dB sidelobes (nbar = 4).
    Taylor,
    /// Rectangular (no window).
    None,
}

impl Window {
    /// Window value at the normalised position `t` in [0, 1] (0 outside).
    pub fn eval(self, t: f64) -> f64 {
        if !(0.0..=1.0).contains(&t) {
            return 0.0;
        }
        let c = |m: f64| (2.0 * std::f64::consts::PI * m * (t - 0.5)).cos();
        match self {
            Window::Hann => 0.5 - 0.5 * (2.0 * std::f64::consts::PI * t).cos(),
            Window::Hamming => 0.54 - 0.46 * (2.0 * std::f64::consts::PI * t).cos(),
            // Taylor (SLL = -35 dB, nbar = 4) cosine-series coefficients.
            Window::Taylor => {
                1.0 + 2.0 * (0.292_656 * c(1.0) - 0.015_849 * c(2.0) + 0.003_655 * c(3.0))
            }
            Window::None => 1.0,
        }
    }
}

/// Imaging options.
#[derive(Clone, Debug, PartialEq)]
pub struct ImagingOptions {
    /// Image size in pixels per side (e.g. 64), >= 2.
    pub size: usize,
    /// Window over the Cartesian k-grid.
    pub window: Window,
    /// Side length of the (square) imaged area in metres; `None` = full
    /// resolution ([`Measurement::full_resolution_extent`]). A larger extent
    /// crops k-space (coarser resolution); a smaller one zero-pads it.
    pub extent_m: Option<f64>,
}

impl Default for ImagingOptions {
    /// 64 x 64, Hann window, full-resolution extent.
    fn default() -> Self {
        ImagingOptions {
            size: 64,
            window: Window::Hann,
            extent_m: None,
        }
    }
}

/// Windowed Cartesian k-grid produced by polar-format interpolation.
#[derive(Clone, Debug)]
pub struct KGrid {
    /// Windowed samples `[row = ky index, col = kx index]`.
    pub data: Array2<Complex64>,
    /// Grid spacing (rad/m) in both directions.
    pub dk: f64,
    /// Grid centre `(kxc, kyc)` (rad/m): sample `(r, c)` is at
    /// `kx = kxc + (c - size/2) dk`, `ky = kyc + (r - size/2) dk`.
    pub centre: [f64; 2],
    /// Image-domain normalisation: sum of the window weights over the grid
    /// cells inside the support (the image is the inverse DFT divided by it).
    pub norm: f64,
    /// Image extent (m) = `2 pi / dk`; pixel spacing = extent / size.
    pub extent_m: f64,
}

/// Catmull-Rom weights for fractional position `t` in [0, 1) between the
/// 2nd and 3rd of four samples.
fn cubic_weights(t: f64) -> [f64; 4] {
    let t2 = t * t;
    let t3 = t2 * t;
    [
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    ]
}

/// Locates `v` in the increasing axis `a`: returns `(i, t)` with
/// `a[i] <= v <= a[i+1]`, `t` the fractional position, or `None` outside.
fn locate(a: &[f64], v: f64) -> Option<(usize, f64)> {
    let n = a.len();
    if v < a[0] || v > a[n - 1] {
        return None;
    }
    let i = match a.partition_point(|&x| x <= v) {
        0 => 0,
        p => (p - 1).min(n - 2),
    };
    Some((i, (v - a[i]) / (a[i + 1] - a[i])))
}

/// Interpolation taps along one axis: indices and weights (cubic, with the
/// end taps clamped to the axis so that the edges fall back to lower order).
fn taps(n: usize, i: usize, t: f64) -> [(usize, f64); 4] {
    let w = cubic_weights(t);
    let mut out = [(0usize, 0.0); 4];
    for (m, o) in out.iter_mut().enumerate() {
        let idx = (i as isize + m as isize - 1).clamp(0, n as isize - 1) as usize;
        *o = (idx, w[m]);
    }
    out
}

/// Polar-format interpolation of `E(f, phi)` (`[n_f, n_phi]`) onto the
/// windowed Cartesian `(kx, ky)` grid used by [`image`]. Bicubic
/// (Catmull-Rom) interpolation in the index coordinates of `(f, phi)`;
/// cells outside the measured annulus sector are zero.
pub fn polar_to_cartesian(
    e: ArrayView2<Complex64>,
    m: &Measurement,
    opts: &ImagingOptions,
) -> Result<KGrid, IsarError> {
    m.validate()?;
    let (nf, np) = (m.n_f(), m.n_phi());
    if e.dim() != (nf, np) {
        return Err(IsarError::Shape {
            got: [e.dim().0, e.dim().1],
            expected: [nf, np],
        });
    }
    let n = opts.size;
    if n < 2 {
        return Err(bad("size", "image size must be >= 2"));
    }
    let extent = match opts.extent_m {
        None => m.full_resolution_extent(n),
        Some(x) if x.is_finite() && x > 0.0 => x,
        Some(_) => return Err(bad("extent_m", "must be positive and finite")),
    };
    let two_pi = 2.0 * std::f64::consts::PI;
    let dk = two_pi / extent;
    let b = m.k_bounds();
    let centre = [0.5 * (b[0] + b[1]), 0.5 * (b[2] + b[3])];
    let half = (n / 2) as f64;
    let kx: Vec<f64> = (0..n).map(|c| centre[0] + (c as f64 - half) * dk).collect();
    let ky: Vec<f64> = (0..n).map(|r| centre[1] + (r as f64 - half) * dk).collect();
    // Window spans the intersection of the grid with the support bounding box.
    let win_axis = |ks: &[f64], lo: f64, hi: f64| -> Vec<f64> {
        let g_lo = ks
            .iter()
            .cloned()
            .filter(|&k| k >= lo)
            .fold(f64::INFINITY, f64::min);
        let g_hi = ks
            .iter()
            .cloned()
            .filter(|&k| k <= hi)
            .fold(f64::NEG_INFINITY, f64::max);
        ks.iter()
            .map(|&k| {
                if g_hi > g_lo {
                    opts.window.eval((k - g_lo) / (g_hi - g_lo))
                } else {
                    1.0
                }
            })
            .collect()
    };
    let wx = win_axis(&kx, b[0], b[1]);
    let wy = win_axis(&ky, b[2], b[3]);
    let k_per_f = 4.0 * std::f64::consts::PI / C0; // 2k = k_per_f * f
    let mut data = Array2::<Complex64>::zeros((n, n));
    let mut norm = 0.0;
    for r in 0..n {
        for c in 0..n {
            let kk = kx[c].hypot(ky[r]);
            let f = kk / k_per_f;
            let phi = ky[r].atan2(kx[c]);
            let (Some((i, ti)), Some((j, tj))) = (locate(&m.freqs, f), locate(&m.azimuths, phi))
            else {
                continue;
            };
            let w = wx[c] * wy[r];
            if w == 0.0 {
                continue;
            }
            let mut acc = Complex64::new(0.0, 0.0);
            for (ii, wi) in taps(nf, i, ti) {
                for (jj, wj) in taps(np, j, tj) {
                    acc += e[[ii, jj]] * (wi * wj);
                }
            }
            data[[r, c]] = acc * w;
            norm += w;
        }
    }
    if norm <= 0.0 {
        return Err(bad(
            "extent_m",
            "the Cartesian grid does not intersect the measured k-space support",
        ));
    }
    Ok(KGrid {
        data,
        dk,
        centre,
        norm,
        extent_m: extent,
    })
}

/// Centred unnormalised 2-D inverse DFT of the grid (zero offset at index
/// `size/2` in both domains), divided by `norm`:
/// `I[p, q] = (1/norm) sum_{r,c} G[r, c] exp(+j 2 pi ((r - n/2)(p - n/2) + (c - n/2)(q - n/2)) / n)`.
pub fn centred_ifft2(g: &Array2<Complex64>, norm: f64) -> Array2<Complex64> {
    let (n, n2) = g.dim();
    assert_eq!(n, n2, "square grid");
    let h = n / 2;
    // ifftshift: G[m] -> H[(m - h) mod n]
    let mut buf = vec![Complex64::new(0.0, 0.0); n * n];
    for r in 0..n {
        for c in 0..n {
            buf[((r + n - h) % n) * n + (c + n - h) % n] = g[[r, c]];
        }
    }
    let mut planner = FftPlanner::<f64>::new();
    let fft = planner.plan_fft_inverse(n);
    fft.process(&mut buf); // all rows
                           // transpose, rows again (= columns), transpose back
    let mut t = vec![Complex64::new(0.0, 0.0); n * n];
    for r in 0..n {
        for c in 0..n {
            t[c * n + r] = buf[r * n + c];
        }
    }
    fft.process(&mut t);
    let inv = 1.0 / norm;
    Array2::from_shape_fn((n, n), |(p, q)| {
        // fftshift: out[p] = F[(p - h) mod n]; t is transposed [col][row]
        t[((q + n - h) % n) * n + (p + n - h) % n] * inv
    })
}

/// Polar-format image: interpolation onto the Cartesian k-grid
/// ([`polar_to_cartesian`]), window, centred 2-D inverse FFT
/// ([`centred_ifft2`]). Returns a `[size, size]` complex image, rows = `y`,
/// columns = `x` (see the module docs for pixel positions and scaling).
pub fn try_image(
    e: ArrayView2<Complex64>,
    m: &Measurement,
    opts: &ImagingOptions,
) -> Result<Array2<Complex64>, IsarError> {
    let g = polar_to_cartesian(e, m, opts)?;
    Ok(centred_ifft2(&g.data, g.norm))
}

/// Infallible wrapper of [`try_image`] with the signature of the spec.
///
/// # Panics
/// If the measurement, the options or the data shape are invalid (use
/// [`try_image`] to get an error instead).
pub fn image(
    e: ArrayView2<Complex64>,
    m: &Measurement,
    opts: &ImagingOptions,
) -> Array2<Complex64> {
    try_image(e, m, opts).unwrap_or_else(|err| panic!("isar::image: {err}"))
}

/// Frequencies per block of the recurrence in [`point_response`]. Fixed (not
/// derived from the thread count) so results are bitwise independent of it.
const F_BLOCK: usize = 32;

/// Far-field monostatic response of point scatterers (amplitudes `a_k`,
/// positions `r_k` in metres) for every `(f, phi)` of `m`: returns
/// `E[i, j] = sum_k a_k exp(-j 2 (2 pi f_i / c) (x_k cos phi_j + y_k sin phi_j))`
/// as an `[n_f, n_phi]` array.
///
/// Exact sum over all scatterers (no FFT or far-field expansion). Parallel
/// over blocks of 32 frequencies (rayon); within a block the phase factor
/// is advanced by exact complex multiplication when the frequencies are
/// uniformly spaced (recomputed directly at the start of each block, so the
/// rounding error stays ~1e-14), and computed directly otherwise. The block
/// layout and summation order do not depend on the number of threads.
pub fn point_response(points: &[(Complex64, [f64; 3])], m: &Measurement) -> Array2<Complex64> {
    point_response_with(points, m, |block, chunk| {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU supports AVX-512F, checked just above.
                return unsafe { block.fill_avx512(chunk) };
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2, checked just above.
                return unsafe { block.fill_avx2(chunk) };
            }
        }
        block.fill::<AZ_LANES>(chunk)
    })
}

/// [`point_response`] with each block summed by `fill` (the tests pass each lane count).
fn point_response_with(
    points: &[(Complex64, [f64; 3])],
    m: &Measurement,
    fill: impl Fn(&ResponseBlock, &mut [Complex64]) + Sync,
) -> Array2<Complex64> {
    let (nf, np) = (m.n_f(), m.n_phi());
    let mut out = Array2::<Complex64>::zeros((nf, np));
    if nf == 0 || np == 0 {
        return out;
    }
    let (cs, k2, uniform) = response_geometry(m);
    // The steps of the uniform recurrence are the same in every block: computed once.
    let dk2 = if nf >= 2 { k2[1] - k2[0] } else { 0.0 };
    let mut steps = vec![Complex64::new(0.0, 0.0); if uniform { points.len() * np } else { 0 }];
    steps.par_chunks_mut(np).zip(points).for_each_init(
        || Phases::new(np),
        |ph, (steps, (_, r))| {
            for (x, &(c, s)) in ph.x.iter_mut().zip(&cs) {
                *x = -dk2 * (r[0] * c + r[1] * s);
            }
            ph.eval();
            for (st, (&c, &s)) in steps.iter_mut().zip(ph.cos.iter().zip(&ph.sin)) {
                *st = Complex64::new(c, s);
            }
        },
    );
    let slice = out.as_slice_mut().expect("standard layout");
    slice
        .par_chunks_mut(F_BLOCK * np)
        .enumerate()
        .for_each(|(b, chunk)| {
            let block = ResponseBlock {
                points,
                cs: &cs,
                k2: &k2,
                i0: b * F_BLOCK,
                steps: uniform.then_some(&steps[..]),
            };
            fill(&block, chunk)
        });
    out
}

/// What [`point_response`] needs of the measurement: each azimuth's `(cos, sin)`, each
/// frequency's two-way wavenumber `4 pi f / c`, and whether the frequencies are uniformly spaced
/// (to 1e-12 of the largest wavenumber), which allows the phase recurrence.
fn response_geometry(m: &Measurement) -> (Vec<(f64, f64)>, Vec<f64>, bool) {
    let cs: Vec<(f64, f64)> = m.azimuths.iter().map(|p| (p.cos(), p.sin())).collect();
    let k2: Vec<f64> = m
        .freqs
        .iter()
        .map(|f| 4.0 * std::f64::consts::PI * f / C0)
        .collect();
    let nf = k2.len();
    let uniform = nf >= 2 && {
        let d = k2[1] - k2[0];
        k2.windows(2)
            .all(|w| ((w[1] - w[0]) - d).abs() <= 1e-12 * k2[nf - 1].abs())
    };
    (cs, k2, uniform)
}

/// One block of up to [`F_BLOCK`] frequencies of [`point_response`]: every scatterer's
/// contribution at every azimuth, added in scatterer order. With uniform frequencies each
/// (scatterer, azimuth) pair starts its phase factor directly at the block's first frequency
/// and advances it by one exact complex multiplication per frequency; the azimuths' recurrences
/// are independent, so they run side by side in vector lanes (real and imaginary parts in
/// separate rows), each with the operations of `Complex64`'s `+=` and `*=` in their order, so
/// the result is the same bits as one recurrence after another (tested against that form).
struct ResponseBlock<'a> {
    points: &'a [(Complex64, [f64; 3])],
    cs: &'a [(f64, f64)],
    k2: &'a [f64],
    i0: usize,
    /// With uniform frequencies, each scatterer's phase step at each azimuth (`[point][azimuth]`).
    steps: Option<&'a [Complex64]>,
}

/// Azimuths advanced together in the uniform recurrence with AVX-512: four registers per
/// row, so that four independent multiply-add chains hide each step's latency.
const AZ_LANES_512: usize = 32;
/// The same with AVX2 or less: its 16 registers hold the phases and steps of 8 lanes.
const AZ_LANES: usize = 8;

impl ResponseBlock<'_> {
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn fill_avx512(&self, chunk: &mut [Complex64]) {
        self.fill::<AZ_LANES_512>(chunk)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn fill_avx2(&self, chunk: &mut [Complex64]) {
        self.fill::<AZ_LANES>(chunk)
    }

    /// Sums the block into `chunk` (`[frequency][azimuth]`, its `nb x n_phi` values).
    #[inline(always)]
    fn fill<const L: usize>(&self, chunk: &mut [Complex64]) {
        let np = self.cs.len();
        let nb = chunk.len() / np;
        let (k2, i0) = (self.k2, self.i0);
        // `[frequency][azimuth]` sums, real and imaginary parts apart.
        let mut re = vec![0.0f64; nb * np];
        let mut im = vec![0.0f64; nb * np];
        let mut u = vec![0.0; np];
        let mut start = vec![Complex64::new(0.0, 0.0); np];
        let mut ph = Phases::new(np);
        for (p, (a, r)) in self.points.iter().enumerate() {
            for (u, &(c, s)) in u.iter_mut().zip(self.cs) {
                *u = r[0] * c + r[1] * s;
            }
            let Some(steps) = self.steps else {
                for ii in 0..nb {
                    let k = k2[i0 + ii];
                    for (x, &u) in ph.x.iter_mut().zip(&u) {
                        *x = -k * u;
                    }
                    ph.eval();
                    for j in 0..np {
                        let v = *a * Complex64::new(ph.cos[j], ph.sin[j]);
                        re[ii * np + j] += v.re;
                        im[ii * np + j] += v.im;
                    }
                }
                continue;
            };
            let step = &steps[p * np..(p + 1) * np];
            for (x, &u) in ph.x.iter_mut().zip(&u) {
                *x = -k2[i0] * u;
            }
            ph.eval();
            for (st, (&c, &s)) in start.iter_mut().zip(ph.cos.iter().zip(&ph.sin)) {
                *st = *a * Complex64::new(c, s);
            }
            // Whole groups of `L` azimuths, then the last ones one lane at a time.
            let whole = np / L * L;
            for j0 in (0..whole).step_by(L) {
                advance::<L>(
                    &start[j0..],
                    &step[j0..],
                    &mut re[j0..],
                    &mut im[j0..],
                    np,
                    nb,
                );
            }
            for j in whole..np {
                advance::<1>(&start[j..], &step[j..], &mut re[j..], &mut im[j..], np, nb);
            }
        }
        for (v, (&r, &i)) in chunk.iter_mut().zip(re.iter().zip(&im)) {
            *v = Complex64::new(r, i);
        }
    }
}

/// Phases and their sines and cosines ([`crate::physics::trig::sincos_slice`]: the same bits
/// as `trig::sincos` one by one), buffers reused for every scatterer.
struct Phases {
    x: Vec<f64>,
    sin: Vec<f64>,
    cos: Vec<f64>,
}

impl Phases {
    fn new(n: usize) -> Self {
        Phases {
            x: vec![0.0; n],
            sin: vec![0.0; n],
            cos: vec![0.0; n],
        }
    }

    /// `sin`, `cos` of every phase in `x`.
    fn eval(&mut self) {
        crate::physics::trig::sincos_slice(&self.x, &mut self.sin, &mut self.cos);
    }
}

/// `L` azimuths' recurrences over `nb` frequencies: row `ii` (stride `np`) of `re`/`im` gains
/// the phase factor, which then advances by its step (`Complex64`'s `*=`: `re = re c - im d`,
/// `im = im c + re d`).
#[inline(always)]
fn advance<const L: usize>(
    start: &[Complex64],
    step: &[Complex64],
    re: &mut [f64],
    im: &mut [f64],
    np: usize,
    nb: usize,
) {
    let mut pr: [f64; L] = std::array::from_fn(|l| start[l].re);
    let mut pi: [f64; L] = std::array::from_fn(|l| start[l].im);
    let sr: [f64; L] = std::array::from_fn(|l| step[l].re);
    let si: [f64; L] = std::array::from_fn(|l| step[l].im);
    for ii in 0..nb {
        let (rr, ri) = (&mut re[ii * np..][..L], &mut im[ii * np..][..L]);
        for l in 0..L {
            rr[l] += pr[l];
            ri[l] += pi[l];
            let a = pr[l];
            pr[l] = pr[l] * sr[l] - pi[l] * si[l];
            pi[l] = pi[l] * sr[l] + a * si[l];
        }
    }
}

#[cfg(test)]
mod tests;
