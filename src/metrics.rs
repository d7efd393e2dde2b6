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

use crate::detect::Detection;
use serde::{Deserialize, Serialize};
use std::cmp::Ordering;
use std::path::{Path, PathBuf};

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

/// Intersection over union of two `[x1, y1, x2, y2]` boxes (no `+1`, no epsilon); 0 when the union is
/// empty.
pub fn iou(a: &[f64; 4], b: &[f64; 4]) -> f64 {
    let w = (a[2].min(b[2]) - a[0].max(b[0])).max(0.0);
    let h = (a[3].min(b[3]) - a[1].max(b[1])).max(0.0);
    let inter = w * h;
    let union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter;
    if union > 0.0 { inter / union } else { 0.0 }
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

// ---------------------------------------------------------------------------------------------------
// numpy building blocks
// ---------------------------------------------------------------------------------------------------

/// `np.linspace(start, stop, num)` (endpoint included), computed as numpy does: `i * step + start`, with
/// the last value set to `stop`.
fn np_linspace(start: f64, stop: f64, num: usize) -> Vec<f64> {
    let step = (stop - start) / (num - 1) as f64;
    let mut y: Vec<f64> = (0..num).map(|i| i as f64 * step + start).collect();
    y[num - 1] = stop;
    y
}

/// `np.interp(x, xp, fp, left, right)` for one `x`, with numpy's choice of segment (the last `j` with
/// `xp[j] <= x`, so repeated `xp` take the value of the last repeat) and its formula.
fn np_interp(x: f64, xp: &[f64], fp: &[f64], left: f64, right: f64) -> f64 {
    let n = xp.len();
    if n == 1 {
        return if x < xp[0] {
            left
        } else if x > xp[0] {
            right
        } else {
            fp[0]
        };
    }
    if x > xp[n - 1] {
        return right;
    }
    if x < xp[0] {
        return left;
    }
    let j = xp.partition_point(|&v| v <= x) - 1;
    if j == n - 1 || xp[j] == x {
        return fp[j];
    }
    let slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j]);
    let mut r = slope * (x - xp[j]) + fp[j];
    if r.is_nan() {
        r = slope * (x - xp[j + 1]) + fp[j + 1];
        if r.is_nan() && fp[j] == fp[j + 1] {
            r = fp[j];
        }
    }
    r
}

/// numpy's pairwise summation (`np.add.reduce` on a contiguous float64 array).
fn np_sum(a: &[f64]) -> f64 {
    fn pairwise(a: &[f64]) -> f64 {
        let n = a.len();
        if n < 8 {
            let mut res = 0.0;
            for &v in a {
                res += v;
            }
            res
        } else if n <= 128 {
            let mut r = [0.0; 8];
            r.copy_from_slice(&a[..8]);
            let mut i = 8;
            while i < n - n % 8 {
                for (k, rk) in r.iter_mut().enumerate() {
                    *rk += a[i + k];
                }
                i += 8;
            }
            let mut res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
            while i < n {
                res += a[i];
                i += 1;
            }
            res
        } else {
            let mut n2 = n / 2;
            n2 -= n2 % 8;
            pairwise(&a[..n2]) + pairwise(&a[n2..])
        }
    }
    0.0 + pairwise(a)
}

fn np_mean(a: &[f64]) -> f64 {
    np_sum(a) / a.len() as f64
}

/// `np.trapezoid(y, x)` for 1-D arrays.
fn np_trapezoid(y: &[f64], x: &[f64]) -> f64 {
    let terms: Vec<f64> = (0..y.len() - 1)
        .map(|i| (x[i + 1] - x[i]) * (y[i + 1] + y[i]) / 2.0)
        .collect();
    np_sum(&terms)
}

/// Row mean of equally long rows (`a.mean(0)`); empty when there are no rows.
fn mean_rows(rows: &[Vec<f64>]) -> Vec<f64> {
    let Some(first) = rows.first() else {
        return Vec::new();
    };
    let mut out = vec![0.0; first.len()];
    for row in rows {
        for (o, v) in out.iter_mut().zip(row) {
            *o += v;
        }
    }
    let n = rows.len() as f64;
    out.iter_mut().for_each(|o| *o /= n);
    out
}

// ---------------------------------------------------------------------------------------------------
// Ultralytics
// ---------------------------------------------------------------------------------------------------

/// Which Ultralytics code to reproduce.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum UltralyticsVersion {
    /// `ultralytics` 8.4.190 (current when written): greedy matching in confidence order, each detection
    /// taking the best unclaimed object per IoU threshold; `compute_ap` ends the curve at
    /// `(recall_max, 0)`; metrics always computed.
    #[default]
    Current,
    /// `ultralytics` 8.3.0 (the 8.3.x line): `match_predictions` with the `np.unique` pruning (each detection
    /// keeps its best object, each object its first such detection, no re-matching); `compute_ap` with the
    /// sentinels `(0, 1)` and `(1, 0)` only (the precision envelope interpolated to recall 1); all metrics
    /// zero when no detection is a true positive at any IoU.
    Legacy,
}

/// Validation metrics as Ultralytics reports them (means over the classes that have objects).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UltralyticsMetrics {
    /// Mean precision at the confidence of maximum (smoothed, class-mean) F1.
    pub precision: f64,
    /// Mean recall at that confidence.
    pub recall: f64,
    /// mAP at IoU 0.5.
    pub map50: f64,
    /// mAP over IoU 0.50:0.05:0.95.
    pub map50_95: f64,
    /// Class-mean AP at each of the 10 IoU thresholds.
    pub ap_per_iou: Vec<f64>,
    /// The confidence (`px[i]`) where the smoothed F1 is largest.
    pub f1_conf: f64,
    /// Confidence grid, `np.linspace(0, 1, 1000)`; also the recall grid of `pr_curve_map50`.
    pub px: Vec<f64>,
    /// Class-mean precision against confidence on `px` (empty when no class has objects).
    pub precision_curve: Vec<f64>,
    /// Class-mean recall against confidence on `px` (empty when no class has objects).
    pub recall_curve: Vec<f64>,
    /// Class-mean F1 against confidence on `px`, unsmoothed (empty when no class has objects).
    pub f1_curve: Vec<f64>,
    /// Class-mean precision envelope against recall on `px` at IoU 0.5 (Ultralytics' `prec_values`);
    /// `Current`: zeros when no class has objects; `Legacy`: only classes with detections and objects
    /// count, empty when there are none.
    pub pr_curve_map50: Vec<f64>,
    pub n_truth: usize,
    pub n_detections: usize,
}

/// The IoU thresholds of the Ultralytics validator, `torch.linspace(0.5, 0.95, 10)` (float32).
const ULTRA_IOUV: [f32; 10] = [0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85, 0.9, 0.95];

/// Ultralytics `box_iou` for one pair: float32 arithmetic, `eps = 1e-7` in the denominator.
fn ultra_box_iou(a: &[f64; 4], b: &[f64; 4]) -> f32 {
    let a: [f32; 4] = a.map(|v| v as f32);
    let b: [f32; 4] = b.map(|v| v as f32);
    let wx = (a[2].min(b[2]) - a[0].max(b[0])).max(0.0);
    let wy = (a[3].min(b[3]) - a[1].max(b[1])).max(0.0);
    let inter = wx * wy;
    let area1 = (a[2] - a[0]) * (a[3] - a[1]);
    let area2 = (b[2] - b[0]) * (b[3] - b[1]);
    inter / (area1 + area2 - inter + 1e-7_f32)
}

/// `match_predictions` for one image: `iou[l][j]` (objects x detections, zero across classes), detections
/// in descending confidence. Returns `correct[j][t]`.
fn ultra_match(iou: &[Vec<f32>], n_det: usize, version: UltralyticsVersion) -> Vec<[bool; 10]> {
    let mut correct = vec![[false; 10]; n_det];
    let n_truth = iou.len();
    match version {
        UltralyticsVersion::Current => {
            let mut matched = vec![[false; 10]; n_truth];
            for (j, correct_j) in correct.iter_mut().enumerate() {
                if !iou.iter().any(|row| row[j] >= ULTRA_IOUV[0]) {
                    continue;
                }
                for (t, &thr) in ULTRA_IOUV.iter().enumerate() {
                    // np.where(matched, 0, iou[:, j]).argmax(0): first maximum
                    let mut k = 0;
                    let mut best = f32::NEG_INFINITY;
                    for (l, row) in iou.iter().enumerate() {
                        let v = if matched[l][t] { 0.0 } else { row[j] };
                        if v > best {
                            best = v;
                            k = l;
                        }
                    }
                    correct_j[t] = best >= thr;
                    if correct_j[t] {
                        matched[k][t] = true;
                    }
                }
            }
        }
        UltralyticsVersion::Legacy => {
            for (t, &thr) in ULTRA_IOUV.iter().enumerate() {
                // each detection's best object (ties: the later object), then each object keeps the
                // lowest-index detection whose best it is
                let mut best_of_det: Vec<Option<usize>> = vec![None; n_det];
                for (j, best) in best_of_det.iter_mut().enumerate() {
                    let mut best_v = f32::NEG_INFINITY;
                    for (l, row) in iou.iter().enumerate() {
                        if row[j] >= thr && row[j] >= best_v {
                            best_v = row[j];
                            *best = Some(l);
                        }
                    }
                }
                let mut taken = vec![false; n_truth];
                for (j, best) in best_of_det.iter().enumerate() {
                    if let Some(l) = *best
                        && !taken[l]
                    {
                        taken[l] = true;
                        correct[j][t] = true;
                    }
                }
            }
        }
    }
    correct
}

/// Ultralytics validation metrics (current version); see [`ultralytics_with`].
pub fn ultralytics(images: &[ImageEval]) -> UltralyticsMetrics {
    ultralytics_with(images, UltralyticsVersion::Current)
}

