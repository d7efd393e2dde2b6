//! Ground observers (issue #46): the two ground campaigns run, are deterministic across thread
//! counts and verify; from the ground a sidereal track leaves a LEO object streaking among point
//! stars, and a GEO stare leaves the geostationary object standing among trailed stars; the
//! FITS carry the site and pointing keywords as astropy computes them
//! (tests/reference/check_ground_fits.py) and the sidereal WCS puts stars on their flux peaks
//! to 0.05 px (tests/reference/check_fits_wcs.py).

use std::path::Path;

mod common;
use common::{json, python_with_astropy, repo, run_on_one_and_two_threads_and_verify};

/// Every truth file of an output: (streak length px, star drift over the exposure, deg).
fn streaks(out: &Path) -> Vec<(f64, f64)> {
    let mut found = Vec::new();
    for i in 0.. {
        let path = out.join(format!("truth/img_{i:06}.json"));
        if !path.exists() {
            break;
        }
        let t = json(&path);
        let p = |k: &str| [t[k][0].as_f64().unwrap(), t[k][1].as_f64().unwrap()];
        let (s, e) = (p("streak_start_px"), p("streak_end_px"));
        let drift = t["pointing"]["drift_deg"].as_f64().unwrap_or(0.0);
        found.push(((s[0] - e[0]).hypot(s[1] - e[1]), drift));
    }
    found
}

fn pixel_scale_deg(out: &Path) -> f64 {
    json(&out.join("manifest.json"))["effective"]["pixel_scale_arcsec"]
        .as_f64()
        .unwrap()
        / 3600.0
}

/// The astropy checks of `out`: the site cards and pointing, and for a sidereal track the
/// WCS's star offsets, whose worst is returned.
fn astropy_checks(python: &Path, out: &Path, site: [&str; 3]) -> Option<f64> {
    let o = std::process::Command::new(python)
        .arg(repo("tests/reference/check_ground_fits.py"))
        .arg(out)
        .args(site)
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&o.stdout).to_string();
    eprintln!("{said}{}", String::from_utf8_lossy(&o.stderr));
    assert!(o.status.success(), "{said}");
    let o = std::process::Command::new(python)
        .arg(repo("tests/reference/check_fits_wcs.py"))
        .arg(out)
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&o.stdout).to_string();
    eprintln!("{said}");
    said.split("max ")
        .nth(1)
        .and_then(|r| r.split(" px").next())
        .and_then(|v| v.parse().ok())
}

#[test]
fn sidereal_leo_from_the_ground() {
    let dir = tempfile::tempdir().unwrap();
    let out = run_on_one_and_two_threads_and_verify(
        &repo("campaigns/ground-sidereal-leo.toml"),
        dir.path(),
    );
    let s = streaks(&out);
    assert_eq!(s.len(), 12);
    for (len, drift) in &s {
        // Sidereal tracking: the stars stand (no drift) and a LEO object 800-2500 km away
        // crosses hundreds of pixels in seconds.
        assert_eq!(*drift, 0.0);
        assert!(*len > 100.0, "{len} px");
    }
    if let Some(python) = python_with_astropy() {
        let worst = astropy_checks(&python, &out, ["-31.2733", "149.0644", "1165.0"]);
        // The 0.05 px (measured 0.030 px).
        assert!(worst.is_some_and(|w| w < 0.05), "{worst:?}");
    }
}

#[test]
fn geo_stare_from_the_ground() {
    let dir = tempfile::tempdir().unwrap();
    let out =
        run_on_one_and_two_threads_and_verify(&repo("campaigns/ground-geo-stare.toml"), dir.path());
    let scale = pixel_scale_deg(&out);
    let s = streaks(&out);
    assert_eq!(s.len(), 12);
    for (len, drift) in &s {
        // Held in altitude and azimuth the stars trail at the Earth's rate (15 arcsec/s cos dec:
        // 2-8 s exposures, 45-155 px at 0.7 arcsec/px); the near-geostationary object (3 deg of
        // inclination: < 0.8 arcsec/s, plus the space sensor's default pointing jitter, which
        // the ground campaigns keep) moves a few pixels. Measured 1.7-8.5 px against 49-155 px,
        // at most 0.11 of the trail; 0.2 bounds it, far from a tracked object's 1.
        let trail_px = drift / scale;
        assert!(trail_px > 30.0, "{trail_px} px");
        assert!(
            *len < 0.2 * trail_px,
            "{len} px against star trails of {trail_px} px"
        );
    }
    if let Some(python) = python_with_astropy() {
        // The centroid check is not meant for trailed stars (the space survey campaign reads
        // ~2 px too): only the header checks count here.
        astropy_checks(&python, &out, ["28.7606", "-17.8816", "2396.0"]);
    }
}
