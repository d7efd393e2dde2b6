//! An independent frame generator for the streak detector's tests: Gaussian line segments
//! (debris streaks and star trails) on a flat sky with Poisson and read noise, stretched to
//! 8 bits as a viewer would, written without soig's renderer, enhancement or random numbers,
//! so that what the detector learnt of soig's own images is not what it is tested on.
//!
//! Units: electrons. A segment's light is a Gaussian of `psf_sigma` across it and the same
//! Gaussian's error-function ends along it (a point source moving uniformly over the
//! exposure). The 8-bit frame is `255 sqrt((e - lo) / (hi - lo))`, clipped, from `lo` 3 noise
//! sigmas below the sky to `hi` `STRETCH_SIGMA` above it.

#![allow(dead_code)]

/// The noise sigmas above the sky that the stretch maps to white.
const STRETCH_SIGMA: f64 = 40.0;

/// A straight segment of light: its ends (pixel centres at integers) and electrons per pixel
/// of its length.
#[derive(Clone, Copy, Debug)]
pub struct Segment {
    pub a: (f64, f64),
    pub b: (f64, f64),
    pub per_px: f64,
}

impl Segment {
    pub fn length(&self) -> f64 {
        (self.b.0 - self.a.0).hypot(self.b.1 - self.a.1)
    }
    /// Orientation in the detector's convention: degrees from +x towards +y, in [0, 180).
    pub fn angle_deg(&self) -> f64 {
        (self.b.1 - self.a.1)
            .atan2(self.b.0 - self.a.0)
            .to_degrees()
            .rem_euclid(180.0)
    }
}

/// The sensor: PSF sigma (px), sky (e-/px) and read noise (e-).
#[derive(Clone, Copy, Debug)]
pub struct Sensor {
    pub psf_sigma: f64,
    pub sky: f64,
    pub read_noise: f64,
}

impl Sensor {
    /// The noise of one pixel of empty sky, electrons.
    pub fn noise(&self) -> f64 {
        (self.sky + self.read_noise * self.read_noise).sqrt()
    }
    /// Electrons per pixel of length of a line whose peak pixel stands `snr` noise sigmas
    /// above the sky.
    pub fn per_px_for_peak_snr(&self, snr: f64) -> f64 {
        snr * self.noise() * (2.0 * std::f64::consts::PI).sqrt() * self.psf_sigma
    }
}

/// SplitMix64: a small, fixed random source (no crate: the test's draws are its own).
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }
    /// Standard normal (Box-Muller).
    pub fn normal(&mut self) -> f64 {
        let u = self.uniform().max(1e-300);
        let v = self.uniform();
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
    /// Poisson of mean `m`: Knuth's product below 30, the normal approximation above.
    pub fn poisson(&mut self, m: f64) -> f64 {
        if m <= 0.0 {
            return 0.0;
        }
        if m > 30.0 {
            return (m + m.sqrt() * self.normal()).round().max(0.0);
        }
        let limit = (-m).exp();
        let (mut k, mut p) = (0.0, self.uniform());
        while p > limit {
            k += 1.0;
            p *= self.uniform();
        }
        k
    }
}

/// erf by Abramowitz and Stegun 7.1.26 (absolute error below 1.5e-7).
fn erf(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
    let y = 1.0
        - t * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))))
            * (-x * x).exp();
    if x >= 0.0 { y } else { -y }
}

/// The noiseless light of `segs` on a `w` x `h` frame, electrons per pixel (sky excluded).
pub fn light(w: usize, h: usize, psf_sigma: f64, segs: &[Segment]) -> Vec<f64> {
    let mut img = vec![0.0; w * h];
    let reach = 5.0 * psf_sigma;
    let norm = 1.0 / ((2.0 * std::f64::consts::PI).sqrt() * psf_sigma);
    for s in segs {
        let len = s.length().max(1e-9);
        let (ux, uy) = ((s.b.0 - s.a.0) / len, (s.b.1 - s.a.1) / len);
        let x0 = (s.a.0.min(s.b.0) - reach).floor().max(0.0) as usize;
        let x1 = ((s.a.0.max(s.b.0) + reach).ceil().max(0.0) as usize).min(w - 1);
        let y0 = (s.a.1.min(s.b.1) - reach).floor().max(0.0) as usize;
        let y1 = ((s.a.1.max(s.b.1) + reach).ceil().max(0.0) as usize).min(h - 1);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let (dx, dy) = (x as f64 - s.a.0, y as f64 - s.a.1);
                let along = dx * ux + dy * uy;
                let across = -dx * uy + dy * ux;
                if across.abs() > reach || along < -reach || along > len + reach {
                    continue;
                }
                let r = std::f64::consts::SQRT_2 * psf_sigma;
                let ends = 0.5 * (erf(along / r) - erf((along - len) / r));
                img[y * w + x] += s.per_px
                    * norm
                    * (-across * across / (2.0 * psf_sigma * psf_sigma)).exp()
                    * ends;
            }
        }
    }
    img
}

/// The 8-bit frame of `segs` seen by `sensor`: sky plus their light, Poisson, plus Gaussian
/// read noise, stretched (module docs).
pub fn frame(w: usize, h: usize, sensor: &Sensor, segs: &[Segment], rng: &mut Rng) -> Vec<u8> {
    let noise = sensor.noise();
    let (lo, hi) = (sensor.sky - 3.0 * noise, sensor.sky + STRETCH_SIGMA * noise);
    light(w, h, sensor.psf_sigma, segs)
        .iter()
        .map(|&l| {
            let e = rng.poisson(sensor.sky + l) + sensor.read_noise * rng.normal();
            let f = ((e - lo) / (hi - lo)).clamp(0.0, 1.0);
            (255.0 * f.sqrt()).round() as u8
        })
        .collect()
}
