//! The light-curve table (`artifacts.light_curve`): the debris' brightness over the exposure as
//! rendered, one row per trajectory sample, written as `truth/<image>_light_curve.csv`.
//!
//! Columns: `image` (campaign image index), `object` and `norad` (which debris: a frame with
//! several objects has rows for each), `sample` (0-based), `t_s` (seconds from the start of the
//! exposure to the sample, the centre of its equal time slice), `utc` (that instant, ISO 8601),
//! `magnitude` (Eq. 6 at the sample's geometry with the tumbling modulation of the truth's
//! `tumble`; `inf` when no light is reflected), `electrons_per_s` (Eq. 3's rate, before the
//! Poisson draw), `electrons` (the sample's expected photo-electrons: the rate over its slice;
//! the rendered streak holds a Poisson draw of their sum), `x_px`, `y_px` (0-based pixel
//! position in the original image with the pointing of the sample's time, before jitter and
//! PSF). The renderer's samples, so a fast streak sampled finer than
//! `render.trajectory_samples` has as many rows as it was sampled with.

use hifitime::Duration;
use serde::Serialize;

use crate::render::iso_utc;
use crate::scene::Scene;

#[derive(Serialize)]
struct Row<'a> {
    image: u64,
    object: &'a str,
    norad: u64,
    sample: usize,
    t_s: f64,
    utc: String,
    magnitude: f64,
    electrons_per_s: f64,
    electrons: f64,
    x_px: f64,
    y_px: f64,
}

/// The CSV of the light curves of the objects an image shows (`Scene::shown`, in their order);
/// an image with no object gets the header alone.
pub fn csv(objects: &[&Scene]) -> anyhow::Result<Vec<u8>> {
    let mut w = csv::Writer::from_writer(Vec::new());
    if objects.is_empty() {
        // The header is written with the first row; an empty image has none.
        w.write_record([
            "image",
            "object",
            "norad",
            "sample",
            "t_s",
            "utc",
            "magnitude",
            "electrons_per_s",
            "electrons",
            "x_px",
            "y_px",
        ])?;
    }
    for scene in objects {
        rows(&mut w, scene)?;
    }
    Ok(w.into_inner().map_err(|e| e.into_error())?)
}

fn rows(w: &mut csv::Writer<Vec<u8>>, scene: &Scene) -> anyhow::Result<()> {
    let slice_s = scene.exposure.exposure_s / scene.object.trajectory.len() as f64;
    for (k, s) in scene.object.trajectory.iter().enumerate() {
        w.serialize(Row {
            image: scene.exposure.image_index,
            object: &scene.object.debris_name,
            norad: scene.object.norad,
            sample: k,
            t_s: s.t_s,
            utc: iso_utc(scene.exposure.start + Duration::from_seconds(s.t_s)),
            magnitude: s.mag,
            electrons_per_s: s.expected_electrons / slice_s,
            electrons: s.expected_electrons,
            x_px: s.x_px,
            y_px: s.y_px,
        })?;
    }
    Ok(())
}
