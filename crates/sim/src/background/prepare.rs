//! From a raw or calibrated frame to a noise field: trim the prescan/overscan, remove the
//! large-scale structure, and replace the pixels of sources and star trails by clean pixels of
//! the same neighbourhood.

use rand::RngExt;
use soig_base::rng::{PixelPurpose, pixel_stream};
use soig_image::imaging::{box_mean, robust_stats};

use super::mask::{clipped_about, components, grow};
use super::trails::{Rounds, trail_mask};

/// A rectangle of a frame, 0-based, end-exclusive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    pub x0: usize,
    pub x1: usize,
    pub y0: usize,
    pub y1: usize,
}

impl Region {
    /// A FITS section such as `[17:1088,1:1030]` (1-based, inclusive, x first) inside a
    /// `width` x `height` frame; None when it does not parse or does not fit.
    pub fn from_fits_section(text: &str, width: usize, height: usize) -> Option<Region> {
        let inner = text.trim().strip_prefix('[')?.strip_suffix(']')?;
        let (x, y) = inner.split_once(',')?;
        let range = |s: &str| -> Option<(usize, usize)> {
            let (a, b) = s.trim().split_once(':')?;
            Some((a.trim().parse().ok()?, b.trim().parse().ok()?))
        };
        let ((x1, x2), (y1, y2)) = (range(x)?, range(y)?);
        (1 <= x1 && x1 <= x2 && x2 <= width && 1 <= y1 && y1 <= y2 && y2 <= height).then_some(
            Region {
                x0: x1 - 1,
                x1: x2,
                y0: y1 - 1,
                y1: y2,
            },
        )
    }

    pub fn width(&self) -> usize {
        self.x1 - self.x0
    }

    pub fn height(&self) -> usize {
        self.y1 - self.y0
    }

    /// The pixels of this region of a `width`-wide frame.
    pub fn crop(&self, pixels: &[f32], width: usize) -> Vec<f32> {
        (self.y0..self.y1)
            .flat_map(|y| {
                pixels[y * width + self.x0..y * width + self.x1]
                    .iter()
                    .copied()
            })
            .collect()
    }
}

/// Edge columns searched for overscan-like steps, at most, per side; the sky's trend is
/// fitted on the next two bands of this width.
const EDGE_SEARCH_COLS: usize = 64;
/// A column is not sky when its median is this many column-to-column noise units from the
/// sky's linear trend, extrapolated from the columns just inside the search band; the walk
/// from the edge stops at the first sky column. The dark frame's shadowed columns sit 4.3-36
/// units off, the outermost sky columns of the three NEOSSat frames within 2.8 (measured with
/// the fit below; see the frame tests).
const EDGE_STEP_SIGMA: f64 = 4.0;

/// Columns at the left and right edges whose level steps away from the sky's: prescan,
/// overscan and shadowed columns that a frame's `TRIMSEC` leaves in. Found from column
/// medians against the sky's linear trend (so a gradient is not a step); a frame narrower
/// than `6 * EDGE_SEARCH_COLS` is not searched.
pub fn edge_columns(pixels: &[f32], width: usize, height: usize) -> (usize, usize) {
    if width < 6 * EDGE_SEARCH_COLS {
        return (0, 0);
    }
    let medians: Vec<f64> = (0..width)
        .map(|x| {
            let col: Vec<f32> = (0..height).map(|y| pixels[y * width + x]).collect();
            robust_stats(&col).0
        })
        .collect();
    // Column-to-column noise of the medians, robust to a smooth gradient.
    let steps: Vec<f32> = medians.windows(2).map(|w| (w[1] - w[0]) as f32).collect();
    let noise = robust_stats(&steps).1 / std::f64::consts::SQRT_2;
    if !(noise.is_finite() && noise > 0.0) {
        return (0, 0);
    }
    // Counted from the edge inwards: `column(d)` is the median d columns in from the edge.
    let side = |column: &dyn Fn(usize) -> f64| {
        let (a, b) = (EDGE_SEARCH_COLS, 3 * EDGE_SEARCH_COLS);
        let n = (b - a) as f64;
        let mean_d = (a + b - 1) as f64 / 2.0;
        let mean_m = (a..b).map(column).sum::<f64>() / n;
        let slope = (a..b)
            .map(|d| (d as f64 - mean_d) * (column(d) - mean_m))
            .sum::<f64>()
            / (a..b).map(|d| (d as f64 - mean_d).powi(2)).sum::<f64>();
        (0..EDGE_SEARCH_COLS)
            .take_while(|&d| {
                let trend = mean_m + slope * (d as f64 - mean_d);
                (column(d) - trend).abs() > EDGE_STEP_SIGMA * noise
            })
            .count()
    };
    (side(&|d| medians[d]), side(&|d| medians[width - 1 - d]))
}

