//! The expected-flux renderer: for each source, the expected photo-electrons per pixel (the
//! Gaussian PSF integrated over each pixel, averaged along the source's path over its share of
//! the exposure, jitter included), then one Poisson draw per pixel. Photons of a source land
//! independently, so the photon-mapped count of each pixel is Poisson with exactly this mean:
//! for a fixed jitter path both renderers have the same distribution (without merging), and
//! this one does work per pixel the PSF reaches instead of per photon.

use soig_base::rng::PixelRng;

use super::{Canvas, Jitter, Path, Source};
use crate::scene::Scene;
use crate::sensor::Sensor;
use soig_base::rng::poisson;
pub use soig_image::psf::{DebrisFlux, DebrisMap};
use soig_image::psf::{add_separable, weights_into};
use soig_image::psf_shape::Psf;

/// Pixels farther than this many PSF sigmas from the path get nothing (a share of 6e-7 of the
/// photons per axis; photon mapping lands them).
const PSF_SUPPORT_SIGMA: f64 = 5.0;

/// Time-average along a path: nodes at most this many PSF sigmas apart. A node stands for a
/// stretch of path at its time-weighted mean position; the spread it hides widens the PSF
/// variance by at most 0.25% (a stretch stays within the spacing of its start).
const NODE_SPACING_SIGMA: f64 = 0.05;

/// Expected photo-electrons per pixel, stars and debris apart (their draws are independent).
pub struct Flux {
    pub width: usize,
    pub height: usize,
    pub psf: Psf,
    pub stars: Vec<f64>,
    pub debris: Vec<f64>,
}

impl Flux {
    pub fn new(width: usize, height: usize, psf_px: f64) -> Flux {
        Flux::with_psf(width, height, Psf::gaussian(psf_px))
    }

    /// `new` through any PSF shape.
    pub fn with_psf(width: usize, height: usize, psf: Psf) -> Flux {
        Flux {
            width,
            height,
            psf,
            stars: vec![0.0; width * height],
            debris: vec![0.0; width * height],
        }
    }

    /// Add one source's expected photons along its path.
    pub(super) fn add(&mut self, source: &Source, jitter: &Jitter) {
        let spacing = NODE_SPACING_SIGMA * self.psf.core_sigma_px();
        for (share, x, y) in path_nodes(source, jitter, spacing) {
            self.deposit(source.expected * share, x, y, source.debris);
        }
    }

    /// The PSF centred on (x, y), integrated over each pixel of its support: each of its
    /// Gaussians separable, so the product of two 1-D pixel integrals (differences of the
    /// normal CDF at pixel edges), weighted (a Gaussian PSF's one weight is 1: bit for bit
    /// the single Gaussian's deposit).
    fn deposit(&mut self, amount: f64, x: f64, y: f64, debris: bool) {
        if amount.is_nan() || amount <= 0.0 || !x.is_finite() || !y.is_finite() {
            return;
        }
        let image = if debris {
            &mut self.debris
        } else {
            &mut self.stars
        };
        for (share, sigma, n) in self.psf.supported(PSF_SUPPORT_SIGMA) {
            let Some((i0, wx)) = pixel_weights(x, sigma, n, self.width) else {
                continue;
            };
            let Some((j0, wy)) = pixel_weights(y, sigma, n, self.height) else {
                continue;
            };
            add_separable(image, self.width, (i0, &wx), (j0, &wy), amount * share);
        }
    }

    /// One Poisson draw per pixel (debris and stars apart, so the debris image stays known).
    pub(super) fn draw(self, rng: &mut PixelRng) -> Canvas {
        let n = self.width * self.height;
        let mut electrons = vec![0u32; n];
        let mut debris = vec![0u32; n];
        let mut debris_total = 0u64;
        for k in 0..n {
            let d = poisson(rng, self.debris[k]);
            let s = poisson(rng, self.stars[k]);
            debris[k] = d.min(u32::MAX as u64) as u32;
            electrons[k] = (d + s).min(u32::MAX as u64) as u32;
            debris_total += d;
        }
        Canvas {
            electrons,
            debris,
            debris_total,
        }
    }
}

/// The expected flux of a scene for a jitter path, without the Poisson draw: the noise-free
/// image an infinite number of photon-mapped renders averages to.
pub fn expected_flux(sensor: &Sensor, scene: &Scene, jitter: &Jitter) -> Flux {
    let mut flux = Flux::with_psf(sensor.width_px, sensor.height_px, scene.psf(sensor));
    super::for_each_source(sensor, scene, jitter, |source| flux.add(source, jitter));
    flux
}

