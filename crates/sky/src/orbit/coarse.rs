//! A cheap stand-in for SGP4, to cull a large population (a catalogue scene's `candidates`):
//! the two-body ellipse of the Brouwer mean elements with the first-order secular J2 drifts of
//! node, perigee and mean anomaly (SGP4's own secular rates, without drag, short-period or
//! deep-space terms), solved by Kepler's equation: about a tenth of an SGP4 call. What it
//! leaves out is measured against SGP4 over the span it will serve (`error_km`), so a test built
//! on it can widen itself by that much and lose nothing.

use hifitime::Epoch;

use super::Propagator;
use super::propagate::{EARTH_RADIUS_KM, MU_KM3_S2};
use crate::{Vec3, norm, sub};

/// WGS72 J2, as SGP4.
const J2: f64 = 0.001_082_616;

/// Instants over its span at which a coarse orbit is measured against SGP4.
const CALIBRATION_POINTS: usize = 17;

/// One object's cheap orbit, valid over a span with a measured error.
#[derive(Clone, Debug)]
pub struct CoarseOrbit {
    /// The TLE epoch, TAI seconds (`seconds`).
    epoch_s: f64,
    a_km: f64,
    e: f64,
    sqrt_1_e2: f64,
    cos_i: f64,
    sin_i: f64,
    /// Node, argument of perigee and mean anomaly at the epoch (rad) and their rates (rad/s).
    raan: (f64, f64),
    argp: (f64, f64),
    mean_anomaly: (f64, f64),
    /// The largest speed on the ellipse (at perigee), km/s.
    pub speed_max_km_s: f64,
    /// The largest distance from SGP4 measured over the span, km (infinite when SGP4 fails
    /// somewhere in it: the object must then be judged exactly).
    pub error_km: f64,
}

/// An instant as TAI seconds, the time scale of [`CoarseOrbit::position_teme_km`].
pub fn seconds(t: Epoch) -> f64 {
    t.to_tai_seconds()
}

impl CoarseOrbit {
    /// The coarse orbit of `p`, measured against SGP4 at evenly spaced instants of `span`.
    pub fn new(p: &Propagator, (start, end): (Epoch, Epoch)) -> CoarseOrbit {
        let m = &p.mean;
        let n = m.mean_motion / 60.0;
        let a_km = (MU_KM3_S2 / (n * n)).cbrt();
        let e = m.eccentricity;
        let (sin_i, cos_i) = m.inclination.sin_cos();
        let sqrt_1_e2 = (1.0 - e * e).sqrt();
        let p_er = a_km / EARTH_RADIUS_KM * (1.0 - e * e);
        let k = J2 / (p_er * p_er) * n;
        let mut orbit = CoarseOrbit {
            epoch_s: seconds(p.epoch()),
            a_km,
            e,
            sqrt_1_e2,
            cos_i,
            sin_i,
            raan: (m.right_ascension, -1.5 * k * cos_i),
            argp: (
                m.argument_of_perigee,
                0.75 * k * (5.0 * cos_i * cos_i - 1.0),
            ),
            mean_anomaly: (
                m.mean_anomaly,
                n + 0.75 * k * sqrt_1_e2 * (3.0 * cos_i * cos_i - 1.0),
            ),
            speed_max_km_s: (MU_KM3_S2 * (1.0 + e) / (a_km * (1.0 - e))).sqrt(),
            error_km: 0.0,
        };
        let span_s = (end - start).to_seconds();
        let step_s = span_s / (CALIBRATION_POINTS - 1) as f64;
        orbit.error_km = (0..CALIBRATION_POINTS)
            .map(|k| {
                let t = start + hifitime::Duration::from_seconds(k as f64 * step_s);
                match p.position_teme_km(t) {
                    Ok(r) => norm(sub(r, orbit.position_teme_km(seconds(t)))),
                    Err(_) => f64::INFINITY,
                }
            })
            .fold(0.0, f64::max);
        orbit
    }

    /// TEME position, km, at `t_s` (`seconds`).
    pub fn position_teme_km(&self, t_s: f64) -> Vec3 {
        let dt = t_s - self.epoch_s;
        let m = self.mean_anomaly.0 + self.mean_anomaly.1 * dt;
        let e = self.e;
        // Kepler's equation by Newton's method from E = M (+ e for high eccentricities).
        let mut big_e = if e > 0.8 { std::f64::consts::PI } else { m };
        for _ in 0..20 {
            let (s, c) = big_e.sin_cos();
            let step = (big_e - e * s - m) / (1.0 - e * c);
            big_e -= step;
            // 1e-10 rad is a micrometre at the GEO radius.
            if step.abs() < 1e-10 {
                break;
            }
        }
        let (s, c) = big_e.sin_cos();
        let (x, y) = (self.a_km * (c - e), self.a_km * self.sqrt_1_e2 * s);
        let (so, co) = (self.raan.0 + self.raan.1 * dt).sin_cos();
        let (sw, cw) = (self.argp.0 + self.argp.1 * dt).sin_cos();
        let (ci, si) = (self.cos_i, self.sin_i);
        [
            (co * cw - so * sw * ci) * x - (co * sw + so * cw * ci) * y,
            (so * cw + co * sw * ci) * x + (co * cw * ci - so * sw) * y,
            sw * si * x + cw * si * y,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::orbit::parse_tles;

    /// Over a day from the epoch the cheap orbit of each catalogue object stays within tens
    /// of km of SGP4 (short-period J2 terms and drag), and its measured error says so.
    #[test]
    fn coarse_orbits_follow_sgp4_within_their_measured_error() {
        let text = include_str!("../../../../campaigns/data/catalog-2022-01-22.tle");
        for tle in parse_tles(text).unwrap() {
            let p = Propagator::from_tle(&tle).unwrap();
            let start = p.epoch();
            let end = start + hifitime::Duration::from_seconds(86_400.0);
            let c = CoarseOrbit::new(&p, (start, end));
            // Measured: 14 to 19 km for these five (LEO to GEO transfer): under 100 km.
            assert!(c.error_km < 100.0, "{}: {} km", tle.norad_id, c.error_km);
            // Between the calibration instants the error stays within twice the measured one
            // plus 20 km (the margin `candidates` allows).
            for k in 0..200 {
                let t = start + hifitime::Duration::from_seconds(k as f64 * 432.0 + 17.0);
                let d = norm(sub(
                    p.position_teme_km(t).unwrap(),
                    c.position_teme_km(seconds(t)),
                ));
                assert!(
                    d <= 2.0 * c.error_km + 20.0,
                    "{}: {d} km at {k}",
                    tle.norad_id
                );
            }
        }
    }
}
