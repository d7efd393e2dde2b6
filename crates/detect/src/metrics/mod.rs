//! Detection metrics, each computed exactly as its reference implementation does.
//!
//! * [`ultralytics`]: the validation metrics of Ultralytics YOLO (`ultralytics` 8.4.190:
//!   `DetectionValidator.update_metrics` -> `box_iou` -> `BaseValidator.match_predictions` ->
//!   `DetMetrics.process` -> `ap_per_class`). [`ultralytics_with`] with [`UltralyticsVersion::Legacy`]
//!   gives the older code (8.3.0 and the 8.3.x line): its `match_predictions` resolves conflicts with
//!   `np.unique`, its `compute_ap` has a single end sentinel, and its validator reports zeros when there is
//!   no true positive at any IoU. The two versions give different mAP on the same input (see the tests).
//! * [`coco`]: pycocotools `COCOeval` (iouType "bbox", area "all", maxDets 100), no crowd boxes.
//! * [`at_threshold`]: precision / recall / TP / FP / FN at a fixed confidence and IoU (this module's own
//!   definition, documented on the function).
//! * [`read_yolo_dirs`]: YOLO-format label and prediction text files.
//! * [`ultralytics_obb`]: the same for oriented boxes (YOLO-OBB files, [`read_obb_dirs`]), as
//!   Ultralytics' `OBBValidator` scores them: probabilistic IoU ([`probiou`]) of the boxes'
//!   minimum-area rectangles ([`xywhr`]).
//!
//! Reference figures come from `tests/reference/metrics_reference.py` (the real pycocotools and Ultralytics
//! code); the tests pin them to 1e-6.
//!
//! # Where the results depend on more than the numbers
//! * Ultralytics IoU is computed in `f32` with `eps = 1e-7` added to the union (its `box_iou`), so it is
//!   not exactly scale invariant: give boxes in pixels, as its validator does (see [`ImageEval::scaled`]).
//!   Scores are rounded to `f32` too (the model's output type).
//! * Tied confidences. Ultralytics sorts with `np.argsort(-conf)`, whose order among equal values is not
//!   defined and, on current numpy, comes from SIMD sorting networks (it differs between machines; on an
//!   AVX2 machine it is not even stable for 5 elements). This module keeps tied detections in input order
//!   (image order, then per image in input order), the order pycocotools' mergesort gives. The result
//!   depends on that order only where a group of tied detections mixes true and false positives at some
//!   IoU threshold; where every tied group is all-TP or all-FP the result is the same for every order.
//! * Within an image, Ultralytics matches detections in the order its NMS returns them (descending
//!   confidence); this module sorts each image's detections by descending score, stably.
//! * Legacy matching, one detection with exactly equal IoU to two objects: numpy's unstable argsort decides;
//!   this module takes the later object (what a stable argsort reversed gives).
//!
//! One file per job: `ultralytics_map` (Ultralytics AP / mAP), `coco_eval` (pycocotools), `matching`
//! (box IoU and the fixed-threshold counts), `yolo_files` (label and prediction files), `numpy` (the
//! numpy arithmetic both references rest on); the reference cases and their pinned figures are in
//! `cases` (tests only).

mod coco_eval;
mod eval;
mod matching;
mod numpy;
mod obb;
mod ultralytics_map;
mod yolo_files;

#[cfg(test)]
mod cases;

pub use coco_eval::{CocoMetrics, coco};
pub use eval::{EvalError, EvalMode, EvalOptions, Evaluation, Scores, eval_dirs};
pub use matching::{AtThreshold, ImageMatch, at_threshold, iou, match_image};
pub use obb::{ObbImage, at_threshold_obb, probiou, read_obb_dirs, ultralytics_obb, xywhr};
pub use ultralytics_map::{UltralyticsMetrics, UltralyticsVersion, ultralytics, ultralytics_with};
pub use yolo_files::{MetricsError, parse_yolo, read_yolo_dirs, read_yolo_file};

use crate::Detection;
use serde::{Deserialize, Serialize};
use std::cmp::Ordering;

/// Ground truth and detections of one image (boxes in any consistent unit: IoU is invariant to per-axis
/// scaling, except for Ultralytics' `eps`, see the module docs).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ImageEval {
    /// Object boxes, `[x1, y1, x2, y2]`.
    pub truth: Vec<[f64; 4]>,
    /// One class per entry of `truth`.
    pub truth_class: Vec<u32>,
    pub detections: Vec<Detection>,
}

impl ImageEval {
    /// The same image with x coordinates multiplied by `sx` and y coordinates by `sy` (e.g. normalised
    /// YOLO boxes to pixels: `sx = width`, `sy = height`).
    pub fn scaled(&self, sx: f64, sy: f64) -> ImageEval {
        ImageEval {
            truth: self
                .truth
                .iter()
                .map(|b| [b[0] * sx, b[1] * sy, b[2] * sx, b[3] * sy])
                .collect(),
            truth_class: self.truth_class.clone(),
            detections: self
                .detections
                .iter()
                .map(|d| Detection {
                    x1: d.x1 * sx,
                    y1: d.y1 * sy,
                    x2: d.x2 * sx,
                    y2: d.y2 * sy,
                    ..*d
                })
                .collect(),
        }
    }

    fn check(&self) {
        assert_eq!(
            self.truth.len(),
            self.truth_class.len(),
            "ImageEval: truth_class must hold one class per truth box"
        );
    }
}

fn det_box(d: &Detection) -> [f64; 4] {
    [d.x1, d.y1, d.x2, d.y2]
}

/// The detection of box `[x1, y1, x2, y2]` (the inverse of `det_box`).
fn box_det(b: [f64; 4], score: f64, class: u32) -> Detection {
    Detection {
        x1: b[0],
        y1: b[1],
        x2: b[2],
        y2: b[3],
        score,
        class,
    }
}

/// Descending order, NaN last, equal values equal (so that a stable sort keeps their order).
fn cmp_desc(a: f64, b: f64) -> Ordering {
    match (a.is_nan(), b.is_nan()) {
        (true, true) => Ordering::Equal,
        (true, false) => Ordering::Greater,
        (false, true) => Ordering::Less,
        _ => b.partial_cmp(&a).unwrap_or(Ordering::Equal),
    }
}
