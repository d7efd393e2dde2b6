//! `soig detect`: soig's detectors on real frames (FITS of any numeric type, PNG).
//!
//! A FITS frame's sky region (`frames`) is enhanced with the campaign's enhancement (soig's
//! defaults without a campaign) into the 8-bit image the detectors were made for; a PNG is
//! taken as already enhanced. Nothing of soig's own sensor is assumed: the streak detector's
//! PSF width is the frame's, from `--psf-fwhm-px`, or `--psf-fwhm-arcsec` over the pixel scale
//! (`--pixel-scale-arcsec`, else the WCS's). YOLO letterboxes a frame of any size into its
//! input as Ultralytics' `predict` does and maps the boxes back (`detect::yolo`).
//!
//! Every position is in the file's own pixel grid, in pixel-edge coordinates (Ultralytics'
//! xyxy: pixel `i` spans `[i, i + 1]`; FITS pixel `p` is centred at `p - 0.5`), and through
//! the frame's TAN WCS, when it has one, on the sky. `output` writes the files.

pub mod catalog;
mod output;

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};

use crate::campaign::Detect;
use crate::detect::detector::Frame as DetectorFrame;
use crate::detect::streak::{Dropped, OwnTrails, StreakParams, detect_streaks_explained};
use crate::detect::yolo::{YoloDetector, YoloParams};
use crate::detect::{Detection, Detector, Stars, StreakDetector};
use crate::enhance::{self, Gray8};
use crate::frames::{Frame, RegionPixels};
use crate::verbs::plan::{Plan, yolo_params};

/// Epoch of Gaia DR3's positions, the default of `--catalog-epoch`.
pub const GAIA_DR3_EPOCH: f64 = 2016.0;

/// FWHM of a Gaussian over its sigma, 2 sqrt(2 ln 2).
const FWHM_PER_SIGMA: f64 = 2.354_820_045_030_949;

/// Which detectors to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Which {
    Streak,
    Yolo,
    All,
}

/// The frame's optics as the user gives them; what is not given comes from the header.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Optics {
    pub psf_fwhm_px: Option<f64>,
    pub psf_fwhm_arcsec: Option<f64>,
    pub pixel_scale_arcsec: Option<f64>,
}

impl Optics {
    /// Each value given must be a positive, finite number.
    fn check(&self) -> anyhow::Result<()> {
        for (name, v) in [
            ("--psf-fwhm-px", self.psf_fwhm_px),
            ("--psf-fwhm-arcsec", self.psf_fwhm_arcsec),
            ("--pixel-scale-arcsec", self.pixel_scale_arcsec),
        ] {
            if let Some(v) = v
                && !(v.is_finite() && v > 0.0)
            {
                bail!("{name} {v}: must be a positive number");
            }
        }
        Ok(())
    }
}

/// Everything `soig detect` does to every frame.
#[derive(Clone, Debug)]
pub struct Options {
    pub which: Which,
    pub model: Option<PathBuf>,
    pub enhance: enhance::Settings,
    pub streak: StreakParams,
    pub yolo: YoloParams,
    pub optics: Optics,
    /// Direction of star trails in the image axes, degrees (see `detect::streak`), if known.
    pub star_trail_angle_deg: Option<f64>,
    /// The campaign the settings came from, for the record.
    pub campaign: Option<PathBuf>,
    /// Record why the streak detector dropped each segment it refined (`--explain`).
    pub explain: bool,
    /// A star catalogue CSV for the star-aware streak detector (`--catalog`, module
    /// `catalog`), and the Julian year of its positions.
    pub catalog: Option<PathBuf>,
    pub catalog_epoch_jyear: f64,
}

