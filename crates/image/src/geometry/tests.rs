//! The frame kinds, warps and label boxes against their definitions.

use super::*;
use rand::RngExt;
use soig_base::rng::{PixelPurpose, pixel_stream};

#[test]
fn rotated_frame_is_the_papers_size_and_inverts() {
    let f = Frame::rotated(1024, 1024, 33.0);
    assert_eq!((f.width, f.height), (1472, 1472));
    for &(x, y) in &[(0.0, 0.0), (1023.0, 17.5), (511.5, 511.5)] {
        let (u, v) = f.map(x, y);
        let (x2, y2) = f.unmap(u, v);
        assert!((x - x2).abs() < 1e-9 && (y - y2).abs() < 1e-9);
    }
    // The centre maps to the centre; a trail along 33 deg becomes horizontal.
    let (cx, cy) = f.map(511.5, 511.5);
    assert!((cx - 735.5).abs() < 1e-9 && (cy - 735.5).abs() < 1e-9);
    let a = 33f64.to_radians();
    let (x1, y1) = f.map(511.5 + 100.0 * a.cos(), 511.5 + 100.0 * a.sin());
    assert!((y1 - cy).abs() < 1e-9 && (x1 - cx - 100.0).abs() < 1e-9);
    // Every corner of the original stays inside the new canvas at any angle.
    for ang in [0.0, 45.0, 90.0, 135.0, -60.0] {
        let f = Frame::rotated(1024, 1024, ang);
        for &(x, y) in &[
            (-0.5, -0.5),
            (1023.5, -0.5),
            (-0.5, 1023.5),
            (1023.5, 1023.5),
        ] {
            let (u, v) = f.map(x, y);
            assert!(
                u >= -0.5 && v >= -0.5 && u <= 1471.5 && v <= 1471.5,
                "{ang}: {u},{v}"
            );
        }
    }
    let p = Frame::padded(1024, 1024, 32);
    assert_eq!((p.width, p.height), (1088, 1088));
    assert_eq!(p.map(0.0, 0.0), (32.0, 32.0));
}

#[test]
fn padding_copies_and_fills_with_the_sky_noise() {
    let (w, h) = (64, 48);
    let mut rng = pixel_stream(1, 0, PixelPurpose::Enhance);
    let mut noise = pixel_stream(2, 0, PixelPurpose::Noise);
    let normal = Normal::new(50.0, 5.0).unwrap();
    let img: Vec<f32> = (0..w * h)
        .map(|_| normal.sample(&mut noise) as f32)
        .collect();
    let f = Frame::padded(w, h, 32);
    let out = warp(&img, w, h, &f, Fill::SkyNoise(&mut rng));
    for j in 0..h {
        for i in 0..w {
            assert_eq!(out[(j + 32) * f.width + i + 32], img[j * w + i]);
        }
    }
    let border: Vec<f32> = out[..f.width * 32].to_vec();
    let (m, s) = robust_stats(&border);
    assert!((m - 50.0).abs() < 0.5 && (s - 5.0).abs() < 0.5, "{m} {s}");
    // Rotation smooths the noise; the fill follows the smoothed sky, not the original.
    let f = Frame::rotated(w, h, 30.0);
    let out = warp(&img, w, h, &f, Fill::SkyNoise(&mut rng));
    let inside: Vec<f32> = (0..f.height)
        .flat_map(|j| (0..f.width).map(move |i| (i, j)))
        .filter(|&(i, j)| {
            let (x, y) = f.unmap(i as f64, j as f64);
            x > 0.0 && y > 0.0 && x < w as f64 - 1.0 && y < h as f64 - 1.0
        })
        .map(|(i, j)| out[j * f.width + i])
        .collect();
    let border: Vec<f32> = out[..f.width * 3].to_vec();
    let (si, so) = (robust_stats(&inside).1, robust_stats(&border).1);
    assert!(
        si < 4.5 && (si - so).abs() < 0.15 * si,
        "inside {si} border {so}"
    );
}

