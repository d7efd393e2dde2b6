//! Random streams. Every image, and every purpose within an image, gets its own stream derived
//! from the campaign seed, so results never depend on thread count or on the order in which
//! images run (GalSim's rule).
//!
//! Two generators, by how many draws a purpose makes. The few decisive draws (which debris,
//! the scene and its retries, the split) come from ChaCha12. The millions of draws per image
//! (every photon, every pixel's noise) come from xoshiro256++, a fast generator that passes
//! BigCrush (Julia's default): ChaCha12 was 14% of a quickstart image's CPU, and the switch
//! took 12.6 ms of CPU off each (100 images, 1 thread: 6.96 s to 5.70 s of user time). Both
//! are seeded from SHA-256 of (seed, image, purpose), so the streams of any two purposes or
//! images are unrelated.

use rand::SeedableRng;
use rand_chacha::ChaCha12Rng;
use rand_distr::{Distribution, Poisson};
use rand_xoshiro::Xoshiro256PlusPlus;
use sha2::{Digest, Sha256};

/// A purpose of few, decisive draws; each has an independent ChaCha12 stream per image.
#[derive(Clone, Copy, Debug)]
#[repr(u64)]
pub enum Purpose {
    /// The scene draw and its retries.
    Scene = 1,
    /// The dataset split (image index unused).
    Split = 4,
    /// Which debris object an image shows, drawn once before the scene's retries.
    Debris = 6,
    /// Whether an image of a mixed campaign (`background.share` below 1) has a real frame under
    /// it, drawn once before the scene's retries.
    BackgroundKind = 12,
    /// How many objects an image of a campaign with `[objects]` shows (#34), drawn once.
    ObjectCount = 13,
    /// A placed object's own draws (`object_stream`): which debris and its draw, retried.
    ObjectScene = 15,
    /// A catalogue object's own draws (size, tumble: `scene::catalogue`), keyed by its NORAD
    /// number in place of the image, so an object keeps them in every image.
    CatalogueObject = 17,
    /// A breakup fragment's size, area-to-mass and ejection velocity (keyed by its index).
    BreakupFragment = 18,
    /// A ground site's scintillation of an object in one exposure (`object_stream`, keyed by
    /// the image and the object's place among those it shows).
    Scintillation = 19,
}

/// A purpose of draws per photon or per pixel; each has an independent [`PixelRng`] stream
/// per image. (The numbers continue `Purpose`'s: no two purposes share a seed.)
#[derive(Clone, Copy, Debug)]
#[repr(u64)]
pub enum PixelPurpose {
    /// Photon tracing (and the jitter path, drawn first).
    Photons = 2,
    /// Detector noise.
    Noise = 3,
    /// Enhancement (noise fill of padded areas).
    Enhance = 5,
    /// The physical noise model's components (`noise`), one stream each.
    Sky = 7,
    Dark = 8,
    ReadNoise = 9,
    /// Hot pixels: their charge per image; their positions from the sensor's own index.
    HotPixels = 10,
    CosmicRays = 11,
    /// A placed object's photons (`object_pixel_stream`).
    ObjectPhotons = 16,
}

/// The generator of per-photon and per-pixel streams.
pub type PixelRng = Xoshiro256PlusPlus;

/// SHA-256 of (seed, image, purpose number): the key of one stream.
fn key(seed: u64, image: u64, purpose: u64) -> [u8; 32] {
    let mut h = Sha256::new();
    h.update(b"soig-stream-v1");
    h.update(seed.to_le_bytes());
    h.update(image.to_le_bytes());
    h.update(purpose.to_le_bytes());
    h.finalize().into()
}

/// The key of one placed object's stream: SHA-256 of (seed, image, object, purpose) under its
/// own tag, so no object stream is ever an image stream.
fn object_key(seed: u64, image: u64, object: u64, purpose: u64) -> [u8; 32] {
    let mut h = Sha256::new();
    h.update(b"soig-object-stream-v1");
    h.update(seed.to_le_bytes());
    h.update(image.to_le_bytes());
    h.update(object.to_le_bytes());
    h.update(purpose.to_le_bytes());
    h.finalize().into()
}

