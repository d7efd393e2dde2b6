//! Contrast-limited adaptive histogram equalisation (CLAHE) of 8-bit grey images,
//! reproducing OpenCV's `cv::CLAHE` (modules/imgproc/src/clahe.cpp, CPU path) exactly:
//! same tiling and padding, same clip limit, same redistribution of the clipped
//! counts, same look-up tables and the same single-precision bilinear interpolation
//! and rounding. On the reference fixtures (OpenCV 5.0.0, see the tests) the output is
//! identical to `cv2.createCLAHE(clip_limit, (tiles_x, tiles_y)).apply(img)` at every pixel.
//!
//! Only `std` is used; the work is single-threaded (about 2-3 ms for 1024x1024 in
//! release mode), so callers may run several images in parallel.

/// Number of grey levels (histogram bins) of an 8-bit image.
const BINS: usize = 256;

/// Pixels per block in the interpolation loop.
const LANES: usize = 8;

/// Contrast-limited adaptive histogram equalisation of an 8-bit image, with OpenCV's semantics
/// (`cv2.createCLAHE(clip_limit, (tiles_x, tiles_y)).apply`).
///
/// * `pixels`: row-major, `width * height` bytes, no row padding.
/// * `clip_limit`: OpenCV's clip limit (relative to a uniform histogram). The absolute
///   per-bin limit is `max(trunc(clip_limit * tile_w * tile_h / 256), 1)`. A value `<= 0`
///   (or NaN) disables clipping, as in OpenCV (plain adaptive histogram equalisation).
/// * `tiles_x`, `tiles_y`: the grid (OpenCV's `tileGridSize = (tiles_x, tiles_y)`,
///   default 8x8). A 0 is treated as 1 (OpenCV would not accept it).
///
/// When `width` is not a multiple of `tiles_x` or `height` not a multiple of `tiles_y`, the
/// histograms are taken from the image extended on the right and bottom by
/// `tiles - size % tiles` pixels each (BORDER_REFLECT_101), exactly as OpenCV does (this
/// includes OpenCV's quirk of adding a full `tiles_x` columns when only the height does not
/// divide, and vice versa). Images smaller than the grid (down to 1x1) are handled the same
/// way: the reflected extension makes every tile at least one pixel, and the result matches
/// OpenCV's (a 1x1 image or a constant image is mapped through the tile LUTs like any other).
///
/// Returns a new `width * height` buffer. An empty image (`width == 0 || height == 0`) gives
/// an empty vector. Panics only if `pixels.len() != width * height`.
/// Memory: `O(width * height + tiles_x * tiles_y * 256)`.
pub fn clahe_u8(
    pixels: &[u8],
    width: usize,
    height: usize,
    clip_limit: f64,
    tiles_x: usize,
    tiles_y: usize,
) -> Vec<u8> {
    assert_eq!(
        Some(pixels.len()),
        width.checked_mul(height),
        "clahe_u8: pixels.len() must equal width * height ({width} x {height})"
    );
    if width == 0 || height == 0 {
        return Vec::new();
    }
    let tiles_x = tiles_x.max(1);
    let tiles_y = tiles_y.max(1);

    // Size of the image the histograms are taken from (OpenCV's `srcExt_`).
    let (rem_x, rem_y) = (width % tiles_x, height % tiles_y);
    let (ext_w, ext_h) = if rem_x == 0 && rem_y == 0 {
        (width, height)
    } else {
        (width + tiles_x - rem_x, height + tiles_y - rem_y)
    };
    let tile_w = ext_w / tiles_x;
    let tile_h = ext_h / tiles_y;
    let tile_total = tile_w * tile_h;

    // OpenCV: lutScale = float(histSize - 1) / tileSizeTotal (float division).
    let lut_scale = (BINS - 1) as f32 / tile_total as f32;
    // OpenCV: clipLimit = max(int(clipLimit_ * tileSizeTotal / histSize), 1) if clipLimit_ > 0.
    // 0 means "no clipping". (`as u32` saturates where OpenCV's int cast would overflow.)
    let clip = if clip_limit > 0.0 {
        ((clip_limit * tile_total as f64 / BINS as f64) as u32).max(1)
    } else {
        0
    };

    let luts = tile_luts(
        pixels, width, height, ext_w, tile_w, tile_h, tiles_x, tiles_y, clip, lut_scale,
    );
    interpolate(
        pixels, width, height, tile_w, tile_h, tiles_x, tiles_y, &luts,
    )
}

