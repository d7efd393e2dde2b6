//! The air over a ground telescope: how much of it a line of sight crosses (airmass), what it
//! takes from the light (extinction), how it blurs a point (seeing, a Moffat profile), how
//! bright it glows (sky background) and how it makes a bright source twinkle (scintillation).
//! Each is a published formula, cited where it is used. The sky's glow in mag/arcsec^2 is the
//! physical noise model's (`noise::sky_e_per_s`, `[noise] sky_mag_per_arcsec2`): a dark-sky
//! value, the twilight sky and the Moon's light not modelled.

use std::f64::consts::PI;

/// Relative airmass at apparent (refracted) altitude `alt_deg`: Kasten & Young (1989, Applied
/// Optics 28, 4735) X = 1 / (sin h + 0.50572 (h + 6.07995 deg)^-1.6364), h in degrees. It
/// follows sec z to 0.1 % above 30 deg and stays finite at the horizon (37.92).
pub fn airmass(alt_deg: f64) -> f64 {
    let h = alt_deg.clamp(0.0, 90.0);
    1.0 / (h.to_radians().sin() + 0.50572 * (h + 6.07995).powf(-1.6364))
}

/// Magnitudes the air takes from a source at airmass `x`, with the band's extinction
/// coefficient `k_mag_per_airmass` (e.g. V ~ 0.12-0.2 at a good site, about 0.25 at sea level):
/// the Bouguer law, k X.
pub fn extinction_mag(k_mag_per_airmass: f64, x: f64) -> f64 {
    k_mag_per_airmass * x
}

/// The seeing FWHM at airmass `x` from its zenith value: Kolmogorov turbulence gives
/// FWHM proportional to X^(3/5) (Roddier 1981, Progress in Optics 19, 281).
pub fn seeing_fwhm_arcsec(zenith_fwhm_arcsec: f64, x: f64) -> f64 {
    zenith_fwhm_arcsec * x.powf(0.6)
}

/// The seeing of one exposure, as the renderer draws it and the truth records it: a Moffat
/// of FWHM `fwhm_arcsec` (the zenith value times the boresight's airmass^0.6) and index
/// `beta`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Seeing {
    pub fwhm_arcsec: f64,
    pub beta: f64,
    /// The boresight's airmass at mid-exposure.
    pub airmass: f64,
}

/// The scintillation of one object in one exposure, as applied and as the truth records it:
/// its relative rms `sigma` (`scintillation_variance` at the object's airmass), the drawn
/// flux `factor` every one of its trajectory samples was multiplied by.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Scintillation {
    pub sigma: f64,
    pub factor: f64,
    /// The object's airmass at mid-exposure.
    pub airmass: f64,
}

/// A Moffat (1969, A&A 3, 455) point-spread function of FWHM `fwhm` and index `beta` > 1,
/// normalised to unit volume: I(r) = (beta - 1) / (pi alpha^2) (1 + r^2 / alpha^2)^-beta, with
/// alpha = FWHM / (2 sqrt(2^(1/beta) - 1)). beta = 4.765 is Trujillo et al.'s (2001, MNRAS
/// 328, 977) fit to Kolmogorov seeing; 2.5 (IRAF's default) has wider wings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Moffat {
    pub alpha: f64,
    pub beta: f64,
}

impl Moffat {
    pub fn from_fwhm(fwhm: f64, beta: f64) -> Self {
        Moffat {
            alpha: fwhm / (2.0 * (2f64.powf(1.0 / beta) - 1.0).sqrt()),
            beta,
        }
    }

    /// Surface density at radius `r` (units of `fwhm`), per unit area.
    pub fn density(&self, r: f64) -> f64 {
        let a2 = self.alpha * self.alpha;
        (self.beta - 1.0) / (PI * a2) * (1.0 + r * r / a2).powf(-self.beta)
    }

