//! Photon counts against Eq. 3, merging, jitter, and the two renderers against each other.

use super::*;
use soig_base::rng::{PixelPurpose, pixel_stream};
use soig_sky::stars::Star;

/// The sensor and render settings of the tests.
struct Fixture {
    sensor: Sensor,
    render: Settings,
}

/// The paper's detector, optics and render settings on a 128 px image with a 0.0125 deg
/// field radius, and the given jitter (the paper's: 2e-4 deg per sqrt(s)).
fn fixture(jitter_deg_per_sqrt_s: f64) -> Fixture {
    Fixture {
        sensor: Sensor::for_tests(128, jitter_deg_per_sqrt_s),
        render: Settings {
            method: RenderMethod::PhotonMapping,
            merge_threshold: 100_000,
            merge_factor: 5,
            jitter_steps: 2000,
        },
    }
}

/// The projection of the test scenes: centred on (10, 20), 128 px.
fn tan_of(c: &Fixture) -> soig_sky::projection::Tan {
    c.sensor.projection(10.0, 20.0)
}

/// A scene centred on (10, 20) with the given stars and a debris streak along +x.
fn scene(c: &Fixture, stars: Vec<Star>, debris_mag: f64, exposure_s: f64) -> Scene {
    let ends = ((30.0, 40.0), (90.0, 40.0));
    Scene::fixed_streak(&c.sensor, (10.0, 20.0), stars, debris_mag, ends, exposure_s)
}

/// Scene `s` rendered on the fixture's sensor, with no real frame, on the photon and noise
/// streams of (`seed`, `i`).
fn rendered(c: &Fixture, s: &Scene, seed: u64, i: u64) -> Exposure {
    render(
        &c.sensor,
        &c.render,
        s,
        None,
        &mut pixel_stream(seed, i, PixelPurpose::Photons),
        &mut pixel_stream(seed, i, PixelPurpose::Noise),
    )
}

#[test]
fn mean_photons_match_eq3_within_poisson_error() {
    // One star in the middle, far from the edges, and a debris streak: over many seeds the
    // mean of the rendered photo-electrons matches t 10^(-0.4 (m - ZP)) within Poisson error.
    let c = fixture(2e-4);
    let tan = tan_of(&c);
    let (ra, dec) = tan.sky(90.0, 90.0);
    let star_mag = 15.0;
    let debris_mag = 14.0;
    let exposure = 5.0;
    let s = scene(
        &c,
        vec![Star {
            ra_deg: ra,
            dec_deg: dec,
            mag: star_mag,
        }],
        debris_mag,
        exposure,
    );
    let zp = c.sensor.zero_point_mag;
    let star_expected = exposure * 10f64.powf(-0.4 * (star_mag - zp));
    let debris_expected = exposure * 10f64.powf(-0.4 * (debris_mag - zp));
    let runs = 200;
    let (mut star_sum, mut debris_sum) = (0.0, 0.0);
    for i in 0..runs {
        let e = rendered(&c, &s, 1, i);
        let total: u64 = e.electrons.iter().map(|&v| v as u64).sum();
        debris_sum += e.truth.seen.rendered_debris_electrons as f64;
        star_sum += (total - e.truth.seen.rendered_debris_electrons) as f64;
        assert!(
            (e.truth.seen.expected_debris_electrons - debris_expected).abs()
                < 1e-6 * debris_expected
        );
    }
    for (sum, expected) in [(star_sum, star_expected), (debris_sum, debris_expected)] {
        let mean = sum / runs as f64;
        let sigma_of_mean = (expected / runs as f64).sqrt();
        assert!(
            (mean - expected).abs() < 4.0 * sigma_of_mean,
            "mean {mean} vs Eq. 3 {expected} (sigma of mean {sigma_of_mean})"
        );
    }
}

