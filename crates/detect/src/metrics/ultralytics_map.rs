//! Ultralytics validation metrics (P, R, mAP50, mAP50-95 and the curves behind them), current and
//! legacy code: `box_iou` -> `match_predictions` -> `ap_per_class` -> `compute_ap`, as its validator
//! runs them.

use super::numpy::{mean_rows, np_interp, np_linspace, np_mean, np_trapezoid};
use super::{ImageEval, cmp_desc, det_box};
use crate::Detection;
use serde::{Deserialize, Serialize};

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
pub(super) fn ultra_match(
    iou: &[Vec<f32>],
    n_det: usize,
    version: UltralyticsVersion,
) -> Vec<[bool; 10]> {
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
    from_stats(detection_stats(images, version), version)
}

/// The metrics of per-detection statistics, as `ap_per_class` computes them: the part shared by
/// axis-aligned and oriented boxes (crates/detect/src/metrics/obb.rs), which differ in the IoU.
pub(super) fn from_stats(stats: Stats, version: UltralyticsVersion) -> UltralyticsMetrics {
    let px = np_linspace(0.0, 1.0, 1000);
    let (tp, conf, pred_cls, target_cls) = stats;
    let (n_truth, n_detections) = (target_cls.len(), conf.len());

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

/// Per-detection statistics in validator order (image order, NMS order within an image):
/// each detection's matches at the 10 IoU thresholds, its confidence and class, and the
/// truth classes.
pub(super) type Stats = (Vec<[bool; 10]>, Vec<f32>, Vec<u32>, Vec<u32>);

fn detection_stats(images: &[ImageEval], version: UltralyticsVersion) -> Stats {
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
    (tp, conf, pred_cls, target_cls)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thresholds_match_torch() {
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
    }

    #[test]
    fn smooth_and_argmax() {
        assert_eq!(smooth(&[1.0; 1000], 0.1).len(), 1000);
        assert_eq!(argmax_first(&[1.0, 3.0, 3.0, 2.0]), 1);
    }
}
