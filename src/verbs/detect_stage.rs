//! The detect stage of a run: each detector over the test split (every image when there is no
//! split), then the report. The stages in order: the test frames (`test_frames`: PNG paths and
//! sizes, nothing of the truth), the streak detector (`streak_run`), YOLO (`yolo_run`); only
//! then the truth (`test_images`), which the report scores against. The detectors are given
//! `TestFrame`s, which hold no truth, and run before any truth file is opened (issue #44; the
//! test `detectors_open_no_truth` runs them with the truth folder gone).

use std::path::Path;
use std::time::Instant;

use anyhow::Context;
use rayon::prelude::*;

use crate::artifacts::WrittenPng;
use crate::dataset::Subset;
use crate::detect::detector::Frame;
use crate::detect::streak::Footprint;
use crate::detect::yolo::YoloDetector;
use crate::detect::{Detection, Detector, Found, Stars, StreakDetector};
use crate::observations::Line;
use crate::progress::Progress;
use crate::report::{self, DetectorRun, ObjectFacts, TestImage};
use crate::verbs::plan::Plan;

/// What an image left for the detect stage.
pub(crate) struct Written {
    pub index: u64,
    pub subset: Option<Subset>,
    pub png: Option<WrittenPng>,
    /// FITS -> PNG conversion time (frame, enhancement, encoding), seconds; None when a shard
    /// did not record it.
    pub conversion_s: Option<f64>,
    /// Direction of star trails in the PNG (survey), degrees.
    pub trail_angle_deg: Option<f64>,
    /// Where the PNG holds the image (a rotated or padded frame), for the streak detector.
    pub footprint: Option<Footprint>,
}

/// Run the detectors on the test split (every image when there is no split) and write the
/// report.
pub(crate) fn detect_and_report(
    plan: &Plan,
    dir: &Path,
    written: &[Written],
    dataset_digest: &str,
    model: Option<&Path>,
    progress: &dyn Progress,
) -> anyhow::Result<()> {
    let chosen: Vec<&Written> = written
        .iter()
        .filter(|w| w.png.is_some() && matches!(w.subset, None | Some(Subset::Test)))
        .collect();
    let runs = run_detectors(plan, &chosen, model, progress)?;
    let images = test_images(dir, &chosen)?;
    let conversion: Vec<f64> = written.iter().filter_map(|w| w.conversion_s).collect();
    report::write(
        dir,
        &plan.name,
        &plan.hash,
        dataset_digest,
        &plan.detect.row_kind,
        &images,
        &runs,
        plan.detect.conf,
        &conversion,
        progress,
    )?;
    if let Some(a) = &plan.detect.astrometry {
        let x = &plan.experiment;
        let setup = report::astrometry::Setup {
            trajectory_samples: x.scene.trajectory_samples,
            seeing: x
                .scene
                .ground
                .as_ref()
                .is_some_and(|g| g.seeing_zenith.is_some()),
            sensor: x.sensor.clone(),
            psf_sigma_px: a.psf_sigma_px,
            observer: &a.observer,
            conf: plan.detect.conf,
            apparent: a.apparent,
        };
        report::astrometry::write(dir, &images, &runs, &setup)?;
    }
    Ok(())
}

/// Each detector of the campaign over the chosen images: what a detector sees of an image is
/// its `TestFrame` (the PNG and its size) and the plan, never its truth.
fn run_detectors(
    plan: &Plan,
    chosen: &[&Written],
    model: Option<&Path>,
    progress: &dyn Progress,
) -> anyhow::Result<Vec<DetectorRun>> {
    let frames: Vec<TestFrame> = chosen.iter().map(|w| TestFrame::of(w)).collect();
    let mut runs = Vec::new();
    if plan.detect.classical {
        runs.push(streak_run(
            plan,
            &plan.detect.streak,
            &frames,
            chosen,
            progress,
        )?);
    }
    if let Some(path) = model {
        runs.push(yolo_run(plan, path, &frames, progress)?);
    }
    Ok(runs)
}

/// What a detector is given of a test image: its PNG and size, nothing of its truth.
struct TestFrame {
    png: std::path::PathBuf,
    width: usize,
    height: usize,
    footprint: Option<Footprint>,
}

impl TestFrame {
    /// The frame a detector reads: this image's grey `pixels`.
    fn frame<'a>(&self, pixels: &'a [u8]) -> Frame<'a> {
        Frame {
            pixels,
            width: self.width,
            height: self.height,
            footprint: self.footprint,
        }
    }

    fn of(w: &Written) -> TestFrame {
        let png = w.png.as_ref().expect("only images with a PNG are chosen");
        TestFrame {
            png: png.path.clone(),
            width: png.width,
            height: png.height,
            footprint: w.footprint,
        }
    }
}