#[test]
fn merged_packets_keep_the_total_and_the_label_holds_the_streak() {
    // A source above the merge threshold is traced in packets; the count stays exact.
    let mut c = fixture(2e-4);
    c.render.merge_threshold = 1000;
    c.render.merge_factor = 5;
    let s = scene(&c, vec![], 10.0, 2.0);
    let e = rendered(&c, &s, 2, 0);
    let total: u64 = e.electrons.iter().map(|&v| v as u64).sum();
    assert_eq!(total, e.truth.seen.rendered_debris_electrons);
    let b = e.truth.label_box_px.unwrap();
    // The streak runs from x = 30 to 90 at y = 40; the box holds it with PSF margins.
    assert!(b.x_min <= 30.0 && b.x_max >= 89.5, "{b:?}");
    assert!(
        b.y_min <= 40.0 && b.y_max >= 40.0 && b.y_max - b.y_min < 12.0,
        "{b:?}"
    );
    // Background and bias scale as Eq. 11: with no source the mean ADU is the mean of
    // background (scaled to 2 s) plus bias.
    let mean_adu = e.adu.iter().map(|&a| a as f64).sum::<f64>() / e.adu.len() as f64;
    let expected_bg = 200.0 * 2.0 / 5.0 + 2.5 + total as f64 / 1.6 / e.adu.len() as f64;
    assert!(
        (mean_adu - expected_bg).abs() < 0.1,
        "{mean_adu} vs {expected_bg}"
    );
}

#[test]
fn star_centroid_lands_where_the_wcs_says() {
    // With the pointing jitter on, a bright star's flux centroid is the traced position
    // (nominal + mean jitter), which is where the FITS WCS (CRPIX shifted) puts it.
    let c = fixture(3e-4);
    let tan = tan_of(&c);
    let (ra, dec) = tan.sky(64.3, 70.8);
    let s = scene(
        &c,
        vec![Star {
            ra_deg: ra,
            dec_deg: dec,
            mag: 12.0,
        }],
        30.0,
        8.0,
    );
    for i in 0..5 {
        let e = rendered(&c, &s, 3, i);
        let st = e.stars[0];
        let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
        for y in 0..128 {
            for x in 0..128 {
                let v = e.electrons[y * 128 + x] as f64;
                sx += v * x as f64;
                sy += v * y as f64;
                sw += v;
            }
        }
        let (cx, cy) = (sx / sw, sy / sw);
        assert!(
            (cx - st.x).abs() < 0.05 && (cy - st.y).abs() < 0.05,
            "centroid {cx},{cy} vs {},{}",
            st.x,
            st.y
        );
        let wcs = s
            .projection(&c.sensor)
            .shifted(e.truth.jitter_mean_px[0], e.truth.jitter_mean_px[1]);
        let (wx, wy) = wcs.pixel(ra, dec).unwrap();
        assert!((wx - st.x).abs() < 1e-9 && (wy - st.y).abs() < 1e-9);
    }
}

