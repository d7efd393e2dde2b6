//! A ground site: its WGS84 geodetic place, its GCRS position and velocity as the Earth turns,
//! its horizon (altitude and azimuth of a GCRS direction) and the refraction that lifts a body
//! seen through the air.
//!
//! Earth-fixed to GCRS goes through SGP4's TEME frame, whose x axis is the mean equinox of date
//! turned by the IAU 1982 Greenwich mean sidereal time: ITRS -> TEME is a rotation by -GMST82
//! about the pole, and TEME -> GCRS is [`teme_to_gcrs_matrix`] (IAU-76/80, the frame the debris
//! already comes through, so the site and the debris share its 0.03 arcsec model error and the
//! line of sight between them does not see it). No Earth-orientation data are read: UT1 is taken
//! equal to UTC (|UT1 - UTC| < 0.9 s: up to 0.4 km of the site's place along its parallel) and
//! polar motion as zero (< 0.5 arcsec: ~15 m of the site's place). A LEO object 1000 km away
//! moves across the sky by ~0.1 arcsec per metre of site error, so a user matching real frames
//! to the arcsecond must shift the epoch by UT1 - UTC; the tests compare with astropy run with
//! the same zero EOP (`tests/reference/site_reference.py`).

use hifitime::{Epoch, Unit};

use super::frames::teme_to_gcrs_matrix;
use super::{Mat3, Vec3, cross, dot, mat_vec, transpose};

/// WGS84 equatorial radius, km, and flattening.
const WGS84_A_KM: f64 = 6378.137;
const WGS84_F: f64 = 1.0 / 298.257_223_563;
/// The Earth's rotation rate, rad per UT1 second (ERFA's `OM`: 1.00273781191135448 turns per
/// UT1 day).
const EARTH_RATE_RAD_S: f64 = 1.002_737_811_911_354_5 * std::f64::consts::TAU / 86_400.0;
/// The same in degrees per second (15.04 arcsec/s).
pub const EARTH_RATE_DEG_S: f64 = 1.002_737_811_911_354_5 * 360.0 / 86_400.0;

/// A place on the ground, WGS84 geodetic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Site {
    /// Geodetic latitude, degrees north.
    pub lat_deg: f64,
    /// Longitude, degrees east.
    pub lon_deg: f64,
    /// Height above the WGS84 ellipsoid, metres.
    pub height_m: f64,
}

/// Greenwich mean sidereal time, IAU 1982 (Aoki et al. 1982, as ERFA `gmst82`), rad, with UT1
/// taken as UTC (module docs).
pub fn gmst82_rad(t: Epoch) -> f64 {
    // Days of UT1 (= UTC) from J2000.0, kept as a Duration until the subtraction so that the
    // fraction of the day keeps its microseconds.
    let d = (t.to_jde_utc_duration() - Unit::Day * 2_451_545.0).to_unit(Unit::Day);
    let tu = d / 36_525.0;
    // Seconds of time: the polynomial of GMST at 0h UT1 less half a day (JD starts at noon),
    // plus the fraction of the day.
    let (a, b, c, e) = (
        24_110.548_41 - 43_200.0,
        8_640_184.812_866,
        0.093_104,
        -6.2e-6,
    );
    let seconds = a + (b + (c + e * tu) * tu) * tu + 86_400.0 * d.rem_euclid(1.0);
    (seconds * std::f64::consts::TAU / 86_400.0).rem_euclid(std::f64::consts::TAU)
}

/// Rotation about the pole by `angle` (a vector turned anticlockwise seen from +z).
fn turn_z(v: Vec3, angle: f64) -> Vec3 {
    let (s, c) = angle.sin_cos();
    [c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]]
}

impl Site {
    /// Earth-fixed (ITRS, polar motion zero) position, km.
    pub fn itrs_km(&self) -> Vec3 {
        let (sl, cl) = self.lat_deg.to_radians().sin_cos();
        let (so, co) = self.lon_deg.to_radians().sin_cos();
        let e2 = WGS84_F * (2.0 - WGS84_F);
        let n = WGS84_A_KM / (1.0 - e2 * sl * sl).sqrt();
        let h = self.height_m / 1000.0;
        [
            (n + h) * cl * co,
            (n + h) * cl * so,
            (n * (1.0 - e2) + h) * sl,
        ]
    }

    /// Position (km) and velocity (km/s) in the GCRS at UTC instant `t`. The velocity is the
    /// Earth's rotation alone (precession-nutation turn the frame ~1e-11 rad/s: 1e-7 m/s here).
    pub fn gcrs_state(&self, t: Epoch) -> (Vec3, Vec3) {
        let (r, v) = self.teme_state(t);
        let m = teme_to_gcrs_matrix(t);
        (mat_vec(&m, r), mat_vec(&m, v))
    }

    /// Position (km) and velocity (km/s) in SGP4's TEME frame at `t`, as a propagator gives
    /// them (the simulator turns both bodies to GCRS with one matrix per exposure).
    pub fn teme_state(&self, t: Epoch) -> (Vec3, Vec3) {
        let r = turn_z(self.itrs_km(), gmst82_rad(t));
        (r, cross([0.0, 0.0, EARTH_RATE_RAD_S], r))
    }

    /// East, north and up unit vectors of the site's horizon in GCRS axes at `t` (north and up
    /// from the geodetic latitude, as a spirit level sets them).
    fn horizon_axes(&self, t: Epoch) -> [Vec3; 3] {
        self.horizon_axes_by(gmst82_rad(t), &teme_to_gcrs_matrix(t))
    }

