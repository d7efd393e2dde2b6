//! The detections' astrometry (`artifacts.astrometry`, issue #45 item 2): the PNG pixel ->
//! (RA, Dec) chain against astropy on soig's own FITS (tests/reference/astrometry_reference.py,
//! run here), including a rotated survey frame with its start and end WCS; a detection put
//! exactly on the truth's ends gives ~0" whichever order its ends come in, and one moved by a
//! known shift gives that shift; the campaign field refused without the detect stage.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

mod common;

use std::io::Write as _;
use std::path::Path;

use common::{
    arg, assert_refused, json, ok, python_with_astropy, quickstart_with, repo, scratch, soig,
};
use soig::detect::Detection;
use soig::observations::{FrameSky, Line, observe};
use soig::report::astrometry::{TruthObject, offset_arcsec, residual};

/// Render `campaign` with `sets` (no detect stage) into `out`.
fn render(campaign: &str, sets: &[&str], out: &Path) {
    let campaign = repo(campaign);
    let mut args = vec!["run", arg(&campaign), "--quiet"];
    for s in sets {
        args.extend(["--set", s]);
    }
    args.extend(["--out", arg(out)]);
    ok(soig(&args));
}

/// soig's (RA, Dec) of PNG pixel-edge points against astropy's on the same FITS, at the
/// exposure's start and end: a rotated survey frame (GEOA a rotation and shift; alternate WCS S
/// and E) and the quickstart's original fixed frame. The tolerance, 1 mas, is far above two
/// double-precision TAN deprojections' disagreement (micro-arcseconds) and far below any
/// convention slip (half a pixel, 0.35" at the quickstart's scale, 7" in the survey's).
#[test]
fn pixel_to_sky_agrees_with_astropy() {
    let Some(python) = python_with_astropy() else {
        return;
    };
    let (tmp, survey) = scratch("survey");
    render(
        "campaigns/survey-quickstart.toml",
        &["images=2", "stages=[\"render\", \"enhance\"]"],
        &survey,
    );
    let fixed = tmp.path().join("fixed");
    ok(quickstart_with(
        &["images=2", "stages=[\"render\", \"enhance\"]"],
        &fixed,
    ));
    let mut checked = 0;
    for (out, moving) in [(&survey, true), (&fixed, false)] {
        let fits = out.join("fits/img_000000.fits");
        let sky = FrameSky::read(&fits).unwrap();
        assert_eq!(sky.start_end.is_some(), moving, "{}", fits.display());
        let points: Vec<([f64; 2], bool)> =
            [[0.0, 0.0], [100.25, 900.5], [512.0, 512.0], [1000.75, 30.0]]
                .into_iter()
                .flat_map(|p| [(p, false), (p, true)])
                .collect();
        let input: String = points
            .iter()
            .map(|(p, e)| format!("{} {} {}\n", p[0], p[1], u8::from(*e)))
            .collect();
        let mut child = std::process::Command::new(&python)
            .arg(repo("tests/reference/astrometry_reference.py"))
            .arg(&fits)
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        child
            .stdin
            .take()
            .unwrap()
            .write_all(input.as_bytes())
            .unwrap();
        let o = child.wait_with_output().unwrap();
        assert!(o.status.success());
        let text = String::from_utf8(o.stdout).unwrap();
        for ((p, at_end), line) in points.iter().zip(text.lines()) {
            let v: Vec<f64> = line.split(' ').map(|x| x.parse().unwrap()).collect();
            let got = sky.radec(*p, *at_end);
            let sep = offset_arcsec([v[0], v[1]], got).0;
            assert!(
                sep < 1e-3,
                "{p:?} at_end {at_end}: soig {got:?}, astropy {v:?}: {sep}\""
            );
            checked += 1;
        }
        if moving {
            // The start and end WCS differ: the same pixel is elsewhere on the sky then.
            let (a, b) = (
                sky.radec([512.0, 512.0], false),
                sky.radec([512.0, 512.0], true),
            );
            assert!(offset_arcsec(a, b).0 > 60.0);
        }
    }
    assert_eq!(checked, 16);
}

/// The PNG pixel-edge point of original-image pixel `p` (centres at integers), by the truth's
/// frame matrix.
fn png_edge(matrix: &serde_json::Value, p: &serde_json::Value) -> [f64; 2] {
    let m = |i: usize, j: usize| matrix[i][j].as_f64().unwrap();
    let (x, y) = (p[0].as_f64().unwrap(), p[1].as_f64().unwrap());
    [
        m(0, 0) * x + m(0, 1) * y + m(0, 2) + 0.5,
        m(1, 0) * x + m(1, 1) * y + m(1, 2) + 0.5,
    ]
}