/// The stream of object `object` (0-based) of image `image`, for one purpose: each object of a
/// frame draws from its own streams, so adding an object never changes the others.
pub fn object_stream(seed: u64, image: u64, object: u64, purpose: Purpose) -> ChaCha12Rng {
    ChaCha12Rng::from_seed(object_key(seed, image, object, purpose as u64))
}

/// The per-photon stream of object `object` of image `image`.
pub fn object_pixel_stream(seed: u64, image: u64, object: u64, purpose: PixelPurpose) -> PixelRng {
    PixelRng::from_seed(object_key(seed, image, object, purpose as u64))
}

/// The stream for (seed, image index, purpose).
pub fn stream(seed: u64, image: u64, purpose: Purpose) -> ChaCha12Rng {
    ChaCha12Rng::from_seed(key(seed, image, purpose as u64))
}

/// The per-photon or per-pixel stream for (seed, image index, purpose). (A key of all zeros,
/// xoshiro's one bad state, is replaced by the crate; SHA-256 does not give it in practice.)
pub fn pixel_stream(seed: u64, image: u64, purpose: PixelPurpose) -> PixelRng {
    PixelRng::from_seed(key(seed, image, purpose as u64))
}

/// A Poisson draw that accepts any mean: 0 for a zero, negative or NaN mean. From rand_distr's
/// limit of ~1.8e19 (about u64::MAX) up it returns the mean rounded, saturating at u64::MAX for
/// larger or infinite means (the relative Poisson spread there is below 1e-9; an infinitely
/// bright source saturates rather than vanishing).
pub fn poisson<R: rand::Rng + ?Sized>(rng: &mut R, mean: f64) -> u64 {
    if mean.is_nan() || mean <= 0.0 {
        return 0;
    }
    if mean >= Poisson::<f64>::MAX_LAMBDA {
        // `as` saturates: 1e25 and +inf give u64::MAX.
        return mean.round() as u64;
    }
    Poisson::new(mean).expect("mean checked").sample(rng) as u64
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::RngExt;

    #[test]
    fn streams_are_distinct_and_repeatable() {
        let a: u64 = stream(1, 2, Purpose::Scene).random();
        let b: u64 = stream(1, 2, Purpose::Scene).random();
        let c: u64 = stream(1, 3, Purpose::Scene).random();
        let d: u64 = stream(1, 2, Purpose::Split).random();
        let e: u64 = stream(2, 2, Purpose::Scene).random();
        assert_eq!(a, b);
        assert!(a != c && a != d && a != e && c != d);
        let f: u64 = pixel_stream(1, 2, PixelPurpose::Photons).random();
        let g: u64 = pixel_stream(1, 2, PixelPurpose::Photons).random();
        let h: u64 = pixel_stream(1, 2, PixelPurpose::Noise).random();
        let i: u64 = pixel_stream(1, 3, PixelPurpose::Photons).random();
        assert_eq!(f, g);
        assert!(f != h && f != i && h != i);
        let j: u64 = object_stream(1, 2, 0, Purpose::Scene).random();
        let k: u64 = object_stream(1, 2, 1, Purpose::Scene).random();
        let l: u64 = object_pixel_stream(1, 2, 0, PixelPurpose::Photons).random();
        assert_eq!(j, object_stream(1, 2, 0, Purpose::Scene).random::<u64>());
        assert!(j != k && j != a && l != f);
    }

    #[test]
    fn poisson_edges() {
        let mut r = pixel_stream(0, 0, PixelPurpose::Photons);
        assert_eq!(poisson(&mut r, 0.0), 0);
        assert_eq!(poisson(&mut r, -1.0), 0);
        assert_eq!(poisson(&mut r, f64::NAN), 0);
        assert_eq!(poisson(&mut r, 1e20), u64::MAX);
        assert_eq!(poisson(&mut r, f64::INFINITY), u64::MAX);
        assert_eq!(poisson(&mut r, f64::NEG_INFINITY), 0);
        let big = poisson(&mut r, 1e15) as f64;
        assert!((big - 1e15).abs() < 6.0 * 1e15f64.sqrt());
        let n = 20_000;
        let mean = (0..n).map(|_| poisson(&mut r, 3.5) as f64).sum::<f64>() / n as f64;
        assert!((mean - 3.5).abs() < 5.0 * (3.5f64 / n as f64).sqrt());
    }
}
