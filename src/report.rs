//! The report of a campaign's detect stage: predictions in YOLO format, metrics in the shape of
//! the paper's Tables 3 and 5 (Ultralytics and COCO conventions side by side), per-image
//! detections, timing in the shape of Table 6, a precision-recall plot and previews of true
//! positives, false positives and misses (ground truth green, predictions red, as the paper's
//! Figs. 11 and 13), and each detector's efficiency against magnitude, SNR and streak length
//! (`efficiency`).
//!
//! Everything here is a pure function of the images and detections, except the timing, which is
//! written to `report/timing.json` and `report/report.md` only: the manifest lists those two as
//! volatile (present, not hashed), so the digest stays reproducible. The figures are drawn in
//! `figures`.

pub mod astrometry;
pub mod efficiency;
mod figures;
pub use efficiency::{Efficiency, HalfRecall, ObjectFacts};
pub(crate) use figures::draw_rect;

use std::fmt::Write as _;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::detect::Detection;
use crate::metrics::{self, AtThreshold, CocoMetrics, ImageEval, UltralyticsMetrics};
use crate::store::fs;

/// Files of the report that hold run-dependent timing: present, but not hashed.
pub const VOLATILE: [&str; 2] = ["report/timing.md", "report/timing.json"];

/// One test image: its PNG and ground truth in pixel-edge coordinates.
pub struct TestImage {
    pub stem: String,
    pub png: std::path::PathBuf,
    pub width: usize,
    pub height: usize,
    /// The label boxes as the image's label file reads (6 decimals of the frame), scaled to
    /// pixels: what `soig eval` scores against.
    pub truth: Vec<[f64; 4]>,
    /// Each labelled object's magnitude, SNR and length from the truth sidecar, in the order
    /// of `truth`.
    pub facts: Vec<ObjectFacts>,
}

/// The detections of one detector on every test image, and its time per image.
pub struct DetectorRun {
    pub name: String,
    pub description: String,
    pub model_sha256: Option<String>,
    /// Per test image, in the order of the test images.
    pub detections: Vec<Vec<Detection>>,
    pub seconds: Vec<f64>,
    /// Each detection's streak (ends, SNR) where the detector gives it (the streak detector),
    /// in the order of `detections`; None for a box-only detector (`observations`).
    pub lines: Option<Vec<Vec<crate::observations::Line>>>,
}

#[derive(Serialize, Deserialize)]
pub struct DetectorMetrics {
    pub detector: String,
    pub description: String,
    pub model_sha256: Option<String>,
    pub ultralytics: UltralyticsSummary,
    pub coco: CocoSummary,
    pub at_threshold: AtThresholdSummary,
}

#[derive(Serialize, Deserialize)]
pub struct UltralyticsSummary {
    pub precision: f64,
    pub recall: f64,
    pub map50: f64,
    pub map50_95: f64,
    pub f1_conf: f64,
}

#[derive(Serialize, Deserialize)]
pub struct CocoSummary {
    pub ap: f64,
    pub ap50: f64,
    pub ap75: f64,
    pub ar100: f64,
}

#[derive(Serialize, Deserialize)]
pub struct AtThresholdSummary {
    pub conf: f64,
    pub iou: f64,
    pub precision: f64,
    pub recall: f64,
    pub tp: usize,
    pub fp: usize,
    #[serde(rename = "fn")]
    pub fn_: usize,
}

/// The deterministic part of the report.
#[derive(Serialize, Deserialize)]
pub struct Report {
    pub campaign: String,
    pub campaign_hash: String,
    /// Digest of the dataset (the manifest of everything but the report).
    pub dataset_digest: String,
    /// e.g. "fixed, original frame, synthetic".
    pub test_set: String,
    pub images: usize,
    pub objects: usize,
    pub detectors: Vec<DetectorMetrics>,
}