impl Options {
    /// The plan's enhancement and detector settings (its campaign's), or soig's defaults
    /// without one.
    pub fn new(plan: Option<&Plan>, which: Which, model: Option<PathBuf>) -> Options {
        let default = Detect::default();
        let (enhance, streak, yolo) = match plan {
            Some(p) => (p.enhance.clone(), p.detect.streak.clone(), p.detect.yolo),
            None => (
                crate::experiment::enhance_settings(None),
                default.streak.clone(),
                yolo_params(&default),
            ),
        };
        Options {
            which,
            model,
            enhance,
            streak,
            yolo,
            optics: Optics::default(),
            star_trail_angle_deg: None,
            campaign: plan.map(|p| p.source.clone()),
            explain: false,
            catalog: None,
            catalog_epoch_jyear: GAIA_DR3_EPOCH,
        }
    }
}

/// Streak-detector knobs from a TOML file holding the keys of a campaign's `[detect.streak]`
/// table (each optional; see `detect::streak::StreakParams`), e.g. settings for real frames.
pub fn streak_params_file(path: &Path) -> anyhow::Result<StreakParams> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read streak settings {}", path.display()))?;
    let params: StreakParams = toml::from_str(&text)
        .map_err(|e| anyhow::anyhow!("{}: {}", path.display(), e.to_string().trim_end()))?;
    if let Err((field, message)) = params.check() {
        // The line that sets the field, for the message.
        let line = text
            .lines()
            .position(|l| l.trim_start().starts_with(field))
            .map(|i| format!(":{}", i + 1))
            .unwrap_or_default();
        bail!("{}{line}: field `{field}`: {message}", path.display());
    }
    Ok(params)
}

/// One detection on one frame.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Found {
    pub detector: &'static str,
    pub confidence: f64,
    /// x1, y1, x2, y2 in the file's pixel-edge coordinates.
    pub pixel_box: [f64; 4],
    /// The streak's ends (streak detector only), same coordinates.
    pub ends: Option<[[f64; 2]; 2]>,
    /// (RA, Dec) in degrees of the box centre and of the ends, through the frame's WCS.
    pub centre_radec: Option<[f64; 2]>,
    pub ends_radec: Option<[[f64; 2]; 2]>,
}

/// What was done to one frame and what was found on it.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FrameResult {
    pub file: String,
    pub sha256: String,
    pub format: &'static str,
    pub width: usize,
    pub height: usize,
    /// The sky region the detectors saw, 0-based half-open, and the keyword that gave it.
    pub region: crate::frames::Region,
    pub region_keyword: Option<&'static str>,
    pub wcs: Option<crate::sky::wcs::TanWcs>,
    pub wcs_problem: Option<String>,
    pub pixel_scale_arcsec: Option<f64>,
    /// The streak detector's PSF FWHM in pixels and where it came from.
    pub psf_fwhm_px: f64,
    pub psf_source: &'static str,
    /// Pixels of a FITS frame that were not finite numbers (no data: each given a value of the
    /// frame's finite pixels drawn at random before enhancing).
    pub non_finite_pixels: usize,
    /// Added to a FITS frame before the square root when it holds negative values (a
    /// calibrated frame whose sky was subtracted), so the square root does not clip half of it.
    pub pedestal: f64,
    pub detections: Vec<Found>,
    /// With `--explain`: the streak detector's segments that did not become detections, and why
    /// (ends shifted into the file's pixel grid as the detections').
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub dropped: Vec<Dropped>,
    /// With `--catalog`: what the star-aware detector knew of the frame's sky.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub catalog: Option<CatalogUse>,
    /// Given neither `--catalog` nor `--star-trail-angle-deg`: the star trails the streak
    /// detector measured on the frame itself (direction, length, count, how sure), or that
    /// they share no direction (point stars).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub own_trails: Option<OwnTrails>,
}

/// What `--catalog` gave the streak detector on one frame.
#[derive(Clone, Debug, serde::Serialize)]
pub struct CatalogUse {
    /// Exposure start (UTC) and length, from the header.
    pub start_utc: String,
    pub exposure_s: f64,
    /// How the camera moved over the exposure, and where that came from.
    pub pointing: &'static str,
    pub drift_deg: f64,
    /// Catalogued stars that can put light on the frame, and those whose trail lies on it.
    pub stars_near: usize,
    pub trails_on_frame: usize,
    /// The star-trail direction the detector used (degrees from +x towards +y), and where it
    /// came from; None: the stars do not move (the plain detector runs).
    pub trail_angle_deg: Option<f64>,
    pub trail_angle_source: &'static str,
}