/// Exactly as Ultralytics computes val metrics: IoU thresholds 0.50:0.05:0.95 (float32), per image
/// `match_predictions` (IoU-based, class-aware; greedy in confidence order for `Current`, the `np.unique`
/// pruning for `Legacy`), then `ap_per_class` over all images: 101-point interpolation of the precision
/// envelope with sentinels, trapezoid rule (`np.trapezoid`), precision / recall / F1 curves against
/// confidence on the 1000-point `px` grid, and P and R at the maximum of `smooth(f1.mean(0), 0.1)`.
///
/// No objects at all gives zeros (Ultralytics warns and reports 0); no detections gives zeros.
/// Detection classes without any object are ignored, as in `ap_per_class`.
pub fn ultralytics_with(images: &[ImageEval], version: UltralyticsVersion) -> UltralyticsMetrics {
    let px = np_linspace(0.0, 1.0, 1000);
    let n_truth: usize = images.iter().map(|im| im.truth.len()).sum();
    let n_detections: usize = images.iter().map(|im| im.detections.len()).sum();

    // Per-detection statistics in validator order (image order, NMS order within an image).
    let mut tp: Vec<[bool; 10]> = Vec::new();
    let mut conf: Vec<f32> = Vec::new();
    let mut pred_cls: Vec<u32> = Vec::new();
    let mut target_cls: Vec<u32> = Vec::new();
    for im in images {
        im.check();
        target_cls.extend_from_slice(&im.truth_class);
        let mut dets: Vec<(f32, &Detection)> =
            im.detections.iter().map(|d| (d.score as f32, d)).collect();
        dets.sort_by(|a, b| cmp_desc(a.0 as f64, b.0 as f64));
        let correct = if im.truth.is_empty() || dets.is_empty() {
            vec![[false; 10]; dets.len()]
        } else {
            let iou: Vec<Vec<f32>> = im
                .truth
                .iter()
                .zip(&im.truth_class)
                .map(|(t, &tc)| {
                    dets.iter()
                        .map(|(_, d)| {
                            if d.class == tc {
                                ultra_box_iou(t, &det_box(d))
                            } else {
                                0.0
                            }
                        })
                        .collect()
                })
                .collect();
            ultra_match(&iou, dets.len(), version)
        };
        tp.extend(correct);
        conf.extend(dets.iter().map(|(c, _)| *c));
        pred_cls.extend(dets.iter().map(|(_, d)| d.class));
    }

    let zero = |px: Vec<f64>| UltralyticsMetrics {
        precision: 0.0,
        recall: 0.0,
        map50: 0.0,
        map50_95: 0.0,
        ap_per_iou: vec![0.0; 10],
        f1_conf: 0.0,
        px,
        precision_curve: Vec::new(),
        recall_curve: Vec::new(),
        f1_curve: Vec::new(),
        pr_curve_map50: Vec::new(),
        n_truth,
        n_detections,
    };
    if version == UltralyticsVersion::Legacy && !tp.iter().any(|row| row.iter().any(|&b| b)) {
        // 8.3.x get_stats: `if len(stats) and stats["tp"].any(): self.metrics.process(...)`
        return zero(px);
    }

    // ap_per_class
    let mut order: Vec<usize> = (0..conf.len()).collect();
    order.sort_by(|&a, &b| cmp_desc(conf[a] as f64, conf[b] as f64));
    let mut classes = target_cls.clone();
    classes.sort_unstable();
    classes.dedup();
    let nc = classes.len();
    let ap_x = np_linspace(0.0, 1.0, 101);
    let mut ap = vec![[0.0f64; 10]; nc];
    let mut p_curve = vec![vec![0.0; 1000]; nc];
    let mut r_curve = vec![vec![0.0; 1000]; nc];
    let mut prec_values: Vec<Vec<f64>> = Vec::new();
    for (ci, &c) in classes.iter().enumerate() {
        let n_l = target_cls.iter().filter(|&&t| t == c).count();
        let idx: Vec<usize> = order
            .iter()
            .copied()
            .filter(|&i| pred_cls[i] == c)
            .collect();
        if idx.is_empty() || n_l == 0 {
            if version == UltralyticsVersion::Current {
                prec_values.push(vec![0.0; 1000]);
            }
            continue;
        }
        let xp: Vec<f64> = idx.iter().map(|&i| -(conf[i] as f64)).collect();
        let mut recall: Vec<Vec<f64>> = (0..10).map(|_| Vec::with_capacity(idx.len())).collect();
        let mut precision: Vec<Vec<f64>> = (0..10).map(|_| Vec::with_capacity(idx.len())).collect();
        for (t, (rec_t, prec_t)) in recall.iter_mut().zip(precision.iter_mut()).enumerate() {
            let (mut tpc, mut fpc) = (0u64, 0u64);
            for &i in &idx {
                if tp[i][t] {
                    tpc += 1;
                } else {
                    fpc += 1;
                }
                rec_t.push(tpc as f64 / (n_l as f64 + 1e-16));
                prec_t.push(tpc as f64 / (tpc + fpc) as f64);
            }
        }
        let r_last = *recall[0].last().unwrap_or(&0.0);
        let p_last = *precision[0].last().unwrap_or(&0.0);
        for (k, &x) in px.iter().enumerate() {
            r_curve[ci][k] = np_interp(-x, &xp, &recall[0], 0.0, r_last);
            p_curve[ci][k] = np_interp(-x, &xp, &precision[0], 1.0, p_last);
        }
        for t in 0..10 {
            let (a, mpre, mrec) = compute_ap(&recall[t], &precision[t], &ap_x, version);
            ap[ci][t] = a;
            if t == 0 {
                let last = *mpre.last().unwrap_or(&0.0);
                prec_values.push(
                    px.iter()
                        .map(|&x| np_interp(x, &mrec, &mpre, mpre[0], last))
                        .collect(),
                );
            }
        }
    }
    if prec_values.is_empty() && version == UltralyticsVersion::Current {
        prec_values.push(vec![0.0; 1000]); // `np.zeros((1, 1000))`
    }
    let f1_rows: Vec<Vec<f64>> = (0..nc)
        .map(|ci| {
            p_curve[ci]
                .iter()
                .zip(&r_curve[ci])
                .map(|(&p, &r)| 2.0 * p * r / (p + r + 1e-16))
                .collect()
        })
        .collect();
    let f1_mean = mean_rows(&f1_rows);
    let i = if nc == 0 {
        0
    } else {
        argmax_first(&smooth(&f1_mean, 0.1))
    };
    let p_at: Vec<f64> = p_curve.iter().map(|row| row[i]).collect();
    let r_at: Vec<f64> = r_curve.iter().map(|row| row[i]).collect();
    let ap50: Vec<f64> = ap.iter().map(|row| row[0]).collect();
    let ap_flat: Vec<f64> = ap.iter().flatten().copied().collect();
    let ap_per_iou: Vec<f64> = if nc == 0 {
        vec![0.0; 10]
    } else {
        (0..10)
            .map(|t| np_mean(&ap.iter().map(|row| row[t]).collect::<Vec<_>>()))
            .collect()
    };
    let mean_or_zero = |v: &[f64]| if v.is_empty() { 0.0 } else { np_mean(v) };
    UltralyticsMetrics {
        precision: mean_or_zero(&p_at),
        recall: mean_or_zero(&r_at),
        map50: mean_or_zero(&ap50),
        map50_95: mean_or_zero(&ap_flat),
        ap_per_iou,
        f1_conf: px[i],
        precision_curve: mean_rows(&p_curve),
        recall_curve: mean_rows(&r_curve),
        f1_curve: f1_mean,
        pr_curve_map50: mean_rows(&prec_values),
        px,
        n_truth,
        n_detections,
    }
}

/// Ultralytics `compute_ap`: returns `(ap, mpre, mrec)`.
fn compute_ap(
    recall: &[f64],
    precision: &[f64],
    ap_x: &[f64],
    version: UltralyticsVersion,
) -> (f64, Vec<f64>, Vec<f64>) {
    let mut mrec = vec![0.0];
    mrec.extend_from_slice(recall);
    let mut mpre = vec![1.0];
    mpre.extend_from_slice(precision);
    if version == UltralyticsVersion::Current {
        mrec.push(*recall.last().unwrap_or(&1.0));
        mpre.push(0.0);
    }
    mrec.push(1.0);
    mpre.push(0.0);
    for k in (0..mpre.len() - 1).rev() {
        mpre[k] = mpre[k].max(mpre[k + 1]);
    }
    let last = *mpre.last().unwrap_or(&0.0);
    let y: Vec<f64> = ap_x
        .iter()
        .map(|&x| np_interp(x, &mrec, &mpre, mpre[0], last))
        .collect();
    (np_trapezoid(&y, ap_x), mpre, mrec)
}

/// Ultralytics `smooth`: box filter of `round(len * f * 2) // 2 + 1` points, edges padded with the end values.
fn smooth(y: &[f64], f: f64) -> Vec<f64> {
    let nf = ((y.len() as f64 * f * 2.0).round_ties_even() as usize) / 2 + 1;
    let half = nf / 2;
    let mut yp = vec![y[0]; half];
    yp.extend_from_slice(y);
    yp.extend(std::iter::repeat_n(y[y.len() - 1], half));
    let w = 1.0 / nf as f64;
    (0..y.len())
        .map(|k| {
            let mut s = 0.0;
            for v in &yp[k..k + nf] {
                s += v * w;
            }
            s
        })
        .collect()
}

/// `np.argmax`: index of the first maximum (the first NaN if any).
fn argmax_first(v: &[f64]) -> usize {
    let mut best = 0;
    for (i, &x) in v.iter().enumerate() {
        if x.is_nan() {
            return i;
        }
        if x > v[best] {
            best = i;
        }
    }
    best
}

// ---------------------------------------------------------------------------------------------------
// COCO
// ---------------------------------------------------------------------------------------------------

/// COCO metrics as pycocotools reports them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CocoMetrics {
    /// AP@[.5:.95] (stats[0]); -1 when no class has objects.
    pub ap: f64,
    /// AP at IoU 0.5 (stats[1]).
    pub ap50: f64,
    /// AP at IoU 0.75 (stats[2]).
    pub ap75: f64,
    /// AR with at most 100 detections per image (stats[8]).
    pub ar100: f64,
    /// The 101-point interpolated precision at IoU 0.5 (`eval['precision'][0, :, k, 0, 2]`), averaged
    /// over the classes where it is defined; -1 where no class defines it.
    pub precision_at_50: Vec<f64>,
}

const COCO_MAX_DETS: usize = 100;
/// `areaRng` "all": `[0 ** 2, 1e5 ** 2]`.
const COCO_AREA: [f64; 2] = [0.0, 1e10];

/// pycocotools `bbIou` on `[x, y, w, h]` boxes, no crowd.
fn coco_iou(d: &[f64; 4], g: &[f64; 4]) -> f64 {
    let ga = g[2] * g[3];
    let da = d[2] * d[3];
    let w = (d[2] + d[0]).min(g[2] + g[0]) - d[0].max(g[0]);
    if w <= 0.0 {
        return 0.0;
    }
    let h = (d[3] + d[1]).min(g[3] + g[1]) - d[1].max(g[1]);
    if h <= 0.0 {
        return 0.0;
    }
    let i = w * h;
    i / (da + ga - i)
}

fn xywh(b: &[f64; 4]) -> [f64; 4] {
    [b[0], b[1], b[2] - b[0], b[3] - b[1]]
}

/// One `evaluateImg` result (area "all", maxDet 100).
struct CocoImage {
    scores: Vec<f64>,
    dt_matched: Vec<[bool; 10]>,
    dt_ignore: Vec<[bool; 10]>,
    gt_ignore: Vec<bool>,
}

fn coco_evaluate_img(
    gts: &[[f64; 4]],
    dts: &[(f64, [f64; 4])],
    iou_thrs: &[f64],
) -> Option<CocoImage> {
    if gts.is_empty() && dts.is_empty() {
        return None;
    }
    // `area < aRng[0] or area > aRng[1]`, written out so that a NaN area is in range as in pycocotools
    #[allow(clippy::manual_range_contains)]
    let out_of_range = |b: &[f64; 4]| {
        let a = b[2] * b[3];
        a < COCO_AREA[0] || a > COCO_AREA[1]
    };
    // gt sorted ignore-last (stable), dt by descending score (stable), at most maxDet
    let mut gt: Vec<([f64; 4], bool)> = gts.iter().map(|b| (*b, out_of_range(b))).collect();
    gt.sort_by_key(|g| g.1);
    let mut dt: Vec<(f64, [f64; 4])> = dts.to_vec();
    dt.sort_by(|a, b| cmp_desc(a.0, b.0));
    dt.truncate(COCO_MAX_DETS);
    let gt_ignore: Vec<bool> = gt.iter().map(|g| g.1).collect();
    let ious: Vec<Vec<f64>> = dt
        .iter()
        .map(|(_, d)| gt.iter().map(|(g, _)| coco_iou(d, g)).collect())
        .collect();
    let mut dt_matched = vec![[false; 10]; dt.len()];
    let mut dt_ignore = vec![[false; 10]; dt.len()];
    if !gt.is_empty() && !dt.is_empty() {
        for (t, &thr) in iou_thrs.iter().enumerate() {
            let mut gt_matched = vec![false; gt.len()];
            for (d, row) in ious.iter().enumerate() {
                let mut best = thr.min(1.0 - 1e-10);
                let mut m: Option<usize> = None;
                for (g, &v) in row.iter().enumerate() {
                    if gt_matched[g] {
                        continue;
                    }
                    if let Some(mm) = m
                        && !gt_ignore[mm]
                        && gt_ignore[g]
                    {
                        break;
                    }
                    if v < best {
                        continue;
                    }
                    best = v;
                    m = Some(g);
                }
                if let Some(m) = m {
                    dt_ignore[d][t] = gt_ignore[m];
                    dt_matched[d][t] = true;
                    gt_matched[m] = true;
                }
            }
        }
    }
    for (d, (_, b)) in dt.iter().enumerate() {
        if out_of_range(b) {
            for t in 0..iou_thrs.len() {
                dt_ignore[d][t] |= !dt_matched[d][t];
            }
        }
    }
    Some(CocoImage {
        scores: dt.iter().map(|d| d.0).collect(),
        dt_matched,
        dt_ignore,
        gt_ignore,
    })
}

