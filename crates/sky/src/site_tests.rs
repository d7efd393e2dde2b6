use super::*;
use crate::apparent::{aberrate, retarded_position};
use crate::orbit::Propagator;
use crate::testing::{arcsec_between, catalog};
use crate::{norm, radec_unit, sub, unit};

/// ((lat, lon, height m), catalogue index, UTC, site GCRS km, km/s, apparent (ra, dec),
/// geometric (alt, az), refracted alt).
type SiteCase = (
    (f64, f64, f64),
    usize,
    &'static str,
    Vec3,
    Vec3,
    (f64, f64),
    (f64, f64),
    f64,
);

include!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/fixtures/sky/site.rs"
));

fn when(utc: &str) -> Epoch {
    format!("{utc} UTC").parse().unwrap()
}

/// The debris' GCRS position and velocity from soig's own SGP4 and TEME -> GCRS.
fn debris_gcrs(p: &Propagator, t: Epoch) -> (Vec3, Vec3) {
    let (r, v) = p.state_teme(t).unwrap();
    let m = teme_to_gcrs_matrix(t);
    (mat_vec(&m, r), mat_vec(&m, v))
}

#[test]
fn site_state_matches_astropy() {
    let (mut worst_r, mut worst_v): (f64, f64) = (0.0, 0.0);
    for ((lat, lon, h), _, utc, r_ref, v_ref, ..) in SITE_REFERENCE {
        let site = Site {
            lat_deg: *lat,
            lon_deg: *lon,
            height_m: *h,
        };
        let (r, v) = site.gcrs_state(when(utc));
        worst_r = worst_r.max(norm(sub(r, *r_ref)));
        worst_v = worst_v.max(norm(sub(v, *v_ref)));
    }
    eprintln!(
        "site GCRS: max {:.3} m, {:.3} mm/s from astropy",
        worst_r * 1e3,
        worst_v * 1e6
    );
    // IAU-76/80 + GMST82 vs astropy's IAU 2006/2000A + ERA: the 0.033 arcsec of TEME -> GCRS
    // (frames.rs) is 1 m at the Earth's radius; 2 m bounds it.
    assert!(worst_r < 2e-3, "{} m", worst_r * 1e3);
    // 0.47 km/s turned by the same 0.03 arcsec is 0.1 mm/s; 1 mm/s bounds it.
    assert!(worst_v < 1e-6, "{} mm/s", worst_v * 1e6);
}

/// The object's apparent place seen from the site (GCRS axes: light-time, then aberration by
/// the site's GCRS velocity) and its geometric altitude and azimuth, within 1 arcsec of
/// astropy + python-sgp4 at three latitudes, LEO and GEO.
#[test]
fn apparent_place_and_horizon_match_astropy() {
    let tles = catalog();
    let (mut worst_radec, mut worst_alt, mut worst_az): (f64, f64, f64) = (0.0, 0.0, 0.0);
    let mut latitudes = Vec::new();
    for ((lat, lon, h), k, utc, _, _, (ra, dec), (alt, az), _) in SITE_REFERENCE {
        let site = Site {
            lat_deg: *lat,
            lon_deg: *lon,
            height_m: *h,
        };
        let t = when(utc);
        let p = Propagator::from_tle(&tles[*k]).unwrap();
        let (obs, obs_v) = site.gcrs_state(t);
        let (deb, deb_v) = debris_gcrs(&p, t);
        let (seen, _) = retarded_position(obs, deb, deb_v);
        let apparent = aberrate(unit(sub(seen, obs)), obs_v);
        worst_radec = worst_radec.max(arcsec_between(apparent, radec_unit(*ra, *dec)));
        let (a, z) = site.alt_az_deg(t, sub(deb, obs));
        worst_alt = worst_alt.max((a - alt).abs() * 3600.0);
        worst_az = worst_az.max(
            ((z - az + 180.0).rem_euclid(360.0) - 180.0).abs() * 3600.0 * alt.to_radians().cos(),
        );
        // alt_az and direction_of invert each other.
        let back = site.direction_of(t, a, z);
        assert!(arcsec_between(back, sub(deb, obs)) < 1e-6);
        if !latitudes.contains(lat) {
            latitudes.push(*lat);
        }
    }
    eprintln!(
        "site apparent places: max {worst_radec:.4} arcsec (ra/dec), {worst_alt:.1e} alt, {worst_az:.1e} az cos(alt)"
    );
    assert_eq!(latitudes.len(), 3);
    // The 1 arcsec. Measured a few hundredths: the site's ~1 m from astropy's (above)
    // seen from 1000-3000 km is ~0.1-0.2 arcsec at most, the rest is sub-mas.
    assert!(worst_radec < 1.0, "{worst_radec} arcsec");
    assert!(worst_alt < 1.0, "{worst_alt} arcsec");
    assert!(worst_az < 1.0, "{worst_az} arcsec");
}

