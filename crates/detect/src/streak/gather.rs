//! The sums of `refine`'s axis search, four axes a vector: each lane's bilinear sample
//! (`soig_image::imaging::bilinear`) read by AVX2 gathers, where one sample at a time was a
//! fifth of the star-aware pass (about 40 scalar instructions a sample, 2.5 million samples an
//! image). Every lane takes the scalar code's steps in the same order and precision (a
//! clamp as `maxpd(min, x)` then `minpd(max, x)`, truncation, f32 products and sums with no
//! fused multiply-add), and each axis's sum adds its samples in increasing t: the same bits
//! (`simd`'s test compares them with [`axis_sum`]).

use soig_image::imaging::bilinear;

/// One axis of a search level: its point, direction, the first t it reads (every `stride`-th
/// from there) and the t it sums over, `a..=b` (empty where `a > b`).
#[derive(Clone, Copy)]
pub(super) struct Axis {
    pub(super) x: f64,
    pub(super) y: f64,
    pub(super) ux: f64,
    pub(super) uy: f64,
    pub(super) from: i64,
    pub(super) a: i64,
    pub(super) b: i64,
}

/// Each axis's sum of z (the `w` x `h` map, bilinear) clipped to +-`clip` at t = `from`,
/// `from + stride`, ... within `a..=b`.
pub(super) fn axis_sums(
    z: &[f32],
    (w, h): (usize, usize),
    axes: &[Axis],
    clip: f64,
    stride: usize,
) -> Vec<f64> {
    #[cfg(target_arch = "x86_64")]
    {
        // Finite points: a NaN truncates out of the map, not to 0.
        let finite = axes
            .iter()
            .all(|a| [a.x, a.y, a.ux, a.uy].iter().all(|v| v.is_finite()));
        if finite && clip.is_finite() && gathers_read(w, h) {
            // SAFETY: the CPU has AVX2 (checked on the line above); every index the gathers
            // read is clamped into the map (finite points, checked too).
            return unsafe { avx2::sums(z, w, h, axes, clip, stride.max(1)) };
        }
    }
    axes.iter()
        .map(|ax| axis_sum(z, (w, h), ax, clip, stride))
        .collect()
}

/// Whether the AVX2 gathers can read a `w` x `h` map: the CPU has AVX2, and the map is not
/// empty and its indices (y w + x) fit the gathers' i32.
#[cfg(target_arch = "x86_64")]
fn gathers_read(w: usize, h: usize) -> bool {
    w >= 1
        && h >= 1
        && w.checked_mul(h).is_some_and(|n| n <= i32::MAX as usize)
        && std::arch::is_x86_feature_detected!("avx2")
}

/// One axis's sum, a sample at a time: the reference the vector build gives the bits of.
pub(super) fn axis_sum(
    z: &[f32],
    (w, h): (usize, usize),
    ax: &Axis,
    clip: f64,
    stride: usize,
) -> f64 {
    let mut s = 0.0;
    let mut t = ax.from;
    while t <= ax.b {
        if t >= ax.a {
            let tf = t as f64;
            s +=
                (bilinear(z, w, h, ax.x + tf * ax.ux, ax.y + tf * ax.uy) as f64).clamp(-clip, clip);
        }
        t += stride.max(1) as i64;
    }
    s
}

/// Contrast sample of `taps` (lateral offset, weight) at (x, y) across the normal `n`:
/// `Maps::contrast`, four taps' samples a vector where AVX2 is (up to 32 taps).
pub(super) fn contrast(
    z: &[f32],
    (w, h): (usize, usize),
    taps: &[(f64, f64)],
    (x, y): (f64, f64),
    n: (f64, f64),
) -> f64 {
    #[cfg(target_arch = "x86_64")]
    {
        let finite =
            [x, y, n.0, n.1].iter().all(|v| v.is_finite()) && taps.iter().all(|t| t.0.is_finite());
        if finite && taps.len() <= 32 && gathers_read(w, h) {
            // SAFETY: the CPU has AVX2 (checked on the line above); every index the gathers
            // read is clamped into the map (finite points, checked too).
            return unsafe { avx2::contrast(z, (w, h), taps, (x, y), n) };
        }
    }
    contrast_at(z, (w, h), taps, (x, y), n)
}