/// Exactly as pycocotools `COCOeval` (iouType "bbox", maxDets 100, area "all", no crowd boxes, classes
/// as categories): AP@[.5:.95], AP50, AP75, AR@100 and the 101-point precision at IoU 0.5.
///
/// pycocotools conventions kept: IoU without `+1` on `[x, y, w, h]` boxes; detections sorted by score
/// with a stable mergesort (ties in input order), at most 100 per image and class; a class without
/// objects is left out of the means (-1 in pycocotools' arrays), and -1 is reported when no class has
/// objects; with objects but no detections everything is 0. (`COCO.loadRes` itself cannot take an empty
/// result list; the reference script builds the empty result set directly.)
pub fn coco(images: &[ImageEval]) -> CocoMetrics {
    let iou_thrs = np_linspace(0.5, 0.95, 10);
    let rec_thrs = np_linspace(0.0, 1.0, 101);
    let mut classes: Vec<u32> = Vec::new();
    for im in images {
        im.check();
        classes.extend_from_slice(&im.truth_class);
        classes.extend(im.detections.iter().map(|d| d.class));
    }
    classes.sort_unstable();
    classes.dedup();
    // precision[t][r] per class, recall[t] per class; None = -1
    let mut precision: Vec<Vec<[f64; 101]>> = Vec::new(); // [class][t]
    let mut recall: Vec<[f64; 10]> = Vec::new(); // [class]
    for &c in &classes {
        let evals: Vec<CocoImage> = images
            .iter()
            .filter_map(|im| {
                let gts: Vec<[f64; 4]> = im
                    .truth
                    .iter()
                    .zip(&im.truth_class)
                    .filter(|(_, tc)| **tc == c)
                    .map(|(b, _)| xywh(b))
                    .collect();
                let dts: Vec<(f64, [f64; 4])> = im
                    .detections
                    .iter()
                    .filter(|d| d.class == c)
                    .map(|d| (d.score, xywh(&det_box(d))))
                    .collect();
                coco_evaluate_img(&gts, &dts, &iou_thrs)
            })
            .collect();
        let npig = evals
            .iter()
            .flat_map(|e| &e.gt_ignore)
            .filter(|&&ig| !ig)
            .count();
        if evals.is_empty() || npig == 0 {
            precision.push(vec![[-1.0; 101]; 10]);
            recall.push([-1.0; 10]);
            continue;
        }
        let mut all: Vec<(f64, [bool; 10], [bool; 10])> = Vec::new();
        for e in &evals {
            for k in 0..e.scores.len() {
                all.push((e.scores[k], e.dt_matched[k], e.dt_ignore[k]));
            }
        }
        all.sort_by(|a, b| cmp_desc(a.0, b.0));
        let mut prec_c = vec![[0.0; 101]; 10];
        let mut rec_c = [0.0; 10];
        for t in 0..10 {
            let (mut tp, mut fp) = (0u64, 0u64);
            let mut rc = Vec::with_capacity(all.len());
            let mut pr = Vec::with_capacity(all.len());
            for (_, m, ig) in &all {
                if !ig[t] {
                    if m[t] {
                        tp += 1;
                    } else {
                        fp += 1;
                    }
                }
                let (tpf, fpf) = (tp as f64, fp as f64);
                rc.push(tpf / npig as f64);
                pr.push(tpf / (fpf + tpf + f64::EPSILON));
            }
            rec_c[t] = rc.last().copied().unwrap_or(0.0);
            for i in (1..pr.len()).rev() {
                if pr[i] > pr[i - 1] {
                    pr[i - 1] = pr[i];
                }
            }
            for (ri, &r) in rec_thrs.iter().enumerate() {
                let i = rc.partition_point(|&v| v < r); // searchsorted(rc, r, side='left')
                if i >= pr.len() {
                    break;
                }
                prec_c[t][ri] = pr[i];
            }
        }
        precision.push(prec_c);
        recall.push(rec_c);
    }
    let mean_defined = |vals: &mut dyn Iterator<Item = f64>| {
        let v: Vec<f64> = vals.filter(|&x| x > -1.0).collect();
        if v.is_empty() { -1.0 } else { np_mean(&v) }
    };
    let ap_at = |t: Option<usize>| match t {
        Some(t) => mean_defined(&mut precision.iter().flat_map(|p| p[t].iter().copied())),
        None => -1.0,
    };
    let find = |x: f64| iou_thrs.iter().position(|&v| v == x);
    CocoMetrics {
        ap: mean_defined(&mut precision.iter().flat_map(|p| p.iter().flatten().copied())),
        ap50: ap_at(find(0.5)),
        ap75: ap_at(find(0.75)),
        ar100: mean_defined(&mut recall.iter().flatten().copied()),
        precision_at_50: (0..101)
            .map(|r| mean_defined(&mut precision.iter().map(|p| p[0][r])))
            .collect(),
    }
}

// ---------------------------------------------------------------------------------------------------
// Fixed threshold
// ---------------------------------------------------------------------------------------------------

/// Counts at one confidence and IoU threshold.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AtThreshold {
    /// `tp / (tp + fp)`; 0 when no detection passes the confidence threshold.
    pub precision: f64,
    /// `tp / (tp + fn)`; 0 when there are no objects.
    pub recall: f64,
    pub tp: usize,
    pub fp: usize,
    pub fn_: usize,
}

/// Precision, recall, TP, FP, FN counting detections with `score >= conf` (the paper reports conf 0.5,
/// IoU 0.5). Matching per image and class, greedy by score as COCO does: detections in descending score
/// (ties in input order) each take the still unmatched object of their class with the highest IoU
/// ([`iou`], plain `f64`), provided it is `>= iou_threshold` (IoU ties: the first object). Unmatched
/// detections are FP, unmatched objects FN.
pub fn at_threshold(images: &[ImageEval], conf: f64, iou_threshold: f64) -> AtThreshold {
    let (mut tp, mut fp, mut fn_) = (0usize, 0usize, 0usize);
    for im in images {
        im.check();
        let mut dets: Vec<&Detection> = im.detections.iter().filter(|d| d.score >= conf).collect();
        dets.sort_by(|a, b| cmp_desc(a.score, b.score));
        let mut matched = vec![false; im.truth.len()];
        for d in dets {
            let db = det_box(d);
            let mut best: Option<(usize, f64)> = None;
            for (g, (tb, &tc)) in im.truth.iter().zip(&im.truth_class).enumerate() {
                if matched[g] || tc != d.class {
                    continue;
                }
                let v = iou(tb, &db);
                if v >= iou_threshold && best.is_none_or(|(_, bv)| v > bv) {
                    best = Some((g, v));
                }
            }
            match best {
                Some((g, _)) => {
                    matched[g] = true;
                    tp += 1;
                }
                None => fp += 1,
            }
        }
        fn_ += matched.iter().filter(|&&m| !m).count();
    }
    let ratio = |a: usize, b: usize| if b == 0 { 0.0 } else { a as f64 / b as f64 };
    AtThreshold {
        precision: ratio(tp, tp + fp),
        recall: ratio(tp, tp + fn_),
        tp,
        fp,
        fn_,
    }
}

// ---------------------------------------------------------------------------------------------------
// YOLO text files
// ---------------------------------------------------------------------------------------------------

/// Errors reading YOLO-format files.
#[derive(thiserror::Error, Debug)]
pub enum MetricsError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}:{line}: {message}", path.display())]
    Parse {
        path: PathBuf,
        line: usize,
        message: String,
    },
    #[error("{}: prediction file without a label file (expected {})", path.display(), expected.display())]
    OrphanPrediction { path: PathBuf, expected: PathBuf },
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> MetricsError + '_ {
    move |source| MetricsError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// `*.txt` files of a directory by stem, sorted.
fn txt_files(dir: &Path) -> Result<Vec<(String, PathBuf)>, MetricsError> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(io_err(dir))? {
        let entry = entry.map_err(io_err(dir))?;
        let path = entry.path();
        if path.extension().and_then(|e| e.to_str()) != Some("txt") || !path.is_file() {
            continue;
        }
        if let Some(stem) = path.file_stem().and_then(|s| s.to_str()) {
            out.push((stem.to_string(), path));
        }
    }
    out.sort();
    Ok(out)
}

/// Parses `cls xc yc w h [score]` lines (`with_score` selects the prediction form); blank lines are
/// skipped. Returns `(class, [x1, y1, x2, y2], score)`.
fn parse_yolo(
    path: &Path,
    text: &str,
    with_score: bool,
) -> Result<Vec<(u32, [f64; 4], f64)>, MetricsError> {
    let want = if with_score { 6 } else { 5 };
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let err = |message: String| MetricsError::Parse {
            path: path.to_path_buf(),
            line: n + 1,
            message,
        };
        let fields: Vec<&str> = line.split_whitespace().collect();
        if fields.is_empty() {
            continue;
        }
        if fields.len() != want {
            let form = if with_score {
                "cls xc yc w h score"
            } else {
                "cls xc yc w h"
            };
            return Err(err(format!(
                "expected {want} fields ({form}), found {}",
                fields.len()
            )));
        }
        let mut v = [0.0f64; 6];
        for (k, f) in fields.iter().enumerate() {
            v[k] = f
                .parse::<f64>()
                .map_err(|_| err(format!("field {} is not a number: {f:?}", k + 1)))?;
            if !v[k].is_finite() {
                return Err(err(format!("field {} is not finite: {f:?}", k + 1)));
            }
        }
        if v[0] < 0.0 || v[0].fract() != 0.0 || v[0] > u32::MAX as f64 {
            return Err(err(format!(
                "class {:?} is not a non-negative integer",
                fields[0]
            )));
        }
        if v[3] < 0.0 || v[4] < 0.0 {
            return Err(err("negative box width or height".to_string()));
        }
        let (xc, yc, w, h) = (v[1], v[2], v[3], v[4]);
        let b = [xc - w / 2.0, yc - h / 2.0, xc + w / 2.0, yc + h / 2.0];
        out.push((v[0] as u32, b, if with_score { v[5] } else { 1.0 }));
    }
    Ok(out)
}

