//! Galactic coordinates: the ICRS -> galactic rotation that the count model's latitude needs.

use super::normalize_ra;
use crate::{Mat3, mat_vec, radec_unit};

/// ICRS -> galactic rotation as astropy composes it: the ICRS -> FK5 (J2000) frame bias, then
/// FK5 -> galactic with the pole (192.8594812065348, 27.12825118085622) and l(NCP) =
/// 122.9319185680026 deg. Printed by `tests/reference/stars_reference.py`; it differs from the rounded
/// Hipparcos matrix (ESA 1997, vol. 1, 1.5.3) by about 4e-8.
const ICRS_TO_GALACTIC: Mat3 = [
    [
        -0.054_875_657_712_591_63,
        -0.873_437_051_955_615_9,
        -0.483_835_073_616_715_46,
    ],
    [
        0.494_109_437_192_726_8,
        -0.444_829_721_223_295_2,
        0.746_982_183_986_667_6,
    ],
    [
        -0.867_666_137_559_657_6,
        -0.198_076_337_273_000_53,
        0.455_983_813_687_301_6,
    ],
];

/// ICRS -> galactic (IAU 1958 / Hipparcos rotation matrix as astropy uses).
/// Returns `(l, b)` in degrees, `l` in `[0, 360)`, `b` in `[-90, 90]`.
pub fn equatorial_to_galactic(ra_deg: f64, dec_deg: f64) -> (f64, f64) {
    let v = radec_unit(ra_deg, dec_deg);
    let g = mat_vec(&ICRS_TO_GALACTIC, v);
    let l = normalize_ra(g[1].atan2(g[0]).to_degrees());
    let b = g[2].atan2(g[0].hypot(g[1])).to_degrees();
    (l, b)
}

/// Inverse of [`equatorial_to_galactic`], for the tests of the procedural sky.
#[cfg(test)]
pub(super) fn galactic_to_equatorial(l: f64, b: f64) -> (f64, f64) {
    let v = mat_vec(&crate::transpose(&ICRS_TO_GALACTIC), radec_unit(l, b));
    (
        normalize_ra(v[1].atan2(v[0]).to_degrees()),
        v[2].atan2(v[0].hypot(v[1])).to_degrees(),
    )
}

#[cfg(test)]
mod tests {
    use super::super::separation_deg;
    use super::*;

    /// (ra, dec, l, b) from tests/reference/stars_reference.py (astropy 8.0.2).
    const ASTROPY_GALACTIC: [(f64, f64, f64, f64); 12] = [
        (0.0, 0.0, 96.33728336969006, -60.188551946914465),
        (359.999999, 0.0, 96.33728152476306, -60.18855154848863),
        (0.0, 90.0, 122.93192525541662, 27.128252414968),
        (0.0, -90.0, 302.9319252554166, -27.12825241496801),
        (
            266.40499,
            -28.93617,
            7.406296754018056e-06,
            2.7642021878106933e-06,
        ),
        (192.85948, 27.12825, 340.73759881165375, 89.99999694344345),
        (123.4, -45.6, 261.7092969378496, -6.159936682658481),
        (359.99999999, 10.0, 102.62623650087524, -50.83256438208554),
        (0.0, 10.0, 102.62623651568119, -50.83256438517407),
        (180.0, 89.999, 122.93217532911345, 27.129227333589267),
        (45.0, -89.999, 302.9313274927996, -27.129099159583586),
        (300.0, 60.0, 93.24034002695457, 15.292488983097952),
    ];

    #[test]
    fn galactic_matches_astropy() {
        for &(ra, dec, l_ref, b_ref) in &ASTROPY_GALACTIC {
            let (l, b) = equatorial_to_galactic(ra, dec);
            assert!((0.0..360.0).contains(&l) && (-90.0..=90.0).contains(&b));
            let sep = separation_deg(l, b, l_ref, b_ref);
            assert!(
                sep < 1e-9,
                "({ra}, {dec}): ({l}, {b}) vs astropy ({l_ref}, {b_ref}), {sep:e} deg"
            );
            assert!((b - b_ref).abs() < 1e-9);
            if b_ref.abs() < 89.0 {
                let dl = (l - l_ref + 180.0).rem_euclid(360.0) - 180.0;
                assert!(dl.abs() < 1e-6, "({ra}, {dec}): l {l} vs {l_ref}");
            }
        }
        // RA 360 is RA 0
        let (a, b) = (
            equatorial_to_galactic(0.0, 10.0),
            equatorial_to_galactic(360.0, 10.0),
        );
        assert!(separation_deg(a.0, a.1, b.0, b.1) < 1e-12);
    }

    #[test]
    fn galactic_matrix_is_a_rotation() {
        let m = &ICRS_TO_GALACTIC;
        for i in 0..3 {
            for j in 0..3 {
                let dot: f64 = (0..3).map(|k| m[i][k] * m[j][k]).sum();
                assert!((dot - if i == j { 1.0 } else { 0.0 }).abs() < 1e-14);
            }
        }
        let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        assert!((det - 1.0).abs() < 1e-14);
    }
}