    /// `horizon_axes` from the sidereal angle `g` and TEME -> GCRS matrix `m` of an instant.
    fn horizon_axes_by(&self, g: f64, m: &Mat3) -> [Vec3; 3] {
        let (sl, cl) = self.lat_deg.to_radians().sin_cos();
        let (so, co) = self.lon_deg.to_radians().sin_cos();
        let to_gcrs = |v: Vec3| mat_vec(m, turn_z(v, g));
        [
            to_gcrs([-so, co, 0.0]),
            to_gcrs([-sl * co, -sl * so, cl]),
            to_gcrs([cl * co, cl * so, sl]),
        ]
    }

    /// The site's zenith (geodetic up) as a GCRS unit vector at `t`.
    pub fn up(&self, t: Epoch) -> Vec3 {
        self.horizon_axes(t)[2]
    }

    /// Altitude and azimuth (north through east), degrees, of the GCRS direction `dir` seen from
    /// the site at `t`; geometric (no refraction: [`refraction_deg`] lifts it).
    pub fn alt_az_deg(&self, t: Epoch, dir: Vec3) -> (f64, f64) {
        alt_az_in(&self.horizon_axes(t), dir)
    }

    /// The site's GCRS position (km) and horizon at `t` from one precession-nutation matrix
    /// (each of `gcrs_state` and `alt_az_deg` computes its own: the night search, which asks
    /// for all three at each grid instant, spent 10 % of a ground run on the matrices).
    pub fn gcrs_horizon(&self, t: Epoch) -> (Vec3, Horizon) {
        let (g, m) = (gmst82_rad(t), teme_to_gcrs_matrix(t));
        let r = turn_z(self.itrs_km(), g);
        (mat_vec(&m, r), Horizon(self.horizon_axes_by(g, &m)))
    }

    /// The GCRS unit vector at altitude `alt_deg`, azimuth `az_deg` (north through east) at `t`:
    /// the inverse of [`Site::alt_az_deg`], for a telescope held fixed in the horizon frame.
    pub fn direction_of(&self, t: Epoch, alt_deg: f64, az_deg: f64) -> Vec3 {
        let [e, n, u] = self.horizon_axes(t);
        let (sa, ca) = alt_deg.to_radians().sin_cos();
        let (sz, cz) = az_deg.to_radians().sin_cos();
        let w = [ca * sz, ca * cz, sa];
        mat_vec(&transpose(&[e, n, u]), w)
    }

    /// The axis (GCRS unit vector: the pole of date) and rate (deg/s) about which a direction
    /// held fixed in altitude and azimuth turns over the sky at `t`: a telescope staring at
    /// GEO is the survey pointing of `pointing::SurveyTrack` with these (stars trail at 15
    /// arcsec/s cos dec, geostationary objects stand). Precession moves the pole ~1e-6 arcsec/s.
    pub fn stare_axis(&self, t: Epoch) -> (Vec3, f64) {
        let axis = mat_vec(&teme_to_gcrs_matrix(t), [0.0, 0.0, 1.0]);
        (axis, EARTH_RATE_RAD_S.to_degrees())
    }
}

/// A site's east, north and up axes (GCRS) at one instant ([`Site::gcrs_horizon`]).
pub struct Horizon([Vec3; 3]);

impl Horizon {
    /// Altitude and azimuth, degrees, of the GCRS direction `dir`, as [`Site::alt_az_deg`].
    pub fn alt_az_deg(&self, dir: Vec3) -> (f64, f64) {
        alt_az_in(&self.0, dir)
    }
}

/// Altitude and azimuth (north through east), degrees, of `dir` in the horizon `[e, n, u]`.
fn alt_az_in(&[e, n, u]: &[Vec3; 3], dir: Vec3) -> (f64, f64) {
    let (x, y, z) = (dot(dir, e), dot(dir, n), dot(dir, u));
    let alt = z.atan2(x.hypot(y)).to_degrees();
    (alt, x.atan2(y).to_degrees().rem_euclid(360.0))
}

/// Standard air for [`refraction_deg`]: 1010 hPa and 10 C, Meeus' reference conditions.
pub const STANDARD_PRESSURE_HPA: f64 = 1010.0;
pub const STANDARD_TEMPERATURE_C: f64 = 10.0;

/// How much the air lifts a body at true (geometric) altitude `alt_deg`, degrees:
/// Saemundsson's formula (Sky & Telescope 72, 70, 1986; Meeus, Astronomical Algorithms 2nd ed.,
/// eq. 16.4) R = 1.02' cot(h + 10.3 / (h + 5.11)), h in degrees, scaled by
/// (P / 1010 hPa) (283 K / T). It inverts Bennett's formula (apparent -> true) to ~4 arcsec and
/// is meant for visible light; below -1 deg (body under the horizon) it returns 0.
pub fn refraction_deg(alt_deg: f64, pressure_hpa: f64, temperature_c: f64) -> f64 {
    if alt_deg < -1.0 {
        return 0.0;
    }
    let h = alt_deg.min(90.0);
    let arcmin = 1.02 / (h + 10.3 / (h + 5.11)).to_radians().tan();
    // cot(90 + small) is a hair below zero at the zenith: the lift there is zero.
    let scale = (pressure_hpa / STANDARD_PRESSURE_HPA) * (283.0 / (273.0 + temperature_c));
    (arcmin * scale).max(0.0) / 60.0
}

/// The Sun's altitude at the site at `t`, degrees (geometric, no refraction), from the Sun of
/// [`crate::ephemeris::sun_position_km`] seen from the site.
pub fn sun_altitude_deg(site: &Site, t: Epoch) -> f64 {
    let (r, _) = site.gcrs_state(t);
    let sun = crate::ephemeris::sun_position_km(t);
    site.alt_az_deg(t, crate::sub(sun, r)).0
}

#[cfg(test)]
#[path = "site_tests.rs"]
mod tests;
