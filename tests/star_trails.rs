//! The star-trail prediction of the star-aware streak detector (`render::trails`, issue #30)
//! against the rendered noise-free image: every star's predicted path lies on its light.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use soig::campaign::Campaign;
use soig::imaging::point_segment_distance;
use soig::render::trails::star_trails;

mod common;
use common::{CampaignToml, rendered, tle_object};

/// Images of 512 px in pointing `mode`; `sensor` adds keys to `[sensor]`.
fn campaign(mode: &str, sensor: &str) -> Campaign {
    CampaignToml::leo("trails", 11, 4)
        .debris(&tle_object(40989))
        .tables(&format!(
            "[pointing]\nmode = \"{mode}\"\n[sensor]\nwidth_px = 512\nheight_px = 512\nfov_radius_deg = 0.05\n{sensor}[render]\ntrajectory_samples = 800\n",
        ))
        .load("trails.toml")
}

/// Distance from `q` to the polyline `nodes`, and the signed lateral offset from its chord.
fn distance(q: (f64, f64), nodes: &[[f64; 2]]) -> f64 {
    let seg = |a: [f64; 2], b: [f64; 2]| point_segment_distance(q, (a[0], a[1]), (b[0], b[1]));
    if nodes.len() == 1 {
        return seg(nodes[0], nodes[0]);
    }
    nodes
        .windows(2)
        .map(|p| seg(p[0], p[1]))
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn predicted_star_trails_lie_on_the_rendered_starlight() {
    let mut centroids = 0;
    // Survey and track pointing, with the paper's jitter and without (the prediction then
    // knows the whole pointing).
    for (c, jitter) in [
        (campaign("survey", ""), true),
        (campaign("survey", "jitter_deg_per_sqrt_s = 0.0\n"), false),
        (campaign("track", ""), true),
        (campaign("track", "jitter_deg_per_sqrt_s = 0.0\n"), false),
    ] {
        let sensor = soig::experiment::of(&c).sensor;
        let psf = sensor.psf_sigma_px();
        let (w, h) = (sensor.width_px, sensor.height_px);
        for image in rendered(&c, 4) {
            let e = &image.exposure;
            let trails = star_trails(&sensor, &image.scene, e.truth.jitter_mean_px);
            // The renderer's margin adds the jitter's largest excursion, which a prediction
            // does not know: it may leave out a few stars passing just beyond that margin.
            assert!(
                trails.len() <= e.stars.len() && trails.len() * 10 >= e.stars.len() * 9,
                "{} predicted of {} traced",
                trails.len(),
                e.stars.len()
            );
            let star: Vec<f64> = e
                .electrons
                .iter()
                .zip(&e.debris_electrons)
                .map(|(&a, &d)| (a - d) as f64)
                .collect();
            // 1. Where the starlight is: within 5 PSF sigmas (plus 2 px for the jitter about
            // its mean) of some predicted path, all but 1% of it (a Gaussian leaves 4e-6 beyond
            // 5 sigma; the rest is the scatter of photon packets and the stars left out).
            let reach = 5.0 * psf + 2.0;
            let mut near = vec![false; w * h];
            for t in &trails {
                let lo = |k: usize| {
                    let v = t.nodes.iter().map(|n| n[k]).fold(f64::MAX, f64::min);
                    (v - reach).floor().max(0.0) as usize
                };
                let hi = |k: usize, n: usize| {
                    let v = t.nodes.iter().map(|n| n[k]).fold(f64::MIN, f64::max);
                    (v + reach).ceil().clamp(0.0, n as f64 - 1.0) as usize
                };
                for y in lo(1)..=hi(1, h) {
                    for x in lo(0)..=hi(0, w) {
                        if !near[y * w + x] && distance((x as f64, y as f64), &t.nodes) <= reach {
                            near[y * w + x] = true;
                        }
                    }
                }
            }
            let total: f64 = star.iter().sum();
            let inside: f64 = star
                .iter()
                .zip(&near)
                .filter(|(_, n)| **n)
                .map(|(s, _)| s)
                .sum();
            assert!(total > 0.0);
            assert!(
                inside >= 0.99 * total,
                "image {}: {inside} of {total} electrons near a predicted trail",
                image.scene.exposure.image_index
            );
            // 2. Without jitter, across the trail: the light's centroid within 3 PSF sigmas of
            // each of the three brightest trails is on the path to 0.2 px (a trail of 3000 or
            // more electrons has a centroid uncertain by under 0.03 px; whole pixels cut the
            // 3-sigma window unevenly by up to a pixel on a side, which moves it by up to 0.1). With jitter the light
            // wanders about its mean shift by a pixel or two within the exposure, which a
            // prediction from the WCS cannot know.
            if jitter {
                continue;
            }
            // Only trails no other star's light reaches (all trails are parallel, and one
            // passing within a few pixels would pull the centroid).
            let alone = |t: &&soig::render::trails::PredictedTrail| {
                trails.iter().all(|o| {
                    std::ptr::eq(o, *t)
                        || o.nodes
                            .iter()
                            .all(|n| distance((n[0], n[1]), &t.nodes) > 6.0 * psf)
                })
            };
            let mut bright: Vec<_> = trails
                .iter()
                .filter(|t| t.nodes.len() >= 8)
                .filter(alone)
                .collect();
            bright.sort_by(|a, b| b.electrons.unwrap().total_cmp(&a.electrons.unwrap()));
            for t in bright.iter().take(3) {
                // Signed offsets from the path itself (a long trail bends by a fraction of a
                // pixel away from its chord), within its ends.
                let (mut sw, mut swd) = (0.0, 0.0);
                for y in 0..h {
                    for x in 0..w {
                        let q = (x as f64, y as f64);
                        let mut best: Option<(f64, f64)> = None;
                        for p in t.nodes.windows(2) {
                            let (a, b) = (p[0], p[1]);
                            let len = (b[0] - a[0]).hypot(b[1] - a[1]);
                            let (ux, uy) = ((b[0] - a[0]) / len, (b[1] - a[1]) / len);
                            let (dx, dy) = (q.0 - a[0], q.1 - a[1]);
                            let along = dx * ux + dy * uy;
                            let across = -dx * uy + dy * ux;
                            if (0.0..=len).contains(&along)
                                && best.is_none_or(|(d, _)| across.abs() < d)
                            {
                                best = Some((across.abs(), across));
                            }
                        }
                        if let Some((d, across)) = best
                            && d <= 3.0 * psf
                        {
                            sw += star[y * w + x];
                            swd += star[y * w + x] * across;
                        }
                    }
                }
                if sw < 3000.0 {
                    continue;
                }
                let centroid = swd / sw;
                centroids += 1;
                assert!(
                    centroid.abs() < 0.2,
                    "image {}: trail of magnitude {:.2} off by {centroid:.3} px",
                    image.scene.exposure.image_index,
                    t.mag
                );
            }
        }
    }
    assert!(centroids >= 2, "only {centroids} trails measured across");
}

/// `soig run`'s star-aware pass reads nothing of the truth (issue #44): the image's mean
/// pointing offset, which the prediction once took from the truth sidecar's `jitter_mean_px`,
/// is measured on the image (`star_trails::pointing_offset`, which `of_image` applies; neither
/// takes a path). On 6 survey images of 512 px with the paper's jitter, the offset fitted to
/// the still pointing's predicted trails, against the recorded mean jitter: across the trails
/// 0.04-0.56 px, and 1.93 in one image (the brightest trails show the jitter of the part of
/// the exposure they were in the image for, not its mean; the pass then follows the wander
/// across the trails itself, `jitter_across`), hence 2.5 px; along them 0.14-2.95 px (only the
/// trails' ends tell), hence 4.
#[test]
fn the_pointing_offset_is_measured_on_the_image() {
    use soig::detect::streak::StarTrail;
    let c = campaign("survey", "");
    let x = soig::experiment::of(&c);
    let inputs = soig::experiment::inputs(&c).unwrap();
    for i in 0..6 {
        let image = soig::simulate::image(&x, &inputs, i).unwrap();
        let png = &image.product.as_ref().expect("a PNG").png;
        assert!(image.product.as_ref().unwrap().frame.is_identity());
        let trails: Vec<StarTrail> = star_trails(&x.sensor, &image.scene, [0.0, 0.0])
            .iter()
            .filter_map(|t| t.on_image(|[x, y]| Some((x, y))))
            .collect();
        const ACROSS_PX: f64 = 2.5;
        const ALONG_PX: f64 = 4.0;
        let got = soig::star_trails::pointing_offset(&trails, &png.pixels, png.width, png.height);
        let want = image.exposure.truth.jitter_mean_px;
        // The miss across the trails and along them.
        let t = trails.iter().find(|t| t.nodes.len() >= 2).expect("a trail");
        let (a, b) = (t.nodes[0], t.nodes[t.nodes.len() - 1]);
        let l = (b.0 - a.0).hypot(b.1 - a.1);
        let (ux, uy) = ((b.0 - a.0) / l, (b.1 - a.1) / l);
        let (ex, ey) = (got.0 - want[0], got.1 - want[1]);
        let (along, across) = ((ex * ux + ey * uy).abs(), (-ex * uy + ey * ux).abs());
        eprintln!(
            "image {i}: measured {got:?}, recorded {want:?}: {across:.2} px across, {along:.2} along"
        );
        assert!(
            across <= ACROSS_PX && along <= ALONG_PX,
            "image {i}: measured {got:?}, recorded {want:?}: {across:.2} px across, {along:.2} along"
        );
    }
}
