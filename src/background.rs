//! The sky background of the detector (paper 3.2.6 and 3.4): the paper's uniform synthetic
//! background, or real frames (semisynthetic images) whose noise, normalised by their own
//! exposure and scaled to the image's, replaces it.
//!
//! The frame gives the noise, not the sky level or the sky: pixels of its own stars, cosmic
//! rays and bad columns (beyond 3 robust sigma from the median, grown by 2 px) are replaced by
//! values drawn from its clean pixels, its large-scale structure (the median of 32 px cells,
//! interpolated) is subtracted, and the image gets the frame's fluctuations about its median
//! plus the sensor's sky level (the uniform model's mean), so a calibrated frame with a median
//! of 0 still gives a sky the enhancement can stretch.
//!
//! A frame smaller than the image is tiled periodically, each image starting the pattern at
//! its own random offset: a flat, calibrated frame has no level to jump at the tile edges, so
//! there is no seam and no black band (the paper's Fig. 9b shows one). Mirror tiling was
//! tried and rejected: it turns the faint star trails left in a real frame into symmetric
//! chevrons that no sky shows.

use std::path::{Path, PathBuf};

use fitsio::FitsFile;

use crate::imaging::robust_stats;
use crate::rng::{Purpose, stream};
use rand::RngExt;

/// A background frame that cannot be used, with its path.
#[derive(Debug, thiserror::Error)]
#[error("{}: {message}", path.display())]
pub struct FrameError {
    pub path: PathBuf,
    pub message: String,
}

/// A real background frame, loaded once per campaign.
#[derive(Debug)]
pub struct RealFrame {
    pub path: PathBuf,
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<f32>,
    pub exposure_s: f64,
    /// Robust median and standard deviation (1.4826 MAD) of the frame after masking, ADU.
    pub median: f64,
    pub sigma: f64,
    /// Pixels replaced because they held sources or defects.
    pub masked: usize,
}

/// Pixels this many robust sigma from the median are sources or defects...
const MASK_SIGMA: f64 = 3.0;
/// ...and so are their neighbours within this many pixels.
const MASK_GROW_PX: usize = 2;

impl RealFrame {
    /// Read a 2-D FITS frame and its exposure in seconds (`EXPTIME`, else `EXPOSURE` as NEOSSat
    /// writes it, else `AEXPTIME`). Non-finite pixels become the frame median.
    pub fn load(path: &Path) -> Result<RealFrame, FrameError> {
        let err = |e: &dyn std::fmt::Display| FrameError {
            path: path.to_path_buf(),
            message: e.to_string(),
        };
        let (mut pixels, rows, cols) = crate::fits::read_f32(path)
            .map_err(|e| err(&format!("not a readable 2-D FITS image ({e})")))?;
        let mut f = FitsFile::open(path).map_err(|e| err(&e))?;
        let hdu = f.primary_hdu().map_err(|e| err(&e))?;
        let exposure_s: f64 = ["EXPTIME", "EXPOSURE", "AEXPTIME"]
            .iter()
            .find_map(|k| hdu.read_key::<f64>(&mut f, k).ok())
            .ok_or_else(|| {
                err(&"no EXPTIME (or EXPOSURE) keyword: the frame's exposure is needed to scale its noise")
            })?;
        if !(exposure_s.is_finite() && exposure_s > 0.0) {
            return Err(err(&format!(
                "EXPTIME = {exposure_s} is not a positive exposure"
            )));
        }
        if rows < 2 || cols < 2 {
            return Err(err(&format!("a {cols} x {rows} frame is too small")));
        }
        let finite = pixels.iter().filter(|v| v.is_finite()).count();
        if finite * 2 < pixels.len() {
            return Err(err(&format!(
                "only {finite} of its {} pixels are finite numbers: not a usable noise frame",
                pixels.len()
            )));
        }
        let (median, sigma) = robust_stats(&pixels);
        let masked = mask_sources(&mut pixels, cols, rows, median, sigma);
        flatten(&mut pixels, cols, rows);
        // The noise statistics of what is left: the frame's sky noise.
        let (median, sigma) = robust_stats(&pixels);
        if !(median.is_finite() && sigma.is_finite() && sigma > 0.0) {
            return Err(err(&format!(
                "no noise left to use (median {median}, robust sigma {sigma}): a constant frame?"
            )));
        }
        Ok(RealFrame {
            path: path.to_path_buf(),
            width: cols,
            height: rows,
            pixels,
            exposure_s,
            median,
            sigma,
            masked,
        })
    }

    /// The frame's value at image pixel (x, y) for a tiling starting at `offset`.
    fn at(&self, x: usize, y: usize, offset: (usize, usize)) -> f32 {
        let (i, j) = ((x + offset.0) % self.width, (y + offset.1) % self.height);
        self.pixels[j * self.width + i]
    }

