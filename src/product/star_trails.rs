//! What the star-aware streak detector of `soig run` knows about an image, and where each piece
//! comes from: the scene (its stars from the campaign's own source, procedural sky or catalogue,
//! its pointing over the exposure, its start and length) is drawn again from the campaign seed
//! and image index, the pure function that drew it for rendering; the truth sidecar gives the
//! image's mean jitter shift (which the FITS WCS includes) and its final frame (original,
//! padded or rotated). `render::trails` predicts each star's path from them; here it is carried
//! into the PNG's frame.

use std::path::Path;

use anyhow::Context;

use crate::detect::streak::StarTrail;
use crate::geometry::Frame;
use crate::scene::{self, Inputs};
use crate::simulate::Experiment;

/// The predicted star trails of image `index` in its PNG, from the campaign's experiment and
/// inputs and the image's truth sidecar `truth`.
pub fn of_image(
    x: &Experiment,
    inputs: &Inputs,
    index: u64,
    truth: &Path,
) -> anyhow::Result<Vec<StarTrail>> {
    #[derive(serde::Deserialize)]
    struct Sidecar {
        jitter_mean_px: [f64; 2],
        frame: Option<Frame>,
    }
    let text =
        std::fs::read_to_string(truth).with_context(|| format!("reading {}", truth.display()))?;
    let s: Sidecar = serde_json::from_str(&text)
        .with_context(|| format!("{}: not a soig truth sidecar", truth.display()))?;
    let scene = scene::draw(&x.scene, &x.sensor, inputs, x.seed, index).map_err(|e| {
        anyhow::anyhow!("{}: the scene cannot be drawn again: {e}", truth.display())
    })?;
    // Only the part of a trail on the detector: beyond it a frame holds fill, not starlight.
    let (w, h) = (x.sensor.width_px as f64, x.sensor.height_px as f64);
    let on_detector =
        |n: &&[f64; 2]| n[0] >= 0.0 && n[1] >= 0.0 && n[0] <= w - 1.0 && n[1] <= h - 1.0;
    let trails = crate::render::trails::star_trails(&x.sensor, &scene, s.jitter_mean_px);
    Ok(trails
        .iter()
        .filter(|t| t.nodes.iter().any(|n| on_detector(&n)))
        .map(|t| {
            let (nodes, times_s) = t
                .nodes
                .iter()
                .zip(&t.times_s)
                .filter(|(n, _)| on_detector(n))
                .map(|(&[px, py], &time)| {
                    let at = match &s.frame {
                        Some(f) => f.map(px, py),
                        None => (px, py),
                    };
                    (at, time)
                })
                .unzip();
            StarTrail {
                nodes,
                times_s,
                electrons: t.expected_electrons,
            }
        })
        .collect())
}
