//! The streak detector's gap test (`detect::streak`, step 6): a chain of star blobs in a row
//! (the jitter-smeared stars of fixed-pointing images, two or three in a line made most of its
//! false boxes) is not a streak, because stretches of it hold no light; a streak beside it, as
//! bright per pixel, is found. `detect_streaks_explained` says why the chain was dropped.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use soig::detect::streak::{Reason, StreakParams, detect_streaks_explained};

const W: usize = 512;

/// Gaussian noise of sd 8 grey levels on 100, deterministic (a 64-bit LCG, Box-Muller).
fn noise() -> Vec<f64> {
    let mut state: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut uniform = || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    (0..W * W)
        .map(|_| {
            let (u, v) = (uniform(), uniform());
            100.0 + 8.0 * (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
        })
        .collect()
}

/// Adds an elliptical Gaussian blob (sigmas `sx` across, `sy` down) of peak `amp` at (x, y).
fn blob(img: &mut [f64], x: f64, y: f64, sx: f64, sy: f64, amp: f64) {
    for py in 0..W {
        for px in 0..W {
            let (dx, dy) = ((px as f64 - x) / sx, (py as f64 - y) / sy);
            let r2 = dx * dx + dy * dy;
            if r2 < 40.0 {
                img[py * W + px] += amp * (-0.5 * r2).exp();
            }
        }
    }
}

#[test]
fn a_chain_of_star_blobs_is_dropped_for_its_gaps_and_a_streak_beside_it_is_found() {
    let mut img = noise();
    // The chain: three blobs 3.5 px wide and 10.6 px tall (FWHM; sigmas 1.5 and 4.5, too long
    // to be masked as round stars), 20 px apart down column 150, as bright as the streak's core.
    for k in 0..3 {
        blob(&mut img, 150.0, 200.0 + 20.0 * k as f64, 1.5, 4.5, 40.0);
    }
    // The streak: 120 px down column 350, as bright: a round blob of the PSF (sigma 1.5) every
    // pixel, each of peak 40 / (sqrt(2 pi) 1.5), so the line's peak is 40 grey levels.
    for k in 0..120 {
        blob(&mut img, 350.0, 180.0 + k as f64, 1.5, 1.5, 40.0 / 3.76);
    }
    let pixels: Vec<u8> = img
        .iter()
        .map(|&v| v.round().clamp(0.0, 255.0) as u8)
        .collect();
    let (found, dropped) = detect_streaks_explained(&pixels, W, W, &StreakParams::default(), None);
    let confident: Vec<_> = found.iter().filter(|c| c.detection.score >= 0.5).collect();
    let at = |c: &&soig::detect::streak::Candidate, x: f64| {
        (c.detection.x1..=c.detection.x2).contains(&x)
    };
    assert!(
        confident
            .iter()
            .any(|c| at(c, 350.0) && c.length_px > 100.0),
        "the streak: {found:?}"
    );
    assert!(
        !confident.iter().any(|c| at(c, 150.0)),
        "a box on the chain: {found:?}"
    );
    let gap = dropped
        .iter()
        .find(|d| matches!(d.reason, Reason::Gap { .. }) && (d.ends[0][0] - 150.5).abs() < 5.0);
    assert!(
        gap.is_some(),
        "the chain is not dropped for a gap: {dropped:#?}"
    );
}
