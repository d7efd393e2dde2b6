//! `soig enhance`: the paper's FITS -> PNG conversion (section 3.3: square root for fixed
//! pointing, the log stretch, CLAHE, gamma, 8-bit PNG) as a command of its own, for any FITS:
//! soig's own images or a real frame. A frame's sky region is read as `soig detect` reads it
//! (`frames`: `TRIMSEC`/`DATASEC`, any numeric type; non-finite pixels given values of the
//! frame's finite ones drawn at random, a negative frame lifted before the square root), so
//! this is the PNG `soig detect` gives its detectors; on a soig FITS of the original frame it
//! is the run's own PNG, byte for byte (tests/cli.rs). The padded and rotated frames are not
//! made here: their padding is sky noise drawn from the image's own random stream, which
//! belongs to the run.
//!
//! The output folder holds `<stem>.png` per input, `timing.json` (the conversion time of each
//! frame: enhancement and PNG encoding, as the report's Table 6 "conversion"; volatile) and a
//! manifest of the settings and every input's sha256; it is written whole or not at all and
//! may not be or hold an input's folder (`output`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::bail;
use serde::Serialize;

use crate::enhance::{self, Gray8, Settings};
use crate::frames::{Frame, RegionPixels, ready_for_enhancement};
use crate::store::fs;

/// One converted frame.
#[derive(Clone, Debug, Serialize)]
pub struct Converted {
    pub file: String,
    pub sha256: String,
    pub png: String,
    pub width: usize,
    pub height: usize,
    /// Non-finite pixels (given values of the frame's finite ones drawn at random).
    pub non_finite_pixels: usize,
    /// Added to every pixel so the square root clips none (a sky-subtracted frame).
    pub pedestal: f64,
    /// Enhancement and PNG encoding, seconds (not in the manifest: it varies).
    #[serde(skip)]
    pub seconds: f64,
}

/// What `run` did: each frame, and the output's digest.
pub struct Summary {
    pub frames: Vec<Converted>,
    pub digest: String,
}

/// Convert every input into `out` with `settings` (`campaign`: where they came from, recorded).
pub fn run(
    inputs: &[PathBuf],
    out: &Path,
    settings: &Settings,
    campaign: Option<&Path>,
) -> anyhow::Result<Summary> {
    if inputs.is_empty() {
        bail!("no input frame given");
    }
    let mut stems = std::collections::BTreeSet::new();
    for p in inputs {
        if !stems.insert(stem(p)) {
            bail!(
                "{}: another input has the same file stem; their PNGs would collide",
                p.display()
            );
        }
    }
    let mut keep = crate::output::input_folders(inputs);
    keep.extend(campaign.map(Path::to_path_buf));
    let keep_refs: Vec<&Path> = keep.iter().map(PathBuf::as_path).collect();
    let mut converted = Vec::new();
    // One frame in memory at a time; a bad input fails the staged output, so none is left.
    let digest = crate::output::write_replacing(out, &keep_refs, |dir| {
        fs::create_dir_all(dir)?;
        for p in inputs {
            let frame = Frame::read(p)?;
            if matches!(frame.pixels, RegionPixels::Gray(_)) {
                bail!(
                    "{}: a PNG is already an 8-bit enhanced image; soig enhance converts FITS",
                    p.display()
                );
            }
            let sha256 = crate::hash::sha256_file(p)?.0;
            converted.push(convert(&frame, &sha256, settings, dir)?);
        }
        write_records(dir, &converted, settings, campaign)
    })?;
    Ok(Summary {
        frames: converted,
        digest,
    })
}

/// Enhance one frame's sky region and write `<stem>.png` into `dir`.
fn convert(
    frame: &Frame,
    sha256: &str,
    settings: &Settings,
    dir: &Path,
) -> anyhow::Result<Converted> {
    let RegionPixels::Values(values) = &frame.pixels else {
        unreachable!("PNG inputs are refused before");
    };
    let (w, h) = (frame.region.width(), frame.region.height());
    let (values, non_finite, pedestal) = ready_for_enhancement(values, settings.sqrt);
    let png = format!("{}.png", stem(&frame.path));
    let started = Instant::now();
    let img: Gray8 = enhance::enhance(&values, w, h, settings);
    fs::create(&dir.join(&png), enhance::png_bytes(&img))?;
    Ok(Converted {
        // The name only: the digest does not depend on where soig was started.
        file: frame
            .path
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned(),
        sha256: sha256.to_string(),
        png,
        width: w,
        height: h,
        non_finite_pixels: non_finite,
        pedestal,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// `timing.json` (volatile) and the manifest, whose digest covers the settings, the inputs'
/// sha256 and the PNGs. Returns the digest.
fn write_records(
    dir: &Path,
    frames: &[Converted],
    settings: &Settings,
    campaign: Option<&Path>,
) -> anyhow::Result<String> {
    let timing: std::collections::BTreeMap<&str, f64> =
        frames.iter().map(|f| (f.png.as_str(), f.seconds)).collect();
    fs::create(
        &dir.join("timing.json"),
        serde_json::to_string_pretty(&timing)? + "\n",
    )?;
    let record = serde_json::json!({
        "command": "enhance",
        "campaign": campaign.map(|c| c.display().to_string()),
        "enhance": {
            "sqrt": settings.sqrt,
            "clahe_clip_limit": settings.clahe_clip_limit,
            "clahe_tiles": settings.clahe_tiles,
            "gamma": settings.gamma,
        },
        "frames": frames,
    });
    let hash = crate::hash::hash_json(&record);
    let manifest =
        crate::manifest::Manifest::build(dir, &hash, record, &["timing.json".to_string()])?;
    manifest.write(dir)?;
    Ok(manifest.digest)
}

/// The file name without its extension.
fn stem(path: &Path) -> String {
    path.file_stem()
        .unwrap_or_default()
        .to_string_lossy()
        .into_owned()
}
