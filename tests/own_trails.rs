//! The streak detector on frames no soig code drew (`independent`): with no catalogue and no
//! trail direction given, it measures the star trails' direction on the frame itself
//! (`detect::streak::OwnTrails`) and keeps debris off that direction, and a frame of point
//! stars is left as it was. Frames of 512 px, PSF sigma 1.4 px, sky 300 e-, read noise 8 e-.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

mod independent;

use independent::{Rng, Segment, Sensor, frame};
use soig::detect::streak::{OwnTrails, StreakParams, detect_streaks, detect_streaks_on_frame};
use soig::imaging::point_segment_distance as distance;

const SIZE: usize = 512;
const SENSOR: Sensor = Sensor {
    psf_sigma: 1.4,
    sky: 300.0,
    read_noise: 8.0,
};

/// The streak detector's defaults with the test sensor's PSF.
fn params() -> StreakParams {
    StreakParams {
        psf_sigma_px: SENSOR.psf_sigma,
        ..StreakParams::default()
    }
}

/// A survey frame: `stars` trails along `trail_deg`, all `trail_len` px long, peak SNR
/// log-uniform in 0.5-20 per pixel, centred anywhere (cut by the frame's edge), and one debris
/// streak `off_deg` from them, 80-300 px, peak SNR 1.5-6 per pixel, inside the frame.
fn survey(rng: &mut Rng, trail_deg: f64, off_deg: f64, stars: usize) -> (Vec<u8>, Segment) {
    let trail_len = rng.range(100.0, 250.0);
    let (tx, ty) = (trail_deg.to_radians().cos(), trail_deg.to_radians().sin());
    let mut segs: Vec<Segment> = (0..stars)
        .map(|_| {
            let (cx, cy) = (rng.range(0.0, SIZE as f64), rng.range(0.0, SIZE as f64));
            let snr = (rng.range(0.5f64.ln(), 20f64.ln())).exp();
            let hl = 0.5 * trail_len;
            Segment {
                a: (cx - hl * tx, cy - hl * ty),
                b: (cx + hl * tx, cy + hl * ty),
                per_px: SENSOR.per_px_for_peak_snr(snr),
            }
        })
        .collect();
    let debris = debris(rng, trail_deg + off_deg);
    segs.push(debris);
    (frame(SIZE, SIZE, &SENSOR, &segs, rng), debris)
}

/// A debris streak along `deg`, 80-300 px, peak SNR 1.5-6 per pixel, inside the frame.
fn debris(rng: &mut Rng, deg: f64) -> Segment {
    let len = rng.range(80.0, 300.0);
    let (dx, dy) = (deg.to_radians().cos(), deg.to_radians().sin());
    let m = 0.5 * len + 10.0;
    let lo = |d: f64| (m * d.abs()).max(10.0);
    let cx = rng.range(lo(dx), SIZE as f64 - lo(dx));
    let cy = rng.range(lo(dy), SIZE as f64 - lo(dy));
    Segment {
        a: (cx - 0.5 * len * dx, cy - 0.5 * len * dy),
        b: (cx + 0.5 * len * dx, cy + 0.5 * len * dy),
        per_px: SENSOR.per_px_for_peak_snr(rng.range(1.5, 6.0)),
    }
}

/// Whether a detection (ends in pixel-edge coordinates) is the debris streak: both its ends
/// within 6 px of the streak's axis (its half-level ends, the PSF's width and the edge
/// convention's half pixel), and at least half its length.
fn is_debris(ends: &[[f64; 2]; 2], d: &Segment) -> bool {
    let e = ends.map(|[x, y]| (x - 0.5, y - 0.5));
    let len = (e[1].0 - e[0].0).hypot(e[1].1 - e[0].1);
    e.iter().all(|&p| distance(p, d.a, d.b) <= 6.0) && len >= 0.5 * d.length()
}

