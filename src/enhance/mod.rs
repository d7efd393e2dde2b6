//! FITS -> PNG enhancement for the detector (paper 3.3): square-root compression (fixed
//! pointing), the paper's "inverse logarithmic correction" with a per-image gain, CLAHE with
//! OpenCV's semantics, gamma 0.7, 8-bit PNG.

pub mod clahe;

use std::io::Write;

use image::ImageEncoder;
use image::codecs::png::{CompressionType, FilterType, PngEncoder};

/// Where the log stretch puts the median (background) level, on [0, 1]. Chosen so that the
/// background noise, and a faint streak on it, sit in the lower-middle grey levels while
/// bright stars are compressed instead of saturating.
pub const BACKGROUND_LEVEL: f64 = 0.25;

/// CLAHE tiles per axis that make sense on a 1024 px image (a campaign's and `soig enhance`'s
/// bound).
pub const CLAHE_TILES: std::ops::RangeInclusive<u32> = 1..=64;
/// Gamma values that leave something to see: O = I^gamma on 8 bits, beyond 20 (or below 1/20)
/// every pixel but the brightest (or the darkest) rounds to 0 (or 255).
pub const GAMMA: std::ops::RangeInclusive<f64> = 0.05..=20.0;

/// An 8-bit greyscale image, row-major, row 0 first (the top of the PNG).
#[derive(Clone, Debug, PartialEq)]
pub struct Gray8 {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<u8>,
}

/// The enhancement's knobs.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Square-root compression first (the paper applies it to fixed pointing only).
    pub sqrt: bool,
    /// CLAHE clip limit and tile grid, as `cv2.createCLAHE(clipLimit, tileGridSize)`.
    pub clahe_clip_limit: f64,
    pub clahe_tiles: [u32; 2],
    /// Power-law correction O = I^gamma on [0, 1].
    pub gamma: f64,
}

/// The whole enhancement chain of one ADU image.
pub fn enhance(adu: &[f32], width: usize, height: usize, settings: &Settings) -> Gray8 {
    // 1. Square-root compression.
    let v: Vec<f64> = if settings.sqrt {
        adu.iter().map(|&a| (a.max(0.0) as f64).sqrt()).collect()
    } else {
        adu.iter().map(|&a| a as f64).collect()
    };
    // 2. Normalise to [0, 1], then the log stretch with the gain that puts the median at
    //    BACKGROUND_LEVEL. ln(1 + g x) / ln(1 + g) maps 1 to 1 for every gain: never saturates.
    let (lo, hi) = v
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let span = if hi > lo { hi - lo } else { 1.0 };
    let mut sorted: Vec<f64> = v.iter().map(|&x| (x - lo) / span).collect();
    let mid = sorted.len() / 2;
    let median = *sorted.select_nth_unstable_by(mid, f64::total_cmp).1;
    let gain = log_gain_for(median, BACKGROUND_LEVEL);
    let denom = (1.0 + gain).ln();
    let stretched: Vec<u8> = v
        .iter()
        .map(|&x| {
            let n = (x - lo) / span;
            let y = if gain > 0.0 {
                (1.0 + gain * n).ln() / denom
            } else {
                n
            };
            (y * 255.0).round().clamp(0.0, 255.0) as u8
        })
        .collect();
    // 3. CLAHE.
    let [tx, ty] = settings.clahe_tiles;
    let equalised = clahe::clahe_u8(
        &stretched,
        width,
        height,
        settings.clahe_clip_limit,
        tx as usize,
        ty as usize,
    );
    // 4. Gamma on [0, 1].
    let lut: Vec<u8> = (0..256)
        .map(|i| ((i as f64 / 255.0).powf(settings.gamma) * 255.0).round() as u8)
        .collect();
    Gray8 {
        width,
        height,
        pixels: equalised.iter().map(|&p| lut[p as usize]).collect(),
    }
}

/// The gain g of y = ln(1 + g x) / ln(1 + g) that maps `x` to `target` (0 if x is already at
/// or above the target, i.e. no brightening needed).
pub fn log_gain_for(x: f64, target: f64) -> f64 {
    if x.is_nan() || x <= 0.0 || x >= target {
        return 0.0;
    }
    let f = |g: f64| (1.0 + g * x).ln() / (1.0 + g).ln() - target;
    // f increases with g from x - target < 0 towards 1 - target > 0.
    let (mut a, mut b) = (1e-9, 1.0);
    while f(b) < 0.0 && b < 1e15 {
        b *= 10.0;
    }
    for _ in 0..200 {
        let m = (a * b).sqrt();
        if f(m) < 0.0 { a = m } else { b = m }
    }
    (a * b).sqrt()
}

/// Encode as an 8-bit greyscale PNG (deterministic bytes for the same pixels).
pub fn png_bytes(img: &Gray8) -> Vec<u8> {
    let mut out = Vec::new();
    PngEncoder::new_with_quality(&mut out, CompressionType::Fast, FilterType::Adaptive)
        .write_image(
            &img.pixels,
            img.width as u32,
            img.height as u32,
            image::ExtendedColorType::L8,
        )
        .expect("encoding to memory cannot fail");
    out
}

/// Write PNG bytes to a file.
pub fn write_png(path: &std::path::Path, img: &Gray8) -> std::io::Result<()> {
    std::fs::File::create(path)?.write_all(&png_bytes(img))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_gain_hits_target() {
        for &x in &[1e-4, 0.003, 0.1, 0.2] {
            let g = log_gain_for(x, 0.25);
            let y = (1.0 + g * x).ln() / (1.0 + g).ln();
            assert!((y - 0.25).abs() < 1e-9, "x {x}: g {g} y {y}");
        }
        assert_eq!(log_gain_for(0.5, 0.25), 0.0);
        assert_eq!(log_gain_for(0.0, 0.25), 0.0);
    }

    #[test]
    fn chain_keeps_order_and_range() {
        // A flat background with one bright and one faint source: brighter stays brighter.
        let (w, h) = (64, 64);
        let mut adu = vec![200.0f32; w * h];
        for (i, a) in adu.iter_mut().enumerate() {
            *a += ((i * 7919) % 13) as f32 * 0.5;
        }
        adu[10 * w + 10] = 5000.0;
        adu[40 * w + 40] = 260.0;
        let paper = Settings {
            sqrt: true,
            clahe_clip_limit: 2.0,
            clahe_tiles: [8, 8],
            gamma: 0.7,
        };
        let img = enhance(&adu, w, h, &paper);
        assert_eq!(img.pixels.len(), w * h);
        let bg = img.pixels[30 * w + 5];
        assert!(img.pixels[10 * w + 10] > bg);
        assert!(img.pixels[40 * w + 40] > bg);
        let png = png_bytes(&img);
        assert_eq!(&png[1..4], b"PNG");
        assert_eq!(png, png_bytes(&img));
    }
}
