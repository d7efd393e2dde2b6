//! The sky background of the detector (paper 3.2.6 and 3.4): the paper's uniform synthetic
//! background, or real frames (semisynthetic images) whose noise matrix, normalised by its own
//! exposure and scaled to the image's, replaces it.
//!
//! A frame is prepared once per run (`prepare`): its prescan/overscan is trimmed (the header's
//! `TRIMSEC`, else `DATASEC`, then edge columns whose level steps away from the sky's, found
//! from column medians); its large-scale structure (a gradient, a dark's row drift) is
//! flattened to its median; a science frame's sources and star trails (connected faint
//! structure of the smoothed frame, and fainter lines and arcs found by a line filter along
//! many orientations, `trails`) are replaced by
//! clean pixels of their own neighbourhood, while a dark frame (shutter closed) is the
//! sensor's noise as it is, hot pixels included. Per image only the cheap fill runs (`fill`):
//! overlapping blocks from random places of the field, cross-faded, so any image size is
//! covered without a seam, a repeat or a black band (the paper's Fig. 9b shows one).
//!
//! The image gets the frame's noise matrix scaled by exposure, level included (paper 3.4):
//! `level_adu` is that level, `sigma` the frame's robust noise.

mod fill;
mod mask;
mod prepare;
mod trails;

/// Rounds of trail masking on a filled frame at most (see `RealFrame::load`).
const MAX_TRAIL_ROUNDS: usize = 12;

use std::path::{Path, PathBuf};

use fitsio::FitsFile;
use soig_base::rng::PixelRng;

pub use prepare::Region;
use soig_image::imaging::robust_stats;

/// A background frame that cannot be used, with its path.
#[derive(Debug, thiserror::Error)]
#[error("{}: {message}", path.display())]
pub struct FrameError {
    pub path: PathBuf,
    pub message: String,
}

/// A real background frame, prepared once per campaign.
#[derive(Debug)]
pub struct RealFrame {
    pub path: PathBuf,
    /// The file's name and sha256: what the truth records (not the path, which depends on
    /// the directory soig runs from).
    pub name: String,
    pub sha256: String,
    /// Size after trimming.
    pub width: usize,
    pub height: usize,
    /// The part of the file's image kept (prescan/overscan trimmed), 0-based.
    pub kept: Region,
    /// A dark frame (shutter closed): used as it is, no sources masked.
    pub dark: bool,
    pub pixels: Vec<f32>,
    pub exposure_s: f64,
    /// Mean of the prepared frame, ADU at its own exposure: its level.
    pub mean: f64,
    /// Robust median and standard deviation (1.4826 MAD) of the prepared frame, ADU.
    pub median: f64,
    pub sigma: f64,
    /// Pixels replaced because they held sources, trails or defects.
    pub masked: usize,
    /// Which pixels of `pixels` were replaced (row-major, `width * height`).
    pub filled: Vec<bool>,
}

