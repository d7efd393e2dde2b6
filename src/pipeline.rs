//! The scheduler: runs every image of a campaign (in parallel with rayon; each image a pure
//! function of the campaign and its index), writes the artifacts into a fresh directory beside
//! the output, adds `data.yaml` and the manifest last, and moves the whole into place, so a
//! failed run never leaves a half-written output.

use std::path::{Path, PathBuf};
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

use rand_chacha::ChaCha12Rng;

use crate::campaign::{Campaign, GeometryKind, PointingMode, Stage};
use crate::dataset::{self, Subset};
use crate::detect::Detection;
use crate::detect::streak::{StreakParams, detect_streaks};
use crate::detect::yolo::{YoloDetector, YoloParams};
use crate::enhance;
use crate::fits::{self, Card, Cards, Pixels};
use crate::geometry::{self, Fill, Frame, LABEL_SHARE};
use crate::manifest::{MANIFEST, Manifest};
use crate::render::{self, Exposure};
use crate::report::{self, DetectorRun, TestImage};
use crate::rng::{Purpose, stream};
use crate::scene::Pointing;
use crate::scene::{self, Inputs};

/// What a finished run reports.
#[derive(Debug)]
pub struct RunSummary {
    pub output: PathBuf,
    pub digest: String,
    pub images: usize,
    pub seconds: f64,
}

/// File stem of image i.
pub fn stem(i: u64) -> String {
    format!("img_{i:06}")
}

/// Run the campaign into `output`. An existing `output` is replaced only if it is a soig output
/// (it holds a manifest).
pub fn run(campaign: &Campaign, output: &Path, progress: bool) -> anyhow::Result<RunSummary> {
    run_with(campaign, output, progress, None)
}

/// `run`, with the Python interpreter for a `train` stage (default: `train::find_python`).
pub fn run_with(
    campaign: &Campaign,
    output: &Path,
    progress: bool,
    python: Option<&Path>,
) -> anyhow::Result<RunSummary> {
    // Find the training Python before rendering anything, so a missing one fails at once.
    let python = if campaign.resolved.stages.contains(&Stage::Train) {
        Some(crate::train::find_python(python)?)
    } else {
        None
    };
    let (digest, images, seconds) = write_replacing(output, |staging| {
        write_all(campaign, staging, progress, python.as_deref())
    })?;
    Ok(RunSummary {
        output: output.to_path_buf(),
        digest,
        images,
        seconds,
    })
}

/// Write a soig output directory whole or not at all: `write` fills a hidden staging directory
/// beside `output`, which replaces `output` only when it succeeds and is deleted when it fails.
/// An existing `output` is replaced only if it is a soig output (it holds a manifest) or empty.
pub fn write_replacing<T>(
    output: &Path,
    write: impl FnOnce(&Path) -> anyhow::Result<T>,
) -> anyhow::Result<T> {
    use anyhow::Context;
    if output.exists() {
        let is_ours = output.join(MANIFEST).is_file();
        let empty = output.is_dir() && std::fs::read_dir(output)?.next().is_none();
        if !is_ours && !empty {
            anyhow::bail!(
                "{} exists and is not a soig output (no {MANIFEST}); refusing to overwrite it",
                output.display()
            );
        }
    }
    let name = output
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "soig-out".into());
    let parent = output
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent)
        .with_context(|| format!("cannot create {}", parent.display()))?;
    let staging = parent.join(format!(".{name}.partial-{}", std::process::id()));
    if staging.exists() {
        std::fs::remove_dir_all(&staging)?;
    }
    match write(&staging) {
        Ok(value) => {
            if output.exists() {
                std::fs::remove_dir_all(output)
                    .with_context(|| format!("cannot replace {}", output.display()))?;
            }
            std::fs::rename(&staging, output).with_context(|| {
                format!("cannot move {} to {}", staging.display(), output.display())
            })?;
            Ok(value)
        }
        Err(e) => {
            let _ = std::fs::remove_dir_all(&staging);
            Err(e)
        }
    }
}