/// OpenCV's `borderInterpolate(p, len, BORDER_REFLECT_101)` for `p >= 0` (padding is only
/// added on the right / bottom): `gfedcb|abcdefgh|gfedcba`, iterated for wide borders.
fn reflect_101(p: usize, len: usize) -> usize {
    if len == 1 {
        return 0;
    }
    let len = len as isize;
    let mut p = p as isize;
    while p < 0 || p >= len {
        p = if p < 0 { -p } else { 2 * len - 2 - p };
    }
    p as usize
}

/// Round to nearest, ties to even, and saturate to `0..=255`: OpenCV's
/// `saturate_cast<uchar>(float)` (`cvRound`, i.e. `cvtss2si`/`lrintf`, then clamp).
/// After clamping to `[0, 255]`, adding 2^23 rounds to an integer in the default IEEE
/// mode (ties to even), which then is the low byte of the bit pattern. Branch-free and
/// conversion-free, so the interpolation loop vectorises. (NaN, which cannot occur here,
/// gives the low byte of its payload, 0 for the default NaN; OpenCV gives 0.)
#[inline(always)]
fn round_sat_u8(v: f32) -> u8 {
    const MAGIC: f32 = 8_388_608.0; // 2^23
    (v.clamp(0.0, 255.0) + MAGIC).to_bits() as u8
}

/// Computes the `tiles_y * tiles_x` look-up tables (as `f32`, each holding an integer
/// 0..=255; `f32` saves the int-to-float conversion in the interpolation and is exact).
#[allow(clippy::too_many_arguments)]
fn tile_luts(
    pixels: &[u8],
    width: usize,
    height: usize,
    ext_w: usize,
    tile_w: usize,
    tile_h: usize,
    tiles_x: usize,
    tiles_y: usize,
    clip: u32,
    lut_scale: f32,
) -> Vec<f32> {
    // Source column of each padding column ext index width..ext_w.
    let pad_cols: Vec<usize> = (width..ext_w).map(|x| reflect_101(x, width)).collect();

    let mut luts = vec![0.0f32; tiles_x * tiles_y * BINS];
    // Four interleaved histograms per tile of the current tile row, so that runs of
    // equal values (dark sky, constant areas) do not serialise on one counter.
    let mut hist4 = vec![[[0u32; BINS]; 4]; tiles_x];

    for (ty, lut_row) in luts.chunks_exact_mut(tiles_x * BINS).enumerate() {
        for h in hist4.iter_mut() {
            *h = [[0; BINS]; 4];
        }
        for ye in ty * tile_h..(ty + 1) * tile_h {
            let y = if ye < height {
                ye
            } else {
                reflect_101(ye, height)
            };
            let row = &pixels[y * width..(y + 1) * width];
            for (tx, h) in hist4.iter_mut().enumerate() {
                let x0 = tx * tile_w;
                let x1 = x0 + tile_w;
                // Columns inside the image.
                if x0 < width {
                    let seg = &row[x0..x1.min(width)];
                    let mut quads = seg.chunks_exact(4);
                    for q in &mut quads {
                        h[0][q[0] as usize] += 1;
                        h[1][q[1] as usize] += 1;
                        h[2][q[2] as usize] += 1;
                        h[3][q[3] as usize] += 1;
                    }
                    for &v in quads.remainder() {
                        h[0][v as usize] += 1;
                    }
                }
                // Reflected padding columns.
                for &sx in &pad_cols[x0.max(width) - width..x1.max(width) - width] {
                    h[0][row[sx] as usize] += 1;
                }
            }
        }

        for (h, lut) in hist4.iter().zip(lut_row.chunks_exact_mut(BINS)) {
            let mut hist = [0u32; BINS];
            for (i, v) in hist.iter_mut().enumerate() {
                *v = h[0][i] + h[1][i] + h[2][i] + h[3][i];
            }
            clip_histogram(&mut hist, clip);
            // OpenCV: sum += hist[i]; lut[i] = saturate_cast<uchar>(sum * lutScale) (float).
            let mut sum = 0u32;
            for (l, &c) in lut.iter_mut().zip(hist.iter()) {
                sum += c;
                *l = f32::from(round_sat_u8(sum as f32 * lut_scale));
            }
        }
    }
    luts
}

