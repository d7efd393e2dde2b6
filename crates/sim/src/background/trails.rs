//! Star trails of a science frame, faint lines and arcs included: a matched filter along many
//! orientations (the mean along a short line through each pixel, the best orientation kept),
//! hysteresis on its significance, and only elongated structure kept (a line, or an arc: low
//! fill of its moment ellipse), grown by the PSF's width.
//!
//! The box-smoothed mask of `prepare` finds a trail as a blob; the raw 187 s science frame's
//! faintest arcs (~0.1 sigma per pixel, README) stay under it, while a line filter averages
//! along the trail and shows them.

use super::mask::{clipped_about, components, grow};

/// Pixels are clipped to this many (lower-side) sigma before filtering, as in `prepare`: a hot
/// pixel then weighs no more than a trail pixel, and a bright trail no more than a faint one.
const CLIP_SIGMA: f64 = 1.0;
/// The frame is binned 2 x 2 first: a trail 2-4 px wide fills a binned pixel's width, and the
/// filter costs a quarter.
const BIN: usize = 2;
/// Length of the filter's line, binned pixels (42 px of the frame): along it the noise drops
/// ~sqrt(21 * 4) = 9x. An arc of radius 150 px leaves a 42 px chord by L^2/8R = 1.5 px, within
/// a binned pixel, so arcs are followed as well as lines.
const LINE_BINNED_PX: isize = 21;
/// Orientations over 180 degrees: 7.5 degrees apart, so a trail is at most 3.75 degrees off
/// one of them, 0.7 binned px at the line's ends: inside the trail's width.
const ANGLES: usize = 24;
/// A trail holds a pixel of the filtered map this many sigma above its median (a seed); it is
/// followed through pixels above `FOLLOW_SIGMA`. Sigma is the map's lower-side spread (median
/// minus 15.87th percentile), which the trails (all positive) do not widen: in the calibrated
/// frame they cover so much that a symmetric robust sigma doubles. On the science frame 5 and
/// 2.5 find every arc seen by eye in the map and mask ~5% of the frame; 4 and 2 mask ~6%,
/// mostly spurs of noise along the same arcs.
const SEED_SIGMA: f64 = 5.0;
const FOLLOW_SIGMA: f64 = 2.5;
/// Components smaller than this (binned px) are noise or stars, left to the pixel mask.
const MIN_BINNED_PX: usize = 10;
/// A component is a trail when its moment ellipse is this elongated (axis ratio) ...
const MIN_ELONGATION: f64 = 3.0;
/// ... or an arc: its pixels fill less than this share of the ellipse of twice its moments'
/// axes (a filled ellipse fills 1, a thin arc of a quarter circle ~0.1).
const MAX_ARC_FILL: f64 = 0.3;
/// The trail mask grows by this many pixels: the PSF's wings (sigma ~1.5 px) beyond the
/// binned pixels that passed `FOLLOW_SIGMA`.
const GROW_PX: usize = 2;

/// Seed and follow thresholds of the rounds after the first (see [`Rounds`]): once the
/// brighter trails are filled, the fainter ones they hid are followed at a lower level. On the
/// calibrated frame, whose arcs overlap densely, 5 and 2.5 in every round leave an arc texture
/// at 20 degrees (tiled Radon z 5.7-7.0, tests/semisynthetic.rs); 4 and 2 take it to 4.5-5.4,
/// and the raw science frame from 4.2-5.5 to 4.0-4.5.
const LATER_SEED_SIGMA: f64 = 4.0;
const LATER_FOLLOW_SIGMA: f64 = 2.0;

/// Which round of masking: the first looks at the frame as it is, a later one at the frame
/// with the trails found so far filled.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rounds {
    First,
    Later,
}

/// The pixels of a flattened `width` x `height` frame on star trails (lines or arcs).
pub fn trail_mask(pixels: &[f32], width: usize, height: usize, round: Rounds) -> Vec<bool> {
    let (seed_sigma, follow_sigma) = match round {
        Rounds::First => (SEED_SIGMA, FOLLOW_SIGMA),
        Rounds::Later => (LATER_SEED_SIGMA, LATER_FOLLOW_SIGMA),
    };
    let (wb, hb) = (width / BIN, height / BIN);
    if wb < LINE_BINNED_PX as usize || hb < LINE_BINNED_PX as usize {
        return vec![false; pixels.len()];
    }
    let (median, sigma) = lower_side(pixels);
    let clip = CLIP_SIGMA * sigma;
    let mut binned = vec![0.0f32; wb * hb];
    for y in 0..hb * BIN {
        for x in 0..wb * BIN {
            let c = clipped_about(pixels[y * width + x], median, clip);
            binned[(y / BIN) * wb + x / BIN] += (c / (BIN * BIN) as f64) as f32;
        }
    }
    let response = line_response(&binned, wb, hb);
    let (r_median, r_sigma) = lower_side(&response);
    let z: Vec<f32> = response
        .iter()
        .map(|&r| ((r as f64 - r_median) / r_sigma) as f32)
        .collect();
    let mut trails = vec![false; wb * hb];
    for component in components(&z, wb, hb, follow_sigma as f32) {
        let seeded = component.iter().any(|&i| z[i] as f64 >= seed_sigma);
        if seeded && component.len() >= MIN_BINNED_PX && elongated(&component, wb) {
            for i in component {
                trails[i] = true;
            }
        }
    }
    let full: Vec<bool> = (0..pixels.len())
        .map(|i| {
            let (x, y) = (i % width / BIN, i / width / BIN);
            x < wb && y < hb && trails[y * wb + x]
        })
        .collect();
    grow(&full, width, height, GROW_PX)
}

