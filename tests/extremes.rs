//! Extreme and stiff cases (issue #6, part 3). Each test pins a defined outcome: a valid image
//! (finite, non-negative, photons where Eq. 3 says) or a clear rejection naming the file, line
//! and field. docs/extreme-cases.md's table lists every case with its outcome and test.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use std::path::Path;

use hifitime::{Duration, Epoch};
use soig::campaign::Campaign;
use soig::experiment;
use soig::render::{self, Exposure};
use soig::rng::{PixelPurpose, pixel_stream, poisson};
use soig::scene::{self, Scene, TrajectorySample};
use soig::sensor::Sensor;
use soig::sky::photometry::{debris_magnitude, diffuse_sphere_phase, photon_rate};
use soig::sky::projection::Tan;
use soig::sky::stars::{ProceduralSky, Star, cumulative_density_per_deg2, equatorial_to_galactic};

mod common;
use common::{CampaignToml, ELEMENTS_40649, arg, scratch, tle_file, tle_object};

/// A small campaign (128 px at the paper's pixel scale unless `extra` says otherwise) observed
/// from SENTINEL-3A; `debris` is the body of one `[[debris]]` table.
fn campaign(debris: &str, extra: &str) -> Campaign {
    extremes(debris, extra).load("extremes.toml")
}

fn campaign_text(debris: &str, extra: &str) -> String {
    extremes(debris, extra).text()
}

fn extremes(debris: &str, extra: &str) -> CampaignToml {
    CampaignToml::new("extremes", 3, 2)
        .debris(debris)
        .tables(extra)
}

fn sensor(width: u32, fov: f64) -> String {
    format!("[sensor]\nwidth_px = {width}\nheight_px = {width}\nfov_radius_deg = {fov}\n")
}

fn all_finite(e: &Exposure) {
    assert!(
        e.adu.iter().all(|a| a.is_finite() && *a >= 0.0),
        "non-finite or negative ADU"
    );
    let t = &e.truth;
    for (name, v) in [
        ("range", t.range_km),
        ("phase", t.phase_angle_deg),
        ("magnitude", t.magnitude),
        ("expected debris", t.expected_debris_electrons),
        ("snr", t.snr),
        ("background sigma", t.background_sigma_adu),
    ] {
        assert!(v.is_finite(), "{name} is {v}");
    }
    if let Some(b) = t.label_box_px {
        let (w, h) = (e.width as f64, e.height as f64);
        assert!(
            b.x_min >= -0.5 && b.y_min >= -0.5 && b.x_max <= w - 0.5 && b.y_max <= h - 0.5,
            "label box {b:?} outside the image"
        );
    }
}

/// The sensor a campaign builds.
fn sensor_of(c: &Campaign) -> Sensor {
    experiment::of(c).sensor
}

fn render_scene(c: &Campaign, s: &Scene, seed: u64) -> Exposure {
    let x = experiment::of(c);
    render::render(
        &x.sensor,
        &x.render,
        s,
        None,
        &mut pixel_stream(seed, s.image_index, PixelPurpose::Photons),
        &mut pixel_stream(seed, s.image_index, PixelPurpose::Noise),
    )
}

/// A hand-made fixed-pointing scene at (ra, dec) of the campaign's sensor (`Scene::fixed_streak`).
fn fixed_scene(
    c: &Campaign,
    pointing: (f64, f64),
    stars: Vec<Star>,
    debris_mag: f64,
    ends_px: ((f64, f64), (f64, f64)),
    exposure_s: f64,
) -> Scene {
    Scene::fixed_streak(
        &sensor_of(c),
        pointing,
        stars,
        debris_mag,
        ends_px,
        exposure_s,
    )
}

/// A star and its pixel.
type Placed = (Star, (f64, f64));

/// The stars whose pixel lies in the image.
fn stars_in_image(tan: &Tan, stars: &[Star], w: u32) -> Vec<Placed> {
    let edge = w as f64 - 0.5;
    stars
        .iter()
        .filter_map(|s| {
            let p = tan.pixel(s.ra_deg, s.dec_deg)?;
            (p.0 >= -0.5 && p.1 >= -0.5 && p.0 < edge && p.1 < edge).then_some((*s, p))
        })
        .collect()
}

/// Model expectation of stars brighter than `mag` in a square field of `side` degrees around
/// (ra, dec) (small field: the density at its centre).
fn expected_stars(ra: f64, dec: f64, side: f64, mag: f64) -> f64 {
    let (_, b) = equatorial_to_galactic(ra, dec);
    cumulative_density_per_deg2(b, mag) * side * side
}

// ---------------------------------------------------------------------------------------------
// Fields at the celestial poles and across RA 0/360
// ---------------------------------------------------------------------------------------------