/// Pixel-to-pixel contrast of a region: the standard deviation of the differences between
/// horizontal neighbours both in the region, over the region's standard deviation (sqrt 2
/// for white noise, less for noise smoothed by resampling).
fn contrast(img: &[f32], width: usize, keep: impl Fn(usize, usize) -> bool) -> (f64, f64, f64) {
    let std = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        (
            m,
            (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / v.len() as f64).sqrt(),
        )
    };
    let height = img.len() / width;
    let mut values = Vec::new();
    let mut diffs = Vec::new();
    for j in 0..height {
        for i in 0..width {
            if keep(i, j) {
                values.push(img[j * width + i] as f64);
                if i + 1 < width && keep(i + 1, j) {
                    diffs.push((img[j * width + i + 1] - img[j * width + i]) as f64);
                }
            }
        }
    }
    let (mean, sigma) = std(&values);
    (mean, sigma, std(&diffs).1 / sigma)
}

/// The two regions of a rotated frame the fill tests compare, as tests of output pixel
/// (i, j): inside, at least 1 px from the original's edge (where bilinear clamps); fill, at
/// least 2 px outside it (so no bilinear pair straddles the boundary).
fn rotated_regions(
    f: &Frame,
    w: usize,
    h: usize,
) -> (
    impl Fn(usize, usize) -> bool + '_,
    impl Fn(usize, usize) -> bool + '_,
) {
    let (w, h) = (w as f64, h as f64);
    let inside = move |i: usize, j: usize| {
        let (x, y) = f.unmap(i as f64, j as f64);
        x > 1.0 && y > 1.0 && x < w - 2.0 && y < h - 2.0
    };
    let fill = move |i: usize, j: usize| {
        let (x, y) = f.unmap(i as f64, j as f64);
        x < -2.5 || y < -2.5 || x > w + 1.5 || y > h + 1.5
    };
    (inside, fill)
}

/// `img` rotated by `angle` degrees, its fill sky noise drawn on stream `seed`: the
/// `contrast` figures (mean, sigma, contrast) of the rotated frame's inside and of its fill.
fn rotated_inside_and_fill(
    img: &[f32],
    (w, h): (usize, usize),
    angle: f64,
    seed: u64,
) -> ((f64, f64, f64), (f64, f64, f64)) {
    let mut rng = pixel_stream(seed, 0, PixelPurpose::Enhance);
    let f = Frame::rotated(w, h, angle);
    let out = warp(img, w, h, &f, Fill::SkyNoise(&mut rng));
    let (inside, fill) = rotated_regions(&f, w, h);
    (
        contrast(&out, f.width, inside),
        contrast(&out, f.width, fill),
    )
}

#[test]
fn rotated_fill_has_the_correlation_of_the_resampled_sky() {
    // The paper's noise: background uniform in [190, 210] ADU plus bias in [2, 3].
    let (w, h) = (256, 256);
    let mut noise = pixel_stream(3, 0, PixelPurpose::Noise);
    let img: Vec<f32> = (0..w * h)
        .map(|_| (noise.random_range(190.0..210.0) + noise.random_range(2.0..3.0)) as f32)
        .collect();
    for angle in [30.0, 17.0, -62.0] {
        let ((mi, si, ci), (mf, sf, cf)) = rotated_inside_and_fill(&img, (w, h), angle, 1);
        // Tens of thousands of pixels in each region: the standard error of a standard
        // deviation is 1/sqrt(2 n) < 0.5%, and the bilinear weights follow each pixel's
        // sub-pixel offset, which the two regions sample alike only statistically (measured:
        // within 0.5% at these angles). 2% is four times that, and far below the 16% of the
        // white fill this replaces (contrast 1.415 against 1.217 inside at 30 deg).
        assert!(
            (cf / ci - 1.0).abs() < 0.02,
            "{angle} deg: contrast inside {ci:.3}, fill {cf:.3}"
        );
        assert!(
            (mf - mi).abs() < 0.05 * si,
            "{angle} deg: mean {mi} vs {mf}"
        );
        assert!(
            (sf / si - 1.0).abs() < 0.02,
            "{angle} deg: sigma inside {si:.3}, fill {sf:.3}"
        );
    }
    // The padded frame copies the image: its fill stays white noise, as the sky it borders.
    let mut rng = pixel_stream(1, 0, PixelPurpose::Enhance);
    let f = Frame::padded(w, h, 32);
    let out = warp(&img, w, h, &f, Fill::SkyNoise(&mut rng));
    let inside = |i: usize, j: usize| (32..32 + w).contains(&i) && (32..32 + h).contains(&j);
    let (_, _, ci) = contrast(&out, f.width, inside);
    let (_, _, cf) = contrast(&out, f.width, |i, j| !inside(i, j));
    assert!(
        (ci - 2f64.sqrt()).abs() < 0.03 && (cf - 2f64.sqrt()).abs() < 0.03,
        "padded: inside {ci:.3}, fill {cf:.3}"
    );
}

