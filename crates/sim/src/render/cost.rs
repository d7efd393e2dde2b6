//! What one image costs, estimated before anything renders. Photon mapping traces one packet
//! per photon of every source (or per `merge_factor` photons above the merge threshold, at most
//! `MAX_PACKETS_PER_SOURCE` a source), so the zero point, the limiting magnitude and the
//! exposure set its work, 2.5 times more a magnitude: a zero point of 40 turns the paper's
//! 0.1 s image into one of hours. The estimate is an upper bound of the star field's work (the
//! star density of the galactic plane, the longest exposure, the debris as bright as the
//! brightest star the gate lets in), plus the pixels' own work; callers refuse what exceeds
//! their limit (`soig::work`).

use soig_sky::photometry::photon_rate;
use soig_sky::stars::{BRIGHT_MAG_LIMIT, cumulative_density_per_deg2};

use super::{MAX_PACKETS_PER_SOURCE, RenderMethod};
use crate::simulate::Experiment;

/// Packets photon mapping traces a second on one core: 3.2e9 packets took 83 s, 1.5e8 took
/// 3.5 s (a 128 px image at zero points 32 and 28, 2026-11-28, on the development machine).
pub const PACKETS_PER_SECOND: f64 = 4e7;

/// A pixel's work besides the photons (detector noise, frames, enhancement, files): a 2048 px
/// image with few photons took 0.6 s (2026-11-28).
pub const SECONDS_PER_PIXEL: f64 = 1.5e-7;

/// Width of the magnitude bins the star field is summed over.
const MAG_STEP: f64 = 0.05;

/// The estimated work of one image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageCost {
    /// Photon packets traced (stars and debris), at most.
    pub packets: f64,
    /// Seconds of one core, at most (packets and pixels).
    pub seconds: f64,
    /// Photo-electrons of the brightest star the gate lets in, over the longest exposure.
    pub brightest_electrons: f64,
}

/// Packets a source of `photons` expected photo-electrons traces (`photons::trace`).
fn packets(photons: f64, threshold: u64, factor: u32) -> f64 {
    let traced = if photons > threshold as f64 {
        photons / f64::from(factor.max(1))
    } else {
        photons
    };
    traced.min(MAX_PACKETS_PER_SOURCE as f64)
}

/// The estimated work of one image of `x` (upper bounds, see the module).
pub fn image(x: &Experiment) -> ImageCost {
    let s = &x.sensor;
    let r = &x.render;
    let t = x.scene.exposure_max_s;
    let pixels = (s.width_px * s.height_px) as f64;
    // No star of the model is brighter than its bright limit (a gate of -30 admits no more).
    let brightest = x.scene.gate.brightest_star_mag.max(BRIGHT_MAG_LIMIT);
    let brightest_electrons = photon_rate(brightest, s.zero_point_mag) * t;
    let mut total = 0.0;
    if r.method == RenderMethod::PhotonMapping {
        // The field and the margin stars are traced in (8 PSF sigmas), square degrees.
        let scale = s.pixel_scale_deg();
        let margin = 2.0 * (8.0 * s.psf_sigma_px() + 1.0);
        let area = (s.width_px as f64 + margin) * (s.height_px as f64 + margin) * scale * scale;
        let mut m = brightest;
        while m < s.mag_limit {
            let next = (m + MAG_STEP).min(s.mag_limit);
            let stars = (cumulative_density_per_deg2(0.0, next)
                - cumulative_density_per_deg2(0.0, m))
            .max(0.0)
                * area;
            let photons = photon_rate(0.5 * (m + next), s.zero_point_mag) * t;
            total += stars * packets(photons, r.merge_threshold, r.merge_factor);
            m = next;
        }
        // Each object's trajectory samples share one source's budget, and are drawn per pixel
        // (no packets) while no sample can reach the merge threshold (`singles_only`).
        let objects = x.scene.objects.map_or(1, |o| o.max.max(1)) as f64;
        let per_sample = brightest_electrons / x.scene.trajectory_samples.max(1) as f64;
        if per_sample + 12.0 * per_sample.sqrt() + 12.0 >= r.merge_threshold as f64 {
            total += objects * packets(brightest_electrons, r.merge_threshold, r.merge_factor);
        }
    }
    ImageCost {
        packets: total,
        seconds: total / PACKETS_PER_SECOND + pixels * SECONDS_PER_PIXEL,
        brightest_electrons,
    }
}
