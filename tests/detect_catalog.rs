//! `soig detect --catalog` (issue #30): a soig survey FITS and a catalogue CSV written from its
//! campaign's own stars give the star trails `soig run` predicts, from the FITS header alone
//! (WCS at mid-exposure, start and end; DATE-OBS, EXPTIME), and the star-aware detector keeps
//! the debris and drops the trails. Bad inputs fail naming the file and what is missing.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use std::path::{Path, PathBuf};

use soig::campaign::Campaign;
use soig::detect_frames::catalog::FrameSky;
use soig::experiment;
use soig::frames::Frame;
use soig::imaging::point_segment_distance;

mod common;
use common::{CampaignToml, arg, leo_and_geo, ok, python_with_astropy, run_quiet, soig};

/// Images of 512 px (0.7 arcsec/px) in pointing `mode`, rendered only (FITS and truth).
fn campaign(mode: &str) -> CampaignToml {
    leo_and_geo("catalog", mode, "").stages(&["render"])
}

/// The truth of image `index` of the run in `dir/run`.
fn truth_of(dir: &Path, index: u64) -> serde_json::Value {
    serde_json::from_str(
        &std::fs::read_to_string(dir.join(format!("run/truth/img_{index:06}.json"))).unwrap(),
    )
    .unwrap()
}

/// The streak's two ends in a truth, as pixel edges: truth ends are pixel centres at
/// integers; soig detect reports pixel edges.
fn streak_ends(truth: &serde_json::Value) -> ([f64; 2], [f64; 2]) {
    let p = |k: &str| [0, 1].map(|i| truth[k][i].as_f64().unwrap() + 0.5);
    (p("streak_start_px"), p("streak_end_px"))
}

/// Render the campaign into `dir`/run; returns the campaign file and the loaded campaign.
fn render(dir: &Path, mode: &str) -> (PathBuf, Campaign) {
    let toml = campaign(mode).write(&dir.join("catalog.toml"));
    ok(run_quiet(&toml, &dir.join("run")));
    let c = Campaign::load(&toml).unwrap();
    (toml, c)
}

/// The stars of image `index`'s scene as a plain catalogue CSV (ra, dec, mag; no proper
/// motion), 10 decimals (4e-7 arcsec; 1e-10 mag).
fn write_catalog(c: &Campaign, index: u64, path: &Path) {
    write_catalog_as(c, index, path, |_, ra, dec| Some((ra, dec)));
}

/// `write_catalog`, each star `k` at (ra, dec) listed where `listed` puts it, or left out.
fn write_catalog_as(
    c: &Campaign,
    index: u64,
    path: &Path,
    listed: impl Fn(usize, f64, f64) -> Option<(f64, f64)>,
) {
    let x = experiment::of(c);
    let inputs = experiment::inputs(c).unwrap();
    let scene = soig::scene::draw(&x.scene, &x.sensor, &inputs, x.seed, index).unwrap();
    let mut csv = String::from("ra,dec,mag\n");
    for (k, s) in scene.exposure.stars.iter().enumerate() {
        let Some((ra, dec)) = listed(k, s.ra_deg, s.dec_deg) else {
            continue;
        };
        csv.push_str(&format!("{ra:.10},{dec:.10},{:.10}\n", s.mag));
    }
    std::fs::write(path, csv).unwrap();
}

