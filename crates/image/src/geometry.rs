//! The final image frame (paper 3.3.6 and 4.2.1): the original image, the padded one (1024 ->
//! 1088 with noise around it), or the survey image rotated so star trails are horizontal and
//! expanded (1024 -> 1472) so no pixel is lost. Each is an affine map of pixel coordinates,
//! recorded in the truth sidecar and the FITS header, so detections map back to the original
//! pixels and, through the WCS, to the sky.

use rand::seq::SliceRandom;
use rand::{Rng, RngExt};
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

use crate::imaging::{bilinear, robust_stats};

/// Which final frame: the original image, padded with noise, or rotated and expanded.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum FrameKind {
    #[default]
    Original,
    Padded,
    Rotated,
}

impl FrameKind {
    /// The name a campaign file and the FITS header use.
    pub fn name(self) -> &'static str {
        match self {
            FrameKind::Original => "original",
            FrameKind::Padded => "padded",
            FrameKind::Rotated => "rotated",
        }
    }
}

/// The affine map from original pixel coordinates to final ones:
/// `x' = m[0][0] x + m[0][1] y + m[0][2]`, `y' = m[1][0] x + m[1][1] y + m[1][2]`
/// (pixel centres at integers in both frames).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Frame {
    pub kind: FrameKind,
    /// Rotation applied, degrees (the star-trail angle, undone).
    pub angle_deg: f64,
    pub width: usize,
    pub height: usize,
    pub matrix: [[f64; 3]; 2],
}

/// Output sizes are rounded up to this multiple, as the paper's 1472 = 46 x 32 (YOLO strides).
const SIZE_MULTIPLE: usize = 32;

impl Frame {
    /// The frame of a `width` x `height` image: `pad_px` is the padded frame's border, and
    /// `trail_angle_deg` the star-trail direction that the rotated frame makes horizontal.
    pub fn new(
        kind: FrameKind,
        width: usize,
        height: usize,
        pad_px: usize,
        trail_angle_deg: f64,
    ) -> Frame {
        match kind {
            FrameKind::Original => Frame::original(width, height),
            FrameKind::Padded => Frame::padded(width, height, pad_px),
            FrameKind::Rotated => Frame::rotated(width, height, trail_angle_deg),
        }
    }

    fn original(width: usize, height: usize) -> Frame {
        Frame {
            kind: FrameKind::Original,
            angle_deg: 0.0,
            width,
            height,
            matrix: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        }
    }

    /// `pad` pixels of noise on every side.
    fn padded(width: usize, height: usize, pad: usize) -> Frame {
        Frame {
            kind: FrameKind::Padded,
            angle_deg: 0.0,
            width: width + 2 * pad,
            height: height + 2 * pad,
            matrix: [[1.0, 0.0, pad as f64], [0.0, 1.0, pad as f64]],
        }
    }

    /// Rotate by `-trail_angle_deg` about the image centre so a trail along `trail_angle_deg`
    /// becomes horizontal, on a square canvas that holds the image at any angle (its
    /// diagonal, rounded up to a multiple of 32: 1024 -> 1472).
    fn rotated(width: usize, height: usize, trail_angle_deg: f64) -> Frame {
        let diag = (width as f64).hypot(height as f64);
        let side = (diag / SIZE_MULTIPLE as f64).ceil() as usize * SIZE_MULTIPLE;
        let (s, c) = trail_angle_deg.to_radians().sin_cos();
        let (cx, cy) = ((width as f64 - 1.0) / 2.0, (height as f64 - 1.0) / 2.0);
        let co = (side as f64 - 1.0) / 2.0;
        // (x', y') = R(-a) (x - cx, y - cy) + (co, co)
        Frame {
            kind: FrameKind::Rotated,
            angle_deg: trail_angle_deg,
            width: side,
            height: side,
            matrix: [[c, s, co - c * cx - s * cy], [-s, c, co + s * cx - c * cy]],
        }
    }

    pub fn map(&self, x: f64, y: f64) -> (f64, f64) {
        let m = &self.matrix;
        (
            m[0][0] * x + m[0][1] * y + m[0][2],
            m[1][0] * x + m[1][1] * y + m[1][2],
        )
    }