/// The outcome of `soig detect`.
#[derive(Debug)]
pub struct Summary {
    pub frames: Vec<FrameResult>,
    pub output: PathBuf,
    pub digest: String,
}

/// Run the detectors on every input and write `out` whole (see [`crate::output`]): one frame
/// in memory at a time, its files written into the staged output as it is done; a bad input
/// fails the staged output, so nothing is left of it and an earlier `out` stays.
pub fn run(inputs: &[PathBuf], out: &Path, opts: &Options) -> anyhow::Result<Summary> {
    if inputs.is_empty() {
        bail!("no input frame given");
    }
    opts.optics.check()?;
    if opts.catalog.is_some() && opts.explain {
        bail!(
            "--explain does not explain the star-aware pass that --catalog runs: give one or the other"
        );
    }
    // The catalogue informs the streak detector only: with YOLO alone it would change nothing
    // but still demand a WCS of every frame.
    if opts.catalog.is_some() && opts.which == Which::Yolo {
        bail!(
            "--catalog informs the streak detector only, and --detector yolo runs none: drop --catalog or use --detector streak or all"
        );
    }
    let catalog = match &opts.catalog {
        Some(path) => Some(catalog::read(path, opts.catalog_epoch_jyear)?),
        None => None,
    };
    let mut yolo = match (opts.which, &opts.model) {
        (Which::Streak, _) => None,
        (Which::Yolo | Which::All, Some(m)) => Some(
            YoloDetector::load(m, opts.yolo)
                .with_context(|| format!("loading model {}", m.display()))?,
        ),
        (Which::Yolo, None) => bail!("--detector yolo needs --model M.onnx"),
        (Which::All, None) => None,
    };
    let mut stems = std::collections::BTreeSet::new();
    for p in inputs {
        if !stems.insert(output::stem(p)) {
            bail!(
                "{}: another input has the same file stem; its prediction and preview files would collide",
                p.display()
            );
        }
    }
    let mut keep = crate::output::input_folders(inputs);
    keep.extend(
        opts.model
            .iter()
            .chain(&opts.campaign)
            .chain(&opts.catalog)
            .cloned(),
    );
    let keep_refs: Vec<&Path> = keep.iter().map(PathBuf::as_path).collect();
    let mut results = Vec::with_capacity(inputs.len());
    let digest = crate::output::write_replacing(out, &keep_refs, |dir| {
        output::prepare(dir, opts)?;
        for p in inputs {
            let frame = Frame::read(p)?;
            let (result, enhanced) = detect_frame(&frame, opts, yolo.as_mut(), catalog.as_ref())?;
            output::write_frame(dir, &result, &enhanced, opts)?;
            results.push(result);
        }
        output::finish(dir, &results, opts)
    })?;
    Ok(Summary {
        frames: results,
        output: out.to_path_buf(),
        digest,
    })
}

/// The frame's sky region as the detectors' 8-bit image, with the non-finite pixels replaced,
/// the pedestal subtracted, and the input's format.
fn enhance_region(frame: &Frame, opts: &Options) -> (Gray8, usize, f64, &'static str) {
    let (rw, rh) = (frame.region.width(), frame.region.height());
    match &frame.pixels {
        RegionPixels::Gray(g) => (
            Gray8 {
                width: rw,
                height: rh,
                pixels: g.clone(),
            },
            0,
            0.0,
            "png",
        ),
        RegionPixels::Values(v) => {
            let (values, non_finite, pedestal) =
                crate::frames::ready_for_enhancement(v, opts.enhance.sqrt);
            (
                enhance::enhance(&values, rw, rh, &opts.enhance),
                non_finite,
                pedestal,
                "fits",
            )
        }
    }
}

