//! A FITS WCS reader for the gnomonic (TAN) projection of real frames: `CTYPEi = RA---TAN /
//! DEC--TAN`, `CRPIXi`, `CRVALi` and the linear part as a CD matrix (`CDi_j`) or as `PCi_j`
//! (default identity) times `CDELTi` (FITS WCS paper I: CD wins when both are given, as in
//! astropy and wcslib). Angles in degrees (`CUNITi` `deg` or `degrees`, or absent). Other
//! projections and distortion (SIP, `-TAN-SIP`, TPV) are refused: ignoring them would give
//! wrong sky positions silently. The deprojection itself is [`Tan::sky`].

use super::projection::Tan;

/// A TAN WCS: pixel (0-based, pixel centres at integers, as soig's arrays) -> (RA, Dec).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct TanWcs {
    /// Reference pixel, 1-based (FITS).
    pub crpix: [f64; 2],
    /// RA and Dec of the reference pixel, degrees.
    pub crval: [f64; 2],
    /// Degrees per pixel: (xi, eta) = cd (p - crpix).
    pub cd: [[f64; 2]; 2],
}

impl TanWcs {
    /// Read the WCS through `key` (a header value as text, `None` when absent). `Ok(None)` when
    /// the header has no celestial WCS; `Err` with the reason when it has one this reader
    /// cannot apply correctly.
    pub fn from_header(key: impl Fn(&str) -> Option<String>) -> Result<Option<TanWcs>, String> {
        let (Some(c1), Some(c2)) = (key("CTYPE1"), key("CTYPE2")) else {
            return Ok(None);
        };
        let (c1, c2) = (c1.trim().to_uppercase(), c2.trim().to_uppercase());
        if c1 != "RA---TAN" || c2 != "DEC--TAN" {
            return Err(format!(
                "CTYPE1/2 = {c1}/{c2}: only RA---TAN/DEC--TAN without distortion is read"
            ));
        }
        for axis in ["CUNIT1", "CUNIT2"] {
            if let Some(u) = key(axis) {
                let u = u.trim().to_lowercase();
                if !(u.is_empty() || u == "deg" || u == "degree" || u == "degrees") {
                    return Err(format!("{axis} = {u}: only degrees are read"));
                }
            }
        }
        let num = |k: &str| -> Result<Option<f64>, String> {
            match key(k) {
                None => Ok(None),
                Some(v) => v
                    .trim()
                    .replace(['D', 'd'], "E")
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .map(Some)
                    .ok_or_else(|| format!("{k} = {v} is not a finite number")),
            }
        };
        let need = |k: &str| num(k)?.ok_or_else(|| format!("{k} is missing"));
        let crpix = [need("CRPIX1")?, need("CRPIX2")?];
        let crval = [need("CRVAL1")?, need("CRVAL2")?];
        let ij = [(1, 1), (1, 2), (2, 1), (2, 2)];
        let cd_cards: Vec<Option<f64>> = ij
            .iter()
            .map(|(i, j)| num(&format!("CD{i}_{j}")))
            .collect::<Result<_, _>>()?;
        let cd = if cd_cards.iter().any(Option::is_some) {
            let v: Vec<f64> = cd_cards.iter().map(|c| c.unwrap_or(0.0)).collect();
            [[v[0], v[1]], [v[2], v[3]]]
        } else {
            let cdelt = [need("CDELT1")?, need("CDELT2")?];
            let mut m = [[1.0, 0.0], [0.0, 1.0]];
            for (i, j) in ij {
                if let Some(v) = num(&format!("PC{i}_{j}"))? {
                    m[i - 1][j - 1] = v;
                }
            }
            [
                [m[0][0] * cdelt[0], m[0][1] * cdelt[0]],
                [m[1][0] * cdelt[1], m[1][1] * cdelt[1]],
            ]
        };
        let det = cd[0][0] * cd[1][1] - cd[0][1] * cd[1][0];
        if det == 0.0 || !det.is_finite() {
            return Err("the CD (or PC x CDELT) matrix is singular".into());
        }
        if !(-90.0..=90.0).contains(&crval[1]) {
            return Err(format!("CRVAL2 = {} is not a declination", crval[1]));
        }
        Ok(Some(TanWcs { crpix, crval, cd }))
    }

    /// (RA, Dec) in degrees of 0-based pixel coordinates (x, y) (pixel centres at integers).
    pub fn sky(&self, x: f64, y: f64) -> (f64, f64) {
        let (dx, dy) = (x + 1.0 - self.crpix[0], y + 1.0 - self.crpix[1]);
        let xi = self.cd[0][0] * dx + self.cd[0][1] * dy;
        let eta = self.cd[1][0] * dx + self.cd[1][1] * dy;
        // A unit-scale projection about CRVAL with its tangent point at 0 deprojects standard
        // coordinates given in degrees.
        Tan::new(self.crval[0], self.crval[1], 1.0, 1, 1).sky(xi, eta)
    }

