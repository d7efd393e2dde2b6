//! The shape of the point-spread function the renderer draws: the sensor's Gaussian, or a
//! ground telescope's seeing, a Moffat profile, held as a mixture of concentric Gaussians so
//! that every renderer (photon mapping, expected flux, the debris drawn per pixel) keeps its
//! separable Gaussian pixel integrals and draws one shape.
//!
//! A Moffat profile is exactly a Gaussian scale mixture: with precision tau = 1/sigma^2
//! Gamma-distributed of shape beta - 1 and rate alpha^2 / 2,
//! int (tau / 2 pi) exp(-tau r^2 / 2) Gamma(tau) dtau = (beta - 1) / (pi alpha^2)
//! (1 + r^2 / alpha^2)^-beta. The mixture here is that integral by the trapezoid rule in
//! u = ln(tau alpha^2 / 2), whose integrand exp((beta - 1) u - e^u) is smooth and decays
//! fast at both ends, so a step of 0.5 is exact to 3e-4 of the profile in its core (measured
//! against the formula, `tests::mixture_follows_the_moffat`).

/// Trapezoid step and range in u = ln(tau alpha^2 / 2) (see the module's doc).
const U_STEP: f64 = 0.5;
const U_MIN: f64 = -14.0;
const U_MAX: f64 = 4.0;
/// Components wider than this many FWHM are left out: they carry the far wing (0.26 % of the
/// light at beta = 2.5, 1e-5 at 4.765), which would cost pixels in proportion to their area;
/// the kept components are renormalised, so the flux is conserved and the wing beyond ~4 FWHM
/// falls off as a Gaussian's.
const MAX_SIGMA_FWHM: f64 = 4.0;
/// Components with less weight than this are left out (they change no pixel's mean by more
/// than 1e-5 of the source).
const MIN_WEIGHT: f64 = 1e-5;
/// A mixture's Gaussian is integrated out to the fewest sigmas (in quarter steps, at least 3)
/// beyond which its weight times its two-sided tail share along an axis is at most this share
/// of the source: a light Gaussian, wide or not, needs no 7-sigma support (which cost 3 times
/// the pixels of this one for a beta 4.765 seeing).
const MIXTURE_TAIL_SHARE: f64 = 1e-7;

/// A point-spread function as concentric Gaussians `(weight, sigma_px)`, weights summing to 1.
#[derive(Clone, Debug, PartialEq)]
pub struct Psf {
    components: Vec<(f64, f64)>,
    /// For a mixture, each Gaussian's support in sigmas (`MIXTURE_TAIL_SHARE`); empty for a
    /// single Gaussian, whose support is the caller's.
    supports: Vec<f64>,
    /// Full width at half maximum, pixels.
    fwhm_px: f64,
}

impl Psf {
    /// The sensor's Gaussian of standard deviation `sigma_px`: one component of weight 1
    /// (the renderers then do exactly what they did before seeing existed).
    pub fn gaussian(sigma_px: f64) -> Psf {
        Psf {
            components: vec![(1.0, sigma_px)],
            supports: Vec::new(),
            fwhm_px: 2.0 * (2.0 * 2f64.ln()).sqrt() * sigma_px,
        }
    }

    /// A Moffat (1969, A&A 3, 455) profile of FWHM `fwhm_px` and index `beta` > 1:
    /// alpha = FWHM / (2 sqrt(2^(1/beta) - 1)).
    pub fn moffat(fwhm_px: f64, beta: f64) -> Psf {
        let alpha = fwhm_px / (2.0 * (2f64.powf(1.0 / beta) - 1.0).sqrt());
        let k = beta - 1.0;
        let steps = ((U_MAX - U_MIN) / U_STEP).round() as usize;
        let mut components: Vec<(f64, f64)> = (0..=steps)
            .map(|i| {
                let u = U_MIN + i as f64 * U_STEP;
                // tau = 2 e^u / alpha^2, so sigma = alpha / sqrt(2 e^u).
                ((k * u - u.exp()).exp(), alpha / (2.0 * u.exp()).sqrt())
            })
            .collect();
        let total: f64 = components.iter().map(|c| c.0).sum();
        components.retain(|&(w, s)| w / total >= MIN_WEIGHT && s <= MAX_SIGMA_FWHM * fwhm_px);
        let kept: f64 = components.iter().map(|c| c.0).sum();
        components.iter_mut().for_each(|c| c.0 /= kept);
        let supports = components
            .iter()
            .map(|&(w, _)| {
                let mut n = 3.0;
                while n < 7.0
                    && w * crate::psf::erfc(n / std::f64::consts::SQRT_2) > MIXTURE_TAIL_SHARE
                {
                    n += 0.25;
                }
                n
            })
            .collect();
        Psf {
            components,
            supports,
            fwhm_px,
        }
    }

