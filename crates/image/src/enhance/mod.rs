//! FITS -> PNG enhancement for the detector (paper 3.3): square-root compression (fixed
//! pointing), the paper's "inverse logarithmic correction" with a per-image gain, CLAHE with
//! OpenCV's semantics, gamma 0.7, 8-bit PNG.

pub mod clahe;

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
    let stretched = log_stretch(adu, settings.sqrt);
    // 3. CLAHE.
    let [tx, ty] = settings.clahe_tiles;
    let mut pixels = clahe::clahe_u8(
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
    for p in &mut pixels {
        *p = lut[*p as usize];
    }
    Gray8 {
        width,
        height,
        pixels,
    }
}

/// Steps 1 and 2 of the chain: the square-root compression (when `sqrt`), normalisation to
/// [0, 1], and the log stretch whose gain puts the median at `BACKGROUND_LEVEL`, to 8 bits.
///
/// The grey level is a monotone function of the ADU (every step is), so nothing per pixel
/// needs the floating-point chain: the extremes and the median are found on the ADU values'
/// bits ([`MedianF32`]), the smallest value reaching each of the 255 levels by bisection,
/// and each pixel's level by a search among those 255 thresholds. The bytes are those of
/// computing every pixel's chain (`tests::log_stretch_by_sorting`) wherever libm's `ln` is
/// monotone (glibc's is, to the tests' every value): the whole enhancement of a quickstart
/// image went from 24.8 to 7.6 ms (`cargo bench enhance`). Frames with a non-finite value take
/// the per-pixel chain.
fn log_stretch(adu: &[f32], sqrt: bool) -> Vec<u8> {
    // 1. Square-root compression (the same expression for the median as for each pixel).
    let prepared = |a: f32| if sqrt { a.max(0.0) } else { a };
    let value = |a: f32| {
        let a = prepared(a) as f64;
        if sqrt { a.sqrt() } else { a }
    };
    if adu.is_empty() {
        return Vec::new();
    }
    // One pass for the extremes, the finiteness and the median's first radix digit.
    let mut finite = true;
    let (mut kmin, mut kmax) = (u32::MAX, 0);
    let mut median = MedianF32::new(adu.len());
    for &a in adu {
        finite &= a.is_finite();
        let k = total_order_key(prepared(a));
        (kmin, kmax) = (kmin.min(k), kmax.max(k));
        median.count_high(k);
    }
    median.pick_high();
    for &a in adu {
        median.count_low(total_order_key(prepared(a)));
    }
    let median = from_total_order_key(median.pick_low());
    // 2. Normalise to [0, 1], then the log stretch with the gain that puts the median at
    //    BACKGROUND_LEVEL. ln(1 + g x) / ln(1 + g) maps 1 to 1 for every gain: never saturates.
    // The extremes in the same order, on the bits (finite frames), or the chain's own fold.
    let (lo, hi) = if finite {
        (
            value(from_total_order_key(kmin)),
            value(from_total_order_key(kmax)),
        )
    } else {
        adu.iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &a| {
                let x = value(a);
                (l.min(x), h.max(x))
            })
    };
    let span = if hi > lo { hi - lo } else { 1.0 };
    let median = (value(median) - lo) / span;
    let gain = log_gain_for(median, BACKGROUND_LEVEL);
    let denom = (1.0 + gain).ln();
    let level = |a: f32| {
        let n = (value(a) - lo) / span;
        let y = if gain > 0.0 {
            (1.0 + gain * n).ln() / denom
        } else {
            n
        };
        grey_level(y * 255.0)
    };
    if !finite {
        return adu.iter().map(|&a| level(a)).collect();
    }
    // threshold[k]: the smallest key (over the frame's range) whose level is at least k; a
    // level never reached stays above every key.
    let level_of_key = |k: u32| level(from_total_order_key(k));
    let mut threshold = [u64::MAX; 257];
    for (k, t) in threshold.iter_mut().enumerate().take(256).skip(1) {
        let (mut a, mut b) = (kmin as u64, kmax as u64 + 1);
        while a < b {
            let m = (a + b) / 2;
            if level_of_key(m as u32) as usize >= k {
                b = m
            } else {
                a = m + 1
            }
        }
        if a <= kmax as u64 {
            *t = a;
        }
    }
    // Keys in 2^18 buckets over the frame's range: a bucket without a threshold inside is one
    // level (most pixels); the others count the thresholds from their first key's level.
    let shift = (64 - ((kmax - kmin) as u64 >> 18).leading_zeros()).min(32);
    let mut bucket_level = vec![(0u8, false); ((kmax - kmin) as usize >> shift) + 1];
    let mut l = 0;
    for (b, entry) in bucket_level.iter_mut().enumerate() {
        let first = kmin as u64 + ((b as u64) << shift);
        while threshold[l + 1] <= first {
            l += 1;
        }
        *entry = (l as u8, threshold[l + 1] < first + (1 << shift));
    }
    adu.iter()
        .map(|&a| {
            let key = total_order_key(prepared(a)) as u64;
            let (mut l, mixed) = bucket_level[((key - kmin as u64) >> shift) as usize];
            if mixed {
                while threshold[l as usize + 1] <= key {
                    l += 1;
                }
            }
            l
        })
        .collect()
}

