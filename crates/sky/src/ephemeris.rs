//! Low-precision analytic ephemerides of the Sun and the Moon.
//!
//! Both functions return the *geometric* geocentric position (no light time,
//! no aberration, no nutation) in km, on GCRS axes (ICRF; the J2000 mean
//! equator and equinox, which differ from ICRF by the ~20 mas frame bias,
//! ignored here).
//!
//! Theories:
//! - Sun: J. Meeus, *Astronomical Algorithms*, 2nd ed. (1998), ch. 25,
//!   "higher accuracy" solar coordinates (Keplerian orbit with the equation of
//!   the centre; mean elements after Newcomb / VSOP87; stated accuracy
//!   0.01 deg), plus the classical Venus / Jupiter / long-period perturbation
//!   terms of Meeus, *Astronomical Formulae for Calculators* (after Newcomb's
//!   Tables of the Sun), plus the exact Earth-Moon barycentre offset (lunar
//!   inequality, up to 6.5 arcsec) computed from the Moon theory below.
//! - Moon: J. Meeus, *Astronomical Algorithms*, 2nd ed. (1998), ch. 47, full
//!   tables 47.A (60 longitude/distance terms) and 47.B (60 latitude terms),
//!   abridged from ELP-2000/82 (Chapront-Touze & Chapront); stated accuracy
//!   ~10 arcsec in longitude, ~4 arcsec in latitude. The mean longitude uses
//!   the Simon et al. (1994) constant (as ERFA `moon98` does) instead of
//!   Meeus's, which folds in the 0.70 arcsec light-time; so the result is
//!   geometric. ERFA's documentation of `moon98` (the same series) gives,
//!   against ELP/MPP02 over 1950-2100, worst cases of 18.3 arcsec in direction
//!   and 31.7 km in position (RMS 2.9 arcsec, 6.1 km).
//!
//! Both theories give coordinates on the mean ecliptic and equinox of date;
//! they are turned to the mean equator of date with the IAU 1980 mean
//! obliquity and then to J2000 with the IAU 1976 precession (Lieske 1977,
//! Meeus ch. 21). Time argument: TT (TT - TDB < 2 ms, irrelevant here).
//!
//! Measured against astropy 8.0.2's built-in ephemeris (geometric:
//! body barycentric minus Earth barycentric; ERFA `epv00` for the Sun, ERFA
//! `moon98` for the Moon), on the 50 epochs pinned in the tests
//! (`tests/reference/ephemeris_reference.py`) and on 4000 random epochs over
//! 1950..2050: Sun max 16.4 arcsec and 1.6e-5 relative distance; Moon max
//! 0.16 arcsec and 3e-10 (astropy's built-in Moon is this same Meeus series,
//! so for the Moon that checks the implementation and the frames, while the
//! accuracy constants below follow ERFA's comparison with ELP/MPP02). The
//! visibility limits this feeds (Sun > 20 deg, Moon > 15 deg from the line of
//! sight) need far less.

use hifitime::Epoch;

use super::{ARCSEC, mat_vec, transpose};

/// Astronomical unit, km (IAU 2012 B2).
const AU_KM: f64 = 149_597_870.7;
/// Moon / (Earth + Moon) mass ratio (DE430: Earth/Moon = 81.300 569).
const MOON_MASS_FRACTION: f64 = 1.0 / (1.0 + 81.300_569);

