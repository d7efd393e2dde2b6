//! Step 2, star-trail removal (survey images): structures along the known trail direction are
//! subtracted before the line filter, so that a debris streak crossing a trail keeps its signal.

use super::lines::transpose;
use super::params::Sanitized;
use super::smooth::corr;
use super::stats::map_stats;

/// Survey images: remove structures elongated along the star-trail direction. From each pixel
/// of `z` the mean along that direction over the `trail_filter_px` pixels before it or the
/// ones after it is subtracted (the larger one where it is significant, at a trail and its
/// ends; their average elsewhere; see [`subtract_side_means`]), then the map's median is
/// restored to zero. A trail longer than the window vanishes up to its ends; a streak crossing
/// it at angle `a` keeps most of its signal (its crossing is about 5 psf_sigma / sin(a) pixels
/// of the window).
#[inline(never)]
pub(super) fn remove_trails(z: &mut [f32], w: usize, h: usize, angle: f64, p: &Sanitized) {
    let hk = p.trail_half;
    if hk == 0 {
        return;
    }
    let (c, s) = (angle.cos(), angle.sin());
    let x_major = c.abs() >= s.abs();
    let t = if x_major { s / c } else { c / s };
    if x_major {
        let mut zt = vec![0f32; w * h];
        transpose(z, &mut zt, w, h);
        subtract_side_means(&mut zt, w, h, t, hk, p.psf_sigma);
        transpose(&zt, z, h, w);
    } else {
        subtract_side_means(z, h, w, t, hk, p.psf_sigma);
    }
    let med = map_stats(z, w, h).0 as f32;
    z.iter_mut().for_each(|v| *v -= med);
}

avx2_dispatch! {
    /// `src -= max(mean before, mean after)` along exact lines advancing one row per step (line
    /// through (row i, position p + i t)); rows are split between the two nearest lines by linear
    /// weights, so that bright trails at any angle leave no aliasing residual. Windows: the
    /// `2 hk + 1` rows on each side, in-map pixels only (a side with fewer than 3 is missing).
    /// The larger side mean is subtracted when it exceeds 3 sigma of its noise (a trail, including
    /// its ends), otherwise the average of the two (unbiased on noise; removes faint trails).
    pub(super) fn subtract_side_means(src: &mut [f32], rows: usize, m: usize, t: f64, hk: usize, psf_sigma: f64) = subtract_side_means_at
}