/// Fixed fields at Dec +-90 exactly and near the poles: the gnomonic projection and the star
/// cells have no singularity there. Every star of the cone that falls in the image is traced
/// once, at the pixel the WCS gives, with a density that matches the count model, and a debris
/// streak across the pole stays straight in pixels.
#[test]
fn pole_fields_are_valid_images() {
    let (w, fov) = (128u32, 0.1);
    let c = campaign(ELEMENTS_40649, &sensor(w, fov));
    let sky = ProceduralSky::new(0);
    let side = 2.0 * fov;
    let (mut seen, mut expected) = (0.0, 0.0);
    for (ra, dec) in [
        (0.0, 90.0),
        (123.0, 90.0),
        (37.0, -90.0),
        (250.0, 89.99),
        (10.0, -89.95),
    ] {
        let stars = sky.stars_in_cone(ra, dec, 0.15, 16.5);
        let s = fixed_scene(
            &c,
            (ra, dec),
            stars.clone(),
            12.0,
            ((10.0, 20.0), (110.0, 100.0)),
            2.0,
        );
        let tan = s.projection(&sensor_of(&c));
        // The streak passes within a pixel of the pole (the image centre is on or near it):
        // pixel -> sky -> pixel is the identity along it, though RA jumps by up to 180 deg.
        for p in &s.trajectory {
            let (x, y) = tan.pixel(p.ra_deg, p.dec_deg).unwrap();
            assert!(
                (x - p.x_px).abs() < 1e-6 && (y - p.y_px).abs() < 1e-6,
                "({ra}, {dec})"
            );
        }
        let inside = stars_in_image(&tan, &stars, w);
        seen += inside.len() as f64;
        expected += expected_stars(ra, dec, side, 16.5);
        eprintln!(
            "({ra}, {dec}): {} stars, model {:.1}",
            inside.len(),
            expected_stars(ra, dec, side, 16.5)
        );
        let e = render_scene(&c, &s, 1);
        all_finite(&e);
        // Every star in the image is traced exactly once, where the WCS puts it.
        for (star, (x, y)) in &inside {
            let traced: Vec<_> = e
                .stars
                .iter()
                .filter(|t| t.ra_deg == star.ra_deg && t.dec_deg == star.dec_deg)
                .collect();
            assert_eq!(traced.len(), 1, "({ra}, {dec}) star {star:?}");
            let (jx, jy) = (e.truth.jitter_mean_px[0], e.truth.jitter_mean_px[1]);
            assert!((traced[0].x - (x + jx)).abs() < 1e-9 && (traced[0].y - (y + jy)).abs() < 1e-9);
        }
        // The label box holds the streak, from (10, 20) to (110, 100).
        let b = e.truth.label_box_px.expect("debris rendered");
        assert!(
            b.x_min <= 11.0 && b.x_max >= 109.0 && b.y_min <= 21.0 && b.y_max >= 99.0,
            "{b:?}"
        );
    }
    // Star density in the polar fields matches the count model (5 fields, ~60 stars each).
    eprintln!("polar fields: {seen} stars, model {expected:.1}");
    assert!(
        (seen - expected).abs() < 5.0 * expected.sqrt(),
        "{seen} stars in the polar fields, model {expected:.1}"
    );
}

