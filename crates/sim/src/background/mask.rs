//! Pixel-mask helpers shared by the source mask (`prepare`) and the trail filter (`trails`):
//! clipping about the median, connected components above a threshold, growing a mask.

/// A pixel's offset from `median`, clipped to +-`clip` (a non-finite pixel counts as the
/// median): hot pixels then weigh no more than the faint trail pixels being looked for.
pub(super) fn clipped_about(v: f32, median: f64, clip: f64) -> f64 {
    if v.is_finite() {
        (v as f64 - median).clamp(-clip, clip)
    } else {
        0.0
    }
}

/// The 8-connected components of the pixels above `threshold`, as pixel indices.
pub(super) fn components(
    v: &[f32],
    width: usize,
    height: usize,
    threshold: f32,
) -> Vec<Vec<usize>> {
    let mut seen = vec![false; v.len()];
    let mut out = Vec::new();
    for start in 0..v.len() {
        if seen[start] || v[start] <= threshold {
            continue;
        }
        seen[start] = true;
        let mut component = vec![start];
        let mut next = 0;
        while next < component.len() {
            let i = component[next];
            next += 1;
            let (x, y) = ((i % width) as isize, (i / width) as isize);
            for (dx, dy) in NEIGHBOURS {
                let (u, w) = (x + dx, y + dy);
                if u >= 0 && w >= 0 && (u as usize) < width && (w as usize) < height {
                    let j = w as usize * width + u as usize;
                    if !seen[j] && v[j] > threshold {
                        seen[j] = true;
                        component.push(j);
                    }
                }
            }
        }
        out.push(component);
    }
    out
}

const NEIGHBOURS: [(isize, isize); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

/// A mask grown by `g` pixels (a square structuring element).
pub(super) fn grow(mask: &[bool], width: usize, height: usize, g: usize) -> Vec<bool> {
    // Separable: grow the rows, then the columns.
    let mut rows = vec![false; mask.len()];
    for y in 0..height {
        for x in 0..width {
            let (a, b) = (x.saturating_sub(g), (x + g + 1).min(width));
            rows[y * width + x] = mask[y * width + a..y * width + b].iter().any(|&m| m);
        }
    }
    let mut out = vec![false; mask.len()];
    for y in 0..height {
        let (a, b) = (y.saturating_sub(g), (y + g + 1).min(height));
        for x in 0..width {
            out[y * width + x] = (a..b).any(|v| rows[v * width + x]);
        }
    }
    out
}
