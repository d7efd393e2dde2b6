//! Gnomonic (TAN) projection of the sky onto the detector, the one pixel convention of soig, and
//! the matching FITS WCS.
//!
//! Pixel convention (everywhere: rendering, labels, rotation, WCS): pixel (i, j) is the square
//! centred on (x, y) = (i, j), so it covers [i - 0.5, i + 0.5); a position falls in pixel
//! floor(x + 0.5). Row j is the j-th row of the array, the FITS row j + 1 and the PNG row j from
//! the top. The tangent point is the image centre ((w - 1) / 2, (h - 1) / 2). As in the paper's
//! Fig. 1, +x points to increasing right ascension (east) and +y to increasing declination, so the
//! FITS CD matrix is diag(+scale, +scale) (the mirror image of the usual east-left display).
//! The paper's Eq. 1/9 (`x = (alpha - A) d / r`) is replaced by this projection: it is exact at
//! any declination, including the poles, where Eq. 1 is singular.

use serde::{Deserialize, Serialize};

/// A tangent-plane projection centred on (ra0, dec0).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tan {
    pub ra0_deg: f64,
    pub dec0_deg: f64,
    /// Degrees per pixel.
    pub scale_deg: f64,
    /// Pixel coordinates of the tangent point (0-based, pixel centres at integers).
    pub cx: f64,
    pub cy: f64,
    sin_dec0: f64,
    cos_dec0: f64,
}

impl Tan {
    pub fn new(ra0_deg: f64, dec0_deg: f64, scale_deg: f64, width: u32, height: u32) -> Tan {
        let (s, c) = dec0_deg.to_radians().sin_cos();
        Tan {
            ra0_deg,
            dec0_deg,
            scale_deg,
            cx: (width as f64 - 1.0) / 2.0,
            cy: (height as f64 - 1.0) / 2.0,
            sin_dec0: s,
            cos_dec0: c,
        }
    }

    /// The same projection with the tangent point moved by (dx, dy) pixels: the WCS of an image
    /// whose sources all landed shifted by (dx, dy), e.g. by the mean pointing jitter.
    pub fn shifted(&self, dx: f64, dy: f64) -> Tan {
        Tan {
            cx: self.cx + dx,
            cy: self.cy + dy,
            ..*self
        }
    }

    /// Standard coordinates (xi east, eta north) of a sky position, degrees; None behind the
    /// tangent plane.
    pub fn standard(&self, ra_deg: f64, dec_deg: f64) -> Option<(f64, f64)> {
        let (sd, cd) = dec_deg.to_radians().sin_cos();
        let (sa, ca) = (ra_deg - self.ra0_deg).to_radians().sin_cos();
        let cos_c = self.sin_dec0 * sd + self.cos_dec0 * cd * ca;
        if cos_c <= 1e-9 {
            return None;
        }
        let xi = cd * sa / cos_c;
        let eta = (self.cos_dec0 * sd - self.sin_dec0 * cd * ca) / cos_c;
        Some((xi.to_degrees(), eta.to_degrees()))
    }

    /// Pixel coordinates of a sky position.
    pub fn pixel(&self, ra_deg: f64, dec_deg: f64) -> Option<(f64, f64)> {
        self.standard(ra_deg, dec_deg).map(|(xi, eta)| {
            (
                self.cx + xi / self.scale_deg,
                self.cy + eta / self.scale_deg,
            )
        })
    }

    /// The angle from the tangent point, degrees, within which every position that projects
    /// into the pixel rectangle [x0, x1] x [y0, y1] lies: its farthest corner's (the projection
    /// is radial, pixel radius = tan(angle) / scale).
    pub fn reach_deg(&self, [x0, x1]: [f64; 2], [y0, y1]: [f64; 2]) -> f64 {
        let dx = (x0 - self.cx).abs().max((x1 - self.cx).abs());
        let dy = (y0 - self.cy).abs().max((y1 - self.cy).abs());
        (dx.hypot(dy) * self.scale_deg.to_radians())
            .atan()
            .to_degrees()
    }

    /// Sky position of pixel coordinates.
    pub fn sky(&self, x: f64, y: f64) -> (f64, f64) {
        let xi = ((x - self.cx) * self.scale_deg).to_radians();
        let eta = ((y - self.cy) * self.scale_deg).to_radians();
        let denom = self.cos_dec0 - eta * self.sin_dec0;
        let ra = self.ra0_deg.to_radians() + xi.atan2(denom);
        let dec = (self.sin_dec0 + eta * self.cos_dec0).atan2((xi * xi + denom * denom).sqrt());
        (ra.to_degrees().rem_euclid(360.0), dec.to_degrees())
    }