/// A fixed pointing at RA 359.95: the field spans RA 359.85 .. 0.05. Star cells wrap: the
/// density is continuous across the seam (strips on both sides match the count model), no star
/// is doubled or missing, and the rendered field has stars on both sides of the seam at the
/// pixels the WCS gives.
#[test]
fn ra_seam_is_continuous() {
    let sky = ProceduralSky::new(0);
    // Density: RA strips of 0.1 deg (signed RA, seam at 0) between Dec 29.5 and 30.5, mag 17.
    let dec0 = 30.0;
    let stars = sky.stars_in_cone(0.0, dec0, 1.2, 17.0);
    let mut keys: Vec<(u64, u64)> = stars
        .iter()
        .map(|s| (s.ra_deg.to_bits(), s.dec_deg.to_bits()))
        .collect();
    keys.sort();
    keys.dedup();
    assert_eq!(keys.len(), stars.len(), "a star is doubled");
    let sin = |d: f64| d.to_radians().sin();
    let strip_deg2 = 0.1f64.to_radians()
        * (sin(dec0 + 0.5) - sin(dec0 - 0.5))
        * (180.0 / std::f64::consts::PI).powi(2);
    for k in -6i32..6 {
        let (lo, hi) = (k as f64 * 0.1, (k + 1) as f64 * 0.1);
        let n = stars
            .iter()
            .filter(|s| {
                let ra = if s.ra_deg > 180.0 {
                    s.ra_deg - 360.0
                } else {
                    s.ra_deg
                };
                ra >= lo && ra < hi && (s.dec_deg - dec0).abs() < 0.5
            })
            .count() as f64;
        let (_, b) = equatorial_to_galactic((lo + 0.05).rem_euclid(360.0), dec0);
        let model = cumulative_density_per_deg2(b, 17.0) * strip_deg2;
        assert!(
            (n - model).abs() < 5.0 * model.sqrt(),
            "strip RA [{lo:.1}, {hi:.1}): {n} stars, model {model:.0}"
        );
    }
    // The cone at 359.95 is the same set written with RA -0.05 or 719.95, and the restriction
    // of the big cone: nothing lost or doubled at the seam.
    let field = sky.stars_in_cone(359.95, dec0, 0.15, 16.5);
    assert_eq!(field, sky.stars_in_cone(-0.05, dec0, 0.15, 16.5));
    assert_eq!(field, sky.stars_in_cone(719.95, dec0, 0.15, 16.5));
    let centre = soig::sky::radec_unit(359.95, dec0);
    let restricted: Vec<Star> = stars
        .iter()
        .copied()
        .filter(|s| {
            s.mag <= 16.5
                && soig::sky::angle_deg(centre, soig::sky::radec_unit(s.ra_deg, s.dec_deg)) <= 0.15
        })
        .collect();
    assert_eq!(field.len(), restricted.len());
    assert!(field.iter().any(|s| s.ra_deg < 1.0) && field.iter().any(|s| s.ra_deg > 359.0));

    // Rendered: stars on both sides of the seam, each traced once where the WCS says.
    let (w, fov) = (128u32, 0.1);
    let c = campaign(ELEMENTS_40649, &sensor(w, fov));
    let s = fixed_scene(
        &c,
        (359.95, dec0),
        field,
        12.0,
        ((-20.0, 64.0), (150.0, 64.0)),
        2.0,
    );
    let tan = s.projection(&sensor_of(&c));
    let inside = stars_in_image(&tan, &s.stars, w);
    let e = render_scene(&c, &s, 2);
    all_finite(&e);
    let (east, west): (Vec<&Placed>, Vec<_>) = inside.iter().partition(|(st, _)| st.ra_deg < 180.0);
    // The seam is at x = cx + 0.05 deg / scale (about 96 px): a quarter of the field is east of it.
    let quarter = expected_stars(359.95, dec0, 2.0 * fov, 16.5) / 4.0;
    eprintln!(
        "seam field: {} east, {} west, model {quarter:.1} / {:.1}",
        east.len(),
        west.len(),
        3.0 * quarter
    );
    assert!(
        (east.len() as f64 - quarter).abs() < 5.0 * quarter.sqrt() && !east.is_empty(),
        "{} stars east of the seam, model {quarter:.1}",
        east.len()
    );
    assert!((west.len() as f64 - 3.0 * quarter).abs() < 5.0 * (3.0 * quarter).sqrt());
    for (st, (x, _)) in &inside {
        let traced = e
            .stars
            .iter()
            .filter(|t| t.ra_deg == st.ra_deg && t.dec_deg == st.dec_deg)
            .count();
        assert_eq!(traced, 1, "{st:?}");
        // East of the seam (RA just above 0) is right of it in the image: +x is +RA.
        let seam_x = tan.pixel(0.0, st.dec_deg).unwrap().0;
        assert_eq!(
            st.ra_deg < 180.0,
            *x > seam_x,
            "{st:?} at x {x}, seam at {seam_x}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Orbits: GEO, highly eccentric, near perigee; decayed and invalid TLEs
// ---------------------------------------------------------------------------------------------

/// Draw and render `n` images; every accepted scene is finite and its image valid.
fn draw_and_render(c: &Campaign, n: u64) -> Vec<(Scene, Exposure)> {
    let inputs = experiment::inputs(c).unwrap();
    let x = experiment::of(c);
    (0..n)
        .map(|i| {
            let s = scene::draw(&x.scene, &x.sensor, &inputs, c.resolved.seed, i)
                .unwrap_or_else(|e| panic!("{e}"));
            for p in &s.trajectory {
                assert!(p.expected_electrons.is_finite() && p.expected_electrons >= 0.0);
                assert!(p.ra_deg.is_finite() && p.dec_deg.is_finite());
            }
            let e = render_scene(c, &s, c.resolved.seed);
            all_finite(&e);
            (s, e)
        })
        .collect()
}

/// Debris in GEO (MSG 4 DEB, 1.015 rev/day, SDP4) and in a GTO-like orbit (BREEZE-M tank,
/// e = 0.52), and a Molniya orbit from elements (e = 0.72): valid scenes and images, at
/// physical ranges.
#[test]
fn geo_and_highly_eccentric_debris() {
    let extra = format!(
        "{}[render]\ntrajectory_samples = 200\n",
        sensor(128, 0.0125)
    );
    // GEO: range from a 800 km LEO observer to the geostationary ring.
    let geo = campaign(&tle_object(40989), &extra);
    for (s, _) in draw_and_render(&geo, 2) {
        let r = s.geometry.range_km;
        assert!((28_000.0..50_000.0).contains(&r), "GEO range {r} km");
    }
    // GTO-like: perigee ~220 km, apogee ~14,000 km altitude.
    let gto = campaign(&tle_object(40386), &extra);
    for (s, _) in draw_and_render(&gto, 2) {
        assert!(s.geometry.range_km < 30_000.0, "{}", s.geometry.range_km);
    }
    // Molniya: 12 h, 63.4 deg, perigee 600 km, apogee 39,700 km.
    let molniya = campaign(
        "norad = 90001\nelements = { period_min = 717.7, inclination_deg = 63.4, apogee_km = 39700.0, perigee_km = 600.0, arg_perigee_deg = 270.0 }",
        &extra,
    );
    for (s, _) in draw_and_render(&molniya, 2) {
        assert!(s.geometry.range_km < 60_000.0, "{}", s.geometry.range_km);
    }
}

/// A TLE from 2022-01-01 (16.2 rev/day, B* 5e-3) that SGP4 finds decayed from hour 65 on.
const DECAYING_TLE: [&str; 2] = [
    "1 99999U 22001A   22001.00000000  .01000000  00000-0  50000-2 0  9993",
    "2 99999  51.6000 100.0000 0005000  90.0000 270.0000 16.20000000000013",
];

/// A decayed TLE (SGP4 reports decay for the whole window) is refused when the campaign loads,
/// naming the campaign file, the line and field of the object, the NORAD number and, for a
/// `tle_file`, the TLE file and the line of the TLE in it. A TLE that decays inside the window
/// is kept (draws after the decay are rejected).
#[test]
fn decayed_tle_is_refused_naming_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let window =
        "[window]\nstart = \"2022-01-10T00:00:00 UTC\"\nend = \"2022-01-11T00:00:00 UTC\"\n";
    let inline = format!("tle = [\"{}\", \"{}\"]", DECAYING_TLE[0], DECAYING_TLE[1]);
    let text = campaign_text(&inline, window);
    let e = Campaign::from_toml(&text, Path::new("decay.toml")).unwrap_err();
    let msg = e.to_string();
    assert_eq!(e.field.as_deref(), Some("debris[0].tle"), "{msg}");
    assert_eq!(e.line, Some(8), "{msg}");
    assert!(
        msg.starts_with("decay.toml:8: field `debris[0].tle`"),
        "{msg}"
    );
    assert!(
        msg.contains("NORAD 99999") && msg.contains("decayed"),
        "{msg}"
    );

    // The same TLE in a file, third of two sets: the message names the file and line 5.
    let tles = dir.path().join("decayed.tle");
    let lines = std::fs::read_to_string(tle_file()).unwrap();
    let first_set: Vec<&str> = lines.lines().take(3).collect();
    std::fs::write(
        &tles,
        format!(
            "{}\nDECAYED\n{}\n{}\n",
            first_set.join("\n"),
            DECAYING_TLE[0],
            DECAYING_TLE[1]
        ),
    )
    .unwrap();
    let text = campaign_text(
        &format!("tle_file = \"{}\"\nnorad = 99999", tles.display()),
        window,
    );
    let e = Campaign::from_toml(&text, Path::new("decay.toml")).unwrap_err();
    let msg = e.to_string();
    assert_eq!(e.field.as_deref(), Some("debris[0].tle_file"), "{msg}");
    assert_eq!(e.line, Some(8), "{msg}");
    assert!(
        msg.contains(&format!("line 5 of {}", tles.display())),
        "{msg}"
    );
    assert!(msg.contains("decayed"), "{msg}");

    // Decaying inside the window (hour 65 after 2022-01-01): kept.
    let inside =
        "[window]\nstart = \"2022-01-02T00:00:00 UTC\"\nend = \"2022-01-05T00:00:00 UTC\"\n";
    let c = Campaign::from_toml(&campaign_text(&inline, inside), Path::new("x.toml")).unwrap();
    let late = c.window_end;
    assert!(c.debris[0].propagator.position_teme_km(late).is_err());

    // The CLI prints the same message and fails before writing anything.
    let path = dir.path().join("decay.toml");
    std::fs::write(&path, campaign_text(&inline, window)).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_soig"))
        .args(["run", arg(&path), "--quiet", "--out"])
        .arg(dir.path().join("out"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("decay.toml:8: field `debris[0].tle`") && stderr.contains("decayed"),
        "{stderr}"
    );
    assert!(!dir.path().join("out").exists());
}

/// A change to the lines of a TLE file.
type Damage = Box<dyn Fn(&mut Vec<String>)>;

/// Invalid TLEs (bad checksum, a malformed line) are refused when the campaign loads, naming
/// the campaign file and line of the field, the TLE file and the line in it.
#[test]
fn invalid_tle_errors_name_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let good = std::fs::read_to_string(tle_file()).unwrap();
    let lines: Vec<String> = good.lines().map(str::to_string).collect();
    let cases: [(&str, Damage, &str); 3] = [
        (
            "checksum",
            Box::new(|l| l[5].replace_range(68..69, "0")), // 40386 line 2, true checksum 5
            "TLE line 6: bad checksum, expected 5, found '0'",
        ),
        (
            "short",
            Box::new(|l| l[4].truncate(50)),
            "TLE line 5: 50 characters, a TLE line has 69",
        ),
        (
            "marker",
            Box::new(|l| l[5].replace_range(0..1, "3")),
            "TLE line 6: line number marker is '3', expected '2'",
        ),
    ];
    for (name, damage, needle) in cases {
        let mut bad = lines.clone();
        damage(&mut bad);
        let path = dir.path().join(format!("{name}.tle"));
        std::fs::write(&path, bad.join("\n") + "\n").unwrap();
        let text = campaign_text(
            &format!("tle_file = \"{}\"\nnorad = 40386", path.display()),
            "",
        );
        let e = Campaign::from_toml(&text, Path::new("bad.toml")).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.starts_with("bad.toml:8: field `debris[0].tle_file`"),
            "{name}: {msg}"
        );
        assert!(msg.contains(&path.display().to_string()), "{name}: {msg}");
        assert!(msg.contains(needle), "{name}: {msg}");
    }
    // An inline TLE with a bad checksum: the field `debris[0].tle` and its line.
    let l2 = format!("{}0", &lines[5][..68]);
    let text = campaign_text(&format!("tle = [\"{}\", \"{}\"]", lines[4], l2), "");
    let e = Campaign::from_toml(&text, Path::new("bad.toml")).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.starts_with("bad.toml:8: field `debris[0].tle`"),
        "{msg}"
    );
    assert!(msg.contains("TLE line 2: bad checksum"), "{msg}");
}

