//! Track pointing (issue #34): the sensor follows the image's debris object, which stays a
//! point on its pixel while the stars trail against its apparent motion.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use soig::campaign::Campaign;
use soig::scene::Pointing;
use soig::sky::{angle_deg, radec_unit};

mod common;
use common::{
    CampaignToml, assert_coco_agrees_with_labels_and_truth, digest, leo_and_geo, rendered,
    run_on_one_and_two_threads_and_verify, run_quiet, tle_object,
};

/// Track images of 512 px at the paper's pixel scale (0.7"), a LEO and a GEO object;
/// `extra` adds tables.
fn track(extra: &str) -> CampaignToml {
    leo_and_geo("track", "track", extra).tables("[render]\ntrajectory_samples = 800\n")
}

fn load(extra: &str) -> Campaign {
    track(extra).load("track.toml")
}

#[test]
fn the_tracked_object_stays_on_its_pixel() {
    // Placed at the centre (within 1e-6 of the half-field: 0.0003 px), and anywhere in the
    // field (the campaign's placement).
    for (extra, centred) in [("placement_fraction = 1e-6\n", true), ("", false)] {
        let c = load(extra);
        let sensor = soig::experiment::of(&c).sensor;
        let psf = sensor.psf_sigma_px();
        for image in rendered(&c, 4) {
            let s = &image.scene;
            assert!(matches!(s.exposure.pointing, Pointing::Track(_)));
            let tan = s.projection(&sensor);
            let mid = s.object.trajectory[s.object.trajectory.len() / 2];
            let home = if centred {
                (tan.cx, tan.cy)
            } else {
                (mid.x_px, mid.y_px)
            };
            // The debris directions between the track's nodes (half a pixel apart) are
            // interpolated: the model errs by micro-pixels; 0.01 px still catches a camera
            // that lags the object by a millisecond of a LEO pass (~0.1 px).
            let off = s
                .object
                .trajectory
                .iter()
                .map(|p| (p.x_px - home.0).hypot(p.y_px - home.1))
                .fold(0.0, f64::max);
            assert!(
                off < 0.01,
                "image {}: {off} px from home",
                s.exposure.image_index
            );
            // The label box (99% of the rendered flux) is a point's: 2 x 2.81 PSF sigmas plus
            // the jitter's wander about its mean (the paper's 0.0002 deg/sqrt(s): ~1 px per
            // sqrt(s), a few px in these 1-10 s exposures), far from the 100+ px streaks.
            let b = image.exposure.truth.label_box_px.expect("a label box");
            let (w, h) = (b.x_max - b.x_min, b.y_max - b.y_min);
            assert!(
                w < 2.0 * 2.81 * psf + 12.0 && h < 2.0 * 2.81 * psf + 12.0,
                "image {}: box {w} x {h} px",
                s.exposure.image_index
            );
            let j = image.exposure.truth.jitter_mean_px;
            assert!(
                b.x_min <= home.0 + j[0] + 0.5 && home.0 + j[0] - 0.5 <= b.x_max,
                "image {}: box {b:?} misses x {}",
                s.exposure.image_index,
                home.0
            );
            assert!(b.y_min <= home.1 + j[1] + 0.5 && home.1 + j[1] - 0.5 <= b.y_max);
        }
    }
}