/// Cell size of the large-scale structure removed from a frame, pixels.
const FLAT_CELL_PX: usize = 32;

/// Subtract the large-scale structure of a frame (the median of each cell, bilinearly
/// interpolated between cell centres) and add back the overall median: a flat frame's blocks
/// join without a level step.
pub fn flatten(pixels: &mut [f32], width: usize, height: usize) {
    let (nx, ny) = (width.div_ceil(FLAT_CELL_PX), height.div_ceil(FLAT_CELL_PX));
    let mut cells = vec![0.0f64; nx * ny];
    for cy in 0..ny {
        for cx in 0..nx {
            let mut v: Vec<f32> = Vec::with_capacity(FLAT_CELL_PX * FLAT_CELL_PX);
            for y in cy * FLAT_CELL_PX..((cy + 1) * FLAT_CELL_PX).min(height) {
                v.extend_from_slice(
                    &pixels[y * width + cx * FLAT_CELL_PX
                        ..y * width + ((cx + 1) * FLAT_CELL_PX).min(width)],
                );
            }
            cells[cy * nx + cx] = robust_stats(&v).0;
        }
    }
    let overall = robust_stats(pixels).0;
    // Cell centres at (c + 0.5) * FLAT_CELL_PX - 0.5; clamp outside the outer centres.
    let coord = |p: usize, n: usize| {
        let u = ((p as f64 + 0.5) / FLAT_CELL_PX as f64 - 0.5).clamp(0.0, (n - 1) as f64);
        let i = (u.floor() as usize).min(n.saturating_sub(2));
        (i, (i + 1).min(n - 1), u - i as f64)
    };
    for y in 0..height {
        let (j0, j1, fy) = coord(y, ny);
        for x in 0..width {
            let (i0, i1, fx) = coord(x, nx);
            let top = cells[j0 * nx + i0] * (1.0 - fx) + cells[j0 * nx + i1] * fx;
            let bottom = cells[j1 * nx + i0] * (1.0 - fx) + cells[j1 * nx + i1] * fx;
            let level = top * (1.0 - fy) + bottom * fy;
            pixels[y * width + x] = (pixels[y * width + x] as f64 - level + overall) as f32;
        }
    }
}

/// Pixels this many robust sigma from the median are sources or defects.
const PIXEL_SIGMA: f64 = 3.0;
/// Before smoothing, pixels are clipped to this many sigma, so that hot pixels do not make
/// blobs of the smoothed map while a trail of many faint pixels does.
const TRAIL_CLIP_SIGMA: f64 = 1.0;
/// Half size of the box that smooths the frame for trails: 11 x 11 px averages the noise
/// down ~11x while a 2-3 px wide trail keeps a quarter of its per-pixel signal.
const TRAIL_BOX_RADIUS: usize = 5;
/// A trail is connected smoothed structure above `TRAIL_SIGMA` (of the smoothed map) of at
/// least `TRAIL_MIN_PX` pixels: an arc is followed along its length, while noise, at 3 sigma
/// of a map with ~120 px correlation areas, seldom gathers that many pixels. (A lower, second
/// threshold to follow arcs further was tried: on the raw science frame's correlated noise it
/// percolates and masks nearly everything.)
const TRAIL_SIGMA: f64 = 3.0;
const TRAIL_MIN_PX: usize = 200;
/// Trail masks grow by this many pixels: the wings of a trail are below the threshold. Single
/// outlying pixels are not grown: in a raw frame most are hot pixels (5x5 growth of the
/// science frame's ~5% of them masked nearly all of it), and a star's wings are smoothed
/// structure, masked with the trails.
const MASK_GROW_PX: usize = 2;