impl RealFrame {
    /// Read a 2-D FITS frame and its exposure in seconds (`EXPTIME`, else `EXPOSURE` as NEOSSat
    /// writes it, else `AEXPTIME`), and prepare its noise field (module doc).
    pub fn load(path: &Path) -> Result<RealFrame, FrameError> {
        let err = |e: &dyn std::fmt::Display| FrameError {
            path: path.to_path_buf(),
            message: e.to_string(),
        };
        let (raw, rows, cols) = soig_image::fits::read_f32(path).map_err(|e| match e {
            fitsio::errors::Error::Message(m) => err(&m),
            e => err(&format!("not a readable 2-D FITS image ({e})")),
        })?;
        let safe = soig_image::fits::CfitsioName::to_read(path).map_err(|e| err(&e))?;
        let mut f = FitsFile::open(&safe.name).map_err(|e| err(&e))?;
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
        let mut text = |k: &str| hdu.read_key::<String>(&mut f, k).ok();
        let section = ["TRIMSEC", "DATASEC"]
            .iter()
            .find_map(|k| text(k).map(|s| (*k, s)));
        let dark = text("SHUTTER").is_some_and(|s| s.trim_start().starts_with('1'))
            || ["OBJECT", "IMAGETYP"]
                .iter()
                .any(|k| text(k).is_some_and(|s| s.trim().eq_ignore_ascii_case("dark")));
        if rows < 2 || cols < 2 {
            return Err(err(&format!("a {cols} x {rows} frame is too small")));
        }
        let finite = raw.iter().filter(|v| v.is_finite()).count();
        if finite * 2 < raw.len() {
            return Err(err(&format!(
                "only {finite} of its {} pixels are finite numbers: not a usable noise frame",
                raw.len()
            )));
        }
        let data = match section {
            Some((key, s)) => Region::from_fits_section(&s, cols, rows).ok_or_else(|| {
                err(&format!(
                    "{key} = '{s}' is not a section of its {cols} x {rows} image"
                ))
            })?,
            None => Region {
                x0: 0,
                x1: cols,
                y0: 0,
                y1: rows,
            },
        };
        let pixels = data.crop(&raw, cols);
        let (left, right) = prepare::edge_columns(&pixels, data.width(), data.height());
        let kept = Region {
            x0: data.x0 + left,
            x1: data.x1 - right,
            ..data
        };
        let (width, height) = (kept.width(), kept.height());
        let mut pixels = kept.crop(&raw, cols);
        // Non-finite pixels (if any) are masked and filled like sources.
        let mut mask: Vec<bool> = pixels.iter().map(|v| !v.is_finite()).collect();
        let (m, _) = robust_stats(&pixels);
        for (p, bad) in pixels.iter_mut().zip(&mask) {
            if *bad {
                *p = m as f32;
            }
        }
        prepare::flatten(&mut pixels, width, height);
        if !dark {
            mask = prepare::source_mask(&pixels, width, height)
                .into_iter()
                .zip(mask)
                .map(|(a, b)| a || b)
                .collect();
        }
        let flattened = pixels.clone();
        let mut masked = prepare::fill_masked(&mut pixels, &mask, width, height);
        // Again: the fill moved the local medians where much was masked.
        prepare::flatten(&mut pixels, width, height);
        // Bright trails hide fainter ones beside and under them: look again on the filled
        // frame, and fill the original anew with the grown mask, until a round adds less than
        // 0.1% of the frame (the calibrated frame takes 9 rounds, the raw science frame 4).
        for _ in 0..if dark { 0 } else { MAX_TRAIL_ROUNDS } {
            let more = trails::trail_mask(&pixels, width, height, trails::Rounds::Later);
            let new = more
                .iter()
                .zip(&mask)
                .filter(|&(m, old)| *m && !old)
                .count();
            if new * 1000 < pixels.len() {
                break;
            }
            mask.iter_mut().zip(more).for_each(|(m, more)| *m |= more);
            pixels.clone_from(&flattened);
            masked = prepare::fill_masked(&mut pixels, &mask, width, height);
            prepare::flatten(&mut pixels, width, height);
        }
        // The noise statistics of what is left: the frame's noise.
        let (median, sigma) = robust_stats(&pixels);
        if !(median.is_finite() && sigma.is_finite() && sigma > 0.0) {
            return Err(err(&format!(
                "no noise left to use (median {median}, robust sigma {sigma}): a constant frame?"
            )));
        }
        let mean = pixels.iter().map(|&v| v as f64).sum::<f64>() / pixels.len() as f64;
        let sha256 = soig_base::hash::sha256_file(path).map_err(|e| err(&e))?.0;
        Ok(RealFrame {
            path: path.to_path_buf(),
            name: path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            sha256,
            width,
            height,
            kept,
            dark,
            pixels,
            exposure_s,
            mean,
            median,
            sigma,
            masked,
            filled: mask,
        })
    }

    /// Exposure scale from this frame to an image exposed `exposure_s` (paper 3.4).
    fn scale(&self, exposure_s: f64) -> f64 {
        exposure_s / self.exposure_s
    }

    /// The mean level this frame contributes to a pixel of an image exposed `exposure_s`, ADU.
    pub fn level_adu(&self, exposure_s: f64) -> f64 {
        self.mean * self.scale(exposure_s)
    }

    /// The background of a `width` x `height` image exposed `exposure_s`: the frame's noise
    /// matrix normalised by its exposure and scaled to this one (paper 3.4), filled from
    /// random blocks of the frame (`fill`) on a grid starting at `phase`.
    pub fn background(
        &self,
        width: usize,
        height: usize,
        exposure_s: f64,
        phase: (usize, usize),
        rng: &mut PixelRng,
    ) -> Vec<f32> {
        let field = fill::Field {
            pixels: &self.pixels,
            width: self.width,
            height: self.height,
            mean: self.mean,
        };
        let k = self.scale(exposure_s);
        let level = self.level_adu(exposure_s);
        fill::fluctuations(&field, width, height, phase, rng)
            .into_iter()
            .map(|d| (level + d as f64 * k) as f32)
            .collect()
    }
}

/// The background model of a campaign, with its frames loaded.
#[derive(Debug)]
pub enum BackgroundModel {
    Uniform,
    Frames(Vec<RealFrame>),
}