/// Worst-case angular error of [`sun_position_km`] over 1950..2050, degrees
/// (25 arcsec; measured max vs astropy/ERFA `epv00`: 16.4 arcsec).
pub const SUN_ACCURACY_DEG: f64 = 25.0 / 3600.0;
/// Worst-case relative distance error of [`sun_position_km`] over 1950..2050
/// (measured max vs astropy/ERFA `epv00`: 1.6e-5, i.e. ~2,400 km).
pub const SUN_DISTANCE_ACCURACY: f64 = 3.0e-5;
/// Worst-case angular error of [`moon_position_km`] over 1950..2050, degrees
/// (20 arcsec: ERFA's worst case of this series vs ELP/MPP02 is 18.3 arcsec;
/// measured max vs astropy, which uses the same series, 0.16 arcsec).
pub const MOON_ACCURACY_DEG: f64 = 20.0 / 3600.0;
/// Worst-case relative distance error of [`moon_position_km`] over 1950..2050
/// (1e-4, i.e. ~36-41 km: ERFA's worst case vs ELP/MPP02 is 31.7 km in
/// position; measured max vs astropy, same series, 3e-10).
pub const MOON_DISTANCE_ACCURACY: f64 = 1.0e-4;

/// Geocentric position of the Sun, km, GCRS axes (ICRF / J2000 mean equator),
/// geometric.
///
/// Meeus (1998) ch. 25 plus planetary perturbations and the Earth-Moon
/// barycentre offset (see the module docs); accuracy see
/// [`SUN_ACCURACY_DEG`] and [`SUN_DISTANCE_ACCURACY`].
pub fn sun_position_km(t: Epoch) -> [f64; 3] {
    let tc = t.to_tt_centuries_j2k();
    let [x, y, z] = sun_of_date_km(tc);
    // The theory gives the Sun relative to the Earth-Moon barycentre; the
    // Earth sits -m_moon/(m_earth + m_moon) * r_moon from it.
    let [mx, my, mz] = moon_of_date_km(tc);
    let f = MOON_MASS_FRACTION;
    ecliptic_of_date_to_gcrs([x + f * mx, y + f * my, z + f * mz], tc)
}

/// Geocentric position of the Moon, km, same axes as [`sun_position_km`].
///
/// Meeus (1998) ch. 47, full tables; accuracy see [`MOON_ACCURACY_DEG`] and
/// [`MOON_DISTANCE_ACCURACY`].
pub fn moon_position_km(t: Epoch) -> [f64; 3] {
    let tc = t.to_tt_centuries_j2k();
    ecliptic_of_date_to_gcrs(moon_of_date_km(tc), tc)
}

/// Sun relative to the Earth-Moon barycentre, km, mean ecliptic and equinox
/// of date (Meeus ch. 25). `tc`: Julian centuries of TT from J2000.
fn sun_of_date_km(tc: f64) -> [f64; 3] {
    // Geometric mean longitude, mean anomaly, eccentricity (eq. 25.2-25.4).
    let l0 = 280.466_46 + tc * (36_000.769_83 + tc * 0.000_303_2);
    let m = 357.529_11 + tc * (35_999.050_29 - tc * 0.000_153_7);
    let e = 0.016_708_634 - tc * (0.000_042_037 + tc * 0.000_000_126_7);
    let mr = m.to_radians();
    // Equation of the centre.
    let c = (1.914_602 - tc * (0.004_817 + tc * 0.000_014)) * mr.sin()
        + (0.019_993 - tc * 0.000_101) * (2.0 * mr).sin()
        + 0.000_289 * (3.0 * mr).sin();
    let nu = mr + c.to_radians();
    // Perturbations by Venus (A, B), Jupiter (C, H) and the long-period
    // inequality (E), from Meeus's *Astronomical Formulae for Calculators*
    // (after Newcomb); their arguments count centuries from 1900.0
    // (JD 2415020.0), i.e. `tc + 1`. The lunar term is handled exactly by the
    // caller (Earth-Moon barycentre offset).
    let t1900 = tc + 1.0;
    let a = (153.23 + 22_518.754_1 * t1900).to_radians();
    let b = (216.57 + 45_037.508_2 * t1900).to_radians();
    let cj = (312.69 + 32_964.357_7 * t1900).to_radians();
    let ee = (231.19 + 20.20 * t1900).to_radians();
    let h = (353.40 + 65_928.715_5 * t1900).to_radians();
    let dl = 0.001_34 * a.cos() + 0.001_54 * b.cos() + 0.002_00 * cj.cos() + 0.001_78 * ee.sin();
    let dr = 0.000_005_43 * a.sin()
        + 0.000_015_75 * b.sin()
        + 0.000_016_27 * cj.sin()
        + 0.000_009_27 * h.sin();
    let lon = (l0 + c + dl).to_radians();
    let r = AU_KM * (1.000_001_018 * (1.0 - e * e) / (1.0 + e * nu.cos()) + dr);
    [r * lon.cos(), r * lon.sin(), 0.0]
}

