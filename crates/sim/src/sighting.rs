//! Where the observer sees the debris: the geometric line of sight (the paper's model), or with
//! `apparent` the debris' light-time position seen through the observer's aberration, in the
//! image's catalogue frame (`sky::apparent`); and the ephemeris the truth sidecar records.

use hifitime::{Duration, Epoch};
use serde::Serialize;

use soig_sky::apparent::{debris_in_catalogue_frame, earth_velocity_km_s, retarded_position};
use soig_sky::frames::teme_to_gcrs_matrix;
use soig_sky::orbit::Propagator;
use soig_sky::{Mat3, Vec3, mat_vec, radec_deg, sub};

use crate::observer::Viewpoint;

/// The observer and the debris at one instant, GCRS km, and the debris direction in the image
/// frame (not normalised).
#[derive(Clone, Copy, Debug)]
pub struct Sight {
    pub observer_km: Vec3,
    /// At the emission time when light-time is on.
    pub debris_km: Vec3,
    pub direction: Vec3,
}

/// The debris' place and the two bodies' states at mid-exposure, for the truth sidecar.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Ephemeris {
    /// Debris (RA, Dec), degrees, at the start, middle and end of the exposure, in the frame of
    /// the image's WCS: geometric, or with `render.apparent_positions` light-time corrected and
    /// aberrated, in the catalogue frame of the stars.
    pub debris_radec_start_deg: [f64; 2],
    pub debris_radec_mid_deg: [f64; 2],
    pub debris_radec_end_deg: [f64; 2],
    /// Geometric GCRS positions (km) and velocities (km/s) at mid-exposure.
    pub observer_gcrs_km: Vec3,
    pub observer_gcrs_km_s: Vec3,
    pub debris_gcrs_km: Vec3,
    pub debris_gcrs_km_s: Vec3,
}

/// Lines of sight over one exposure. The TEME -> GCRS rotation changes by far less than a
/// milliarcsecond over an exposure, so one matrix (at mid-exposure) serves it all, and so does
/// one Earth velocity (it turns by 0.01 arcsec of aberration in 600 s).
pub struct Sighting<'a> {
    observer: &'a dyn Viewpoint,
    debris: &'a Propagator,
    teme_to_gcrs: Mat3,
    /// The Earth's barycentric velocity, km/s, when apparent places are on.
    earth_km_s: Option<Vec3>,
}

/// GCRS position (km) and velocity (km/s) of `body` at `t` through the TEME -> GCRS rotation
/// `teme_to_gcrs`; None if it cannot be propagated.
fn gcrs_state(teme_to_gcrs: &Mat3, body: &dyn Viewpoint, t: Epoch) -> Option<(Vec3, Vec3)> {
    let (r, v) = body.teme_state(t)?;
    let (r, v) = (mat_vec(teme_to_gcrs, r), mat_vec(teme_to_gcrs, v));
    r.iter()
        .chain(v.iter())
        .all(|x| x.is_finite())
        .then_some((r, v))
}

/// The observer's geometric GCRS state at mid-exposure `mid`, as every [`Ephemeris`] of that
/// exposure states it (`observer_gcrs_km`, `observer_gcrs_km_s`), for a frame with no object
/// of its own (a stare); None if it cannot be propagated.
pub fn observer_state_at_mid(observer: &dyn Viewpoint, mid: Epoch) -> Option<(Vec3, Vec3)> {
    gcrs_state(&teme_to_gcrs_matrix(mid), observer, mid)
}

impl<'a> Sighting<'a> {
    pub fn new(
        observer: &'a dyn Viewpoint,
        debris: &'a Propagator,
        mid: Epoch,
        apparent: bool,
    ) -> Self {
        Sighting {
            observer,
            debris,
            teme_to_gcrs: teme_to_gcrs_matrix(mid),
            earth_km_s: apparent.then(|| earth_velocity_km_s(mid)),
        }
    }

    /// The rotation from TEME to GCRS used for this exposure.
    pub fn teme_to_gcrs(&self) -> &Mat3 {
        &self.teme_to_gcrs
    }

    /// GCRS position (km) and velocity (km/s) of a body; None if it cannot be propagated.
    fn state(&self, body: &dyn Viewpoint, t: Epoch) -> Option<(Vec3, Vec3)> {
        gcrs_state(&self.teme_to_gcrs, body, t)
    }

    /// The axis and rate of a ground telescope's stare (`Viewpoint::stare_axis`).
    pub fn stare_axis(&self, t: Epoch) -> Option<(Vec3, f64)> {
        self.observer.stare_axis(t)
    }

