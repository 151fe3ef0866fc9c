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
    hex(&Sha256::digest(bytes))
}

/// Lower-case hex of a digest.
pub(crate) fn hex(digest: &[u8]) -> String {
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// [`sha256_hex`] of everything `r` yields, read 1 MiB at a time (a table of gigabytes is
/// hashed in bounded memory).
///
/// # Errors
/// If reading fails.
pub fn sha256_hex_of(mut r: impl std::io::Read) -> std::io::Result<String> {
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        match r.read(&mut buf)? {
            0 => break,
            n => hasher.update(&buf[..n]),
        }
    }
    Ok(hex(&hasher.finalize()))
}

/// Draws the padded white seed of sample `index` from the data seed: ChaCha20 seeded with
/// `data_seed` on stream `index`, complex circular (`E|z|^2 = 1`, parts `N(0, 1/2)`), each
/// part a `rand_distr` standard normal (real part first). Sample format 1.
pub fn white_seed(data_seed: u64, index: usize, rows: usize, cols: usize) -> Array2<Complex64> {
    let mut out = Array2::zeros((rows, cols));
    white_seed_into(
        data_seed,
        index,
        out.as_slice_mut().expect("standard layout"),
    );
    out
}

/// [`white_seed`] into `out` (row-major, any length): the same values, drawn from the same
/// ChaCha20 words, which come 16 blocks at a time from an AVX-512 kernel where the CPU has one
/// ([`Chacha20Words`]) and from `rand_chacha` elsewhere.
pub fn white_seed_into(data_seed: u64, index: usize, out: &mut [Complex64]) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            return draw_white(&mut Chacha20Words::new(data_seed, index as u64), out);
        }
    }
    let mut rng = ChaCha20Rng::seed_from_u64(data_seed);
    rng.set_stream(index as u64);
    draw_white(&mut rng, out)
}

fn draw_white<R: rand::Rng>(rng: &mut R, out: &mut [Complex64]) {
    let scale = std::f64::consts::FRAC_1_SQRT_2;
    for z in out {
        let re: f64 = StandardNormal.sample(rng);
        let im: f64 = StandardNormal.sample(rng);
        *z = Complex64::new(re * scale, im * scale);
    }
}

/// The words of ChaCha20 stream `stream` seeded with `seed` (`seed_from_u64`), exactly those of
/// `rand_chacha`'s `ChaCha20Rng`, generated 16 blocks (256 words) at a time by an AVX-512 kernel.
/// A `u64` is two consecutive words, low first, as `ChaCha20Rng::next_u64` forms it from a
/// stream read only in `u64`s (all that [`white_seed`]'s draws read). Only made where the CPU
/// has AVX-512F.
#[cfg(target_arch = "x86_64")]
struct Chacha20Words {
    key: [u32; 8],
    stream: u64,
    next_block: u64,
    buf: [u32; 256],
    pos: usize,
}

#[cfg(target_arch = "x86_64")]
impl Chacha20Words {
    fn new(seed: u64, stream: u64) -> Chacha20Words {
        Chacha20Words {
            key: normal::key_words(&ChaCha20Rng::seed_from_u64(seed).get_seed()),
            stream,
            next_block: 0,
            buf: [0; 256],
            pos: 256,
        }
    }

    #[cold]
    fn refill(&mut self) {
        assert!(std::arch::is_x86_feature_detected!("avx512f"));
        // SAFETY: the CPU has AVX-512F, asserted just above; the buffer holds 16 blocks.
        unsafe {
            normal::chacha_avx512::<10>(&self.key, self.stream, self.next_block, &mut self.buf)
        };
        self.next_block += 16;
        self.pos = 0;
    }
}

#[cfg(target_arch = "x86_64")]
impl rand::TryRng for Chacha20Words {
    type Error = std::convert::Infallible;

    fn try_next_u32(&mut self) -> Result<u32, Self::Error> {
        if self.pos == self.buf.len() {
            self.refill();
        }
        self.pos += 1;
        Ok(self.buf[self.pos - 1])
    }

    #[inline]
    fn try_next_u64(&mut self) -> Result<u64, Self::Error> {
        // A pair that straddles a refill (after an odd number of `u32` reads; `white_seed`
        // reads only `u64`s) is read word by word, low word first, as `rand_core` does.
        if self.pos + 1 >= self.buf.len() {
            let lo = u64::from(self.try_next_u32()?);
            let hi = u64::from(self.try_next_u32()?);
            return Ok(hi << 32 | lo);
        }
        let (lo, hi) = (self.buf[self.pos], self.buf[self.pos + 1]);
        self.pos += 2;
        Ok(u64::from(hi) << 32 | u64::from(lo))
    }

    fn try_fill_bytes(&mut self, dst: &mut [u8]) -> Result<(), Self::Error> {
        for b in dst.chunks_mut(4) {
            let w = self.try_next_u32()?.to_le_bytes();
            b.copy_from_slice(&w[..b.len()]);
        }
        Ok(())
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The oracle: sample format 1 as first written, straight from `rand_chacha` and
    /// `rand_distr`.
    fn white_oracle(data_seed: u64, index: usize, n: usize) -> Vec<Complex64> {
        let mut rng = ChaCha20Rng::seed_from_u64(data_seed);
        rng.set_stream(index as u64);
        let scale = std::f64::consts::FRAC_1_SQRT_2;
        (0..n)
            .map(|_| {
                let re: f64 = StandardNormal.sample(&mut rng);
                let im: f64 = StandardNormal.sample(&mut rng);
                Complex64::new(re * scale, im * scale)
            })
            .collect()
    }

    #[test]
    fn white_seeds_are_the_format_1_values_bit_for_bit() {
        // 300,000 normals: about 1,200 of them in the ziggurat's base strip, so the tail and
        // rejection branches (which read extra words) are taken many times.
        for (seed, index, n) in [
            (1u64, 0usize, 1),
            (7, 3, 127),
            (20200403, 999, 6400),
            (u64::MAX, 1 << 20, 150_000),
        ] {
            let mut got = vec![Complex64::new(0.0, 0.0); n];
            white_seed_into(seed, index, &mut got);
            let want = white_oracle(seed, index, n);
            assert!(
                got.iter()
                    .zip(&want)
                    .all(|(a, b)| a.re.to_bits() == b.re.to_bits()
                        && a.im.to_bits() == b.im.to_bits()),
                "seed {seed}, stream {index}, {n} values"
            );
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn chacha20_words_are_rand_chachas_in_any_mix_of_reads() {
        use rand::Rng;
        if !std::arch::is_x86_feature_detected!("avx512f") {
            eprintln!("no AVX-512F here: the kernel is not used, so not tested");
            return;
        }
        let mut fast = Chacha20Words::new(42, 5);
        let mut slow = ChaCha20Rng::seed_from_u64(42);
        slow.set_stream(5);
        // An odd number of u32 reads puts u64 reads across buffer refills.
        for i in 0..5000 {
            if i % 7 == 3 {
                assert_eq!(fast.next_u32(), slow.next_u32(), "read {i}");
            } else {
                assert_eq!(fast.next_u64(), slow.next_u64(), "read {i}");
            }
        }
    }
}
