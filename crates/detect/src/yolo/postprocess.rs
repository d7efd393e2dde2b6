//! Decoding of the network output as Ultralytics' `non_max_suppression` (class-aware,
//! torchvision's NMS in f32) and `scale_boxes` back to the original image.

use super::preprocess::py_round;
use crate::Detection;

/// Ultralytics' `max_wh`: class offset added to boxes so that NMS never mixes classes.
const MAX_WH: f32 = 7680.0;
/// Ultralytics' `max_nms`: at most this many candidates (highest scores) go into NMS.
const MAX_NMS: usize = 30_000;

/// A box in network-input coordinates after NMS (f32, as torch holds it).
#[derive(Clone, Copy, Debug)]
pub(super) struct Cand {
    b: [f32; 4],
    score: f32,
    class: u32,
}

/// Ultralytics' `non_max_suppression` for one image: `data` is the (4 + nc, n) output.
pub(super) fn nms_decode(
    data: &[f32],
    nc: usize,
    n: usize,
    conf: f64,
    iou: f64,
    max_det: usize,
) -> Vec<Cand> {
    let row = |k: usize| &data[k * n..(k + 1) * n];
    let mut cands: Vec<Cand> = Vec::new();
    for i in 0..n {
        // torch's max over classes: the first maximum.
        let (mut best, mut j) = (row(4)[i], 0usize);
        for c in 1..nc {
            let s = row(4 + c)[i];
            if s > best {
                best = s;
                j = c;
            }
        }
        // torch compares the f32 scores with the threshold cast to f32.
        if best > conf as f32 {
            let (xc, yc) = (row(0)[i], row(1)[i]);
            let (hw, hh) = (row(2)[i] / 2.0, row(3)[i] / 2.0);
            cands.push(Cand {
                b: [xc - hw, yc - hh, xc + hw, yc + hh],
                score: best,
                class: j as u32,
            });
        }
    }
    // torchvision.ops.nms sorts by score, descending, stably.
    cands.sort_by(|a, b| b.score.total_cmp(&a.score));
    cands.truncate(MAX_NMS);
    // Class-aware: offset boxes by class * max_wh (in f32, as torch does).
    let boxes: Vec<[f32; 4]> = cands
        .iter()
        .map(|c| {
            let off = c.class as f32 * MAX_WH;
            [c.b[0] + off, c.b[1] + off, c.b[2] + off, c.b[3] + off]
        })
        .collect();
    let areas: Vec<f32> = boxes
        .iter()
        .map(|b| (b[2] - b[0]) * (b[3] - b[1]))
        .collect();
    let mut suppressed = vec![false; cands.len()];
    let mut keep = Vec::new();
    for i in 0..cands.len() {
        if keep.len() >= max_det {
            break;
        }
        if suppressed[i] {
            continue;
        }
        keep.push(cands[i]);
        let bi = boxes[i];
        for j in i + 1..cands.len() {
            if suppressed[j] {
                continue;
            }
            let bj = boxes[j];
            let w = (bi[2].min(bj[2]) - bi[0].max(bj[0])).max(0.0);
            let h = (bi[3].min(bj[3]) - bi[1].max(bj[1])).max(0.0);
            let inter = w * h;
            let ovr = inter / (areas[i] + areas[j] - inter);
            if f64::from(ovr) > iou {
                suppressed[j] = true;
            }
        }
    }
    keep
}

/// Ultralytics' `scale_boxes(img1_shape, boxes, img0_shape)` then `clip_boxes`, in f32.
pub(super) fn scale_boxes(
    kept: &[Cand],
    img1: (usize, usize),
    img0: (usize, usize),
) -> Vec<Detection> {
    let (h1, w1) = (img1.0 as f64, img1.1 as f64);
    let (h0, w0) = (img0.0 as f64, img0.1 as f64);
    let gain = f64::min(h1 / h0, w1 / w0);
    let new_h = py_round(h0 * gain).max(1) as f64;
    let new_w = py_round(w0 * gain).max(1) as f64;
    let (gain_y, gain_x) = ((new_h / h0) as f32, (new_w / w0) as f32);
    let pad_x = py_round((w1 - new_w) / 2.0 - 0.1) as f32;
    let pad_y = py_round((h1 - new_h) / 2.0 - 0.1) as f32;
    let (wc, hc) = (w0 as f32, h0 as f32);
    kept.iter()
        .map(|c| {
            let x1 = ((c.b[0] - pad_x) / gain_x).clamp(0.0, wc);
            let y1 = ((c.b[1] - pad_y) / gain_y).clamp(0.0, hc);
            let x2 = ((c.b[2] - pad_x) / gain_x).clamp(0.0, wc);
            let y2 = ((c.b[3] - pad_y) / gain_y).clamp(0.0, hc);
            Detection {
                x1: f64::from(x1),
                y1: f64::from(y1),
                x2: f64::from(x2),
                y2: f64::from(y2),
                score: f64::from(c.score),
                class: c.class,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nms_is_class_aware_and_ordered() {
        // Three anchors, two classes: anchor 0 and 1 overlap (same class 0), anchor 2 overlaps
        // anchor 0 but is class 1.
        let n = 3;
        let xc = [100.0f32, 102.0, 100.0];
        let yc = [100.0f32, 100.0, 100.0];
        let w = [50.0f32, 50.0, 50.0];
        let h = [50.0f32, 50.0, 50.0];
        let c0 = [0.9f32, 0.8, 0.1];
        let c1 = [0.0f32, 0.0, 0.7];
        let data: Vec<f32> = [xc, yc, w, h, c0, c1].concat();
        let kept = nms_decode(&data, 2, n, 0.25, 0.5, 300);
        let got: Vec<(f32, u32)> = kept.iter().map(|c| (c.score, c.class)).collect();
        assert_eq!(got, vec![(0.9, 0), (0.7, 1)]);
        let kept = nms_decode(&data, 2, n, 0.25, 0.5, 1);
        assert_eq!(kept.len(), 1);
        let kept = nms_decode(&data, 2, n, 0.95, 0.5, 300);
        assert!(kept.is_empty());
    }
}