    /// FITS WCS keywords (name, value, comment) describing this projection.
    pub fn wcs_cards(&self) -> Vec<(&'static str, WcsValue, &'static str)> {
        use WcsValue::*;
        vec![
            ("WCSAXES", Int(2), "two world axes"),
            ("CTYPE1", Str("RA---TAN"), "gnomonic projection"),
            ("CTYPE2", Str("DEC--TAN"), "gnomonic projection"),
            ("CUNIT1", Str("deg"), ""),
            ("CUNIT2", Str("deg"), ""),
            ("RADESYS", Str("ICRS"), ""),
            (
                "CRVAL1",
                Real(self.ra0_deg),
                "[deg] RA of the tangent point",
            ),
            (
                "CRVAL2",
                Real(self.dec0_deg),
                "[deg] Dec of the tangent point",
            ),
            (
                "CRPIX1",
                Real(self.cx + 1.0),
                "tangent point, 1-based pixel",
            ),
            (
                "CRPIX2",
                Real(self.cy + 1.0),
                "tangent point, 1-based pixel",
            ),
            ("CD1_1", Real(self.scale_deg), "+x is +RA (paper Fig. 1)"),
            ("CD1_2", Real(0.0), ""),
            ("CD2_1", Real(0.0), ""),
            ("CD2_2", Real(self.scale_deg), "+y is +Dec"),
        ]
    }
}

/// A FITS header value.
#[derive(Clone, Copy, Debug)]
pub enum WcsValue {
    Int(i64),
    Real(f64),
    Str(&'static str),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_everywhere() {
        for &(ra0, dec0) in &[
            (0.0, 0.0),
            (359.95, 10.0),
            (10.0, 89.99),
            (200.0, -90.0),
            (45.0, -60.0),
        ] {
            let tan = Tan::new(ra0, dec0, 0.1 / 512.0, 1024, 1024);
            for &(x, y) in &[(0.0, 0.0), (511.5, 511.5), (1023.0, 17.0), (-30.0, 1100.0)] {
                let (ra, dec) = tan.sky(x, y);
                let (x2, y2) = tan.pixel(ra, dec).unwrap();
                assert!(
                    (x - x2).abs() < 1e-7 && (y - y2).abs() < 1e-7,
                    "{ra0},{dec0}: {x},{y} -> {x2},{y2}"
                );
            }
        }
    }

    #[test]
    fn centre_and_axes() {
        let tan = Tan::new(100.0, 30.0, 0.1 / 512.0, 1024, 1024);
        let (x, y) = tan.pixel(100.0, 30.0).unwrap();
        assert!((x - 511.5).abs() < 1e-12 && (y - 511.5).abs() < 1e-12);
        // East (increasing RA) is +x, north is +y.
        let (xe, ye) = tan.pixel(100.01, 30.0).unwrap();
        assert!(xe > 511.5 && (ye - 511.5).abs() < 0.1);
        let (xn, yn) = tan.pixel(100.0, 30.01).unwrap();
        assert!(yn > 511.5 && (xn - 511.5).abs() < 1e-9);
        // 0.01 deg of RA at dec 30 is 0.01 cos 30 deg on the sky.
        assert!(((xe - 511.5) * 0.1 / 512.0 - 0.01 * 30f64.to_radians().cos()).abs() < 1e-7);
        // Behind the plane.
        assert!(tan.pixel(280.0, -30.0).is_none());
    }

    #[test]
    fn matches_astropy_wcs() {
        // (ra0, dec0, ra, dec, x, y): astropy.wcs all_world2pix(origin 0) of the header soig
        // writes, printed by tests/reference/wcs_reference.py (astropy 8.0).
        let cases = [
            (123.4, -56.7, 123.4, -56.7, 511.500000000, 511.500000000),
            (123.4, -56.7, 123.45, -56.68, 652.124528173, 613.848731590),
            (123.4, -56.7, 123.33, -56.75, 314.991636453, 255.399547067),
            (359.98, 10.0, 0.03, 10.02, 763.595328514, 613.919142810),
            (359.98, 10.0, 359.93, 9.97, 259.365878084, 357.919033013),
            (45.0, 89.95, 225.0, 89.97, 511.500000000, 921.100266179),
            (45.0, 89.95, 100.0, 89.9, 930.906065839, 473.828664292),
        ];
        for (ra0, dec0, ra, dec, x, y) in cases {
            let tan = Tan::new(ra0, dec0, 0.1 / 512.0, 1024, 1024);
            let cards = tan.wcs_cards();
            let crpix1 = cards.iter().find(|c| c.0 == "CRPIX1").map(|c| c.1);
            assert!(matches!(crpix1, Some(WcsValue::Real(v)) if v == 512.5));
            let (px, py) = tan.pixel(ra, dec).unwrap();
            assert!(
                (px - x).abs() < 1e-6 && (py - y).abs() < 1e-6,
                "{ra},{dec}: {px},{py} vs astropy {x},{y}"
            );
        }
    }
}