    /// The share of the light within radius `r`: 1 - (1 + r^2 / alpha^2)^(1 - beta).
    pub fn enclosed(&self, r: f64) -> f64 {
        1.0 - (1.0 + r * r / (self.alpha * self.alpha)).powf(1.0 - self.beta)
    }
}

/// Scale height of the turbulence that makes scintillation, metres (Young 1967; Osborn et al.
/// 2015).
pub const SCINTILLATION_SCALE_HEIGHT_M: f64 = 8000.0;

/// Relative variance of a source's flux from scintillation over an exposure: Young's (1967,
/// AJ 72, 747) approximation with Osborn et al.'s (2015, MNRAS 452, 1707, eq. 7) empirical
/// correction, sigma^2 = 10e-6 C_Y^2 D^(-4/3) t^(-1) X^3 exp(-2 h / H), with D the aperture in
/// metres, t the exposure in seconds, X the airmass (their (cos gamma)^-3), h the site's
/// height and H = 8000 m. C_Y = 1 is Young's own formula (in metres: his 0.09 D_cm^(-2/3)
/// (2t)^(-1/2) squared is 8.7e-6 D_m^(-4/3) / t); C_Y depends on the site's turbulence
/// profile (Osborn et al. tabulate it per observatory), 1.5 a typical value. It matters for bright sources, whose photon noise falls below
/// it (a 1 m telescope at the zenith, sea level, 1 s, C_Y 1.5: 0.47 %).
pub fn scintillation_variance(
    c_y: f64,
    aperture_m: f64,
    x: f64,
    height_m: f64,
    exposure_s: f64,
) -> f64 {
    10e-6 * c_y * c_y * aperture_m.powf(-4.0 / 3.0) / exposure_s
        * x.powi(3)
        * (-2.0 * height_m / SCINTILLATION_SCALE_HEIGHT_M).exp()
}

