//! Scores a user can reproduce (issue #43): a run's report.json holds the metrics `soig eval`
//! gives on the run's own label and prediction files, to 1e-9, in both conventions, for every
//! detector of a multi-object run (campaigns/quickstart-multi.toml, 40 images); and its
//! prediction files and detections.csv write scores at round-trip precision (on the main of
//! 2026-11-28 they had 6 decimals, which tied scores, and the streak detector's COCO AP was
//! 0.908 in report.json but 0.922 from its files).

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

mod common;

use std::path::Path;

use common::{arg, eval_json, ort_available, run_report};

/// `soig eval` of detector `name`'s predictions in `mode`, as JSON.
fn eval(out: &Path, name: &str, mode: &str) -> serde_json::Value {
    eval_json(
        &out.join("labels/test"),
        &out.join(format!("report/predictions/{name}")),
        &["--images", arg(&out.join("images/test")), "--mode", mode],
    )
}

#[test]
fn report_metrics_are_soig_eval_of_the_runs_own_files() {
    if !ort_available() {
        return;
    }
    let (_tmp, out, report) =
        run_report("campaigns/quickstart-multi.toml", &["--set", "images=40"]);
    let detectors = report["detectors"].as_array().unwrap();
    assert_eq!(detectors.len(), 2, "{report}");
    let close = |a: &serde_json::Value, b: &serde_json::Value, what: &str| {
        let (a, b) = (a.as_f64().unwrap(), b.as_f64().unwrap());
        assert!((a - b).abs() <= 1e-9, "{what}: report {a}, soig eval {b}");
    };
    for d in detectors {
        let name = d["detector"].as_str().unwrap();
        let u = eval(&out, name, "ultralytics");
        for key in ["precision", "recall", "map50", "map50_95"] {
            close(&d["ultralytics"][key], &u[key], &format!("{name} {key}"));
        }
        let c = eval(&out, name, "coco");
        for key in ["ap", "ap50", "ap75", "ar100"] {
            close(&d["coco"][key], &c[key], &format!("{name} coco {key}"));
        }
    }
    // Scores at round-trip precision: each prediction's score parses back to a number whose
    // shortest form is the one written (so no two scores tie by rounding).
    let mut scores = 0;
    for d in detectors {
        let dir = out
            .join("report/predictions")
            .join(d["detector"].as_str().unwrap());
        for e in std::fs::read_dir(dir).unwrap() {
            for line in std::fs::read_to_string(e.unwrap().path()).unwrap().lines() {
                let fields: Vec<&str> = line.split_whitespace().collect();
                for f in &fields[1..] {
                    let x: f64 = f.parse().unwrap();
                    assert_eq!(x.to_string(), *f, "{line}");
                }
                scores += 1;
            }
        }
    }
    assert!(scores > 0);
    let csv = std::fs::read_to_string(out.join("report/detections.csv")).unwrap();
    let longest = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(6).unwrap().len())
        .max()
        .unwrap();
    assert!(
        longest > 8,
        "scores in detections.csv at 6 decimals:\n{csv}"
    );
}
