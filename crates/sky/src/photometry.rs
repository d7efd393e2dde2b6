//! Debris brightness (paper Eq. 6-7) and photon rates (Eq. 3 with the zero-point convention of
//! physics.md).

/// Apparent magnitude of the Sun used by Eq. 6.
pub const SUN_MAG: f64 = -26.7;

/// Diffuse-sphere phase function, Eq. 7: F = 2/(3 pi^2) [(pi - phi) cos phi + sin phi].
pub fn diffuse_sphere_phase(phase_rad: f64) -> f64 {
    let phi = phase_rad.clamp(0.0, std::f64::consts::PI);
    2.0 / (3.0 * std::f64::consts::PI.powi(2))
        * ((std::f64::consts::PI - phi) * phi.cos() + phi.sin())
}

/// Eq. 6: m = -26.7 - 2.5 log10(A rho F(phi)) + 5 log10(r), A in m^2, r in m.
/// Towards phase 180 deg F -> 0 and the magnitude grows without bound (+infinity when F <= 0).
pub fn debris_magnitude(area_m2: f64, albedo: f64, phase_rad: f64, range_km: f64) -> f64 {
    let f = diffuse_sphere_phase(phase_rad);
    let reflect = area_m2 * albedo * f;
    if reflect <= 0.0 {
        return f64::INFINITY;
    }
    SUN_MAG - 2.5 * reflect.log10() + 5.0 * (range_km * 1000.0).log10()
}

/// Photo-electrons per second of a source of magnitude `mag` for a sensor whose zero point
/// (magnitude of 1 e-/s) is `zero_point_mag`: the paper's Eq. 3 in SPIMT's convention,
/// `10^(-0.4 (m - 25 + 2.74))` with 25 - 2.74 = 22.26.
pub fn photon_rate(mag: f64, zero_point_mag: f64) -> f64 {
    10f64.powf(-0.4 * (mag - zero_point_mag))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phase_function_limits() {
        assert!((diffuse_sphere_phase(0.0) - 2.0 / (3.0 * std::f64::consts::PI)).abs() < 1e-15);
        assert!(diffuse_sphere_phase(std::f64::consts::PI).abs() < 1e-15);
        // Monotone decreasing.
        let mut last = f64::INFINITY;
        for i in 0..=180 {
            let f = diffuse_sphere_phase((i as f64).to_radians());
            assert!(f <= last + 1e-15);
            last = f;
        }
    }

    #[test]
    fn magnitude_and_rate() {
        // 1 m^2 at 1000 km, phase 90 deg: F = 2/(3 pi^2) = 0.06755; m = -26.7 + 2.9258 + 30 = 6.2258
        let m = debris_magnitude(1.0, 1.0, std::f64::consts::FRAC_PI_2, 1000.0);
        assert!(
            (m - (-26.7 - 2.5 * (2.0 / (3.0 * std::f64::consts::PI.powi(2))).log10() + 30.0)).abs()
                < 1e-12
        );
        assert!((m - 6.2258).abs() < 1e-3);
        assert!(debris_magnitude(1.0, 1.0, std::f64::consts::PI, 1000.0) > 40.0);
        assert!(debris_magnitude(0.0, 1.0, 1.0, 1000.0).is_infinite());
        // Zero point: magnitude 22.26 gives 1 e-/s; 5 magnitudes brighter gives 100.
        assert!((photon_rate(22.26, 22.26) - 1.0).abs() < 1e-12);
        assert!((photon_rate(17.26, 22.26) - 100.0).abs() < 1e-9);
    }
}