/// The pixels of a flattened frame that hold sources, defects or star trails: single pixels
/// beyond `PIXEL_SIGMA`, connected faint structure of the smoothed frame (a trail is a line
/// or an arc: found along its length, not as a blob), the latter grown, and the lines and arcs
/// of `trails` (fainter trails, found by a line filter).
pub fn source_mask(pixels: &[f32], width: usize, height: usize) -> Vec<bool> {
    let (median, sigma) = robust_stats(pixels);
    let outliers: Vec<bool> = pixels
        .iter()
        .map(|&v| !v.is_finite() || (v as f64 - median).abs() > PIXEL_SIGMA * sigma)
        .collect();
    let clip = TRAIL_CLIP_SIGMA * sigma;
    let clipped: Vec<f32> = pixels
        .iter()
        .map(|&v| clipped_about(v, median, clip) as f32)
        .collect();
    let smooth = box_mean(&clipped, width, height, TRAIL_BOX_RADIUS);
    let mut trails = vec![false; pixels.len()];
    let (s_median, s_sigma) = robust_stats(&smooth);
    let threshold = (s_median + TRAIL_SIGMA * s_sigma) as f32;
    for component in components(&smooth, width, height, threshold) {
        if component.len() >= TRAIL_MIN_PX {
            for i in component {
                trails[i] = true;
            }
        }
    }
    let lines = trail_mask(pixels, width, height, Rounds::First);
    grow(&trails, width, height, MASK_GROW_PX)
        .into_iter()
        .zip(outliers)
        .zip(lines)
        .map(|((t, o), l)| t || o || l)
        .collect()
}

/// Neighbourhood searched for a clean pixel to put in a masked one: the noise of the same
/// part of the sensor (its columns, its hot-pixel density), not of the frame as a whole.
const FILL_RADIUS_PX: i64 = 24;
/// Random tries in the neighbourhood before a clean pixel of the whole frame is taken.
const FILL_TRIES: usize = 64;

