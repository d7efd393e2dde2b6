//! The final image frame (paper 3.3.6 and 4.2.1): the original image, the padded one (1024 ->
//! 1088 with noise around it), or the survey image rotated so star trails are horizontal and
//! expanded (1024 -> 1472) so no pixel is lost. Each is an affine map of pixel coordinates,
//! recorded in the truth sidecar and the FITS header, so detections map back to the original
//! pixels and, through the WCS, to the sky.

use rand::Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

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

    pub fn is_identity(&self) -> bool {
        self.kind == FrameKind::Original
    }
}

/// What fills the parts of the final image that the original does not cover.
pub enum Fill<'a, R: Rng> {
    Zero,
    /// Gaussian noise with the robust mean and standard deviation of the covered part of the
    /// resampled image (so the fill matches the sky it borders after interpolation smoothing).
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
            let (mean, sigma) = robust_stats(&out);
            let normal = Normal::new(mean, sigma).expect("finite robust sigma");
            for v in out.iter_mut().filter(|v| v.is_nan()) {
                *v = normal.sample(rng) as f32;
            }
        }
    }
    out
}

fn bilinear(img: &[f32], width: usize, height: usize, x: f64, y: f64) -> f32 {
    let x = x.clamp(0.0, (width - 1) as f64);
    let y = y.clamp(0.0, (height - 1) as f64);
    let (i, j) = (x.floor() as usize, y.floor() as usize);
    let (i1, j1) = ((i + 1).min(width - 1), (j + 1).min(height - 1));
    let (fx, fy) = ((x - i as f64) as f32, (y - j as f64) as f32);
    let at = |a: usize, b: usize| img[b * width + a];
    let top = at(i, j) * (1.0 - fx) + at(i1, j) * fx;
    let bottom = at(i, j1) * (1.0 - fx) + at(i1, j1) * fx;
    top * (1.0 - fy) + bottom * fy
}

/// Median and robust standard deviation (1.4826 MAD) of the finite pixels of an image: the sky
/// level and noise, unmoved by stars, which would inflate a plain standard deviation and make
/// the fill look noisier than the sky it borders.
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

/// A box in pixel coordinates, edges included: pixel i spans [i - 0.5, i + 0.5).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BoxPx {
    pub x_min: f64,
    pub y_min: f64,
    pub x_max: f64,
    pub y_max: f64,
}

impl BoxPx {
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

/// Share of the rendered debris flux the label box must hold.
pub const LABEL_SHARE: f64 = 0.99;

/// The label box of a source image (e.g. the noise-free debris electrons, in any frame): the
/// box between the `t` and `1 - t` flux quantiles of each axis, with the largest tail `t` for
/// which it still holds `share` of the flux. The tightest such box, no wider than needed. None
/// if the image holds no flux.
pub fn flux_box(img: &[f32], width: usize, height: usize, share: f64) -> Option<BoxPx> {
    let mut col = vec![0.0f64; width];
    let mut row = vec![0.0f64; height];
    // Summed-area table, one row and column of zeros in front.
    let mut sat = vec![0.0f64; (width + 1) * (height + 1)];
    for j in 0..height {
        let mut line = 0.0;
        for i in 0..width {
            let v = img[j * width + i].max(0.0) as f64;
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
    Some(BoxPx {
        x_min: x0 as f64 - 0.5,
        y_min: y0 as f64 - 0.5,
        x_max: x1 as f64 + 0.5,
        y_max: y1 as f64 + 0.5,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, stream};

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
        let mut rng = stream(1, 0, Purpose::Enhance);
        let mut noise = stream(2, 0, Purpose::Noise);
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
}
