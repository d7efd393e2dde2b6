//! Filling an image of any size from a smaller (or larger) noise field without seams or
//! periodicity: overlapping square blocks, each cut from a random place of the field, joined
//! by a dithered cross-fade.
//!
//! Where blocks overlap, each pixel takes the value of one of them, chosen at random with
//! probability proportional to its weight (a ramp across the overlap): every pixel is a real
//! pixel of the frame, so its distribution (heavy tails of hot pixels included) is the
//! frame's everywhere. A weighted mean would not be: it lowers the variance by up to 29% in
//! the middle of an overlap (a band of smooth noise), and even normalised to keep the variance
//! it makes the noise more Gaussian there (measured on the dark frame: a band whose robust
//! sigma stands 11 sd off). Every block comes from an independent random place, so nothing
//! repeats at the block pitch.

use rand::RngExt;
use soig_base::rng::PixelRng;

/// Side of a block, pixels, at most (a field smaller than this gives smaller blocks).
const BLOCK_PX: usize = 256;

/// A noise field: its pixels (row-major) and their mean.
pub struct Field<'a> {
    pub pixels: &'a [f32],
    pub width: usize,
    pub height: usize,
    pub mean: f64,
}

/// The fluctuations of `field` about its mean, cut into overlapping blocks and laid over a
/// `width` x `height` image; the grid starts at `phase` (so block edges move from image to
/// image) and each block's source corner is drawn from `rng`. Returns fluctuations (mean 0).
pub fn fluctuations(
    field: &Field,
    width: usize,
    height: usize,
    phase: (usize, usize),
    rng: &mut PixelRng,
) -> Vec<f32> {
    let block = BLOCK_PX.min(field.width).min(field.height);
    // A quarter of the block on each side is cross-faded with the neighbour.
    let overlap = (block / 4).max(1);
    let pitch = block - overlap;
    // 1-D weight of position u in a block: a linear ramp over the overlap at both ends,
    // strictly positive so every pixel has a weight.
    let ramp: Vec<f64> = (0..block)
        .map(|u| {
            let edge = (u.min(block - 1 - u) as f64 + 0.5) / overlap as f64;
            edge.min(1.0)
        })
        .collect();
    // Weighted reservoir choice per pixel: the k-th candidate replaces the chosen one with
    // probability w_k / (w_1 + ... + w_k), so each is chosen with probability w_i / sum w.
    let mut chosen = vec![0.0f32; width * height];
    let mut total = vec![0.0f64; width * height];
    let start = |p: usize| -((p % pitch) as isize) - overlap as isize;
    let (sx, sy) = (start(phase.0), start(phase.1));
    let mut by = sy;
    while by < height as isize {
        let mut bx = sx;
        while bx < width as isize {
            let fx = rng.random_range(0..=field.width - block);
            let fy = rng.random_range(0..=field.height - block);
            for v in 0..block {
                let y = by + v as isize;
                if y < 0 || y >= height as isize {
                    continue;
                }
                let row = &field.pixels[(fy + v) * field.width + fx..][..block];
                for (u, &value) in row.iter().enumerate() {
                    let x = bx + u as isize;
                    if x < 0 || x >= width as isize {
                        continue;
                    }
                    let w = ramp[u] * ramp[v];
                    let i = y as usize * width + x as usize;
                    total[i] += w;
                    if w >= total[i] || rng.random::<f64>() * total[i] < w {
                        chosen[i] = (value as f64 - field.mean) as f32;
                    }
                }
            }
            bx += pitch as isize;
        }
        by += pitch as isize;
    }
    chosen
}

#[cfg(test)]
mod tests {
    use super::*;
    use soig_base::rng::{PixelPurpose, pixel_stream};

    fn white(n: usize, seed: u64) -> Vec<f32> {
        let mut rng = pixel_stream(seed, 0, PixelPurpose::Noise);
        (0..n).map(|_| rng.random_range(-1.0f32..1.0)).collect()
    }

    /// A zero-mean field of `width` x `height` pixels.
    fn field(pixels: &[f32], width: usize, height: usize) -> Field<'_> {
        Field {
            pixels,
            width,
            height,
            mean: 0.0,
        }
    }

    #[test]
    fn cross_fade_keeps_the_variance_everywhere() {
        // White noise of variance 1/3: every column of a 1000-wide fill keeps it (overlaps
        // included); a plain weighted mean would drop to ~1/6 in the overlaps' middles.
        let px = white(300 * 300, 3);
        let field = field(&px, 300, 300);
        let mut rng = pixel_stream(4, 0, PixelPurpose::Noise);
        let (w, h) = (1000, 1000);
        let out = fluctuations(&field, w, h, (37, 91), &mut rng);
        for x in 0..w {
            let var = (0..h).map(|y| (out[y * w + x] as f64).powi(2)).sum::<f64>() / h as f64;
            // 1000 samples of a variance-1/3 uniform: the estimate's sd is ~0.3/sqrt(1000)*...
            // about 0.0094 (var of x^2 = 1/5 - 1/9); 5 sd is 0.047.
            assert!((var - 1.0 / 3.0).abs() < 0.05, "column {x}: {var}");
        }
    }

    #[test]
    fn a_field_smaller_than_a_block_still_fills() {
        let px = white(40 * 30, 5);
        let field = field(&px, 40, 30);
        let mut rng = pixel_stream(6, 0, PixelPurpose::Noise);
        let out = fluctuations(&field, 100, 70, (0, 0), &mut rng);
        assert_eq!(out.len(), 7000);
        // Every pixel is one of the field's.
        assert!(out.iter().all(|v| px.contains(v)));
    }
}