impl Report {
    /// Read a `report.json` (of a run's `report/` or a pinned `results/` row).
    pub fn read(path: &Path) -> Result<Report, crate::Error> {
        let text =
            crate::hash::read_regular_to_string(path).map_err(|e| crate::Error::input(path, e))?;
        serde_json::from_str(&text)
            .map_err(|e| crate::Error::input(path, format!("not a soig report: {e}")))
    }
}

/// Median and spread (min, max) of timings.
#[derive(Serialize)]
pub struct Timing {
    pub median_s: f64,
    pub min_s: f64,
    pub max_s: f64,
    pub n: usize,
}

impl Timing {
    pub fn of(samples: &[f64]) -> Timing {
        let mut v: Vec<f64> = samples.to_vec();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let median = match n {
            0 => f64::NAN,
            _ if n % 2 == 1 => v[n / 2],
            _ => (v[n / 2 - 1] + v[n / 2]) / 2.0,
        };
        Timing {
            median_s: median,
            min_s: v.first().copied().unwrap_or(f64::NAN),
            max_s: v.last().copied().unwrap_or(f64::NAN),
            n,
        }
    }
}

/// What the report scores: each test image's truth (as its label file reads, see
/// `TestImage::truth`) and its detections as `soig eval` reads them back from the prediction
/// files, so report.json holds the figures `soig eval` gives on the run's own files.
fn evals(images: &[TestImage], run: &DetectorRun) -> Vec<ImageEval> {
    images
        .iter()
        .zip(&run.detections)
        .map(|(img, dets)| ImageEval {
            truth: img.truth.clone(),
            truth_class: vec![0; img.truth.len()],
            detections: dets
                .iter()
                .map(|d| as_written(d, img.width, img.height))
                .collect(),
        })
        .collect()
}

/// A detection as `soig eval` reads it from its prediction line: normalised, written, read and
/// scaled back to the image's pixels (as `ImageEval::scaled` scales it).
fn as_written(d: &Detection, width: usize, height: usize) -> Detection {
    let line = yolo_prediction_line(d, width, height);
    let read = metrics::parse_yolo(Path::new("(prediction line)"), &line, true)
        .expect("a prediction line soig writes reads back");
    let (class, b, score) = read[0];
    let (w, h) = (width as f64, height as f64);
    Detection {
        x1: b[0] * w,
        y1: b[1] * h,
        x2: b[2] * w,
        y2: b[3] * h,
        score,
        class,
    }
}

/// Metrics of one detector in both conventions and at the fixed threshold.
pub fn detector_metrics(
    images: &[TestImage],
    run: &DetectorRun,
    conf: f64,
) -> (
    DetectorMetrics,
    UltralyticsMetrics,
    CocoMetrics,
    AtThreshold,
) {
    let e = evals(images, run);
    let u = metrics::ultralytics(&e);
    let c = metrics::coco(&e);
    let t = metrics::at_threshold(&e, conf, 0.5);
    let m = DetectorMetrics {
        detector: run.name.clone(),
        description: run.description.clone(),
        model_sha256: run.model_sha256.clone(),
        ultralytics: UltralyticsSummary {
            precision: u.precision,
            recall: u.recall,
            map50: u.map50,
            map50_95: u.map50_95,
            f1_conf: u.f1_conf,
        },
        coco: CocoSummary {
            ap: c.ap,
            ap50: c.ap50,
            ap75: c.ap75,
            ar100: c.ar100,
        },
        at_threshold: AtThresholdSummary {
            conf,
            iou: 0.5,
            precision: t.precision,
            recall: t.recall,
            tp: t.tp,
            fp: t.fp,
            fn_: t.fn_,
        },
    };
    (m, u, c, t)
}

/// The YOLO prediction line of a detection: `cls xc yc w h score`, normalised, each number at
/// round-trip precision (the shortest text that reads back as the same f64: 6 decimals tied
/// scores, and `soig eval` of the files then disagreed with the report).
pub fn yolo_prediction_line(d: &Detection, width: usize, height: usize) -> String {
    let (w, h) = (width as f64, height as f64);
    format!(
        "{} {} {} {} {} {}\n",
        d.class,
        (d.x1 + d.x2) / 2.0 / w,
        (d.y1 + d.y2) / 2.0 / h,
        (d.x2 - d.x1) / w,
        (d.y2 - d.y1) / h,
        d.score
    )
}