    /// The Gaussians `(weight, sigma_px)`, narrowest last.
    pub fn components(&self) -> &[(f64, f64)] {
        &self.components
    }

    /// The Gaussians `(weight, sigma_px, support in sigmas)`: a single Gaussian's support is
    /// `single_support` (the caller's own), a mixture's its own (`MIXTURE_TAIL_SHARE`).
    pub fn supported(&self, single_support: f64) -> impl Iterator<Item = (f64, f64, f64)> + '_ {
        self.components.iter().enumerate().map(move |(i, &(w, s))| {
            (
                w,
                s,
                self.supports.get(i).copied().unwrap_or(single_support),
            )
        })
    }

    /// The farthest any Gaussian reaches, pixels, with `single_support` sigmas for a single one.
    pub fn reach_px(&self, single_support: f64) -> f64 {
        self.supported(single_support)
            .map(|(_, s, n)| s * n)
            .fold(0.0, f64::max)
    }

    /// Whether this is a single Gaussian.
    pub fn is_gaussian(&self) -> bool {
        self.components.len() == 1
    }

    /// The widest component's sigma, pixels (the Gaussian's own sigma for one).
    pub fn max_sigma_px(&self) -> f64 {
        self.components.iter().map(|c| c.1).fold(0.0, f64::max)
    }

    /// The sigma of a Gaussian of the same FWHM, pixels (the sensor's own sigma for a
    /// Gaussian): the scale of the core, for node spacings and margins.
    pub fn core_sigma_px(&self) -> f64 {
        match self.components.as_slice() {
            [(_, s)] => *s,
            _ => self.fwhm_px / (2.0 * (2.0 * 2f64.ln()).sqrt()),
        }
    }

    pub fn fwhm_px(&self) -> f64 {
        self.fwhm_px
    }

    /// The profile's surface density at radius `r_px`, per pixel^2 (unit volume).
    pub fn density(&self, r_px: f64) -> f64 {
        self.components
            .iter()
            .map(|&(w, s)| {
                w / (2.0 * std::f64::consts::PI * s * s) * (-r_px * r_px / (2.0 * s * s)).exp()
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn moffat_density(r: f64, fwhm: f64, beta: f64) -> f64 {
        let a = fwhm / (2.0 * (2f64.powf(1.0 / beta) - 1.0).sqrt());
        (beta - 1.0) / (PI * a * a) * (1.0 + r * r / (a * a)).powf(-beta)
    }

    #[test]
    fn mixture_follows_the_moffat() {
        for beta in [2.5, 4.765] {
            let psf = Psf::moffat(3.0, beta);
            let w: f64 = psf.components().iter().map(|c| c.0).sum();
            assert!((w - 1.0).abs() < 1e-12);
            // The core (r < 2 FWHM), where a pixel's light comes from: the trapezoid rule's
            // error plus the renormalised wing, measured 2.6e-3 at beta = 2.5 (the wing's
            // share) and 1e-4 at 4.765; 3e-3 bounds both.
            for i in 0..=60 {
                let r = f64::from(i) * 0.1;
                let rel = psf.density(r) / moffat_density(r, 3.0, beta) - 1.0;
                assert!(rel.abs() < 3e-3, "beta {beta} r {r}: {rel}");
            }
            // Its half maximum sits at half the FWHM to 1e-3 of the peak.
            let half = psf.density(1.5) / psf.density(0.0);
            assert!((half - 0.5).abs() < 1e-3, "{half}");
            assert!(psf.max_sigma_px() <= 4.0 * 3.0);
        }
        // Each of a mixture's Gaussians reaches as far as its weight needs: its tail beyond
        // the support holds at most 1e-7 of the source, and a fourth of a sigma less would not.
        for beta in [2.5, 4.765] {
            let psf = Psf::moffat(3.0, beta);
            for (w, _, n) in psf.supported(99.0) {
                let tail = |n: f64| w * crate::psf::erfc(n / std::f64::consts::SQRT_2);
                assert!((3.0..=7.0).contains(&n));
                assert!(tail(n) <= 1e-7 || n == 7.0, "{w} {n}");
                assert!(n == 3.0 || tail(n - 0.25) > 1e-7, "{w} {n}");
            }
        }
        // The Gaussian is one component of its own sigma, supported as far as the caller asks.
        let g = Psf::gaussian(1.4);
        assert_eq!(g.supported(7.0).collect::<Vec<_>>(), vec![(1.0, 1.4, 7.0)]);
        assert!(g.is_gaussian());
        assert_eq!(g.components(), &[(1.0, 1.4)]);
        assert_eq!(g.core_sigma_px(), 1.4);
    }
}
