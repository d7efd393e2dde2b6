//! The air over a ground site in the rendered campaign (issue #46): the seeing the truth
//! records follows the zenith FWHM times the boresight's airmass^0.6; scintillation multiplies
//! each object's flux by a factor drawn from its own stream (the scenes otherwise the same)
//! whose spread is the formula's sigma; the sky toward the boresight (dark sky, twilight, the
//! Moon) becomes the physical noise model's sky of each image; out-of-range values are refused
//! naming the field.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use soig::atmosphere::scintillation_variance;
use soig::campaign::Campaign;
use soig::experiment;
use soig_sim::observer::GroundGate;

mod common;
use common::{CampaignToml, assert_refused, rendered, run_quiet, tle_object};

/// Siding Spring, tracking the stars on two LEO objects in late January 2022, 256 px images,
/// with the site's further keys `air` (each starting with a comma).
fn campaign_toml(air: &str, images: u32) -> CampaignToml {
    CampaignToml::new("ground-air", 20220122, images)
        .observer(&format!(
            "name = \"Siding Spring\"\nsite = {{ lat_deg = -31.2733, lon_deg = 149.0644, height_m = 1165.0{air} }}"
        ))
        .debris(&tle_object(37476))
        .debris(&tle_object(41335))
        .tables(
            "[window]\nstart = \"2022-01-22T00:00:00 UTC\"\nend = \"2022-01-26T00:00:00 UTC\"\n\
             [sensor]\nwidth_px = 256\nheight_px = 256\n[pointing]\nmode = \"fixed\"\n",
        )
}

fn campaign(air: &str, images: u32) -> Campaign {
    campaign_toml(air, images).load("ground-air.toml")
}

/// A physical detector: 0.5 e-/s dark, 5 e- read noise, a 21.5 mag/arcsec^2 sky of its own.
const PHYSICAL: &str = "[noise]\nmodel = \"physical\"\nsky_mag_per_arcsec2 = 21.5\ndark_e_per_s = 0.5\nread_noise_e = 5.0\n";

/// tests/reference/moon_sky_reference.py (astropy `get_body('moon')`, `get_sun` from Siding
/// Spring): (UTC, boresight RA, Dec) -> (Moon zenith distance, Sun altitude, boresight-Moon
/// separation, Moon phase angle), degrees.
const MOON_REFERENCE: [(&str, f64, f64, f64, f64, f64, f64); 4] = [
    (
        "2022-01-22T12:00:00",
        120.0,
        -40.0,
        90.7959,
        -29.6442,
        70.6078,
        52.7263,
    ),
    (
        "2022-01-23T14:30:00",
        200.0,
        -20.0,
        65.8705,
        -39.2521,
        22.7237,
        65.8877,
    ),
    (
        "2022-01-18T13:00:00",
        110.0,
        20.0,
        61.0650,
        -35.2789,
        17.3494,
        8.2607,
    ),
    (
        "2022-01-25T16:00:00",
        250.0,
        -60.0,
        60.1346,
        -34.0079,
        54.7737,
        91.6487,
    ),
];

/// The campaign of `images` with a physical sky (extinction 0.15 mag per airmass, zenith sky
/// V 21.7 mag/arcsec^2, `PHYSICAL`'s tables) and its ground gate.
fn physical_sky(images: u32) -> (Campaign, GroundGate) {
    let sky = ", extinction_mag_per_airmass = 0.15, sky = { zenith_v_mag_per_arcsec2 = 21.7 }";
    let c = campaign_toml(sky, images)
        .tables(PHYSICAL)
        .load("ground-air.toml");
    let gate = experiment::of(&c)
        .scene
        .ground
        .clone()
        .expect("a ground gate");
    (c, gate)
}

#[test]
fn the_sky_models_moon_and_sun_are_astropys() {
    let (_, gate) = physical_sky(1);
    for (utc, ra, dec, moon_z, sun_alt, sep, phase) in MOON_REFERENCE {
        let t: hifitime::Epoch = format!("{utc} UTC").parse().unwrap();
        let (_, g) = gate.sky(t, soig::sky::radec_unit(ra, dec)).unwrap();
        // The Moon's ephemeris is astropy's to 20 arcsec (sky::ephemeris), the site's place
        // and UT1 = UTC add under 1 arcsec; 1 arcmin bounds every angle with room (measured:
        // see the message).
        for (ours, theirs, what) in [
            (g.moon_z_deg, moon_z, "Moon zenith distance"),
            (g.sun_alt_deg, sun_alt, "Sun altitude"),
            (g.moon_sep_deg, sep, "Moon separation"),
            (g.moon_phase_deg, phase, "Moon phase angle"),
        ] {
            assert!(
                (ours - theirs).abs() < 1.0 / 60.0,
                "{utc} {what}: {ours} vs astropy {theirs} ({:.2} arcmin)",
                (ours - theirs) * 60.0
            );
        }
    }
}