/// A TLE line with its checksum (column 69) made right: digits summed, '-' counting 1.
fn with_checksum(line: &str) -> String {
    let sum: u32 = line[..68]
        .chars()
        .map(|c| c.to_digit(10).unwrap_or(u32::from(c == '-')))
        .sum();
    format!("{}{}", &line[..68], sum % 10)
}

/// An orbit whose perigee is inside the Earth cannot exist: a TLE (inline or in a file) or an
/// element set with a(1 - e) below 6378.137 km is refused at load, naming the campaign file,
/// line and field, and for a file the TLE's line in it. `DECAYING_TLE` with e = 0.1: a = 6598
/// km from 16.2 rev/day, perigee radius 5938 km. Elements: period 1% short of what apogee
/// 1000 km and perigee 10 km give (the 1% the period check allows), so a = 6842 km and
/// a(1 - e) = 6350 km, 28 km below the surface although `perigee_km` is positive.
#[test]
fn orbits_below_the_surface_are_refused_naming_file_and_line() {
    let l2 = with_checksum(&DECAYING_TLE[1].replace(" 0005000 ", " 1000000 "));
    assert_ne!(l2, DECAYING_TLE[1]);
    let inline = format!("tle = [\"{}\", \"{l2}\"]", DECAYING_TLE[0]);
    let e = Campaign::from_toml(&campaign_text(&inline, ""), Path::new("low.toml")).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.starts_with("low.toml:8: field `debris[0].tle`: NORAD 99999: perigee radius 593"),
        "{msg}"
    );
    assert!(
        msg.contains("below the Earth's surface (6378.137 km)"),
        "{msg}"
    );

    // The same TLE in a file, third of two sets: its line 5 and the file are named.
    let (_dir, tles) = scratch("low.tle");
    let catalogue = std::fs::read_to_string(tle_file()).unwrap();
    let first: Vec<&str> = catalogue.lines().take(3).collect();
    let text = format!("{}\nLOW\n{}\n{l2}\n", first.join("\n"), DECAYING_TLE[0]);
    std::fs::write(&tles, text).unwrap();
    let debris = format!("tle_file = \"{}\"\nnorad = 99999", tles.display());
    let e = Campaign::from_toml(&campaign_text(&debris, ""), Path::new("low.toml")).unwrap_err();
    let msg = e.to_string();
    assert_eq!(e.field.as_deref(), Some("debris[0].tle_file"), "{msg}");
    assert_eq!(e.line, Some(8), "{msg}");
    assert!(msg.contains("perigee radius 593"), "{msg}");
    assert!(
        msg.contains(&format!("line 5 of {}", tles.display())),
        "{msg}"
    );

    // An element set: the field `debris[0].elements` on its line.
    let elements = "norad = 90002\nelements = { period_min = 93.87, inclination_deg = 51.6, apogee_km = 1000.0, perigee_km = 10.0 }";
    let e = Campaign::from_toml(&campaign_text(elements, ""), Path::new("low.toml")).unwrap_err();
    let msg = e.to_string();
    assert_eq!(e.field.as_deref(), Some("debris[0].elements"), "{msg}");
    assert_eq!(e.line, Some(9), "{msg}");
    assert!(msg.contains("perigee radius 63"), "{msg}");
    assert!(msg.contains("below the Earth's surface"), "{msg}");
    // The same element set with the period apogee and perigee give (94.72 min) is kept.
    let fine = elements.replace("93.87", "94.72");
    Campaign::from_toml(&campaign_text(&fine, ""), Path::new("ok.toml")).unwrap();
}