/// OpenCV's histogram clipping: clip every bin at `clip`, add `clipped / 256` to every
/// bin, then one more to bins `0, step, 2*step, ...` (`step = max(256 / residual, 1)`)
/// until the `residual = clipped % 256` extra counts are used up. `clip == 0`: no clipping.
fn clip_histogram(hist: &mut [u32; BINS], clip: u32) {
    if clip == 0 {
        return;
    }
    let mut clipped = 0u32;
    for v in hist.iter_mut() {
        if *v > clip {
            clipped += *v - clip;
            *v = clip;
        }
    }
    let batch = clipped / BINS as u32;
    let residual = (clipped % BINS as u32) as usize;
    for v in hist.iter_mut() {
        *v += batch;
    }
    // `residual < 256`, so the step is >= 1 (OpenCV's MAX(..., 1) is a no-op).
    if let Some(step) = BINS.checked_div(residual) {
        for v in hist.iter_mut().step_by(step).take(residual) {
            *v += 1;
        }
    }
}

/// Interpolation coordinate of OpenCV: `f = i * (1/tile) - 0.5` in `f32`, the two
/// neighbouring tiles `floor(f)` and `floor(f) + 1` clamped to the grid, and the weights
/// `a = f - floor(f)`, `1 - a`.
#[inline]
fn axis_weights(i: usize, inv_tile: f32, tiles: usize) -> (usize, usize, f32, f32) {
    let f = i as f32 * inv_tile - 0.5;
    let t1 = f.floor();
    let a = f - t1;
    let t1 = t1 as isize;
    let lo = t1.max(0) as usize;
    let hi = ((t1 + 1) as usize).min(tiles - 1);
    (lo, hi, a, 1.0 - a)
}

/// Bilinear interpolation between the four neighbouring tile LUTs, exactly as
/// OpenCV's `CLAHE_Interpolation_Body` (same `f32` expression, same evaluation order).
#[allow(clippy::too_many_arguments)]
fn interpolate(
    pixels: &[u8],
    width: usize,
    height: usize,
    tile_w: usize,
    tile_h: usize,
    tiles_x: usize,
    tiles_y: usize,
    luts: &[f32],
) -> Vec<u8> {
    let inv_tw = 1.0f32 / tile_w as f32;
    let inv_th = 1.0f32 / tile_h as f32;

    // Per-column weights, and runs of columns sharing the same pair of tile columns.
    let mut xa = Vec::with_capacity(width);
    let mut xa1 = Vec::with_capacity(width);
    let mut runs: Vec<(usize, usize, usize, usize)> = Vec::new(); // (start, end, tx1, tx2)
    for x in 0..width {
        let (lo, hi, a, a1) = axis_weights(x, inv_tw, tiles_x);
        xa.push(a);
        xa1.push(a1);
        match runs.last_mut() {
            Some(r) if r.2 == lo && r.3 == hi => r.1 = x + 1,
            _ => runs.push((x, x + 1, lo, hi)),
        }
    }

    let plane_len = tiles_x * BINS;

    let mut out = vec![0u8; width * height];
    for (y, (src_row, dst_row)) in pixels
        .chunks_exact(width)
        .zip(out.chunks_exact_mut(width))
        .enumerate()
    {
        let (ty1, ty2, ya, ya1) = axis_weights(y, inv_th, tiles_y);
        let plane1 = &luts[ty1 * plane_len..(ty1 + 1) * plane_len];
        let plane2 = &luts[ty2 * plane_len..(ty2 + 1) * plane_len];
        for &(x0, x1, tx1, tx2) in &runs {
            let l11 = lut(plane1, tx1);
            let l12 = lut(plane1, tx2);
            let l21 = lut(plane2, tx1);
            let l22 = lut(plane2, tx2);
            let src = &src_row[x0..x1];
            let dst = &mut dst_row[x0..x1];
            let a = &xa[x0..x1];
            let a1 = &xa1[x0..x1];
            // Blocks of LANES pixels: the table look-ups are scalar, the arithmetic is
            // written lane-wise so that it compiles to SIMD (same f32 operations and order
            // per pixel as the scalar tail, hence as OpenCV).
            let mut d_blocks = dst.chunks_exact_mut(LANES);
            let mut s_blocks = src.chunks_exact(LANES);
            let mut a_blocks = a.chunks_exact(LANES);
            let mut a1_blocks = a1.chunks_exact(LANES);
            for (((d, s), a), a1) in (&mut d_blocks)
                .zip(&mut s_blocks)
                .zip(&mut a_blocks)
                .zip(&mut a1_blocks)
            {
                let a: [f32; LANES] = a.try_into().expect("block of LANES");
                let a1: [f32; LANES] = a1.try_into().expect("block of LANES");
                let s: [u8; LANES] = s.try_into().expect("block of LANES");
                let v11 = s.map(|v| l11[v as usize]);
                let v12 = s.map(|v| l12[v as usize]);
                let v21 = s.map(|v| l21[v as usize]);
                let v22 = s.map(|v| l22[v as usize]);
                let mut out = [0u8; LANES];
                for i in 0..LANES {
                    let res = (v11[i] * a1[i] + v12[i] * a[i]) * ya1
                        + (v21[i] * a1[i] + v22[i] * a[i]) * ya;
                    out[i] = round_sat_u8(res);
                }
                d.copy_from_slice(&out);
            }
            for (((d, &s), &a), &a1) in d_blocks
                .into_remainder()
                .iter_mut()
                .zip(s_blocks.remainder())
                .zip(a_blocks.remainder())
                .zip(a1_blocks.remainder())
            {
                let v = s as usize;
                let res = (l11[v] * a1 + l12[v] * a) * ya1 + (l21[v] * a1 + l22[v] * a) * ya;
                *d = round_sat_u8(res);
            }
        }
    }
    out
}

