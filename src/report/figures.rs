//! The report's figures: precision against recall for each detector, and previews of true
//! positives, false positives and misses (ground truth green, predictions red).

use std::path::Path;

use image::{Rgb, RgbImage};

use super::{DetectorRun, TestImage};
use crate::detect::Detection;
use crate::metrics;

/// Precision against recall at IoU 0.5 for each detector.
pub(super) fn pr_plot(
    path: &Path,
    curves: &[(String, Vec<f64>, Vec<f64>, f64)],
) -> anyhow::Result<()> {
    use plotters::prelude::*;
    crate::plot::png(path, (640, 480), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption("Precision-recall at IoU 0.5", ("sans-serif", 22))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..1.0, 0.0..1.05)?;
        chart
            .configure_mesh()
            .x_desc("recall")
            .y_desc("precision")
            .draw()?;
        let colors = &crate::plot::PALETTE[..3];
        for (k, (name, px, py, map50)) in curves.iter().enumerate() {
            let c = colors[k % colors.len()];
            chart
                .draw_series(LineSeries::new(
                    px.iter().copied().zip(py.iter().copied()),
                    c.stroke_width(2),
                ))?
                .label(format!("{name} (mAP50 {map50:.3})"))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
        }
        crate::plot::legend(&mut chart, SeriesLabelPosition::LowerLeft)
    })
}

/// Up to three previews each of true positives, false positives and misses of one detector at
/// the campaign's confidence: a crop around the boxes, ground truth green, predictions red.
pub(super) fn previews(
    dir: &Path,
    images: &[TestImage],
    run: &DetectorRun,
    conf: f64,
) -> anyhow::Result<()> {
    let (mut tp, mut fp, mut miss) = (0, 0, 0);
    for (img, dets) in images.iter().zip(&run.detections) {
        let kept: Vec<&Detection> = dets.iter().filter(|d| d.score >= conf).collect();
        let matched = |t: &[f64; 4]| {
            kept.iter()
                .any(|d| metrics::iou(t, &[d.x1, d.y1, d.x2, d.y2]) >= 0.5)
        };
        let true_pos = |d: &Detection| {
            img.truth
                .iter()
                .any(|t| metrics::iou(t, &[d.x1, d.y1, d.x2, d.y2]) >= 0.5)
        };
        let kind = if img.truth.iter().any(|t| !matched(t)) && miss < 3 {
            miss += 1;
            "miss"
        } else if kept.iter().any(|d| !true_pos(d)) && fp < 3 {
            fp += 1;
            "false-positive"
        } else if !kept.is_empty() && img.truth.iter().all(matched) && tp < 3 {
            tp += 1;
            "true-positive"
        } else {
            continue;
        };
        let gray = image::open(&img.png)?.to_luma8();
        let mut rgb = RgbImage::from_fn(gray.width(), gray.height(), |x, y| {
            let v = gray.get_pixel(x, y)[0];
            Rgb([v, v, v])
        });
        let boxes: Vec<([f64; 4], Rgb<u8>)> = img
            .truth
            .iter()
            .map(|t| (*t, Rgb([0, 220, 0])))
            .chain(
                kept.iter()
                    .map(|d| ([d.x1, d.y1, d.x2, d.y2], Rgb([230, 0, 0]))),
            )
            .collect();
        for (b, c) in &boxes {
            draw_rect(&mut rgb, b, *c);
        }
        // Crop to the boxes with a margin, at least 256 px.
        let (mut x0, mut y0, mut x1, mut y1) = (
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        );
        for (b, _) in &boxes {
            x0 = x0.min(b[0]);
            y0 = y0.min(b[1]);
            x1 = x1.max(b[2]);
            y1 = y1.max(b[3]);
        }
        let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
        let side = ((x1 - x0).max(y1 - y0) + 64.0).max(256.0);
        let (w, h) = (rgb.width() as f64, rgb.height() as f64);
        let left = (cx - side / 2.0).clamp(0.0, (w - side).max(0.0)) as u32;
        let top = (cy - side / 2.0).clamp(0.0, (h - side).max(0.0)) as u32;
        let s = side.min(w).min(h) as u32;
        let crop = image::imageops::crop_imm(&rgb, left, top, s, s).to_image();
        let path = dir.join(format!("{}_{kind}_{}.png", run.name, img.stem));
        crate::store::fs::create(&path, crate::plot::rgb_png(&crop)?)?;
    }
    Ok(())
}

/// A 2 px rectangle along the edges of a pixel-edge box `[x1, y1, x2, y2]`, clipped to the image.
pub(crate) fn draw_rect(img: &mut RgbImage, b: &[f64; 4], c: Rgb<u8>) {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let clamp = |v: f64, n: i64| (v.round() as i64).clamp(0, n - 1);
    let (x0, y0, x1, y1) = (
        clamp(b[0], w),
        clamp(b[1], h),
        clamp(b[2] - 1.0, w),
        clamp(b[3] - 1.0, h),
    );
    for t in 0..2 {
        for x in x0..=x1 {
            for y in [(y0 + t).min(h - 1), (y1 - t).max(0)] {
                img.put_pixel(x as u32, y as u32, c);
            }
        }
        for y in y0..=y1 {
            for x in [(x0 + t).min(w - 1), (x1 - t).max(0)] {
                img.put_pixel(x as u32, y as u32, c);
            }
        }
    }
}