/// Periodic terms of Meeus table 47.A: multiples of D, M, M', F; longitude
/// coefficient (1e-6 deg, sine), distance coefficient (1e-3 km, cosine).
#[rustfmt::skip]
const MOON_LR: [(i8, i8, i8, i8, i32, i32); 60] = [
    (0, 0, 1, 0, 6_288_774, -20_905_355), (2, 0, -1, 0, 1_274_027, -3_699_111),
    (2, 0, 0, 0, 658_314, -2_955_968),    (0, 0, 2, 0, 213_618, -569_925),
    (0, 1, 0, 0, -185_116, 48_888),       (0, 0, 0, 2, -114_332, -3_149),
    (2, 0, -2, 0, 58_793, 246_158),       (2, -1, -1, 0, 57_066, -152_138),
    (2, 0, 1, 0, 53_322, -170_733),       (2, -1, 0, 0, 45_758, -204_586),
    (0, 1, -1, 0, -40_923, -129_620),     (1, 0, 0, 0, -34_720, 108_743),
    (0, 1, 1, 0, -30_383, 104_755),       (2, 0, 0, -2, 15_327, 10_321),
    (0, 0, 1, 2, -12_528, 0),             (0, 0, 1, -2, 10_980, 79_661),
    (4, 0, -1, 0, 10_675, -34_782),       (0, 0, 3, 0, 10_034, -23_210),
    (4, 0, -2, 0, 8_548, -21_636),        (2, 1, -1, 0, -7_888, 24_208),
    (2, 1, 0, 0, -6_766, 30_824),         (1, 0, -1, 0, -5_163, -8_379),
    (1, 1, 0, 0, 4_987, -16_675),         (2, -1, 1, 0, 4_036, -12_831),
    (2, 0, 2, 0, 3_994, -10_445),         (4, 0, 0, 0, 3_861, -11_650),
    (2, 0, -3, 0, 3_665, 14_403),         (0, 1, -2, 0, -2_689, -7_003),
    (2, 0, -1, 2, -2_602, 0),             (2, -1, -2, 0, 2_390, 10_056),
    (1, 0, 1, 0, -2_348, 6_322),          (2, -2, 0, 0, 2_236, -9_884),
    (0, 1, 2, 0, -2_120, 5_751),          (0, 2, 0, 0, -2_069, 0),
    (2, -2, -1, 0, 2_048, -4_950),        (2, 0, 1, -2, -1_773, 4_130),
    (2, 0, 0, 2, -1_595, 0),              (4, -1, -1, 0, 1_215, -3_958),
    (0, 0, 2, 2, -1_110, 0),              (3, 0, -1, 0, -892, 3_258),
    (2, 1, 1, 0, -810, 2_616),            (4, -1, -2, 0, 759, -1_897),
    (0, 2, -1, 0, -713, -2_117),          (2, 2, -1, 0, -700, 2_354),
    (2, 1, -2, 0, 691, 0),                (2, -1, 0, -2, 596, 0),
    (4, 0, 1, 0, 549, -1_423),            (0, 0, 4, 0, 537, -1_117),
    (4, -1, 0, 0, 520, -1_571),           (1, 0, -2, 0, -487, -1_739),
    (2, 1, 0, -2, -399, 0),               (0, 0, 2, -2, -381, -4_421),
    (1, 1, 1, 0, 351, 0),                 (3, 0, -2, 0, -340, 0),
    (4, 0, -3, 0, 330, 0),                (2, -1, 2, 0, 327, 0),
    (0, 2, 1, 0, -323, 1_165),            (1, 1, -1, 0, 299, 0),
    (2, 0, 3, 0, 294, 0),                 (2, 0, -1, -2, 0, 8_752),
];