/// The flux factor of one exposure from a standard normal draw `g`: log-normal (weak
/// scintillation is, Dravins et al. 1997, PASP 109, 173) with mean 1 and relative variance
/// `variance`, exp(s g - s^2 / 2) with s^2 = ln(1 + variance).
pub fn scintillation_factor(variance: f64, g: f64) -> f64 {
    let s2 = variance.ln_1p();
    (s2.sqrt() * g - s2 / 2.0).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn airmass_follows_kasten_young() {
        // Zenith: 1 / (1 + 0.50572 * 96.07995^-1.6364) = 1 / 1.000288 = 0.999712 (the fit's
        // offset).
        assert!(
            (airmass(90.0) - 0.999_712).abs() < 1e-6,
            "{}",
            airmass(90.0)
        );
        // Horizon: Kasten & Young's table, 37.92.
        assert!((airmass(0.0) - 37.92).abs() < 0.01, "{}", airmass(0.0));
        // 30 deg up: sec z = 2; the formula gives 1.9942 (the curved atmosphere is thinner).
        assert!((airmass(30.0) - 1.9942).abs() < 5e-4, "{}", airmass(30.0));
        // Above 30 deg it follows sec z to 0.3 %.
        for alt in [30.0, 45.0, 60.0, 75.0] {
            let secz = 1.0 / f64::to_radians(alt).sin();
            assert!((airmass(alt) / secz - 1.0).abs() < 3e-3, "{alt}");
        }
        // Below the horizon it holds the horizon's value (no NaN).
        assert_eq!(airmass(-3.0), airmass(0.0));
    }

    #[test]
    fn extinction_and_seeing_scale_with_airmass() {
        assert!((extinction_mag(0.15, 2.0) - 0.30).abs() < 1e-12);
        // X = 2: 2^0.6 = 1.5157 times the zenith FWHM.
        assert!((seeing_fwhm_arcsec(1.2, 2.0) - 1.2 * 1.515_716).abs() < 1e-6);
    }

    #[test]
    fn moffat_has_its_fwhm_and_unit_volume() {
        for beta in [2.5, 4.765] {
            let m = Moffat::from_fwhm(3.0, beta);
            // Half the peak at half the FWHM.
            assert!((m.density(1.5) / m.density(0.0) - 0.5).abs() < 1e-12);
            // The volume out to 1000 FWHM by the midpoint rule on rings equals `enclosed`.
            let (n, r_max) = (200_000, 3000.0);
            let dr = r_max / f64::from(n);
            let vol: f64 = (0..n)
                .map(|i| {
                    let r = (f64::from(i) + 0.5) * dr;
                    2.0 * PI * r * m.density(r) * dr
                })
                .sum();
            // Midpoint rule on rings of dr = 0.015 (about alpha / 100): measured 4e-6 at
            // beta = 2.5; 1e-5 bounds it, far below a wrong normalisation or alpha.
            assert!((vol - m.enclosed(r_max)).abs() < 1e-5, "{vol}");
            assert!(m.enclosed(r_max) > 0.999_99);
        }
    }

    #[test]
    fn scintillation_follows_young_and_osborn() {
        // Young (1967) in his units, 0.09 D_cm^(-2/3) X^1.75 exp(-h/8000) (2t)^(-1/2), squared,
        // against C_Y = 1 in metres at X = 1: Young's coefficient 0.09^2 / 2 * 100^(-4/3) =
        // 8.73e-6 is the 10e-6 of Osborn et al.'s eq. 7 to 13 % (they round it).
        let young = 0.09f64.powi(2) / 2.0 * 100f64.powf(-4.0 / 3.0);
        assert!((young - 8.725e-6).abs() < 1e-9, "{young}");
        let v = scintillation_variance(1.0, 1.0, 1.0, 0.0, 1.0);
        assert!((v - 1e-5).abs() < 1e-18, "{v}");
        assert!((young / v - 0.8725).abs() < 1e-3);
        // C_Y^2, D^(-4/3), 1/t, X^3, exp(-2h/H), each alone.
        let base = scintillation_variance(1.5, 0.5, 1.5, 2400.0, 10.0);
        let ratio = |v: f64| v / base;
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12 * b.abs().max(1.0);
        assert!(close(
            ratio(scintillation_variance(3.0, 0.5, 1.5, 2400.0, 10.0)),
            4.0
        ));
        assert!(close(
            ratio(scintillation_variance(1.5, 1.0, 1.5, 2400.0, 10.0)),
            0.5f64.powf(4.0 / 3.0)
        ));
        assert!(close(
            ratio(scintillation_variance(1.5, 0.5, 3.0, 2400.0, 10.0)),
            8.0
        ));
        assert!(close(
            ratio(scintillation_variance(1.5, 0.5, 1.5, 0.0, 10.0)),
            0.6f64.exp()
        ));
        assert!(close(
            ratio(scintillation_variance(1.5, 0.5, 1.5, 2400.0, 40.0)),
            0.25
        ));
    }

    #[test]
    fn scintillation_factor_is_lognormal_of_mean_one() {
        // The median (g = 0) is exp(-s^2/2); the mean over a fine normal quadrature is 1 and
        // the relative variance is the one asked.
        let var = 0.04;
        let (n, lo, hi) = (20_000, -10.0, 10.0);
        let dg = (hi - lo) / f64::from(n);
        let (mut m1, mut m2) = (0.0, 0.0);
        for i in 0..n {
            let g = lo + (f64::from(i) + 0.5) * dg;
            let w = (-g * g / 2.0).exp() / (2.0 * PI).sqrt() * dg;
            let f = scintillation_factor(var, g);
            m1 += w * f;
            m2 += w * f * f;
        }
        // Midpoint rule on a smooth integrand: exact to 1e-10 here.
        assert!((m1 - 1.0).abs() < 1e-9, "{m1}");
        assert!((m2 - m1 * m1 - var).abs() < 1e-9, "{}", m2 - m1 * m1);
        assert_eq!(scintillation_factor(0.0, 1.7), 1.0);
    }
}