fn write_all(
    campaign: &Campaign,
    dir: &Path,
    progress: bool,
    python: Option<&Path>,
) -> anyhow::Result<(String, usize, f64)> {
    use anyhow::Context;
    let c = &campaign.resolved;
    let n = c.images as usize;
    let stages = &c.stages;
    let enhance_stage = stages.contains(&Stage::Enhance);
    let dataset_stage = stages.contains(&Stage::Dataset);
    let subsets = dataset::assign(c.seed, n, &c.split);

    let mut dirs = vec![dir.join("truth")];
    if c.artifacts.fits || c.artifacts.noise_free_fits {
        dirs.push(dir.join("fits"));
    }
    if enhance_stage {
        if dataset_stage {
            for s in [Subset::Train, Subset::Val, Subset::Test] {
                dirs.push(dir.join("images").join(s.name()));
                dirs.push(dir.join("labels").join(s.name()));
            }
        } else {
            dirs.push(dir.join("images"));
            dirs.push(dir.join("labels"));
        }
    }
    for d in &dirs {
        std::fs::create_dir_all(d).with_context(|| format!("cannot create {}", d.display()))?;
    }

    let inputs = Inputs::load(campaign).map_err(anyhow::Error::msg)?;
    let bar = if progress {
        ProgressBar::new(n as u64)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} images, {per_sec}, ETA {eta}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_message(format!("soig {}", c.name));
    let started = Instant::now();
    let written: Vec<Written> = (0..n as u64)
        .into_par_iter()
        .map(|i| -> anyhow::Result<Written> {
            let subset = dataset_stage.then(|| subsets[i as usize]);
            let w = image(campaign, &inputs, i, dir, enhance_stage, subset)?;
            bar.inc(1);
            Ok(w)
        })
        .collect::<anyhow::Result<_>>()?;
    bar.finish_and_clear();
    let seconds = started.elapsed().as_secs_f64();

    if dataset_stage {
        std::fs::write(
            dir.join("data.yaml"),
            dataset::data_yaml(&c.name, &campaign.hash),
        )?;
    }
    // The dataset's own digest goes into the report: taken before training and detection add
    // their files.
    let dataset_digest = if stages.contains(&Stage::Detect) {
        Manifest::build(dir, &campaign.hash, serde_json::to_value(c)?, &[])?.digest
    } else {
        String::new()
    };
    let trained = match python {
        Some(python) => Some(crate::train::fit(campaign, dir, python)?),
        None => None,
    };
    if stages.contains(&Stage::Detect) {
        // A train stage's model, else the campaign's (validation allows one, not both).
        let model = match &trained {
            Some(t) => Some(t.model.clone()),
            None => c.detect.model.as_ref().map(|m| campaign.base_dir.join(m)),
        };
        detect_and_report(
            campaign,
            dir,
            &written,
            &dataset_digest,
            model.as_deref(),
            progress,
        )?;
    }
    let mut volatile: Vec<String> = report::VOLATILE
        .iter()
        .filter(|v| dir.join(v).is_file())
        .map(|v| v.to_string())
        .collect();
    if trained.is_some() {
        volatile.extend(crate::train::volatile_files(dir)?);
    }
    let mut manifest = Manifest::build(dir, &campaign.hash, serde_json::to_value(c)?, &volatile)?;
    if let Some(t) = trained {
        manifest.training = Some(t.record);
        manifest.seal();
    }
    manifest.write(dir)?;
    Ok((manifest.digest, n, seconds))
}

/// What an image left for the detect stage.
struct Written {
    subset: Option<Subset>,
    /// The PNG, its size, and the label box in pixel-edge coordinates.
    png: Option<(PathBuf, usize, usize, Option<[f64; 4]>)>,
    /// FITS -> PNG conversion time (frame, enhancement, encoding), seconds.
    conversion_s: f64,
    /// Direction of star trails in the PNG (survey), degrees.
    trail_angle_deg: Option<f64>,
}

