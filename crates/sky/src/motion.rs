//! The camera's motion over an exposure, as a FITS header carries it: besides the primary WCS
//! (at mid-exposure), the WCS at the start of the exposure (alternate WCS `S`, `CRVAL1S` ...)
//! and at its end (`E`). soig writes them for survey and track images (`cards`); `soig detect
//! --catalog` reads them back (`ExposureMotion`) to place every catalogued star over the
//! exposure. Between two of these instants the camera is taken to turn at a constant rate about
//! a fixed axis: exactly the survey pointing's motion (the observer's orbit turns it so), and
//! for track pointing, whose camera follows the debris, the great-circle path between them.

use super::pointing::Pointing;
use super::projection::Tan;
use super::projection::WcsValue;
use super::vec3::{Vec3, cross, dot, norm, radec_deg, radec_unit, rotate, scale};
use super::wcs::TanWcs;

/// The alternate-WCS letters of the exposure's start and end.
pub const START: char = 'S';
pub const END: char = 'E';

/// A camera at one instant: a TAN WCS as vectors, so that turning it is a rotation.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    /// Sky directions of the tangent plane's +xi and +eta axes and of the tangent point (the
    /// local east, north and boresight for a camera read from a WCS; turned with the camera).
    east: Vec3,
    north: Vec3,
    boresight: Vec3,
    /// Reference pixel, 0-based (pixel centres at integers).
    crpix: [f64; 2],
    /// Pixels per degree of standard coordinates: p - crpix = cd_inv (xi, eta).
    cd_inv: [[f64; 2]; 2],
}

/// Local east and north at a direction (ra, dec).
fn east_north(ra_deg: f64, dec_deg: f64) -> (Vec3, Vec3) {
    let (sa, ca) = ra_deg.to_radians().sin_cos();
    let (sd, cd) = dec_deg.to_radians().sin_cos();
    ([-sa, ca, 0.0], [-sd * ca, -sd * sa, cd])
}

fn invert(m: [[f64; 2]; 2]) -> [[f64; 2]; 2] {
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    [
        [m[1][1] / det, -m[0][1] / det],
        [-m[1][0] / det, m[0][0] / det],
    ]
}

impl Camera {
    /// The camera of a TAN WCS (its CD matrix is not singular: `TanWcs::from_header` checks).
    pub fn of(w: &TanWcs) -> Camera {
        let (east, north) = east_north(w.crval[0], w.crval[1]);
        Camera {
            east,
            north,
            boresight: radec_unit(w.crval[0], w.crval[1]),
            crpix: [w.crpix[0] - 1.0, w.crpix[1] - 1.0],
            cd_inv: invert(w.cd),
        }
    }

    /// The camera of soig's own projection.
    pub fn of_tan(t: &Tan) -> Camera {
        let (east, north) = east_north(t.ra0_deg, t.dec0_deg);
        Camera {
            east,
            north,
            boresight: radec_unit(t.ra0_deg, t.dec0_deg),
            crpix: [t.cx, t.cy],
            cd_inv: [[1.0 / t.scale_deg, 0.0], [0.0, 1.0 / t.scale_deg]],
        }
    }

    /// Pixel coordinates (0-based, pixel centres at integers) of the unit direction `s`; None
    /// behind the tangent plane.
    pub fn pixel(&self, s: Vec3) -> Option<(f64, f64)> {
        let d = dot(s, self.boresight);
        if d <= 1e-9 {
            return None;
        }
        let xi = (dot(s, self.east) / d).to_degrees();
        let eta = (dot(s, self.north) / d).to_degrees();
        let m = &self.cd_inv;
        Some((
            self.crpix[0] + m[0][0] * xi + m[0][1] * eta,
            self.crpix[1] + m[1][0] * xi + m[1][1] * eta,
        ))
    }

    /// The camera turned by `angle` radians about the unit `axis`: it sees at each pixel what
    /// this one sees at the same pixel, turned.
    pub fn turned(&self, axis: Vec3, angle: f64) -> Camera {
        let r = |v| rotate(v, axis, angle);
        Camera {
            east: r(self.east),
            north: r(self.north),
            boresight: r(self.boresight),
            ..*self
        }
    }

    /// The camera as a TAN WCS: the standard coordinates about the boresight are the local
    /// ones, so the camera's own axes (turned away from the local east and north) go into CD.
    pub fn wcs(&self) -> TanWcs {
        let (ra, dec) = radec_deg(self.boresight);
        let (e, n) = east_north(ra, dec);
        // (xi, eta) along the camera's axes = m (xi, eta) along the local ones.
        let m = [
            [dot(self.east, e), dot(self.east, n)],
            [dot(self.north, e), dot(self.north, n)],
        ];
        let cd_body = invert(self.cd_inv);
        // CD = m^T cd_body (m is a rotation: its inverse is its transpose).
        let cd = [0, 1].map(|i| [0, 1].map(|j| m[0][i] * cd_body[0][j] + m[1][i] * cd_body[1][j]));
        TanWcs {
            crpix: [self.crpix[0] + 1.0, self.crpix[1] + 1.0],
            crval: [ra, dec],
            cd,
        }
    }