/// The largest distance, in pixels, between the on-frame trail nodes predicted from the FITS
/// header and a catalogue of the campaign's stars, and those `soig run` predicts from the
/// campaign (`render::trails`), over the four images of pointing `mode` (track: each node's
/// distance from the other's path, as their time grids differ). Checks on the way that both
/// have the same stars on the frame with the same number of nodes there (but track), the same
/// expected electrons to 1e-9 where both expose a star alike (MAGZERO and the same exposure
/// share; the CSV's 10 decimals of a magnitude leave 1e-10), and whether the header says the
/// camera moved.
fn prediction_gap_px(mode: &str) -> f64 {
    let tmp = tempfile::tempdir().unwrap();
    let (_, c) = render(tmp.path(), mode);
    let x = experiment::of(&c);
    let inputs = experiment::inputs(&c).unwrap();
    let psf = x.sensor.psf_sigma_px();
    let (mut compared, mut gap) = (0, 0.0f64);
    for index in 0..4u64 {
        let cat = tmp.path().join(format!("stars{index}.csv"));
        write_catalog(&c, index, &cat);
        let fits = tmp.path().join(format!("run/fits/img_{index:06}.fits"));
        let frame = Frame::read(&fits).unwrap();
        let sky = FrameSky::of(&frame).unwrap();
        assert_eq!(
            sky.motion.is_some(),
            mode != "fixed",
            "{mode}: the camera's motion"
        );
        let catalog = soig::sky::stars::StarCatalog::from_csv_path(&cat, 2016.0).unwrap();
        let mine = sky.predict(&catalog, frame.region, psf);
        // soig run's prediction: the scene drawn again, with the image's mean jitter shift.
        let truth: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(tmp.path().join(format!("run/truth/img_{index:06}.json")))
                .unwrap(),
        )
        .unwrap();
        let jm = [0, 1].map(|k| truth["jitter_mean_px"][k].as_f64().unwrap());
        let scene = soig::scene::draw(&x.scene, &x.sensor, &inputs, x.seed, index).unwrap();
        let theirs = soig::render::trails::star_trails(&x.sensor, &scene, jm);
        // Where a trail enters or leaves, the renderer decides which nodes are near the frame
        // before the mean jitter shift and the header after it: they may differ there, off
        // the frame. On the frame, every node must agree.
        let on = |n: &&[f64; 2]| n[0] >= 0.0 && n[1] >= 0.0 && n[0] <= 511.0 && n[1] <= 511.0;
        let on_frame = |nodes: &[[f64; 2]]| nodes.iter().filter(on).copied().collect::<Vec<_>>();
        let same_star =
            |a: (f64, f64), b: (f64, f64)| (a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9;
        let visible = |nodes: &[[f64; 2]]| !on_frame(nodes).is_empty();
        let (ours, run) = (
            mine.iter().filter(|m| visible(&m.nodes)).count(),
            theirs.iter().filter(|t| visible(&t.nodes)).count(),
        );
        if mode == "track" {
            // A star passing just outside the margin may be traced by one and not the other.
            assert!(
                ours.abs_diff(run) <= 2,
                "image {index}: stars {ours} against {run}"
            );
        } else {
            assert_eq!(ours, run, "image {index}: stars on the frame");
        }
        assert!(theirs.len() >= 3, "image {index}: {} stars", theirs.len());
        for t in theirs.iter().filter(|t| visible(&t.nodes)) {
            let Some(m) = mine
                .iter()
                .find(|m| same_star((m.ra_deg, m.dec_deg), (t.ra_deg, t.dec_deg)))
            else {
                assert_eq!(mode, "track", "image {index}: no prediction for {t:?}");
                continue;
            };
            let (a, b) = (on_frame(&m.nodes), on_frame(&t.nodes));
            if mode == "track" {
                // Its time grid follows the debris' path, the header's the boresight's: the
                // nodes differ, the paths must not. Each node's distance from the other path.
                let to_path = |q: [f64; 2], path: &[[f64; 2]]| {
                    path.windows(2)
                        .map(|w| to_segment(q, w[0], w[1]))
                        .fold(f64::INFINITY, f64::min)
                };
                for q in &a {
                    gap = gap.max(to_path(*q, &t.nodes));
                }
                for q in &b {
                    gap = gap.max(to_path(*q, &m.nodes));
                }
                continue;
            }
            assert_eq!(a.len(), b.len(), "image {index}: nodes of {m:?}");
            // The on-frame nodes' times, from the start and end WCS, are the renderer's
            // (issue #44): 1e-9 s, float rounding of the same grid.
            assert_eq!(m.times_s.len(), m.nodes.len());
            let timed = |nodes: &[[f64; 2]], times: &[f64]| {
                let on_times = nodes.iter().zip(times).filter(|(n, _)| on(n));
                on_times.map(|(_, &t)| t).collect::<Vec<_>>()
            };
            let (tm, tt) = (timed(&m.nodes, &m.times_s), timed(&t.nodes, &t.times_s));
            assert_eq!(tm.len(), tt.len(), "image {index}: timed nodes of {m:?}");
            for (a, b) in tm.iter().zip(&tt) {
                assert!(
                    (a - b).abs() < 1e-9,
                    "image {index}: node time {a} against {b}"
                );
            }
            for (a, b) in a.iter().zip(&b) {
                gap = gap.max((a[0] - b[0]).hypot(a[1] - b[1]));
            }
            if m.nodes.len() == t.nodes.len() {
                let e = m.electrons.expect("soig's FITS has MAGZERO");
                assert!(
                    (e / t.electrons.unwrap() - 1.0).abs() < 1e-9,
                    "image {index}: {e} electrons against {:?}",
                    t.electrons
                );
                compared += 1;
            }
        }
    }
    assert!(
        mode == "track" || compared > 20,
        "{mode}: {compared} trails compared"
    );
    gap
}