    /// The mean ADU this frame adds to a pixel of an image exposed `exposure_s`, on top of the
    /// sensor's sky level (see `background`): the mean of its scaled fluctuations about its
    /// median, close to 0 (the frame gives the noise, the sensor the level).
    pub fn level_adu(&self, exposure_s: f64) -> f64 {
        let mean = self.pixels.iter().map(|&v| v as f64).sum::<f64>() / self.pixels.len() as f64;
        (mean - self.median) * exposure_s / self.exposure_s
    }

    /// The background of a `width` x `height` image exposed `exposure_s`: the mirror-tiled
    /// frame's fluctuations about its median, normalised by its exposure and scaled to this one
    /// (paper 3.4), on the sky level `level_adu`.
    pub fn background(
        &self,
        width: usize,
        height: usize,
        exposure_s: f64,
        offset: (usize, usize),
        level_adu: f64,
    ) -> Vec<f32> {
        let k = exposure_s / self.exposure_s;
        let mut out = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                out.push((level_adu + (self.at(x, y, offset) as f64 - self.median) * k) as f32);
            }
        }
        out
    }
}

/// Replace non-finite pixels and pixels beyond `MASK_SIGMA` (grown by `MASK_GROW_PX`) by
/// clean pixels of the same frame, drawn by a fixed stream so the result is reproducible.
fn mask_sources(pixels: &mut [f32], width: usize, height: usize, median: f64, sigma: f64) -> usize {
    let bad = |v: f32| !v.is_finite() || ((v as f64 - median).abs() > MASK_SIGMA * sigma);
    let mut mask = vec![false; pixels.len()];
    let g = MASK_GROW_PX as isize;
    for y in 0..height {
        for x in 0..width {
            if bad(pixels[y * width + x]) {
                for dy in -g..=g {
                    for dx in -g..=g {
                        let (u, v) = (x as isize + dx, y as isize + dy);
                        if u >= 0 && v >= 0 && (u as usize) < width && (v as usize) < height {
                            mask[v as usize * width + u as usize] = true;
                        }
                    }
                }
            }
        }
    }
    let clean: Vec<f32> = pixels
        .iter()
        .zip(&mask)
        .filter(|(_, m)| !**m)
        .map(|(p, _)| *p)
        .collect();
    if clean.is_empty() {
        return 0;
    }
    let mut rng = stream(0, 0, Purpose::Noise);
    let mut n = 0;
    for (p, m) in pixels.iter_mut().zip(&mask) {
        if *m {
            *p = clean[rng.random_range(0..clean.len())];
            n += 1;
        }
    }
    n
}

/// Cell size of the large-scale structure removed from a frame, pixels.
const FLAT_CELL_PX: usize = 32;

/// Subtract the large-scale structure of a frame (the median of each cell, bilinearly
/// interpolated between cell centres) and add back the overall median: a flat frame tiles
/// without seams.
fn flatten(pixels: &mut [f32], width: usize, height: usize) {
    let (nx, ny) = (width.div_ceil(FLAT_CELL_PX), height.div_ceil(FLAT_CELL_PX));
    let mut cells = vec![0.0f64; nx * ny];
    for cy in 0..ny {
        for cx in 0..nx {
            let mut v: Vec<f32> = Vec::with_capacity(FLAT_CELL_PX * FLAT_CELL_PX);
            for y in cy * FLAT_CELL_PX..((cy + 1) * FLAT_CELL_PX).min(height) {
                v.extend_from_slice(
                    &pixels[y * width + cx * FLAT_CELL_PX
                        ..y * width + ((cx + 1) * FLAT_CELL_PX).min(width)],
                );
            }
            cells[cy * nx + cx] = robust_stats(&v).0;
        }
    }
    let overall = robust_stats(pixels).0;
    // Cell centres at (c + 0.5) * FLAT_CELL_PX - 0.5; clamp outside the outer centres.
    let coord = |p: usize, n: usize| {
        let u = ((p as f64 + 0.5) / FLAT_CELL_PX as f64 - 0.5).clamp(0.0, (n - 1) as f64);
        let i = (u.floor() as usize).min(n.saturating_sub(2));
        (i, (i + 1).min(n - 1), u - i as f64)
    };
    for y in 0..height {
        let (j0, j1, fy) = coord(y, ny);
        for x in 0..width {
            let (i0, i1, fx) = coord(x, nx);
            let top = cells[j0 * nx + i0] * (1.0 - fx) + cells[j0 * nx + i1] * fx;
            let bottom = cells[j1 * nx + i0] * (1.0 - fx) + cells[j1 * nx + i1] * fx;
            let level = top * (1.0 - fy) + bottom * fy;
            pixels[y * width + x] = (pixels[y * width + x] as f64 - level + overall) as f32;
        }
    }
}

/// The background model of a campaign, with its frames loaded.
#[derive(Debug)]
pub enum BackgroundModel {
    Uniform,
    Frames(Vec<RealFrame>),
}

