//! Survey pointing, rotation and padding: star trails, label boxes and frames (issue #3).

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use rand_chacha::ChaCha12Rng;
use soig::campaign::Campaign;
use soig::geometry::{self, Fill, Frame, FrameKind, LABEL_SHARE};
use soig::scene::Pointing;

mod common;
use common::{CampaignToml, leo_and_geo, neossat_frame, rendered, tle_object};

fn campaign(mode: &str) -> Campaign {
    leo_and_geo("geom", mode, "")
        .tables("[render]\ntrajectory_samples = 800\n")
        .load("geom.toml")
}

#[test]
fn survey_star_trails_are_parallel_and_horizontal_after_rotation() {
    let c = campaign("survey");
    let sensor = soig::experiment::of(&c).sensor;
    for image in rendered(&c, 4) {
        let s = image.scene;
        let Pointing::Survey(track) = s.exposure.pointing else {
            panic!("survey scene expected")
        };
        let frame = Frame::new(FrameKind::Rotated, 512, 512, 0, track.trail_angle_deg);
        let tan = s.projection(&sensor);
        let at = |t: f64, ra: f64, dec: f64| s.pixel_at(&tan, t, ra, dec);
        let mut n = 0;
        for star in s.exposure.stars.iter().take(200) {
            let (Some(p), Some(q)) = (
                at(0.0, star.ra_deg, star.dec_deg),
                at(s.exposure.exposure_s, star.ra_deg, star.dec_deg),
            ) else {
                continue;
            };
            // In the original image every trail runs along the trail angle: they are parallel...
            let ang = (q.1 - p.1).atan2(q.0 - p.0).to_degrees();
            let d = (ang - track.trail_angle_deg + 540.0).rem_euclid(360.0) - 180.0;
            assert!(d.abs() < 1.0, "trail at {ang} vs {}", track.trail_angle_deg);
            // ...and after rotation it is horizontal within 1 degree.
            let (p2, q2) = (frame.map(p.0, p.1), frame.map(q.0, q.1));
            let tilt = (q2.1 - p2.1).atan2(q2.0 - p2.0).to_degrees();
            assert!(tilt.abs() < 1.0, "tilt {tilt}");
            n += 1;
        }
        assert!(n > 10);
        // The trail is as long as the drift says.
        let drift_px = track.drift_deg / sensor.pixel_scale_deg();
        let (ra, dec) = (s.exposure.stars[0].ra_deg, s.exposure.stars[0].dec_deg);
        let (p, q) = (
            at(0.0, ra, dec).unwrap(),
            at(s.exposure.exposure_s, ra, dec).unwrap(),
        );
        let len = (q.0 - p.0).hypot(q.1 - p.1);
        assert!(
            (len - drift_px).abs() < 0.01 * drift_px,
            "{len} vs {drift_px}"
        );
    }
}

/// The smallest box holding at least `share` of an image's flux, by brute force over the
/// tightest quantile boxes: the reference "needed" box.
fn needed_extent(img: &[f32], w: usize, h: usize, share: f64) -> (f64, f64) {
    let mut col = vec![0.0f64; w];
    let mut row = vec![0.0f64; h];
    for j in 0..h {
        for i in 0..w {
            col[i] += img[j * w + i] as f64;
            row[j] += img[j * w + i] as f64;
        }
    }
    let narrowest = |hist: &[f64]| {
        let total: f64 = hist.iter().sum();
        let mut best = hist.len() as f64;
        for lo in 0..hist.len() {
            let mut acc = 0.0;
            for (k, v) in hist[lo..].iter().enumerate() {
                acc += v;
                if acc >= share * total {
                    best = best.min((k + 1) as f64);
                    break;
                }
            }
        }
        best
    };
    (narrowest(&col), narrowest(&row))
}

#[test]
fn label_box_is_the_tight_box_of_the_streak_in_every_frame() {
    for mode in ["fixed", "survey"] {
        let c = campaign(mode);
        for image in rendered(&c, 3) {
            let (s, e) = (image.scene, image.exposure);
            let debris: Vec<f32> = e.debris_electrons.iter().map(|&v| v as f32).collect();
            let mut frames = vec![
                Frame::new(FrameKind::Original, 512, 512, 0, 0.0),
                Frame::new(FrameKind::Padded, 512, 512, 32, 0.0),
            ];
            if let Pointing::Survey(t) = s.exposure.pointing {
                frames.push(Frame::new(
                    FrameKind::Rotated,
                    512,
                    512,
                    0,
                    t.trail_angle_deg,
                ));
            }
            for f in frames {
                let img = geometry::warp::<ChaCha12Rng>(&debris, 512, 512, &f, Fill::Zero);
                let total: f64 = img.iter().map(|&v| v as f64).sum();
                let b = geometry::flux_box(&img, f.width, f.height, LABEL_SHARE).unwrap();
                let mut inside = 0.0;
                for j in 0..f.height {
                    for i in 0..f.width {
                        if (i as f64) > b.x_min
                            && (i as f64) < b.x_max
                            && (j as f64) > b.y_min
                            && (j as f64) < b.y_max
                        {
                            inside += img[j * f.width + i] as f64;
                        }
                    }
                }
                assert!(
                    inside >= 0.99 * total,
                    "{mode} {}: box holds {:.4} of the flux",
                    f.kind.name(),
                    inside / total
                );
                // Needed: on each axis, the narrowest range holding 99.5% of the flux (a box that
                // narrow on both axes is sure to hold 99% in 2-D).
                let (nw, nh) = needed_extent(&img, f.width, f.height, 0.995);
                assert!(
                    b.x_max - b.x_min <= nw + 2.0 && b.y_max - b.y_min <= nh + 2.0,
                    "{mode} {}: box {:?} vs needed {nw} x {nh}",
                    f.kind.name(),
                    b
                );
            }
        }
    }
}

#[test]
fn semisynthetic_background_has_the_real_frames_noise_scaled_by_exposure() {
    let frame = neossat_frame();
    let c = CampaignToml::new("semi", 3, 3)
        .observer(&tle_object(37216))
        .debris(&tle_object(40989))
        .tables(&format!(
            "[background]\nkind = \"frames\"\npaths = [\"{}\"]\n",
            frame.display()
        ))
        .load("semi.toml");
    let real = soig::background::RealFrame::load(&frame).unwrap();
    for image in rendered(&c, 3) {
        let (s, e) = (image.scene, image.exposure);
        assert!(s.exposure.background.is_some());
        // Background = ADU - electrons / gain - bias (uniform 2..3, mean 2.5).
        let bg: Vec<f32> = e
            .adu
            .iter()
            .zip(&e.electrons)
            .map(|(&a, &el)| a - el as f32 / 1.6 - 2.5)
            .collect();
        let (median, sigma) = soig::imaging::robust_stats(&bg);
        let k = s.exposure.exposure_s / real.exposure_s;
        let expected_sigma = ((real.sigma * k).powi(2) + 1.0 / 12.0).sqrt();
        assert!(
            (sigma - expected_sigma).abs() < 0.03 * expected_sigma,
            "sigma {sigma} vs {expected_sigma}"
        );
        // On the frame's own level scaled by exposure (paper 3.4): its median, scaled.
        let level = real.median * k;
        assert!(
            (median - level).abs() < 0.05 * expected_sigma,
            "median {median} vs {level}"
        );
        assert!((e.truth.background_sigma_adu - expected_sigma).abs() < 0.03 * expected_sigma);
    }
}