/// Write the report under `dir/report/`.
#[allow(clippy::too_many_arguments)]
pub fn write(
    dir: &Path,
    campaign: &str,
    campaign_hash: &str,
    dataset_digest: &str,
    test_set: &str,
    images: &[TestImage],
    runs: &[DetectorRun],
    conf: f64,
    conversion_s: &[f64],
    progress: &dyn crate::progress::Progress,
) -> anyhow::Result<()> {
    let rdir = dir.join("report");
    fs::create_dir_all(&rdir.join("previews"))?;
    let mut detectors = Vec::new();
    let mut curves = Vec::new();
    let mut csv_rows = csv::Writer::from_writer(Vec::new());
    csv_rows.write_record([
        "image", "detector", "x1", "y1", "x2", "y2", "score", "class",
    ])?;
    progress.start("report", runs.len() as u64);
    for run in runs {
        let pdir = rdir.join("predictions").join(&run.name);
        fs::create_dir_all(&pdir)?;
        for (img, dets) in images.iter().zip(&run.detections) {
            let mut text = String::new();
            for d in dets {
                text.push_str(&yolo_prediction_line(d, img.width, img.height));
                csv_rows.write_record([
                    img.stem.clone(),
                    run.name.clone(),
                    format!("{:.3}", d.x1),
                    format!("{:.3}", d.y1),
                    format!("{:.3}", d.x2),
                    format!("{:.3}", d.y2),
                    d.score.to_string(),
                    d.class.to_string(),
                ])?;
            }
            fs::create(&pdir.join(format!("{}.txt", img.stem)), text)?;
        }
        let (m, u, _, _) = detector_metrics(images, run, conf);
        curves.push((
            run.name.clone(),
            u.px.clone(),
            u.pr_curve_map50.clone(),
            u.map50,
        ));
        figures::previews(&rdir.join("previews"), images, run, conf)?;
        detectors.push(m);
        progress.advance();
    }
    progress.finish();
    fs::create(
        &rdir.join("detections.csv"),
        csv_rows.into_inner().map_err(|e| e.into_error())?,
    )?;

    let facts: Vec<Vec<ObjectFacts>> = images.iter().map(|i| i.facts.clone()).collect();
    let efficiencies: Vec<Efficiency> = runs
        .iter()
        .map(|run| efficiency::efficiency(&run.name, &evals(images, run), &facts, conf))
        .collect();
    fs::create(
        &rdir.join("efficiency.json"),
        serde_json::to_string_pretty(&efficiencies)? + "\n",
    )?;
    efficiency::write_csv(&rdir.join("efficiency.csv"), &efficiencies)?;
    efficiency::plot(&rdir.join("efficiency.png"), &efficiencies)?;

    let report = Report {
        campaign: campaign.to_string(),
        campaign_hash: campaign_hash.to_string(),
        dataset_digest: dataset_digest.to_string(),
        test_set: test_set.to_string(),
        images: images.len(),
        objects: images.iter().map(|i| i.truth.len()).sum(),
        detectors,
    };
    fs::create(
        &rdir.join("report.json"),
        serde_json::to_string_pretty(&report)? + "\n",
    )?;

    // Tables 3 and 5: one row per test set (and geometry) and detector.
    let mut table = csv::Writer::from_writer(Vec::new());
    table.write_record([
        "test_set",
        "detector",
        "precision",
        "recall",
        "map50",
        "map50_95",
        "coco_ap",
        "coco_ap50",
        "precision_at_conf",
        "recall_at_conf",
    ])?;
    for d in &report.detectors {
        table.write_record([
            test_set.to_string(),
            d.detector.clone(),
            format!("{:.4}", d.ultralytics.precision),
            format!("{:.4}", d.ultralytics.recall),
            format!("{:.4}", d.ultralytics.map50),
            format!("{:.4}", d.ultralytics.map50_95),
            format!("{:.4}", d.coco.ap),
            format!("{:.4}", d.coco.ap50),
            format!("{:.4}", d.at_threshold.precision),
            format!("{:.4}", d.at_threshold.recall),
        ])?;
    }
    fs::create(
        &rdir.join("metrics.csv"),
        table.into_inner().map_err(|e| e.into_error())?,
    )?;
    figures::pr_plot(&rdir.join("pr_curve.png"), &curves)?;

    // Table 6: conversion and detection time per image (volatile).
    let conversion = Timing::of(conversion_s);
    let detection: Vec<(String, Timing)> = runs
        .iter()
        .map(|r| (r.name.clone(), Timing::of(&r.seconds)))
        .collect();
    fs::create(
        &rdir.join("timing.json"),
        serde_json::to_string_pretty(&serde_json::json!({
            "conversion_per_image": conversion,
            "detection_per_image": detection.iter().map(|(n, t)| (n.clone(), t)).collect::<std::collections::BTreeMap<_, _>>(),
        }))? + "\n",
    )?;
    fs::create(
        &rdir.join("report.md"),
        markdown(&report, &efficiencies, conf),
    )?;
    fs::create(
        &rdir.join("timing.md"),
        timing_markdown(&conversion, &detection),
    )?;
    Ok(())
}

