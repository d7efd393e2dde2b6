//! Step 7, output: the score of a candidate and its box in the generator's label convention.

use super::refine::{Ctx, Seg};
use super::{Candidate, Detection, Sanitized};

/// Score in [0, 1): increasing in SNR and in elongation.
pub(super) fn score(snr: f64, elongation: f64, p: &Sanitized) -> f64 {
    let a = 1.0 - (-snr.max(0.0) / p.snr_scale).exp();
    let b = 1.0 - (-(elongation - 1.0).max(0.0) / p.elong_scale).exp();
    (a * b).clamp(0.0, 1.0)
}

impl Ctx<'_> {
    pub(super) fn candidate(&self, s: &Seg, score: f64) -> Candidate {
        let p = self.p;
        let (a, b) = s.ends();
        let (ux, uy) = s.dir();
        let along = p.pad_along * p.psf_sigma;
        let across = p.pad_across * p.psf_sigma;
        // Support of an ellipse (semi-axes along/across) in the x and y directions.
        let ex = ((along * ux).powi(2) + (across * uy).powi(2)).sqrt();
        let ey = ((along * uy).powi(2) + (across * ux).powi(2)).sqrt();
        let (w, h) = (self.w as f64, self.h as f64);
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
}

#[cfg(test)]
mod tests {
    use super::super::StreakParams;
    use super::*;

    #[test]
    fn score_is_monotone_and_bounded() {
        let p = Sanitized::new(&StreakParams::default());
        let mut prev = -1.0;
        for i in 0..200 {
            let snr = i as f64 * 0.5;
            let s = score(snr, 8.0, &p);
            assert!((0.0..1.0).contains(&s) && s >= prev);
            prev = s;
        }
        let mut prev = -1.0;
        for i in 0..200 {
            let s = score(12.0, 1.0 + i as f64 * 0.25, &p);
            assert!((0.0..1.0).contains(&s) && s >= prev);
            prev = s;
        }
        assert_eq!(score(0.0, 10.0, &p), 0.0);
        assert_eq!(score(10.0, 1.0, &p), 0.0);
    }
}