    /// Sky direction of the pixel +x axis at the reference pixel (with the boresight, it fixes
    /// the camera's attitude).
    fn x_axis(&self) -> Vec3 {
        let cd = invert(self.cd_inv);
        let v: Vec3 = [0, 1, 2].map(|k| cd[0][0] * self.east[k] + cd[1][0] * self.north[k]);
        scale(v, 1.0 / norm(v))
    }
}

/// The rotation (unit axis, angle in radians) that turns camera `a` into camera `b`, taken as
/// the same rigid camera; None when they point the same way.
fn turn_between(a: &Camera, b: &Camera) -> Option<(Vec3, f64)> {
    // Orthonormal frames (boresight, x axis, their cross product) of both; Q = B A^T.
    let frame = |c: &Camera| {
        let (z, x0) = (c.boresight, c.x_axis());
        // Only the part of the x axis across the boresight (it is across it, to rounding).
        let x = {
            let v: Vec3 = [0, 1, 2].map(|k| x0[k] - dot(x0, z) * z[k]);
            scale(v, 1.0 / norm(v))
        };
        [z, x, cross(z, x)]
    };
    let (fa, fb) = (frame(a), frame(b));
    let q = |i: usize, j: usize| (0..3).map(|k| fb[k][i] * fa[k][j]).sum::<f64>();
    let trace = q(0, 0) + q(1, 1) + q(2, 2);
    // sin(angle) axis from Q's antisymmetric part, cos(angle) from its trace: atan2 keeps the
    // angle exact for the small turns of one exposure, where acos of the trace would not.
    let v: Vec3 = [q(2, 1) - q(1, 2), q(0, 2) - q(2, 0), q(1, 0) - q(0, 1)];
    let sin = norm(v) / 2.0;
    let cos = (trace - 1.0) / 2.0;
    (sin > 0.0).then(|| (scale(v, 1.0 / norm(v)), sin.atan2(cos)))
}

/// A frame's camera over its exposure: at the start, mid-exposure and the end.
#[derive(Clone, Copy, Debug)]
pub struct ExposureMotion {
    start: Camera,
    mid: Camera,
    first_half: Option<(Vec3, f64)>,
    second_half: Option<(Vec3, f64)>,
}

impl ExposureMotion {
    /// From the WCS at the start, mid-exposure and end.
    pub fn new(start: &TanWcs, mid: &TanWcs, end: &TanWcs) -> ExposureMotion {
        let (s, m, e) = (Camera::of(start), Camera::of(mid), Camera::of(end));
        ExposureMotion {
            start: s,
            mid: m,
            first_half: turn_between(&s, &m),
            second_half: turn_between(&m, &e),
        }
    }

    /// Read the alternate WCS `S` and `E` through `key` (a header value as text) beside the
    /// primary WCS `mid`. `Ok(None)` when the header has neither; `Err` with the reason when it
    /// has one alone or one that cannot be read.
    pub fn from_header(
        key: impl Fn(&str) -> Option<String>,
        mid: &TanWcs,
    ) -> Result<Option<ExposureMotion>, String> {
        let alternate = |letter: char| {
            TanWcs::from_header(|k| key(&format!("{k}{letter}")))
                .map_err(|e| format!("alternate WCS {letter}: {e}"))
        };
        match (alternate(START)?, alternate(END)?) {
            (None, None) => Ok(None),
            (Some(s), Some(e)) => Ok(Some(ExposureMotion::new(&s, mid, &e))),
            (Some(_), None) => Err(format!(
                "the WCS at the exposure's start (alternate {START}) has no end (alternate {END})"
            )),
            (None, Some(_)) => Err(format!(
                "the WCS at the exposure's end (alternate {END}) has no start (alternate {START})"
            )),
        }
    }

    /// The camera at `fraction` of the exposure (0 its start, 1 its end).
    pub fn camera_at(&self, fraction: f64) -> Camera {
        let f = 2.0 * fraction;
        let (from, turn, f) = if f <= 1.0 {
            (&self.start, self.first_half, f)
        } else {
            (&self.mid, self.second_half, f - 1.0)
        };
        match turn {
            Some((axis, angle)) => from.turned(axis, f * angle),
            None => *from,
        }
    }

    /// The boresight's path over the exposure, degrees: each half's turn times the sine of
    /// the boresight's angle from its axis (the survey track's `drift_deg`, which sets the
    /// renderer's time nodes).
    pub fn drift_deg(&self) -> f64 {
        let path = |t: Option<(Vec3, f64)>, c: &Camera| {
            t.map_or(0.0, |(axis, angle)| {
                angle.abs() * norm(cross(axis, c.boresight))
            })
        };
        (path(self.first_half, &self.start) + path(self.second_half, &self.mid)).to_degrees()
    }
}