/// Near perigee at high speed: a Molniya-like orbit (apogee 39,700 km, perigee 1500 km) in
/// the observer's orbital plane, with its perigee passage (9.3 km/s) right above the observer
/// at the window start, on the day side. The trajectory crosses the 0.025 deg field in a
/// fraction of the exposure: a valid image whose streak leaves it, with the label box clipped.
#[test]
fn near_perigee_at_high_speed() {
    use soig::sky::{angle_deg, norm, radec_unit, sub, unit};
    let probe = campaign(ELEMENTS_40649, "");
    let obs = &probe
        .observer
        .orbit()
        .expect("a satellite observer")
        .propagator;
    // A day-side instant: the Sun 40-80 deg from the observer's zenith.
    let t0 = (0..1440)
        .map(|k| {
            Epoch::from_gregorian_utc_at_midnight(2022, 3, 1)
                + Duration::from_seconds(60.0 * k as f64)
        })
        .find(|&t| {
            let r = obs.position_teme_km(t).unwrap();
            let sun = soig::sky::ephemeris::sun_position_km(t);
            (40.0..80.0).contains(&angle_deg(r, sub(sun, r)))
        })
        .expect("a day-side instant");
    // The observer's orbital plane and argument of latitude at t0 (osculating, TEME).
    let r = obs.position_teme_km(t0).unwrap();
    let v = sub(
        obs.position_teme_km(t0 + Duration::from_seconds(1.0))
            .unwrap(),
        r,
    );
    let h = unit([
        r[1] * v[2] - r[2] * v[1],
        r[2] * v[0] - r[0] * v[2],
        r[0] * v[1] - r[1] * v[0],
    ]);
    let inc = h[2].acos().to_degrees();
    let raan = h[0].atan2(-h[1]).to_degrees().rem_euclid(360.0);
    let node = radec_unit(raan, 0.0);
    let mut arg_lat = angle_deg(node, r);
    if r[2] < 0.0 {
        arg_lat = 360.0 - arg_lat;
    }
    let start = format!("{t0}");
    let c = campaign(
        &format!(
            "norad = 90002\nelements = {{ period_min = 735.0, inclination_deg = {inc}, apogee_km = 39700.0, perigee_km = 1500.0, raan_deg = {raan}, arg_perigee_deg = {arg_lat}, mean_anomaly_deg = 0.0 }}"
        ),
        &format!(
            "[window]\nstart = \"{start}\"\nend = \"{}\"\n{}",
            t0 + Duration::from_seconds(60.0),
            sensor(128, 0.0125)
        ),
    );
    let deb = &c.debris[0].propagator;
    let d0 = deb.position_teme_km(c.window_start).unwrap();
    let speed = norm(sub(
        deb.position_teme_km(c.window_start + Duration::from_seconds(1.0))
            .unwrap(),
        d0,
    ));
    eprintln!(
        "perigee radius {:.0} km, speed {speed:.2} km/s, {:.1} deg from the observer's zenith",
        norm(d0),
        angle_deg(d0, r)
    );
    assert!(speed > 9.0 && norm(d0) < 6378.0 + 1600.0 && angle_deg(d0, r) < 2.0);
    let scale = sensor_of(&c).pixel_scale_deg();
    for (s, e) in draw_and_render(&c, 2) {
        let (first, last) = (s.trajectory.first().unwrap(), s.trajectory.last().unwrap());
        let moved = angle_deg(
            radec_unit(first.ra_deg, first.dec_deg),
            radec_unit(last.ra_deg, last.dec_deg),
        );
        eprintln!(
            "range {:.0} km, {moved:.3} deg in {:.1} s, attempts {}, rejections {:?}, label {:?}",
            s.geometry.range_km, s.exposure_s, s.attempts, s.rejections, e.truth.label_box_px
        );
        assert!(s.geometry.range_km < 3000.0);
        // Several field widths per exposure: the streak enters and leaves the image.
        assert!(moved > 4.0 * 128.0 * scale, "moved {moved} deg");
        let inside = |p: &TrajectorySample| {
            (-0.5..127.5).contains(&p.x_px) && (-0.5..127.5).contains(&p.y_px)
        };
        assert!(!inside(first) || !inside(last));
    }
}