/// Survey and fixed pointing: the header gives `soig run`'s prediction node for node, to
/// 1e-3 px (the header's 15 significant digits and the CSV's 10 decimals of a degree leave
/// under 1e-5 px; a wrong turn direction or time moves a trail's ends by tens of pixels).
#[test]
fn predicts_the_trails_soig_run_predicts_from_the_header_alone() {
    for mode in ["survey", "fixed"] {
        let gap = prediction_gap_px(mode);
        assert!(gap < 1e-3, "{mode}: nodes {gap} px apart");
    }
}

/// Track pointing: between the start, mid-exposure and end WCS the header's constant-rate turn
/// only approximates the camera following the debris; measured: 0.28 px at most from the
/// renderer's paths (and one star of 449 at an image's edge that only the run predicts). 0.5 px
/// bounds it, a third of a PSF sigma (1.4 px here), well inside the reach within which the
/// star-aware pass takes a line for a star's.
#[test]
fn track_pointing_is_approximated_between_its_three_wcs() {
    let gap = prediction_gap_px("track");
    assert!(gap < 0.5, "track: paths {gap} px apart");
}

/// Errors: a PNG, a FITS without a WCS, a catalogue with a bad value; each names the file
/// (and the catalogue's line and column) and leaves no output. `--catalog` with YOLO alone is
/// refused too.
#[test]
fn bad_catalogue_inputs_fail_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let (_, c) = render(tmp.path(), "survey");
    let cat = tmp.path().join("stars.csv");
    write_catalog(&c, 0, &cat);
    let fits = tmp.path().join("run/fits/img_000000.fits");
    let out = tmp.path().join("det");
    // `soig detect [extra] --catalog CATALOG --out OUT FRAME` must fail, naming `expect`.
    let fails = |extra: &[&str], catalog: &Path, frame: &Path, expect: &[&str]| {
        let mut args = vec!["detect"];
        args.extend(extra);
        args.extend(["--catalog", arg(catalog), "--out", arg(&out), arg(frame)]);
        let o = soig(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} succeeded");
        for e in expect {
            assert!(err.contains(e), "{e:?} not in {err}");
        }
        assert!(!out.exists(), "{args:?} left an output");
    };
    // A catalogue whose third line has no number for the declination.
    let bad = tmp.path().join("bad.csv");
    std::fs::write(&bad, "ra,dec,mag\n10.0,20.0,12.0\n10.1,north,13.0\n").unwrap();
    fails(&[], &bad, &fits, &["bad.csv:3", "dec"]);
    // A PNG: no WCS, no timing.
    let png = tmp.path().join("frame.png");
    image::GrayImage::from_pixel(64, 48, image::Luma([20u8]))
        .save(&png)
        .unwrap();
    fails(&[], &cat, &png, &["frame.png", "PNG", "FITS"]);
    // A FITS without a WCS.
    let bare = tmp.path().join("bare.fits");
    let pixels = vec![100.0f32; 64 * 48];
    soig::fits::write_image(&bare, 64, 48, soig::fits::Pixels::F32(&pixels), &Vec::new()).unwrap();
    fails(&[], &cat, &bare, &["bare.fits", "WCS"]);
    // YOLO alone: the catalogue would inform no detector.
    fails(
        &["--detector", "yolo"],
        &cat,
        &fits,
        &["--catalog", "--detector yolo"],
    );
}

/// A frame's boxes at confidence 0.5 or more: those on the debris streak `t0`-`t1` (both ends
/// within 5 px of it) and the others.
fn debris_and_other(frame: &serde_json::Value, t0: [f64; 2], t1: [f64; 2]) -> (usize, usize) {
    let (mut debris, mut other) = (0, 0);
    for d in frame["detections"].as_array().unwrap() {
        if d["confidence"].as_f64().unwrap() < 0.5 {
            continue;
        }
        let e = [0, 1].map(|k| [0, 1].map(|i| d["ends"][k][i].as_f64().unwrap()));
        if to_segment(e[0], t0, t1) < 5.0 && to_segment(e[1], t0, t1) < 5.0 {
            debris += 1;
        } else {
            other += 1;
        }
    }
    (debris, other)
}

