//! Extreme and stiff cases of orbits (issue #6, part 3; the rest in `tests/extremes.rs`): GEO,
//! highly eccentric and near-perigee debris give valid images; decayed, invalid and
//! sub-surface orbits are refused naming the file, line and field (docs/extreme-cases.md).

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use std::path::Path;

use hifitime::{Duration, Epoch};
use soig::campaign::Campaign;
use soig::scene::TrajectorySample;

mod common;
mod extremes_shared;
use common::{ELEMENTS_40649, arg, scratch, tle_file, tle_object};
use extremes_shared::{campaign, campaign_text, draw_and_render, sensor, sensor_of};

// ---------------------------------------------------------------------------------------------
// Orbits: GEO, highly eccentric, near perigee; decayed and invalid TLEs
// ---------------------------------------------------------------------------------------------

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
        let r = s.object.geometry.range_km;
        assert!((28_000.0..50_000.0).contains(&r), "GEO range {r} km");
    }
    // GTO-like: perigee ~220 km, apogee ~14,000 km altitude.
    let gto = campaign(&tle_object(40386), &extra);
    for (s, _) in draw_and_render(&gto, 2) {
        assert!(
            s.object.geometry.range_km < 30_000.0,
            "{}",
            s.object.geometry.range_km
        );
    }
    // Molniya: 12 h, 63.4 deg, perigee 600 km, apogee 39,700 km.
    let molniya = campaign(
        "norad = 90001\nelements = { period_min = 717.7, inclination_deg = 63.4, apogee_km = 39700.0, perigee_km = 600.0, arg_perigee_deg = 270.0 }",
        &extra,
    );
    for (s, _) in draw_and_render(&molniya, 2) {
        assert!(
            s.object.geometry.range_km < 60_000.0,
            "{}",
            s.object.geometry.range_km
        );
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
    let late = c.world.window_end;
    assert!(c.world.debris[0].propagator.position_teme_km(late).is_err());

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
        .world
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
    let deb = &c.world.debris[0].propagator;
    let d0 = deb.position_teme_km(c.world.window_start).unwrap();
    let speed = norm(sub(
        deb.position_teme_km(c.world.window_start + Duration::from_seconds(1.0))
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
        let (first, last) = (
            s.object.trajectory.first().unwrap(),
            s.object.trajectory.last().unwrap(),
        );
        let moved = angle_deg(
            radec_unit(first.ra_deg, first.dec_deg),
            radec_unit(last.ra_deg, last.dec_deg),
        );
        eprintln!(
            "range {:.0} km, {moved:.3} deg in {:.1} s, attempts {}, rejections {:?}, label {:?}",
            s.object.geometry.range_km,
            s.exposure.exposure_s,
            s.attempts,
            s.rejections,
            e.truth.label_box_px
        );
        assert!(s.object.geometry.range_km < 3000.0);
        // Several field widths per exposure: the streak enters and leaves the image.
        assert!(moved > 4.0 * 128.0 * scale, "moved {moved} deg");
        let inside = |p: &TrajectorySample| {
            (-0.5..127.5).contains(&p.x_px) && (-0.5..127.5).contains(&p.y_px)
        };
        assert!(!inside(first) || !inside(last));
    }
}