#[test]
fn debris_drawn_per_pixel_is_distributed_as_its_photons_traced() {
    // The photon-mapping renderer draws the debris per pixel (`DebrisFlux::draw`) where no
    // sample can be merged. Against its photons traced singly (`trace`, as before), for a
    // moving jitter path: the same mean and variance in every pixel with signal (chi-square
    // over pixels, as above), the same mean total, and the expected flux holds every photon
    // (the 7-sigma support drops 1e-11 of them).
    let c = fixture(4e-4);
    let s = scene(&c, vec![], 14.5, 2.0);
    let mut settings = c.render.clone();
    settings.jitter_steps = 50;
    let jitter = Jitter::of_scene(
        &c.sensor,
        &settings,
        &s,
        &mut pixel_stream(12, 0, PixelPurpose::Photons),
    );
    assert!(
        jitter.max_excursion() > 0.5,
        "the jitter path moves the streak"
    );
    let flux = expected::debris_flux(&c.sensor, &s, &jitter);
    let lambda: f64 = s
        .object
        .trajectory
        .iter()
        .map(|p| p.expected_electrons)
        .sum();
    assert!(
        (flux.total() / lambda - 1.0).abs() < 1e-9,
        "{} of {lambda}",
        flux.total()
    );
    let psf = s.psf(&c.sensor);
    let runs = 300;
    let (mut traced, mut drawn) = (Vec::new(), Vec::new());
    for i in 0..runs {
        let rng = &mut pixel_stream(13, i, PixelPurpose::Photons);
        let mut tally = Tally::new(128, 128);
        for_each_source(&c.sensor, &s, &jitter, |source| {
            let count = poisson(rng, source.expected);
            let singles = (u64::MAX, 1);
            trace(
                &mut tally,
                rng,
                count,
                singles,
                u64::MAX,
                &jitter,
                &psf,
                source,
            );
        });
        traced.push(tally.canvas());
        let mut tally = Tally::new(128, 128);
        tally.draw_debris(&flux, rng);
        drawn.push(tally.canvas());
    }
    let total = |v: &[Canvas]| v.iter().map(|c| c.debris_total as f64).sum::<f64>() / runs as f64;
    let se = (lambda / runs as f64).sqrt();
    for t in [total(&traced), total(&drawn)] {
        assert!((t - lambda).abs() < 4.0 * se, "mean total {t} vs {lambda}");
    }
    let a = pixel_stats(&traced.into_iter().map(|c| c.debris).collect::<Vec<_>>());
    let b = pixel_stats(&drawn.into_iter().map(|c| c.debris).collect::<Vec<_>>());
    let on: Vec<usize> = (0..a.mean.len()).filter(|&k| b.mean[k] >= 5.0).collect();
    assert!(on.len() > 100, "{} pixels with signal", on.len());
    assert_same_means_and_variances(&a, &b, &on);
}

/// Per-pixel sums over seeds: count, mean, second and fourth central moments.
struct PixelStats {
    n: f64,
    mean: Vec<f64>,
    var: Vec<f64>,
    /// Standard error of each sample variance (from the fourth central moment).
    var_se: Vec<f64>,
}

fn pixel_stats(images: &[Vec<u32>]) -> PixelStats {
    let n = images.len() as f64;
    let len = images[0].len();
    let mut st = PixelStats {
        n,
        mean: vec![0.0; len],
        var: vec![0.0; len],
        var_se: vec![0.0; len],
    };
    for k in 0..len {
        let m = images.iter().map(|im| im[k] as f64).sum::<f64>() / n;
        let m2 = images
            .iter()
            .map(|im| (im[k] as f64 - m).powi(2))
            .sum::<f64>()
            / n;
        let m4 = images
            .iter()
            .map(|im| (im[k] as f64 - m).powi(4))
            .sum::<f64>()
            / n;
        st.mean[k] = m;
        st.var[k] = m2 * n / (n - 1.0);
        st.var_se[k] = ((m4 - m2 * m2 * (n - 3.0) / (n - 1.0)) / n).max(0.0).sqrt();
    }
    st
}

/// Chi-square of the per-pixel differences (a - b) / se over the pixels `on`, and its
/// z-score against chi-square with as many degrees of freedom.
fn chi2_z(on: &[usize], diff_se: impl Fn(usize) -> (f64, f64)) -> (f64, f64) {
    let chi2: f64 = on
        .iter()
        .map(|&k| {
            let (d, se) = diff_se(k);
            (d / se).powi(2)
        })
        .sum();
    let dof = on.len() as f64;
    (chi2, (chi2 - dof) / (2.0 * dof).sqrt())
}