// ---------------------------------------------------------------------------------------------
// Phase angles, exposures, magnitudes
// ---------------------------------------------------------------------------------------------

/// Eq. 6/7 near phase 0 and 180 deg (and beyond, by rounding): F stays in [0, 2/(3 pi)],
/// finite and monotone; the magnitude is finite, or +infinity where F is 0 (exactly 180 deg),
/// never NaN; the photon rate is finite and >= 0 (0 for +infinity). A scene whose magnitude is
/// +infinity is rejected as fainter than the limit; a trajectory sample with it gets no photon.
#[test]
fn phase_angles_near_0_and_180_stay_finite() {
    use std::f64::consts::PI;
    let mut phases: Vec<f64> = vec![-1e-3, -0.0, 0.0, f64::MIN_POSITIVE, PI, PI + 1e-9, 4.0];
    for k in 0..=40 {
        let d = 10f64.powf(-(k as f64) / 2.0); // 1 .. 1e-20 rad
        phases.push(d);
        phases.push(PI - d);
    }
    phases.sort_by(f64::total_cmp);
    let mut last_f = f64::INFINITY;
    for &phi in &phases {
        let f = diffuse_sphere_phase(phi);
        assert!(
            f.is_finite() && (0.0..=2.0 / (3.0 * PI) + 1e-15).contains(&f),
            "F({phi}) = {f}"
        );
        assert!(f <= last_f + 1e-18, "F not monotone at {phi}");
        last_f = f;
        for range_km in [1.0, 700.0, 36_000.0, 400_000.0] {
            for area in [1e-6, 0.956, 50.0] {
                let m = debris_magnitude(area, 1.0, phi, range_km);
                assert!(!m.is_nan() && m != f64::NEG_INFINITY, "m({phi}) = {m}");
                let rate = photon_rate(m, 22.26);
                assert!(rate.is_finite() && rate >= 0.0, "rate({m}) = {rate}");
            }
        }
    }
    // Opposition (0 deg): the brightest a sphere gets, 2.5 log10(pi) = 1.24 mag brighter than
    // at 90 deg.
    let m0 = debris_magnitude(1.0, 1.0, 0.0, 1000.0);
    let m90 = debris_magnitude(1.0, 1.0, PI / 2.0, 1000.0);
    assert!((m90 - m0 - 2.5 * PI.log10()).abs() < 1e-12);
    assert_eq!(photon_rate(f64::INFINITY, 22.26), 0.0);
}

/// Exposures of 0.01 s and 600 s with fixed pointing: valid images whose background and bias
/// follow Eq. 11 (background scaled linearly with exposure). A 600 s survey exposure is refused
/// at load (the boresight would drift by tens of degrees), naming the field and its line.
#[test]
fn exposures_of_10_ms_and_600_s() {
    for t in [0.01, 600.0] {
        let c = campaign(
            &tle_object(37476),
            &format!(
                "{}[exposure]\nmin_s = {t}\nmax_s = {t}\n",
                sensor(128, 0.0125)
            ),
        );
        for (s, e) in draw_and_render(&c, 1) {
            assert_eq!(s.exposure_s, t);
            let n = e.adu.len() as f64;
            let debris_adu = e.truth.rendered_debris_electrons as f64 / 1.6;
            let stars_adu = (e.electrons.iter().map(|&v| v as f64).sum::<f64>()
                - e.truth.rendered_debris_electrons as f64)
                / 1.6;
            let mean = e.adu.iter().map(|&a| a as f64).sum::<f64>() / n;
            let expected = 200.0 * t / 5.0 + 2.5 + (debris_adu + stars_adu) / n;
            // Consecutive in-image samples at most two PSF sigmas apart: a streak, not dots (the
            // 600 s trajectory is resampled from 2000 to tens of thousands of samples).
            let spacing_px = scene::max_sample_spacing_px(&sensor_of(&c), &s.trajectory);
            let psf_px = 1.0 / 3600.0 / sensor_of(&c).pixel_scale_deg();
            assert!(
                spacing_px <= 2.2 * psf_px,
                "{spacing_px} px between samples"
            );
            eprintln!(
                "{t} s: mean ADU {mean:.3} (Eq. 11: {expected:.3}), debris {} e- rendered of {:.1} expected, snr {:.2}, sample spacing {spacing_px:.1} px, streak {:?} -> {:?}",
                e.truth.rendered_debris_electrons,
                e.truth.expected_debris_electrons,
                s.snr,
                e.truth.streak_start_px,
                e.truth.streak_end_px
            );
            assert!(
                (mean - expected).abs() < 0.01 * expected + 0.05,
                "{mean} vs {expected}"
            );
            if t > 1.0 {
                // The LEO debris crosses the whole field in under a second: the trajectory is
                // resampled at least tenfold (the scene drawn under the paper's gate: 18-fold).
                assert!(
                    s.trajectory.len() > 10 * 2000,
                    "{} samples",
                    s.trajectory.len()
                );
                let b = e.truth.label_box_px.expect("debris in the image");
                assert!((b.x_max - b.x_min).max(b.y_max - b.y_min) > 100.0, "{b:?}");
            }
        }
    }
    let e = Campaign::from_toml(
        &campaign_text(
            ELEMENTS_40649,
            "[pointing]\nmode = \"survey\"\n[exposure]\nmin_s = 600.0\nmax_s = 600.0\n",
        ),
        Path::new("long.toml"),
    )
    .unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.starts_with("long.toml:14: field `exposure.max_s`: survey pointing would drift"),
        "{msg}"
    );
}

