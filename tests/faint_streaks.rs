//! The streak detector on real sensor noise (issue #36): streaks at a per-pixel SNR of 1, too
//! faint for any local line filter but with an integrated (matched-filter) SNR of 20-40, are
//! found on the noise of each NEOSSat frame in tests/fixtures/neossat/, and the debris-free
//! backgrounds of the three frames give no box at confidence 0.5.
//!
//! The images are made as a semisynthetic campaign makes them: the frame's prepared noise
//! field (its sources and trails masked, hot pixels and column structure kept) filled to
//! 1024 x 1024 at the frame's own exposure, the streak added in ADU, then soig's default
//! enhancement (square root, CLAHE, gamma) to 8 bits, and the detector with its defaults.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use soig::background::RealFrame;
use soig::detect::streak::{Candidate, StreakParams, detect_streaks};
use soig::enhance;
use soig::imaging::robust_stats;
use soig::rng::{PixelPurpose, pixel_stream};

mod common;
use common::{NEOSSAT_FRAMES, real_frame};

const SIZE: usize = 1024;
/// The detector's default PSF sigma, pixels: the streaks are drawn with it.
const PSF: f64 = 1.5;

/// Background `i` of a frame at its own exposure (ADU).
fn background(f: &RealFrame, i: u64) -> Vec<f32> {
    let mut rng = pixel_stream(36, i, PixelPurpose::Noise);
    let phase = (53 * i as usize + 7, 29 * i as usize + 3);
    f.background(SIZE, SIZE, f.exposure_s, phase, &mut rng)
}

fn detect(adu: &[f32]) -> Vec<Candidate> {
    let settings = soig::experiment::enhance_settings(None);
    let img = enhance::enhance(adu, SIZE, SIZE, &settings);
    detect_streaks(&img.pixels, SIZE, SIZE, &StreakParams::default(), None)
}

/// The standard normal CDF (soig's erfc, good to 1.2e-7).
fn phi(x: f64) -> f64 {
    0.5 * soig::psf::erfc(-x / std::f64::consts::SQRT_2)
}

/// A streak of `len` pixels through the image centre at `angle_deg`: Gaussian cross-section
/// of peak `amp` ADU, erf ends. Returns the signal image.
fn streak(len: f64, angle_deg: f64, amp: f64) -> Vec<f64> {
    let (ux, uy) = (angle_deg.to_radians().cos(), angle_deg.to_radians().sin());
    let c = SIZE as f64 / 2.0;
    let (x0, y0) = (c - 0.5 * len * ux, c - 0.5 * len * uy);
    let mut s = vec![0.0; SIZE * SIZE];
    for y in 0..SIZE {
        for x in 0..SIZE {
            let (dx, dy) = (x as f64 - x0, y as f64 - y0);
            let t = dx * ux + dy * uy;
            let u = -dx * uy + dy * ux;
            if u.abs() > 6.0 * PSF || t < -6.0 * PSF || t > len + 6.0 * PSF {
                continue;
            }
            let along = phi(t / PSF) - phi((t - len) / PSF);
            s[y * SIZE + x] = amp * (-u * u / (2.0 * PSF * PSF)).exp() * along;
        }
    }
    s
}

/// The box holding the streak's pixels of at least 1 % of its peak (pixel-edge coordinates).
fn truth_box(s: &[f64], amp: f64) -> [f64; 4] {
    let mut b = [f64::INFINITY, f64::INFINITY, 0.0f64, 0.0f64];
    for (i, &v) in s.iter().enumerate() {
        if v >= 0.01 * amp {
            let (x, y) = ((i % SIZE) as f64, (i / SIZE) as f64);
            b = [
                b[0].min(x),
                b[1].min(y),
                b[2].max(x + 1.0),
                b[3].max(y + 1.0),
            ];
        }
    }
    b
}

fn iou(a: &[f64; 4], c: &Candidate) -> f64 {
    let d = &c.detection;
    let ix = (a[2].min(d.x2) - a[0].max(d.x1)).max(0.0);
    let iy = (a[3].min(d.y2) - a[1].max(d.y1)).max(0.0);
    let inter = ix * iy;
    inter / ((a[2] - a[0]) * (a[3] - a[1]) + (d.x2 - d.x1) * (d.y2 - d.y1) - inter)
}

#[test]
fn debris_free_backgrounds_of_the_three_frames_give_no_box() {
    for name in NEOSSAT_FRAMES {
        let f = real_frame(name);
        for i in 0..2 {
            let found = detect(&background(&f, i));
            let strong: Vec<_> = found.iter().filter(|c| c.detection.score >= 0.5).collect();
            assert!(strong.is_empty(), "{name} background {i}: {strong:?}");
        }
    }
}

/// Measured 2026-11-26 (IoU of the best box at confidence 0.5): every streak of L >= 300 px off
/// the rows is found on all three frames (IoU 0.89-1.00), and all six on the raw science frame
/// and on the calibrated frame (0.91-1.00; its 240 px at 20 deg was missed before the map was
/// centred on its median, see `detect::streak`). Missed: on the dark frame (the semisynthetic
/// test sets' noise) the 240 px at 20 deg (MF SNR 25), the 200 px at 60 deg (23) and the
/// row-aligned 400 px (32.5: its row-correlated noise makes sums along rows several times noisier
/// than white noise). The test asserts the first set and at least 15 of the 18.
#[test]
fn streaks_of_per_pixel_snr_1_and_integrated_snr_20_to_40_are_found() {
    // (length px, angle deg): lengths chosen so that the white-noise matched-filter SNR
    // sqrt(sum (s / sigma)^2) = sqrt(L sqrt(pi) psf) spans 23-38.5; angles along the rows and
    // columns (where the sensor's structure is) and away from them.
    let cases = [
        (240.0, 20.0),
        (300.0, 90.0),
        (560.0, 133.0),
        (400.0, 0.0),
        (200.0, 60.0),
        (400.0, 160.0),
    ];
    let mut report = Vec::new();
    let (mut found_n, mut must_miss) = (0, 0);
    for name in NEOSSAT_FRAMES {
        let f = real_frame(name);
        for (j, &(len, angle)) in cases.iter().enumerate() {
            let bg = background(&f, 10 + j as u64);
            // Per-pixel SNR 1: the streak's peak equals the robust noise sigma of this very
            // background (MAD, so the hot-pixel tail does not inflate it).
            let (_, sigma) = robust_stats(&bg);
            let amp = sigma;
            let s = streak(len, angle, amp);
            let mf: f64 = s.iter().map(|v| (v / amp) * (v / amp)).sum::<f64>().sqrt();
            assert!((20.0..=40.0).contains(&mf), "{name} L {len}: MF SNR {mf}");
            let adu: Vec<f32> = bg.iter().zip(&s).map(|(&b, &v)| b + v as f32).collect();
            let truth = truth_box(&s, amp);
            let found = detect(&adu);
            let best = found
                .iter()
                .filter(|c| c.detection.score >= 0.5)
                .map(|c| iou(&truth, c))
                .fold(0.0, f64::max);
            report.push(format!(
                "{name} L {len} at {angle} deg (MF SNR {mf:.1}): best IoU {best:.2}"
            ));
            let hit = best >= 0.5;
            found_n += usize::from(hit);
            if len >= 300.0 && angle != 0.0 && !hit {
                must_miss += 1;
            }
        }
    }
    let report = report.join("\n");
    eprintln!("{report}");
    assert_eq!(
        must_miss, 0,
        "a streak of L >= 300 px off the rows missed:\n{report}"
    );
    assert!(found_n >= 15, "only {found_n} of 18 found:\n{report}");
}