/// Two renderers' per-pixel means and variances over the pixels `on` agree within their
/// standard errors: chi-square z-scores within 4.
fn assert_same_means_and_variances(a: &PixelStats, b: &PixelStats, on: &[usize]) {
    let n = a.n;
    let (chi2, z) = chi2_z(on, |k| {
        (a.mean[k] - b.mean[k], ((a.var[k] + b.var[k]) / n).sqrt())
    });
    eprintln!("means: chi2 {chi2:.1} over {} pixels (z {z:.2})", on.len());
    assert!(
        z.abs() < 4.0,
        "means: chi2 {chi2} over {} pixels (z {z})",
        on.len()
    );
    let (chi2, z) = chi2_z(on, |k| {
        (a.var[k] - b.var[k], a.var_se[k].hypot(b.var_se[k]))
    });
    eprintln!(
        "variances: chi2 {chi2:.1} over {} pixels (z {z:.2})",
        on.len()
    );
    assert!(
        z.abs() < 4.0,
        "variances: chi2 {chi2} over {} pixels (z {z})",
        on.len()
    );
}

/// The noise-free images of `runs` seeds, for a fixed jitter path.
fn noise_free(c: &Fixture, s: &Scene, jitter: &Jitter, runs: u64) -> Vec<Vec<u32>> {
    (0..runs)
        .map(|i| {
            render_with_jitter(
                &c.sensor,
                &c.render,
                s,
                None,
                jitter,
                &mut pixel_stream(11, i, PixelPurpose::Photons),
                &mut pixel_stream(11, i, PixelPurpose::Noise),
                None,
            )
            .electrons
        })
        .collect()
}

#[test]
fn expected_and_photon_mapping_agree_in_mean_and_variance_per_pixel() {
    // A star and a debris streak, a fixed (non-trivial) jitter path, merging off: for every
    // pixel with signal, the mean and the variance over seeds of the two renderers agree
    // within their standard errors (chi-square over pixels), and merging 5 photons per
    // packet inflates the variance about 5 times (packets of F land like N / F photons of
    // weight F: variance ~ F x mean, less where one pixel holds much of a source and for the
    // remainder traced singly) as the exact formula below predicts, without biasing the mean.
    let mut exact = fixture(4e-4);
    exact.render.jitter_steps = 50;
    exact.render.merge_threshold = 1_000_000_000_000;
    let mut expected = fixture(4e-4);
    expected.render.jitter_steps = 50;
    expected.render.merge_threshold = 1_000_000_000_000;
    expected.render.method = RenderMethod::Expected;
    let mut merged = fixture(4e-4);
    merged.render.jitter_steps = 50;
    merged.render.merge_threshold = 1;
    merged.render.merge_factor = 5;
    let tan = tan_of(&exact);
    let (ra, dec) = tan.sky(80.3, 70.6);
    let star = Star {
        ra_deg: ra,
        dec_deg: dec,
        mag: 15.5,
    };
    let s = scene(&exact, vec![star], 14.5, 2.0);
    let jitter = Jitter::of_scene(
        &exact.sensor,
        &exact.render,
        &s,
        &mut pixel_stream(10, 0, PixelPurpose::Photons),
    );
    assert!(
        jitter.max_excursion() > 0.5,
        "the jitter path moves the sources"
    );
    let runs = 300;
    let a = pixel_stats(&noise_free(&exact, &s, &jitter, runs));
    let b = pixel_stats(&noise_free(&expected, &s, &jitter, runs));
    let m = pixel_stats(&noise_free(&merged, &s, &jitter, runs));
    // Pixels where the Poisson counts are near normal.
    let on: Vec<usize> = (0..a.mean.len()).filter(|&k| b.mean[k] >= 5.0).collect();
    assert!(on.len() > 100, "{} pixels with signal", on.len());
    assert_same_means_and_variances(&a, &b, &on);
    let n = a.n;
    // Both are Poisson: variance = mean, summed over the pixels.
    let ratio = |st: &PixelStats| {
        on.iter().map(|&k| st.var[k]).sum::<f64>() / on.iter().map(|&k| st.mean[k]).sum::<f64>()
    };
    for st in [&a, &b] {
        assert!(
            (ratio(st) - 1.0).abs() < 0.03,
            "variance/mean {}",
            ratio(st)
        );
    }
    // Merging: the mean is unbiased, the variance 5 times the Poisson one.
    let (chi2, z) = chi2_z(&on, |k| {
        (m.mean[k] - b.mean[k], ((m.var[k] + b.var[k]) / n).sqrt())
    });
    assert!(z.abs() < 4.0, "merged means: chi2 {chi2} (z {z})");
    // The exact merged variance of a pixel, per source with N ~ Poisson(lambda) photons in
    // P = N div F packets and S = N mod F singles, each landing in the pixel with chance p:
    // p (1 - p) (F^2 E[P] + E[S]) + p^2 lambda. Summed over the pixels with signal.
    let f = 5.0;
    let psf_px = exact.sensor.psf_sigma_px();
    let mut predicted = vec![0.0; a.mean.len()];
    for_each_source(&merged.sensor, &s, &jitter, |source| {
        let mut flux = expected::Flux::new(128, 128, psf_px);
        flux.add(source, &jitter);
        let lambda = source.expected;
        // The Poisson pmf in logs (exp(-lambda) underflows for a bright star).
        let (mut e_p, mut e_s, mut ln_pmf) = (0.0, 0.0, -lambda);
        for count in 0..(lambda + 12.0 * lambda.sqrt() + 30.0) as u64 {
            e_p += ln_pmf.exp() * (count / 5) as f64;
            e_s += ln_pmf.exp() * (count % 5) as f64;
            ln_pmf += (lambda / (count + 1) as f64).ln();
        }
        for (k, v) in predicted.iter_mut().enumerate() {
            let p = (flux.stars[k] + flux.debris[k]) / lambda;
            *v += p * (1.0 - p) * (f * f * e_p + e_s) + p * p * lambda;
        }
    });
    let predicted_ratio =
        on.iter().map(|&k| predicted[k]).sum::<f64>() / on.iter().map(|&k| b.mean[k]).sum::<f64>();
    eprintln!(
        "{} pixels, {runs} seeds: variance/mean exact {:.4}, expected {:.4}, merged {:.4} (theory {predicted_ratio:.4})",
        on.len(),
        ratio(&a),
        ratio(&b),
        ratio(&m)
    );
    assert!(
        (ratio(&m) / predicted_ratio - 1.0).abs() < 0.05 && predicted_ratio > 4.0,
        "merged variance/mean {} vs theory {predicted_ratio}",
        ratio(&m)
    );
}