    /// The inverse map: final pixel coordinates back to the original image.
    pub fn unmap(&self, x: f64, y: f64) -> (f64, f64) {
        let m = &self.matrix;
        let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
        let (u, v) = (x - m[0][2], y - m[1][2]);
        (
            (m[1][1] * u - m[0][1] * v) / det,
            (-m[1][0] * u + m[0][0] * v) / det,
        )
    }

    /// The outline of the original `width` x `height` image in this frame (its pixels' outer
    /// edges, in pixel-centre coordinates, corners in order around it): where the frame holds
    /// the image and not the conversion's fill. None in the original frame.
    pub fn footprint(&self, width: usize, height: usize) -> Option<[[f64; 2]; 4]> {
        if self.is_identity() {
            return None;
        }
        let (w, h) = (width as f64 - 0.5, height as f64 - 0.5);
        let corner = |x: f64, y: f64| {
            let (u, v) = self.map(x, y);
            [u, v]
        };
        Some([
            corner(-0.5, -0.5),
            corner(w, -0.5),
            corner(w, h),
            corner(-0.5, h),
        ])
    }

    pub fn is_identity(&self) -> bool {
        self.kind == FrameKind::Original
    }

    /// Whether the frame interpolates between original pixels (else it copies them: the
    /// original frame, or one shifted by whole pixels as the padded one).
    pub fn resamples(&self) -> bool {
        let m = &self.matrix;
        let whole = |v: f64| v == v.round();
        let copies = m[0][0] == 1.0 && m[0][1] == 0.0 && m[1][0] == 0.0 && m[1][1] == 1.0;
        !(copies && whole(m[0][2]) && whole(m[1][2]))
    }
}

/// What fills the parts of the final image that the original does not cover.
pub enum Fill<'a, R: Rng> {
    Zero,
    /// Noise with the robust mean and standard deviation of the covered part of the resampled
    /// image: white where the frame copies pixels, resampled as the image where it
    /// interpolates, so the fill has the sky's spatial correlation too.
    SkyNoise(&'a mut R),
}

/// Resample an image into a frame: bilinear interpolation between pixel centres (as
/// `cv2.warpAffine` with INTER_LINEAR), the uncovered area filled. Integer shifts copy exactly.
pub fn warp<R: Rng>(
    img: &[f32],
    width: usize,
    height: usize,
    frame: &Frame,
    fill: Fill<R>,
) -> Vec<f32> {
    if frame.is_identity() {
        return img.to_vec();
    }
    let (wf, hf) = (width as f64, height as f64);
    let mut out = Vec::with_capacity(frame.width * frame.height);
    for j in 0..frame.height {
        for i in 0..frame.width {
            let (x, y) = frame.unmap(i as f64, j as f64);
            // Covered if the point falls in some original pixel [-0.5, n - 0.5).
            if x >= -0.5 && y >= -0.5 && x < wf - 0.5 && y < hf - 0.5 {
                out.push(bilinear(img, width, height, x, y));
            } else {
                out.push(f32::NAN);
            }
        }
    }
    match fill {
        Fill::Zero => out.iter_mut().filter(|v| v.is_nan()).for_each(|v| *v = 0.0),
        Fill::SkyNoise(rng) => {
            if frame.resamples() {
                fill_resampled_noise(&mut out, img, width, frame, rng);
            } else {
                let (mean, sigma) = robust_stats(&out);
                let normal = Normal::new(mean, sigma).expect("finite robust sigma");
                for v in out.iter_mut().filter(|v| v.is_nan()) {
                    *v = normal.sample(rng) as f32;
                }
            }
        }
    }
    out
}