#[test]
fn the_sky_of_each_image_is_the_sites_toward_its_boresight() {
    let (c, gate) = physical_sky(3);
    let sensor = experiment::of(&c).sensor;
    for image in rendered(&c, 3) {
        let t = &image.exposure.truth;
        let v = t.sky_v_mag_per_arcsec2.expect("the sky in the truth");
        // The site's model at the boresight and mid-exposure, as the scene drew it.
        let mid = image.scene.exposure.start + hifitime::Duration::from_seconds(t.exposure_s / 2.0);
        let (ra, dec) = image.scene.exposure.pointing.mid_radec_deg();
        let (again, g) = gate.sky(mid, soig::sky::radec_unit(ra, dec)).unwrap();
        assert_eq!(v, again);
        // A night sky: the Sun below the night's -12 deg, and K&S's sky no darker than the
        // dark zenith's 21.7 (nor brighter than a full Moon's ~17).
        assert!(g.sun_alt_deg <= -12.0, "{g:?}");
        assert!(v <= 21.7 + 1e-9 && v > 16.0, "{v} {g:?}");
        // The detector's noise is that sky's: sigma^2 = (sky + dark) t + read^2, over gain.
        let scale = sensor.pixel_scale_deg() * 3600.0;
        let sky_e = soig::noise::sky_e_per_s(v, sensor.zero_point_mag, scale);
        let sigma = ((sky_e + 0.5) * t.exposure_s + 25.0).sqrt() / sensor.gain_e_per_adu;
        assert!((t.background_sigma_adu - sigma).abs() < 1e-9 * sigma);
    }
}

const SEEING: &str = ", seeing = { fwhm_arcsec = 1.5, beta = 3.0 }";

#[test]
fn the_truth_records_the_seeing_of_the_boresights_airmass() {
    let c = campaign(SEEING, 2);
    for image in rendered(&c, 2) {
        let s = image.exposure.truth.seeing.expect("seeing in the truth");
        assert_eq!(s.beta, 3.0);
        assert!(s.airmass >= 1.0 && s.airmass < 3.0, "{}", s.airmass);
        assert!((s.fwhm_arcsec - 1.5 * s.airmass.powf(0.6)).abs() < 1e-12);
        assert!(image.exposure.truth.scintillation.is_none());
    }
    // Without `seeing` nothing is recorded and the campaign's hash is the plain site's.
    let plain = campaign("", 1);
    assert!(rendered(&plain, 1)[0].exposure.truth.seeing.is_none());
    let json = serde_json::to_value(&plain.resolved).unwrap();
    assert!(json["observer"]["site"].get("seeing").is_none(), "{json}");
}