/// Median and lower-side sigma (median minus the 15.87th percentile) of the finite values.
fn lower_side(v: &[f32]) -> (f64, f64) {
    let mut s: Vec<f32> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if s.is_empty() {
        return (0.0, 1.0);
    }
    s.sort_by(f32::total_cmp);
    let at = |q: f64| s[((s.len() - 1) as f64 * q).round() as usize] as f64;
    let median = at(0.5);
    let sigma = median - at(0.1587);
    (median, if sigma > 0.0 { sigma } else { 1.0 })
}

/// For each pixel, the largest mean over `ANGLES` lines of `LINE_BINNED_PX` pixels centred on
/// it (pixels outside the frame left out of the mean).
fn line_response(v: &[f32], width: usize, height: usize) -> Vec<f32> {
    let half = LINE_BINNED_PX / 2;
    let mut best = vec![f32::NEG_INFINITY; v.len()];
    for k in 0..ANGLES {
        let angle = std::f64::consts::PI * k as f64 / ANGLES as f64;
        let steps: Vec<(isize, isize)> = (-half..=half)
            .map(|s| {
                let s = s as f64;
                (
                    (s * angle.cos()).round() as isize,
                    (s * angle.sin()).round() as isize,
                )
            })
            .collect();
        for y in 0..height as isize {
            for x in 0..width as isize {
                let (mut sum, mut n) = (0.0f32, 0u32);
                for &(dx, dy) in &steps {
                    let (u, w) = (x + dx, y + dy);
                    if u >= 0 && w >= 0 && (u as usize) < width && (w as usize) < height {
                        sum += v[w as usize * width + u as usize];
                        n += 1;
                    }
                }
                let i = y as usize * width + x as usize;
                best[i] = best[i].max(sum / n as f32);
            }
        }
    }
    best
}

/// Whether a component (pixel indices of a `width`-wide map) is a line or an arc.
fn elongated(component: &[usize], width: usize) -> bool {
    let n = component.len() as f64;
    let xy = |i: usize| ((i % width) as f64, (i / width) as f64);
    let (mx, my) = component.iter().fold((0.0, 0.0), |(a, b), &i| {
        let (x, y) = xy(i);
        (a + x / n, b + y / n)
    });
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for &i in component {
        let (x, y) = xy(i);
        sxx += (x - mx).powi(2) / n;
        syy += (y - my).powi(2) / n;
        sxy += (x - mx) * (y - my) / n;
    }
    let mean = (sxx + syy) / 2.0;
    let spread = (((sxx - syy) / 2.0).powi(2) + sxy * sxy).sqrt();
    // A one-pixel-wide line has a minor variance of 0; a pixel's own is 1/12.
    let (major, minor) = (mean + spread, (mean - spread).max(1.0 / 12.0));
    let fill = n / (std::f64::consts::PI * 4.0 * (major * minor).sqrt());
    (major / minor).sqrt() >= MIN_ELONGATION || fill < MAX_ARC_FILL
}

#[cfg(test)]
mod tests {
    use super::*;
    use soig_base::rng::{PixelPurpose, pixel_stream};

    /// A 512 x 512 frame of unit Gaussian noise plus `amplitude` on the pixels of `arc`.
    fn noisy(arc: impl Fn(usize, usize) -> bool, amplitude: f32) -> Vec<f32> {
        let (w, h) = (512, 512);
        let mut rng = pixel_stream(3, 0, PixelPurpose::Noise);
        let normal = rand_distr::Normal::new(0.0f32, 1.0).unwrap();
        (0..w * h)
            .map(|i| {
                let n = rand_distr::Distribution::sample(&normal, &mut rng);
                n + if arc(i % w, i / w) { amplitude } else { 0.0 }
            })
            .collect()
    }

    fn on_arc(x: usize, y: usize) -> bool {
        let r = ((x as f64 + 100.0).powi(2) + (y as f64 + 100.0).powi(2)).sqrt();
        (r - 400.0).abs() < 1.5
    }

    /// An arc 3 px wide at 0.7 sigma per pixel: 1% of its pixels pass a 3-sigma cut.
    #[test]
    fn a_faint_arc_is_masked_and_noise_is_not() {
        let (w, h) = (512, 512);
        let px = noisy(on_arc, 0.7);
        let mask = trail_mask(&px, w, h, Rounds::First);
        let arc: Vec<usize> = (0..w * h).filter(|&i| on_arc(i % w, i / w)).collect();
        let hit = arc.iter().filter(|&&i| mask[i]).count();
        // The arc's ends (within a half line of the edge) and short gaps where the noise
        // dips may be missed: 80% of its length is found.
        assert!(hit * 10 >= arc.len() * 8, "{hit} of {}", arc.len());
        // The grown arc is ~1.6% of the frame; noise alone must add little.
        let share = mask.iter().filter(|&&m| m).count() as f64 / mask.len() as f64;
        assert!(share < 0.03, "{share}");
        // Pure noise: a few chance alignments of its tail pass (0.53% of this frame, measured),
        // not a share that would take texture out of a frame.
        let clean = noisy(|_, _| false, 0.0);
        let share = trail_mask(&clean, w, h, Rounds::First)
            .iter()
            .filter(|&&m| m)
            .count();
        assert!(share * 100 < w * h, "{share}");
    }
}