/// Periodic terms of Meeus table 47.B: multiples of D, M, M', F; latitude
/// coefficient (1e-6 deg, sine).
#[rustfmt::skip]
const MOON_B: [(i8, i8, i8, i8, i32); 60] = [
    (0, 0, 0, 1, 5_128_122), (0, 0, 1, 1, 280_602), (0, 0, 1, -1, 277_693),
    (2, 0, 0, -1, 173_237),  (2, 0, -1, 1, 55_413), (2, 0, -1, -1, 46_271),
    (2, 0, 0, 1, 32_573),    (0, 0, 2, 1, 17_198),  (2, 0, 1, -1, 9_266),
    (0, 0, 2, -1, 8_822),    (2, -1, 0, -1, 8_216), (2, 0, -2, -1, 4_324),
    (2, 0, 1, 1, 4_200),     (2, 1, 0, -1, -3_359), (2, -1, -1, 1, 2_463),
    (2, -1, 0, 1, 2_211),    (2, -1, -1, -1, 2_065), (0, 1, -1, -1, -1_870),
    (4, 0, -1, -1, 1_828),   (0, 1, 0, 1, -1_794), (0, 0, 0, 3, -1_749),
    (0, 1, -1, 1, -1_565),   (1, 0, 0, 1, -1_491), (0, 1, 1, 1, -1_475),
    (0, 1, 1, -1, -1_410),   (0, 1, 0, -1, -1_344), (1, 0, 0, -1, -1_335),
    (0, 0, 3, 1, 1_107),     (4, 0, 0, -1, 1_021), (4, 0, -1, 1, 833),
    (0, 0, 1, -3, 777),      (4, 0, -2, 1, 671),   (2, 0, 0, -3, 607),
    (2, 0, 2, -1, 596),      (2, -1, 1, -1, 491),  (2, 0, -2, 1, -451),
    (0, 0, 3, -1, 439),      (2, 0, 2, 1, 422),    (2, 0, -3, -1, 421),
    (2, 1, -1, 1, -366),     (2, 1, 0, 1, -351),   (4, 0, 0, 1, 331),
    (2, -1, 1, 1, 315),      (2, -2, 0, -1, 302),  (0, 0, 1, 3, -283),
    (2, 1, 1, -1, -229),     (1, 1, 0, -1, 223),   (1, 1, 0, 1, 223),
    (0, 1, -2, -1, -220),    (2, 1, -1, -1, -220), (1, 0, 1, 1, -185),
    (2, -1, -2, -1, 181),    (0, 1, 2, 1, -177),   (4, 0, -2, -1, 176),
    (4, -1, -1, -1, 166),    (1, 0, 1, -1, -164),  (4, 0, 1, -1, 132),
    (1, 0, -1, -1, -119),    (4, -1, 0, -1, 115),  (2, -2, 0, 1, 107),
];