/// A detection whose ends are exactly the truth's streak ends gives ~0" against the places the
/// truth says its FITS WCS gives there (`streak_*_wcs_radec_deg`), with either end first (the
/// pairing swaps when the rule's order is not the truth's), and one moved 4 px along x gives
/// 4 px of the WCS's scale at each end. Quickstart images: fixed pointing, one WCS.
#[test]
fn residuals_of_known_detections() {
    let (_tmp, out) = scratch("run");
    ok(quickstart_with(
        &["images=4", "stages=[\"render\", \"enhance\"]"],
        &out,
    ));
    let mut swapped = 0;
    for i in 0..4 {
        let stem = format!("img_{i:06}");
        let t = json(&out.join(format!("truth/{stem}.json")));
        let sky = FrameSky::read(&out.join(format!("fits/{stem}.fits"))).unwrap();
        let matrix = &t["frame"]["matrix"];
        let start = png_edge(matrix, &t["streak_start_px"]);
        let end = png_edge(matrix, &t["streak_end_px"]);
        let place = |k: &str| [t[k][0].as_f64().unwrap(), t[k][1].as_f64().unwrap()];
        let object = TruthObject {
            name: "debris".into(),
            norad: t["norad"].as_u64().unwrap(),
            label: Some(0),
            // The mid-exposure place is not read for a detection (its ends are at the start
            // and end).
            ephemeris: Some([
                place("streak_start_wcs_radec_deg"),
                [f64::NAN; 2],
                place("streak_end_wcs_radec_deg"),
            ]),
            snr: 50.0,
            magnitude: 12.0,
            ends_px: [[0.0; 2]; 2],
            exposure_s: t["exposure_s"].as_f64().unwrap(),
            seeing: None,
        };
        let scale = sky.png_scale_arcsec();
        for (shift, ends) in [
            (0.0, [start, end]),
            (0.0, [end, start]),
            (4.0, [start, end]),
        ] {
            let moved = ends.map(|[x, y]| [x + shift, y]);
            let d = Detection {
                x1: moved[0][0].min(moved[1][0]) - 2.0,
                y1: moved[0][1].min(moved[1][1]) - 2.0,
                x2: moved[0][0].max(moved[1][0]) + 2.0,
                y2: moved[0][1].max(moved[1][1]) + 2.0,
                score: 1.0,
                class: 0,
            };
            let line = Line {
                ends: moved,
                snr: Some(30.0),
            };
            let o = observe(&stem, "test", 0, &d, Some(line), &[], (0, 0), &sky, 1.5);
            let truth_box = [[d.x1, d.y1, d.x2, d.y2]];
            // Ends beyond the image are cut by its edge: only the ends inside are compared.
            let Some(r) = residual(&o, &truth_box, std::slice::from_ref(&object)) else {
                assert!(
                    o.cut[0] && o.cut[1],
                    "{stem}: no residual though an end is inside"
                );
                continue;
            };
            let rule_first_is_start = start[0] <= end[0];
            assert_eq!(r.pairing == 0, rule_first_is_start, "{stem}: pairing");
            // The same streak run the other way in time: the other pairing.
            let mut reversed = object.clone();
            reversed.ephemeris = object.ephemeris.map(|[a, m, b]| [b, m, a]);
            let back = residual(&o, &truth_box, std::slice::from_ref(&reversed)).unwrap();
            assert_eq!(back.pairing, 1 - r.pairing, "{stem}: reversed pairing");
            swapped += r.pairing + back.pairing;
            for e in r.ends.iter().flatten() {
                // TAN's scale changes by under 0.1% within the quickstart's 0.1-degree field.
                let want = shift * scale;
                assert!(
                    (e.0 - want).abs() < 1e-3 + 2e-3 * want,
                    "{stem} shift {shift}: {}\" vs {want}\"",
                    e.0
                );
            }
            assert!(r.correlated);
        }
    }
    assert!(
        swapped > 0,
        "some truth streak runs towards smaller x (the swap is exercised)"
    );
}

/// The campaign field needs the detect stage: refused with its name.
#[test]
fn astrometry_needs_the_detect_stage() {
    let (_tmp, out) = scratch("run");
    let o = quickstart_with(
        &[
            "stages=[\"render\", \"enhance\"]",
            "artifacts.astrometry=true",
        ],
        &out,
    );
    assert_refused(
        &o,
        "`artifacts.astrometry`: the astrometry is of the detect stage's",
    );
}