/// The report: every figure in it a function of the output's hashed files, so it is hashed
/// too (the times, which are not, are in `timing.md`).
fn markdown(r: &Report, efficiencies: &[Efficiency], conf: f64) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# soig report: {}\n", r.campaign);
    let _ = writeln!(
        s,
        "Test set: {}, {} images, {} objects.",
        r.test_set, r.images, r.objects
    );
    let _ = writeln!(
        s,
        "Campaign hash `{}`, dataset digest `{}`.\n",
        r.campaign_hash, r.dataset_digest
    );
    let _ = writeln!(s, "## Metrics (the shape of the paper's Tables 3 and 5)\n");
    let _ = writeln!(
        s,
        "P and R are Ultralytics' (at its max-F1 confidence); mAP as Ultralytics (`ap_per_class`) and as pycocotools; P/R@{conf} at the campaign's confidence, IoU 0.5.\n"
    );
    let _ = writeln!(
        s,
        "| detector | P | R | mAP50 | mAP50-95 | COCO AP50 | COCO AP | P@{conf} | R@{conf} |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|");
    for d in &r.detectors {
        let _ = writeln!(
            s,
            "| {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
            d.detector,
            d.ultralytics.precision,
            d.ultralytics.recall,
            d.ultralytics.map50,
            d.ultralytics.map50_95,
            d.coco.ap50,
            d.coco.ap,
            d.at_threshold.precision,
            d.at_threshold.recall
        );
    }
    let _ = writeln!(s);
    for d in &r.detectors {
        let model = d
            .model_sha256
            .as_deref()
            .map(|h| format!(", model sha256 `{h}`"))
            .unwrap_or_default();
        let _ = writeln!(s, "- `{}`: {}{model}", d.detector, d.description);
    }
    efficiency_markdown(&mut s, efficiencies, conf);
    let _ = writeln!(
        s,
        "\nTime per image (the shape of Table 6) depends on the machine: it is in `timing.md`, outside the digest.\n\n![precision-recall](pr_curve.png)\n\nPreviews of true positives, false positives and misses are in `previews/` (ground truth green, predictions red)."
    );
    s
}

/// Table 6's shape: conversion and detection time per image on this machine, this run
/// (volatile: listed in the manifest, not hashed).
fn timing_markdown(conversion: &Timing, detection: &[(String, Timing)]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "## Time per image (the shape of Table 6; this machine, this run)\n"
    );
    let _ = writeln!(s, "| step | median | min | max | n |");
    let _ = writeln!(s, "|---|---|---|---|---|");
    let row = |s: &mut String, name: &str, t: &Timing| {
        let _ = writeln!(
            s,
            "| {name} | {:.1} ms | {:.1} ms | {:.1} ms | {} |",
            t.median_s * 1e3,
            t.min_s * 1e3,
            t.max_s * 1e3,
            t.n
        );
    };
    row(&mut s, "conversion (FITS to PNG)", conversion);
    for (name, t) in detection {
        row(&mut s, &format!("detection: {name}"), t);
    }
    s
}