/// The PSF's FWHM in pixels and where it came from: the options, else the streak detector's.
fn psf_fwhm(
    frame: &Frame,
    opts: &Options,
    pixel_scale: Option<f64>,
) -> anyhow::Result<(f64, &'static str)> {
    Ok(
        match (opts.optics.psf_fwhm_px, opts.optics.psf_fwhm_arcsec) {
            (Some(px), _) => (px, "--psf-fwhm-px"),
            (None, Some(arcsec)) => match pixel_scale {
                Some(s) => (
                    arcsec / s,
                    if opts.optics.pixel_scale_arcsec.is_some() {
                        "--psf-fwhm-arcsec / --pixel-scale-arcsec"
                    } else {
                        "--psf-fwhm-arcsec / the WCS's pixel scale"
                    },
                ),
                None => bail!(
                    "{}: --psf-fwhm-arcsec needs a pixel scale: the frame has no WCS; give --pixel-scale-arcsec",
                    frame.path.display()
                ),
            },
            (None, None) => (
                opts.streak.psf_sigma_px * FWHM_PER_SIGMA,
                "the streak detector's psf_sigma_px (not the frame's optics: give --psf-fwhm-px)",
            ),
        },
    )
}

/// The catalogued stars' trails on the detector's image (the frame's sky region), their
/// direction, and what the catalogue was used for.
fn catalogue_sky(
    frame: &Frame,
    opts: &Options,
    cat: &crate::sky::stars::StarCatalog,
    psf_sigma_px: f64,
    psf_fwhm_px: f64,
) -> anyhow::Result<(Vec<crate::hint::StarTrail>, Option<f64>, CatalogUse)> {
    let facts = catalog::FrameSky::of(frame)?;
    let predicted = facts.predict(cat, frame.region, psf_sigma_px);
    let trails = catalog::in_region(&predicted, frame.region);
    // A trail shorter than the PSF's width is a star that does not move.
    let from_trails = catalog::trail_angle_deg(&trails, 2.0 * psf_fwhm_px);
    let (angle, source) = match (opts.star_trail_angle_deg, from_trails) {
        (Some(a), _) => (Some(a), "--star-trail-angle-deg"),
        (None, Some(a)) => (Some(a), "the predicted trails"),
        (None, None) => (None, "none: the predicted stars do not move"),
    };
    let use_ = CatalogUse {
        start_utc: crate::render::iso_utc(facts.start),
        exposure_s: facts.exposure_s,
        pointing: if facts.motion.is_some() {
            "moving: the WCS at the exposure's start and end (alternate WCS S and E)"
        } else {
            "fixed on the sky: the header has no WCS at the exposure's start and end"
        },
        drift_deg: facts.motion.as_ref().map_or(0.0, |m| m.drift_deg()),
        stars_near: predicted.len(),
        trails_on_frame: trails.len(),
        trail_angle_deg: angle,
        trail_angle_source: source,
    };
    Ok((trails, angle, use_))
}

