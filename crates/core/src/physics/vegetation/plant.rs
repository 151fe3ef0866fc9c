//! One plant in the wind: its geometry (stems, branches and leaves as point scatterers, fixed
//! by the seed), the wind's gusts and the damped oscillators that move it, and the scatterers
//! of one pose.

use super::params::{PlantParams, WindParams};
use num_complex::Complex64;
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
type V3 = [f64; 3];

fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}
fn unit(a: V3) -> V3 {
    scale(a, 1.0 / norm(a))
}
/// Rodrigues rotation of `v` about the unit axis `k` by `th`.
fn rotate(v: V3, k: V3, th: f64) -> V3 {
    let (s, c) = th.sin_cos();
    add(
        add(scale(v, c), scale(cross(k, v), s)),
        scale(k, dot(k, v) * (1.0 - c)),
    )
}

/// A structural point scatterer (stem or branch).
#[derive(Clone, Debug)]
struct StructPoint {
    pub(super) pos: V3,
    amp: f64,
    stem: usize,
    /// height fraction along the stem of the point (or of the branch root)
    pub(super) s: f64,
    /// branch index and fraction along it, if on a branch
    branch: Option<(usize, f64)>,
}

#[derive(Clone, Debug)]
pub(super) struct Leaf {
    centre: V3,
    axis: V3,
    side: V3,
    pub(super) normal: V3,
    area: f64,
    pub(super) size: f64,
    /// in-plane offsets (along axis, along side) of the cluster points
    offsets: Vec<(f64, f64)>,
    stem: usize,
    pub(super) s: f64,
    branch: usize,
    pub(super) t: f64,
    /// nearest structural point for double bounce
    db_partner: Option<usize>,
}

/// Static plant geometry built from the seed.
#[derive(Clone, Debug)]
pub(super) struct Plant {
    points: Vec<StructPoint>,
    pub(super) leaves: Vec<Leaf>,
    pub(super) n_branches: usize,
    pub(super) background: Vec<(Complex64, V3)>,
}

pub(super) fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

