//! The files of `soig detect`: `detections.csv` and `detections.json`, YOLO-format predictions
//! `predictions/<detector>/<stem>.txt` (`cls xc yc w h conf`, normalised by the file's size as
//! Ultralytics' `save_txt`; one file per frame and detector, empty when nothing was found),
//! previews `previews/<stem>.png` and the manifest.

use std::fmt::Write as _;
use std::path::Path;

use image::{Rgb, RgbImage};

use super::{FrameResult, Options, Which};
use crate::enhance::Gray8;
use crate::manifest::Manifest;
use crate::store::fs;

/// Preview colours: streak boxes red, YOLO boxes yellow, streak ends green, and what lies
/// outside the sky region (prescan, overscan) a dark blue.
const STREAK: Rgb<u8> = Rgb([230, 0, 0]);
const YOLO: Rgb<u8> = Rgb([255, 200, 0]);
const END: Rgb<u8> = Rgb([0, 220, 0]);
const NOT_SKY: Rgb<u8> = Rgb([20, 20, 70]);

/// The file name without its extension.
pub(super) fn stem(path: &Path) -> String {
    path.file_stem()
        .unwrap_or_default()
        .to_string_lossy()
        .into_owned()
}

/// The detectors that ran.
fn detectors(opts: &Options) -> Vec<&'static str> {
    let mut d = Vec::new();
    if opts.which != Which::Yolo {
        d.push("streak");
    }
    if opts.which != Which::Streak && opts.model.is_some() {
        d.push("yolo");
    }
    d
}

/// The folders of `dir` that frames' files go into.
pub(super) fn prepare(dir: &Path, opts: &Options) -> anyhow::Result<()> {
    fs::create_dir_all(&dir.join("previews"))?;
    for d in detectors(opts) {
        fs::create_dir_all(&dir.join("predictions").join(d))?;
    }
    Ok(())
}

/// One frame's predictions (a file per detector) and preview, as soon as it is done.
pub(super) fn write_frame(
    dir: &Path,
    f: &FrameResult,
    enhanced: &Gray8,
    opts: &Options,
) -> anyhow::Result<()> {
    let name = stem(Path::new(&f.file));
    for d in detectors(opts) {
        let path = dir.join("predictions").join(d).join(format!("{name}.txt"));
        fs::create(&path, yolo_txt(f, d))?;
    }
    let path = dir.join("previews").join(format!("{name}.png"));
    fs::create(&path, crate::plot::rgb_png(&preview(f, enhanced))?)?;
    Ok(())
}

/// Every frame's rows and records, the settings, and the manifest; returns its digest.
pub(super) fn finish(dir: &Path, frames: &[FrameResult], opts: &Options) -> anyhow::Result<String> {
    let ran = detectors(opts);
    fs::create(&dir.join("detections.csv"), csv(frames))?;
    let mut settings = serde_json::json!({
        "command": "detect",
        "detectors": ran,
        "model": opts.model.as_ref().map(|m| m.display().to_string()),
        "model_sha256": match &opts.model {
            Some(m) if ran.contains(&"yolo") => Some(crate::hash::sha256_file(m)?.0),
            _ => None,
        },
        "campaign": opts.campaign.as_ref().map(|c| c.display().to_string()),
        "enhance": {
            "sqrt": opts.enhance.sqrt,
            "clahe_clip_limit": opts.enhance.clahe_clip_limit,
            "clahe_tiles": opts.enhance.clahe_tiles,
            "gamma": opts.enhance.gamma,
        },
        "streak": opts.streak,
        "yolo": { "conf": opts.yolo.conf, "iou": opts.yolo.iou, "max_det": opts.yolo.max_det },
        "optics": opts.optics,
        "star_trail_angle_deg": opts.star_trail_angle_deg,
        "inputs": frames.iter().map(|f| serde_json::json!({"file": f.file, "sha256": f.sha256})).collect::<Vec<_>>(),
    });
    // Only with --catalog, so that the settings (and digest) of every other run stay as they were.
    if let Some(c) = &opts.catalog {
        settings["catalog"] = serde_json::json!({
            "file": c.display().to_string(),
            "sha256": crate::hash::sha256_file(c)?.0,
            "epoch_jyear": opts.catalog_epoch_jyear,
        });
    }
    let json = serde_json::json!({
        "tool": "soig",
        "version": env!("CARGO_PKG_VERSION"),
        "coordinates": "pixel-edge, 0-based, in the file's own pixel grid (pixel i spans [i, i+1]; FITS pixel p is centred at p - 0.5); RA/Dec in degrees through the frame's TAN WCS",
        "settings": settings,
        "frames": frames,
    });
    fs::create(
        &dir.join("detections.json"),
        serde_json::to_string_pretty(&json)? + "\n",
    )?;
    let hash = crate::hash::hash_json(&settings);
    let manifest = Manifest::build(dir, &hash, settings, &[])?;
    manifest.write(dir)?;
    Ok(manifest.digest)
}