/// The truth's own ends on the GEO stare (issue #45: residuals from the truth below 0.1"):
/// each end is a trajectory sample at the centre of its time slice, and against the ephemeris
/// at that instant it sits within 1 mas (the pixel was made by the same TAN the FITS WCS
/// states, with no jitter in this campaign; what is left is the parabola through the
/// ephemeris' start, middle and end, evaluated 2.5 ms from its start: micro-arcseconds). Their
/// ADES `obsTime`s and TDM times are those instants: the renderer's own first and last samples
/// (the light curve's `utc`), not the exposure's start and end.
#[test]
fn geo_stare_truth_ends_at_their_own_instants() {
    let (_tmp, out) = scratch("run");
    render(
        "campaigns/geo-stare.toml",
        &[
            "images=3",
            "stages=[\"render\", \"enhance\", \"dataset\", \"detect\"]",
            "split.train=0.0",
            "split.val=0.0",
            "split.test=1.0",
            "detect.classical=true",
            "artifacts.astrometry=true",
            "artifacts.light_curve=true",
        ],
        &out,
    );
    let csv = std::fs::read_to_string(out.join("report/astrometry.csv")).unwrap();
    let mut head = csv.lines().next().unwrap().split(',');
    let sep = head.position(|c| c == "separation_arcsec").unwrap();
    let truth: Vec<f64> = csv
        .lines()
        .filter(|l| l.starts_with("truth,"))
        .map(|l| l.split(',').nth(sep).unwrap().parse().unwrap())
        .collect();
    assert!(truth.len() >= 10, "{} truth ends", truth.len());
    let worst = truth.iter().copied().fold(0.0, f64::max);
    assert!(worst < 1e-3, "truth residual {worst}\"");

    // The ADES obsTimes, per image and label, against the light curve's first and last samples.
    let psv = std::fs::read_to_string(out.join("report/observations/truth.psv")).unwrap();
    let rows: Vec<Vec<&str>> = psv
        .lines()
        .skip_while(|l| !l.starts_with("trkSub|"))
        .skip(1)
        .map(|l| l.split('|').collect())
        .collect();
    assert_eq!(rows.len(), truth.len());
    let mut tdm_times = Vec::new();
    let tdm = std::fs::read_to_string(out.join("report/observations/truth.tdm")).unwrap();
    for l in tdm.lines().filter(|l| l.starts_with("ANGLE_1 = ")) {
        tdm_times.push(l.split_whitespace().nth(2).unwrap().to_string());
    }
    let ades_times: Vec<String> = rows
        .iter()
        .map(|r| r[8].trim_end_matches('Z').to_string())
        .collect();
    assert_eq!(tdm_times, ades_times, "the TDM's and the ADES' times");
    for r in &rows {
        // remarks: "truth img_000000 label 3 end first"
        let words: Vec<&str> = r[17].split_whitespace().collect();
        let (stem, label, first) = (words[1], words[3], words[5] == "first");
        let t = json(&out.join(format!("truth/{stem}.json")));
        let label: usize = label.parse().unwrap();
        let object = t["objects"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|o| !o["label_box_final_px"].is_null())
            .nth(label)
            .unwrap();
        let norad = object["norad"].as_u64().unwrap().to_string();
        let curve =
            std::fs::read_to_string(out.join(format!("truth/{stem}_light_curve.csv"))).unwrap();
        let utc: Vec<&str> = curve
            .lines()
            .map(|l| l.split(',').collect::<Vec<_>>())
            .filter(|c| c[2] == norad)
            .map(|c| c[5])
            .collect();
        let want = if first { utc[0] } else { utc[utc.len() - 1] };
        // The light curve counts from the exact start, the report from `DATE-OBS`, truncated
        // to the microsecond: the two may differ by 1 us (a wrong slice count by ms).
        let (got, want_at) = (
            seconds_of_day(r[8].trim_end_matches('Z')),
            seconds_of_day(want),
        );
        assert!(
            (got - want_at).abs() <= 1.5e-6,
            "{stem} label {label}: {} vs {want}",
            r[8]
        );
        // Half a slice inside the exposure, not its start or end.
        assert_ne!(want, t["start_utc"].as_str().unwrap());

        // A space-based observer's place (ADES `sys`, `ctr`, `pos1..3`): the stare has no
        // object of its own, yet its FITS states the observer's mid-exposure GCRS state
        // (`OBSPOS-*`, `OBSVEL-*`), the very state each object's ephemeris gives (a card's 15
        // significant digits: 1e-9 km), moved to the record's instant by its velocity
        // (written to 0.1 m: 5e-5 km).
        let sky = FrameSky::read(&out.join(format!("fits/{stem}.fits"))).unwrap();
        let (p, v) = sky
            .observer
            .expect("OBSPOS and OBSVEL on a catalogue stare's FITS");
        let e = &object["ephemeris"];
        for k in 0..3 {
            assert!((p[k] - e["observer_gcrs_km"][k].as_f64().unwrap()).abs() < 1e-9);
            assert!((v[k] - e["observer_gcrs_km_s"][k].as_f64().unwrap()).abs() < 1e-9);
        }
        assert_eq!((r[3], r[4]), ("ICRF_KM", "399"));
        let t_s = if first { 0.0025 } else { 9.9975 };
        for k in 0..3 {
            let want = p[k] + v[k] * (t_s - 5.0);
            let got: f64 = r[5 + k].parse().unwrap();
            assert!(
                (got - want).abs() < 5e-5 + 1e-9,
                "pos{}: {got} vs {want}",
                k + 1
            );
        }
    }
}

/// Seconds since midnight of ISO 8601 UTC `t` (`YYYY-MM-DDThh:mm:ss.ffffff`); the dates
/// compared here are the same day.
fn seconds_of_day(t: &str) -> f64 {
    let (_, time) = t.split_once('T').unwrap();
    let v: Vec<f64> = time.split(':').map(|x| x.parse().unwrap()).collect();
    v[0] * 3600.0 + v[1] * 60.0 + v[2]
}