/// Fill the NaN pixels of a resampled frame with sky resampled the same way: a lattice of
/// original pixel centres beyond the image, each node a pixel of the image drawn at random
/// (every finite pixel: a real frame's noise has a tail of hot and warm pixels, and a fill
/// drawn within 3 robust sigma lost it, its standard deviation 16.5-24.1 grey levels against
/// 28.7-37.6 inside, a step at the join where every false positive of 60 rotated
/// semisynthetic images sat; issue #30), read through the frame's bilinear map. White noise
/// around a bilinearly resampled sky has about 16% more pixel-to-pixel contrast than the sky
/// (sqrt 2 against ~1.2 for the neighbour difference over the sigma), enough to outline the
/// image in every PNG; this fill has the sky's correlation, and, drawn from the image's own
/// distribution, its mean and, tail included, its standard deviation: bilinear interpolation
/// keeps less of that between independent nodes than between the frame's correlated
/// neighbours (a fill 4% below the frame in the PNGs of 60 rotated survey images), which each
/// fill pixel's gain for its sub-pixel offset and the frame's neighbour correlation restores.
fn fill_resampled_noise<R: Rng>(
    out: &mut [f32],
    img: &[f32],
    width: usize,
    frame: &Frame,
    rng: &mut R,
) {
    let mut sky: Vec<f32> = img.iter().copied().filter(|v| v.is_finite()).collect();
    let holes: Vec<(usize, f64, f64)> = out
        .iter()
        .enumerate()
        .filter(|(_, v)| v.is_nan())
        .map(|(k, _)| {
            let (x, y) = frame.unmap((k % frame.width) as f64, (k / frame.width) as f64);
            (k, x, y)
        })
        .collect();
    if holes.is_empty() || sky.is_empty() {
        return;
    }
    // The lattice spans the nodes around every hole; only the nodes some hole reads get a
    // value.
    let (mut x0, mut y0, mut x1, mut y1) = (i64::MAX, i64::MAX, i64::MIN, i64::MIN);
    for &(_, x, y) in &holes {
        let (i, j) = (x.floor() as i64, y.floor() as i64);
        (x0, y0, x1, y1) = (x0.min(i), y0.min(j), x1.max(i + 1), y1.max(j + 1));
    }
    let lw = (x1 - x0 + 1) as usize;
    let at = |i: i64, j: i64| (j - y0) as usize * lw + (i - x0) as usize;
    let mut lattice = vec![f32::NAN; lw * (y1 - y0 + 1) as usize];
    let mut needed = vec![false; lattice.len()];
    for &(_, x, y) in &holes {
        let (i, j) = (x.floor() as i64, y.floor() as i64);
        for (a, b) in [(i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)] {
            needed[at(a, b)] = true;
        }
    }
    // Stratified draws: node k of n takes the frame's value at quantile (k + u) / n, the
    // values then shuffled over the nodes. The nodes hold the frame's distribution, each fill
    // its share of the hot-pixel tail: drawn independently, the few tail pixels of a fill
    // wandered in number from image to image, and its plain standard deviation (ADU) with
    // them (0.89-1.11 of the frame's over 60 rotated survey images, stratified 0.88-1.06,
    // both with the gain below; docs/semisynthetic/rotated-fill.md).
    sky.sort_unstable_by(f32::total_cmp);
    let n = needed.iter().filter(|&&b| b).count();
    let m = sky.len() as f64;
    let mut values: Vec<f32> = (0..n)
        .map(|k| {
            let q = (k as f64 + rng.random::<f64>()) / n as f64;
            sky[((q * m) as usize).min(sky.len() - 1)]
        })
        .collect();
    values.shuffle(rng);
    for (v, _) in lattice.iter_mut().zip(&needed).filter(|(_, n)| **n) {
        *v = values.pop().expect("one value per needed node");
    }
    // Interpolated between independent nodes, the fill keeps less variance than the frame
    // does between its correlated neighbours: each fill pixel's fluctuation is scaled about
    // the mean by the ratio for its sub-pixel offset, and kept within the frame's extremes
    // (which set the enhancement's stretch).
    let mean = (sky.iter().map(|&v| v as f64).sum::<f64>() / m) as f32;
    let (lo, hi) = (sky[0], sky[sky.len() - 1]);
    let rho = neighbour_correlation(img, width);
    for (k, x, y) in holes {
        let (i, j) = (x.floor() as i64, y.floor() as i64);
        let (fx, fy) = ((x - i as f64) as f32, (y - j as f64) as f32);
        let node = |a: i64, b: i64| lattice[at(a, b)];
        let top = node(i, j) * (1.0 - fx) + node(i + 1, j) * fx;
        let bottom = node(i, j + 1) * (1.0 - fx) + node(i + 1, j + 1) * fx;
        let v = top * (1.0 - fy) + bottom * fy;
        let g = correlation_gain(rho, fx as f64, fy as f64) as f32;
        out[k] = (mean + (v - mean) * g).clamp(lo, hi);
    }
}