/// Magnitudes from -1 to 25, stars and debris: photon counts follow Eq. 3 over 27 magnitudes
/// (1e-10 of the flux at 25), packets keep the totals exact, pixels stay below u32::MAX, the
/// ADU finite and the FITS float32 round trip exact. The debris trajectory samples share one
/// source's packet budget, so a magnitude -1 debris renders in bounded time.
#[test]
fn magnitudes_from_minus_1_to_25() {
    let (w, fov) = (128u32, 0.0125);
    let c = campaign(ELEMENTS_40649, &sensor(w, fov));
    let tan = Tan::new(10.0, 20.0, sensor_of(&c).pixel_scale_deg(), w, w);
    let t = 0.01;
    let zp = c.resolved.sensor.zero_point_mag;
    let star_at = |x: f64, y: f64, mag: f64| {
        let (ra_deg, dec_deg) = tan.sky(x, y);
        Star {
            ra_deg,
            dec_deg,
            mag,
        }
    };
    for (star_mag, debris_mag) in [(-1.0, 25.0), (25.0, -1.0), (6.0, 16.5), (16.5, 6.0)] {
        let stars = vec![star_at(40.0, 90.0, star_mag)];
        let s = fixed_scene(
            &c,
            (10.0, 20.0),
            stars,
            debris_mag,
            ((70.0, 30.0), (100.0, 40.0)),
            t,
        );
        let e = render_scene(&c, &s, 4);
        all_finite(&e);
        let total: u64 = e.electrons.iter().map(|&v| v as u64).sum();
        let debris = e.truth.rendered_debris_electrons;
        let star = total - debris;
        for (what, got, mag) in [("star", star, star_mag), ("debris", debris, debris_mag)] {
            let expected = photon_rate(mag, zp) * t;
            assert!(
                (got as f64 - expected).abs() < 6.0 * expected.sqrt() + 1.0,
                "{what} of magnitude {mag}: {got} e- vs Eq. 3 {expected:.3e}"
            );
        }
        assert!(e.electrons.iter().all(|&v| v < u32::MAX));
        eprintln!(
            "star {star_mag} / debris {debris_mag}: {star} / {debris} e-, peak {}",
            e.electrons.iter().max().unwrap()
        );
    }
    // The float32 FITS holds the brightest image exactly.
    let s = fixed_scene(
        &c,
        (10.0, 20.0),
        vec![star_at(64.0, 64.0, -1.0)],
        -1.0,
        ((10.0, 10.0), (120.0, 20.0)),
        t,
    );
    let e = render_scene(&c, &s, 5);
    let (_dir, path) = scratch("bright.fits");
    soig::fits::write_image(
        &path,
        e.width,
        e.height,
        soig::fits::Pixels::F32(&e.adu),
        &soig::fits::wcs_cards(&tan),
    )
    .unwrap();
    let (back, rows, cols) = soig::fits::read_f32(&path).unwrap();
    assert_eq!((rows, cols), (e.height, e.width));
    assert_eq!(back, e.adu);
}

/// The campaign of `w` x `w` px over `fov` degrees (the debris 40649) and a star of magnitude
/// `mag` at the centre pixel of a field centred on (10, 20) degrees.
fn star_at_the_centre(w: u32, fov: f64, mag: f64) -> (Campaign, Star) {
    let c = campaign(ELEMENTS_40649, &sensor(w, fov));
    let tan = Tan::new(10.0, 20.0, sensor_of(&c).pixel_scale_deg(), w, w);
    let centre = f64::from(w / 2);
    let (ra_deg, dec_deg) = tan.sky(centre, centre);
    (
        c,
        Star {
            ra_deg,
            dec_deg,
            mag,
        },
    )
}

/// A magnitude-6 star in the field (the brightest the visibility rules admit, paper 3.2.3) over
/// the paper's 5 s: 1.6e7 photo-electrons, traced in 5-photon packets; no full-well
/// saturation is modelled, so its core holds ~1e6 e- per pixel, exact in u32 and in the
/// float32 FITS. The enhanced PNG stays valid, with the star at the top of the range.
#[test]
fn magnitude_6_star_in_the_field() {
    let w = 128u32;
    let (c, star) = star_at_the_centre(w, 0.0125, 6.0);
    let s = fixed_scene(
        &c,
        (10.0, 20.0),
        vec![star],
        14.0,
        ((10.0, 20.0), (50.0, 30.0)),
        5.0,
    );
    let e = render_scene(&c, &s, 6);
    all_finite(&e);
    let expected = photon_rate(6.0, c.resolved.sensor.zero_point_mag) * 5.0;
    let total: u64 = e.electrons.iter().map(|&v| v as u64).sum();
    let star_e = (total - e.truth.rendered_debris_electrons) as f64;
    assert!(
        (star_e - expected).abs() < 6.0 * expected.sqrt() + 0.001 * expected,
        "{star_e} vs {expected}"
    );
    let peak = *e.electrons.iter().max().unwrap();
    assert!(peak > 500_000 && peak < u32::MAX / 100, "peak {peak}");
    let settings = experiment::of(&c).product.expect("enhance stage").enhance;
    let png = soig::enhance::enhance(&e.adu, e.width, e.height, &settings);
    let centre = png.pixels[64 * w as usize + 64];
    let median = {
        let mut p = png.pixels.clone();
        p.sort();
        p[p.len() / 2]
    };
    assert!(
        centre >= 250 && median > 20 && median < 200,
        "centre {centre}, median {median}"
    );
    // The visibility rule: a star brighter than 6 in the star cone rejects the draw.
    assert_eq!(c.resolved.visibility.brightest_star_mag, 6.0);
}