/// Geocentric Moon, km, mean ecliptic and equinox of date (Meeus ch. 47).
/// `tc`: Julian centuries of TT from J2000.
fn moon_of_date_km(tc: f64) -> [f64; 3] {
    let t2 = tc * tc;
    let t3 = t2 * tc;
    let t4 = t3 * tc;
    // Fundamental arguments, degrees (eq. 47.1-47.5).
    // Mean longitude: Simon et al. (1994) constant as in ERFA `moon98`,
    // i.e. Meeus's 218.316 447 7 deg without its -0.70 arcsec light-time
    // term, so that the position is geometric.
    let lp = 218.316_654_36 + 481_267.881_234_21 * tc - 0.001_578_6 * t2 + t3 / 538_841.0
        - t4 / 65_194_000.0;
    let d = 297.850_192_1 + 445_267.111_403_4 * tc - 0.001_881_9 * t2 + t3 / 545_868.0
        - t4 / 113_065_000.0;
    let m = 357.529_109_2 + 35_999.050_290_9 * tc - 0.000_153_6 * t2 + t3 / 24_490_000.0;
    let mp = 134.963_396_4 + 477_198.867_505_5 * tc + 0.008_741_4 * t2 + t3 / 69_699.0
        - t4 / 14_712_000.0;
    let f = 93.272_095_0 + 483_202.017_523_3 * tc - 0.003_653_9 * t2 - t3 / 3_526_000.0
        + t4 / 863_310_000.0;
    let a1 = (119.75 + 131.849 * tc).to_radians();
    let a2 = (53.09 + 479_264.290 * tc).to_radians();
    let a3 = (313.45 + 481_266.484 * tc).to_radians();
    // Decrease of the Earth's orbital eccentricity (eq. 47.6).
    let ecc = 1.0 - 0.002_516 * tc - 0.000_007_4 * t2;
    let (lp, d, m, mp, f) = (
        lp.to_radians(),
        d.to_radians(),
        m.to_radians(),
        mp.to_radians(),
        f.to_radians(),
    );
    let arg = |kd: i8, km: i8, kmp: i8, kf: i8| {
        f64::from(kd) * d + f64::from(km) * m + f64::from(kmp) * mp + f64::from(kf) * f
    };
    let ecc_factor = |km: i8| ecc.powi(i32::from(km.unsigned_abs()));

    let (mut sl, mut sr) = (0.0, 0.0);
    for &(kd, km, kmp, kf, cl, cr) in &MOON_LR {
        let a = arg(kd, km, kmp, kf);
        let ef = ecc_factor(km);
        sl += ef * f64::from(cl) * a.sin();
        sr += ef * f64::from(cr) * a.cos();
    }
    let mut sb = 0.0;
    for &(kd, km, kmp, kf, cb) in &MOON_B {
        sb += ecc_factor(km) * f64::from(cb) * arg(kd, km, kmp, kf).sin();
    }
    // Additive terms (Venus, Jupiter, flattening of the Earth).
    sl += 3958.0 * a1.sin() + 1962.0 * (lp - f).sin() + 318.0 * a2.sin();
    sb += -2235.0 * lp.sin()
        + 382.0 * a3.sin()
        + 175.0 * (a1 - f).sin()
        + 175.0 * (a1 + f).sin()
        + 127.0 * (lp - mp).sin()
        - 115.0 * (lp + mp).sin();

    let lon = lp + (sl * 1e-6).to_radians();
    let lat = (sb * 1e-6).to_radians();
    let r = 385_000.56 + sr * 1e-3;
    [
        r * lat.cos() * lon.cos(),
        r * lat.cos() * lon.sin(),
        r * lat.sin(),
    ]
}