/// The LUT of tile column `t` within a tile row, as a fixed-size array reference (so that
/// indexing with a `u8` value needs no bounds check).
#[inline(always)]
fn lut(plane: &[f32], t: usize) -> &[f32; BINS] {
    plane[t * BINS..(t + 1) * BINS]
        .try_into()
        .expect("LUT slice has BINS entries")
}

#[cfg(test)]
mod tests {
    //! Reference fixtures come from `tests/reference/clahe_reference.py` (OpenCV 5.0.0,
    //! `cv2.createCLAHE(clip, (tx, ty)).apply`), listed in `tests/fixtures/clahe/manifest.txt`.
    //! Result with this implementation: every PNG case (9 images x 6 parameter sets) is
    //! identical to OpenCV's (max difference 0, 0 differing pixels), and the six 1024x1024
    //! cases match OpenCV's output sha256 exactly. The tests allow 1 grey level.

    use super::*;
    use std::path::PathBuf;

    fn fixture_dir() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/fixtures/clahe")
    }

    fn load_grey(name: &str) -> (Vec<u8>, usize, usize) {
        let img = image::open(fixture_dir().join(name))
            .unwrap_or_else(|e| panic!("cannot read fixture {name}: {e}"))
            .into_luma8();
        let (w, h) = img.dimensions();
        (img.into_raw(), w as usize, h as usize)
    }

    /// (kind, image name, clip, tiles_x, tiles_y, file or sha256) per manifest line.
    fn manifest() -> Vec<(String, String, f64, usize, usize, String)> {
        let text = std::fs::read_to_string(fixture_dir().join("manifest.txt")).unwrap();
        text.lines()
            .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
            .map(|l| {
                let f: Vec<&str> = l.split_whitespace().collect();
                assert_eq!(f.len(), 6, "bad manifest line {l:?}");
                (
                    f[0].to_string(),
                    f[1].to_string(),
                    f[2].parse().unwrap(),
                    f[3].parse().unwrap(),
                    f[4].parse().unwrap(),
                    f[5].to_string(),
                )
            })
            .collect()
    }

    #[test]
    fn matches_opencv_png_fixtures() {
        let cases: Vec<_> = manifest().into_iter().filter(|c| c.0 == "png").collect();
        assert_eq!(cases.len(), 9 * 6, "expected 9 images x 6 parameter sets");
        let mut total_diff = 0usize;
        for (_, name, clip, tx, ty, file) in &cases {
            let (input, w, h) = load_grey(&format!("{name}_in.png"));
            let (expected, ew, eh) = load_grey(file);
            assert_eq!((w, h), (ew, eh));
            let got = clahe_u8(&input, w, h, *clip, *tx, *ty);
            assert_eq!(got.len(), expected.len());
            let mut max_diff = 0u8;
            let mut n_diff = 0usize;
            for (&g, &e) in got.iter().zip(&expected) {
                let d = g.abs_diff(e);
                max_diff = max_diff.max(d);
                n_diff += usize::from(d != 0);
            }
            eprintln!(
                "{name:>13} {w}x{h} clip {clip:>4} grid {tx}x{ty}: max diff {max_diff}, {n_diff} pixels differ"
            );
            assert!(
                max_diff <= 1,
                "{file}: max difference {max_diff} > 1 ({n_diff} pixels differ)"
            );
            total_diff += n_diff;
        }
        eprintln!("total differing pixels over all PNG cases: {total_diff}");
    }

    /// The 1024x1024 input of `tests/tests/reference/clahe_reference.py::big_formula`.
    fn big_formula() -> Vec<u8> {
        let mut v = Vec::with_capacity(1024 * 1024);
        for y in 0..1024usize {
            for x in 0..1024usize {
                let p =
                    ((x ^ y) & 63) + ((x * x + 3 * y * y) >> 14) + 17 * ((x / 128 + y / 128) & 1);
                v.push((p % 256) as u8);
            }
        }
        v
    }

    #[test]
    fn matches_opencv_sha256_1024() {
        let cases: Vec<_> = manifest().into_iter().filter(|c| c.0 == "sha").collect();
        assert_eq!(cases.len(), 6);
        let input = big_formula();
        for (_, name, clip, tx, ty, sha) in &cases {
            assert_eq!(name, "big1024");
            let got = clahe_u8(&input, 1024, 1024, *clip, *tx, *ty);
            assert_eq!(&sha256_hex(&got), sha, "clip {clip} grid {tx}x{ty}");
        }
    }

    #[test]
    fn degenerate_inputs_do_not_panic() {
        let clips = [-1.0, 0.0, f64::NAN, f64::INFINITY, 1e300, 1e-9, 2.0, 40.0];
        for h in 1..=11usize {
            for w in 1..=11usize {
                let img: Vec<u8> = (0..w * h).map(|i| (i * 73 % 256) as u8).collect();
                for (tx, ty) in [(0, 0), (1, 1), (8, 8), (3, 5), (13, 2), (1, 17)] {
                    for &c in &clips {
                        let out = clahe_u8(&img, w, h, c, tx, ty);
                        assert_eq!(out.len(), w * h);
                    }
                }
            }
        }
        assert!(clahe_u8(&[], 0, 5, 2.0, 8, 8).is_empty());
        assert!(clahe_u8(&[], 7, 0, 2.0, 8, 8).is_empty());
        // A grid of 0 behaves as a grid of 1.
        let img: Vec<u8> = (0..64u8).collect();
        assert_eq!(
            clahe_u8(&img, 8, 8, 2.0, 0, 0),
            clahe_u8(&img, 8, 8, 2.0, 1, 1)
        );
    }

    #[test]
    #[should_panic(expected = "pixels.len()")]
    fn wrong_length_panics() {
        clahe_u8(&[0u8; 10], 3, 3, 2.0, 8, 8);
    }

    #[test]
    fn reflect_101_like_opencv() {
        // len 4: abcd|cba dcb ...   (OpenCV borderInterpolate, BORDER_REFLECT_101)
        let got: Vec<usize> = (4..12).map(|p| reflect_101(p, 4)).collect();
        assert_eq!(got, [2, 1, 0, 1, 2, 3, 2, 1]);
        assert_eq!(reflect_101(7, 1), 0);
        assert_eq!(reflect_101(2, 2), 0);
        assert_eq!(reflect_101(3, 2), 1);
    }

    #[test]
    fn rounding_like_cv_round() {
        let cases = [
            (0.0, 0),
            (0.49999997, 0),
            (0.5, 0),
            (1.5, 2),
            (2.5, 2),
            (3.5000002, 4),
            (127.49999, 127),
            (254.5, 254),
            (255.00003, 255),
            (255.6, 255),
            (1e9, 255),
            (-0.4, 0),
            (-7.0, 0),
            (f32::NAN, 0),
        ];
        for (v, want) in cases {
            assert_eq!(round_sat_u8(v), want, "{v}");
        }
    }

    #[test]
    fn clip_histogram_redistribution() {
        // 300 pixels in bin 10, clip 5: clipped 295 = 1 * 256 + 39; step 256 / 39 = 6.
        let mut h = [0u32; BINS];
        h[10] = 300;
        clip_histogram(&mut h, 5);
        assert_eq!(h.iter().sum::<u32>(), 300);
        for (i, &v) in h.iter().enumerate() {
            let extra = u32::from(i % 6 == 0 && i / 6 < 39);
            let base = if i == 10 { 5 } else { 0 };
            assert_eq!(v, base + 1 + extra, "bin {i}");
        }
    }

    #[test]
    #[ignore = "timing; run with cargo test --release -- --ignored --nocapture"]
    fn timing_1024() {
        let input = big_formula();
        for (clip, t) in [(2.0, 8), (40.0, 8), (3.0, 5)] {
            let _ = clahe_u8(&input, 1024, 1024, clip, t, t);
            let n = 200;
            let start = std::time::Instant::now();
            let mut acc = 0u64;
            for _ in 0..n {
                acc += u64::from(clahe_u8(&input, 1024, 1024, clip, t, t)[12345]);
            }
            let dt = start.elapsed().as_secs_f64() / n as f64;
            eprintln!(
                "clahe_u8 1024x1024 clip {clip} grid {t}x{t}: {:.3} ms ({acc})",
                dt * 1e3
            );
        }
        let star: Vec<u8> = (0..1472 * 1472)
            .map(|i| {
                if i % 997 == 0 {
                    250
                } else {
                    10 + (i % 3) as u8
                }
            })
            .collect();
        let n = 100;
        let start = std::time::Instant::now();
        for _ in 0..n {
            std::hint::black_box(clahe_u8(&star, 1472, 1472, 2.0, 8, 8));
        }
        let dt = start.elapsed().as_secs_f64() / n as f64;
        eprintln!(
            "clahe_u8 1472x1472 star-like clip 2 grid 8x8: {:.3} ms",
            dt * 1e3
        );
    }

    /// Minimal SHA-256 (FIPS 180-4), test-only, to compare with the Python reference.
    fn sha256_hex(data: &[u8]) -> String {
        const K: [u32; 64] = [
            0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4,
            0xab1c5ed5, 0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe,
            0x9bdc06a7, 0xc19bf174, 0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f,
            0x4a7484aa, 0x5cb0a9dc, 0x76f988da, 0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7,
            0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967, 0x27b70a85, 0x2e1b2138, 0x4d2c6dfc,
            0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85, 0xa2bfe8a1, 0xa81a664b,
            0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070, 0x19a4c116,
            0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
            0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7,
            0xc67178f2,
        ];
        let mut h: [u32; 8] = [
            0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a, 0x510e527f, 0x9b05688c, 0x1f83d9ab,
            0x5be0cd19,
        ];
        let mut msg = data.to_vec();
        msg.push(0x80);
        while msg.len() % 64 != 56 {
            msg.push(0);
        }
        msg.extend_from_slice(&((data.len() as u64) * 8).to_be_bytes());
        for block in msg.chunks_exact(64) {
            let mut w = [0u32; 64];
            for (i, c) in block.chunks_exact(4).enumerate() {
                w[i] = u32::from_be_bytes([c[0], c[1], c[2], c[3]]);
            }
            for i in 16..64 {
                let s0 = w[i - 15].rotate_right(7) ^ w[i - 15].rotate_right(18) ^ (w[i - 15] >> 3);
                let s1 = w[i - 2].rotate_right(17) ^ w[i - 2].rotate_right(19) ^ (w[i - 2] >> 10);
                w[i] = w[i - 16]
                    .wrapping_add(s0)
                    .wrapping_add(w[i - 7])
                    .wrapping_add(s1);
            }
            let mut v = h;
            for i in 0..64 {
                let s1 = v[4].rotate_right(6) ^ v[4].rotate_right(11) ^ v[4].rotate_right(25);
                let ch = (v[4] & v[5]) ^ (!v[4] & v[6]);
                let t1 = v[7]
                    .wrapping_add(s1)
                    .wrapping_add(ch)
                    .wrapping_add(K[i])
                    .wrapping_add(w[i]);
                let s0 = v[0].rotate_right(2) ^ v[0].rotate_right(13) ^ v[0].rotate_right(22);
                let maj = (v[0] & v[1]) ^ (v[0] & v[2]) ^ (v[1] & v[2]);
                let t2 = s0.wrapping_add(maj);
                v = [
                    t1.wrapping_add(t2),
                    v[0],
                    v[1],
                    v[2],
                    v[3].wrapping_add(t1),
                    v[4],
                    v[5],
                    v[6],
                ];
            }
            for (a, b) in h.iter_mut().zip(v) {
                *a = a.wrapping_add(b);
            }
        }
        h.iter().map(|x| format!("{x:08x}")).collect()
    }

    #[test]
    fn sha256_known_vectors() {
        assert_eq!(
            sha256_hex(b""),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"
        );
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }
}