/// How much more variance bilinear interpolation at sub-pixel offset (fx, fy) keeps between
/// pixels with neighbour correlations `rho` (horizontal, vertical, diagonal) than between
/// independent ones, as a factor on the standard deviation.
fn correlation_gain(rho: [f64; 3], fx: f64, fy: f64) -> f64 {
    let (ax, ay) = ((1.0 - fx).powi(2) + fx * fx, (1.0 - fy).powi(2) + fy * fy);
    let (bx, by) = (2.0 * fx * (1.0 - fx), 2.0 * fy * (1.0 - fy));
    let kept = ax * ay + bx * ay * rho[0] + ax * by * rho[1] + bx * by * rho[2];
    (kept.max(0.0) / (ax * ay)).sqrt()
}

/// The correlation of the sky's horizontal, vertical and diagonal (both, averaged) neighbours,
/// over the pairs of finite pixels within 5 robust sigma of the median: the noise the PNG
/// shows, not the hot pixels and stars that carry most of the plain variance.
fn neighbour_correlation(img: &[f32], width: usize) -> [f64; 3] {
    let height = img.len() / width;
    let (median, sigma) = robust_stats(img);
    let sky = |i: usize, j: usize| {
        let v = img[j * width + i] as f64 - median;
        (v.abs() <= 5.0 * sigma).then_some(v)
    };
    // Pearson's correlation of pixel (i, j) with pixel (i + dx, j + dy), dx >= 0.
    let corr = |dx: usize, dy: isize| {
        let mut s = [0.0f64; 6];
        for j in 0..height {
            let Some(j2) = j.checked_add_signed(dy).filter(|&j2| j2 < height) else {
                continue;
            };
            for i in 0..width.saturating_sub(dx) {
                if let (Some(a), Some(b)) = (sky(i, j), sky(i + dx, j2)) {
                    for (acc, v) in s.iter_mut().zip([1.0, a, b, a * a, b * b, a * b]) {
                        *acc += v;
                    }
                }
            }
        }
        let [n, sa, sb, saa, sbb, sab] = s;
        let (ma, mb) = (sa / n, sb / n);
        let r = (sab / n - ma * mb) / ((saa / n - ma * ma) * (sbb / n - mb * mb)).sqrt();
        // No pair, or a flat sky: nothing to correct for.
        if r.is_finite() { r } else { 0.0 }
    };
    [corr(1, 0), corr(0, 1), (corr(1, 1) + corr(1, -1)) / 2.0]
}

/// A box in pixel coordinates, edges included: pixel i spans [i - 0.5, i + 0.5).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BoxPx {
    pub x_min: f64,
    pub y_min: f64,
    pub x_max: f64,
    pub y_max: f64,
}

impl BoxPx {
    /// The box moved by (dx, dy) pixels: from a sub-image's coordinates to the image's.
    pub fn shifted(self, dx: f64, dy: f64) -> BoxPx {
        BoxPx {
            x_min: self.x_min + dx,
            y_min: self.y_min + dy,
            x_max: self.x_max + dx,
            y_max: self.y_max + dy,
        }
    }

    /// The YOLO line `0 xc yc w h`, normalised by the image size.
    pub fn yolo_line(&self, width: usize, height: usize) -> String {
        let (w, h) = (width as f64, height as f64);
        let xc = ((self.x_min + self.x_max) / 2.0 + 0.5) / w;
        let yc = ((self.y_min + self.y_max) / 2.0 + 0.5) / h;
        format!(
            "0 {:.6} {:.6} {:.6} {:.6}\n",
            xc,
            yc,
            (self.x_max - self.x_min) / w,
            (self.y_max - self.y_min) / h
        )
    }
}

/// A pixel value `flux_box` reads as f32: an image in any frame (f32), or the renderer's
/// photo-electron counts or expected flux (u32, f64: read `as f32` in place, not through a
/// 4 MB copy per image).
pub trait Flux: Copy {
    fn flux(self) -> f32;
}