/// The integrated matched-filter SNR against a dense numpy sum of the same Gaussian streaks
/// (tests/reference/matched_filter_reference.py: the PSF integrated over every pixel of the
/// image with math.erfc, no support cut). One diagonal streak leaves the image (only its
/// in-image pixels count), one short faint streak sits inside it. Tolerance 1e-5 relative:
/// soig's erfc is good to 1.2e-7 and its 7-sigma PSF support drops ~1e-11 of the flux; anything
/// else (a wrong shot-noise term, gain, PSF width or clipping) moves the SNR by percents.
#[test]
fn matched_filter_snr_matches_numpy() {
    let c = fixture(0.0);
    for (mag, from, to, t, expected) in [
        (13.0, (30.3, 40.7), (150.0, 100.2), 2.0, 63.173575463),
        (17.0, (40.0, 40.0), (43.0, 41.0), 5.0, 10.723850467),
    ] {
        let s = Scene::fixed_streak(&c.sensor, (10.0, 20.0), vec![], mag, (from, to), t);
        let jitter = Jitter::of_scene(
            &c.sensor,
            &c.render,
            &s,
            &mut pixel_stream(0, 0, PixelPurpose::Photons),
        );
        let sigma = c.sensor.background_sigma_adu(t, None);
        let snr = expected::matched_filter_snr(&c.sensor, &s, &jitter, sigma);
        assert!(
            (snr - expected).abs() < 1e-5 * expected,
            "{mag}: {snr} vs {expected}"
        );
    }
}