/// The 50% magnitude of each detector and its recall per magnitude bin.
fn efficiency_markdown(s: &mut String, efficiencies: &[Efficiency], conf: f64) {
    let _ = writeln!(s, "\n## Detection efficiency\n");
    let _ = writeln!(
        s,
        "Recall of each detector at confidence {conf}, IoU 0.5, by the debris' magnitude (`efficiency.csv` also bins by matched-filter SNR, streak length, per-pixel SNR and, for survey images, angle to the star trails; `efficiency.png` plots all five).\n"
    );
    for e in efficiencies {
        let _ = writeln!(
            s,
            "- `{}`: magnitude of 50% recall: {}",
            e.detector, e.half_recall
        );
    }
    let Some(first) = efficiencies.first() else {
        return;
    };
    let magnitude = efficiency::Quantity::Magnitude;
    recall_table(s, efficiencies, magnitude, "magnitude", |b| {
        format!("{:.1}-{:.1}", b.lo, b.hi)
    });
    // Survey images: recall by the angle between the streak and the star trails.
    let angle = efficiency::Quantity::TrailAngleDeg;
    if !first.curves[&angle].is_empty() {
        recall_table(s, efficiencies, angle, "angle to the star trails", |b| {
            format!("{}-{} deg", b.lo, b.hi)
        });
    }
    let _ = writeln!(s, "\n![efficiency](efficiency.png)");
}

/// One Markdown table of recall by `quantity`: a row per bin (`label` names it), its object
/// count and each detector's recall.
fn recall_table(
    s: &mut String,
    efficiencies: &[efficiency::Efficiency],
    quantity: efficiency::Quantity,
    heading: &str,
    label: impl Fn(&efficiency::Bin) -> String,
) {
    let _ = write!(s, "\n| {heading} | objects |");
    for e in efficiencies {
        let _ = write!(s, " recall {} |", e.detector);
    }
    let _ = write!(s, "\n|---|---|");
    for _ in efficiencies {
        let _ = write!(s, "---|");
    }
    let _ = writeln!(s);
    for (k, b) in efficiencies[0].curves[&quantity].iter().enumerate() {
        let _ = write!(s, "| {} | {} |", label(b), b.objects);
        for e in efficiencies {
            let _ = write!(s, " {:.2} |", e.curves[&quantity][k].recall);
        }
        let _ = writeln!(s);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timing_median_and_spread() {
        let t = Timing::of(&[3.0, 1.0, 2.0, 10.0]);
        assert_eq!((t.median_s, t.min_s, t.max_s, t.n), (2.5, 1.0, 10.0, 4));
        assert!(Timing::of(&[]).median_s.is_nan());
    }

    #[test]
    fn prediction_line_round_trips_a_box() {
        let d = Detection {
            x1: 100.0,
            y1: 200.0,
            x2: 300.0,
            y2: 260.0,
            score: 0.75,
            class: 0,
        };
        assert_eq!(
            yolo_prediction_line(&d, 1000, 500),
            "0 0.2 0.46 0.2 0.12 0.75\n"
        );
        // Round-trip precision: two scores 6 decimals would tie stay apart, and the report
        // scores what the file holds.
        let a = Detection {
            score: 0.123_456_78,
            ..d
        };
        let b = Detection {
            score: 0.123_456_81,
            ..d
        };
        let (ra, rb) = (as_written(&a, 1000, 500), as_written(&b, 1000, 500));
        assert_eq!((ra.score, rb.score), (a.score, b.score));
        assert!((ra.x1 - a.x1).abs() < 1e-9 && (ra.y2 - a.y2).abs() < 1e-9);
    }
}
