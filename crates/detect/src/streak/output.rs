//! Step 7, output: the candidate, its score and its box in the generator's label convention.

use super::accept::boxed_score;
use super::fit::fitted_box;
use super::maps::Maps;
use super::params::Sanitized;
use super::segment::Seg;
use crate::Detection;

/// The reference image area of the confidence: 1024 x 1024 pixels.
const MEGAPIXEL: f64 = 1_048_576.0;

/// Confidence in [0, 1): the probability that noise alone gives no candidate as significant
/// in an image of `area_px` pixels, under a Gumbel model of the most significant noise candidate
/// (the maximum of many nearly Gaussian tests has a Gumbel tail): noise candidates of SNR >= s
/// are expected `(area_px / 2^20) exp(-(s - confidence_snr) / confidence_snr_scale) ln 2` times,
/// so a long streak in a 1024 x 1024 image scores 0.5 at `confidence_snr`; times
/// `1 - exp(-(elongation - 1) / confidence_elongation_scale)`, which leaves long streaks alone
/// but keeps short ones (elongation about 3 at 25 px), where unmasked bright stars and warm
/// pixel clusters also reach a high SNR, below 0.5.
pub(super) fn confidence(snr: f64, elongation: f64, area_px: f64, p: &Sanitized) -> f64 {
    let expected = (area_px / MEGAPIXEL)
        * (-(snr - p.confidence_snr) / p.confidence_scale).exp()
        * std::f64::consts::LN_2;
    let shape = 1.0 - (-(elongation - 1.0).max(0.0) / p.elongation_scale).exp();
    ((-expected).exp() * shape).clamp(0.0, 1.0)
}

/// One detected streak.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Candidate {
    /// Box (pixel-edge coordinates), score in [0, 1) and class.
    pub detection: Detection,
    /// The half-level ends of the streak, in the box's pixel-edge coordinates (pixel `i` spans
    /// `[i, i + 1]`, so a pixel centre is at `i + 0.5`), not clipped to the image.
    pub ends: [[f64; 2]; 2],
    /// Length between the half-level ends, pixels.
    pub length_px: f64,
    /// Axis orientation, degrees from +x towards +y (image rows down), in [0, 180).
    pub orientation_deg: f64,
    /// sqrt(l1 / l2) of the z-weighted second moments around the segment.
    pub elongation: f64,
    /// Background-subtracted grey levels summed within 3 PSF sigmas of the segment.
    pub flux: f64,
    /// Matched-filter signal-to-noise ratio of the whole streak.
    pub snr: f64,
}

/// The candidate of the kept segment `s` of score `score`, boxed.
#[cfg(test)]
pub(super) fn candidate(maps: &Maps, s: &Seg, score: f64) -> Candidate {
    boxed(maps, s, unboxed(maps, s, score))
}

/// `c`, the candidate of `s` ([`unboxed`]), with the fitted streak's label box (`fit`); the
/// padded segment's where it cannot be fitted.
pub(super) fn boxed(maps: &Maps, s: &Seg, c: Candidate) -> Candidate {
    let Some(b) = fitted_box(maps, s) else {
        return c;
    };
    let across = (b.x_max - b.x_min).hypot(b.y_max - b.y_min);
    let score = boxed_score(maps, s, across, c.detection.score);
    let detection = Detection {
        x1: b.x_min,
        y1: b.y_min,
        x2: b.x_max,
        y2: b.y_max,
        score,
        ..c.detection
    };
    Candidate { detection, ..c }
}

/// [`candidate`] with the padded segment's box: all that tells one candidate from another
/// (the fitted box, most of a candidate's time, is only its label box).
pub(super) fn unboxed(maps: &Maps, s: &Seg, score: f64) -> Candidate {
    let p = maps.p;
    let (a, b) = s.ends();
    let (ux, uy) = s.dir();
    let along = p.pad_along * p.psf_sigma;
    let across = p.pad_across * p.psf_sigma;
    // Support of an ellipse (semi-axes along/across) in the x and y directions.
    let ex = ((along * ux).powi(2) + (across * uy).powi(2)).sqrt();
    let ey = ((along * uy).powi(2) + (across * ux).powi(2)).sqrt();
    let (w, h) = (maps.w as f64, maps.h as f64);
    let detection = Detection {
        x1: (a.0.min(b.0) - ex + 0.5).clamp(0.0, w),
        y1: (a.1.min(b.1) - ey + 0.5).clamp(0.0, h),
        x2: (a.0.max(b.0) + ex + 0.5).clamp(0.0, w),
        y2: (a.1.max(b.1) + ey + 0.5).clamp(0.0, h),
        score,
        class: p.class,
    };
    Candidate {
        detection,
        ends: [[a.0 + 0.5, a.1 + 0.5], [b.0 + 0.5, b.1 + 0.5]],
        length_px: s.length,
        orientation_deg: s.theta.to_degrees().rem_euclid(180.0),
        elongation: s.elongation,
        flux: s.flux,
        snr: s.snr,
    }
}

#[cfg(test)]
mod tests {
    use super::super::params::StreakParams;
    use super::*;

    #[test]
    fn confidence_is_monotone_bounded_and_half_at_its_snr() {
        let p = Sanitized::new(&StreakParams::default());
        // A long streak: the shape factor is 1 to 1e-12.
        let long = 100.0;
        let mut prev = -1.0;
        for i in 0..200 {
            let c = confidence(i as f64 * 0.25, long, MEGAPIXEL, &p);
            assert!((0.0..=1.0).contains(&c) && c >= prev, "{i} {c}");
            prev = c;
        }
        let mut prev = -1.0;
        for i in 0..200 {
            let c = confidence(12.0, 1.0 + i as f64 * 0.25, MEGAPIXEL, &p);
            assert!((0.0..=1.0).contains(&c) && c >= prev, "{i} {c}");
            prev = c;
        }
        assert!((confidence(p.confidence_snr, long, MEGAPIXEL, &p) - 0.5).abs() < 1e-9);
        // Four times the area holds four times the noise candidates: 0.5^4.
        let c4 = confidence(p.confidence_snr, long, 4.0 * MEGAPIXEL, &p);
        assert!((c4 - 0.0625).abs() < 1e-9, "{c4}");
        assert!(confidence(0.0, long, MEGAPIXEL, &p) < 1e-3);
        assert_eq!(confidence(50.0, 1.0, MEGAPIXEL, &p), 0.0);
        let sure = p.confidence_snr + 20.0 * p.confidence_scale;
        assert!(confidence(sure, long, MEGAPIXEL, &p) > 0.999);
    }
}
