//! Oriented boxes (YOLO-OBB: `cls x1 y1 x2 y2 x3 y3 x4 y4 [score]`, normalised corners) scored
//! as Ultralytics 8.4.190's `OBBValidator` scores them: each box reduced to (cx, cy, w, h, angle)
//! by its minimum-area rectangle (`ops.xyxyxyxy2xywhr`, OpenCV's `minAreaRect` on float32
//! corners), the IoU of two boxes their probabilistic IoU (`metrics.batch_probiou`: the
//! Hellinger distance between the Gaussians of the two boxes, float32), then the same
//! `match_predictions` and `ap_per_class` as axis-aligned boxes.

use std::path::Path;

use super::matching::{greedy, tally};
use super::ultralytics_map::{Stats, from_stats, ultra_match};
use super::yolo_files::{parse_lines, read_paired};
use super::{AtThreshold, MetricsError, UltralyticsMetrics, UltralyticsVersion, cmp_desc};

/// A box's four corners, in order around it.
pub type Corners = [[f64; 2]; 4];

/// One image's oriented objects and detections.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObbImage {
    pub truth: Vec<Corners>,
    pub truth_class: Vec<u32>,
    /// (corners, score, class).
    pub detections: Vec<(Corners, f64, u32)>,
}

impl ObbImage {
    /// The image with x multiplied by `sx` and y by `sy` (normalised corners to pixels).
    pub fn scaled(&self, sx: f64, sy: f64) -> ObbImage {
        let scale = |c: &Corners| c.map(|[x, y]| [x * sx, y * sy]);
        ObbImage {
            truth: self.truth.iter().map(scale).collect(),
            truth_class: self.truth_class.clone(),
            detections: self
                .detections
                .iter()
                .map(|(c, s, k)| (scale(c), *s, *k))
                .collect(),
        }
    }
}