/// The debris' expected photo-electrons of a scene for a jitter path ([`DebrisFlux`]).
pub fn debris_flux(sensor: &Sensor, scene: &Scene, jitter: &Jitter) -> DebrisFlux {
    let samples: Vec<(f64, f64, f64)> = scene
        .object
        .trajectory
        .iter()
        .map(|p| {
            let (jx, jy) = jitter.at(p.t_s);
            (p.expected_electrons, p.x_px + jx, p.y_px + jy)
        })
        .collect();
    DebrisFlux::of_samples_psf(
        &samples,
        &scene.psf(sensor),
        sensor.width_px,
        sensor.height_px,
    )
}

/// The matched-filter SNR of a scene's debris for a jitter path (`DebrisFlux`).
pub fn matched_filter_snr(
    sensor: &Sensor,
    scene: &Scene,
    jitter: &Jitter,
    noise_sigma_adu: f64,
) -> f64 {
    debris_flux(sensor, scene, jitter).matched_filter_snr(sensor.gain_e_per_adu, noise_sigma_adu)
}

/// First pixel and the PSF share of each pixel of the support along one axis (pixel i spans
/// [i - 0.5, i + 0.5)); None when the support misses the image.
fn pixel_weights(c: f64, sigma: f64, support: f64, n: usize) -> Option<(usize, Vec<f64>)> {
    let mut w = Vec::new();
    weights_into(c, sigma, support, n, &mut w).map(|lo| (lo, w))
}

/// Nodes (share of the source's photons, x, y) along its jittered path: the path is linear
/// between the breakpoints of the jitter grid and of a survey trail, so each piece is cut into
/// equal steps at most `spacing` long (midpoint rule), and consecutive steps that stay within
/// `spacing` of the first are merged into one node at their mean (a fixed star with a fine
/// jitter grid needs nodes for where it goes, not for every jitter step).
fn path_nodes(source: &Source, jitter: &Jitter, spacing: f64) -> Vec<(f64, f64, f64)> {
    let at = |t: f64| {
        let (x, y) = source.path.at(t);
        let (jx, jy) = jitter.at(t);
        (x + jx, y + jy)
    };
    let (t_a, t_b) = (source.t_a, source.t_b);
    if matches!(source.path, Path::Instant { .. }) || t_b <= t_a {
        let (x, y) = at(t_a);
        return vec![(1.0, x, y)];
    }
    let mut breaks: Vec<f64> = vec![t_a, t_b];
    let grid = |step: f64, breaks: &mut Vec<f64>| {
        let first = (t_a / step).floor() as usize + 1;
        breaks.extend((first..).map(|k| k as f64 * step).take_while(|&t| t < t_b));
    };
    grid(jitter.dt, &mut breaks);
    if let Path::Trail { step, .. } = source.path {
        grid(step, &mut breaks);
    }
    breaks.sort_by(f64::total_cmp);
    breaks.dedup();

    let span = t_b - t_a;
    let mut nodes = Vec::new();
    // The node being gathered: its first position, total share, and share-weighted sums.
    let mut open: Option<((f64, f64), f64, f64, f64)> = None;
    for w in breaks.windows(2) {
        let (u, v) = (w[0], w[1]);
        let (p, q) = (at(u), at(v));
        let length = (q.0 - p.0).hypot(q.1 - p.1);
        let m = ((length / spacing).ceil() as usize).max(1);
        let share = (v - u) / span / m as f64;
        for j in 0..m {
            let f = (j as f64 + 0.5) / m as f64;
            let (x, y) = (p.0 + f * (q.0 - p.0), p.1 + f * (q.1 - p.1));
            match &mut open {
                Some((first, s, sx, sy)) if (x - first.0).hypot(y - first.1) <= spacing => {
                    *s += share;
                    *sx += share * x;
                    *sy += share * y;
                }
                _ => {
                    if let Some((_, s, sx, sy)) = open {
                        nodes.push((s, sx / s, sy / s));
                    }
                    open = Some(((x, y), share, share * x, share * y));
                }
            }
        }
    }
    if let Some((_, s, sx, sy)) = open {
        nodes.push((s, sx / s, sy / s));
    }
    nodes
}

#[cfg(test)]
mod tests {
    use super::*;
    use soig_image::psf::erfc;

    #[test]
    fn erfc_and_pixel_mass() {
        // Reference values of erfc (Abramowitz & Stegun table 7.1).
        for (x, e) in [
            (0.0, 1.0),
            (0.5, 0.479_500_122),
            (1.0, 0.157_299_207),
            (2.0, 0.004_677_735),
        ] {
            assert!((erfc(x) - e).abs() < 2e-7 * e.max(1e-3), "{x}");
            assert!((erfc(-x) - (2.0 - e)).abs() < 2e-7);
        }
        // The pixel shares of a PSF well inside the image sum to 1 (up to the support cut).
        let (_, w) = pixel_weights(10.3, 1.4, PSF_SUPPORT_SIGMA, 64).unwrap();
        let total: f64 = w.iter().sum();
        assert!((total - 1.0).abs() < 2e-6, "{total}");
        assert!(pixel_weights(-20.0, 1.0, PSF_SUPPORT_SIGMA, 64).is_none());
    }
}