/// Reads YOLO-format text files: labels `cls xc yc w h` (normalised), predictions `cls xc yc w h score`,
/// paired by file stem (`labels/a.txt` with `predictions/a.txt`). A label file with no prediction file
/// means no detections; a prediction file with no label file is an error, as are malformed lines (the
/// error names the file and line). Boxes stay normalised (x1 y1 x2 y2); scale them to pixels with
/// [`ImageEval::scaled`] for Ultralytics-exact figures. Sorted by stem.
pub fn read_yolo_dirs(
    labels: &Path,
    predictions: &Path,
) -> Result<Vec<(String, ImageEval)>, MetricsError> {
    let label_files = txt_files(labels)?;
    let pred_files = txt_files(predictions)?;
    for (stem, path) in &pred_files {
        if label_files
            .binary_search_by(|(s, _)| s.as_str().cmp(stem))
            .is_err()
        {
            return Err(MetricsError::OrphanPrediction {
                path: path.clone(),
                expected: labels.join(format!("{stem}.txt")),
            });
        }
    }
    let mut out = Vec::with_capacity(label_files.len());
    for (stem, path) in label_files {
        let text = std::fs::read_to_string(&path).map_err(io_err(&path))?;
        let truth = parse_yolo(&path, &text, false)?;
        let mut im = ImageEval {
            truth: truth.iter().map(|t| t.1).collect(),
            truth_class: truth.iter().map(|t| t.0).collect(),
            detections: Vec::new(),
        };
        if let Ok(i) = pred_files.binary_search_by(|(s, _)| s.as_str().cmp(&stem)) {
            let ppath = &pred_files[i].1;
            let text = std::fs::read_to_string(ppath).map_err(io_err(ppath))?;
            im.detections = parse_yolo(ppath, &text, true)?
                .into_iter()
                .map(|(class, b, score)| Detection {
                    x1: b[0],
                    y1: b[1],
                    x2: b[2],
                    y2: b[3],
                    score,
                    class,
                })
                .collect();
        }
        out.push((stem, im));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn d(b: [f64; 4], score: f64, class: u32) -> Detection {
        Detection {
            x1: b[0],
            y1: b[1],
            x2: b[2],
            y2: b[3],
            score,
            class,
        }
    }

    fn bx(x: f64, y: f64, w: f64, h: f64) -> [f64; 4] {
        [x, y, x + w, y + h]
    }

    fn img(truth: &[([f64; 4], u32)], dets: &[([f64; 4], f64, u32)]) -> ImageEval {
        ImageEval {
            truth: truth.iter().map(|t| t.0).collect(),
            truth_class: truth.iter().map(|t| t.1).collect(),
            detections: dets.iter().map(|&(b, s, c)| d(b, s, c)).collect(),
        }
    }

    /// splitmix64, as `SplitMix64` in tests/reference/metrics_reference.py.
    struct SplitMix64(u64);

    impl SplitMix64 {
        fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        fn uniform(&mut self) -> f64 {
            (self.next_u64() >> 11) as f64 * (-53f64).exp2()
        }
        fn below(&mut self, n: u64) -> u64 {
            self.next_u64() % n
        }
    }

    /// `stress()` of tests/reference/metrics_reference.py: objects with 0-2 jittered detections each (10 % with
    /// a random class), plus 0-2 random false positives per image.
    fn stress(seed: u64, n_images: usize, n_classes: u64) -> Vec<ImageEval> {
        let mut rng = SplitMix64(seed);
        let mut images = Vec::new();
        for _ in 0..n_images {
            let mut im = ImageEval::default();
            for _ in 0..rng.below(6) {
                let w = 4.0 + 60.0 * rng.uniform();
                let h = 4.0 + 60.0 * rng.uniform();
                let x1 = 1000.0 * rng.uniform();
                let y1 = 1000.0 * rng.uniform();
                let c = rng.below(n_classes) as u32;
                im.truth.push([x1, y1, x1 + w, y1 + h]);
                im.truth_class.push(c);
                for _ in 0..rng.below(3) {
                    let j = 0.3 * rng.uniform();
                    let dx1 = (2.0 * rng.uniform() - 1.0) * j * w;
                    let dy1 = (2.0 * rng.uniform() - 1.0) * j * h;
                    let dx2 = (2.0 * rng.uniform() - 1.0) * j * w;
                    let dy2 = (2.0 * rng.uniform() - 1.0) * j * h;
                    let dc = if rng.uniform() < 0.9 {
                        c
                    } else {
                        rng.below(n_classes) as u32
                    };
                    let score = rng.uniform();
                    im.detections.push(d(
                        [x1 + dx1, y1 + dy1, x1 + w + dx2, y1 + h + dy2],
                        score,
                        dc,
                    ));
                }
            }
            for _ in 0..rng.below(3) {
                let w = 4.0 + 60.0 * rng.uniform();
                let h = 4.0 + 60.0 * rng.uniform();
                let x1 = 1000.0 * rng.uniform();
                let y1 = 1000.0 * rng.uniform();
                let dc = rng.below(n_classes) as u32;
                let score = 0.6 * rng.uniform();
                im.detections.push(d([x1, y1, x1 + w, y1 + h], score, dc));
            }
            images.push(im);
        }
        images
    }

    /// The cases of tests/reference/metrics_reference.py (`CASES`), same names, same inputs.
    fn case(name: &str) -> Vec<ImageEval> {
        match name {
            "no_predictions" => vec![
                img(
                    &[(bx(10., 10., 20., 20.), 0), (bx(100., 100., 30., 10.), 0)],
                    &[],
                ),
                img(&[(bx(50., 60., 12., 12.), 0)], &[]),
            ],
            "no_labels" => vec![
                img(
                    &[],
                    &[
                        (bx(10., 10., 20., 20.), 0.9, 0),
                        (bx(200., 10., 20., 20.), 0.4, 0),
                    ],
                ),
                img(&[], &[(bx(5., 5., 8., 8.), 0.7, 0)]),
            ],
            "duplicates" => vec![img(
                &[([10., 10., 50., 40.], 0), ([200., 200., 230., 220.], 0)],
                &[
                    ([11., 10., 50., 41.], 0.9, 0),
                    ([10., 11., 49., 40.], 0.8, 0),
                    ([12., 12., 52., 42.], 0.7, 0),
                    ([201., 200., 230., 221.], 0.6, 0),
                ],
            )],
            "perfect" => vec![
                img(
                    &[(bx(10., 10., 20., 20.), 0), (bx(300., 40., 8., 30.), 0)],
                    &[
                        (bx(10., 10., 20., 20.), 0.9, 0),
                        (bx(300., 40., 8., 30.), 0.8, 0),
                    ],
                ),
                img(
                    &[(bx(500., 500., 16., 16.), 0)],
                    &[(bx(500., 500., 16., 16.), 0.75, 0)],
                ),
            ],
            "ties" => vec![
                img(
                    &[
                        (bx(10., 10., 20., 20.), 0),
                        (bx(100., 10., 20., 20.), 0),
                        (bx(200., 10., 20., 20.), 0),
                    ],
                    &[
                        (bx(10., 10., 20., 20.), 0.8, 0),
                        (bx(100., 10., 20., 20.), 0.6, 0),
                        (bx(600., 600., 20., 20.), 0.7, 0),
                        (bx(200., 10., 20., 20.), 0.6, 0),
                    ],
                ),
                img(
                    &[(bx(10., 10., 20., 20.), 0), (bx(300., 300., 10., 10.), 0)],
                    &[
                        (bx(10., 10., 20., 20.), 0.8, 0),
                        (bx(700., 600., 20., 20.), 0.7, 0),
                        (bx(300., 300., 10., 10.), 0.6, 0),
                    ],
                ),
                img(
                    &[(bx(40., 40., 20., 20.), 0)],
                    &[(bx(800., 800., 20., 20.), 0.7, 0)],
                ),
            ],
            "half_recall" => vec![img(
                &[(bx(10., 10., 20., 20.), 0), (bx(100., 100., 20., 20.), 0)],
                &[(bx(10., 10., 20., 20.), 0.9, 0)],
            )],
            "mixed" => vec![
                img(&[(bx(10., 10., 20., 20.), 0)], &[]),
                img(
                    &[],
                    &[
                        (bx(30., 30., 10., 10.), 0.35, 0),
                        (bx(60., 30., 10., 10.), 0.55, 1),
                    ],
                ),
                img(
                    &[
                        (bx(10., 10., 20., 20.), 0),
                        (bx(50., 50., 30., 30.), 1),
                        (bx(120., 40., 10., 25.), 0),
                    ],
                    &[
                        ([11., 11., 31., 29.], 0.95, 0),
                        ([52., 49., 80., 82.], 0.85, 1),
                        ([50., 50., 80., 80.], 0.5, 0),
                        ([121., 44., 131., 63.], 0.45, 0),
                        ([400., 400., 410., 410.], 0.65, 1),
                    ],
                ),
                img(
                    &[(bx(70., 70., 14., 14.), 1), (bx(90., 70., 14., 14.), 1)],
                    &[
                        ([72., 70., 86., 84.], 0.75, 1),
                        ([91., 71., 105., 85.], 0.75, 0),
                        ([88., 70., 103., 85.], 0.25, 1),
                    ],
                ),
            ],
            "multi_box" => vec![img(
                &[
                    (bx(0., 0., 20., 20.), 0),
                    (bx(100., 0., 20., 20.), 0),
                    (bx(200., 0., 20., 20.), 0),
                    (bx(300., 0., 20., 20.), 0),
                    (bx(400., 0., 20., 20.), 0),
                    (bx(500., 0., 20., 20.), 0),
                ],
                &[
                    (bx(0., 0., 20., 10.4), 0.3, 0),
                    (bx(100., 0., 20., 11.6), 0.9, 0),
                    (bx(200., 0., 20., 13.2), 0.5, 0),
                    (bx(300., 0., 20., 14.8), 0.7, 0),
                    (bx(400., 0., 20., 16.6), 0.2, 0),
                    (bx(500., 0., 20., 19.4), 0.6, 0),
                    (bx(250., 250., 20., 20.), 0.8, 0),
                ],
            )],
            "iou_boundaries" => vec![
                img(&[([0., 0., 0.1, 0.1], 0)], &[([0., 0., 0.1, 0.05], 0.9, 0)]),
                img(
                    &[
                        ([0., 0., 10., 10.], 0),
                        ([20., 0., 40., 20.], 0),
                        ([60., 0., 80., 20.], 0),
                    ],
                    &[
                        ([0., 0., 10., 5.], 0.8, 0),
                        ([20., 0., 40., 15.], 0.7, 0),
                        ([60., 0., 80., 11.], 0.6, 0),
                    ],
                ),
            ],
            "stress_single" => stress(42, 50, 1),
            "stress_multi" => stress(7, 40, 3),
            _ => panic!("unknown case {name}"),
        }
    }

    /// `checksum()` of the reference script.
    fn checksum(images: &[ImageEval]) -> f64 {
        let mut s = 0.0;
        for (k, im) in images.iter().enumerate() {
            let k1 = (k + 1) as f64;
            for (b, &c) in im.truth.iter().zip(&im.truth_class) {
                s += k1 * (b[0] + 2.0 * b[1] + 3.0 * b[2] + 4.0 * b[3] + 5.0 * c as f64);
            }
            for det in &im.detections {
                s += k1
                    * (det.x1 - 2.0 * det.y1 + 3.0 * det.x2 - 4.0 * det.y2
                        + 1000.0 * det.score
                        + 7.0 * det.class as f64);
            }
        }
        s
    }

    struct Curve {
        len: usize,
        mean: f64,
        samples: &'static [(usize, f64)],
    }

    struct UltraExpected {
        precision: f64,
        recall: f64,
        map50: f64,
        map50_95: f64,
        f1_conf: f64,
        ap_per_iou: [f64; 10],
        precision_curve: Curve,
        recall_curve: Curve,
        f1_curve: Curve,
        pr_curve_map50: Curve,
    }

    struct CocoExpected {
        ap: f64,
        ap50: f64,
        ap75: f64,
        ar100: f64,
        /// run-length encoded: (value, count)
        precision_at_50: &'static [(f64, usize)],
    }

    struct Expected {
        name: &'static str,
        n_truth: usize,
        n_detections: usize,
        checksum: f64,
        coco: CocoExpected,
        current: UltraExpected,
        legacy: UltraExpected,
    }

    const TOL: f64 = 1e-6;

    thread_local! {
        /// Largest |Rust - reference| seen by `close` in this test's thread.
        static MAX_DEV: std::cell::Cell<f64> = const { std::cell::Cell::new(0.0) };
    }

    fn close(what: &str, got: f64, want: f64) -> Option<String> {
        let dev = (got - want).abs();
        MAX_DEV.with(|m| m.set(m.get().max(if dev.is_nan() { f64::INFINITY } else { dev })));
        (dev.is_nan() || dev > TOL).then(|| format!("{what}: got {got}, reference {want}"))
    }

    fn check_curve(errs: &mut Vec<String>, what: &str, got: &[f64], want: &Curve) {
        if got.len() != want.len {
            errs.push(format!(
                "{what}: length {} vs reference {}",
                got.len(),
                want.len
            ));
            return;
        }
        if !got.is_empty() {
            errs.extend(close(
                &format!("{what} mean"),
                got.iter().sum::<f64>() / got.len() as f64,
                want.mean,
            ));
        }
        for &(i, v) in want.samples {
            errs.extend(close(&format!("{what}[{i}]"), got[i], v));
        }
    }

    fn check_ultra(
        errs: &mut Vec<String>,
        tag: &str,
        got: &UltralyticsMetrics,
        want: &UltraExpected,
    ) {
        errs.extend(close(
            &format!("{tag} precision"),
            got.precision,
            want.precision,
        ));
        errs.extend(close(&format!("{tag} recall"), got.recall, want.recall));
        errs.extend(close(&format!("{tag} map50"), got.map50, want.map50));
        errs.extend(close(
            &format!("{tag} map50_95"),
            got.map50_95,
            want.map50_95,
        ));
        errs.extend(close(&format!("{tag} f1_conf"), got.f1_conf, want.f1_conf));
        for t in 0..10 {
            errs.extend(close(
                &format!("{tag} ap_per_iou[{t}]"),
                got.ap_per_iou[t],
                want.ap_per_iou[t],
            ));
        }
        check_curve(
            errs,
            &format!("{tag} precision_curve"),
            &got.precision_curve,
            &want.precision_curve,
        );
        check_curve(
            errs,
            &format!("{tag} recall_curve"),
            &got.recall_curve,
            &want.recall_curve,
        );
        check_curve(
            errs,
            &format!("{tag} f1_curve"),
            &got.f1_curve,
            &want.f1_curve,
        );
        check_curve(
            errs,
            &format!("{tag} pr_curve_map50"),
            &got.pr_curve_map50,
            &want.pr_curve_map50,
        );
        if got.px.len() != 1000 || got.px[0] != 0.0 || got.px[999] != 1.0 {
            errs.push(format!("{tag} px is not linspace(0, 1, 1000)"));
        }
    }

    fn check_case(name: &str) {
        let want = EXPECTED
            .iter()
            .find(|e| e.name == name)
            .expect("case in EXPECTED");
        let images = case(name);
        let mut errs = Vec::new();
        let cs = checksum(&images);
        if (cs - want.checksum).abs() > 1e-9 * want.checksum.abs().max(1.0) {
            errs.push(format!(
                "input checksum {cs} vs reference {}: the cases differ",
                want.checksum
            ));
        }
        let cur = ultralytics(&images);
        let leg = ultralytics_with(&images, UltralyticsVersion::Legacy);
        for m in [&cur, &leg] {
            if m.n_truth != want.n_truth || m.n_detections != want.n_detections {
                errs.push(format!(
                    "counts {} / {} vs {} / {}",
                    m.n_truth, m.n_detections, want.n_truth, want.n_detections
                ));
            }
        }
        check_ultra(&mut errs, "ultralytics", &cur, &want.current);
        check_ultra(&mut errs, "ultralytics legacy", &leg, &want.legacy);
        let c = coco(&images);
        errs.extend(close("coco ap", c.ap, want.coco.ap));
        errs.extend(close("coco ap50", c.ap50, want.coco.ap50));
        errs.extend(close("coco ap75", c.ap75, want.coco.ap75));
        errs.extend(close("coco ar100", c.ar100, want.coco.ar100));
        let p50: Vec<f64> = want
            .coco
            .precision_at_50
            .iter()
            .flat_map(|&(v, n)| std::iter::repeat_n(v, n))
            .collect();
        if c.precision_at_50.len() != 101 || p50.len() != 101 {
            errs.push(format!(
                "precision_at_50 length {} / {}",
                c.precision_at_50.len(),
                p50.len()
            ));
        } else {
            for (r, (&got, &want)) in c.precision_at_50.iter().zip(&p50).enumerate() {
                errs.extend(close(&format!("coco precision_at_50[{r}]"), got, want));
            }
        }
        eprintln!(
            "case {name}: largest deviation from the references {:.1e}",
            MAX_DEV.with(|m| m.get())
        );
        assert!(errs.is_empty(), "case {name}:\n{}", errs.join("\n"));
    }

    // One test per reference case; figures from tests/reference/metrics_reference.py (pycocotools 2.0.11,
    // ultralytics 8.4.190 and the 8.3.0 sources, numpy 2.4.6, torch 2.15.0).
    #[test]
    fn reference_no_predictions() {
        check_case("no_predictions");
    }
    #[test]
    fn reference_no_labels() {
        check_case("no_labels");
    }
    #[test]
    fn reference_duplicates() {
        check_case("duplicates");
    }
    #[test]
    fn reference_perfect() {
        check_case("perfect");
    }
    #[test]
    fn reference_ties() {
        check_case("ties");
    }
    #[test]
    fn reference_half_recall() {
        check_case("half_recall");
    }
    #[test]
    fn reference_mixed() {
        check_case("mixed");
    }
    #[test]
    fn reference_multi_box() {
        check_case("multi_box");
    }
    #[test]
    fn reference_iou_boundaries() {
        check_case("iou_boundaries");
    }
    #[test]
    fn reference_stress_single() {
        check_case("stress_single");
    }
    #[test]
    fn reference_stress_multi() {
        check_case("stress_multi");
    }

    #[test]
    fn every_reference_case_is_tested() {
        for e in EXPECTED {
            let _ = case(e.name);
        }
        assert_eq!(EXPECTED.len(), 11);
    }

    #[test]
    fn headline_figures() {
        // perfect detector: Ultralytics 0.995, COCO 1.0
        let p = case("perfect");
        assert!((ultralytics(&p).map50 - 0.995).abs() < 1e-12);
        assert!((ultralytics_with(&p, UltralyticsVersion::Legacy).map50 - 0.995).abs() < 1e-12);
        assert!((coco(&p).ap - 1.0).abs() < 1e-12);
        // precision 1 up to recall 0.5: legacy Ultralytics 0.75, current 0.495, COCO 0.505
        let h = case("half_recall");
        assert!((ultralytics_with(&h, UltralyticsVersion::Legacy).map50 - 0.75).abs() < 1e-12);
        assert!((ultralytics(&h).map50 - 0.495).abs() < 1e-12);
        assert!((coco(&h).ap50 - 0.504_950_495_049_505).abs() < 1e-12);
        // no objects: Ultralytics zeros, pycocotools -1
        let n = case("no_labels");
        let u = ultralytics(&n);
        assert_eq!(
            (u.precision, u.recall, u.map50, u.map50_95),
            (0.0, 0.0, 0.0, 0.0)
        );
        assert!(u.precision_curve.is_empty() && u.pr_curve_map50 == vec![0.0; 1000]);
        let c = coco(&n);
        assert_eq!((c.ap, c.ap50, c.ap75, c.ar100), (-1.0, -1.0, -1.0, -1.0));
        assert!(c.precision_at_50.iter().all(|&v| v == -1.0));
        // nothing at all
        let c = coco(&[ImageEval::default()]);
        assert_eq!((c.ap, c.ar100), (-1.0, -1.0));
        let u = ultralytics(&[]);
        assert_eq!((u.map50, u.precision, u.f1_conf), (0.0, 0.0, 0.0));
    }

    #[test]
    fn thresholds_match_the_references() {
        // torch.linspace(0.5, 0.95, 10) (float32), as printed by the reference environment
        let torch = [
            0.5,
            0.550000011920929,
            0.6000000238418579,
            0.6499999761581421,
            0.699999988079071,
            0.75,
            0.800000011920929,
            0.8500000238418579,
            0.8999999761581421,
            0.949999988079071,
        ];
        for (a, b) in ULTRA_IOUV.iter().zip(torch) {
            assert_eq!(*a as f64, b);
        }
        // np.linspace(.5, 0.95, 10) of pycocotools: 0.8999999999999999 at index 8, 0.75 exact
        let coco_thr = np_linspace(0.5, 0.95, 10);
        assert_eq!(coco_thr[8], 0.8999999999999999);
        assert_eq!(coco_thr[5], 0.75);
        assert_eq!(np_linspace(0.0, 1.0, 101)[7], 0.07);
    }

    #[test]
    fn numpy_interp_rules() {
        let xp = [0.0, 0.5, 0.5, 1.0];
        let fp = [1.0, 1.0, 0.0, 0.0];
        assert_eq!(np_interp(0.5, &xp, &fp, 9.0, 9.0), 0.0); // last of the repeats
        assert_eq!(np_interp(0.25, &xp, &fp, 9.0, 9.0), 1.0);
        assert_eq!(np_interp(-0.1, &xp, &fp, 7.0, 9.0), 7.0);
        assert_eq!(np_interp(1.1, &xp, &fp, 7.0, 9.0), 9.0);
        assert_eq!(np_interp(2.0, &[2.0], &[3.0], 0.0, 1.0), 3.0);
        assert_eq!(smooth(&[1.0; 1000], 0.1).len(), 1000);
        assert_eq!(argmax_first(&[1.0, 3.0, 3.0, 2.0]), 1);
        let v: Vec<f64> = (0..300).map(|i| (i as f64).sin()).collect();
        assert!((np_sum(&v) - v.iter().sum::<f64>()).abs() < 1e-9);
    }

    #[test]
    fn iou_basics() {
        assert_eq!(iou(&[0., 0., 10., 10.], &[0., 0., 10., 10.]), 1.0);
        assert_eq!(iou(&[0., 0., 10., 10.], &[10., 0., 20., 10.]), 0.0);
        assert!((iou(&[0., 0., 10., 10.], &[5., 0., 15., 10.]) - 1.0 / 3.0).abs() < 1e-15);
        assert_eq!(iou(&[0., 0., 0., 0.], &[0., 0., 0., 0.]), 0.0);
        // scale invariance (up to rounding)
        let a = [0.1, 0.2, 0.3, 0.5];
        let b = [0.15, 0.25, 0.35, 0.45];
        let s = |x: [f64; 4]| [x[0] * 640.0, x[1] * 480.0, x[2] * 640.0, x[3] * 480.0];
        assert!((iou(&a, &b) - iou(&s(a), &s(b))).abs() < 1e-12);
    }

    #[test]
    fn at_threshold_counts() {
        let images = case("mixed");
        // conf 0.5: image 2 keeps 0.55 (class 1, no object: FP); image 3 keeps 0.95 (IoU 0.8, TP),
        // 0.85 (class 1, IoU 0.84, TP), 0.65 (FP), 0.5 (class 0 on the class-1 object: FP); image 4 keeps
        // both 0.75 (class 1 on object 0: TP; class 0: FP). Objects missed: image 1, image 3 third, image 4
        // second.
        let r = at_threshold(&images, 0.5, 0.5);
        assert_eq!((r.tp, r.fp, r.fn_), (3, 4, 3));
        assert!((r.precision - 3.0 / 7.0).abs() < 1e-15 && (r.recall - 0.5).abs() < 1e-15);
        let r = at_threshold(&case("duplicates"), 0.5, 0.5);
        assert_eq!((r.tp, r.fp, r.fn_), (2, 2, 0));
        let r = at_threshold(&case("no_predictions"), 0.5, 0.5);
        assert_eq!(
            (r.tp, r.fp, r.fn_, r.precision, r.recall),
            (0, 0, 3, 0.0, 0.0)
        );
        let r = at_threshold(&case("no_labels"), 0.5, 0.5);
        assert_eq!(
            (r.tp, r.fp, r.fn_, r.precision, r.recall),
            (0, 2, 0, 0.0, 0.0)
        );
        // the higher score takes the object even when the lower one overlaps better
        let im = img(
            &[([0., 0., 10., 10.], 0)],
            &[([0., 0., 10., 10.], 0.6, 0), ([0., 0., 10., 8.], 0.9, 0)],
        );
        let r = at_threshold(&[im], 0.5, 0.5);
        assert_eq!((r.tp, r.fp), (1, 1));
    }

    struct TempDir(PathBuf);

    impl TempDir {
        fn new(tag: &str) -> TempDir {
            let p = std::env::temp_dir().join(format!("soig-metrics-{tag}-{}", std::process::id()));
            let _ = std::fs::remove_dir_all(&p);
            std::fs::create_dir_all(p.join("labels")).unwrap();
            std::fs::create_dir_all(p.join("pred")).unwrap();
            TempDir(p)
        }
        fn write(&self, rel: &str, text: &str) {
            std::fs::write(self.0.join(rel), text).unwrap();
        }
        fn read(&self) -> Result<Vec<(String, ImageEval)>, MetricsError> {
            read_yolo_dirs(&self.0.join("labels"), &self.0.join("pred"))
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    #[test]
    fn yolo_round_trip() {
        let t = TempDir::new("ok");
        t.write("labels/b.txt", "0 0.5 0.5 0.2 0.1\n\n1 0.25 0.75 0.1 0.1\n");
        t.write("labels/a.txt", "");
        t.write("labels/c.txt", "0 0.1 0.1 0.02 0.02\n");
        t.write("labels/notes.md", "ignored");
        t.write(
            "pred/b.txt",
            "0 0.5 0.5 0.2 0.1 0.9\n1 0.3 0.7 0.1 0.1 0.4\n",
        );
        t.write("pred/a.txt", "0 0.9 0.9 0.05 0.05 0.3\n");
        let got = t.read().unwrap();
        let stems: Vec<&str> = got.iter().map(|g| g.0.as_str()).collect();
        assert_eq!(stems, ["a", "b", "c"]);
        let a = &got[0].1;
        assert!(a.truth.is_empty() && a.detections.len() == 1);
        let b = &got[1].1;
        assert_eq!(b.truth_class, [0, 1]);
        assert!((b.truth[0][0] - 0.4).abs() < 1e-15 && (b.truth[0][3] - 0.55).abs() < 1e-15);
        assert_eq!(b.detections[1].class, 1);
        assert_eq!(b.detections[0].score, 0.9);
        assert!(got[2].1.detections.is_empty()); // no prediction file: no detections
        let px: Vec<ImageEval> = got.iter().map(|g| g.1.scaled(640.0, 512.0)).collect();
        assert!((px[1].truth[0][2] - 0.6 * 640.0).abs() < 1e-9);
        assert_eq!(at_threshold(&px, 0.5, 0.5).tp, 1);
    }

    #[test]
    fn yolo_errors_name_file_and_line() {
        let t = TempDir::new("bad-label");
        t.write("labels/x.txt", "0 0.5 0.5 0.2 0.1\n0 0.5 0.5 0.2\n");
        let e = t.read().unwrap_err().to_string();
        assert!(
            e.contains("x.txt:2:") && e.contains("expected 5 fields"),
            "{e}"
        );

        let t = TempDir::new("bad-pred");
        t.write("labels/x.txt", "0 0.5 0.5 0.2 0.1\n");
        t.write(
            "pred/x.txt",
            "0 0.5 0.5 0.2 0.1 0.5\n\n0 0.5 0.5 0.2 0.1 abc\n",
        );
        let e = t.read().unwrap_err().to_string();
        assert!(
            e.contains("pred") && e.contains("x.txt:3:") && e.contains("field 6"),
            "{e}"
        );

        let t = TempDir::new("bad-class");
        t.write("labels/x.txt", "1.5 0.5 0.5 0.2 0.1\n");
        assert!(t.read().unwrap_err().to_string().contains("x.txt:1:"));

        let t = TempDir::new("orphan");
        t.write("labels/x.txt", "");
        t.write("pred/y.txt", "0 0.5 0.5 0.2 0.1 0.5\n");
        let e = t.read().unwrap_err();
        assert!(
            matches!(e, MetricsError::OrphanPrediction { .. }) && e.to_string().contains("y.txt"),
            "{e}"
        );

        let e = read_yolo_dirs(
            Path::new("/nonexistent/labels"),
            Path::new("/nonexistent/pred"),
        )
        .unwrap_err();
        assert!(e.to_string().contains("/nonexistent/labels"), "{e}");
    }

    // Generated by tests/reference/metrics_reference.py --rust; do not edit by hand.
    #[rustfmt::skip]
    const EXPECTED: &[Expected] = &[
        Expected {
            name: "no_predictions",
            n_truth: 3, n_detections: 0, checksum: 2658.0,
            coco: CocoExpected { ap: 0.0, ap50: 0.0, ap75: 0.0, ar100: 0.0,
                precision_at_50: &[(0.0, 101)] },
            current: UltraExpected {
                precision: 0.0, recall: 0.0, map50: 0.0,
                map50_95: 0.0, f1_conf: 0.0,
                ap_per_iou: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                precision_curve: Curve { len: 1000, mean: 0.0, samples: &[(0, 0.0), (1, 0.0), (100, 0.0), (250, 0.0), (400, 0.0), (500, 0.0), (600, 0.0), (750, 0.0), (900, 0.0), (998, 0.0), (999, 0.0)] },
                recall_curve: Curve { len: 1000, mean: 0.0, samples: &[(0, 0.0), (1, 0.0), (100, 0.0), (250, 0.0), (400, 0.0), (500, 0.0), (600, 0.0), (750, 0.0), (900, 0.0), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.0, samples: &[(0, 0.0), (1, 0.0), (100, 0.0), (250, 0.0), (400, 0.0), (500, 0.0), (600, 0.0), (750, 0.0), (900, 0.0), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.0, samples: &[(0, 0.0), (1, 0.0), (100, 0.0), (250, 0.0), (400, 0.0), (500, 0.0), (600, 0.0), (750, 0.0), (900, 0.0), (998, 0.0), (999, 0.0)] },
            },
            legacy: UltraExpected {
                precision: 0.0, recall: 0.0, map50: 0.0,
                map50_95: 0.0, f1_conf: 0.0,
                ap_per_iou: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                precision_curve: Curve { len: 0, mean: 0.0, samples: &[] },
                recall_curve: Curve { len: 0, mean: 0.0, samples: &[] },
                f1_curve: Curve { len: 0, mean: 0.0, samples: &[] },
                pr_curve_map50: Curve { len: 0, mean: 0.0, samples: &[] },
            },
        },
        Expected {
            name: "no_labels",
            n_truth: 0, n_detections: 3, checksum: 3344.0,
            coco: CocoExpected { ap: -1.0, ap50: -1.0, ap75: -1.0, ar100: -1.0,
                precision_at_50: &[(-1.0, 101)] },
            current: UltraExpected {
                precision: 0.0, recall: 0.0, map50: 0.0,
                map50_95: 0.0, f1_conf: 0.0,
                ap_per_iou: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                precision_curve: Curve { len: 0, mean: 0.0, samples: &[] },
                recall_curve: Curve { len: 0, mean: 0.0, samples: &[] },
                f1_curve: Curve { len: 0, mean: 0.0, samples: &[] },
                pr_curve_map50: Curve { len: 1000, mean: 0.0, samples: &[(0, 0.0), (1, 0.0), (100, 0.0), (250, 0.0), (400, 0.0), (500, 0.0), (600, 0.0), (750, 0.0), (900, 0.0), (998, 0.0), (999, 0.0)] },
            },
            legacy: UltraExpected {
                precision: 0.0, recall: 0.0, map50: 0.0,
                map50_95: 0.0, f1_conf: 0.0,
                ap_per_iou: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                precision_curve: Curve { len: 0, mean: 0.0, samples: &[] },
                recall_curve: Curve { len: 0, mean: 0.0, samples: &[] },
                f1_curve: Curve { len: 0, mean: 0.0, samples: &[] },
                pr_curve_map50: Curve { len: 0, mean: 0.0, samples: &[] },
            },
        },
        Expected {
            name: "duplicates",
            n_truth: 2, n_detections: 4, checksum: 5045.0,
            coco: CocoExpected { ap: 0.6772277227722773, ap50: 0.7524752475247525, ap75: 0.7524752475247525, ar100: 0.9,
                precision_at_50: &[(0.9999999999999998, 51), (0.5, 50)] },
            current: UltraExpected {
                precision: 0.5, recall: 1.0, map50: 0.7450000000000001,
                map50_95: 0.6705000000000001, f1_conf: 0.0,
                ap_per_iou: [0.7450000000000001, 0.7450000000000001, 0.7450000000000001, 0.7450000000000001, 0.7450000000000001, 0.7450000000000001, 0.7450000000000001, 0.7450000000000001, 0.7450000000000001, 0.0],
                precision_curve: Curve { len: 1000, mean: 0.5585251958759234, samples: &[(0, 0.5), (1, 0.5), (100, 0.5), (250, 0.5), (400, 0.5), (500, 0.5), (600, 0.49899903837745707), (750, 0.41791791761959635), (900, 1.0), (998, 1.0), (999, 1.0)] },
                recall_curve: Curve { len: 1000, mean: 0.7749249278783092, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 1.0), (500, 1.0), (600, 0.9969971151323712), (750, 0.5), (900, 0.0), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.55829355111638, samples: &[(0, 0.6666666666666666), (1, 0.6666666666666666), (100, 0.6666666666666666), (250, 0.6666666666666666), (400, 0.6666666666666666), (500, 0.6666666666666666), (600, 0.6651094664233488), (750, 0.4552889856463068), (900, 0.0), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.7495, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 1.0), (500, 0.5), (600, 0.5), (750, 0.5), (900, 0.5), (998, 0.5), (999, 0.0)] },
            },
            legacy: UltraExpected {
                precision: 0.5, recall: 1.0, map50: 0.7450000000000001,
                map50_95: 0.6705000000000001, f1_conf: 0.0,
                ap_per_iou: [0.7450000000000001, 0.7450000000000001, 0.7450000000000001, 0.7450000000000001, 0.7450000000000001, 0.7450000000000001, 0.7450000000000001, 0.7450000000000001, 0.7450000000000001, 0.0],
                precision_curve: Curve { len: 1000, mean: 0.5585251958759234, samples: &[(0, 0.5), (1, 0.5), (100, 0.5), (250, 0.5), (400, 0.5), (500, 0.5), (600, 0.49899903837745707), (750, 0.41791791761959635), (900, 1.0), (998, 1.0), (999, 1.0)] },
                recall_curve: Curve { len: 1000, mean: 0.7749249278783092, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 1.0), (500, 1.0), (600, 0.9969971151323712), (750, 0.5), (900, 0.0), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.55829355111638, samples: &[(0, 0.6666666666666666), (1, 0.6666666666666666), (100, 0.6666666666666666), (250, 0.6666666666666666), (400, 0.6666666666666666), (500, 0.6666666666666666), (600, 0.6651094664233488), (750, 0.4552889856463068), (900, 0.0), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.7495, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 1.0), (500, 0.5), (600, 0.5), (750, 0.5), (900, 0.5), (998, 0.5), (999, 0.0)] },
            },
        },
        Expected {
            name: "perfect",
            n_truth: 3, n_detections: 3, checksum: 14040.0,
            coco: CocoExpected { ap: 1.0, ap50: 1.0, ap75: 1.0, ar100: 1.0,
                precision_at_50: &[(1.0, 101)] },
            current: UltraExpected {
                precision: 1.0, recall: 1.0, map50: 0.995,
                map50_95: 0.9949999999999999, f1_conf: 0.0,
                ap_per_iou: [0.995, 0.995, 0.995, 0.995, 0.995, 0.995, 0.995, 0.995, 0.995, 0.995],
                precision_curve: Curve { len: 1000, mean: 1.0, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 1.0), (500, 1.0), (600, 1.0), (750, 1.0), (900, 1.0), (998, 1.0), (999, 1.0)] },
                recall_curve: Curve { len: 1000, mean: 0.8414581247715688, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 1.0), (500, 1.0), (600, 1.0), (750, 0.9949949961882811), (900, 0.0), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.8612557973338153, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 1.0), (500, 1.0), (600, 1.0), (750, 0.9974912198670766), (900, 0.0), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.999, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 1.0), (500, 1.0), (600, 1.0), (750, 1.0), (900, 1.0), (998, 1.0), (999, 0.0)] },
            },
            legacy: UltraExpected {
                precision: 1.0, recall: 1.0, map50: 0.995,
                map50_95: 0.9949999999999999, f1_conf: 0.0,
                ap_per_iou: [0.995, 0.995, 0.995, 0.995, 0.995, 0.995, 0.995, 0.995, 0.995, 0.995],
                precision_curve: Curve { len: 1000, mean: 1.0, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 1.0), (500, 1.0), (600, 1.0), (750, 1.0), (900, 1.0), (998, 1.0), (999, 1.0)] },
                recall_curve: Curve { len: 1000, mean: 0.8414581247715688, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 1.0), (500, 1.0), (600, 1.0), (750, 0.9949949961882811), (900, 0.0), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.8612557973338153, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 1.0), (500, 1.0), (600, 1.0), (750, 0.9974912198670766), (900, 0.0), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.999, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 1.0), (500, 1.0), (600, 1.0), (750, 1.0), (900, 1.0), (998, 1.0), (999, 0.0)] },
            },
        },
        Expected {
            name: "ties",
            n_truth: 6, n_detections: 8, checksum: 11060.0,
            coco: CocoExpected { ap: 0.6460396039603961, ap50: 0.6460396039603961, ap75: 0.6460396039603961, ar100: 0.8333333333333334,
                precision_at_50: &[(1.0, 34), (0.625, 50), (0.0, 17)] },
            current: UltraExpected {
                precision: 0.625, recall: 0.8333333333333334, map50: 0.6475,
                map50_95: 0.6475, f1_conf: 0.0,
                ap_per_iou: [0.6475, 0.6475, 0.6475, 0.6475, 0.6475, 0.6475, 0.6475, 0.6475, 0.6475, 0.6475],
                precision_curve: Curve { len: 1000, mean: 0.7034017356391905, samples: &[(0, 0.625), (1, 0.625), (100, 0.625), (250, 0.625), (400, 0.625), (500, 0.625), (600, 0.4993994230264742), (750, 0.8358358352391927), (900, 1.0), (998, 1.0), (999, 1.0)] },
                recall_curve: Curve { len: 1000, mean: 0.5749749759594365, samples: &[(0, 0.8333333333333334), (1, 0.8333333333333334), (100, 0.8333333333333334), (250, 0.8333333333333334), (400, 0.8333333333333334), (500, 0.8333333333333334), (600, 0.49899903837745707), (750, 0.3333333333333333), (900, 0.0), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.5192927723138167, samples: &[(0, 0.7142857142857143), (1, 0.7142857142857143), (100, 0.7142857142857143), (250, 0.7142857142857143), (400, 0.7142857142857143), (500, 0.7142857142857143), (600, 0.49919915041945645), (750, 0.4765981734189871), (900, 0.0), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.6455, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 0.625), (500, 0.625), (600, 0.625), (750, 0.625), (900, 0.0), (998, 0.0), (999, 0.0)] },
            },
            legacy: UltraExpected {
                precision: 0.625, recall: 0.8333333333333334, map50: 0.6985000000000001,
                map50_95: 0.6985000000000001, f1_conf: 0.0,
                ap_per_iou: [0.6985000000000001, 0.6985000000000001, 0.6985000000000001, 0.6985000000000001, 0.6985000000000001, 0.6985000000000001, 0.6985000000000001, 0.6985000000000001, 0.6985000000000001, 0.6985000000000001],
                precision_curve: Curve { len: 1000, mean: 0.7034017356391905, samples: &[(0, 0.625), (1, 0.625), (100, 0.625), (250, 0.625), (400, 0.625), (500, 0.625), (600, 0.4993994230264742), (750, 0.8358358352391927), (900, 1.0), (998, 1.0), (999, 1.0)] },
                recall_curve: Curve { len: 1000, mean: 0.5749749759594365, samples: &[(0, 0.8333333333333334), (1, 0.8333333333333334), (100, 0.8333333333333334), (250, 0.8333333333333334), (400, 0.8333333333333334), (500, 0.8333333333333334), (600, 0.49899903837745707), (750, 0.3333333333333333), (900, 0.0), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.5192927723138167, samples: &[(0, 0.7142857142857143), (1, 0.7142857142857143), (100, 0.7142857142857143), (250, 0.7142857142857143), (400, 0.7142857142857143), (500, 0.7142857142857143), (600, 0.49919915041945645), (750, 0.4765981734189871), (900, 0.0), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.6975307807807808, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 0.625), (500, 0.625), (600, 0.625), (750, 0.625), (900, 0.37162162162162166), (998, 0.0037537537537536414), (999, 0.0)] },
            },
        },
        Expected {
            name: "half_recall",
            n_truth: 2, n_detections: 1, checksum: 2240.0,
            coco: CocoExpected { ap: 0.5049504950495048, ap50: 0.5049504950495048, ap75: 0.5049504950495048, ar100: 0.5,
                precision_at_50: &[(0.9999999999999998, 51), (0.0, 50)] },
            current: UltraExpected {
                precision: 1.0, recall: 0.5, map50: 0.495,
                map50_95: 0.495, f1_conf: 0.0,
                ap_per_iou: [0.495, 0.495, 0.495, 0.495, 0.495, 0.495, 0.495, 0.495, 0.495, 0.495],
                precision_curve: Curve { len: 1000, mean: 1.0, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 1.0), (500, 1.0), (600, 1.0), (750, 1.0), (900, 1.0), (998, 1.0), (999, 1.0)] },
                recall_curve: Curve { len: 1000, mean: 0.45, samples: &[(0, 0.5), (1, 0.5), (100, 0.5), (250, 0.5), (400, 0.5), (500, 0.5), (600, 0.5), (750, 0.5), (900, 0.0), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.5999999999999999, samples: &[(0, 0.6666666666666666), (1, 0.6666666666666666), (100, 0.6666666666666666), (250, 0.6666666666666666), (400, 0.6666666666666666), (500, 0.6666666666666666), (600, 0.6666666666666666), (750, 0.6666666666666666), (900, 0.0), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.5, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 1.0), (500, 0.0), (600, 0.0), (750, 0.0), (900, 0.0), (998, 0.0), (999, 0.0)] },
            },
            legacy: UltraExpected {
                precision: 1.0, recall: 0.5, map50: 0.75,
                map50_95: 0.75, f1_conf: 0.0,
                ap_per_iou: [0.75, 0.75, 0.75, 0.75, 0.75, 0.75, 0.75, 0.75, 0.75, 0.75],
                precision_curve: Curve { len: 1000, mean: 1.0, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 1.0), (500, 1.0), (600, 1.0), (750, 1.0), (900, 1.0), (998, 1.0), (999, 1.0)] },
                recall_curve: Curve { len: 1000, mean: 0.45, samples: &[(0, 0.5), (1, 0.5), (100, 0.5), (250, 0.5), (400, 0.5), (500, 0.5), (600, 0.5), (750, 0.5), (900, 0.0), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.5999999999999999, samples: &[(0, 0.6666666666666666), (1, 0.6666666666666666), (100, 0.6666666666666666), (250, 0.6666666666666666), (400, 0.6666666666666666), (500, 0.6666666666666666), (600, 0.6666666666666666), (750, 0.6666666666666666), (900, 0.0), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.7497497497497497, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 1.0), (500, 0.9989989989989989), (600, 0.7987987987987988), (750, 0.4984984984984986), (900, 0.19819819819819817), (998, 0.002002002002001957), (999, 0.0)] },
            },
        },
        Expected {
            name: "mixed",
            n_truth: 6, n_detections: 10, checksum: 27449.0,
            coco: CocoExpected { ap: 0.43559405940594054, ap50: 0.6826732673267326, ap75: 0.600990099009901, ar100: 0.5,
                precision_at_50: &[(0.9999999999999999, 34), (0.75, 33), (0.3, 34)] },
            current: UltraExpected {
                precision: 0.5, recall: 0.8333333333333333, map50: 0.6815,
                map50_95: 0.4344000000000001, f1_conf: 0.0,
                ap_per_iou: [0.6815, 0.6815, 0.6815, 0.599, 0.599, 0.599, 0.335, 0.1675, 0.0, 0.0],
                precision_curve: Curve { len: 1000, mean: 0.6084751460297249, samples: &[(0, 0.5), (1, 0.5), (100, 0.5), (250, 0.49995829162661565), (400, 0.5001334722784774), (500, 0.4250834184090826), (600, 0.49236737251341584), (750, 0.7509384384943737), (900, 0.93862613736912), (998, 1.0), (999, 1.0)] },
                recall_curve: Curve { len: 1000, mean: 0.5791374728012343, samples: &[(0, 0.8333333333333333), (1, 0.8333333333333333), (100, 0.8333333333333333), (250, 0.8331943054220521), (400, 0.7497775586533191), (500, 0.5274997274741636), (600, 0.5), (750, 0.49874874904707023), (900, 0.16666666666666666), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.5116875446069626, samples: &[(0, 0.625), (1, 0.625), (100, 0.625), (250, 0.624928312034045), (400, 0.6000059161345654), (500, 0.46779242730008186), (600, 0.4932964794077752), (750, 0.599397370062324), (900, 0.24155038930171893), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.68265, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 0.75), (500, 0.75), (600, 0.75), (750, 0.3), (900, 0.3), (998, 0.3), (999, 0.0)] },
            },
            legacy: UltraExpected {
                precision: 0.5, recall: 0.8333333333333333, map50: 0.7151599999999999,
                map50_95: 0.46439700000000006, f1_conf: 0.0,
                ap_per_iou: [0.7151599999999999, 0.7151599999999999, 0.7151599999999999, 0.6321650000000001, 0.6321650000000001, 0.6321650000000001, 0.4013300000000001, 0.20066500000000004, 0.0, 0.0],
                precision_curve: Curve { len: 1000, mean: 0.6084751460297249, samples: &[(0, 0.5), (1, 0.5), (100, 0.5), (250, 0.49995829162661565), (400, 0.5001334722784774), (500, 0.4250834184090826), (600, 0.49236737251341584), (750, 0.7509384384943737), (900, 0.93862613736912), (998, 1.0), (999, 1.0)] },
                recall_curve: Curve { len: 1000, mean: 0.5791374728012343, samples: &[(0, 0.8333333333333333), (1, 0.8333333333333333), (100, 0.8333333333333333), (250, 0.8331943054220521), (400, 0.7497775586533191), (500, 0.5274997274741636), (600, 0.5), (750, 0.49874874904707023), (900, 0.16666666666666666), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.5116875446069626, samples: &[(0, 0.625), (1, 0.625), (100, 0.625), (250, 0.624928312034045), (400, 0.6000059161345654), (500, 0.46779242730008186), (600, 0.4932964794077752), (750, 0.599397370062324), (900, 0.24155038930171893), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.71605, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 1.0), (400, 0.75), (500, 0.75), (600, 0.75), (750, 0.44954954954954957), (900, 0.35945945945945945), (998, 0.30060060060060056), (999, 0.0)] },
            },
        },
        Expected {
            name: "multi_box",
            n_truth: 6, n_detections: 7, checksum: 16336.0,
            coco: CocoExpected { ap: 0.2911810466760962, ap50: 0.8811881188118814, ap75: 0.09618104667609617, ar100: 0.4833333333333334,
                precision_at_50: &[(0.9999999999999998, 17), (0.8571428571428571, 84)] },
            current: UltraExpected {
                precision: 0.8571428571428571, recall: 1.0, map50: 0.8764285714285713,
                map50_95: 0.2902392857142857, f1_conf: 0.0,
                ap_per_iou: [0.8764285714285713, 0.6864285714285714, 0.3941428571428572, 0.3941428571428572, 0.23607142857142854, 0.09571428571428572, 0.09571428571428572, 0.04125000000000001, 0.04125000000000001, 0.04125000000000001],
                precision_curve: Curve { len: 1000, mean: 0.801080132264236, samples: &[(0, 0.8571428571428571), (1, 0.8571428571428571), (100, 0.8571428571428571), (250, 0.8451785136244533), (400, 0.8165999342560332), (500, 0.799749749809414), (600, 0.7494995191887286), (750, 0.5820820823804036), (900, 1.0), (998, 1.0), (999, 1.0)] },
                recall_curve: Curve { len: 1000, mean: 0.5833166551989715, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 0.916249595371173), (400, 0.7496663379468322), (500, 0.6658324993647133), (600, 0.49899903837745707), (750, 0.24874874904707028), (900, 0.0), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.6096735633071845, samples: &[(0, 0.923076923076923), (1, 0.923076923076923), (100, 0.923076923076923), (250, 0.8792802467156922), (400, 0.7817029494229627), (500, 0.7266727951733529), (600, 0.5991188969711171), (750, 0.3485479458822382), (900, 0.0), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.8801428571428571, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 0.8571428571428571), (400, 0.8571428571428571), (500, 0.8571428571428571), (600, 0.8571428571428571), (750, 0.8571428571428571), (900, 0.8571428571428571), (998, 0.8571428571428571), (999, 0.0)] },
            },
            legacy: UltraExpected {
                precision: 0.8571428571428571, recall: 1.0, map50: 0.8764285714285713,
                map50_95: 0.3631101428571428, f1_conf: 0.0,
                ap_per_iou: [0.8764285714285713, 0.7447142857142858, 0.4903142857142857, 0.4903142857142857, 0.34535714285714286, 0.19047142857142857, 0.19047142857142857, 0.10101, 0.10101, 0.10101],
                precision_curve: Curve { len: 1000, mean: 0.801080132264236, samples: &[(0, 0.8571428571428571), (1, 0.8571428571428571), (100, 0.8571428571428571), (250, 0.8451785136244533), (400, 0.8165999342560332), (500, 0.799749749809414), (600, 0.7494995191887286), (750, 0.5820820823804036), (900, 1.0), (998, 1.0), (999, 1.0)] },
                recall_curve: Curve { len: 1000, mean: 0.5833166551989715, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 0.916249595371173), (400, 0.7496663379468322), (500, 0.6658324993647133), (600, 0.49899903837745707), (750, 0.24874874904707028), (900, 0.0), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.6096735633071845, samples: &[(0, 0.923076923076923), (1, 0.923076923076923), (100, 0.923076923076923), (250, 0.8792802467156922), (400, 0.7817029494229627), (500, 0.7266727951733529), (600, 0.5991188969711171), (750, 0.3485479458822382), (900, 0.0), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.8801428571428571, samples: &[(0, 1.0), (1, 1.0), (100, 1.0), (250, 0.8571428571428571), (400, 0.8571428571428571), (500, 0.8571428571428571), (600, 0.8571428571428571), (750, 0.8571428571428571), (900, 0.8571428571428571), (998, 0.8571428571428571), (999, 0.0)] },
            },
        },
        Expected {
            name: "iou_boundaries",
            n_truth: 4, n_detections: 4, checksum: 7132.8,
            coco: CocoExpected { ap: 0.1595709570957096, ap50: 1.0, ap75: 0.0858085808580858, ar100: 0.25,
                precision_at_50: &[(1.0, 101)] },
            current: UltraExpected {
                precision: 0.75, recall: 0.75, map50: 0.5587500000000001,
                map50_95: 0.11329166666666668, f1_conf: 0.0,
                ap_per_iou: [0.5587500000000001, 0.2475, 0.08166666666666667, 0.08166666666666667, 0.08166666666666667, 0.08166666666666667, 0.0, 0.0, 0.0, 0.0],
                precision_curve: Curve { len: 1000, mean: 0.7039372680632312, samples: &[(0, 0.75), (1, 0.75), (100, 0.75), (250, 0.75), (400, 0.75), (500, 0.75), (600, 0.7494995191887286), (750, 0.5820820823804036), (900, 1.0), (998, 1.0), (999, 1.0)] },
                recall_curve: Curve { len: 1000, mean: 0.5623123122824802, samples: &[(0, 0.75), (1, 0.75), (100, 0.75), (250, 0.75), (400, 0.75), (500, 0.75), (600, 0.7484985575661856), (750, 0.37312312357060545), (900, 0.0), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.5782751499559954, samples: &[(0, 0.75), (1, 0.75), (100, 0.75), (250, 0.75), (400, 0.75), (500, 0.75), (600, 0.7489987039564102), (750, 0.4547468615102961), (900, 0.0), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.5625, samples: &[(0, 0.75), (1, 0.75), (100, 0.75), (250, 0.75), (400, 0.75), (500, 0.75), (600, 0.75), (750, 0.0), (900, 0.0), (998, 0.0), (999, 0.0)] },
            },
            legacy: UltraExpected {
                precision: 0.75, recall: 0.75, map50: 0.65625,
                map50_95: 0.17379166666666665, f1_conf: 0.0,
                ap_per_iou: [0.65625, 0.375, 0.17666666666666664, 0.17666666666666664, 0.17666666666666664, 0.17666666666666664, 0.0, 0.0, 0.0, 0.0],
                precision_curve: Curve { len: 1000, mean: 0.7039372680632312, samples: &[(0, 0.75), (1, 0.75), (100, 0.75), (250, 0.75), (400, 0.75), (500, 0.75), (600, 0.7494995191887286), (750, 0.5820820823804036), (900, 1.0), (998, 1.0), (999, 1.0)] },
                recall_curve: Curve { len: 1000, mean: 0.5623123122824802, samples: &[(0, 0.75), (1, 0.75), (100, 0.75), (250, 0.75), (400, 0.75), (500, 0.75), (600, 0.7484985575661856), (750, 0.37312312357060545), (900, 0.0), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.5782751499559954, samples: &[(0, 0.75), (1, 0.75), (100, 0.75), (250, 0.75), (400, 0.75), (500, 0.75), (600, 0.7489987039564102), (750, 0.4547468615102961), (900, 0.0), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.6559684684684685, samples: &[(0, 0.75), (1, 0.75), (100, 0.75), (250, 0.75), (400, 0.75), (500, 0.75), (600, 0.75), (750, 0.7477477477477479), (900, 0.29729729729729726), (998, 0.0030030030030029353), (999, 0.0)] },
            },
        },
        Expected {
            name: "stress_single",
            n_truth: 115, n_detections: 168, checksum: 14893131.298971158,
            coco: CocoExpected { ap: 0.22635342566222041, ap50: 0.4848683311836383, ap75: 0.144480780339637, ar100: 0.39391304347826084,
                precision_at_50: &[(1.0, 9), (0.9166666666666666, 1), (0.8947368421052632, 5), (0.8695652173913043, 3), (0.8275862068965517, 3), (0.825, 8), (0.8181818181818182, 3), (0.7592592592592593, 4), (0.711864406779661, 1), (0.6984126984126984, 2), (0.6666666666666666, 2), (0.6575342465753424, 1), (0.6447368421052632, 1), (0.5952380952380952, 1), (0.5894736842105263, 5), (0.5728155339805825, 3), (0.5660377358490566, 1), (0.5648148148148148, 1), (0.5478260869565217, 1), (0.5470085470085471, 1), (0.5416666666666666, 1), (0.5365853658536586, 1), (0.5317460317460317, 1), (0.53125, 1), (0.5307692307692308, 1), (0.5144927536231884, 1), (0.5, 3), (0.4807692307692308, 1), (0.0, 35)] },
            current: UltraExpected {
                precision: 0.5220522228100984, recall: 0.6086956521739131, map50: 0.4846210282898994,
                map50_95: 0.2246022965562468, f1_conf: 0.17617617617617617,
                ap_per_iou: [0.4846210282898994, 0.4429129586693978, 0.4225421969317329, 0.3457017729917572, 0.2655659501527563, 0.14065778609440938, 0.0744136950975057, 0.05080582443455536, 0.01665141516729391, 0.002150337733159819],
                precision_curve: Curve { len: 1000, mean: 0.693096661144934, samples: &[(0, 0.44642857142857145), (1, 0.44642857142857145), (100, 0.4978139203767669), (250, 0.5463829611227082), (400, 0.5795886189293991), (500, 0.6638249815732039), (600, 0.8019865071049118), (750, 0.8062861545517509), (900, 1.0), (998, 1.0), (999, 1.0)] },
                recall_curve: Curve { len: 1000, mean: 0.37717627725191927, samples: &[(0, 0.6521739130434783), (1, 0.6521739130434783), (100, 0.6434782608695652), (250, 0.55512871999301), (400, 0.46754965965661943), (500, 0.3949590977472487), (600, 0.3130434782608696), (750, 0.20869565217391303), (900, 0.0859753049506385), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.4227455799320208, samples: &[(0, 0.5300353356890459), (1, 0.5300353356890459), (100, 0.5613504429179347), (250, 0.5507211208633117), (400, 0.5175753137154179), (500, 0.4952543599871865), (600, 0.4503137117340374), (750, 0.3315693222242254), (900, 0.1583374954452512), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.4834539450436126, samples: &[(0, 1.0), (1, 1.0), (100, 0.8947368421052632), (250, 0.825), (400, 0.6575342465753424), (500, 0.5728155339805825), (600, 0.5303030303030303), (750, 0.0), (900, 0.0), (998, 0.0), (999, 0.0)] },
            },
            legacy: UltraExpected {
                precision: 0.5220522228100984, recall: 0.6086956521739131, map50: 0.5609882157898993,
                map50_95: 0.29252331008681726, f1_conf: 0.17617617617617617,
                ap_per_iou: [0.5609882157898993, 0.5247617817213458, 0.5067386255031615, 0.4322643291462944, 0.34930198125874706, 0.220055046368382, 0.14482615154349873, 0.1122589494345554, 0.055063468738722476, 0.018974551363566114],
                precision_curve: Curve { len: 1000, mean: 0.693096661144934, samples: &[(0, 0.44642857142857145), (1, 0.44642857142857145), (100, 0.4978139203767669), (250, 0.5463829611227082), (400, 0.5795886189293991), (500, 0.6638249815732039), (600, 0.8019865071049118), (750, 0.8062861545517509), (900, 1.0), (998, 1.0), (999, 1.0)] },
                recall_curve: Curve { len: 1000, mean: 0.37717627725191927, samples: &[(0, 0.6521739130434783), (1, 0.6521739130434783), (100, 0.6434782608695652), (250, 0.55512871999301), (400, 0.46754965965661943), (500, 0.3949590977472487), (600, 0.3130434782608696), (750, 0.20869565217391303), (900, 0.0859753049506385), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.4227455799320208, samples: &[(0, 0.5300353356890459), (1, 0.5300353356890459), (100, 0.5613504429179347), (250, 0.5507211208633117), (400, 0.5175753137154179), (500, 0.4952543599871865), (600, 0.4503137117340374), (750, 0.3315693222242254), (900, 0.1583374954452512), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.5610256015215191, samples: &[(0, 1.0), (1, 1.0), (100, 0.8947368421052632), (250, 0.825), (400, 0.6575342465753424), (500, 0.5728155339805825), (600, 0.5303030303030303), (750, 0.3199069605319606), (900, 0.12719192406692403), (998, 0.0012847669097668657), (999, 0.0)] },
            },
        },
        Expected {
            name: "stress_multi",
            n_truth: 87, n_detections: 132, checksum: 8913419.12099315,
            coco: CocoExpected { ap: 0.30957315892746495, ap50: 0.5236807271457666, ap75: 0.26362513248873953, ar100: 0.4788249559082892,
                precision_at_50: &[(1.0, 4), (0.9583333333333334, 4), (0.8842592592592592, 18), (0.8111888111888111, 7), (0.794871794871795, 1), (0.7724358974358975, 2), (0.7660256410256411, 2), (0.7100301659125189, 3), (0.7007422402159245, 2), (0.6640755735492578, 1), (0.6457342657342657, 3), (0.6159924026590694, 4), (0.6076507276507277, 7), (0.5862365862365863, 2), (0.3811083811083811, 6), (0.3707809805370781, 2), (0.34146341463414637, 1), (0.34089619965967105, 3), (0.17391304347826086, 4), (0.16025641025641027, 3), (0.0, 22)] },
            current: UltraExpected {
                precision: 0.5523817465709898, recall: 0.642471340388007, map50: 0.5232517471391182,
                map50_95: 0.3075846840657262, f1_conf: 0.1991991991991992,
                ap_per_iou: [0.5232517471391182, 0.506303376065747, 0.4657200507015406, 0.43115236137631935, 0.3728369007676721, 0.2604192250254767, 0.21524331482456652, 0.14822993552341376, 0.10912261691609519, 0.04356731231731232],
                precision_curve: Curve { len: 1000, mean: 0.6910240283300629, samples: &[(0, 0.45991970991970993), (1, 0.45991970991970993), (100, 0.4974804204835009), (250, 0.571270077456001), (400, 0.6004120249708608), (500, 0.6848759241437828), (600, 0.7700658823385499), (750, 0.8408642689352597), (900, 0.8072100600209406), (998, 1.0), (999, 1.0)] },
                recall_curve: Curve { len: 1000, mean: 0.391389245458848, samples: &[(0, 0.6960427689594356), (1, 0.6960427689594356), (100, 0.6647583631825922), (250, 0.5921074643286214), (400, 0.4701829805996473), (500, 0.3828909975999332), (600, 0.3266540794043045), (750, 0.23030830083014975), (900, 0.07577412397012416), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.4329465586640291, samples: &[(0, 0.5529100529100529), (1, 0.5529100529100529), (100, 0.5684036123547435), (250, 0.5803207098886266), (400, 0.525346296435174), (500, 0.48913299792899867), (600, 0.4587092610786818), (750, 0.3594438487414883), (900, 0.1361551016023649), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.5225113836816117, samples: &[(0, 1.0), (1, 1.0), (100, 0.8842592592592592), (250, 0.8396788396788398), (400, 0.7100301659125189), (500, 0.6076507276507277), (600, 0.3811083811083811), (750, 0.16025641025641027), (900, 0.0), (998, 0.0), (999, 0.0)] },
            },
            legacy: UltraExpected {
                precision: 0.5523817465709898, recall: 0.642471340388007, map50: 0.5915233089106801,
                map50_95: 0.37580532312703047, f1_conf: 0.1991991991991992,
                ap_per_iou: [0.5915233089106801, 0.574574937837309, 0.5379491105306005, 0.5055789486779066, 0.4515598844506557, 0.3403965365374941, 0.29146830716968264, 0.2143720755424856, 0.1667813632422328, 0.08384875837125838],
                precision_curve: Curve { len: 1000, mean: 0.6910240283300629, samples: &[(0, 0.45991970991970993), (1, 0.45991970991970993), (100, 0.4974804204835009), (250, 0.571270077456001), (400, 0.6004120249708608), (500, 0.6848759241437828), (600, 0.7700658823385499), (750, 0.8408642689352597), (900, 0.8072100600209406), (998, 1.0), (999, 1.0)] },
                recall_curve: Curve { len: 1000, mean: 0.391389245458848, samples: &[(0, 0.6960427689594356), (1, 0.6960427689594356), (100, 0.6647583631825922), (250, 0.5921074643286214), (400, 0.4701829805996473), (500, 0.3828909975999332), (600, 0.3266540794043045), (750, 0.23030830083014975), (900, 0.07577412397012416), (998, 0.0), (999, 0.0)] },
                f1_curve: Curve { len: 1000, mean: 0.4329465586640291, samples: &[(0, 0.5529100529100529), (1, 0.5529100529100529), (100, 0.5684036123547435), (250, 0.5803207098886266), (400, 0.525346296435174), (500, 0.48913299792899867), (600, 0.4587092610786818), (750, 0.3594438487414883), (900, 0.1361551016023649), (998, 0.0), (999, 0.0)] },
                pr_curve_map50: Curve { len: 1000, mean: 0.5918731575433854, samples: &[(0, 1.0), (1, 1.0), (100, 0.8842592592592592), (250, 0.8396788396788398), (400, 0.7100301659125189), (500, 0.6076507276507277), (600, 0.5263445263445263), (750, 0.3830701330701331), (900, 0.16118866118866113), (998, 0.0016281682948348826), (999, 0.0)] },
            },
        },
    ];
}