/// Mean ecliptic and equinox of date -> GCRS (J2000 mean equator) axes.
fn ecliptic_of_date_to_gcrs(v: [f64; 3], tc: f64) -> [f64; 3] {
    // IAU 1980 mean obliquity of the ecliptic (Meeus eq. 22.2).
    let eps = (84_381.448 + tc * (-46.815 + tc * (-0.000_59 + tc * 0.001_813))) * ARCSEC;
    let (se, ce) = eps.sin_cos();
    let q = [v[0], ce * v[1] - se * v[2], se * v[1] + ce * v[2]];
    // IAU 1976 precession angles from J2000 to date (Meeus eq. 21.3).
    let zeta = tc * (2306.2181 + tc * (0.301_88 + tc * 0.017_998)) * ARCSEC;
    let z = tc * (2306.2181 + tc * (1.094_68 + tc * 0.018_203)) * ARCSEC;
    let theta = tc * (2004.3109 + tc * (-0.426_65 - tc * 0.041_833)) * ARCSEC;
    let (sz, cz) = zeta.sin_cos();
    let (szz, czz) = z.sin_cos();
    let (st, ct) = theta.sin_cos();
    // p maps J2000 -> date; apply its transpose.
    let p = [
        [
            cz * ct * czz - sz * szz,
            -sz * ct * czz - cz * szz,
            -st * czz,
        ],
        [
            cz * ct * szz + sz * czz,
            -sz * ct * szz + cz * czz,
            -st * szz,
        ],
        [cz * st, -sz * st, ct],
    ];
    mat_vec(&transpose(&p), q)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{angle_deg, norm};
    use hifitime::TimeScale;

    /// (year, month, day, hour, minute, second, is_tt, Sun km, Moon km).
    type Row = (i32, u8, u8, u8, u8, u8, bool, [f64; 3], [f64; 3]);

    include!(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/fixtures/sky/ephemeris.rs"
    ));

    fn epoch(row: &Row) -> Epoch {
        let &(y, mo, d, h, mi, s, is_tt, _, _) = row;
        let scale = if is_tt { TimeScale::TT } else { TimeScale::UTC };
        Epoch::from_gregorian(y, mo, d, h, mi, s, 0, scale)
    }

    /// Max angular (arcsec) and relative distance errors over the table, checked against the
    /// body's stated accuracy.
    fn check_accuracy(
        name: &str,
        body: fn(Epoch) -> [f64; 3],
        pick: fn(&Row) -> [f64; 3],
        accuracy_deg: f64,
        distance_accuracy: f64,
    ) -> (f64, f64) {
        let (mut ang, mut dist) = (0.0_f64, 0.0_f64);
        for row in &REFERENCE {
            let got = body(epoch(row));
            let want = pick(row);
            ang = ang.max(angle_deg(got, want) * 3600.0);
            dist = dist.max((norm(got) / norm(want) - 1.0).abs());
        }
        eprintln!("{name}: max angle {ang:.2} arcsec, max relative distance {dist:.2e}");
        assert!(ang < accuracy_deg * 3600.0, "{name} angle {ang} arcsec");
        assert!(dist < distance_accuracy, "{name} distance {dist}");
        (ang, dist)
    }

    #[test]
    fn sun_matches_astropy() {
        check_accuracy(
            "Sun",
            sun_position_km,
            |r| r.7,
            SUN_ACCURACY_DEG,
            SUN_DISTANCE_ACCURACY,
        );
    }

    #[test]
    fn moon_matches_astropy() {
        let (ang, dist) = check_accuracy(
            "Moon",
            moon_position_km,
            |r| r.8,
            MOON_ACCURACY_DEG,
            MOON_DISTANCE_ACCURACY,
        );
        // astropy's built-in Moon (ERFA moon98) is the same Meeus series, so
        // the implementation and the frame chain must agree much more tightly;
        // the residue is IAU 1976 vs IAU 2006 precession and the frame bias.
        assert!(ang < 0.5, "Moon implementation: {ang} arcsec");
        assert!(dist < 1e-8, "Moon implementation: distance {dist}");
    }

    #[test]
    fn distances_are_sane() {
        let start = Epoch::from_gregorian_utc_at_midnight(2022, 1, 1);
        for k in 0..=(366 * 4) {
            let t = start + hifitime::Unit::Hour * (6 * k);
            let sun_au = norm(sun_position_km(t)) / AU_KM;
            assert!((0.983..=1.017).contains(&sun_au), "Sun {sun_au} AU at {t}");
            let moon_km = norm(moon_position_km(t));
            assert!(
                (356_000.0..=407_000.0).contains(&moon_km),
                "Moon {moon_km} km at {t}"
            );
        }
    }
}