/// Run the detectors on the test split (every image when there is no split) and write the
/// report. YOLO runs outside the rayon pool: ONNX Runtime slows ~3x beside a busy pool.
fn detect_and_report(
    campaign: &Campaign,
    dir: &Path,
    written: &[Written],
    dataset_digest: &str,
    model: Option<&Path>,
    progress: bool,
) -> anyhow::Result<()> {
    use anyhow::Context;
    let c = &campaign.resolved;
    let chosen: Vec<&Written> = written
        .iter()
        .filter(|w| w.png.is_some() && matches!(w.subset, None | Some(Subset::Test)))
        .collect();
    let images: Vec<TestImage> = chosen
        .iter()
        .map(|w| {
            let (png, width, height, label) = w.png.clone().expect("filtered");
            TestImage {
                stem: png
                    .file_stem()
                    .unwrap_or_default()
                    .to_string_lossy()
                    .into_owned(),
                png,
                width,
                height,
                truth: label.into_iter().collect(),
            }
        })
        .collect();
    let load = |img: &TestImage| -> anyhow::Result<Vec<u8>> {
        Ok(image::open(&img.png)
            .with_context(|| format!("reading {}", img.png.display()))?
            .to_luma8()
            .into_raw())
    };
    let mut runs = Vec::new();
    if c.detect.classical {
        let params = StreakParams::default();
        let results: Vec<(Vec<Detection>, f64)> = images
            .par_iter()
            .zip(chosen.par_iter())
            .map(|(img, w)| -> anyhow::Result<(Vec<Detection>, f64)> {
                let pixels = load(img)?;
                let t = Instant::now();
                let found =
                    detect_streaks(&pixels, img.width, img.height, &params, w.trail_angle_deg);
                Ok((
                    found.into_iter().map(|c| c.detection).collect(),
                    t.elapsed().as_secs_f64(),
                ))
            })
            .collect::<anyhow::Result<_>>()?;
        let (detections, seconds) = results.into_iter().unzip();
        runs.push(DetectorRun {
            name: "streak".into(),
            description: "classical streak detector (background mesh, oriented line filters, components, moments; no model)".into(),
            model_sha256: None,
            detections,
            seconds,
        });
    }
    if let Some(path) = model {
        let params = YoloParams {
            conf: c.detect.conf,
            iou: c.detect.iou,
            max_det: c.detect.max_det as usize,
            ..YoloParams::default()
        };
        let mut yolo = YoloDetector::load(path, params)
            .with_context(|| format!("loading model {}", path.display()))?;
        let bar = if progress {
            ProgressBar::new(images.len() as u64)
        } else {
            ProgressBar::hidden()
        };
        bar.set_style(
            ProgressStyle::with_template("yolo [{bar:30}] {pos}/{len} images, {per_sec}")
                .expect("valid template"),
        );
        let (mut detections, mut seconds) = (Vec::new(), Vec::new());
        for img in &images {
            let pixels = load(img)?;
            let t = Instant::now();
            detections.push(yolo.detect(&pixels, img.width, img.height)?);
            seconds.push(t.elapsed().as_secs_f64());
            bar.inc(1);
        }
        bar.finish_and_clear();
        runs.push(DetectorRun {
            name: "yolo".into(),
            description: format!(
                "YOLOv8 {} through ONNX Runtime, conf {}, NMS IoU {}",
                c.detect
                    .model
                    .as_deref()
                    .unwrap_or("train/model.onnx (trained by this run)"),
                c.detect.conf,
                c.detect.iou
            ),
            model_sha256: match &c.detect.model_sha256 {
                Some(sha) => Some(sha.clone()),
                None => Some(crate::hash::sha256_file(path)?.0),
            },
            detections,
            seconds,
        });
    }
    let geometry = match c.enhance.geometry {
        GeometryKind::Original => "original frame",
        GeometryKind::Padded => "padded frame",
        GeometryKind::Rotated => "rotated and expanded frame",
    };
    let kind = match c.background {
        crate::campaign::Background::Uniform => "synthetic",
        crate::campaign::Background::Frames { .. } => "semisynthetic",
    };
    let mode = match c.pointing.mode {
        PointingMode::Fixed => "fixed",
        PointingMode::Survey => "survey",
    };
    let conversion: Vec<f64> = written.iter().map(|w| w.conversion_s).collect();
    report::write(
        dir,
        &c.name,
        &campaign.hash,
        dataset_digest,
        &format!("{mode}, {geometry}, {kind}"),
        &images,
        &runs,
        c.detect.conf,
        &conversion,
    )
}