/// A star's trail is the debris' apparent motion reversed. The expectation is built from the
/// truth's ephemeris (SGP4 at the exposure's start and end, not the track's interpolated
/// nodes) through the mid-exposure projection, without the tracking rotation: to first order
/// the star at the boresight moves by minus the debris' displacement; the rest is second
/// order in the drift (up to 1 deg here), well within 0.1% in length and 0.05 deg.
#[test]
fn star_trails_match_the_tracking_rate() {
    let c = load("placement_fraction = 1e-6\n");
    let sensor = soig::experiment::of(&c).sensor;
    let mut pinned = Vec::new();
    for image in rendered(&c, 4) {
        let s = &image.scene;
        let Pointing::Track(t) = &s.exposure.pointing else {
            panic!("track pointing expected")
        };
        let tan = s.projection(&sensor);
        let e = s.object.ephemeris.expect("an ephemeris");
        let [ra0, dec0] = e.debris_radec_start_deg;
        let [ra1, dec1] = e.debris_radec_end_deg;
        let (a, b) = (tan.pixel(ra0, dec0).unwrap(), tan.pixel(ra1, dec1).unwrap());
        let expected = (a.0 - b.0, a.1 - b.1);
        // The star at the mid-exposure boresight, as the renderer places it.
        let (p, q) = (
            s.pixel_at(&tan, 0.0, t.mid_ra_deg, t.mid_dec_deg).unwrap(),
            s.pixel_at(&tan, s.exposure.exposure_s, t.mid_ra_deg, t.mid_dec_deg)
                .unwrap(),
        );
        let got = (q.0 - p.0, q.1 - p.1);
        let len = |v: (f64, f64)| v.0.hypot(v.1);
        let ang = |v: (f64, f64)| v.1.atan2(v.0).to_degrees();
        let d_ang = (ang(got) - ang(expected) + 540.0).rem_euclid(360.0) - 180.0;
        assert!(len(expected) > 50.0, "{expected:?}");
        assert!(
            (len(got) / len(expected) - 1.0).abs() < 1e-3 && d_ang.abs() < 0.05,
            "image {}: trail {got:?} vs {expected:?}",
            s.exposure.image_index
        );
        // The recorded direction and drift say the same.
        let d_rec = (t.trail_angle_deg - ang(expected) + 540.0).rem_euclid(360.0) - 180.0;
        assert!(
            d_rec.abs() < 0.05,
            "{} vs {}",
            t.trail_angle_deg,
            ang(expected)
        );
        let chord = angle_deg(radec_unit(ra0, dec0), radec_unit(ra1, dec1));
        // The path is the chord and its curvature's second-order excess.
        assert!(
            t.drift_deg >= chord * (1.0 - 1e-9) && t.drift_deg < chord * 1.001,
            "{} vs {chord}",
            t.drift_deg
        );
        pinned.push((len(expected), ang(expected)));
    }
    // The independent expectation itself, pinned (SGP4 and the projection of this campaign's
    // four images, LEO and GEO objects tracked from SENTINEL-3A; 1e-6 px and deg
    // leave room for the last bits of libm on another x86-64 and nothing else).
    let want = [
        (1530.1663819148375, -4.079085478357949),
        (5041.246639433688, -28.231185985070884),
        (1857.1590982660782, -132.75679881404926),
        (515.5368647816324, 119.18048905286341),
    ];
    for (k, ((l, a), (wl, wa))) in pinned.iter().zip(want).enumerate() {
        assert!(
            (l - wl).abs() < 1e-6 && (a - wa).abs() < 1e-6,
            "image {k}: trail {l} px at {a} deg, pinned {wl} px at {wa} deg"
        );
    }
}

/// The campaign runs, verifies, and gives the same bytes on 1 and 2 threads.
#[test]
fn track_campaign_runs_verifies_and_is_thread_independent() {
    let tmp = tempfile::tempdir().unwrap();
    let file = track("")
        .tables("[artifacts]\nnoise_free_fits = true\ncoco = true\n")
        .write(&tmp.path().join("track.toml"));
    let one = run_on_one_and_two_threads_and_verify(&file, tmp.path());
    let fits = std::fs::read(one.join("fits").join("img_000000.fits")).unwrap();
    let header = String::from_utf8_lossy(&fits[..2880 * 4]);
    assert!(header.contains("POINTING= 'track"), "no POINTING card");
    assert!(header.contains("DRIFTANG="));
    let truth: serde_json::Value =
        serde_json::from_slice(&std::fs::read(one.join("truth").join("img_000000.json")).unwrap())
            .unwrap();
    assert_eq!(truth["pointing"]["mode"], "track");
    assert!(truth["pointing"]["boresight_radec_start_deg"][1].is_number());
    // Labels, truths and COCO agree: every tracked object is in its field.
    assert!(assert_coco_agrees_with_labels_and_truth(&one) > 0);
}

/// The classical detector on track images: the star trails are not debris. It gets their
/// direction (a tracked object does not move, so nothing along the trails is debris), and the
/// point-like object is out of its scope (no streak): no detection at the campaign's
/// confidence in the test split.
#[test]
fn the_streak_detector_reports_no_star_trail_in_track_images() {
    let tmp = tempfile::tempdir().unwrap();
    let file = CampaignToml::leo("track-detect", 20220101, 12)
        .stages(&["render", "enhance", "dataset", "detect"])
        .debris(&tle_object(40386))
        .debris(&tle_object(40989))
        .tables("[pointing]\nmode = \"track\"\n[split]\ntrain = 0.5\nval = 0.0\ntest = 0.5\n[detect]\nclassical = true\n")
        .write(&tmp.path().join("t.toml"));
    let out = tmp.path().join("out");
    let o = run_quiet(&file, &out);
    digest(&o);
    let csv = std::fs::read_to_string(out.join("report").join("detections.csv")).unwrap();
    let confident: Vec<&str> = csv
        .lines()
        .skip(1)
        .filter(|l| l.split(',').nth(6).unwrap().parse::<f64>().unwrap() >= 0.5)
        .collect();
    assert!(confident.is_empty(), "{confident:?}");
    let test_images = std::fs::read_dir(out.join("images").join("test"))
        .unwrap()
        .count();
    assert!(test_images >= 4, "{test_images} test images");
}
