//! Seeds and random streams, the one module every layer may use: seeds derived from the master
//! seed and a job's canonical identity (never its position), and the ChaCha20 streams that
//! white noise and textures are drawn from, so that any sample can be regenerated alone and no
//! result depends on the thread count.

use ndarray::Array2;
use num_complex::Complex64;
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};
use sha2::{Digest, Sha256};

pub mod normal;

/// Derives a 64-bit seed from the master seed, a domain and a canonical identity
/// (first 8 bytes, little endian, of SHA-256 over `isar-clutter/v1/<domain>/<master>/<identity>`).
pub fn derive_seed(master: u64, domain: &str, identity: &str) -> u64 {
    let digest = Sha256::digest(format!("isar-clutter/v1/{domain}/{master}/{identity}").as_bytes());
    u64::from_le_bytes(digest[..8].try_into().expect("8 bytes"))
}

/// Hex SHA-256 of bytes.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// Draws the padded white seed of sample `index` from the data seed: ChaCha20 seeded with
/// `data_seed` on stream `index`, complex circular (`E|z|^2 = 1`, parts `N(0, 1/2)`).
pub fn white_seed(data_seed: u64, index: usize, rows: usize, cols: usize) -> Array2<Complex64> {
    let mut rng = ChaCha20Rng::seed_from_u64(data_seed);
    rng.set_stream(index as u64);
    let scale = std::f64::consts::FRAC_1_SQRT_2;
    Array2::from_shape_simple_fn((rows, cols), || {
        let re: f64 = StandardNormal.sample(&mut rng);
        let im: f64 = StandardNormal.sample(&mut rng);
        Complex64::new(re * scale, im * scale)
    })
}

/// First stream of the texture draws: sample `s` uses stream `TEXTURE_STREAM + s`, far from
/// the seeds' streams `0..N`.
const TEXTURE_STREAM: u64 = 1 << 40;

/// The gamma texture `tau ~ Gamma(nu, 1/nu)` (mean 1, variance `1/nu`) of sample `index`.
pub fn texture(data_seed: u64, index: usize, nu: f64) -> f64 {
    let mut rng = ChaCha20Rng::seed_from_u64(data_seed);
    rng.set_stream(TEXTURE_STREAM + index as u64);
    rand_distr::Gamma::new(nu, 1.0 / nu)
        .expect("validated shape")
        .sample(&mut rng)
}