/// The paper's signal-to-noise gate divides by the level of the noise matrices: the mean of
/// what the detector adds to a pixel besides photo-electrons, for the uniform model and for a
/// real frame (on a 512 px image, one whole period of the 512 px frame's tiling).
#[test]
fn noise_level_is_the_mean_the_detector_adds() {
    use crate::background::{FrameChoice, RealFrame};
    let c = fixture(0.0);
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/fixtures/neossat/NEOSSAT_240__30_2020214095318.fits");
    let frame = RealFrame::load(&path).unwrap();
    let mut big = fixture(0.0);
    big.sensor.width_px = 512;
    big.sensor.height_px = 512;
    big.sensor.fov_radius_deg = 0.05;
    for (c, t, f) in [(&c, 2.0, None), (&c, 7.0, None), (&big, 3.0, Some(&frame))] {
        // Magnitude 60: 1e-15 e-/s, no debris photon.
        let mut s = scene(c, vec![], 60.0, t);
        if f.is_some() {
            s.exposure.background = Some(FrameChoice {
                frame: 0,
                offset: (100, 37),
            });
        }
        let e = render(
            &c.sensor,
            &c.render,
            &s,
            f,
            &mut pixel_stream(1, 0, PixelPurpose::Photons),
            &mut pixel_stream(1, 0, PixelPurpose::Noise),
        );
        let n = e.adu.len() as f64;
        let mean = e.adu.iter().map(|&v| v as f64).sum::<f64>() / n;
        let level = c.sensor.noise_level_adu(t, f);
        // Five standard errors of the mean of n uniform draws (background plus bias), float32
        // rounding (~1e-5 relative), and for the real (dark) frame the sampling of its
        // flattened noise matrix by the image's ~9 random 256 px blocks: their means differ
        // from the frame's by a fraction of its sigma (measured 0.08% of its level at 3 s).
        let sampling = if f.is_some() { 5e-3 * level } else { 0.0 };
        let tolerance =
            5.0 * c.sensor.background_sigma_adu(t, None) / n.sqrt() + 1e-4 * level + sampling;
        assert!(
            (mean - level).abs() < tolerance,
            "{t} s, frame {}: mean {mean} vs level {level} (tolerance {tolerance})",
            f.is_some()
        );
    }
    // The paper's 5 s level: 200 ADU of background plus 2.5 of bias.
    assert!((c.sensor.noise_level_adu(5.0, None) - 202.5).abs() < 1e-12);
}

#[test]
fn an_objects_own_box_holds_the_whole_image_draws_and_label() {
    // A placed object is drawn into its flux's own box (`DebrisFlux::draw_own_box`), not a
    // whole image: the same draws from the same stream, the same total, the same pixels once
    // put back, and the same label box to the bit as `flux_box` of the whole image's map;
    // `DebrisMap::crop` of that whole map gives the box of its lit pixels, and the same label.
    let c = fixture(2e-4);
    let s = scene(&c, vec![], 14.5, 2.0);
    let jitter = Jitter::of_scene(
        &c.sensor,
        &c.render,
        &s,
        &mut pixel_stream(5, 0, PixelPurpose::Photons),
    );
    let flux = expected::debris_flux(&c.sensor, &s, &jitter);
    let (w, h) = (c.sensor.width_px, c.sensor.height_px);
    let mut whole = vec![0u32; w * h];
    let total = flux.draw(
        &mut pixel_stream(5, 0, PixelPurpose::Photons),
        &mut whole,
        w,
    );
    let (own, own_total) = flux.draw_own_box(&mut pixel_stream(5, 0, PixelPurpose::Photons));
    assert!(total > 0);
    assert_eq!(own_total, total);
    assert!(own.width < w && own.height < h, "the box is not the image");
    let back: Vec<u32> = own.to_image(w, h).iter().map(|&v| v as u32).collect();
    assert_eq!(back, whole);
    let label = flux_box(&whole, w, h, LABEL_SHARE);
    assert!(label.is_some());
    assert_eq!(own.label_box(LABEL_SHARE), label);
    let cropped = expected::DebrisMap::crop(&whole, w);
    assert_eq!(cropped.counts.iter().map(|&v| v as u64).sum::<u64>(), total);
    assert_eq!(cropped.label_box(LABEL_SHARE), label);
    assert!(
        expected::DebrisMap::crop(&vec![0; w * h], w)
            .label_box(LABEL_SHARE)
            .is_none()
    );
}