/// Each chosen image's PNG and truth, its sidecar's facts checked against its label boxes.
fn test_images(dir: &Path, chosen: &[&Written]) -> anyhow::Result<Vec<TestImage>> {
    chosen
        .iter()
        .map(|w| -> anyhow::Result<TestImage> {
            let png = w.png.as_ref().expect("filtered");
            let stem = png
                .path
                .file_stem()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned();
            let sidecar = dir.join("truth").join(format!("{stem}.json"));
            let facts = ObjectFacts::read(&sidecar)?;
            if facts.len() != png.labels.len() {
                anyhow::bail!(
                    "{}: {} labelled objects, its image's record has {} label boxes",
                    sidecar.display(),
                    facts.len(),
                    png.labels.len()
                );
            }
            // The truth as the label file reads (what `soig eval` scores against), in pixels.
            let label = dir.join(crate::artifacts::dataset_paths(w.index, w.subset).1);
            let (fw, fh) = (png.width as f64, png.height as f64);
            let truth: Vec<[f64; 4]> = crate::metrics::read_yolo_file(&label, false)?
                .iter()
                .map(|(_, b, _)| [b[0] * fw, b[1] * fh, b[2] * fw, b[3] * fh])
                .collect();
            if truth.len() != png.labels.len() {
                anyhow::bail!(
                    "{}: {} label lines, its image's record has {} label boxes",
                    label.display(),
                    truth.len(),
                    png.labels.len()
                );
            }
            Ok(TestImage {
                stem,
                png: png.path.clone(),
                width: png.width,
                height: png.height,
                truth,
                facts,
            })
        })
        .collect()
}

/// An image's grey pixels.
fn load(img: &TestFrame) -> anyhow::Result<Vec<u8>> {
    Ok(image::open(&img.png)
        .with_context(|| format!("reading {}", img.png.display()))?
        .to_luma8()
        .into_raw())
}

/// What a detector finds on one frame (YOLO may fail: a model or image it cannot use).
fn detect_once(
    detector: &mut impl Detector,
    frame: Frame<'_>,
    stars: Stars<'_>,
) -> anyhow::Result<Vec<Found>> {
    detector
        .detect(frame, stars)
        .map_err(|e| anyhow::anyhow!("{}: {e}", detector.name()))
}

/// One detector over the images in parallel, with a progress bar: `detect` gives an image's
/// detections and the seconds the detector spent on it.
fn run_detector<T: Send>(
    name: &str,
    images: &[TestFrame],
    progress: &dyn Progress,
    detect: impl Fn(usize, &TestFrame) -> anyhow::Result<(T, f64)> + Sync,
) -> anyhow::Result<(Vec<T>, Vec<f64>)> {
    progress.start(name, images.len() as u64);
    let results: Vec<(T, f64)> = images
        .par_iter()
        .enumerate()
        .map(|(i, img)| {
            crate::progress::check(progress)?;
            let found = detect(i, img)?;
            progress.advance();
            Ok(found)
        })
        .collect::<anyhow::Result<_>>()?;
    progress.finish();
    Ok(results.into_iter().unzip())
}

/// The classical streak detector. Survey images get the catalogued stars' trails, predicted as
/// the images were drawn, placed by the pointing offset measured on each image (nothing of the
/// truth: `star_trails`). Track images get the trail direction alone: the star-aware pass
/// recovers debris moving along the trails, and a tracked object does not move; its prediction
/// misses trails bent by the pointing jitter (up to 8 px at the ends of 300 px trails, which it
/// then reported as debris in the track quickstart; with the direction alone, none).
/// With `[detect] stars = "frame"`, no image gets either: the detector measures the star trails
/// on the image itself (`Stars::Unknown`), as on a user's bare frame.
fn streak_run(
    plan: &Plan,
    params: &crate::detect::streak::StreakParams,
    images: &[TestFrame],
    chosen: &[&Written],
    progress: &dyn Progress,
) -> anyhow::Result<DetectorRun> {
    let told = plan.detect.told;
    let inputs = match plan.detect.star_trails {
        true => Some(plan.inputs()?),
        false => None,
    };
    let detector = StreakDetector {
        params: params.clone(),
    };
    let (detections, seconds) = run_detector("streak", images, progress, |i, img| {
        let pixels = load(img)?;
        // The prediction is part of the detector's time.
        let t = Instant::now();
        let trails = match &inputs {
            Some(inputs) => Some(crate::star_trails::of_image(
                &plan.experiment,
                inputs,
                chosen[i].index,
                &pixels,
                img.width,
                img.height,
            )?),
            None => None,
        };
        let stars = if told {
            Stars::told(chosen[i].trail_angle_deg, trails.as_deref())
        } else {
            Stars::Unknown
        };
        let found = detect_once(&mut detector.clone(), img.frame(&pixels), stars)?;
        let seconds = t.elapsed().as_secs_f64();
        // The streak detector's ends and SNR, for the observations (`artifacts.astrometry`).
        let lines = found
            .iter()
            .filter_map(|f| match f {
                Found::Streak(c) => Some(Line {
                    ends: c.ends,
                    snr: Some(c.snr),
                }),
                Found::Box(_) => None,
            })
            .collect();
        Ok((
            (found.iter().map(|f| *f.detection()).collect(), lines),
            seconds,
        ))
    })?;
    let (detections, lines): (Vec<Vec<Detection>>, Vec<Vec<Line>>) = detections.into_iter().unzip();
    Ok(DetectorRun {
        name: "streak".into(),
        description: if told {
            "classical streak detector (background mesh, oriented line filters, components, moments; no model)".into()
        } else {
            "classical streak detector (background mesh, oriented line filters, components, moments; no model), star trails measured on each frame".into()
        },
        model_sha256: None,
        detections,
        seconds,
        lines: Some(lines),
    })
}

