//! The helpers `tests/extremes.rs` and `tests/extremes_orbits.rs` share: a small campaign,
//! its sensor, one rendered scene and the checks every valid image passes.

use soig::campaign::Campaign;
use soig::experiment;
use soig::render::{self, Exposure};
use soig::rng::{PixelPurpose, pixel_stream};
use soig::scene::{self, Scene};
use soig::sensor::Sensor;

use crate::common::CampaignToml;

/// A small campaign (128 px at the paper's pixel scale unless `extra` says otherwise) observed
/// from SENTINEL-3A; `debris` is the body of one `[[debris]]` table.
pub fn campaign(debris: &str, extra: &str) -> Campaign {
    extremes(debris, extra).load("extremes.toml")
}

pub fn campaign_text(debris: &str, extra: &str) -> String {
    extremes(debris, extra).text()
}

pub fn extremes(debris: &str, extra: &str) -> CampaignToml {
    CampaignToml::new("extremes", 3, 2)
        .debris(debris)
        .tables(extra)
}

pub fn sensor(width: u32, fov: f64) -> String {
    format!("[sensor]\nwidth_px = {width}\nheight_px = {width}\nfov_radius_deg = {fov}\n")
}

pub fn all_finite(e: &Exposure) {
    assert!(
        e.adu.iter().all(|a| a.is_finite() && *a >= 0.0),
        "non-finite or negative ADU"
    );
    let t = &e.truth;
    for (name, v) in [
        ("range", t.seen.range_km),
        ("phase", t.seen.phase_angle_deg),
        ("magnitude", t.seen.magnitude),
        ("expected debris", t.seen.expected_debris_electrons),
        ("snr", t.seen.snr),
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
pub fn sensor_of(c: &Campaign) -> Sensor {
    experiment::of(c).sensor
}

pub fn render_scene(c: &Campaign, s: &Scene, seed: u64) -> Exposure {
    let x = experiment::of(c);
    render::render(
        &x.sensor,
        &x.render,
        s,
        None,
        &mut pixel_stream(seed, s.exposure.image_index, PixelPurpose::Photons),
        &mut pixel_stream(seed, s.exposure.image_index, PixelPurpose::Noise),
    )
}

/// Draw and render `n` images; every accepted scene is finite and its image valid.
pub fn draw_and_render(c: &Campaign, n: u64) -> Vec<(Scene, Exposure)> {
    let inputs = experiment::inputs(c).unwrap();
    let x = experiment::of(c);
    (0..n)
        .map(|i| {
            let s = scene::draw(&x.scene, &x.sensor, &inputs, c.resolved.seed, i)
                .unwrap_or_else(|e| panic!("{e}"));
            for p in &s.object.trajectory {
                assert!(p.expected_electrons.is_finite() && p.expected_electrons >= 0.0);
                assert!(p.ra_deg.is_finite() && p.dec_deg.is_finite());
            }
            let e = render_scene(c, &s, c.resolved.seed);
            all_finite(&e);
            (s, e)
        })
        .collect()
}