/// Distance from `q` to the segment `a`-`b`.
fn to_segment(q: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    point_segment_distance((q[0], q[1]), (a[0], a[1]), (b[0], b[1]))
}

/// The star-aware pass on soig's survey FITS, told only the catalogue: in each of the four
/// images every box at confidence 0.5 or more is the debris streak (both ends within 5 px of
/// the truth segment), and the streak is found. Without the catalogue (and so without the
/// trails' direction) the detector once marked star trails as debris (17 boxes in these
/// images); it now measures the trails' direction on the frame itself (issue #44) and marks at
/// most one. The trail direction it derives from the
/// predicted trails is the header's (Eq. 13) to 0.01 degrees (measured: 0.003 at most; the
/// trails' chords average over the field, Eq. 13 holds at its centre).
#[test]
fn star_aware_detection_on_soig_fits_keeps_the_debris_and_drops_the_trails() {
    let tmp = tempfile::tempdir().unwrap();
    let (toml, c) = render(tmp.path(), "survey");
    let mut trails_without = 0;
    for index in 0..4u64 {
        let cat = tmp.path().join(format!("stars{index}.csv"));
        write_catalog(&c, index, &cat);
        let fits = tmp.path().join(format!("run/fits/img_{index:06}.fits"));
        let truth = truth_of(tmp.path(), index);
        let (t0, t1) = streak_ends(&truth);
        for with in [false, true] {
            let out = tmp.path().join(format!("det{index}{with}"));
            let mut args = vec![
                "detect",
                "--campaign",
                arg(&toml),
                "--out",
                arg(&out),
                arg(&fits),
            ];
            if with {
                args.extend(["--catalog", arg(&cat)]);
            }
            ok(soig(&args));
            let found: serde_json::Value = serde_json::from_str(
                &std::fs::read_to_string(out.join("detections.json")).unwrap(),
            )
            .unwrap();
            let frame = &found["frames"][0];
            let (debris, other) = debris_and_other(frame, t0, t1);
            if !with {
                // Told nothing of the stars, the detector measures their trails on the frame
                // (issue #44) instead of boxing them: their direction to half a degree (the
                // settled direction of the lines along them; measured: within 0.2).
                trails_without += other;
                let own = &frame["own_trails"];
                assert_eq!(own["verdict"], "common", "image {index}: {own}");
                let want = truth["pointing"]["trail_angle_deg"].as_f64().unwrap();
                let diff = (own["angle_deg"].as_f64().unwrap() - want).rem_euclid(180.0);
                assert!(
                    diff.min(180.0 - diff) < 0.5,
                    "image {index}: {own} against {want}"
                );
                continue;
            }
            assert_eq!((debris, other), (1, 0), "image {index}: {frame}");
            let recorded = &found["settings"]["catalog"];
            assert_eq!(recorded["file"], cat.display().to_string());
            assert_eq!(recorded["sha256"].as_str().unwrap().len(), 64);
            let used = &frame["catalog"];
            assert!(used["trails_on_frame"].as_u64().unwrap() > 10, "{used}");
            let want = truth["pointing"]["trail_angle_deg"].as_f64().unwrap();
            let got = used["trail_angle_deg"].as_f64().unwrap();
            let diff = (got - want).rem_euclid(180.0);
            assert!(
                diff.min(180.0 - diff) < 0.01,
                "image {index}: {got} against {want}"
            );
        }
    }
    // Before the frame's own trails were measured, every trail was boxed (10 or more here).
    assert!(
        trails_without <= 1,
        "{trails_without} trails marked without the catalogue"
    );
}