impl BackgroundModel {
    /// The uniform model without frames, else every frame loaded.
    pub fn load(frames: &[PathBuf]) -> Result<BackgroundModel, FrameError> {
        if frames.is_empty() {
            return Ok(BackgroundModel::Uniform);
        }
        Ok(BackgroundModel::Frames(
            frames
                .iter()
                .map(|p| RealFrame::load(p))
                .collect::<Result<_, _>>()?,
        ))
    }
}

/// Which frame and where its tiling starts, drawn per image.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct FrameChoice {
    pub frame: usize,
    pub offset: (usize, usize),
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(w: usize, h: usize) -> RealFrame {
        RealFrame {
            path: PathBuf::from("x"),
            width: w,
            height: h,
            pixels: (0..w * h).map(|i| i as f32).collect(),
            exposure_s: 10.0,
            median: 0.0,
            sigma: 1.0,
            masked: 0,
        }
    }

    #[test]
    fn periodic_tiling_scaled_by_exposure_on_the_sky_level() {
        let f = frame(3, 2);
        let bg = f.background(8, 5, 10.0, (0, 0), 0.0);
        assert_eq!(
            bg[..8].to_vec(),
            vec![0.0, 1.0, 2.0, 0.0, 1.0, 2.0, 0.0, 1.0]
        );
        assert_eq!((bg[8], bg[16], bg[24]), (3.0, 0.0, 3.0));
        // Exposure scaling: half the exposure, half the fluctuation; the level is added.
        let half = f.background(8, 5, 5.0, (0, 0), 100.0);
        assert_eq!(half[2], 101.0);
        // An offset shifts the pattern.
        assert_eq!(
            f.background(4, 1, 10.0, (1, 1), 0.0),
            vec![4.0, 5.0, 3.0, 4.0]
        );
    }

    /// A 64 x 64 frame of `value`s with an EXPTIME of 10 s.
    fn frame_of(dir: &Path, name: &str, value: impl Fn(usize) -> f32) -> PathBuf {
        let path = dir.join(name);
        let pixels: Vec<f32> = (0..64 * 64).map(value).collect();
        let cards = vec![(
            "EXPTIME".to_string(),
            crate::fits::Card::Real(10.0),
            String::new(),
        )];
        crate::fits::write_image(&path, 64, 64, crate::fits::Pixels::F32(&pixels), &cards).unwrap();
        path
    }

    #[test]
    fn unusable_frames_are_refused_with_their_path() {
        let dir = tempfile::tempdir().unwrap();
        let cases = [
            (frame_of(dir.path(), "nan.fits", |_| f32::NAN), "finite"),
            (frame_of(dir.path(), "flat.fits", |_| 100.0), "no noise"),
        ];
        for (path, expect) in cases {
            let e = RealFrame::load(&path).unwrap_err().to_string();
            assert!(
                e.contains(path.to_str().unwrap()) && e.contains(expect),
                "{e}"
            );
        }
        let text = dir.path().join("text.fits");
        std::fs::write(&text, "not a FITS file").unwrap();
        let e = RealFrame::load(&text).unwrap_err().to_string();
        assert!(
            e.contains("text.fits") && e.contains("not a readable"),
            "{e}"
        );
        // A noisy frame loads.
        let ok = frame_of(dir.path(), "ok.fits", |i| 100.0 + ((i * 7919) % 13) as f32);
        assert!(RealFrame::load(&ok).is_ok());
    }

    #[test]
    fn loads_the_neossat_frame() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fixtures/neossat/NEOS_SCI_2024239174545_cord.fits");
        let f = RealFrame::load(&path).unwrap();
        assert_eq!((f.width, f.height), (512, 512));
        assert!((f.exposure_s - 10.0026).abs() < 1e-4, "{}", f.exposure_s);
        // physics.md: median 0, robust sigma about 31 ADU.
        assert!(
            f.median.abs() < 5.0 && (f.sigma - 31.0).abs() < 6.0,
            "{} {}",
            f.median,
            f.sigma
        );
        // Its stars and defects are masked: nothing beyond 3 sigma of the original is left.
        assert!(
            f.masked > 0 && f.masked < f.pixels.len() / 3,
            "{}",
            f.masked
        );
        // Flattened: the medians of the four quadrants agree within a tenth of the noise.
        let quad = |x0: usize, y0: usize| {
            let v: Vec<f32> = (y0..y0 + 256)
                .flat_map(|y| f.pixels[y * 512 + x0..y * 512 + x0 + 256].to_vec())
                .collect();
            robust_stats(&v).0
        };
        let q = [quad(0, 0), quad(256, 0), quad(0, 256), quad(256, 256)];
        let spread = q.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
            - q.iter().cloned().fold(f64::INFINITY, f64::min);
        assert!(spread < 0.1 * f.sigma, "{q:?}");
        let missing = RealFrame::load(Path::new("/nonexistent/frame.fits")).unwrap_err();
        let missing = missing.to_string();
        assert!(missing.contains("/nonexistent/frame.fits"), "{missing}");
    }
}
