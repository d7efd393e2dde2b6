//! `soig eval` and Python's `soig.eval`: YOLO-format label and prediction folders scored as
//! Ultralytics or pycocotools score them, plus precision and recall at one confidence and IoU.
//! One function for both, so the two can never disagree.

use std::path::{Path, PathBuf};

use super::{AtThreshold, CocoMetrics, MetricsError, UltralyticsMetrics};

/// Which reference's metrics to compute.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EvalMode {
    Ultralytics,
    Coco,
    /// Oriented boxes (YOLO-OBB files), as Ultralytics' OBB validator scores them.
    UltralyticsObb,
}

/// How to score: the mode, where the images are (their sizes turn normalised boxes into pixels;
/// without them every image is `image_size` square), and the fixed threshold's confidence and IoU.
#[derive(Clone, Copy, Debug)]
pub struct EvalOptions<'a> {
    pub mode: EvalMode,
    pub images: Option<&'a Path>,
    pub image_size: u32,
    pub conf: f64,
    pub iou: f64,
}

/// The metrics of one mode.
#[derive(Clone, Debug)]
pub enum Scores {
    Ultralytics(UltralyticsMetrics),
    Coco(CocoMetrics),
    UltralyticsObb(UltralyticsMetrics),
}

/// What `eval_dirs` measured.
#[derive(Clone, Debug)]
pub struct Evaluation {
    pub images: usize,
    pub scores: Scores,
    pub conf: f64,
    pub iou: f64,
    pub at_threshold: AtThreshold,
}

/// A folder that cannot be scored.
#[derive(thiserror::Error, Debug)]
pub enum EvalError {
    #[error(transparent)]
    Files(#[from] MetricsError),
    #[error("no image for {stem} in {}", dir.display())]
    NoImage { stem: String, dir: PathBuf },
    #[error("{}: {message}", path.display())]
    Image { path: PathBuf, message: String },
    /// An option out of its range, by name.
    #[error("`{name}` = {value}: {allowed}")]
    Option {
        name: &'static str,
        value: String,
        allowed: &'static str,
    },
}

/// Refuse an option out of its range (NaN included), by name, before any file is read.
fn check(options: &EvalOptions) -> Result<(), EvalError> {
    let bad = |name, value: String, allowed| {
        Err(EvalError::Option {
            name,
            value,
            allowed,
        })
    };
    if options.images.is_none() && !(1..=65_536).contains(&options.image_size) {
        return bad(
            "image_size",
            options.image_size.to_string(),
            "must be between 1 and 65536 pixels",
        );
    }
    if !(0.0..=1.0).contains(&options.conf) {
        return bad(
            "conf",
            options.conf.to_string(),
            "must be a confidence in [0, 1]",
        );
    }
    if !(options.iou > 0.0 && options.iou <= 1.0) {
        return bad(
            "iou",
            options.iou.to_string(),
            "must be an IoU threshold in (0, 1]",
        );
    }
    Ok(())
}

/// Score the predictions in `predictions` against the labels in `labels` (YOLO text files paired
/// by stem).
pub fn eval_dirs(
    labels: &Path,
    predictions: &Path,
    options: EvalOptions,
) -> Result<Evaluation, EvalError> {
    check(&options)?;
    if options.mode == EvalMode::UltralyticsObb {
        return eval_obb_dirs(labels, predictions, options);
    }
    let pairs = super::read_yolo_dirs(labels, predictions)?;
    let mut scaled = Vec::with_capacity(pairs.len());
    for (stem, e) in &pairs {
        let (w, h) = match options.images {
            Some(dir) => image_size_of(dir, stem)?,
            None => (options.image_size, options.image_size),
        };
        scaled.push(e.scaled(w as f64, h as f64));
    }
    Ok(Evaluation {
        images: scaled.len(),
        scores: match options.mode {
            EvalMode::Ultralytics => Scores::Ultralytics(super::ultralytics(&scaled)),
            EvalMode::Coco => Scores::Coco(super::coco(&scaled)),
            EvalMode::UltralyticsObb => unreachable!("scored by eval_obb_dirs"),
        },
        conf: options.conf,
        iou: options.iou,
        at_threshold: super::at_threshold(&scaled, options.conf, options.iou),
    })
}

/// [`eval_dirs`] of oriented boxes: corners scaled to pixels as axis-aligned boxes are.
fn eval_obb_dirs(
    labels: &Path,
    predictions: &Path,
    options: EvalOptions,
) -> Result<Evaluation, EvalError> {
    let mut scaled = Vec::new();
    for (stem, e) in super::read_obb_dirs(labels, predictions)? {
        let (w, h) = match options.images {
            Some(dir) => image_size_of(dir, &stem)?,
            None => (options.image_size, options.image_size),
        };
        scaled.push(e.scaled(w as f64, h as f64));
    }
    Ok(Evaluation {
        images: scaled.len(),
        scores: Scores::UltralyticsObb(super::ultralytics_obb(&scaled)),
        conf: options.conf,
        iou: options.iou,
        at_threshold: super::at_threshold_obb(&scaled, options.conf, options.iou),
    })
}

/// The size of image `stem` in `dir` (PNG or JPEG).
fn image_size_of(dir: &Path, stem: &str) -> Result<(u32, u32), EvalError> {
    let path = ["png", "jpg", "jpeg"]
        .iter()
        .map(|ext| dir.join(format!("{stem}.{ext}")))
        .find(|p| p.is_file())
        .ok_or_else(|| EvalError::NoImage {
            stem: stem.into(),
            dir: dir.to_path_buf(),
        })?;
    image::image_dimensions(&path).map_err(|e| EvalError::Image {
        message: e.to_string(),
        path,
    })
}

impl Evaluation {
    /// The mode's name, as `soig eval --mode` takes it.
    fn mode_name(&self) -> &'static str {
        match self.scores {
            Scores::Ultralytics(_) => "ultralytics",
            Scores::Coco(_) => "coco",
            Scores::UltralyticsObb(_) => "ultralytics-obb",
        }
    }

