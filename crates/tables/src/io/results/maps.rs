//! The `.npy` maps a job writes under `maps/<job>/`, named once for the runner that writes them
//! and the report that draws them.

/// The per-pixel sample mean (complex).
pub const MEAN: &str = "mean";
/// The per-pixel variance.
pub const VARIANCE: &str = "variance";
/// The prefix of a noise floor's comparison maps (the metric between two independent
/// draws of the same data).
pub const NOISE_FLOOR: &str = "noise_floor_";
/// The prefix of a synthetic model's exact expected maps.
pub const EXPECTED: &str = "expected_";
/// The components a comparison map is computed on.
pub const COMPONENTS: [&str; 2] = ["re", "im"];

/// `<prefix>level<level>_<kind>_<direction>`: a level's directional map, `kind` the
/// column it holds ([`super::col::CORRELATION`] or [`super::col::COVARIANCE`]), `prefix`
/// empty or [`EXPECTED`].
pub fn level(prefix: &str, level: usize, kind: &str, direction: impl std::fmt::Display) -> String {
    format!("{prefix}level{level}_{kind}_{direction}")
}

/// `<prefix><stem>`: a comparison map of a metric (`stem` its metric's
/// `crate::stats::metrics::map_stem`), `prefix` empty or [`NOISE_FLOOR`].
pub fn comparison(prefix: &str, stem: &str) -> String {
    format!("{prefix}{stem}")
}

/// The file of map `name` in a job's maps folder `dir`.
pub fn file(dir: &std::path::Path, name: &str) -> std::path::PathBuf {
    dir.join(format!("{name}.npy"))
}