/// A plant's scatterers (stem, branches, leaves) drawn from its parameters.
///
/// Long because the parts are placed in one pass over the same random stream: split, the order of
/// the draws (and so every plant) would have to be kept by hand.
pub(super) fn build_plant(p: &PlantParams, rng: &mut ChaCha8Rng) -> Plant {
    let tau = 2.0 * std::f64::consts::PI;
    let mut points = vec![];
    let mut leaves = vec![];
    let mut n_branches = 0;
    let z = [0.0, 0.0, 1.0];
    for st in 0..p.n_stems {
        let a0 = tau * st as f64 / p.n_stems as f64 + 0.3 * rng.random::<f64>();
        let base = [p.base_radius_m * a0.cos(), p.base_radius_m * a0.sin(), 0.0];
        let lean = p.stem_lean_rad * rng.random::<f64>();
        let lean_az = tau * rng.random::<f64>();
        let dir = [
            lean.sin() * lean_az.cos(),
            lean.sin() * lean_az.sin(),
            lean.cos(),
        ];
        let n_pts = (p.stem_height_m / p.scatterer_spacing_m).ceil().max(1.0) as usize;
        let step_sd = p.stem_crookedness_m / (n_pts as f64).sqrt();
        let mut wiggle = [0.0f64; 3];
        let mut wiggles = Vec::with_capacity(n_pts + 1);
        for i in 0..=n_pts {
            let s = i as f64 / n_pts as f64;
            if i > 0 {
                wiggle[0] += step_sd * normal(rng);
                wiggle[1] += step_sd * normal(rng);
            }
            wiggles.push(wiggle);
            points.push(StructPoint {
                pos: add(add(base, scale(dir, s * p.stem_height_m)), wiggle),
                amp: p.stem_amplitude,
                stem: st,
                s,
                branch: None,
            });
        }
        for b in 0..p.branches_per_stem {
            let s = p.branch_start_frac
                + (1.0 - p.branch_start_frac) * (b as f64 + rng.random::<f64>())
                    / p.branches_per_stem as f64;
            let wi = wiggles[((s * n_pts as f64).round() as usize).min(n_pts)];
            let root = add(add(base, scale(dir, s * p.stem_height_m)), wi);
            let az = tau * rng.random::<f64>();
            let el = p.branch_elevation_rad * (0.7 + 0.6 * rng.random::<f64>());
            let bdir = [el.cos() * az.cos(), el.cos() * az.sin(), el.sin()];
            let bi = n_branches;
            n_branches += 1;
            let nb = (p.branch_length_m / p.scatterer_spacing_m).ceil() as usize;
            for i in 1..=nb {
                let t = i as f64 / nb as f64;
                points.push(StructPoint {
                    pos: add(root, scale(bdir, t * p.branch_length_m)),
                    amp: p.branch_amplitude,
                    stem: st,
                    s,
                    branch: Some((bi, t)),
                });
            }
            for l in 0..p.leaves_per_branch {
                let dist = (p.branch_length_m - l as f64 * p.leaf_spacing_m).max(0.0);
                let t = if p.branch_length_m > 0.0 {
                    dist / p.branch_length_m
                } else {
                    0.0
                };
                let attach = add(root, scale(bdir, dist));
                let size = p.leaf_size_m * (p.leaf_size_spread * normal(rng)).exp();
                // leaf normal: tilted from vertical, random azimuth
                let tilt = p.leaf_max_tilt_rad * rng.random::<f64>();
                let naz = tau * rng.random::<f64>();
                let n = [tilt.sin() * naz.cos(), tilt.sin() * naz.sin(), tilt.cos()];
                // leaf axis: branch direction projected onto the leaf plane
                let mut ax = add(bdir, scale(n, -dot(bdir, n)));
                if norm(ax) < 1e-6 {
                    ax = cross(n, z);
                    if norm(ax) < 1e-6 {
                        ax = [1.0, 0.0, 0.0];
                    }
                }
                let ax = unit(ax);
                let side = cross(n, ax);
                let offsets = (0..p.leaf_points)
                    .map(|_| {
                        (
                            size * (rng.random::<f64>() - 0.5),
                            0.6 * size * (rng.random::<f64>() - 0.5),
                        )
                    })
                    .collect();
                leaves.push(Leaf {
                    centre: add(attach, scale(ax, 0.5 * size)),
                    axis: ax,
                    side,
                    normal: n,
                    area: 0.5 * size * size,
                    size,
                    offsets,
                    stem: st,
                    s,
                    branch: bi,
                    t,
                    db_partner: None,
                });
            }
        }
    }
    if p.double_bounce {
        for leaf in leaves.iter_mut() {
            let mut best: Option<(usize, f64)> = None;
            for (i, sp) in points.iter().enumerate() {
                let d = norm(add(sp.pos, scale(leaf.centre, -1.0)));
                if d < p.double_bounce_max_dist_m && best.is_none_or(|(_, bd)| d < bd) {
                    best = Some((i, d));
                }
            }
            leaf.db_partner = best.map(|(i, _)| i);
        }
    }
    // background residual: 32 fixed random points (power scaled later)
    let background = (0..32)
        .map(|_| {
            let r = 0.25 * rng.random::<f64>().sqrt();
            let a = tau * rng.random::<f64>();
            let amp = Complex64::new(normal(rng), normal(rng));
            (amp, [r * a.cos(), r * a.sin(), 0.0])
        })
        .collect();
    Plant {
        points,
        leaves,
        n_branches,
        background,
    }
}

/// Dynamic wind state: gusts, stem and branch oscillators, leaf flutter.
struct WindState {
    g_shared: [f64; 2],
    g_stem: Vec<[f64; 2]>,
    stem_x: Vec<[f64; 2]>,
    stem_v: Vec<[f64; 2]>,
    br_x: Vec<[f64; 2]>,
    br_v: Vec<[f64; 2]>,
    /// per leaf: two angles (rad) and a 2-D translation (m)
    pub(super) leaf: Vec<[f64; 4]>,
}

/// Positions/orientation deviations of one sample.
pub(super) struct Pose {
    pub(super) stem_d: Vec<[f64; 2]>,
    pub(super) br_d: Vec<[f64; 2]>,
    pub(super) leaf: Vec<[f64; 4]>,
}

pub(super) struct WindSim<'a> {
    pub(super) p: &'a PlantParams,
    pub(super) w: &'a WindParams,
    st: WindState,
    leaf_sigma: Vec<[f64; 2]>,
    stem_of_branch: Vec<usize>,
}