/// `v.round().clamp(0.0, 255.0) as u8` without libm's `round` (a call on baseline x86-64)
/// or a branch (the fraction is a coin toss, mispredicted half the time: 16 ms an image): on
/// [0, 255] the fraction `v - trunc(v)` is exact, so rounding half away from zero is one
/// comparison. NaN gives 0, as `as u8` does.
fn grey_level(v: f64) -> u8 {
    let v = v.clamp(0.0, 255.0);
    let t = v as u32; // NaN: 0
    (t + (v - t as f64 >= 0.5) as u32) as u8
}

/// The element of rank `len / 2` of `len` values in `f32::total_cmp`'s order, as
/// `select_nth_unstable_by(len / 2, f32::total_cmp)` would return it: a radix selection on
/// their [`total_order_key`]s, 16 bits a pass, fed every key twice (`count_high`, then
/// `count_low`).
struct MedianF32 {
    rank: usize,
    high: u32,
    counts: Vec<u32>,
}

impl MedianF32 {
    fn new(len: usize) -> Self {
        MedianF32 {
            rank: len / 2,
            high: 0,
            counts: vec![0; (1 << 16) + 8],
        }
    }

    fn count_high(&mut self, key: u32) {
        self.counts[(key >> 16) as usize] += 1;
    }

    fn pick_high(&mut self) {
        self.high = pick(&self.counts[..1 << 16], &mut self.rank);
        self.counts.fill(0);
    }

    fn count_low(&mut self, key: u32) {
        // Keys of other buckets go to slots past the end: no branch to mispredict. Eight of
        // them, by the key's last bits, because most keys are elsewhere and increments of one
        // slot wait on each other (one slot took 2 ms of a 1024 px image).
        let slot = if key >> 16 == self.high {
            key & 0xffff
        } else {
            1 << 16 | (key & 7)
        };
        self.counts[slot as usize] += 1;
    }

    /// The median's key.
    fn pick_low(&mut self) -> u32 {
        self.high << 16 | pick(&self.counts[..1 << 16], &mut self.rank)
    }
}

/// A key whose unsigned order is `f32::total_cmp`'s: every bit of a negative flipped, only
/// the sign bit of a positive.
fn total_order_key(v: f32) -> u32 {
    let b = v.to_bits();
    if b >> 31 == 1 { !b } else { b | 1 << 31 }
}

fn from_total_order_key(k: u32) -> f32 {
    f32::from_bits(if k >> 31 == 1 { k & !(1 << 31) } else { !k })
}

/// The bucket holding the element of rank `rank`; `rank` becomes its rank within the bucket.
fn pick(counts: &[u32], rank: &mut usize) -> u32 {
    for (bucket, &c) in counts.iter().enumerate() {
        let c = c as usize;
        if *rank < c {
            return bucket as u32;
        }
        *rank -= c;
    }
    unreachable!("rank below the number of values")
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

    /// Steps 1-2 as first written: every value transformed and stored, the median by a
    /// selection over them, libm's round. `log_stretch` must give the same bytes.
    fn log_stretch_by_sorting(adu: &[f32], sqrt: bool) -> Vec<u8> {
        let v: Vec<f64> = if sqrt {
            adu.iter().map(|&a| (a.max(0.0) as f64).sqrt()).collect()
        } else {
            adu.iter().map(|&a| a as f64).collect()
        };
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
        v.iter()
            .map(|&x| {
                let n = (x - lo) / span;
                let y = if gain > 0.0 {
                    (1.0 + gain * n).ln() / denom
                } else {
                    n
                };
                (y * 255.0).round().clamp(0.0, 255.0) as u8
            })
            .collect()
    }

    #[test]
    fn log_stretch_gives_the_bytes_of_sorting_every_value() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha12Rng::seed_from_u64(7);
        let mut cases: Vec<Vec<f32>> = vec![
            vec![5.0],
            vec![3.0, 3.0, 3.0, 3.0],
            vec![-0.0, 0.0, -0.0, 0.0, 1.0],
            vec![-5.0, -1.0, 0.0, 2.0, 1e30, -1e30],
            vec![100.0, 100.5, 101.0, 100.25],
        ];
        for n in [2, 3, 10, 1001, 65_537] {
            // Sky-like values with repeats, negatives and a few bright sources.
            let v: Vec<f32> = (0..n)
                .map(|i| match i % 97 {
                    0 => rng.random_range(1e3f32..1e6),
                    1 => -rng.random_range(0f32..50.0),
                    2 => 120.0,
                    _ => 100.0 + rng.random_range(-10f32..10.0),
                })
                .collect();
            cases.push(v);
        }
        for v in &cases {
            for sqrt in [true, false] {
                assert_eq!(
                    log_stretch(v, sqrt),
                    log_stretch_by_sorting(v, sqrt),
                    "{v:?}"
                );
            }
        }
    }

    #[test]
    fn grey_level_rounds_as_libm() {
        for v in [
            -1.0,
            -0.5,
            -0.0,
            0.0,
            0.49999999999999994,
            0.5,
            1.5,
            2.5,
            254.5,
            254.49,
            255.0,
            300.0,
            f64::NAN,
            f64::INFINITY,
        ] {
            assert_eq!(grey_level(v), v.round().clamp(0.0, 255.0) as u8, "{v}");
        }
        for i in 0..100_000 {
            let v = i as f64 * 0.00255;
            assert_eq!(grey_level(v), v.round().clamp(0.0, 255.0) as u8, "{v}");
        }
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
