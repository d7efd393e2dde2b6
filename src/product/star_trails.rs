//! What the star-aware streak detector of `soig run` knows about an image, and where each piece
//! comes from: the scene (its stars from the campaign's own source, procedural sky or catalogue,
//! its pointing over the exposure, its start and length) is drawn again from the campaign seed
//! and image index, the pure function that drew it for rendering, and its final frame
//! (original, padded or rotated) follows from the campaign and that pointing, as it did for
//! rendering. Nothing comes from the truth: the image's mean pointing offset (the jitter's mean,
//! which the FITS WCS includes and a plate solution would measure) is measured on the image
//! itself (`pointing_offset`), by fitting the predicted trails to where its light is.
//! `render::trails` predicts each star's path; here it is carried into the PNG's frame.

use crate::detect::streak::StarTrail;
use crate::geometry::Frame;
use crate::scene::{self, Inputs};
use crate::simulate::Experiment;

/// The offset is looked for within this many pixels of the still pointing's prediction (the
/// paper's jitter, 2e-4 deg per sqrt(s), moves a 5 s exposure's mean by 1-3 px at 0.7"/px),
/// first in whole pixels, then in `FINE_STEP_PX` within a pixel of the best.
const SEARCH_PX: i32 = 8;
const FINE_STEP_PX: f64 = 0.25;
/// The fit reads the `FIT_TRAILS` brightest predicted trails (electrons per pixel of path) of
/// at least `FIT_MIN_PX` pixels inside the image, at most `FIT_SAMPLES` points of each.
const FIT_TRAILS: usize = 24;
const FIT_MIN_PX: usize = 32;
const FIT_SAMPLES: usize = 128;

/// The predicted star trails of image `index` in its PNG (`pixels`, `w` x `h` grey levels),
/// from the campaign's experiment and inputs, moved by the image's mean pointing offset
/// measured on the PNG.
pub fn of_image(
    x: &Experiment,
    inputs: &Inputs,
    index: u64,
    pixels: &[u8],
    w: usize,
    h: usize,
) -> anyhow::Result<Vec<StarTrail>> {
    let scene = scene::draw(&x.scene, &x.sensor, inputs, x.seed, index)
        .map_err(|e| anyhow::anyhow!("image {index}: the scene cannot be drawn again: {e}"))?;
    let frame = x.product.as_ref().map(|p| {
        let angle = scene.exposure.pointing.trail_angle_deg().unwrap_or(0.0);
        Frame::new(
            p.frame,
            x.sensor.width_px,
            x.sensor.height_px,
            p.pad_px,
            angle,
        )
    });
    // Only the part of a trail on the detector: beyond it a frame holds fill, not starlight.
    let (sw, sh) = (x.sensor.width_px as f64, x.sensor.height_px as f64);
    let on_detector = |[x, y]: [f64; 2]| x >= 0.0 && y >= 0.0 && x <= sw - 1.0 && y <= sh - 1.0;
    let trails: Vec<StarTrail> = crate::render::trails::star_trails(&x.sensor, &scene, [0.0, 0.0])
        .iter()
        .filter_map(|t| {
            t.on_image(|n| {
                on_detector(n).then(|| match &frame {
                    Some(f) => f.map(n[0], n[1]),
                    None => (n[0], n[1]),
                })
            })
        })
        .collect();
    let (dx, dy) = pointing_offset(&trails, pixels, w, h);
    Ok(trails
        .into_iter()
        .map(|t| StarTrail {
            nodes: t.nodes.iter().map(|&(x, y)| (x + dx, y + dy)).collect(),
            ..t
        })
        .collect())
}

/// The shift (px, in the image) that puts the predicted `trails` on the image's light: the
/// one, within `SEARCH_PX`, that maximises the sum of grey levels along the brightest trails
/// (a trail's light is highest on its path; a shift across it loses it, and along it the
/// trail's ends). (0, 0) where no trail is bright and long enough to fit.
pub fn pointing_offset(trails: &[StarTrail], pixels: &[u8], w: usize, h: usize) -> (f64, f64) {
    // The bounds converted once, not at each of the fit's million points.
    let (x_max, y_max) = ((w - 1) as f64, (h - 1) as f64);
    let inside = |x: f64, y: f64| x >= 0.0 && y >= 0.0 && x <= x_max && y <= y_max;
    // Each trail's points 1 px apart inside the image.
    let mut bright: Vec<(f64, Vec<(f64, f64)>)> = trails
        .iter()
        .filter(|t| t.nodes.len() >= 2)
        .map(|t| {
            let mut pts = Vec::new();
            for p in t.nodes.windows(2) {
                let (a, b) = (p[0], p[1]);
                let n = (b.0 - a.0).hypot(b.1 - a.1).ceil().max(1.0) as usize;
                for j in 0..n {
                    let f = j as f64 / n as f64;
                    let q = (a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1));
                    if inside(q.0, q.1) {
                        pts.push(q);
                    }
                }
            }
            (t.electrons / (pts.len().max(1) as f64), pts)
        })
        .filter(|(_, pts)| pts.len() >= FIT_MIN_PX)
        .collect();
    bright.sort_by(|a, b| b.0.total_cmp(&a.0));
    let samples: Vec<(f64, f64)> = bright
        .iter()
        .take(FIT_TRAILS)
        .flat_map(|(_, pts)| {
            let stride = (pts.len() / FIT_SAMPLES).max(1);
            pts.iter().step_by(stride).copied().collect::<Vec<_>>()
        })
        .collect();
    if samples.is_empty() {
        return (0.0, 0.0);
    }
    let grey: Vec<f32> = pixels.iter().map(|&v| v as f32).collect();
    // Beyond the image counts as black, so a shift off the frame gains nothing.
    let light = |dx: f64, dy: f64| -> f64 {
        samples
            .iter()
            .map(|&(x, y)| (x + dx, y + dy))
            .filter(|&(x, y)| inside(x, y))
            .map(|(x, y)| soig_image::imaging::bilinear(&grey, w, h, x, y) as f64)
            .sum()
    };
    let best_of = |grid: &mut dyn Iterator<Item = (f64, f64)>| {
        grid.map(|(dx, dy)| (light(dx, dy), dx, dy))
            .fold(
                (f64::NEG_INFINITY, 0.0, 0.0),
                |m, c| if c.0 > m.0 { c } else { m },
            )
    };
    let r = SEARCH_PX;
    let (_, cx, cy) =
        best_of(&mut (-r..=r).flat_map(|dy| (-r..=r).map(move |dx| (dx as f64, dy as f64))));
    let k = (1.0 / FINE_STEP_PX).round() as i32;
    let (_, fx, fy) = best_of(&mut (-k..=k).flat_map(|j| {
        (-k..=k).map(move |i| (cx + i as f64 * FINE_STEP_PX, cy + j as f64 * FINE_STEP_PX))
    }));
    (fx, fy)
}