/// 24 survey frames, half with the debris within 5 degrees of the trails (1.5-5 degrees off
/// them, either side; closer than about 1 degree it is taken for a star by design), half
/// beyond (5-90); every frame's trails at their own direction. The trails' direction is
/// measured to 0.5 degree in every frame (the settled direction is the length-weighted median
/// orientation of the lines found along the trails, each measured to 0.1-0.3 degree; measured
/// here: within 0.16). At confidence 0.5, measured 2026-11-28: 2 of 12 found within 5 degrees,
/// 11 of 12 beyond (the miss: peak SNR 1.7 a pixel), 3 false boxes. The bounds below are those
/// figures less one streak each, so that a change which loses more fails (2026-11-29, with the
/// seam cut: 3 of 12, 11 of 12, 4 false boxes, at the bound); issue #44 asks for
/// 0.85 within and 0.95 beyond at P 0.95, which this does not reach (within 5 degrees the
/// star-aware pass would need the trails subtracted, as the catalogue's are).
#[test]
fn trails_measured_and_debris_off_them_found() {
    let params = params();
    let mut rng = Rng::new(44);
    let (mut within, mut beyond, mut false_boxes) = ((0, 0), (0, 0), 0);
    for k in 0..24 {
        let trail = rng.range(0.0, 180.0);
        let near = k % 2 == 0;
        let side = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
        let off = side
            * if near {
                rng.range(1.5, 5.0)
            } else {
                rng.range(5.0, 90.0)
            };
        let (pixels, d) = survey(&mut rng, trail, off, 40);
        let (found, own) = detect_streaks_on_frame(&pixels, SIZE, SIZE, &params, None, None);
        let model = match own {
            Some(OwnTrails::Common(m)) => m,
            other => panic!("frame {k}: trails at {trail:.2} deg, measured {other:?}"),
        };
        let err = (model.angle_deg - trail + 90.0).rem_euclid(180.0) - 90.0;
        assert!(
            err.abs() <= 0.5,
            "frame {k}: trails at {trail:.2} deg, measured {:.2}",
            model.angle_deg
        );
        let kept: Vec<_> = found.iter().filter(|c| c.detection.score >= 0.5).collect();
        let hit = kept.iter().any(|c| is_debris(&c.ends, &d));
        false_boxes += kept.iter().filter(|c| !is_debris(&c.ends, &d)).count();
        let tally = if near { &mut within } else { &mut beyond };
        tally.0 += usize::from(hit);
        tally.1 += 1;
        eprintln!(
            "frame {k}: trails {trail:.2}, measured {:.2}, debris {off:+.2} off, SNR/px {:.1}, {:.0} px: {}; {} boxes",
            model.angle_deg,
            d.per_px / SENSOR.per_px_for_peak_snr(1.0),
            d.length(),
            if hit { "found" } else { "missed" },
            kept.len()
        );
    }
    eprintln!("within 5 deg {within:?}, beyond {beyond:?}, false boxes {false_boxes}");
    assert!(within.0 >= 1, "within 5 degrees: {within:?}");
    assert!(beyond.0 >= 10, "beyond 5 degrees: {beyond:?}");
    assert!(false_boxes <= 4, "{false_boxes} false boxes");
}

/// Point stars (no trails) and one debris streak: no common trail direction, and the
/// detections are exactly those of the detector told nothing (the frame is left as it was).
#[test]
fn point_stars_leave_the_frame_as_it_was() {
    let params = params();
    let mut rng = Rng::new(45);
    for k in 0..6 {
        let mut segs: Vec<Segment> = (0..150)
            .map(|_| {
                let p = (rng.range(0.0, SIZE as f64), rng.range(0.0, SIZE as f64));
                // A point: a segment of a tenth of a pixel holding a Gaussian of this peak SNR.
                let snr = (rng.range(1f64.ln(), 200f64.ln())).exp();
                let total = snr * SENSOR.noise() * 2.0 * std::f64::consts::PI * 1.4 * 1.4;
                Segment {
                    a: p,
                    b: (p.0 + 0.1, p.1),
                    per_px: total / 0.1,
                }
            })
            .collect();
        let deg = rng.range(0.0, 180.0);
        let d = debris(&mut rng, deg);
        segs.push(d);
        let pixels = frame(SIZE, SIZE, &SENSOR, &segs, &mut rng);
        let (found, own) = detect_streaks_on_frame(&pixels, SIZE, SIZE, &params, None, None);
        assert!(
            matches!(own, Some(OwnTrails::NoCommonDirection { .. })),
            "frame {k}: {own:?}"
        );
        let plain = detect_streaks(&pixels, SIZE, SIZE, &params, None);
        assert_eq!(found, plain, "frame {k}");
    }
}