/// Draw, render and write one image.
fn image(
    campaign: &Campaign,
    inputs: &Inputs,
    i: u64,
    dir: &Path,
    enhance_stage: bool,
    subset: Option<Subset>,
) -> anyhow::Result<Written> {
    use anyhow::Context;
    let c = &campaign.resolved;
    let seed = c.seed;
    let scene = scene::draw(campaign, inputs, i, &mut stream(seed, i, Purpose::Scene))?;
    let mut exposure = render::render(
        campaign,
        &scene,
        inputs.frame(scene.background),
        &mut stream(seed, i, Purpose::Photons),
        &mut stream(seed, i, Purpose::Noise),
    );
    let stem = stem(i);
    let (w, h) = (exposure.width, exposure.height);

    // The final frame of the PNG and its label: the debris alone is warped like the image, so
    // the box is the tight box of the rendered streak in that frame.
    let conversion_started = Instant::now();
    let final_image = enhance_stage.then(|| {
        let frame = match c.enhance.geometry {
            GeometryKind::Original => Frame::original(w, h),
            GeometryKind::Padded => Frame::padded(w, h, c.enhance.pad_px as usize),
            GeometryKind::Rotated => match scene.pointing {
                Pointing::Survey(track) => Frame::rotated(w, h, track.trail_angle_deg),
                Pointing::Fixed { .. } => unreachable!("validated: rotated needs survey pointing"),
            },
        };
        let mut rng = stream(seed, i, Purpose::Enhance);
        let adu = geometry::warp(&exposure.adu, w, h, &frame, Fill::SkyNoise(&mut rng));
        let debris: Vec<f32> = exposure
            .debris_electrons
            .iter()
            .map(|&v| v as f32)
            .collect();
        let debris = geometry::warp::<ChaCha12Rng>(&debris, w, h, &frame, Fill::Zero);
        let label = geometry::flux_box(&debris, frame.width, frame.height, LABEL_SHARE);
        exposure.truth.frame = Some(frame.clone());
        exposure.truth.label_box_final_px = label;
        (frame, adu, label)
    });
    let mut conversion_s = conversion_started.elapsed().as_secs_f64();
    let cards = provenance_cards(campaign, &scene, &exposure);
    if c.artifacts.fits {
        let mut cards = cards.clone();
        cards.push((
            "BUNIT".into(),
            Card::Str("adu".into()),
            "Eq. 11: e-/gain + background + bias".into(),
        ));
        let path = dir.join("fits").join(format!("{stem}.fits"));
        fits::write_image(&path, w, h, Pixels::F32(&exposure.adu), &cards)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    if c.artifacts.noise_free_fits {
        let mut cards = cards;
        cards.push((
            "BUNIT".into(),
            Card::Str("electron".into()),
            "noise-free photo-electrons".into(),
        ));
        let path = dir.join("fits").join(format!("{stem}_clean.fits"));
        let e: Vec<i32> = exposure
            .electrons
            .iter()
            .map(|&v| v.min(i32::MAX as u32) as i32)
            .collect();
        fits::write_image(&path, w, h, Pixels::I32(&e), &cards)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    if c.artifacts.star_list {
        let path = dir.join("truth").join(format!("{stem}_stars.csv"));
        let mut w =
            csv::Writer::from_path(&path).with_context(|| format!("writing {}", path.display()))?;
        for s in &exposure.stars {
            w.serialize(s)?;
        }
        w.flush()?;
    }
    let truth_path = dir.join("truth").join(format!("{stem}.json"));
    std::fs::write(
        &truth_path,
        serde_json::to_string_pretty(&exposure.truth)? + "\n",
    )?;

    let mut png_written = None;
    if let Some((frame, adu, label)) = final_image {
        let started = Instant::now();
        let sqrt = c.enhance.sqrt && c.pointing.mode == PointingMode::Fixed;
        let png = enhance::enhance(&adu, frame.width, frame.height, &c.enhance, sqrt);
        let label_line = label
            .map(|b| b.yolo_line(frame.width, frame.height))
            .unwrap_or_default();
        let (img_dir, lbl_dir) = match subset {
            Some(s) => (
                dir.join("images").join(s.name()),
                dir.join("labels").join(s.name()),
            ),
            None => (dir.join("images"), dir.join("labels")),
        };
        let png_path = img_dir.join(format!("{stem}.png"));
        enhance::write_png(&png_path, &png)?;
        std::fs::write(lbl_dir.join(format!("{stem}.txt")), label_line)?;
        conversion_s += started.elapsed().as_secs_f64();
        // Pixel-edge coordinates: pixel i spans [i, i + 1).
        let edges = label.map(|b| [b.x_min + 0.5, b.y_min + 0.5, b.x_max + 0.5, b.y_max + 0.5]);
        png_written = Some((png_path, frame.width, frame.height, edges));
    }
    let trail_angle_deg = match (scene.pointing, c.enhance.geometry) {
        (Pointing::Survey(_), GeometryKind::Rotated) => Some(0.0),
        (Pointing::Survey(t), _) => Some(t.trail_angle_deg),
        (Pointing::Fixed { .. }, _) => None,
    };
    Ok(Written {
        subset,
        png: png_written,
        conversion_s,
        trail_angle_deg,
    })
}

/// WCS and provenance keywords of an image.
fn provenance_cards(campaign: &Campaign, scene: &scene::Scene, exposure: &Exposure) -> Cards {
    let c = &campaign.resolved;
    let t = &exposure.truth;
    let [jx, jy] = t.jitter_mean_px;
    let mut cards = fits::wcs_cards(&scene.projection(campaign).shifted(jx, jy));
    let mut push =
        |k: &str, v: Card, comment: &str| cards.push((k.to_string(), v, comment.to_string()));
    push(
        "ORIGIN",
        Card::Str("soig".into()),
        "space optical image generator",
    );
    push(
        "SOIGVER",
        Card::Str(env!("CARGO_PKG_VERSION").into()),
        "soig version",
    );
    push("CAMPAIGN", Card::Str(c.name.clone()), "campaign name");
    push(
        "CAMPHASH",
        Card::Str(campaign.hash.clone()),
        "sha256 of the resolved campaign",
    );
    push("SEED", Card::Int(c.seed as i64), "campaign seed");
    push(
        "IMGINDEX",
        Card::Int(scene.image_index as i64),
        "image index in the campaign",
    );
    push("OBJECT", Card::Str(t.object.clone()), "debris in the field");
    push(
        "NORAD",
        Card::Int(t.norad as i64),
        "NORAD catalogue number of the debris",
    );
    push(
        "OBSERVER",
        Card::Str(campaign.observer.name.clone()),
        "observing satellite",
    );
    push(
        "DATE-OBS",
        Card::Str(t.start_utc.clone()),
        "UTC start of exposure",
    );
    push("TIMESYS", Card::Str("UTC".into()), "");
    push(
        "MJD-OBS",
        Card::Real(scene.start.to_mjd_utc_days()),
        "[d] UTC start of exposure",
    );
    push("EXPTIME", Card::Real(t.exposure_s), "[s] exposure time");
    push("GAIN", Card::Real(c.sensor.gain_e_per_adu), "[e-/ADU]");
    match scene.pointing {
        Pointing::Fixed { .. } => push("POINTING", Card::Str("fixed".into()), "fixed or survey"),
        Pointing::Survey(track) => {
            push(
                "POINTING",
                Card::Str("survey".into()),
                "fixed or survey; WCS at mid-exposure",
            );
            push(
                "DRIFTANG",
                Card::Real(track.trail_angle_deg),
                "[deg] star-trail direction from +x to +y (Eq. 13)",
            );
            push(
                "DRIFT",
                Card::Real(track.drift_deg),
                "[deg] boresight drift over the exposure",
            );
        }
    }
    if let Some(f) = &t.frame {
        push(
            "GEOMETRY",
            Card::Str(f.kind.clone()),
            "frame of the PNG and its label",
        );
        push(
            "GEOANGLE",
            Card::Real(f.angle_deg),
            "[deg] rotation undone in the PNG",
        );
        push("GEONAX1", Card::Int(f.width as i64), "PNG width");
        push("GEONAX2", Card::Int(f.height as i64), "PNG height");
        for (r, row) in f.matrix.iter().enumerate() {
            for (k, v) in row.iter().enumerate() {
                push(
                    &format!("GEOA{}{}", r + 1, k + 1),
                    Card::Real(*v),
                    "PNG pixel = A (x, y, 1), 0-based",
                );
            }
        }
    }
    push(
        "MAGZERO",
        Card::Real(c.sensor.zero_point_mag),
        "magnitude of 1 e-/s",
    );
    push(
        "DEBMAG",
        Card::Real(t.magnitude),
        "debris magnitude at mid-exposure (Eq. 6)",
    );
    cards
}