#[test]
fn scintillation_scales_each_objects_flux_by_a_factor_of_the_formulas_spread() {
    let n = 120;
    let off = campaign(SEEING, n);
    let on = campaign(
        &format!("{SEEING}, scintillation = {{ aperture_m = 0.1, c_y = 1.5 }}"),
        n,
    );
    let (x_off, x_on) = (experiment::of(&off), experiment::of(&on));
    let (in_off, in_on) = (
        experiment::inputs(&off).unwrap(),
        experiment::inputs(&on).unwrap(),
    );
    let mut z = Vec::new();
    for i in 0..u64::from(n) {
        let a = soig::scene::draw(&x_off.scene, &x_off.sensor, &in_off, x_off.seed, i).unwrap();
        let b = soig::scene::draw(&x_on.scene, &x_on.sensor, &in_on, x_on.seed, i).unwrap();
        // The same scene: scintillation draws from a stream of its own.
        assert_eq!(
            (a.object.debris_index, a.exposure.start),
            (b.object.debris_index, b.exposure.start)
        );
        assert!(a.scintillation.is_none());
        let s = b.scintillation.expect("scintillated");
        // The object's flux, every trajectory sample, times the factor.
        for (p, q) in a.object.trajectory.iter().zip(&b.object.trajectory) {
            assert!(
                (q.expected_electrons - p.expected_electrons * s.factor).abs()
                    <= 1e-12 * p.expected_electrons
            );
        }
        // Sigma is the formula's at the object's airmass, this exposure and the site's height.
        let v = scintillation_variance(1.5, 0.1, s.airmass, 1165.0, b.exposure.exposure_s);
        assert!(
            (s.sigma - v.sqrt()).abs() < 1e-15,
            "{} vs {}",
            s.sigma,
            v.sqrt()
        );
        assert!(s.sigma > 0.005 && s.sigma < 0.2, "{}", s.sigma);
        // ln(factor) is normal of mean -s^2/2 and deviation s, s^2 = ln(1 + sigma^2).
        let s2 = s.sigma.powi(2).ln_1p();
        z.push((s.factor.ln() + s2 / 2.0) / s2.sqrt());
    }
    let m = z.iter().sum::<f64>() / z.len() as f64;
    let sd = (z.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (z.len() - 1) as f64).sqrt();
    eprintln!("scintillation z over {n} images: mean {m:.3}, sd {sd:.3}");
    // 120 standard normal draws: the mean's standard error is 0.091 and the deviation's
    // 0.065; four of each bound a right draw and catch a factor twice or half the formula's.
    assert!(m.abs() < 4.0 * 0.091, "mean z {m}");
    assert!((sd - 1.0).abs() < 4.0 * 0.065, "sd z {sd}");
}

#[test]
fn air_out_of_range_is_refused_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    for (air, field) in [
        (
            ", seeing = { fwhm_arcsec = -1.0 }",
            "observer.site.seeing.fwhm_arcsec",
        ),
        (
            ", seeing = { fwhm_arcsec = 1.0, beta = 1.0 }",
            "observer.site.seeing.beta",
        ),
        (
            ", scintillation = { aperture_m = 0.0 }",
            "observer.site.scintillation.aperture_m",
        ),
        (
            ", scintillation = { aperture_m = 1.0, c_y = nan }",
            "observer.site.scintillation.c_y",
        ),
        (
            ", sky = { zenith_v_mag_per_arcsec2 = 30.0 }",
            "observer.site.sky.zenith_v_mag_per_arcsec2",
        ),
        // The paper's noise has no sky in magnitudes to replace.
        (
            ", sky = { zenith_v_mag_per_arcsec2 = 21.7 }",
            "needs the physical noise model",
        ),
    ] {
        let path = campaign_toml(air, 1).write(&dir.path().join("air.toml"));
        let o = run_quiet(&path, &dir.path().join("out"));
        assert_refused(&o, field);
    }
}

/// The two ground sensor presets (campaigns/base/ground-*.toml): their published field and
/// pixel count give the pixel scale, their aperture the scintillation's, their place the site.
#[test]
fn ground_presets_carry_their_published_figures() {
    let dir = tempfile::tempdir().unwrap();
    // Each with an object it can see in the window: the near-GEO MSG 4 cover from Tenerife in
    // January, SENTINEL 3A (LEO, sunlit in the short nights) from Korla in June.
    for (base, pixel_arcsec, aperture_m, lat, norad, month) in [
        (
            "ground-ogs-1m.toml",
            0.7 * 3600.0 / 4096.0,
            1.0,
            28.30096,
            40989,
            "01",
        ),
        (
            "ground-survey-36cm.toml",
            2.6 * 3600.0 / 4096.0,
            0.355,
            41.76,
            41335,
            "06",
        ),
    ] {
        let text = format!(
            "extends = \"{}\"\nname = \"preset\"\nseed = 1\nimages = 1\n[[debris]]\n{}\n\
             [window]\nstart = \"2022-{month}-22T00:00:00 UTC\"\nend = \"2022-{month}-26T00:00:00 UTC\"\n",
            common::repo(&format!("campaigns/base/{base}")).display(),
            tle_object(norad)
        );
        let path = dir.path().join("preset.toml");
        std::fs::write(&path, text).unwrap();
        let c = Campaign::load(&path).unwrap_or_else(|e| panic!("{base}: {e}"));
        let x = experiment::of(&c);
        let scale = x.sensor.pixel_scale_deg() * 3600.0;
        assert!((scale - pixel_arcsec).abs() < 1e-9, "{base}: {scale}");
        let gate = x.scene.ground.expect("a ground site");
        assert_eq!(gate.site.lat_deg, lat);
        assert_eq!(gate.scintillation.map(|s| s.1), Some(aperture_m));
    }
}