impl<'a> WindSim<'a> {
    pub(super) fn new(
        p: &'a PlantParams,
        w: &'a WindParams,
        plant: &Plant,
        rng: &mut ChaCha8Rng,
    ) -> Self {
        let ns = p.n_stems;
        let nb = plant.n_branches;
        let u = w.speed_mps;
        let leaf_sigma: Vec<[f64; 2]> = plant
            .leaves
            .iter()
            .map(|l| {
                let ang = (p.leaf_flutter_scale * u * l.size / 0.1).min(1.0);
                [ang, 0.3 * l.size * ang]
            })
            .collect();
        let mut stem_of_branch = vec![0; nb];
        for sp in &plant.points {
            if let Some((b, _)) = sp.branch {
                stem_of_branch[b] = sp.stem;
            }
        }
        for l in &plant.leaves {
            stem_of_branch[l.branch] = l.stem;
        }
        // leaf flutter starts in its stationary distribution
        let leaf = leaf_sigma
            .iter()
            .map(|s| {
                [
                    s[0] * normal(rng),
                    s[0] * normal(rng),
                    s[1] * normal(rng),
                    s[1] * normal(rng),
                ]
            })
            .collect();
        let sg = w.turbulence_intensity * u;
        let shared = w.gust_coherence.sqrt() * sg;
        let local = (1.0 - w.gust_coherence).sqrt() * sg;
        let mut s = WindSim {
            p,
            w,
            st: WindState {
                g_shared: [shared * normal(rng), 0.7 * shared * normal(rng)],
                g_stem: (0..ns)
                    .map(|_| [local * normal(rng), 0.7 * local * normal(rng)])
                    .collect(),
                stem_x: vec![[0.0; 2]; ns],
                stem_v: vec![[0.0; 2]; ns],
                br_x: vec![[0.0; 2]; nb],
                br_v: vec![[0.0; 2]; nb],
                leaf,
            },
            leaf_sigma,
            stem_of_branch,
        };
        // burn-in so the oscillators reach their stationary regime
        let t_osc = 1.0 / (p.sway_damping * 2.0 * std::f64::consts::PI * p.stem_sway_freq_hz);
        let burn = 5.0 * w.gust_time_constant_s.max(t_osc);
        s.advance(burn.min(600.0), rng);
        s
    }

    /// Advances the whole wind state by `dt_total` seconds.
    pub(super) fn advance(&mut self, dt_total: f64, rng: &mut ChaCha8Rng) {
        let (p, w) = (self.p, self.w);
        let u = w.speed_mps;
        let tau = w.gust_time_constant_s;
        let sg = w.turbulence_intensity * u;
        let shared = w.gust_coherence.sqrt() * sg;
        let local = (1.0 - w.gust_coherence).sqrt() * sg;
        let f_max = p.stem_sway_freq_hz.max(p.branch_sway_freq_hz);
        let n_sub = ((dt_total * 40.0 * f_max).ceil() as usize).max(1);
        let dt = dt_total / n_sub as f64;
        let rho = (-dt / tau).exp();
        let q = (1.0 - rho * rho).sqrt();
        let ws = 2.0 * std::f64::consts::PI * p.stem_sway_freq_hz;
        let wb = 2.0 * std::f64::consts::PI * p.branch_sway_freq_hz;
        let (sd, cd) = w.direction_rad.sin_cos();
        let st = &mut self.st;
        for _ in 0..n_sub {
            st.g_shared[0] = rho * st.g_shared[0] + q * shared * normal(rng);
            st.g_shared[1] = rho * st.g_shared[1] + q * 0.7 * shared * normal(rng);
            for g in st.g_stem.iter_mut() {
                g[0] = rho * g[0] + q * local * normal(rng);
                g[1] = rho * g[1] + q * 0.7 * local * normal(rng);
            }
            // load in the xy frame from the along/cross-wind gusts
            let load = |g: [f64; 2], flex: f64| -> [f64; 2] {
                let a = w.deflection_gain * flex * u * 2.0 * g[0];
                let c = w.deflection_gain * flex * u * g[1];
                [a * cd - c * sd, a * sd + c * cd]
            };
            let step = |x: &mut [f64; 2], v: &mut [f64; 2], f: [f64; 2], om: f64| {
                for k in 0..2 {
                    let acc = om * om * (f[k] - x[k]) - 2.0 * p.sway_damping * om * v[k];
                    v[k] += dt * acc;
                    x[k] += dt * v[k];
                }
            };
            for i in 0..st.stem_x.len() {
                let g = [
                    st.g_shared[0] + st.g_stem[i][0],
                    st.g_shared[1] + st.g_stem[i][1],
                ];
                let f = load(g, p.stem_flexibility);
                step(&mut st.stem_x[i], &mut st.stem_v[i], f, ws);
            }
            for b in 0..st.br_x.len() {
                let i = self.stem_of_branch[b];
                let g = [
                    st.g_shared[0] + st.g_stem[i][0],
                    st.g_shared[1] + st.g_stem[i][1],
                ];
                let f = load(g, p.branch_flexibility);
                step(&mut st.br_x[b], &mut st.br_v[b], f, wb);
            }
        }
        // leaf flutter: exact OU transition over the whole interval
        let tl = 1.0 / (2.0 * std::f64::consts::PI * p.leaf_flutter_freq_hz);
        let r = (-dt_total / tl).exp();
        let qq = (1.0 - r * r).sqrt();
        for (l, s) in st.leaf.iter_mut().zip(&self.leaf_sigma) {
            for (k, v) in l.iter_mut().enumerate() {
                let sig = if k < 2 { s[0] } else { s[1] };
                *v = r * *v + qq * sig * normal(rng);
            }
        }
    }