#[inline(always)]
pub(super) fn subtract_side_means_at(
    src: &mut [f32],
    rows: usize,
    m: usize,
    t: f64,
    hk: usize,
    psf_sigma: f64,
) {
    let k = 2 * hk + 1;
    // Line coordinate of pixel (i, pos): pos + base[i].0 + base[i].1 (integer + fraction).
    let top = (0..rows).map(|i| i as f64 * t).fold(0.0, f64::max).ceil();
    let base: Vec<(usize, f32)> = (0..rows)
        .map(|i| {
            let a = top - i as f64 * t;
            let l = a.floor();
            (l as usize, (a - l) as f32)
        })
        .collect();
    let span = base.iter().map(|b| b.0).max().unwrap_or(0) + m + 2;
    // Noise sd of a window mean of n in-map terms: sqrt(c / n).
    let c_noise = line_correlation_sum(t, psf_sigma) as f32;
    // Window means and their significance (mean / noise sd) for the last 2 hk + 3 centres, by
    // line; NaN where fewer than 3 pixels.
    let ring_len = 2 * hk + 3;
    let slot = |q: isize| (q + hk as isize + 1) as usize % ring_len;
    let mut ring = vec![0f32; ring_len * span];
    let mut ring_z = vec![0f32; ring_len * span];
    let mut acc = vec![0f32; span];
    let mut cnt = vec![0f32; span];
    let splat = |acc: &mut [f32], cnt: &mut [f32], row: &[f32], (l, f): (usize, f32), sign: f32| {
        let (a0, a1) = (sign * (1.0 - f), sign * f);
        for (a, &v) in acc[l..l + m].iter_mut().zip(row) {
            *a += a0 * v;
        }
        for (a, &v) in acc[l + 1..l + 1 + m].iter_mut().zip(row) {
            *a += a1 * v;
        }
        cnt[l..l + m].iter_mut().for_each(|c| *c += a0);
        cnt[l + 1..l + 1 + m].iter_mut().for_each(|c| *c += a1);
    };
    let (hk_i, k_i, rows_i) = (hk as isize, k as isize, rows as isize);
    let mut side = vec![0f32; m];
    let lerp = |r: &[f32], l: usize, f: f32| -> Vec<f32> {
        r[l..l + m]
            .iter()
            .zip(&r[l + 1..l + 1 + m])
            .map(|(&a, &b)| (1.0 - f) * a + f * b)
            .collect()
    };
    for i in -1..=(rows_i + 2 * hk_i) {
        if (0..rows_i).contains(&i) {
            let iu = i as usize;
            splat(
                &mut acc,
                &mut cnt,
                &src[iu * m..(iu + 1) * m],
                base[iu],
                1.0,
            );
        }
        if (0..rows_i).contains(&(i - k_i)) {
            let qu = (i - k_i) as usize;
            splat(
                &mut acc,
                &mut cnt,
                &src[qu * m..(qu + 1) * m],
                base[qu],
                -1.0,
            );
        }
        // Means of the window centred on row q = i - hk (rows q - hk ..= q + hk).
        let q = i - hk_i;
        let sq = slot(q);
        for (((mv, zv), &a), &n) in ring[sq * span..(sq + 1) * span]
            .iter_mut()
            .zip(ring_z[sq * span..(sq + 1) * span].iter_mut())
            .zip(&acc)
            .zip(&cnt)
        {
            if n >= 3.0 {
                *mv = a / n;
                *zv = *mv * (n / c_noise).sqrt();
            } else {
                *mv = f32::NAN;
                *zv = f32::NAN;
            }
        }
        // Row c = q - hk - 1 now has both side windows (centres c - hk - 1 and c + hk + 1).
        let c = q - hk_i - 1;
        if (0..rows_i).contains(&c) {
            let cu = c as usize;
            let (l, f) = base[cu];
            let sb = slot(c - hk_i - 1);
            let (mb, zb) = (
                lerp(&ring[sb * span..], l, f),
                lerp(&ring_z[sb * span..], l, f),
            );
            let (ma, za) = (
                lerp(&ring[sq * span..], l, f),
                lerp(&ring_z[sq * span..], l, f),
            );
            for (j, v) in side.iter_mut().enumerate() {
                *v = match (mb[j].is_nan(), ma[j].is_nan()) {
                    (false, false) => {
                        if zb[j].max(za[j]) > 3.0 {
                            mb[j].max(ma[j])
                        } else {
                            0.5 * (mb[j] + ma[j])
                        }
                    }
                    (false, true) => mb[j],
                    (true, false) => ma[j],
                    (true, true) => 0.0,
                };
            }
            for (v, &sv) in src[cu * m..(cu + 1) * m].iter_mut().zip(&side) {
                *v -= sv;
            }
        }
    }
}

/// Sum over all lags of the noise correlation between the pixels of a digital line of slope
/// `t` (|t| <= 1): the variance of a long line sum per term.
fn line_correlation_sum(t: f64, psf_sigma: f64) -> f64 {
    let lags = (12.0 * psf_sigma).ceil() as i64;
    let mut c = 1.0;
    for k in 1..=lags {
        let (dx, dy) = (k as f64, (k as f64 * t).round());
        c += 2.0 * corr(dx * dx + dy * dy, psf_sigma);
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn side_means_remove_a_full_trail() {
        let (rows, m, hk) = (200, 3, 20);
        let mut src = vec![0f32; rows * m];
        for i in 0..rows {
            src[i * m + 1] = 50.0;
        }
        subtract_side_means(&mut src, rows, m, 0.0, hk, 1.5);
        let col: Vec<f32> = (0..rows).map(|i| src[i * m + 1]).collect();
        assert!(col.iter().all(|v| v.abs() < 1e-3), "{col:?}");
        // A finite diagonal trail (slope -1) in a 120 x 120 map.
        let (rows, m) = (120, 120);
        let mut src = vec![0f32; rows * m];
        for i in 20..100 {
            src[i * m + (110 - i)] = 50.0;
        }
        subtract_side_means(&mut src, rows, m, -1.0, hk, 1.5);
        let on: Vec<f32> = (20..100).map(|i| src[i * m + (110 - i)]).collect();
        // Removed wherever a full window fits on one side (trail of 80 px, windows of 41).
        assert!(on.iter().all(|v| v.abs() < 2.0), "{on:?}");
        assert!(
            on[..38].iter().chain(&on[42..]).all(|v| v.abs() < 1e-3),
            "{on:?}"
        );
    }
}