/// The WCS at the exposure's start and end are standard alternate WCS: astropy
/// (`WCS(header, key="S")`, the project's .venv) reads them as soig does, to 1e-9 degrees
/// (0.005 milli-pixel here; the cards hold 15 significant digits). Without astropy the test
/// says so and passes, unless SOIG_REQUIRE_ONNXRUNTIME is set (scripts/test.sh), when it fails.
#[test]
fn astropy_reads_the_start_and_end_wcs_as_soig_does() {
    let Some(python) = python_with_astropy() else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    render(tmp.path(), "survey");
    let fits = tmp.path().join("run/fits/img_000000.fits");
    let pixels = [[0.0, 0.0], [511.0, 0.0], [0.0, 511.0], [255.5, 300.25]];
    let script = r#"
import json, sys
from astropy.io import fits
from astropy.wcs import WCS
h = fits.getheader(sys.argv[1])
pixels = json.loads(sys.argv[2])
print(json.dumps({k: WCS(h, key=k).all_pix2world(pixels, 0).tolist() for k in "SE"}))
"#;
    let o = std::process::Command::new(&python)
        .args(["-c", script])
        .arg(&fits)
        .arg(serde_json::to_string(&pixels).unwrap())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let theirs: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let frame = Frame::read(&fits).unwrap();
    for key in ["S", "E"] {
        let wcs = soig::sky::wcs::TanWcs::from_header(|k| {
            frame.header.get(&format!("{k}{key}")).cloned()
        })
        .unwrap()
        .expect("a survey FITS has the alternate WCS");
        for (p, t) in pixels.iter().zip(theirs[key].as_array().unwrap()) {
            let (ra, dec) = wcs.sky(p[0], p[1]);
            let (tra, tdec) = (t[0].as_f64().unwrap(), t[1].as_f64().unwrap());
            let dra = ((ra - tra + 180.0).rem_euclid(360.0) - 180.0) * dec.to_radians().cos();
            assert!(
                dra.abs() < 1e-9 && (dec - tdec).abs() < 1e-9,
                "WCS {key} at {p:?}: soig ({ra}, {dec}), astropy ({tra}, {tdec})"
            );
        }
    }
}

/// A catalogue that misses every tenth star, or places every star 1" off at random, adds no
/// false box (issue #44): the lines it leaves unexplained have a star trail's shape (along the
/// trails near them, a trail's length or cut by the frame's edge) and are dropped, and the
/// debris streak of each of the four images is still the one box. Before, the pass reported
/// every trail a catalogue missed (`scripts/catalog-robustness.py`: P 0.53 with 10% missing,
/// 0.78 with 1" errors, on 40 survey images of seed 7001; 1.000 and 1.000 since the trails'
/// true ends are told, `unlisted.rs`). The bounds are exact: one box, no other.
#[test]
fn an_incomplete_or_misplaced_catalogue_adds_no_false_box() {
    let tmp = tempfile::tempdir().unwrap();
    let (toml, c) = render(tmp.path(), "survey");
    // A fixed pseudo-random sequence (the test must not depend on a generator's version):
    // splitmix64 of the star's index, as a uniform in [0, 1).
    let uniform = |k: u64| {
        let mut z = k.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    for index in 0..4u64 {
        let truth = truth_of(tmp.path(), index);
        let (t0, t1) = streak_ends(&truth);
        let missing = tmp.path().join(format!("missing{index}.csv"));
        write_catalog_as(&c, index, &missing, |k, ra, dec| {
            (k % 10 != 3).then_some((ra, dec))
        });
        let moved = tmp.path().join(format!("moved{index}.csv"));
        write_catalog_as(&c, index, &moved, |k, ra, dec| {
            // 1" in a uniform direction (Box-Muller would give a Gaussian; a fixed size is the
            // harder case at the same rms).
            let a = std::f64::consts::TAU * uniform(k as u64 + 1000 * index);
            let r = 1.0 / 3600.0;
            Some((ra + r * a.cos() / dec.to_radians().cos(), dec + r * a.sin()))
        });
        let fits = tmp.path().join(format!("run/fits/img_{index:06}.fits"));
        for (name, cat) in [("missing", &missing), ("moved", &moved)] {
            let out = tmp.path().join(format!("det-{name}{index}"));
            ok(soig(&[
                "detect",
                "--campaign",
                arg(&toml),
                "--out",
                arg(&out),
                "--catalog",
                arg(cat),
                arg(&fits),
            ]));
            let found: serde_json::Value = serde_json::from_str(
                &std::fs::read_to_string(out.join("detections.json")).unwrap(),
            )
            .unwrap();
            let (debris, other) = debris_and_other(&found["frames"][0], t0, t1);
            assert_eq!((debris, other), (1, 0), "{name} image {index}: {found}");
        }
    }
}