/// YOLO through ONNX Runtime. One single-threaded session per rayon thread (ONNX Runtime's own
/// pool slows ~3x beside a busy rayon pool), lent to whichever image a thread takes: every
/// image is detected exactly as on one thread (same detections for any thread count), and the
/// stage uses every core. Nothing inside `detect` waits on rayon, so at most that many images
/// are in flight and the pool never runs dry.
fn yolo_run(
    plan: &Plan,
    path: &Path,
    images: &[TestFrame],
    progress: &dyn Progress,
) -> anyhow::Result<DetectorRun> {
    let d = &plan.detect;
    let sessions = std::sync::Mutex::new(
        (0..rayon::current_num_threads())
            .map(|_| {
                YoloDetector::load(path, d.yolo)
                    .with_context(|| format!("loading model {}", path.display()))
            })
            .collect::<anyhow::Result<Vec<_>>>()?,
    );
    let (detections, seconds) = run_detector("yolo", images, progress, |_, img| {
        let pixels = load(img)?;
        let mut yolo = sessions
            .lock()
            .expect("no session holder panicked")
            .pop()
            .expect("one session per rayon thread");
        let t = Instant::now();
        let found = detect_once(&mut yolo, img.frame(&pixels), Stars::Unknown);
        let seconds = t.elapsed().as_secs_f64();
        sessions
            .lock()
            .expect("no session holder panicked")
            .push(yolo);
        let boxes: Vec<Detection> = found?.iter().map(|f| *f.detection()).collect();
        Ok((boxes, seconds))
    })?;
    Ok(DetectorRun {
        name: "yolo".into(),
        description: format!(
            "YOLOv8 {} through ONNX Runtime, conf {}, NMS IoU {}",
            d.model
                .as_ref()
                .map_or("train/model.onnx (trained by this run)", |m| m
                    .name
                    .as_str()),
            d.conf,
            d.yolo.iou
        ),
        model_sha256: match d.model.as_ref().and_then(|m| m.sha256.as_ref()) {
            Some(sha) => Some(sha.clone()),
            None => Some(crate::hash::sha256_file(path)?.0),
        },
        detections,
        seconds,
        lines: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::Campaign;
    use crate::pipeline::{RunOptions, run_with, written};
    use crate::shard::{RECORDS, Shard};

    /// The detectors open no truth file: a shard of the survey quickstart (its images' PNGs,
    /// labels, truth and records, nothing detected) has its truth folder taken away, and each
    /// detector still runs on every test image, told of the stars by the catalogue and, with
    /// `stars = "frame"`, by nothing.
    #[test]
    fn detectors_open_no_truth() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        for stars in ["catalogue", "frame"] {
            let sets = ["images=4".to_string(), format!("detect.stars=\"{stars}\"")];
            let campaign = Campaign::load_with_overrides(
                &root.join("campaigns/survey-quickstart.toml"),
                &sets,
            )
            .unwrap();
            assert_eq!(
                format!("{:?}", campaign.resolved.detect.stars).to_lowercase(),
                stars
            );
            let tmp = tempfile::tempdir().unwrap();
            // A shard index of the count is refused, not a panic (the library's callers).
            let beyond = RunOptions {
                shard: Some(Shard { index: 1, count: 1 }),
                ..RunOptions::default()
            };
            let out = tmp.path().join("beyond");
            assert!(run_with(&campaign, &out, beyond, None, &crate::progress::Silent).is_err());
            let dir = tmp.path().join("shard");
            let options = RunOptions {
                shard: Some(Shard { index: 0, count: 1 }),
                ..RunOptions::default()
            };
            run_with(&campaign, &dir, options, None, &crate::progress::Silent).unwrap();
            let records: Vec<crate::journal::Record> = std::fs::read_to_string(dir.join(RECORDS))
                .unwrap()
                .lines()
                .map(|l| serde_json::from_str(l).unwrap())
                .collect();
            let plan = Plan::new(&campaign).unwrap();
            let written = written(&plan, &dir, &records);
            let chosen: Vec<&Written> = written.iter().filter(|w| w.png.is_some()).collect();
            assert_eq!(chosen.len(), 4);
            let hidden = tmp.path().join("hidden-truth");
            std::fs::rename(dir.join("truth"), &hidden).unwrap();
            let runs = run_detectors(&plan, &chosen, None, &crate::progress::Silent).unwrap();
            assert_eq!(runs.len(), 1, "the streak detector");
            let found: usize = runs[0].detections.iter().map(Vec::len).sum();
            assert!(found > 0, "{stars}: the detector ran and found streaks");
            // The truth is gone indeed: the report's half cannot read it.
            assert!(test_images(&dir, &chosen).is_err());
            std::fs::rename(&hidden, dir.join("truth")).unwrap();
            assert_eq!(test_images(&dir, &chosen).unwrap().len(), 4);
        }
    }
}
