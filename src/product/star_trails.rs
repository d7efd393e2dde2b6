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
    // The bounds converted once, not at each trail point.
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
    // Beyond the image counts as black, so a shift off the frame gains nothing.
    let r = SEARCH_PX;
    let whole: Vec<f64> = (-r..=r).map(|d| d as f64).collect();
    let (cx, cy) = best_shift(&samples, pixels, w, h, &whole, &whole);
    let k = (1.0 / FINE_STEP_PX).round() as i32;
    let fine = |c: f64| -> Vec<f64> { (-k..=k).map(|i| c + i as f64 * FINE_STEP_PX).collect() };
    best_shift(&samples, pixels, w, h, &fine(cx), &fine(cy))
}

/// Where a sample lands along one axis under one shift: the pixel (column, or row start) at
/// and after it and the fraction between them, as `imaging::bilinear` finds them; `None` off
/// the image.
type Axis = Option<(usize, usize, f32)>;

/// Each sample's `Axis` for each shift in `offsets` (shift-major): `coord` shifted, within
/// `0..=max`, its pixel and the next (the last pixel's next is itself) times `stride`.
fn axis(
    coords: impl Iterator<Item = f64> + Clone,
    offsets: &[f64],
    max: usize,
    stride: usize,
) -> Vec<Axis> {
    let top = max as i64 as f64;
    offsets
        .iter()
        .flat_map(|&d| {
            coords.clone().map(move |c| {
                let v = c + d;
                (v >= 0.0 && v <= top).then(|| {
                    let vi = v as i64;
                    let i = vi as usize;
                    (
                        i * stride,
                        (i + 1).min(max) * stride,
                        (v - vi as f64) as f32,
                    )
                })
            })
        })
        .collect()
}

/// The shift of the grid `xs` x `ys` (rows `ys`, each over `xs`; the first of equals) with
/// the most light under the shifted `samples`: the sum, in the samples' order, of the image's
/// grey levels interpolated as `imaging::bilinear` does, over the shifted samples inside the
/// image. Each sample's pixels and fractions are found once per shift along each axis, not at
/// each of the grid's points (the same values).
fn best_shift(
    samples: &[(f64, f64)],
    pixels: &[u8],
    w: usize,
    h: usize,
    xs: &[f64],
    ys: &[f64],
) -> (f64, f64) {
    let n = samples.len();
    let cols = axis(samples.iter().map(|s| s.0), xs, w - 1, 1);
    let rows = axis(samples.iter().map(|s| s.1), ys, h - 1, w);
    let at = |k: usize| pixels[k] as f32;
    let light = |a: usize, b: usize| -> f64 {
        cols[a * n..(a + 1) * n]
            .iter()
            .zip(&rows[b * n..(b + 1) * n])
            .filter_map(|(c, r)| {
                let ((i, i1, fx), (j, j1, fy)) = ((*c)?, (*r)?);
                let top = at(j + i) * (1.0 - fx) + at(j + i1) * fx;
                let bottom = at(j1 + i) * (1.0 - fx) + at(j1 + i1) * fx;
                Some((top * (1.0 - fy) + bottom * fy) as f64)
            })
            .sum()
    };
    let mut best = (f64::NEG_INFINITY, 0.0, 0.0);
    for (b, &dy) in ys.iter().enumerate() {
        for (a, &dx) in xs.iter().enumerate() {
            let l = light(a, b);
            if l > best.0 {
                best = (l, dx, dy);
            }
        }
    }
    (best.1, best.2)
}

#[cfg(test)]
mod tests {
    use super::best_shift;

    /// `best_shift` reads pixels and fractions as `imaging::bilinear` does, by a copy of its
    /// arithmetic (for speed): it must find the shift the plain search finds, bilinear over an
    /// f32 copy at every grid point, the first of equal maxima, rows outer. (Checked to fail
    /// with one pixel of the interpolation read from the wrong row.)
    #[test]
    fn best_shift_finds_the_plain_search_s_shift() {
        let (w, h) = (61usize, 47usize);
        let mut state = 12345u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) as u32
        };
        let whole: Vec<f64> = (-8..=8).map(|d| d as f64).collect();
        let fine: Vec<f64> = (-4..=4).map(|i| 3.0 + i as f64 * 0.25).collect();
        for _ in 0..20 {
            let pixels: Vec<u8> = (0..w * h).map(|_| (next() % 256) as u8).collect();
            let samples: Vec<(f64, f64)> = (0..40)
                .map(|_| {
                    let x = (next() % 6000) as f64 / 100.0;
                    (x, (next() % 4600) as f64 / 100.0)
                })
                .collect();
            let grey: Vec<f32> = pixels.iter().map(|&v| v as f32).collect();
            let (xm, ym) = ((w - 1) as f64, (h - 1) as f64);
            let plain = |xs: &[f64], ys: &[f64]| {
                let mut best = (f64::NEG_INFINITY, 0.0, 0.0);
                for &dy in ys {
                    for &dx in xs {
                        let l: f64 = samples
                            .iter()
                            .map(|&(x, y)| (x + dx, y + dy))
                            .filter(|&(x, y)| x >= 0.0 && y >= 0.0 && x <= xm && y <= ym)
                            .map(|(x, y)| soig_image::imaging::bilinear(&grey, w, h, x, y) as f64)
                            .sum();
                        if l > best.0 {
                            best = (l, dx, dy);
                        }
                    }
                }
                (best.1, best.2)
            };
            for (xs, ys) in [(&whole, &whole), (&fine, &whole), (&whole, &fine)] {
                assert_eq!(best_shift(&samples, &pixels, w, h, xs, ys), plain(xs, ys));
            }
        }
    }
}