    /// The figures as JSON (`soig eval --json`, Python's `soig.eval`).
    pub fn to_json(&self) -> serde_json::Value {
        let fixed = &self.at_threshold;
        let fixed = serde_json::json!({
            "conf": self.conf, "iou": self.iou, "precision": fixed.precision, "recall": fixed.recall,
            "tp": fixed.tp, "fp": fixed.fp, "fn": fixed.fn_,
        });
        match &self.scores {
            Scores::Ultralytics(m) | Scores::UltralyticsObb(m) => serde_json::json!({
                "mode": self.mode_name(), "images": self.images, "objects": m.n_truth,
                "detections": m.n_detections, "precision": m.precision, "recall": m.recall,
                "map50": m.map50, "map50_95": m.map50_95, "f1_conf": m.f1_conf,
                "at_threshold": fixed,
            }),
            Scores::Coco(m) => serde_json::json!({
                "mode": "coco", "images": self.images, "ap": m.ap, "ap50": m.ap50,
                "ap75": m.ap75, "ar100": m.ar100, "at_threshold": fixed,
            }),
        }
    }

    /// The figures as `soig eval` prints them.
    pub fn text(&self) -> String {
        let (conf, iou, fixed) = (self.conf, self.iou, &self.at_threshold);
        let threshold = format!(
            "at conf {conf}, IoU {iou}: P {:.4}  R {:.4}  (TP {}, FP {}, FN {})",
            fixed.precision, fixed.recall, fixed.tp, fixed.fp, fixed.fn_
        );
        match &self.scores {
            Scores::Ultralytics(m) | Scores::UltralyticsObb(m) => format!(
                "{}: {} images, {} objects, {} detections\nP {:.4}  R {:.4}  mAP50 {:.4}  mAP50-95 {:.4}  (P, R at max-F1 confidence {:.3})\n{threshold}",
                self.mode_name(),
                self.images,
                m.n_truth,
                m.n_detections,
                m.precision,
                m.recall,
                m.map50,
                m.map50_95,
                m.f1_conf,
            ),
            Scores::Coco(m) => format!(
                "coco: {} images\nAP {:.4}  AP50 {:.4}  AP75 {:.4}  AR100 {:.4}\n{threshold}",
                self.images, m.ap, m.ap50, m.ap75, m.ar100,
            ),
        }
    }
}