/// [`contrast`] a sample at a time: the reference.
pub(super) fn contrast_at(
    z: &[f32],
    (w, h): (usize, usize),
    taps: &[(f64, f64)],
    (x, y): (f64, f64),
    (nx, ny): (f64, f64),
) -> f64 {
    taps.iter()
        .map(|&(u, a)| a * bilinear(z, w, h, x + u * nx, y + u * ny) as f64)
        .sum()
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::Axis;
    use std::arch::x86_64::*;

    /// Four axes' lanes: point, direction, first t and range as f64 (exact: |t| < 2^53).
    struct Quad {
        x: __m256d,
        y: __m256d,
        ux: __m256d,
        uy: __m256d,
        from: __m256d,
        a: __m256d,
        b: __m256d,
        /// Steps until every lane is past its `b`.
        steps: i64,
    }

    /// A map's constants for [`Map4::bilinear`].
    struct Map4<'a> {
        z: &'a [f32],
        xmax: __m256d,
        ymax: __m256d,
        wm1: __m128i,
        hm1: __m128i,
        w: __m128i,
    }

    impl<'a> Map4<'a> {
        #[target_feature(enable = "avx2")]
        fn new(z: &'a [f32], w: usize, h: usize) -> Map4<'a> {
            Map4 {
                z,
                xmax: _mm256_set1_pd((w - 1) as i64 as f64),
                ymax: _mm256_set1_pd((h - 1) as i64 as f64),
                wm1: _mm_set1_epi32((w - 1) as i32),
                hm1: _mm_set1_epi32((h - 1) as i32),
                w: _mm_set1_epi32(w as i32),
            }
        }

        /// `bilinear` at four points (finite), lane by lane.
        #[target_feature(enable = "avx2")]
        #[inline]
        fn bilinear(&self, px: __m256d, py: __m256d) -> __m128 {
            // The point clamped to the pixel centres, x.clamp(0, w - 1).
            let zero = _mm256_setzero_pd();
            let px = _mm256_min_pd(self.xmax, _mm256_max_pd(zero, px));
            let py = _mm256_min_pd(self.ymax, _mm256_max_pd(zero, py));
            let (xi, yi) = (_mm256_cvttpd_epi32(px), _mm256_cvttpd_epi32(py));
            let fx = _mm256_cvtpd_ps(_mm256_sub_pd(px, _mm256_cvtepi32_pd(xi)));
            let fy = _mm256_cvtpd_ps(_mm256_sub_pd(py, _mm256_cvtepi32_pd(yi)));
            let one_i = _mm_set1_epi32(1);
            let xi1 = _mm_min_epi32(_mm_add_epi32(xi, one_i), self.wm1);
            let yi1 = _mm_min_epi32(_mm_add_epi32(yi, one_i), self.hm1);
            let (r0, r1) = (_mm_mullo_epi32(yi, self.w), _mm_mullo_epi32(yi1, self.w));
            let p = self.z.as_ptr();
            // SAFETY: every index is y * w + x with 0 <= x < w and 0 <= y < h (the clamps
            // above), inside `z`.
            let (v00, v10, v01, v11) = unsafe {
                (
                    _mm_i32gather_ps::<4>(p, _mm_add_epi32(r0, xi)),
                    _mm_i32gather_ps::<4>(p, _mm_add_epi32(r0, xi1)),
                    _mm_i32gather_ps::<4>(p, _mm_add_epi32(r1, xi)),
                    _mm_i32gather_ps::<4>(p, _mm_add_epi32(r1, xi1)),
                )
            };
            let one = _mm_set1_ps(1.0);
            let (gx, gy) = (_mm_sub_ps(one, fx), _mm_sub_ps(one, fy));
            let top = _mm_add_ps(_mm_mul_ps(v00, gx), _mm_mul_ps(v10, fx));
            let bottom = _mm_add_ps(_mm_mul_ps(v01, gx), _mm_mul_ps(v11, fx));
            _mm_add_ps(_mm_mul_ps(top, gy), _mm_mul_ps(bottom, fy))
        }
    }

    /// [`super::contrast`] in AVX2 (finite point and normal; the map's indices fit i32).
    #[target_feature(enable = "avx2")]
    pub(super) fn contrast(
        z: &[f32],
        (w, h): (usize, usize),
        taps: &[(f64, f64)],
        (x, y): (f64, f64),
        (nx, ny): (f64, f64),
    ) -> f64 {
        let map = Map4::new(z, w, h);
        let (x, y, nx, ny) = (
            _mm256_set1_pd(x),
            _mm256_set1_pd(y),
            _mm256_set1_pd(nx),
            _mm256_set1_pd(ny),
        );
        let mut vals = [0f32; 32];
        for (c, out) in taps.chunks(4).zip(vals.chunks_mut(4)) {
            // Padding lanes read the first tap's point again, never summed.
            let u = [0, 1, 2, 3].map(|k| c.get(k).unwrap_or(&c[0]).0);
            let u = lanes(u);
            let px = _mm256_add_pd(x, _mm256_mul_pd(u, nx));
            let py = _mm256_add_pd(y, _mm256_mul_pd(u, ny));
            let mut four = [0f32; 4];
            // SAFETY: four f32 stored into an array of four.
            unsafe { _mm_storeu_ps(four.as_mut_ptr(), map.bilinear(px, py)) };
            out.copy_from_slice(&four);
        }
        // The products and their sum in the taps' order, as `super::contrast_at`.
        taps.iter().zip(vals).map(|(&(_, a), v)| a * v as f64).sum()
    }

    /// Four lanes from an array.
    #[target_feature(enable = "avx2")]
    fn lanes(v: [f64; 4]) -> __m256d {
        _mm256_setr_pd(v[0], v[1], v[2], v[3])
    }

    /// [`super::axis_sums`] in AVX2 (`stride` at least 1; finite points; the map's indices fit
    /// i32).
    #[target_feature(enable = "avx2")]
    pub(super) fn sums(
        z: &[f32],
        w: usize,
        h: usize,
        axes: &[Axis],
        clip: f64,
        stride: usize,
    ) -> Vec<f64> {
        let st = stride as i64;
        let mut quads = Vec::with_capacity(axes.len().div_ceil(4));
        for c in axes.chunks(4) {
            // Padding lanes copy the last axis with an empty range: read, never summed.
            let pad = Axis {
                a: 1,
                b: 0,
                ..c[c.len() - 1]
            };
            let l = [0, 1, 2, 3].map(|k| c.get(k).copied().unwrap_or(pad));
            let steps = l
                .iter()
                .map(|a| {
                    if a.b >= a.from {
                        (a.b - a.from) / st + 1
                    } else {
                        0
                    }
                })
                .max()
                .unwrap_or(0);
            quads.push(Quad {
                x: lanes(l.map(|a| a.x)),
                y: lanes(l.map(|a| a.y)),
                ux: lanes(l.map(|a| a.ux)),
                uy: lanes(l.map(|a| a.uy)),
                from: lanes(l.map(|a| a.from as f64)),
                a: lanes(l.map(|a| a.a as f64)),
                b: lanes(l.map(|a| a.b as f64)),
                steps,
            });
        }
        let mut acc = vec![_mm256_setzero_pd(); quads.len()];
        let steps = quads.iter().map(|q| q.steps).max().unwrap_or(0);
        let (lo, hi) = (_mm256_set1_pd(-clip), _mm256_set1_pd(clip));
        let map = Map4::new(z, w, h);
        // Step by step, every quad at that step (their samples lie near each other's).
        for m in 0..steps {
            let dm = _mm256_set1_pd((m * st) as f64);
            for (q, s) in quads.iter().zip(acc.iter_mut()) {
                if m >= q.steps {
                    continue;
                }
                let t = _mm256_add_pd(q.from, dm);
                let inside = _mm256_and_pd(
                    _mm256_cmp_pd::<_CMP_GE_OQ>(t, q.a),
                    _mm256_cmp_pd::<_CMP_LE_OQ>(t, q.b),
                );
                let px = _mm256_add_pd(q.x, _mm256_mul_pd(t, q.ux));
                let py = _mm256_add_pd(q.y, _mm256_mul_pd(t, q.uy));
                let v = _mm256_cvtps_pd(map.bilinear(px, py));
                // v.clamp(-clip, clip), added where t is in the axis's range.
                let v = _mm256_min_pd(hi, _mm256_max_pd(lo, v));
                *s = _mm256_blendv_pd(*s, _mm256_add_pd(*s, v), inside);
            }
        }
        let mut out = Vec::with_capacity(axes.len());
        for s in &acc {
            let mut four = [0.0; 4];
            // SAFETY: four f64 stored into an array of four.
            unsafe { _mm256_storeu_pd(four.as_mut_ptr(), *s) };
            out.extend(four);
        }
        out.truncate(axes.len());
        out
    }
}