/// (cx, cy, w, h, angle in radians) of the minimum-area rectangle around `corners`, as
/// `xyxyxyxy2xywhr` gives it (corners rounded to float32 first, as it feeds OpenCV). Every
/// edge of the convex hull is tried as a side (the rectangle of least area has a side on one);
/// of four corners in order around a convex box, the edges are the hull's.
pub fn xywhr(corners: &Corners) -> [f64; 5] {
    let p: Vec<[f64; 2]> = corners
        .iter()
        .map(|c| [c[0] as f32 as f64, c[1] as f32 as f64])
        .collect();
    let mut best: Option<(f64, [f64; 5])> = None;
    for k in 0..4 {
        let (a, b) = (p[k], p[(k + 1) % 4]);
        let len = (b[0] - a[0]).hypot(b[1] - a[1]);
        if len == 0.0 {
            continue;
        }
        let u = [(b[0] - a[0]) / len, (b[1] - a[1]) / len];
        let (mut s0, mut s1, mut t0, mut t1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for q in &p {
            let (s, t) = (q[0] * u[0] + q[1] * u[1], -q[0] * u[1] + q[1] * u[0]);
            (s0, s1, t0, t1) = (s0.min(s), s1.max(s), t0.min(t), t1.max(t));
        }
        let area = (s1 - s0) * (t1 - t0);
        if best.is_none_or(|(a, _)| area < a) {
            let (sc, tc) = ((s0 + s1) / 2.0, (t0 + t1) / 2.0);
            let centre = [sc * u[0] - tc * u[1], sc * u[1] + tc * u[0]];
            let angle = u[1].atan2(u[0]);
            best = Some((area, [centre[0], centre[1], s1 - s0, t1 - t0, angle]));
        }
    }
    // Four equal corners: a point.
    let [cx, cy, mut w, mut h, mut angle] = best.map_or([p[0][0], p[0][1], 0.0, 0.0, 0.0], |b| b.1);
    // Ultralytics' canonical form: w the longer side, the angle in [-pi/4, 3pi/4). The same box,
    // but probiou's float32 arithmetic on a long thin box rounds differently at another angle.
    if w < h {
        (w, h) = (h, w);
        angle += std::f64::consts::FRAC_PI_2;
    }
    while angle >= 3.0 * std::f64::consts::FRAC_PI_4 {
        angle -= std::f64::consts::PI;
    }
    while angle < -std::f64::consts::FRAC_PI_4 {
        angle += std::f64::consts::PI;
    }
    [cx, cy, w, h, angle]
}

/// Ultralytics' `batch_probiou` of two (cx, cy, w, h, angle) boxes, in float32 as its
/// tensors are, `eps = 1e-7`.
pub fn probiou(b1: &[f64; 5], b2: &[f64; 5]) -> f32 {
    const EPS: f32 = 1e-7;
    let cov = |b: &[f64; 5]| {
        let (a, bb, r) = (
            (b[2] as f32).powi(2) / 12.0,
            (b[3] as f32).powi(2) / 12.0,
            b[4] as f32,
        );
        let (cos, sin) = (r.cos(), r.sin());
        let (cos2, sin2) = (cos.powi(2), sin.powi(2));
        (
            a * cos2 + bb * sin2,
            a * sin2 + bb * cos2,
            (a - bb) * cos * sin,
        )
    };
    let (x1, y1, x2, y2) = (b1[0] as f32, b1[1] as f32, b2[0] as f32, b2[1] as f32);
    let ((a1, bb1, c1), (a2, bb2, c2)) = (cov(b1), cov(b2));
    let det = (a1 + a2) * (bb1 + bb2) - (c1 + c2).powi(2);
    let t1 = ((a1 + a2) * (y1 - y2).powi(2) + (bb1 + bb2) * (x1 - x2).powi(2)) / (det + EPS) * 0.25;
    let t2 = ((c1 + c2) * (x2 - x1) * (y1 - y2)) / (det + EPS) * 0.5;
    let own = (a1 * bb1 - c1.powi(2)).max(0.0) * (a2 * bb2 - c2.powi(2)).max(0.0);
    let t3 = (det / (4.0 * own.sqrt() + EPS) + EPS).ln() * 0.5;
    let bd = (t1 + t2 + t3).clamp(EPS, 100.0);
    let hd = (1.0 - (-bd).exp() + EPS).sqrt();
    1.0 - hd
}

/// The probiou of every object (rows) with every detection (columns, in `order`).
fn iou_matrix(im: &ObbImage, order: &[usize]) -> Vec<Vec<f32>> {
    let dets: Vec<[f64; 5]> = order.iter().map(|&j| xywhr(&im.detections[j].0)).collect();
    im.truth
        .iter()
        .zip(&im.truth_class)
        .map(|(t, &tc)| {
            let t = xywhr(t);
            order
                .iter()
                .zip(&dets)
                .map(|(&j, d)| {
                    if im.detections[j].2 == tc {
                        probiou(&t, d)
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect()
}

/// Ultralytics' OBB validation metrics (P, R, mAP50, mAP50-95) of `images` in pixels.
pub fn ultralytics_obb(images: &[ObbImage]) -> UltralyticsMetrics {
    let version = UltralyticsVersion::Current;
    let (mut tp, mut conf, mut pred_cls, mut target_cls) = (vec![], vec![], vec![], vec![]);
    for im in images {
        target_cls.extend_from_slice(&im.truth_class);
        // Scores as the model's float32, in descending order, ties in input order.
        let mut order: Vec<usize> = (0..im.detections.len()).collect();
        order.sort_by(|&a, &b| {
            cmp_desc(
                im.detections[a].1 as f32 as f64,
                im.detections[b].1 as f32 as f64,
            )
        });
        let correct = if im.truth.is_empty() || order.is_empty() {
            vec![[false; 10]; order.len()]
        } else {
            ultra_match(&iou_matrix(im, &order), order.len(), version)
        };
        tp.extend(correct);
        conf.extend(order.iter().map(|&j| im.detections[j].1 as f32));
        pred_cls.extend(order.iter().map(|&j| im.detections[j].2));
    }
    let stats: Stats = (tp, conf, pred_cls, target_cls);
    from_stats(stats, version)
}

/// Precision, recall, TP, FP, FN at one confidence and IoU, as `matching::at_threshold` counts
/// axis-aligned boxes, with the probiou (float32, as Ultralytics') for IoU.
pub fn at_threshold_obb(images: &[ObbImage], conf: f64, iou_threshold: f64) -> AtThreshold {
    tally(images.iter().map(|im| {
        let dets: Vec<(f64, u32)> = im.detections.iter().map(|d| (d.1, d.2)).collect();
        let boxes: Vec<[f64; 5]> = im.detections.iter().map(|d| xywhr(&d.0)).collect();
        let truth: Vec<[f64; 5]> = im.truth.iter().map(xywhr).collect();
        let (found, fp) = greedy(&im.truth_class, &dets, (conf, iou_threshold), |g, j| {
            probiou(&truth[g], &boxes[j]) as f64
        });
        (found, fp.len())
    }))
}

/// YOLO-OBB lines, `cls x1 y1 x2 y2 x3 y3 x4 y4` and a score for predictions.
fn parse_obb(
    path: &Path,
    text: &str,
    with_score: bool,
) -> Result<Vec<(Corners, f64, u32)>, MetricsError> {
    let (want, form) = if with_score {
        (10, "cls x1 y1 x2 y2 x3 y3 x4 y4 score")
    } else {
        (9, "cls x1 y1 x2 y2 x3 y3 x4 y4")
    };
    Ok(parse_lines(path, text, want, form)?
        .into_iter()
        .map(|(_, class, v)| {
            let corners = [[v[0], v[1]], [v[2], v[3]], [v[4], v[5]], [v[6], v[7]]];
            (corners, if with_score { v[8] } else { 1.0 }, class)
        })
        .collect())
}

/// YOLO-OBB label files (`labels`) and prediction files (`predictions`, Ultralytics' `save_txt`
/// with `save_conf` for an OBB model), paired by stem as `read_yolo_dirs` pairs them; corners
/// stay normalised.
pub fn read_obb_dirs(
    labels: &Path,
    predictions: &Path,
) -> Result<Vec<(String, ObbImage)>, MetricsError> {
    read_paired(labels, predictions, parse_obb, |truth, detections| {
        ObbImage {
            truth: truth.iter().map(|t| t.0).collect(),
            truth_class: truth.iter().map(|t| t.2).collect(),
            detections,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(cx: f64, cy: f64, w: f64, h: f64, deg: f64) -> Corners {
        let (c, s) = (deg.to_radians().cos(), deg.to_radians().sin());
        [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]].map(|[a, b]| {
            let (x, y) = (a * w / 2.0, b * h / 2.0);
            [cx + x * c - y * s, cy + x * s + y * c]
        })
    }

    #[test]
    fn a_rectangle_comes_back_from_its_corners() {
        let b = xywhr(&rect(300.0, 200.0, 150.0, 6.0, 30.0));
        assert!(
            (b[0] - 300.0).abs() < 1e-4 && (b[1] - 200.0).abs() < 1e-4,
            "{b:?}"
        );
        let (w, h) = (b[2].max(b[3]), b[2].min(b[3]));
        assert!((w - 150.0).abs() < 1e-4 && (h - 6.0).abs() < 1e-4, "{b:?}");
        // The same box has probiou 1 (less float32 rounding), a disjoint one 0.
        let same = probiou(&b, &b);
        assert!((same - 1.0).abs() < 1e-3, "{same}");
        let far = xywhr(&rect(900.0, 900.0, 150.0, 6.0, 30.0));
        assert!(probiou(&b, &far) < 1e-3);
        // Turned 90 degrees about its centre: a long thin box barely overlaps itself.
        let turned = xywhr(&rect(300.0, 200.0, 150.0, 6.0, 120.0));
        assert!(probiou(&b, &turned) < 0.2, "{}", probiou(&b, &turned));
    }
}
