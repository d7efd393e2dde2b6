//! Box IoU and this crate's own fixed-threshold counts (precision, recall, TP, FP, FN at one
//! confidence and IoU), the figures the paper reports at conf 0.5, IoU 0.5.

use super::{ImageEval, cmp_desc, det_box};
use serde::{Deserialize, Serialize};

/// Intersection over union of two `[x1, y1, x2, y2]` boxes (no `+1`, no epsilon); 0 when the union is
/// empty.
pub fn iou(a: &[f64; 4], b: &[f64; 4]) -> f64 {
    let w = (a[2].min(b[2]) - a[0].max(b[0])).max(0.0);
    let h = (a[3].min(b[3]) - a[1].max(b[1])).max(0.0);
    let inter = w * h;
    let union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter;
    if union > 0.0 { inter / union } else { 0.0 }
}

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
/// IoU 0.5), matched per image by [`match_image`].
pub fn at_threshold(images: &[ImageEval], conf: f64, iou_threshold: f64) -> AtThreshold {
    tally(images.iter().map(|im| {
        let m = match_image(im, conf, iou_threshold);
        (m.found, m.false_positives)
    }))
}

/// The counts of per-image matches: whether each object was found, and the false positives.
pub(super) fn tally(images: impl Iterator<Item = (Vec<bool>, usize)>) -> AtThreshold {
    let (mut tp, mut fp, mut fn_) = (0usize, 0usize, 0usize);
    for (found_each, false_positives) in images {
        let found = found_each.iter().filter(|&&f| f).count();
        tp += found;
        fp += false_positives;
        fn_ += found_each.len() - found;
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

/// How the detections of one image matched its objects at one confidence and IoU threshold.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageMatch {
    /// Per object (in the image's order): whether a detection took it.
    pub found: Vec<bool>,
    /// Detections with `score >= conf` that took no object.
    pub false_positives: usize,
    /// Their boxes, in matching order (descending score).
    pub false_positive_boxes: Vec<[f64; 4]>,
}

/// Match one image, greedy by score as COCO does: detections with `score >= conf` in descending
/// score (ties in input order) each take the still unmatched object of their class with the
/// highest IoU ([`iou`], plain `f64`), provided it is `>= iou_threshold` (IoU ties: the first
/// object). Unmatched detections are false positives, unmatched objects misses.
pub fn match_image(im: &ImageEval, conf: f64, iou_threshold: f64) -> ImageMatch {
    im.check();
    let dets: Vec<(f64, u32)> = im.detections.iter().map(|d| (d.score, d.class)).collect();
    let (found, false_positives) = greedy(&im.truth_class, &dets, (conf, iou_threshold), |g, j| {
        iou(&im.truth[g], &det_box(&im.detections[j]))
    });
    let false_positive_boxes: Vec<[f64; 4]> = false_positives
        .iter()
        .map(|&j| det_box(&im.detections[j]))
        .collect();
    ImageMatch {
        found,
        false_positives: false_positive_boxes.len(),
        false_positive_boxes,
    }
}

/// [`match_image`]'s rule for any IoU: `dets` (score, class), `iou(g, j)` of object g and
/// detection j. Returns whether each object was found and the false positives' indices in
/// matching order.
pub(super) fn greedy(
    truth_class: &[u32],
    dets: &[(f64, u32)],
    (conf, iou_threshold): (f64, f64),
    iou: impl Fn(usize, usize) -> f64,
) -> (Vec<bool>, Vec<usize>) {
    let mut order: Vec<usize> = (0..dets.len()).filter(|&j| dets[j].0 >= conf).collect();
    order.sort_by(|&a, &b| cmp_desc(dets[a].0, dets[b].0));
    let mut found = vec![false; truth_class.len()];
    let mut false_positives = Vec::new();
    for j in order {
        let mut best: Option<(usize, f64)> = None;
        for (g, &tc) in truth_class.iter().enumerate() {
            if found[g] || tc != dets[j].1 {
                continue;
            }
            let v = iou(g, j);
            if v >= iou_threshold && best.is_none_or(|(_, bv)| v > bv) {
                best = Some((g, v));
            }
        }
        match best {
            Some((g, _)) => found[g] = true,
            None => false_positives.push(j),
        }
    }
    (found, false_positives)
}

#[cfg(test)]
mod tests {
    use super::super::cases::{case, img};
    use super::*;

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

    /// The frames of a campaign with several objects per image and empty images (#34): two
    /// objects in image 1, one in image 2, none in image 3; six detections. By hand, at conf 0.5
    /// and IoU 0.5: A and C found (IoU 1), B missed (its neighbour's IoU is 25/175), FPs in
    /// every image: TP 2, FP 3, FN 1. COCO (every score, IoU 1 at every threshold) in score
    /// order: .9 TP, .85 FP, .8 FP, .7 TP, .6 FP, .3 FP with 3 objects: recall 1/3 at
    /// precision 1, then 2/3 at 1/2; the 101-point envelope is 1 for the 34 recall points
    /// 0..0.33 and 1/2 for the 33 points 0.34..0.66: AP = (34 + 16.5) / 101 = 0.5 at every IoU,
    /// AR 2/3. pycocotools divides by tp + fp + 2.2e-16, hence the 1e-12.
    #[test]
    fn several_objects_and_an_empty_image_by_hand() {
        let (a, b, c) = (
            [0., 0., 10., 10.],
            [100., 100., 110., 110.],
            [0., 0., 20., 20.],
        );
        let images = [
            img(
                &[(a, 0), (b, 0)],
                &[(a, 0.9, 0), ([95., 95., 105., 105.], 0.8, 0)],
            ),
            img(
                &[(c, 0)],
                &[
                    (c, 0.7, 0),
                    ([500., 500., 510., 510.], 0.6, 0),
                    ([300., 0., 310., 10.], 0.3, 0),
                ],
            ),
            img(&[], &[([50., 50., 60., 60.], 0.85, 0)]),
        ];
        let r = at_threshold(&images, 0.5, 0.5);
        assert_eq!((r.tp, r.fp, r.fn_), (2, 3, 1));
        assert!((r.precision - 0.4).abs() < 1e-15 && (r.recall - 2.0 / 3.0).abs() < 1e-15);
        let m = match_image(&images[0], 0.5, 0.5);
        assert_eq!(m.found, [true, false]);
        assert_eq!(m.false_positive_boxes, [[95., 95., 105., 105.]]);
        let c = crate::metrics::coco(&images);
        for (what, v, want) in [
            ("ap", c.ap, 0.5),
            ("ap50", c.ap50, 0.5),
            ("ap75", c.ap75, 0.5),
            ("ar100", c.ar100, 2.0 / 3.0),
        ] {
            assert!((v - want).abs() < 1e-12, "{what} {v}");
        }
    }
}