/// Enhance one frame, run the detectors on its sky region, put the results into the file's
/// pixel grid and on the sky. Returns them and the enhanced sky region (for the preview).
fn detect_frame(
    frame: &Frame,
    opts: &Options,
    yolo: Option<&mut YoloDetector>,
    stars: Option<&crate::sky::stars::StarCatalog>,
) -> anyhow::Result<(FrameResult, Gray8)> {
    let (rw, rh) = (frame.region.width(), frame.region.height());
    let (enhanced, non_finite, pedestal, format) = enhance_region(frame, opts);
    let pixel_scale = opts
        .optics
        .pixel_scale_arcsec
        .or(frame.wcs.map(|w| w.pixel_scale_arcsec()));
    let (psf_fwhm_px, psf_source) = psf_fwhm(frame, opts, pixel_scale)?;
    let psf_sigma_px = psf_fwhm_px / FWHM_PER_SIGMA;
    let sky = match stars {
        Some(cat) => Some(catalogue_sky(frame, opts, cat, psf_sigma_px, psf_fwhm_px)?),
        None => None,
    };
    let mut found = Vec::new();
    let mut dropped = Vec::new();
    let mut own_trails = None;
    let (ox, oy) = (frame.region.x0 as f64, frame.region.y0 as f64);
    let shift = |d: &Detection| [d.x1 + ox, d.y1 + oy, d.x2 + ox, d.y2 + oy];
    let image = DetectorFrame::new(&enhanced.pixels, rw, rh);
    if opts.which != Which::Yolo {
        let params = StreakParams {
            psf_sigma_px,
            ..opts.streak.clone()
        };
        let detector = StreakDetector {
            params: params.clone(),
        };
        let explained =
            |angle: Option<f64>| detect_streaks_explained(&enhanced.pixels, rw, rh, &params, angle);
        let (cands, own, why) = match (&sky, opts.star_trail_angle_deg) {
            // The catalogue's pass drops what the predicted trails explain: not explained.
            (Some((trails, angle, _)), _) => {
                let (c, o) = detector.detect_measuring(image, Stars::told(*angle, Some(trails)));
                (c, o, Vec::new())
            }
            // --explain along a given direction: one pass gives both (what `Stars::Along` runs).
            (None, Some(a)) if opts.explain => {
                let (c, why) = explained(Some(a));
                (c, None, why)
            }
            (None, angle) => {
                let (c, o) =
                    detector.detect_measuring(image, angle.map_or(Stars::Unknown, Stars::Along));
                // --explain on a bare frame explains the first pass along the measured direction.
                let why = if opts.explain {
                    explained(o.as_ref().and_then(|o| o.model()).map(|m| m.angle_deg)).1
                } else {
                    Vec::new()
                };
                (c, o, why)
            }
        };
        own_trails = own;
        if opts.explain {
            dropped = why;
            for d in &mut dropped {
                d.ends = d.ends.map(|[x, y]| [x + ox, y + oy]);
            }
        }
        for c in cands {
            let ends = c.ends.map(|[x, y]| [x + ox, y + oy]);
            found.push(Found {
                detector: "streak",
                confidence: c.detection.score,
                pixel_box: shift(&c.detection),
                ends: Some(ends),
                centre_radec: None,
                ends_radec: None,
            });
        }
    }
    if let Some(y) = yolo {
        let boxes = Detector::detect(y, image, Stars::Unknown)
            .map_err(|e| anyhow::anyhow!("YOLO on {}: {e}", frame.path.display()))?;
        for d in boxes.iter().map(|f| f.detection()) {
            found.push(Found {
                detector: "yolo",
                confidence: d.score,
                pixel_box: shift(d),
                ends: None,
                centre_radec: None,
                ends_radec: None,
            });
        }
    }
    if let Some(w) = &frame.wcs {
        // Pixel-edge coordinates to the WCS's 0-based pixel centres: minus half a pixel.
        let sky = |[x, y]: [f64; 2]| {
            let (ra, dec) = w.sky(x - 0.5, y - 0.5);
            [ra, dec]
        };
        for f in &mut found {
            let b = f.pixel_box;
            f.centre_radec = Some(sky([(b[0] + b[2]) / 2.0, (b[1] + b[3]) / 2.0]));
            f.ends_radec = f.ends.map(|e| e.map(sky));
        }
    }
    let result = FrameResult {
        file: frame.path.display().to_string(),
        sha256: crate::hash::sha256_file(&frame.path)?.0,
        format,
        width: frame.width,
        height: frame.height,
        region: frame.region,
        region_keyword: frame.region_keyword,
        wcs: frame.wcs,
        wcs_problem: frame.wcs_problem.clone(),
        pixel_scale_arcsec: pixel_scale,
        psf_fwhm_px,
        psf_source,
        non_finite_pixels: non_finite,
        pedestal,
        detections: found,
        dropped,
        catalog: sky.map(|s| s.2),
        own_trails,
    };
    Ok((result, enhanced))
}