    /// The observer's GCRS position (km) at `t`; None if it cannot be propagated.
    pub fn observer_km(&self, t: Epoch) -> Option<Vec3> {
        self.state(self.observer, t).map(|(r, _)| r)
    }

    /// The sight at `t`; None if either body cannot be propagated.
    pub fn at(&self, t: Epoch) -> Option<Sight> {
        let observer = self.state(self.observer, t)?;
        let debris = self.state(self.debris, t)?;
        Some(self.sight(observer, debris))
    }

    /// The sight from the two bodies' GCRS states (position km, velocity km/s).
    fn sight(&self, observer: (Vec3, Vec3), debris: (Vec3, Vec3)) -> Sight {
        let (observer_km, observer_km_s) = observer;
        let (debris_now_km, debris_km_s) = debris;
        let Some(earth_km_s) = self.earth_km_s else {
            return Sight {
                observer_km,
                debris_km: debris_now_km,
                direction: sub(debris_now_km, observer_km),
            };
        };
        let (debris_km, _) = retarded_position(observer_km, debris_now_km, debris_km_s);
        Sight {
            observer_km,
            debris_km,
            direction: debris_in_catalogue_frame(
                sub(debris_km, observer_km),
                observer_km_s,
                earth_km_s,
            ),
        }
    }

    /// The sights over an exposure from `start` lasting `exposure_s`, interpolated between
    /// the bodies' states at nodes (see `Track`); None if a node cannot be propagated.
    pub fn track(&self, start: Epoch, exposure_s: f64) -> Option<Track<'_>> {
        let segments = ((exposure_s / TRACK_NODE_SPACING_S).ceil() as usize).max(3);
        let step_s = exposure_s / segments as f64;
        let mut observer = Vec::with_capacity(segments + 1);
        let mut debris = Vec::with_capacity(segments + 1);
        for k in 0..=segments {
            let t = start + Duration::from_seconds(k as f64 * step_s);
            observer.push(self.state(self.observer, t)?);
            debris.push(self.state(self.debris, t)?);
        }
        Some(Track {
            sighting: self,
            step_s,
            observer,
            debris,
        })
    }

    /// The ephemeris of an exposure from `start` lasting `exposure_s`.
    pub fn ephemeris(&self, start: Epoch, exposure_s: f64) -> Option<Ephemeris> {
        let at = |f: f64| -> Option<[f64; 2]> {
            let s = self.at(start + Duration::from_seconds(f * exposure_s))?;
            let (ra, dec) = radec_deg(s.direction);
            Some([ra, dec])
        };
        let mid = start + Duration::from_seconds(exposure_s / 2.0);
        let (observer_gcrs_km, observer_gcrs_km_s) = self.state(self.observer, mid)?;
        let (debris_gcrs_km, debris_gcrs_km_s) = self.state(self.debris, mid)?;
        Some(Ephemeris {
            debris_radec_start_deg: at(0.0)?,
            debris_radec_mid_deg: at(0.5)?,
            debris_radec_end_deg: at(1.0)?,
            observer_gcrs_km,
            observer_gcrs_km_s,
            debris_gcrs_km,
            debris_gcrs_km_s,
        })
    }
}

/// Node spacing of a `Track`, seconds: at most this, and at least 3 segments per exposure (a
/// cubic needs 4 nodes).
const TRACK_NODE_SPACING_S: f64 = 5.0;

/// The sights over one exposure, from the two bodies' SGP4 states at nodes `step_s` apart
/// (exposure start and end included), each coordinate a cubic through the 4 nodes around the
/// time (the first or last 4 at the ends). A scene draw needs the sight at every trajectory
/// sample (2000 or more per attempt); SGP4 at each was two thirds of the draw, and the orbit
/// is smooth on these scales: a cubic through nodes h apart errs by at most
/// h^4 max|r''''| / 24, with |r''''| about w^4 r for an angular rate w: 1.2e-8 km/s^4 in a
/// 90 min circular orbit (0.3 mm at h = 5 s), 2.2e-8 at the perigee of the paper's Table 1
/// orbit (0.57 mm). Measured against SGP4 in `tests`: at most 0.44 mm, 4.1e-5 arcsec.
pub struct Track<'a> {
    sighting: &'a Sighting<'a>,
    step_s: f64,
    observer: Vec<(Vec3, Vec3)>,
    debris: Vec<(Vec3, Vec3)>,
}

