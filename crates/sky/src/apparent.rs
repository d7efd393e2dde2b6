//! Apparent places: where a moving observer sees a source. Light-time for the debris (its
//! position at t - range/c, seen from the observer at t) and special-relativistic aberration.
//!
//! Stars are aberrated by the observer's barycentric velocity (the Earth's annual motion,
//! ~30 km/s, plus the observer's orbital GCRS velocity, ~7.5 km/s). The debris is not: light-
//! time is solved in the GCRS, which moves with the Earth, so only the observer's GCRS velocity
//! aberrates it (adding the annual motion would move it by ~20 arcsec from where a real frame
//! shows it against its stars). An image's WCS is the catalogue frame (as a plate solution
//! gives it): there the stars keep their catalogue places and the debris sits at
//! [`debris_in_catalogue_frame`], its apparent direction with the stars' aberration taken out.
//! Gravitational light deflection (< 0.02 arcsec more than 20 deg from the Sun) is left out.

use hifitime::{Duration, Epoch};

use super::ephemeris::sun_position_km;
use super::{Vec3, dot, scale, sub, unit};

/// Speed of light, km/s.
pub const C_KM_S: f64 = 299_792.458;

/// Half-step of the central difference of the Sun's position, s: its curvature error is
/// ~(omega h)^2 / 6 ~ 1e-12 of the velocity, and rounding ~1e-11 km/s.
const VELOCITY_STEP_S: f64 = 60.0;

/// The Earth's barycentric velocity, km/s, GCRS axes: minus the rate of the geocentric Sun of
/// [`sun_position_km`] (Meeus' series with the Earth-Moon barycentre offset). That is the
/// heliocentric velocity; the Sun's own barycentric motion (<= 0.016 km/s, 0.011 arcsec of
/// aberration) is left out.
pub fn earth_velocity_km_s(t: Epoch) -> Vec3 {
    let h = Duration::from_seconds(VELOCITY_STEP_S);
    let (a, b) = (sun_position_km(t - h), sun_position_km(t + h));
    scale(sub(b, a), -1.0 / (2.0 * VELOCITY_STEP_S))
}

/// The direction in which an observer moving at `velocity_km_s` sees a source whose direction
/// at rest is the unit vector `u` (special relativity, as ERFA `ab` without light deflection).
pub fn aberrate(u: Vec3, velocity_km_s: Vec3) -> Vec3 {
    let b = scale(velocity_km_s, 1.0 / C_KM_S);
    let inv_gamma = (1.0 - dot(b, b)).sqrt();
    let ub = dot(u, b);
    let k = 1.0 + ub / (1.0 + inv_gamma);
    unit([
        inv_gamma * u[0] + k * b[0],
        inv_gamma * u[1] + k * b[1],
        inv_gamma * u[2] + k * b[2],
    ])
}

/// The rest direction that [`aberrate`] turns into `apparent` (a fixed-point iteration: the
/// first step leaves ~(v/c)^2 ~ 1e-8, each next one multiplies it by ~v/c).
pub fn unaberrate(apparent: Vec3, velocity_km_s: Vec3) -> Vec3 {
    let mut u = apparent;
    for _ in 0..3 {
        let miss = sub(apparent, aberrate(u, velocity_km_s));
        u = unit([u[0] + miss[0], u[1] + miss[1], u[2] + miss[2]]);
    }
    u
}

/// Light-time: where the observer at `observer_km` sees a body that is at `body_km` moving at
/// `body_km_s` now, i.e. its position at t - tau with tau = |r(t - tau) - observer| / c, the
/// motion taken as uniform over tau (the exact root of that quadratic). The acceleration left
/// out moves it by a tau^2 / 2: 0.04 mm for LEO debris (8 m/s^2, tau ~ 3 ms, which itself
/// moves it ~20 m), 2 mm at GEO ranges (0.2 m/s^2, 0.13 s). Returns the position and tau, s.
pub fn retarded_position(observer_km: Vec3, body_km: Vec3, body_km_s: Vec3) -> (Vec3, f64) {
    let d = sub(body_km, observer_km);
    // (v.v - c^2) tau^2 - 2 (d.v) tau + d.d = 0: a < 0 < c, so one positive root.
    let a = dot(body_km_s, body_km_s) - C_KM_S * C_KM_S;
    let b = -2.0 * dot(d, body_km_s);
    let c = dot(d, d);
    let tau = (-b - (b * b - 4.0 * a * c).sqrt()) / (2.0 * a);
    (sub(body_km, scale(body_km_s, tau)), tau)
}