/// How the camera of `pointing` is turned at `t_s` seconds after the start from its
/// mid-exposure place: it sees s where the mid-exposure camera sees R^-1 s (see
/// `Scene::pixel_at`); None for fixed pointing.
fn turn_at(pointing: &Pointing, t_s: f64) -> Option<(Vec3, f64)> {
    match pointing {
        Pointing::Fixed { .. } => None,
        Pointing::Survey(track) => Some((
            track.axis,
            (track.rate_deg_s * (t_s - track.t_mid_s)).to_radians(),
        )),
        Pointing::Track(track) => track.turn_at(t_s),
    }
}

/// The header cards (keyword, value, comment) of the WCS at the start and end of an exposure of
/// `exposure_s` seconds whose mid-exposure WCS is `mid` (jitter shift included), for a pointing
/// that moves; none for fixed pointing.
pub fn cards(
    pointing: &Pointing,
    mid: &Tan,
    exposure_s: f64,
) -> Vec<(String, WcsValue, &'static str)> {
    let mut cards = Vec::new();
    if matches!(pointing, Pointing::Fixed { .. }) {
        return cards;
    }
    let camera = Camera::of_tan(mid);
    for (letter, t, name) in [
        (START, 0.0, "exposure start"),
        (END, exposure_s, "exposure end"),
    ] {
        let w = match turn_at(pointing, t) {
            Some((axis, angle)) => camera.turned(axis, angle).wcs(),
            None => camera.wcs(),
        };
        let mut push = |k: &str, v: WcsValue, comment: &'static str| {
            cards.push((format!("{k}{letter}"), v, comment))
        };
        push("WCSNAME", WcsValue::Str(name), "camera at this instant");
        push("CTYPE1", WcsValue::Str("RA---TAN"), "gnomonic projection");
        push("CTYPE2", WcsValue::Str("DEC--TAN"), "gnomonic projection");
        push("CUNIT1", WcsValue::Str("deg"), "");
        push("CUNIT2", WcsValue::Str("deg"), "");
        for (k, v, comment) in [
            ("CRVAL1", w.crval[0], "[deg] RA of the tangent point"),
            ("CRVAL2", w.crval[1], "[deg] Dec of the tangent point"),
            ("CRPIX1", w.crpix[0], "tangent point, 1-based pixel"),
            ("CRPIX2", w.crpix[1], "tangent point, 1-based pixel"),
        ] {
            push(k, WcsValue::Real(v), comment);
        }
        for (i, j) in [(1, 1), (1, 2), (2, 1), (2, 2)] {
            push(
                &format!("CD{i}_{j}"),
                WcsValue::Real(w.cd[i - 1][j - 1]),
                "",
            );
        }
    }
    cards
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A camera read from its own WCS projects every direction where it did: the WCS written
    /// is the camera (to 1e-9 px: rounding only).
    #[test]
    fn a_turned_camera_and_its_wcs_agree() {
        let tan = Tan::new(123.4, -56.7, 0.001, 512, 400).shifted(0.3, -0.2);
        let axis = super::super::vec3::unit([0.3, -0.5, 0.8]);
        let turned = Camera::of_tan(&tan).turned(axis, 0.02);
        let back = Camera::of(&turned.wcs());
        for (x, y) in [(0.0, 0.0), (511.0, 0.0), (255.5, 199.5), (37.0, 399.0)] {
            // The direction the turned camera sees at (x, y): the mid camera's, turned.
            let (ra, dec) = tan.sky(x, y);
            let s = rotate(radec_unit(ra, dec), axis, 0.02);
            let (a, b) = (turned.pixel(s).unwrap(), back.pixel(s).unwrap());
            assert!(
                (a.0 - x).abs() < 1e-9 && (a.1 - y).abs() < 1e-9,
                "{a:?} {x} {y}"
            );
            assert!(
                (b.0 - x).abs() < 1e-9 && (b.1 - y).abs() < 1e-9,
                "{b:?} {x} {y}"
            );
            // And through the WCS reader's own deprojection.
            let (ra2, dec2) = turned.wcs().sky(x, y);
            let s2 = radec_unit(ra2, dec2);
            assert!(norm(super::super::vec3::sub(s, s2)) < 1e-13);
        }
    }

    /// The turn found between two cameras is the one that made them, and the motion
    /// interpolates it at a constant rate.
    #[test]
    fn the_turn_between_two_cameras_is_recovered() {
        let tan = Tan::new(10.0, 80.0, 0.0008, 300, 300);
        let axis = super::super::vec3::unit([0.1, 0.9, -0.2]);
        let mid = Camera::of_tan(&tan);
        let (s, e) = (mid.turned(axis, -0.01), mid.turned(axis, 0.01));
        let m = ExposureMotion::new(&s.wcs(), &mid.wcs(), &e.wcs());
        let sin = norm(cross(axis, radec_unit(10.0, 80.0)));
        assert!((m.drift_deg() - 0.02f64.to_degrees() * sin).abs() < 1e-10);
        let quarter = mid.turned(axis, -0.005);
        let star = radec_unit(12.0, 80.05);
        let (a, b) = (
            m.camera_at(0.25).pixel(star).unwrap(),
            quarter.pixel(star).unwrap(),
        );
        assert!(
            (a.0 - b.0).abs() < 1e-7 && (a.1 - b.1).abs() < 1e-7,
            "{a:?} {b:?}"
        );
    }
}