impl Track<'_> {
    /// The sight `t_s` seconds after the exposure's start (within the exposure).
    pub fn at(&self, t_s: f64) -> Sight {
        let segments = self.observer.len() - 1;
        let u = if self.step_s > 0.0 {
            t_s / self.step_s
        } else {
            0.0
        };
        // The 4 nodes around u: i-1, i, i+1, i+2 where u lies in [i, i+1], kept in range.
        let first = (u.floor() as isize - 1).clamp(0, segments as isize - 3) as usize;
        let x = u - first as f64;
        // Lagrange weights of nodes 0, 1, 2, 3 (x counted in node steps from the first).
        let w = [
            -(x - 1.0) * (x - 2.0) * (x - 3.0) / 6.0,
            x * (x - 2.0) * (x - 3.0) / 2.0,
            -x * (x - 1.0) * (x - 3.0) / 2.0,
            x * (x - 1.0) * (x - 2.0) / 6.0,
        ];
        let at = |states: &[(Vec3, Vec3)]| {
            let (mut r, mut v) = ([0.0; 3], [0.0; 3]);
            for (wk, (rk, vk)) in w.iter().zip(&states[first..first + 4]) {
                for i in 0..3 {
                    r[i] += wk * rk[i];
                    v[i] += wk * vk[i];
                }
            }
            (r, v)
        };
        self.sighting.sight(at(&self.observer), at(&self.debris))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use soig_sky::apparent::C_KM_S;
    use soig_sky::orbit::OrbitalElements;
    use soig_sky::{angle_deg, dot, norm, scale, unit};

    /// Period (min) of a circular orbit at `altitude_km` (Kepler, WGS72).
    fn period(altitude_km: f64) -> f64 {
        std::f64::consts::TAU * ((6378.135 + altitude_km).powi(3) / 398_600.8).sqrt() / 60.0
    }

    /// An orbit of this period, (apogee, perigee) altitudes and (inclination, RAAN, mean
    /// anomaly) in degrees, at 2022-03-01.
    fn orbit_with(
        period_min: f64,
        apsides_km: (f64, f64),
        angles_deg: (f64, f64, f64),
        norad: u64,
    ) -> Propagator {
        let el = OrbitalElements {
            period_min,
            inclination_deg: angles_deg.0,
            apogee_km: apsides_km.0,
            perigee_km: apsides_km.1,
            raan_deg: angles_deg.1,
            arg_perigee_deg: 0.0,
            mean_anomaly_deg: angles_deg.2,
            epoch: Epoch::from_gregorian_utc_at_midnight(2022, 3, 1),
        };
        Propagator::from_elements(&el, norad).unwrap()
    }

    /// A circular-ish orbit at `altitude_km` (period by Kepler's law, WGS72).
    fn orbit(altitude_km: f64, inclination_deg: f64, raan_deg: f64, norad: u64) -> Propagator {
        let apsides = (altitude_km + 5.0, altitude_km - 5.0);
        orbit_with(
            period(altitude_km),
            apsides,
            (inclination_deg, raan_deg, 0.0),
            norad,
        )
    }

    /// Against the stars the debris moves by its own barycentric velocity times the light time
    /// over its range (planetary aberration): to first order in v/c the catalogue-frame direction
    /// is u - (v_debris + v_earth)_perp / c, an expectation built from the geometric states
    /// alone. Also: the ephemeris' velocities are the rates of its positions.
    #[test]
    fn apparent_debris_moves_by_its_own_velocity_times_light_time() {
        let (observer, debris) = (orbit(800.0, 98.6, 0.0, 1), orbit(1200.0, 60.0, 20.0, 2));
        for minutes in [3.0, 17.0, 41.0] {
            let t = Epoch::from_gregorian_utc_at_midnight(2022, 3, 1)
                + Duration::from_seconds(minutes * 60.0);
            let geometric = Sighting::new(&observer, &debris, t, false);
            let apparent = Sighting::new(&observer, &debris, t, true);
            let e = geometric.ephemeris(t, 0.0).unwrap();
            let u = unit(sub(e.debris_gcrs_km, e.observer_gcrs_km));
            let g = geometric.at(t).unwrap();
            assert!(angle_deg(g.direction, u) < 1e-12);
            let v = e.debris_gcrs_km_s;
            let ve = earth_velocity_km_s(t);
            let w = scale([v[0] + ve[0], v[1] + ve[1], v[2] + ve[2]], 1.0 / C_KM_S);
            let perp = sub(w, scale(u, dot(w, u)));
            let expected = unit(sub(u, perp));
            let got = unit(apparent.at(t).unwrap().direction);
            let shift = angle_deg(got, u) * 3600.0;
            let miss = angle_deg(got, expected) * 3600.0;
            // Second-order terms, (40 km/s / c)^2 ~ 2e-8 rad: 0.004 arcsec.
            assert!(
                miss < 0.005,
                "{minutes} min: {miss} arcsec of a {shift} arcsec shift"
            );
            assert!(shift > 1.0, "{shift}");

            // Light-time against the body propagated to t - tau, tau iterated: the uniform
            // motion over tau leaves a tau^2 / 2 (a < 0.01 km/s^2 in LEO) and SGP4's velocity
            // series errs by ~1e-5 km/s times tau (ranges here 1000-5000 km: tau 3-18 ms, 1.3
            // mm at most, 3e-10 rad).
            let sight = apparent.at(t).unwrap();
            let mut tau = 0.0;
            for _ in 0..4 {
                let d = geometric
                    .state(&debris, t - Duration::from_seconds(tau))
                    .unwrap()
                    .0;
                tau = norm(sub(d, sight.observer_km)) / C_KM_S;
            }
            let exact = geometric
                .state(&debris, t - Duration::from_seconds(tau))
                .unwrap()
                .0;
            let bound = 0.01 * tau * tau / 2.0 + 2e-5 * tau + 1e-9;
            assert!(norm(sub(sight.debris_km, exact)) < bound, "{tau}");
            assert!(norm(sub(sight.debris_km, e.debris_gcrs_km)) > 0.01);

            // Velocities against the central difference of positions: SGP4's velocity is its
            // own series, not exactly the rate of its positions (measured ~1.1e-5 km/s; the
            // difference itself errs by jerk h^2 / 6 ~ 4e-7 km/s): 1e-4 km/s, where a wrong
            // frame or unit would be off by km/s.
            let h = 0.5;
            let at = |dt: f64| {
                geometric
                    .ephemeris(t + Duration::from_seconds(dt), 0.0)
                    .unwrap()
            };
            let (a, b) = (at(-h), at(h));
            let rate = |p: Vec3, q: Vec3| scale(sub(q, p), 1.0 / (2.0 * h));
            let ob = rate(a.observer_gcrs_km, b.observer_gcrs_km);
            let db = rate(a.debris_gcrs_km, b.debris_gcrs_km);
            assert!(norm(sub(ob, e.observer_gcrs_km_s)) < 1e-4);
            assert!(norm(sub(db, e.debris_gcrs_km_s)) < 1e-4);
        }
    }

    /// A track against SGP4 at 401 times of each exposure (0.5 s to 600 s), geometric and
    /// apparent, for debris in a 300 km orbit, 60-100 km from the observer, and in the paper's
    /// Table 1 orbit at its perigee (deep space). Measured: at most 0.44 mm and 4.1e-5 arcsec
    /// (6e-5 px of 0.7"), as the h^4 bound predicts; asserted: 1 mm and 1e-4 arcsec, where a
    /// wrong node, weight or time would be off by metres.
    #[test]
    fn track_follows_sgp4_to_a_millimetre() {
        let observer = orbit(800.0, 98.6, 0.0, 1);
        let cases = [
            orbit_with(period(300.0), (305.0, 295.0), (51.6, 10.0, 20.0), 2),
            orbit_with(period(810.0), (815.0, 805.0), (98.6, 0.5, 0.7), 3),
            orbit_with(375.48, (20490.0, 1235.0), (52.78, 5.0, 0.0), 4),
        ];
        let epoch = Epoch::from_gregorian_utc_at_midnight(2022, 3, 1);
        for debris in &cases {
            for apparent in [false, true] {
                for exposure in [0.5, 5.0, 30.0, 600.0] {
                    for start_min in [0.0, 13.0, 47.0] {
                        let start = epoch + Duration::from_seconds(start_min * 60.0);
                        let mid = start + Duration::from_seconds(exposure / 2.0);
                        let s = Sighting::new(&observer, debris, mid, apparent);
                        let track = s.track(start, exposure).unwrap();
                        for k in 0..=400 {
                            let t_s = exposure * k as f64 / 400.0;
                            let exact = s.at(start + Duration::from_seconds(t_s)).unwrap();
                            let got = track.at(t_s);
                            let km = norm(sub(got.debris_km, exact.debris_km))
                                .max(norm(sub(got.observer_km, exact.observer_km)));
                            let arcsec = angle_deg(got.direction, exact.direction) * 3600.0;
                            assert!(
                                km < 1e-6 && arcsec < 1e-4,
                                "{exposure} s from {start_min} min, t {t_s}: {km} km, {arcsec} arcsec"
                            );
                        }
                    }
                }
            }
        }
    }
}
