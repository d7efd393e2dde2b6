//! COCO metrics exactly as pycocotools `COCOeval` computes them for boxes (AP@[.5:.95], AP50, AP75,
//! AR@100 and the precision at IoU 0.5).

use super::numpy::{np_linspace, np_mean};
use super::{ImageEval, cmp_desc, det_box};
use serde::{Deserialize, Serialize};

/// COCO metrics as pycocotools reports them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CocoMetrics {
    /// AP@[.5:.95] (`stats[0]`); -1 when no class has objects.
    pub ap: f64,
    /// AP at IoU 0.5 (`stats[1]`).
    pub ap50: f64,
    /// AP at IoU 0.75 (`stats[2]`).
    pub ap75: f64,
    /// AR with at most 100 detections per image (`stats[8]`).
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