/// Saemundsson's lift against ERFA `refco` (astropy's AltAz at 1010 hPa, 10 C, dry, 0.55 um),
/// a different model of the same air, above 20 deg.
#[test]
fn refraction_matches_erfa_refco() {
    let (mut worst, mut worst_rel): (f64, f64) = (0.0, 0.0);
    for (_, _, _, _, _, _, (alt, _), refracted) in SITE_REFERENCE {
        let lift = refraction_deg(*alt, STANDARD_PRESSURE_HPA, STANDARD_TEMPERATURE_C);
        let refco = refracted - alt;
        worst = worst.max((lift - refco).abs() * 3600.0);
        worst_rel = worst_rel.max((lift / refco - 1.0).abs());
    }
    eprintln!(
        "refraction: max {worst:.2} arcsec, {:.1} % of the lift from ERFA refco",
        worst_rel * 100.0
    );
    // Saemundsson's curve (fitted to Bennett's, whose air is not refco's dry air at 0.55 um)
    // lifts 3.8-4.8 % more than refco here (measured: 6.6 arcsec at 20 deg, 2.6 at 47 deg):
    // the spread between published models, far above the 1 arcsec of the placement, which
    // is why soig's truth is given unrefracted and the lift apart. 6 % and 8 arcsec bound it.
    assert!(worst_rel < 0.06, "{worst_rel}");
    assert!(worst < 8.0, "{worst} arcsec");
}

/// Saemundsson's formula at hand-computed points: 1.02' cot(10.3/5.11 deg) = 28.98' for a body
/// on the true horizon, ~59" at 45 deg, none at the zenith; linear in pressure.
#[test]
fn refraction_follows_saemundsson() {
    let r0 = refraction_deg(0.0, STANDARD_PRESSURE_HPA, STANDARD_TEMPERATURE_C) * 60.0;
    // 1.02 cot(10.3 / 5.11 deg) = 28.98'.
    assert!((r0 - 28.98).abs() < 0.01, "{r0}'");
    assert!(refraction_deg(90.0, 1010.0, 10.0).abs() < 1e-4 / 3600.0);
    let r45 = refraction_deg(45.0, STANDARD_PRESSURE_HPA, STANDARD_TEMPERATURE_C) * 3600.0;
    // ~58-60" at 45 deg in standard air.
    assert!((r45 - 59.0).abs() < 2.0, "{r45}\"");
    // Half the pressure, half the lift; below the horizon none.
    let half = refraction_deg(45.0, 505.0, 10.0) * 3600.0;
    assert!((half - r45 / 2.0).abs() < 1e-9);
    assert_eq!(refraction_deg(-5.0, 1010.0, 10.0), 0.0);
}

/// The sidereal day: the site comes back to its place after 86164.0905 s of UT1.
#[test]
fn site_turns_once_a_sidereal_day() {
    let site = Site {
        lat_deg: 28.76,
        lon_deg: -17.88,
        height_m: 2396.0,
    };
    let t = Epoch::from_gregorian_utc_hms(2022, 1, 22, 0, 0, 0);
    let (r0, v0) = site.gcrs_state(t);
    let (r1, _) = site.gcrs_state(t + 86_164.090_5 * Unit::Second);
    // Precession moves the equinox 50.3 arcsec a year, 0.138 arcsec a day: 4.3 m on the
    // Earth's radius (measured 4.07 m at 28.8 deg).
    assert!(norm(sub(r0, r1)) < 5e-3, "{} m", norm(sub(r0, r1)) * 1e3);
    // 465 m/s cos(lat) at the equator's rate.
    let fixed = site.itrs_km();
    let expect = EARTH_RATE_RAD_S * fixed[0].hypot(fixed[1]);
    // The rotation alone: equal to f64 rounding.
    assert!(
        (norm(v0) - expect).abs() < 1e-12,
        "{} vs {expect}",
        norm(v0)
    );
}

/// A direction fixed in altitude and azimuth turns about `stare_axis` at its rate: after 600 s
/// the rotated direction and the one `direction_of` gives agree.
#[test]
fn a_stare_turns_about_the_pole() {
    let site = Site {
        lat_deg: -31.27,
        lon_deg: 149.06,
        height_m: 1165.0,
    };
    let t0 = Epoch::from_gregorian_utc_hms(2022, 1, 22, 12, 0, 0);
    let (axis, rate_deg_s) = site.stare_axis(t0);
    for (alt, az) in [(45.0, 0.0), (50.0, 350.0), (80.0, 120.0)] {
        let d0 = site.direction_of(t0, alt, az);
        for dt in [60.0, 600.0] {
            let d1 = site.direction_of(t0 + dt * Unit::Second, alt, az);
            let turned = crate::rotate(d0, axis, (rate_deg_s * dt).to_radians());
            // Precession and nutation move the pole by < 1e-3 arcsec in 600 s.
            assert!(
                arcsec_between(turned, d1) < 1e-3,
                "{}",
                arcsec_between(turned, d1)
            );
        }
    }
}