/// Most pixels all background frames may hold together: 2^28, 256 NEOSSat-sized frames, about
/// 3 GB with the noise field prepared for each.
pub const MAX_BACKGROUND_PIXELS: u64 = 1 << 28;

impl BackgroundModel {
    /// The uniform model without frames, else every frame loaded.
    pub fn load(frames: &[PathBuf]) -> Result<BackgroundModel, FrameError> {
        if frames.is_empty() {
            return Ok(BackgroundModel::Uniform);
        }
        // Every frame stays in memory for the whole run: bound them all together, so that
        // 2000 frames fail at once with a message instead of exhausting memory.
        let mut loaded = Vec::with_capacity(frames.len());
        let mut pixels = 0usize;
        for p in frames {
            let f = RealFrame::load(p)?;
            pixels += f.width * f.height;
            if pixels as u64 > MAX_BACKGROUND_PIXELS {
                return Err(FrameError {
                    path: p.clone(),
                    message: format!(
                        "the background frames up to this one hold {pixels} pixels, more than the {MAX_BACKGROUND_PIXELS} (~{} GB in memory) soig keeps: use fewer frames",
                        (MAX_BACKGROUND_PIXELS * 12) >> 30
                    ),
                });
            }
            loaded.push(f);
        }
        Ok(BackgroundModel::Frames(loaded))
    }
}

/// Which frame, and the phase of its block grid, drawn per image.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct FrameChoice {
    pub frame: usize,
    pub offset: (usize, usize),
}

#[cfg(test)]
mod tests {
    use super::*;
    use soig_base::rng::{PixelPurpose, pixel_stream};

    /// A prepared 300 x 300 frame of constant level 100 plus a ramp-free pattern, 10 s.
    fn frame() -> RealFrame {
        let pixels: Vec<f32> = (0..300 * 300)
            .map(|i| 100.0 + ((i * 7919) % 13) as f32 - 6.0)
            .collect();
        RealFrame {
            path: PathBuf::from("x"),
            name: "x".into(),
            sha256: String::new(),
            width: 300,
            height: 300,
            kept: Region {
                x0: 0,
                x1: 300,
                y0: 0,
                y1: 300,
            },
            dark: false,
            pixels,
            exposure_s: 10.0,
            mean: 100.0,
            median: 100.0,
            sigma: 3.7,
            masked: 0,
            filled: vec![false; 300 * 300],
        }
    }

    #[test]
    fn the_noise_matrix_is_scaled_by_exposure_level_included() {
        let f = frame();
        assert_eq!(f.level_adu(5.0), 50.0);
        let bg = |t: f64| {
            let mut rng = pixel_stream(1, 2, PixelPurpose::Noise);
            f.background(700, 500, t, (3, 4), &mut rng)
        };
        let (full, half) = (bg(10.0), bg(5.0));
        // Same blocks, half the exposure: every pixel is half (paper 3.4).
        for (a, b) in full.iter().zip(&half) {
            assert!((a / 2.0 - b).abs() < 1e-3, "{a} {b}");
        }
        let mean = full.iter().map(|&v| v as f64).sum::<f64>() / full.len() as f64;
        // The pattern's values are -6..6 about 100: the mean of 350000 of them is within 0.1.
        assert!((mean - 100.0).abs() < 0.1, "{mean}");
    }