    /// Current deviations (steady deflection included).
    pub(super) fn pose(&self) -> Pose {
        let (p, w) = (self.p, self.w);
        let u2 = w.speed_mps * w.speed_mps;
        let (sd, cd) = w.direction_rad.sin_cos();
        let steady = |flex: f64| {
            let d = w.deflection_gain * flex * u2;
            [d * cd, d * sd]
        };
        let s0 = steady(p.stem_flexibility);
        let b0 = steady(p.branch_flexibility);
        Pose {
            stem_d: self
                .st
                .stem_x
                .iter()
                .map(|x| [s0[0] + x[0], s0[1] + x[1]])
                .collect(),
            br_d: self
                .st
                .br_x
                .iter()
                .map(|x| [b0[0] + x[0], b0[1] + x[1]])
                .collect(),
            leaf: self.st.leaf.clone(),
        }
    }
}

/// Scatterers of the plant in a given pose: `(amplitude, position)`.
pub(super) fn scatterers(p: &PlantParams, plant: &Plant, pose: &Pose) -> Vec<(Complex64, V3)> {
    let disp = |stem: usize, s: f64, br: Option<(usize, f64)>| -> V3 {
        let d = pose.stem_d[stem];
        let mut v = [d[0] * s * s, d[1] * s * s, 0.0];
        if let Some((b, t)) = br {
            let e = pose.br_d[b];
            v[0] += e[0] * t * t;
            v[1] += e[1] * t * t;
        }
        v
    };
    let mut out = Vec::with_capacity(plant.points.len() + plant.leaves.len() * p.leaf_points);
    let struct_pos: Vec<V3> = plant
        .points
        .iter()
        .map(|sp| add(sp.pos, disp(sp.stem, sp.s, sp.branch)))
        .collect();
    for (sp, pos) in plant.points.iter().zip(&struct_pos) {
        if sp.amp != 0.0 {
            out.push((Complex64::new(sp.amp, 0.0), *pos));
        }
    }
    let rhat0 = [1.0, 0.0, 0.0];
    for (li, leaf) in plant.leaves.iter().enumerate() {
        let f = pose.leaf[li];
        // flutter: rotate about the leaf axis then about the side vector
        let n1 = rotate(leaf.normal, leaf.axis, f[0]);
        let side1 = rotate(leaf.side, leaf.axis, f[0]);
        let n2 = rotate(n1, side1, f[1]);
        let ax2 = rotate(leaf.axis, side1, f[1]);
        let centre = add(
            add(
                leaf.centre,
                disp(leaf.stem, leaf.s, Some((leaf.branch, leaf.t))),
            ),
            [f[2], f[3], 0.0],
        );
        let inc = dot(n2, rhat0).abs();
        let a_leaf =
            p.leaf_gain * leaf.area * (p.leaf_diffuse_floor + (1.0 - p.leaf_diffuse_floor) * inc);
        let a_pt = a_leaf / leaf.offsets.len() as f64;
        for &(da, ds) in &leaf.offsets {
            let pos = add(centre, add(scale(ax2, da), scale(side1, ds)));
            out.push((Complex64::new(a_pt, 0.0), pos));
        }
        if let Some(j) = leaf.db_partner {
            let r2 = struct_pos[j];
            let d = norm(add(centre, scale(r2, -1.0)));
            let mid = scale(add(centre, r2), 0.5);
            let amp = p.double_bounce_strength * (a_leaf * plant.points[j].amp).abs().sqrt();
            out.push((Complex64::new(amp, 0.0), add(mid, [0.5 * d, 0.0, 0.0])));
        }
    }
    out
}