/// Survey pointing: the stars `for_each_source` passes over before tracing them (farther from
/// the tangent point than the near rectangle's reach plus the largest turn) are exactly those
/// that no node would have put near the image. A grid of 6561 stars 0.08 deg around a 128 px
/// field that drifts 300 px, traced node by node as `Scene::pixel_at` places them.
#[test]
fn survey_stars_passed_over_are_near_at_no_node() {
    use crate::scene::{Pointing, SurveyTrack};
    use soig_sky::{radec_unit, unit};
    let c = fixture(0.0);
    let mut s = scene(&c, Vec::new(), 12.0, 1.0);
    let exposure_s = s.exposure.exposure_s;
    let rate_deg_s = 300.0 * c.sensor.pixel_scale_deg() / exposure_s;
    s.exposure.pointing = Pointing::Survey(SurveyTrack {
        mid_ra_deg: 10.0,
        mid_dec_deg: 20.0,
        // Perpendicular to the boresight, tilted so the trails run askew to the pixel axes.
        axis: unit(radec_unit(100.0, 30.0)),
        rate_deg_s,
        t_mid_s: exposure_s / 2.0,
        drift_deg: rate_deg_s * exposure_s,
        trail_angle_deg: 0.0,
    });
    let step = 0.08 / 40.0;
    s.exposure.stars = (-40..=40)
        .flat_map(|i| (-40..=40).map(move |j| (i, j)))
        .map(|(i, j)| Star {
            ra_deg: 10.0 + i as f64 * step / 20f64.to_radians().cos(),
            dec_deg: 20.0 + j as f64 * step,
            mag: 12.0,
        })
        .collect();
    let jitter = Jitter::still(exposure_s);
    let traced = for_each_source(&c.sensor, &s, &jitter, |_| {});
    // The renderer's `near`, node by node over every star (its margin: 8 core sigmas, the
    // jitter's excursion and a pixel).
    let tan = tan_of(&c);
    let margin = 8.0 * s.psf(&c.sensor).core_sigma_px() + jitter.max_excursion() + 1.0;
    let w = c.sensor.width_px as f64;
    let near = |(x, y): (f64, f64)| {
        x > -0.5 - margin && y > -0.5 - margin && x < w - 0.5 + margin && y < w - 0.5 + margin
    };
    let drift_px = rate_deg_s * exposure_s / tan.scale_deg;
    let nodes = ((drift_px / sources::SURVEY_NODE_SPACING_PX).ceil() as usize + 1).max(2);
    let dt = exposure_s / (nodes - 1) as f64;
    let expected: Vec<(u64, u64)> = s
        .exposure
        .stars
        .iter()
        .filter(|star| {
            (0..nodes).any(|k| {
                s.pixel_at(&tan, k as f64 * dt, star.ra_deg, star.dec_deg)
                    .is_some_and(near)
            })
        })
        .map(|star| (star.ra_deg.to_bits(), star.dec_deg.to_bits()))
        .collect();
    let got: Vec<(u64, u64)> = traced
        .iter()
        .map(|t| (t.ra_deg.to_bits(), t.dec_deg.to_bits()))
        .collect();
    // Some stars are near, most are not: both sides of the test are exercised.
    assert!(
        expected.len() > 200 && expected.len() < 3000,
        "{}",
        expected.len()
    );
    assert_eq!(got, expected);
}