/// Replace the masked pixels by clean pixels drawn from their neighbourhood (else from the
/// whole frame), by a fixed stream so a frame always gives the same field. Returns how many.
pub fn fill_masked(pixels: &mut [f32], mask: &[bool], width: usize, height: usize) -> usize {
    let clean: Vec<usize> = (0..pixels.len()).filter(|&i| !mask[i]).collect();
    if clean.is_empty() {
        return 0;
    }
    let source = pixels.to_vec();
    let mut rng = pixel_stream(0, 0, PixelPurpose::Noise);
    let mut n = 0;
    for i in (0..pixels.len()).filter(|&i| mask[i]) {
        let (x, y) = ((i % width) as i64, (i / width) as i64);
        let near = (0..FILL_TRIES).find_map(|_| {
            let u = x + rng.random_range(-FILL_RADIUS_PX..=FILL_RADIUS_PX);
            let v = y + rng.random_range(-FILL_RADIUS_PX..=FILL_RADIUS_PX);
            let inside = u >= 0 && v >= 0 && (u as usize) < width && (v as usize) < height;
            // The index only inside: off the image it would overflow (a debug build panics).
            let j = inside.then(|| v as usize * width + u as usize)?;
            (!mask[j]).then_some(j)
        });
        let j = near.unwrap_or_else(|| clean[rng.random_range(0..clean.len())]);
        pixels[i] = source[j];
        n += 1;
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_sections_parse_and_must_fit() {
        let r = Region::from_fits_section("[17:1088,1:1030]", 1088, 1030).unwrap();
        assert_eq!((r.x0, r.x1, r.y0, r.y1), (16, 1088, 0, 1030));
        assert_eq!((r.width(), r.height()), (1072, 1030));
        assert!(Region::from_fits_section("[17:1089,1:1030]", 1088, 1030).is_none());
        assert!(Region::from_fits_section("[0:10,1:10]", 100, 100).is_none());
        assert!(Region::from_fits_section("17:20,1:10", 100, 100).is_none());
        let px: Vec<f32> = (0..12).map(|i| i as f32).collect();
        let r = Region::from_fits_section("[2:3,2:3]", 4, 3).unwrap();
        assert_eq!(r.crop(&px, 4), vec![5.0, 6.0, 9.0, 10.0]);
    }

    /// A 400 x 64 frame of noise whose first 10 and last 5 columns sit 50 units lower.
    #[test]
    fn stepped_edge_columns_are_found_and_a_gradient_is_not() {
        let (w, h) = (400, 64);
        let mut rng = pixel_stream(1, 0, PixelPurpose::Noise);
        let noise: Vec<f32> = (0..w * h).map(|_| rng.random_range(-1.0..1.0)).collect();
        let mut px = noise.clone();
        for y in 0..h {
            for x in (0..10).chain(w - 5..w) {
                px[y * w + x] -= 50.0;
            }
        }
        assert_eq!(edge_columns(&px, w, h), (10, 5));
        // A smooth ramp of 100 units across the frame is sky, not overscan.
        let ramp: Vec<f32> = (0..w * h)
            .map(|i| noise[i] + 100.0 * (i % w) as f32 / w as f32)
            .collect();
        assert_eq!(edge_columns(&ramp, w, h), (0, 0));
    }

    /// A faint arc, 5 px wide and 1.5 sigma per pixel (few of its pixels pass a 3-sigma cut), is
    /// masked along its length;
    /// the noise around it mostly is not.
    #[test]
    fn a_faint_arc_is_masked_as_a_trail() {
        let (w, h) = (256, 256);
        let mut rng = pixel_stream(2, 0, PixelPurpose::Noise);
        let normal = rand_distr::Normal::new(0.0f32, 1.0).unwrap();
        let mut px: Vec<f32> = (0..w * h)
            .map(|_| rand_distr::Distribution::sample(&normal, &mut rng))
            .collect();
        // An arc of radius 150 px centred off the frame.
        let on_arc = |x: usize, y: usize| {
            let r = ((x as f64 + 40.0).powi(2) + (y as f64 + 40.0).powi(2)).sqrt();
            (r - 150.0).abs() < 2.5
        };
        for y in 0..h {
            for x in 0..w {
                if on_arc(x, y) {
                    px[y * w + x] += 1.5;
                }
            }
        }
        let mask = source_mask(&px, w, h);
        let arc: Vec<usize> = (0..w * h).filter(|&i| on_arc(i % w, i / w)).collect();
        let hit = arc.iter().filter(|&&i| mask[i]).count();
        assert!(hit * 10 >= arc.len() * 8, "{hit} of {}", arc.len());
        // 3-sigma pixels are 0.27% of pure noise; the arc's grown mask ~6%: anything much
        // above means noise was taken for trails.
        let share = mask.iter().filter(|&&m| m).count() as f64 / mask.len() as f64;
        assert!(share < 0.08, "{share}");
    }

    #[test]
    fn masked_pixels_take_values_of_their_neighbourhood() {
        // Left half 0, right half 100; mask a pixel in each half, far from the middle.
        let (w, h) = (200, 50);
        let mut px: Vec<f32> = (0..w * h)
            .map(|i| if i % w < 100 { 0.0 } else { 100.0 })
            .collect();
        let mut mask = vec![false; w * h];
        mask[25 * w + 20] = true;
        mask[25 * w + 180] = true;
        px[25 * w + 20] = 1e6;
        px[25 * w + 180] = 1e6;
        assert_eq!(fill_masked(&mut px, &mask, w, h), 2);
        assert_eq!((px[25 * w + 20], px[25 * w + 180]), (0.0, 100.0));
    }
}