#[test]
fn rotated_fill_keeps_the_hot_pixel_tail() {
    // A dark frame's noise: Gaussian (sigma 5 ADU) with 1% hot pixels 20 sigma up, which
    // carry most of the plain standard deviation (sqrt(25 + 0.01 * 100^2) = 11.2 ADU).
    let (w, h) = (512, 512);
    let mut noise = pixel_stream(7, 0, PixelPurpose::Noise);
    let gauss = Normal::new(100.0, 5.0).unwrap();
    let img: Vec<f32> = (0..w * h)
        .map(|_| {
            let hot = if noise.random::<f64>() < 0.01 {
                100.0
            } else {
                0.0
            };
            (gauss.sample(&mut noise) + hot) as f32
        })
        .collect();
    for angle in [30.0, -62.0] {
        let ((_, si, _), (_, sf, _)) = rotated_inside_and_fill(&img, (w, h), angle, 2);
        // The tail makes the pixel values' kurtosis large (0.01 * 100^4 / 125^2 = 64 before
        // the resampling averages it down), and the relative standard error of a standard
        // deviation is sqrt((kurtosis - 1) / n) / 2: under 1.5% over the 70 000 or more
        // pixels of each region. 5% (the bound) is over three of those.
        assert!(
            (sf / si - 1.0).abs() < 0.05,
            "{angle} deg: sigma inside {si:.3}, fill {sf:.3}"
        );
    }
}

#[test]
fn rotated_fill_has_the_variance_the_correlated_sky_would_have_there() {
    // Read noise with the vertical correlation of the NEOSSat dark frame's (0.22-0.27 in
    // its 5-sigma core): each pixel plus half the one below, correlation 0.5 / 1.25 = 0.4,
    // over a sky wide enough to hold the whole rotated canvas; the image is its centre.
    // The reference is that sky resampled at the fill's pixels: what the frame would show
    // there. Between independent nodes the fill kept sqrt(1 / (1 + 0.4 / 2)) = 0.91 of it
    // on average; at 89.9 deg the sub-pixel offsets sweep the canvas so slowly that the
    // fill, all far from the centre, sits near offset 0.5, where it kept sqrt(1 / 1.4).
    let (w, h, m) = (512, 512, 280);
    let (sw, sh) = (w + 2 * m, h + 2 * m);
    let mut noise = pixel_stream(11, 0, PixelPurpose::Noise);
    let gauss = Normal::new(0.0, 5.0).unwrap();
    let white: Vec<f64> = (0..sw * (sh + 1))
        .map(|_| gauss.sample(&mut noise))
        .collect();
    let sky: Vec<f32> = (0..sw * sh)
        .map(|k| (100.0 + white[k] + 0.5 * white[k + sw]) as f32)
        .collect();
    let img: Vec<f32> = (0..w * h)
        .map(|k| sky[(k / w + m) * sw + k % w + m])
        .collect();
    for angle in [30.0, 89.9, -62.0] {
        let mut rng = pixel_stream(4, 0, PixelPurpose::Enhance);
        let f = Frame::rotated(w, h, angle);
        let out = warp(&img, w, h, &f, Fill::SkyNoise(&mut rng));
        let (_, fill) = rotated_regions(&f, w, h);
        let reference: Vec<f32> = (0..f.width * f.height)
            .map(|k| {
                let (x, y) = f.unmap((k % f.width) as f64, (k / f.width) as f64);
                bilinear(&sky, sw, sh, x + m as f64, y + m as f64)
            })
            .collect();
        let (_, sf, _) = contrast(&out, f.width, &fill);
        let (_, sr, _) = contrast(&reference, f.width, &fill);
        // Both over the same 250 000 or more pixels, each standard deviation with a
        // relative standard error near 1/sqrt(2 n), n its independent values (over 60 000
        // even counting a 2 x 2 footprint once): 0.3%, 0.4% for the ratio; the estimated
        // correlation moves the gain by about 0.1%. Measured: within 0.4% at these angles.
        // 2% is over four standard errors, and under a quarter of the 9% lost before.
        assert!(
            (sf / sr - 1.0).abs() < 0.02,
            "{angle} deg: sigma of the sky there {sr:.3}, of the fill {sf:.3}"
        );
    }
}