fn opt(v: Option<f64>) -> String {
    v.map(|v| format!("{v:.9}")).unwrap_or_default()
}

/// One row per detection; sky columns empty without a WCS, end columns empty for YOLO.
fn csv(frames: &[FrameResult]) -> String {
    let mut s = String::from(
        "file,detector,confidence,x1,y1,x2,y2,end1_x,end1_y,end2_x,end2_y,ra_deg,dec_deg,end1_ra_deg,end1_dec_deg,end2_ra_deg,end2_dec_deg\n",
    );
    for f in frames {
        for d in &f.detections {
            let b = d.pixel_box;
            let e = d.ends;
            let end = |i: usize, j: usize| opt(e.map(|e| e[i][j]));
            let c = d.centre_radec;
            let er = d.ends_radec;
            let end_sky = |i: usize, j: usize| opt(er.map(|e| e[i][j]));
            let file = if f.file.contains([',', '"', '\n']) {
                format!("\"{}\"", f.file.replace('"', "\"\""))
            } else {
                f.file.clone()
            };
            let _ = writeln!(
                s,
                "{file},{},{},{:.3},{:.3},{:.3},{:.3},{},{},{},{},{},{},{},{},{},{}",
                d.detector,
                d.confidence,
                b[0],
                b[1],
                b[2],
                b[3],
                end(0, 0),
                end(0, 1),
                end(1, 0),
                end(1, 1),
                opt(c.map(|c| c[0])),
                opt(c.map(|c| c[1])),
                end_sky(0, 0),
                end_sky(0, 1),
                end_sky(1, 0),
                end_sky(1, 1),
            );
        }
    }
    s
}

/// Ultralytics' prediction text: `cls xc yc w h conf`, normalised by the file's size, at
/// round-trip precision (6 decimals tied scores).
fn yolo_txt(f: &FrameResult, detector: &str) -> String {
    let (w, h) = (f.width as f64, f.height as f64);
    let mut s = String::new();
    for d in f.detections.iter().filter(|d| d.detector == detector) {
        let b = d.pixel_box;
        let _ = writeln!(
            s,
            "0 {} {} {} {} {}",
            (b[0] + b[2]) / 2.0 / w,
            (b[1] + b[3]) / 2.0 / h,
            (b[2] - b[0]) / w,
            (b[3] - b[1]) / h,
            d.confidence
        );
    }
    s
}

/// The enhanced sky region in the file's frame, with every detection drawn.
fn preview(f: &FrameResult, enhanced: &Gray8) -> RgbImage {
    let r = f.region;
    let mut img = RgbImage::from_pixel(f.width as u32, f.height as u32, NOT_SKY);
    for y in 0..r.height() {
        for x in 0..r.width() {
            let v = enhanced.pixels[y * r.width() + x];
            img.put_pixel((x + r.x0) as u32, (y + r.y0) as u32, Rgb([v, v, v]));
        }
    }
    for d in &f.detections {
        let colour = if d.detector == "yolo" { YOLO } else { STREAK };
        crate::report::draw_rect(&mut img, &d.pixel_box, colour);
        for [x, y] in d.ends.into_iter().flatten() {
            cross(&mut img, x, y);
        }
    }
    img
}

/// A small cross centred on a pixel-edge position.
fn cross(img: &mut RgbImage, x: f64, y: f64) {
    let (cx, cy) = (x.floor() as i64, y.floor() as i64);
    for t in -4i64..=4 {
        for (px, py) in [(cx + t, cy), (cx, cy + t)] {
            if px >= 0 && py >= 0 && (px as u32) < img.width() && (py as u32) < img.height() {
                img.put_pixel(px as u32, py as u32, END);
            }
        }
    }
}