    /// A 64 x 64 frame of `value`s with an EXPTIME of 10 s.
    fn frame_of(dir: &Path, name: &str, value: impl Fn(usize) -> f32) -> PathBuf {
        let path = dir.join(name);
        let pixels: Vec<f32> = (0..64 * 64).map(value).collect();
        let cards = vec![(
            "EXPTIME".to_string(),
            soig_image::fits::Card::Real(10.0),
            String::new(),
        )];
        soig_image::fits::write_image(
            &path,
            64,
            64,
            soig_image::fits::Pixels::F32(&pixels),
            &cards,
        )
        .unwrap();
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
            e.contains("text.fits") && e.contains("not a FITS file"),
            "{e}"
        );
        // A noisy frame loads.
        let ok = frame_of(dir.path(), "ok.fits", |i| 100.0 + ((i * 7919) % 13) as f32);
        assert!(RealFrame::load(&ok).is_ok());
    }

    fn fixture(name: &str) -> RealFrame {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../tests/fixtures/neossat")
            .join(name);
        RealFrame::load(&path).unwrap()
    }

    /// The medians of a frame's four quadrants agree within `share` of its noise: flat.
    fn assert_flat(f: &RealFrame, share: f64) {
        let (hw, hh) = (f.width / 2, f.height / 2);
        let quad = |x0: usize, y0: usize| {
            let v: Vec<f32> = (y0..y0 + hh)
                .flat_map(|y| f.pixels[y * f.width + x0..y * f.width + x0 + hw].to_vec())
                .collect();
            robust_stats(&v).0
        };
        let q = [quad(0, 0), quad(hw, 0), quad(0, hh), quad(hw, hh)];
        let spread = q.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
            - q.iter().cloned().fold(f64::INFINITY, f64::min);
        assert!(spread < share * f.sigma, "{}: {q:?}", f.name);
    }

    #[test]
    fn loads_the_calibrated_neossat_frame() {
        let f = fixture("NEOS_SCI_2024239174545_cord.fits");
        // No section keywords and no stepped edge columns: nothing trimmed.
        assert_eq!((f.width, f.height, f.dark), (512, 512, false));
        assert!((f.exposure_s - 10.0026).abs() < 1e-4, "{}", f.exposure_s);
        // physics.md: median 0, robust sigma about 31 ADU with its trails; without them less.
        // The calibration subtracted a sky level that held the arcs' light too, so the sky
        // between them sits below 0: -8 ADU (-0.35 sigma) with every round of trail masking.
        assert!(
            (-10.0..5.0).contains(&f.median) && (20.0..31.0).contains(&f.sigma),
            "{} {}",
            f.median,
            f.sigma
        );
        // Its stars and dense, overlapping arcs are masked: half the frame (50%, measured),
        // not most of it.
        assert!(
            f.masked > 0 && f.masked < f.pixels.len() * 6 / 10,
            "{}",
            f.masked
        );
        assert_flat(&f, 0.1);
        let missing = RealFrame::load(Path::new("/nonexistent/frame.fits")).unwrap_err();
        let missing = missing.to_string();
        assert!(missing.contains("/nonexistent/frame.fits"), "{missing}");
    }

    /// The raw dark frame: `TRIMSEC = '[17:1088,1:1030]'` drops the 16 overscan columns
    /// (column medians ~1677 ADU, sd 18), and the column statistics the shadowed columns the
    /// header keeps at both edges (medians 1680-1906 against the sky's ~2080).
    #[test]
    fn the_dark_frame_is_trimmed_and_kept_as_it_is() {
        let f = fixture("NEOSSAT_240__30_2020214095318.fits");
        assert!(f.dark);
        assert_eq!((f.kept.y0, f.kept.y1), (0, 1030));
        assert!(
            (37..=40).contains(&f.kept.x0) && (1063..=1068).contains(&f.kept.x1),
            "{:?}",
            f.kept
        );
        assert_eq!(f.masked, 0);
        assert!((f.exposure_s - 28.007).abs() < 1e-6);
        // What is left is sky-free dark + bias (~2080 ADU) with no overscan level in it: every
        // column median within 60 ADU (5 column-median sd) of the frame's.
        for x in 0..f.width {
            let col: Vec<f32> = (0..f.height).map(|y| f.pixels[y * f.width + x]).collect();
            let m = robust_stats(&col).0;
            assert!(
                (m - f.median).abs() < 60.0,
                "column {x}: {m} vs {}",
                f.median
            );
        }
        assert!((f.median - 2080.0).abs() < 40.0, "{}", f.median);
        assert_flat(&f, 0.1);
    }

    /// The raw 187 s science frame: `TRIMSEC = '[41:1064,1:1020]'` (1024 columns of sky, the
    /// rest prescan/overscan at ~1700 and ~3600 ADU); its gradient is flattened and its trails
    /// and bright streak are masked.
    #[test]
    fn the_science_frame_is_trimmed_flattened_and_masked() {
        let f = fixture("NEOSSAT_240__30_2026025124741.fits");
        assert!(!f.dark);
        assert_eq!(
            (f.kept.x0, f.kept.x1, f.width, f.height),
            (40, 1064, 1024, 1020)
        );
        assert_flat(&f, 0.1);
        let share = f.masked as f64 / f.pixels.len() as f64;
        // Its 3-sigma pixels (hot pixels, mostly) are ~6%; the trails and streak ~10%.
        assert!((0.1..0.35).contains(&share), "{share}");
        // Nothing bright is left (the streak saturates, ~50000 ADU above the sky): the brightest
        // pixel is a noise pixel within the pixel mask's cut, 3 robust sigma of the unmasked
        // frame (1684 ADU, 4.6 sigma of the masked one's 1107) plus the second flattening.
        let max = f.pixels.iter().cloned().fold(f32::MIN, f32::max) as f64;
        assert!(
            max - f.median < 6.0 * f.sigma,
            "{max} {} {}",
            f.median,
            f.sigma
        );
    }
}