// ---------------------------------------------------------------------------------------------
// A streak leaving the image; a huge Poisson mean
// ---------------------------------------------------------------------------------------------

/// A streak leaving the image: the label box is the box of the flux that landed, clipped to
/// the image; the SNR gate counts only the in-image part of the streak. A streak wholly
/// outside has SNR 0 (the gate rejects the draw) and, if rendered, no label box (an empty
/// label file, a background image for YOLO).
#[test]
fn streak_leaving_the_image() {
    let (w, fov) = (128u32, 0.0125);
    let c = campaign(ELEMENTS_40649, &sensor(w, fov));
    let sigma = sensor_of(&c).background_sigma_adu(2.0, None);
    // A magnitude-11 streak between two pixel places, no star, over 2 s.
    let streak = |ends| fixed_scene(&c, (10.0, 20.0), vec![], 11.0, ends, 2.0);
    // From the centre out through the right edge: half the streak is in the image.
    let s = streak(((64.0, 64.0), (320.0, 64.0)));
    let e = render_scene(&c, &s, 7);
    all_finite(&e);
    let b = e.truth.label_box_px.expect("debris in the image");
    assert!(b.x_max == 127.5 && (b.x_min - 64.0).abs() < 4.0, "{b:?}");
    assert!(b.y_min > 55.0 && b.y_max < 73.0, "{b:?}");
    let expected = e.truth.expected_debris_electrons;
    let landed = e.truth.rendered_debris_electrons as f64;
    // The streak is 256 px long and 64 px of it lie in the image: a quarter of the flux.
    assert!(
        (landed / expected - 0.25).abs() < 0.02,
        "{landed} of {expected}"
    );
    assert!(e.truth.streak_end_px[0] > 300.0);
    // The SNR of the leaving streak is that of its in-image part alone.
    let inside: Vec<TrajectorySample> = s
        .trajectory
        .iter()
        .copied()
        .filter(|p| p.x_px < 127.5)
        .collect();
    let full = scene::expected_snr(&sensor_of(&c), &s.trajectory, sigma);
    assert!(
        full > 0.0
            && (full - scene::expected_snr(&sensor_of(&c), &inside, sigma)).abs() < 1e-12 * full
    );
    // Wholly outside: SNR 0, below any gate; rendered anyway, no label.
    let out = streak(((200.0, 64.0), (400.0, 64.0)));
    assert_eq!(
        scene::expected_snr(&sensor_of(&c), &out.trajectory, sigma),
        0.0
    );
    let e = render_scene(&c, &out, 8);
    all_finite(&e);
    assert_eq!(e.truth.label_box_px, None);
    assert_eq!(e.truth.rendered_debris_electrons, 0);
}

/// A huge Poisson mean: rand_distr refuses means above ~1.8e19 (about u64::MAX); soig's draw
/// returns the rounded mean there, saturating at u64::MAX for larger and infinite means (the
/// Poisson spread is below 1e-9 of the mean). A source that bright renders in bounded time
/// (at most MAX_PACKETS_PER_SOURCE packets of at most u32::MAX photons), every pixel it hits
/// saturated at u32::MAX, and the image finite.
#[test]
fn huge_poisson_mean() {
    let mut r = pixel_stream(0, 0, PixelPurpose::Photons);
    let limit = rand_distr::Poisson::<f64>::MAX_LAMBDA;
    assert!(limit > 1.8e19 && limit < 1.9e19);
    let below = poisson(&mut r, 1e19) as f64;
    assert!((below - 1e19).abs() < 1e19 * 1e-8, "{below}");
    assert_eq!(poisson(&mut r, limit), limit.round() as u64);
    for mean in [1e20, 1e30, f64::MAX, f64::INFINITY] {
        assert_eq!(poisson(&mut r, mean), u64::MAX, "{mean}");
    }
    for mean in [0.0, -1.0, f64::NEG_INFINITY, f64::NAN] {
        assert_eq!(poisson(&mut r, mean), 0, "{mean}");
    }
    // A magnitude -30 star for 0.01 s: 1.3e19 expected photo-electrons. Before the renderer
    // clamped its count this traced ~1e11 single photons (a hang).
    let (w, fov) = (64u32, 0.00625);
    let (c, star) = star_at_the_centre(w, fov, -30.0);
    let s = fixed_scene(
        &c,
        (10.0, 20.0),
        vec![star],
        -40.0,
        ((5.0, 5.0), (60.0, 10.0)),
        0.01,
    );
    let started = std::time::Instant::now();
    let e = render_scene(&c, &s, 9);
    eprintln!("rendered in {:.1} s", started.elapsed().as_secs_f64());
    all_finite(&e);
    assert_eq!(e.electrons[32 * w as usize + 32], u32::MAX);
    assert!(e.adu.iter().all(|a| a.is_finite()));
    assert!(*e.adu.iter().fold(&0.0f32, |a, b| if b > a { b } else { a }) > 2.0e9);
}