impl Flux for f32 {
    fn flux(self) -> f32 {
        self
    }
}

impl Flux for u32 {
    fn flux(self) -> f32 {
        self as f32
    }
}

impl Flux for f64 {
    fn flux(self) -> f32 {
        self as f32
    }
}

/// Share of the rendered debris flux the label box must hold.
pub const LABEL_SHARE: f64 = 0.99;

/// The label box of a source image (e.g. the noise-free debris electrons, in any frame): the
/// box between the `t` and `1 - t` flux quantiles of each axis, with the largest tail `t` for
/// which it still holds `share` of the flux. The tightest such box, no wider than needed. None
/// if the image holds no flux.
pub fn flux_box<P: Flux>(img: &[P], width: usize, height: usize, share: f64) -> Option<BoxPx> {
    // Only the rectangle around the lit pixels is tabulated: a streak covers a sliver of the
    // image, and the zeros outside it change no sum, so the box (and its bits) is the one a
    // whole-image table gives (that table was 8.4 MB per 1024 px image).
    let stride = width;
    if stride == 0 {
        return None;
    }
    let lit = |v: &P| v.flux() > 0.0;
    let (mut x_first, mut x_last, mut y_first, mut y_last) = (stride, 0, height, 0);
    for (j, row) in img.chunks_exact(stride).take(height).enumerate() {
        if let Some(i) = row.iter().position(lit) {
            let i_last = row.iter().rposition(lit).unwrap_or(i);
            (x_first, x_last) = (x_first.min(i), x_last.max(i_last));
            (y_first, y_last) = (y_first.min(j), j);
        }
    }
    if y_first > y_last {
        return None;
    }
    let (width, height) = (x_last - x_first + 1, y_last - y_first + 1);
    let mut col = vec![0.0f64; width];
    let mut row = vec![0.0f64; height];
    // Summed-area table, one row and column of zeros in front.
    let mut sat = vec![0.0f64; (width + 1) * (height + 1)];
    for j in 0..height {
        let mut line = 0.0;
        for i in 0..width {
            let v = img[(j + y_first) * stride + i + x_first].flux().max(0.0) as f64;
            col[i] += v;
            row[j] += v;
            line += v;
            sat[(j + 1) * (width + 1) + i + 1] = sat[j * (width + 1) + i + 1] + line;
        }
    }
    let total = sat[sat.len() - 1];
    if total <= 0.0 {
        return None;
    }
    let quantiles = |hist: &[f64], cut: f64| {
        let mut acc = 0.0;
        let lo = hist.iter().position(|&c| {
            acc += c;
            acc > cut
        });
        acc = 0.0;
        let hi = hist.iter().rposition(|&c| {
            acc += c;
            acc > cut
        });
        (
            lo.unwrap_or(0),
            hi.unwrap_or(hist.len() - 1).max(lo.unwrap_or(0)),
        )
    };
    let box_at = |tail: f64| {
        let (x0, x1) = quantiles(&col, tail * total);
        let (y0, y1) = quantiles(&row, tail * total);
        let w1 = width + 1;
        let inside = sat[(y1 + 1) * w1 + x1 + 1] - sat[y0 * w1 + x1 + 1] - sat[(y1 + 1) * w1 + x0]
            + sat[y0 * w1 + x0];
        ((x0, x1, y0, y1), inside / total)
    };
    // Bisection on the tail: the box shrinks, and holds less, as the tail grows.
    let (mut ok, mut too_far) = (0.0, (1.0 - share).max(0.0));
    if box_at(too_far).1 >= share {
        ok = too_far;
    } else {
        for _ in 0..40 {
            let mid = (ok + too_far) / 2.0;
            if box_at(mid).1 >= share {
                ok = mid;
            } else {
                too_far = mid;
            }
        }
    }
    let ((x0, x1, y0, y1), _) = box_at(ok);
    let (x0, x1, y0, y1) = (x0 + x_first, x1 + x_first, y0 + y_first, y1 + y_first);
    Some(BoxPx {
        x_min: x0 as f64 - 0.5,
        y_min: y0 as f64 - 0.5,
        x_max: x1 as f64 + 0.5,
        y_max: y1 as f64 + 0.5,
    })
}

#[cfg(test)]
mod tests;