/// The debris direction in an image's catalogue frame: the light-time line of sight `los`
/// aberrated by the observer's GCRS velocity (what the observer sees), then the stars'
/// aberration (the observer's barycentric velocity) taken out, as a plate solution against
/// catalogue stars does.
pub fn debris_in_catalogue_frame(los: Vec3, observer_gcrs_km_s: Vec3, earth_km_s: Vec3) -> Vec3 {
    let barycentric = [
        observer_gcrs_km_s[0] + earth_km_s[0],
        observer_gcrs_km_s[1] + earth_km_s[1],
        observer_gcrs_km_s[2] + earth_km_s[2],
    ];
    unaberrate(aberrate(unit(los), observer_gcrs_km_s), barycentric)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{angle_deg, norm, radec_unit};

    const ARCSEC_DEG: f64 = 1.0 / 3600.0;

    /// (UTC, observer position, observer velocity, ICRS (ra, dec), apparent (ra, dec), Earth
    /// velocity).
    type StarCase = (&'static str, Vec3, Vec3, (f64, f64), (f64, f64), Vec3);

    /// Figures printed by `tests/reference/apparent_reference.py` (astropy 8.0.2, pyerfa
    /// 2.0.1.5, bundled IERS tables): UTC instant, observer GCRS position (km) and velocity
    /// (km/s), ICRS (ra, dec) of a star, its apparent (ra, dec) in astropy's
    /// `GCRS(obstime, obsgeoloc, obsgeovel)`; and the Earth's barycentric velocity (km/s,
    /// ERFA `epv00`) at that instant.
    #[rustfmt::skip]
    const STARS: [StarCase; 6] = [
    ("2022-01-01T00:00:00", [7000.0, 0.0, 0.0], [-0.0, 3.77302664505, 6.53507384754], (100.0, 23.0), (100.006139965538, 23.000472196459), [-29.8179417798, -4.96973701764, -2.1527015784]),
    ("2022-03-20T15:33:00", [4.28626379702e-13, 3500.0, 6062.17782649], [-7.54605329011, 2.31031250198e-16, 4.00157863479e-16], (90.0, 0.0), (90.001567887539, -0.002273146617), [-0.651417048068, -27.4393853726, -11.8934018981]),
    ("2022-06-21T09:13:00", [-6577.8483455, -1197.07050164, -2073.38692908], [2.58090222783, -3.54548529639, -6.14096067083], (270.0, -66.0), (270.014980405484, -65.999818637540), [29.3009486862, -0.27396066864, -0.119471690295]),
    ("2022-09-23T01:03:00", [3500.0, -3031.08891325, -5250.0], [6.53507384754, 1.88651332253, 3.26753692377], (1.0, -5.0), (1.005562732345, -4.997019017635), [-0.318236414203, 27.2223673806, 11.8011317997]),
    ("2022-12-21T21:48:00", [4949.74746831, 2474.87373415, 4286.60704987], [-5.33586545263, 2.66793272632, 4.62099503315], (45.0, 89.5), (45.598812679527, 89.504428350277), [-30.2829113083, 0.0339926661459, 0.0161291007919]),
    ("2024-08-26T17:45:45", [-4499.51326781, 2681.15555092, 4643.89763718], [-5.78061219037, -2.42525477846, -4.20066449759], (310.0, -30.0), (310.004294793075, -30.000123966767), [12.7669571564, 24.3727780587, 10.5643508934]),
    ];

    #[test]
    fn star_places_match_astropy() {
        for (utc, _pos, vel, (ra, dec), (ra_app, dec_app), v_earth) in STARS {
            let t: Epoch = format!("{utc} UTC").parse().unwrap();
            let ve = earth_velocity_km_s(t);
            // Measured 0.015-0.017 km/s: the Sun's barycentric motion left out (<= 0.016 km/s)
            // plus Meeus' rate error (its Sun is within 16 arcsec: ~1e-4 of 30 km/s).
            assert!(
                norm(sub(ve, v_earth)) < 0.025,
                "{utc}: {ve:?} vs {v_earth:?}"
            );
            let v = [vel[0] + ve[0], vel[1] + ve[1], vel[2] + ve[2]];
            let got = aberrate(radec_unit(ra, dec), v);
            let miss = angle_deg(got, radec_unit(ra_app, dec_app));
            // 0.025 km/s of velocity is 0.017 arcsec; astropy's light deflection by the Sun
            // adds up to 0.011 arcsec at these elongations (> 40 deg): 0.03 bounds both
            // (measured 0.004-0.010 arcsec).
            assert!(miss < 0.03 * ARCSEC_DEG, "{utc}: {} arcsec", miss * 3600.0);
            // The shift itself is the ~20-25 arcsec of annual plus orbital aberration.
            let shift = angle_deg(got, radec_unit(ra, dec)) * 3600.0;
            assert!(shift > 1.0, "{utc}: {shift}");
        }
    }

    #[test]
    fn unaberrate_inverts_aberrate() {
        let v = [-25.0, 18.0, 7.5];
        for (ra, dec) in [(0.0, 0.0), (123.0, -45.0), (300.0, 89.9)] {
            let u = radec_unit(ra, dec);
            let back = unaberrate(aberrate(u, v), v);
            // f64 rounding of unit vectors: ~1e-16 rad = 2e-11 arcsec.
            assert!(angle_deg(back, u) < 1e-9 * ARCSEC_DEG);
        }
    }

    /// A body in uniform motion seen from the origin: the light-time solves its defining
    /// equation |r(t - tau)| = c tau, found here by iterating it.
    #[test]
    fn light_time_of_uniform_motion_solves_its_equation() {
        let (r0, w) = ([700.0, -300.0, 450.0], [-7.2, 1.1, 3.0]);
        let (r, tau) = retarded_position([0.0; 3], r0, w);
        let at = |d: f64| [r0[0] - w[0] * d, r0[1] - w[1] * d, r0[2] - w[2] * d];
        let mut iterated = 0.0;
        for _ in 0..6 {
            iterated = norm(at(iterated)) / C_KM_S;
        }
        // Both at f64 rounding of tau (~1e-19 s).
        assert!((tau - iterated).abs() < 1e-15, "{tau} vs {iterated}");
        assert!((norm(r) - C_KM_S * tau).abs() < 1e-9);
        assert!(norm(sub(r, at(iterated))) < 1e-9);
        // 885 km at 7.9 km/s: 3 ms and ~23 m along the track.
        assert!((tau - norm(r0) / C_KM_S).abs() < 1e-6);
        assert!(
            (norm(sub(r, r0)) - 0.0233).abs() < 0.001,
            "{}",
            norm(sub(r, r0))
        );
    }

    /// The debris co-moves with the Earth: against the stars it moves by the stars' annual
    /// aberration, not its own (v_earth ~30 km/s perpendicular: 20.6 arcsec).
    #[test]
    fn debris_shifts_against_the_stars_by_the_annual_aberration() {
        let los = [1000.0, 0.0, 0.0];
        let v_obs = [0.0, 7.5, 0.0];
        let v_earth = [0.0, 0.0, 30.0];
        let got = debris_in_catalogue_frame(los, v_obs, v_earth);
        let shift = angle_deg(got, unit(los)) * 3600.0;
        let annual = (30.0 / C_KM_S).asin().to_degrees() * 3600.0;
        // Second-order (v/c)^2 terms: ~1e-8 rad = 0.002 arcsec.
        assert!((shift - annual).abs() < 0.005, "{shift} vs {annual}");
        // Away from the Earth's motion, towards -z.
        assert!(got[2] < 0.0);
    }
}