/// The box depends on the lit pixels only: a streak placed anywhere in a larger dark image
/// (negative ringing around it, as a resampling kernel leaves) gets the same box, shifted.
#[test]
fn flux_box_is_the_same_wherever_the_flux_sits() {
    let (w, h) = (23, 17);
    let streak: Vec<f32> = (0..w * h)
        .map(|k| {
            let (i, j) = ((k % w) as f32, (k / w) as f32);
            let d = (j - 0.6 * i - 2.0).abs();
            if d < 1.5 {
                100.0 / (1.0 + d + 0.1 * i)
            } else {
                -0.01
            }
        })
        .collect();
    let alone = flux_box(&streak, w, h, LABEL_SHARE).unwrap();
    let (big_w, big_h, ox, oy) = (200, 150, 91, 47);
    let mut big = vec![0.0f32; big_w * big_h];
    for j in 0..h {
        for i in 0..w {
            big[(j + oy) * big_w + i + ox] = streak[j * w + i];
        }
    }
    let placed = flux_box(&big, big_w, big_h, LABEL_SHARE).unwrap();
    let (dx, dy) = (ox as f64, oy as f64);
    assert_eq!(
        placed,
        BoxPx {
            x_min: alone.x_min + dx,
            y_min: alone.y_min + dy,
            x_max: alone.x_max + dx,
            y_max: alone.y_max + dy
        }
    );
}

#[test]
fn flux_box_holds_the_flux() {
    let (w, h) = (40, 30);
    let mut img = vec![0.0f32; w * h];
    img[10 * w + 5] = 1000.0;
    img[20 * w + 30] = 1000.0;
    img[15 * w + 17] = 1.0; // inside anyway
    let b = flux_box(&img, w, h, LABEL_SHARE).unwrap();
    assert_eq!(
        b,
        BoxPx {
            x_min: 4.5,
            y_min: 9.5,
            x_max: 30.5,
            y_max: 20.5
        }
    );
    assert!(flux_box(&vec![0.0; w * h], w, h, LABEL_SHARE).is_none());
    // A faint far pixel (0.05% of the flux) is left out: the box is no wider than needed.
    img[2 * w + 39] = 1.0;
    assert_eq!(flux_box(&img, w, h, LABEL_SHARE).unwrap(), b);
    assert_eq!(
        b.yolo_line(w, h),
        format!(
            "0 {:.6} {:.6} {:.6} {:.6}\n",
            18.0 / 40.0,
            15.5 / 30.0,
            26.0 / 40.0,
            11.0 / 30.0
        )
    );
}

#[test]
fn the_footprint_is_the_original_images_outline() {
    assert_eq!(Frame::original(64, 48).footprint(64, 48), None);
    let padded = Frame::padded(64, 48, 10).footprint(64, 48).unwrap();
    assert_eq!(
        padded,
        [[9.5, 9.5], [73.5, 9.5], [73.5, 57.5], [9.5, 57.5]],
        "the pad's inner edge"
    );
    let f = Frame::rotated(1024, 768, 33.0);
    let corners = f.footprint(1024, 768).unwrap();
    let outer = [[-0.5, -0.5], [1023.5, -0.5], [1023.5, 767.5], [-0.5, 767.5]];
    for (c, o) in corners.iter().zip(outer) {
        let (x, y) = f.unmap(c[0], c[1]);
        assert!(
            (x - o[0]).abs() < 1e-9 && (y - o[1]).abs() < 1e-9,
            "{c:?} {o:?}"
        );
        assert!(
            c.iter().all(|&v| (0.0..f.width as f64).contains(&v)),
            "{c:?}"
        );
    }
}
