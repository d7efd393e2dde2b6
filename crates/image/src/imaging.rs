//! Image-plane helpers shared across the crate: bilinear sampling between pixel centres, a box
//! mean, robust statistics (median and 1.4826 MAD sigma) of pixel values, and a point's
//! distance from a segment. Images are row-major `f32` slices with pixel centres at integer
//! coordinates.

/// Bilinear interpolation between pixel centres (as `cv2.warpAffine` with INTER_LINEAR), in
/// single precision; a point beyond the outer pixel centres takes the edge value.
// Inlined across crates: the streak refinement samples it ~10^6 times an image (22% of the
// detector's time in a call of its own). Always: with its bounds converted through i64 (below)
// LLVM's plain `inline` left it a call in `refine` (1.4 G instructions more on 6 images).
#[inline(always)]
pub fn bilinear(img: &[f32], width: usize, height: usize, x: f64, y: f64) -> f32 {
    // The bounds through i64 too (the same values: a map's side is far below 2^53): usize to
    // f64 is a sequence of seven instructions, i64 to f64 one.
    let x = x.clamp(0.0, (width - 1) as i64 as f64);
    let y = y.clamp(0.0, (height - 1) as i64 as f64);
    // Truncation is the floor here (x, y >= 0 after the clamp; NaN gives 0 either way), and
    // needs no call to libm's floor, which the default x86-64 target has no instruction for.
    // Through i64, not straight to usize: x86-64 converts f64 to and from signed 64-bit
    // integers in one instruction, to and from unsigned ones only by a sequence of them
    // (the same values here, where 0 <= x < 2^53).
    let (xi, yi) = (x as i64, y as i64);
    let (fx, fy) = ((x - xi as f64) as f32, (y - yi as f64) as f32);
    let (i, j) = (xi as usize, yi as usize);
    let (i1, j1) = ((i + 1).min(width - 1), (j + 1).min(height - 1));
    let at = |a: usize, b: usize| img[b * width + a];
    let top = at(i, j) * (1.0 - fx) + at(i1, j) * fx;
    let bottom = at(i, j1) * (1.0 - fx) + at(i1, j1) * fx;
    top * (1.0 - fy) + bottom * fy
}

/// Distance from `p` to the segment `a`-`b` (a point where `a` is `b`).
// Inlined across crates: the streak detector measures it in its per-sample loops.
#[inline]
pub fn point_segment_distance(p: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 {
        (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let (ex, ey) = (a.0 + t * dx - p.0, a.1 + t * dy - p.1);
    (ex * ex + ey * ey).sqrt()
}

/// Median and robust standard deviation (1.4826 MAD) of the finite pixels of an image: the sky
/// level and noise, unmoved by stars, which would inflate a plain standard deviation. The
/// median of an even count is the upper middle value; `(0, 0)` when no pixel is finite.
pub fn robust_stats(img: &[f32]) -> (f64, f64) {
    let mut v: Vec<f32> = img.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return (0.0, 0.0);
    }
    let mid = v.len() / 2;
    let median = *v.select_nth_unstable_by(mid, f32::total_cmp).1;
    let mut dev: Vec<f32> = v.iter().map(|x| (x - median).abs()).collect();
    let mad = *dev.select_nth_unstable_by(mid, f32::total_cmp).1;
    (median as f64, 1.4826 * mad as f64)
}

/// The mean over a (2r+1)^2 box, the box clipped at the frame's edges (summed-area table).
pub fn box_mean(v: &[f32], width: usize, height: usize, r: usize) -> Vec<f32> {
    let mut sat = vec![0.0f64; (width + 1) * (height + 1)];
    for y in 0..height {
        let mut row = 0.0;
        for x in 0..width {
            row += v[y * width + x] as f64;
            sat[(y + 1) * (width + 1) + x + 1] = sat[y * (width + 1) + x + 1] + row;
        }
    }
    let mut out = Vec::with_capacity(v.len());
    for y in 0..height {
        let (y0, y1) = (y.saturating_sub(r), (y + r + 1).min(height));
        for x in 0..width {
            let (x0, x1) = (x.saturating_sub(r), (x + r + 1).min(width));
            let s = sat[y1 * (width + 1) + x1]
                - sat[y0 * (width + 1) + x1]
                - sat[y1 * (width + 1) + x0]
                + sat[y0 * (width + 1) + x0];
            out.push((s / ((x1 - x0) * (y1 - y0)) as f64) as f32);
        }
    }
    out
}