    /// Pixel scale, arcseconds per pixel: the square root of the pixel's area on the sky.
    pub fn pixel_scale_arcsec(&self) -> f64 {
        (self.cd[0][0] * self.cd[1][1] - self.cd[0][1] * self.cd[1][0])
            .abs()
            .sqrt()
            * 3600.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Header cards (keyword, value as written).
    type Cards = &'static [(&'static str, &'static str)];

    fn header(cards: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let cards: Vec<(String, String)> = cards
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        move |k: &str| cards.iter().find(|c| c.0 == k).map(|c| c.1.clone())
    }

    /// The NEOSSat frames' WCS cards (CD and CDELT both present: CD wins).
    const NEOSSAT_RAW: Cards = &[
        ("CTYPE1", "RA---TAN"),
        ("CTYPE2", "DEC--TAN"),
        ("CUNIT1", "degrees"),
        ("CUNIT2", "degrees"),
        ("CRPIX1", "558"),
        ("CRPIX2", "509"),
        ("CRVAL1", "240.32140211"),
        ("CRVAL2", "-29.55762221"),
        ("CDELT1", "0.0008325"),
        ("CDELT2", "0.0008325"),
        ("CD1_1", "0.0007414"),
        ("CD1_2", "-0.00037866"),
        ("CD2_1", "0.00037866"),
        ("CD2_2", "0.0007414"),
    ];

    /// astropy's `WCS(header).all_pix2world(x, y, 0)` of the same cards, printed by
    /// tests/reference/tan_wcs_reference.py (astropy 8.0.2) to 9 decimals. The tolerance, 2e-9
    /// deg (7 µas), is that printed rounding (5e-10) plus the f64 rounding of two independent
    /// evaluations of the projection; a wrong
    /// convention (1-based pixel, CD transposed, CDELT applied) moves the positions by a pixel,
    /// 3 arcsec.
    #[test]
    fn matches_astropy() {
        let cases: &[(Cards, f64, f64, f64, f64)] = &[
            (NEOSSAT_RAW, 0.0, 0.0, 240.066315740, -30.144899841),
            (NEOSSAT_RAW, 557.0, 508.0, 240.321402110, -29.557622210),
            (NEOSSAT_RAW, 1077.0, 1019.0, 240.540912902, -28.981704760),
            (NEOSSAT_RAW, 100.5, 980.25, 239.727804518, -29.379040375),
            (PC_CDELT, 10.0, 20.0, 44.228830710, 89.829815468),
            (PC_CDELT, 300.0, -40.0, 10.596439988, 89.744109173),
        ];
        for (cards, x, y, ra, dec) in cases {
            let w = TanWcs::from_header(header(cards)).unwrap().unwrap();
            let (r, d) = w.sky(*x, *y);
            assert!(
                (r - ra).abs() < 2e-9 && (d - dec).abs() < 2e-9,
                "({x}, {y}): {r}, {d} vs astropy {ra}, {dec}"
            );
        }
        let w = TanWcs::from_header(header(NEOSSAT_RAW)).unwrap().unwrap();
        // 0.0008325 deg/px, within the rounding of the header's CD cards.
        assert!((w.pixel_scale_arcsec() - 2.997).abs() < 0.001);
    }

    /// PC x CDELT near the pole, with a rotation and a flip.
    const PC_CDELT: Cards = &[
        ("CTYPE1", "RA---TAN"),
        ("CTYPE2", "DEC--TAN"),
        ("CRPIX1", "100.5"),
        ("CRPIX2", "200.0"),
        ("CRVAL1", "12.5"),
        ("CRVAL2", "89.9"),
        ("CDELT1", "-0.0005"),
        ("CDELT2", "0.0005"),
        ("PC1_1", "0.8"),
        ("PC1_2", "0.6"),
        ("PC2_1", "-0.6"),
        ("PC2_2", "0.8"),
    ];

    #[test]
    fn refuses_what_it_cannot_apply() {
        assert_eq!(TanWcs::from_header(header(&[])), Ok(None));
        let with = |k: &'static str, v: &'static str| {
            let mut cards: Vec<(&str, &str)> = NEOSSAT_RAW.to_vec();
            cards.retain(|c| c.0 != k);
            cards.push((k, v));
            TanWcs::from_header(header(&cards)).unwrap_err()
        };
        assert!(with("CTYPE1", "RA---TAN-SIP").contains("CTYPE1"));
        assert!(with("CTYPE2", "DEC--SIN").contains("DEC--SIN"));
        assert!(with("CUNIT1", "arcsec").contains("CUNIT1"));
        assert!(with("CRVAL2", "95").contains("CRVAL2"));
        assert!(with("CD1_1", "x").contains("CD1_1"));
        let mut no_crpix: Vec<(&str, &str)> = NEOSSAT_RAW.to_vec();
        no_crpix.retain(|c| c.0 != "CRPIX2");
        assert!(
            TanWcs::from_header(header(&no_crpix))
                .unwrap_err()
                .contains("CRPIX2 is missing")
        );
    }
}
