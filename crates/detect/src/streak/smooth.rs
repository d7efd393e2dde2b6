//! Step 2, the cross-section matched filter: Gaussian smoothing with mirrored borders, the edge
//! rows and columns rescaled to the interior noise, and the noise correlation of the smoothed map
//! that the line sums' noise models use.

pub(super) fn gaussian_kernel(sigma: f64) -> Vec<f32> {
    let r = (3.0 * sigma).ceil() as i64;
    let k: Vec<f64> = (-r..=r)
        .map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let s: f64 = k.iter().sum();
    k.iter().map(|v| (v / s) as f32).collect()
}

/// Mirror (reflect-101) index into [0, n).
fn reflect(i: isize, n: usize) -> usize {
    if n == 1 {
        return 0;
    }
    let period = 2 * (n as isize - 1);
    let m = i.rem_euclid(period);
    if m >= n as isize {
        (period - m) as usize
    } else {
        m as usize
    }
}

avx2_dispatch! {
    /// Separable convolution with mirrored borders.
    pub(super) fn smooth(src: &[f32], w: usize, h: usize, k: &[f32]) -> Vec<f32> = smooth_at
}

#[inline(always)]
pub(super) fn smooth_at(src: &[f32], w: usize, h: usize, k: &[f32]) -> Vec<f32> {
    let r = (k.len() / 2) as isize;
    let ru = r as usize;
    let mut tmp = vec![0f32; w * h];
    for y in 0..h {
        let row = &src[y * w..(y + 1) * w];
        let out = &mut tmp[y * w..(y + 1) * w];
        // Interior: one shifted slice per tap (vectorised).
        if w > 2 * ru {
            let n = w - 2 * ru;
            for (kk, &kv) in k.iter().enumerate() {
                for (o, &v) in out[ru..ru + n].iter_mut().zip(&row[kk..kk + n]) {
                    *o += kv * v;
                }
            }
        }
        // Edges: mirrored.
        for x in (0..ru.min(w)).chain(w.saturating_sub(ru).max(ru.min(w))..w) {
            let xi = x as isize;
            out[x] = k
                .iter()
                .enumerate()
                .map(|(kk, &kv)| kv * row[reflect(xi + kk as isize - r, w)])
                .sum();
        }
    }
    let mut out = vec![0f32; w * h];
    for y in 0..h {
        let orow = &mut out[y * w..(y + 1) * w];
        for (kk, &kv) in k.iter().enumerate() {
            let yy = reflect(y as isize + kk as isize - r, h);
            let irow = &tmp[yy * w..(yy + 1) * w];
            for (o, &v) in orow.iter_mut().zip(irow) {
                *o += kv * v;
            }
        }
    }
    out
}

/// Near the edges the mirrored smoothing counts some pixels twice, which raises the noise (up
/// to about 1.4 times on the edge row for sigma 1.5) and would make lines along the edges.
/// Divide by the exact noise ratio of the folded kernel, per row and per column.
#[inline(never)]
pub(super) fn equalise_edge_noise(z: &mut [f32], w: usize, h: usize, k: &[f32]) {
    let ratio = |n: usize| -> Vec<f32> {
        let r = (k.len() / 2) as isize;
        let base: f64 = k.iter().map(|&v| (v as f64).powi(2)).sum();
        let of = |var: f64| (base / var).sqrt() as f32;
        // Where no tap is mirrored the folded kernel is the kernel, each tap alone at its
        // place: its squares summed in order are the fold's sum (the zeros around add
        // nothing), so one value serves the interior, where each row's fold was n values.
        let unfolded = of(k.iter().map(|&kv| kv as f64 * kv as f64).sum());
        let folded_at = |i: usize| {
            let mut folded = vec![0f64; n];
            for (kk, &kv) in k.iter().enumerate() {
                folded[reflect(i as isize + kk as isize - r, n)] += kv as f64;
            }
            of(folded.iter().map(|v| v * v).sum())
        };
        let interior = |i: usize| i as isize >= r && i as isize + r < n as isize;
        (0..n)
            .map(|i| if interior(i) { unfolded } else { folded_at(i) })
            .collect()
    };
    let (fx, fy) = (ratio(w), ratio(h));
    for (y, row) in z.chunks_mut(w).enumerate() {
        for (v, &f) in row.iter_mut().zip(&fx) {
            *v *= f * fy[y];
        }
    }
}

/// Correlation of the smoothed unit-noise map at distance d (white noise through a Gaussian).
pub(super) fn corr(d2: f64, psf_sigma: f64) -> f64 {
    (-d2 / (4.0 * psf_sigma * psf_sigma)).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The interior's one value gives each row's fold bit for bit: against every row folded
    /// (as before it), on sides shorter and longer than the kernel, for several widths.
    #[test]
    fn the_interior_ratio_is_every_row_s_fold() {
        for sigma in [0.5, 1.4, 2.3] {
            let k = gaussian_kernel(sigma);
            for (w, h) in [(1, 9), (3, 5), (17, 40), (64, 7)] {
                let mut z = vec![1f32; w * h];
                equalise_edge_noise(&mut z, w, h, &k);
                let r = (k.len() / 2) as isize;
                let base: f64 = k.iter().map(|&v| (v as f64).powi(2)).sum();
                let every = |n: usize| -> Vec<f32> {
                    (0..n)
                        .map(|i| {
                            let mut folded = vec![0f64; n];
                            for (kk, &kv) in k.iter().enumerate() {
                                folded[reflect(i as isize + kk as isize - r, n)] += kv as f64;
                            }
                            let var: f64 = folded.iter().map(|v| v * v).sum();
                            (base / var).sqrt() as f32
                        })
                        .collect()
                };
                let (fx, fy) = (every(w), every(h));
                for y in 0..h {
                    for x in 0..w {
                        let want = 1f32 * (fx[x] * fy[y]);
                        assert_eq!(z[y * w + x].to_bits(), want.to_bits(), "{w}x{h} {sigma}");
                    }
                }
            }
        }
    }
}
