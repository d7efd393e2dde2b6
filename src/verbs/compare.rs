//! `soig compare BASELINE RUN`: what differs between two runs, or a run and a pinned
//! `results/` row (digest.txt, report.json, metrics.csv: no images), in the order a CI user
//! needs it: tampering, campaign hash and soig version, the artifacts added, removed and changed
//! (pixels for images, moved boxes for labels), then each metric's change per detector against
//! its tolerance. Identical digests of untampered outputs are "identical"; otherwise the verdict
//! is the metrics' (outputs without metrics can only be identical).

mod artifacts;
mod tolerance;

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use serde::Serialize;

use crate::manifest::{self, MANIFEST, Manifest};
use crate::report::{DetectorMetrics, Report};

pub use artifacts::{Artifacts, Change, Detail};
pub use tolerance::{Metric, Tolerances};

/// How many entries of each list the text form shows (the JSON form has them all).
const SHOWN: usize = 10;

/// One side of the comparison.
struct Side {
    dir: PathBuf,
    digest: String,
    campaign_hash: String,
    /// Not recorded in a `results/` row.
    version: Option<String>,
    /// Only a run folder has one (a `results/` row holds no artifacts).
    manifest: Option<Manifest>,
    /// What `soig verify` finds wrong with a run folder.
    tampered: Vec<String>,
    report: Option<Report>,
}

impl Side {
    fn load(dir: &Path, role: &str) -> anyhow::Result<Side> {
        if !dir.is_dir() {
            bail!("{role} {}: no such folder", dir.display());
        }
        if dir.join(MANIFEST).is_file() {
            let (m, problems) = manifest::verify(dir)?;
            let report = dir.join("report/report.json");
            let report = std::fs::symlink_metadata(&report)
                .is_ok()
                .then(|| Report::read(&report))
                .transpose()?;
            return Ok(Side {
                dir: dir.to_path_buf(),
                digest: m.digest.clone(),
                campaign_hash: m.campaign_hash.clone(),
                version: Some(m.version.clone()),
                tampered: problems.iter().map(|p| p.to_string()).collect(),
                manifest: Some(m),
                report,
            });
        }
        let (digest, report) = (dir.join("digest.txt"), dir.join("report.json"));
        if !(digest.is_file() && report.is_file()) {
            bail!(
                "{role} {} is not a soig output: no {MANIFEST} (a run folder), nor digest.txt and report.json (a results/ row)",
                dir.display()
            );
        }
        let report = Report::read(&report)?;
        Ok(Side {
            dir: dir.to_path_buf(),
            digest: std::fs::read_to_string(&digest)
                .with_context(|| format!("reading {}", digest.display()))?
                .trim()
                .to_string(),
            campaign_hash: report.campaign_hash.clone(),
            version: None,
            manifest: None,
            tampered: Vec::new(),
            report: Some(report),
        })
    }

    fn facts(&self) -> SideFacts {
        SideFacts {
            dir: self.dir.display().to_string(),
            kind: if self.manifest.is_some() {
                "run"
            } else {
                "results row"
            },
            digest: self.digest.clone(),
            campaign_hash: self.campaign_hash.clone(),
            version: self.version.clone(),
            test_images: self.report.as_ref().map(|r| r.images),
            test_objects: self.report.as_ref().map(|r| r.objects),
        }
    }
}

/// What is known of one side.
#[derive(Serialize)]
pub struct SideFacts {
    pub dir: String,
    pub kind: &'static str,
    pub digest: String,
    pub campaign_hash: String,
    pub version: Option<String>,
    pub test_images: Option<usize>,
    pub test_objects: Option<usize>,
}

/// One metric of one detector on both sides.
#[derive(Serialize)]
pub struct MetricChange {
    pub detector: String,
    pub metric: &'static str,
    pub baseline: Option<f64>,
    pub run: Option<f64>,
    /// run - baseline.
    pub change: Option<f64>,
    pub tolerance: f64,
    pub verdict: MetricVerdict,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MetricVerdict {
    /// Within the tolerance either way.
    Within,
    /// Fell by more than the tolerance.
    Regression,
    /// Rose by more than the tolerance: not a failure, but the baseline is out of date.
    Improved,
    /// The detector is in the baseline only.
    Missing,
    /// The detector is in the run only.
    New,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    Identical,
    WithinTolerance,
    Regression,
}

/// Everything `soig compare` found.
#[derive(Serialize)]
pub struct Comparison {
    pub verdict: Verdict,
    /// Why the verdict is not `identical`, one line each.
    pub reasons: Vec<String>,
    pub baseline: SideFacts,
    pub run: SideFacts,
    /// Files whose bytes no longer match their own manifest, per side.
    pub tampered: Vec<String>,
    /// Absent when a side is a `results/` row (it holds no artifacts).
    pub artifacts: Option<Artifacts>,
    pub metrics: Vec<MetricChange>,
}

impl Comparison {
    /// 0 identical or within tolerance, 1 a regression.
    pub fn exit_code(&self) -> u8 {
        match self.verdict {
            Verdict::Identical | Verdict::WithinTolerance => 0,
            Verdict::Regression => 1,
        }
    }
}

/// Compare `run` with `baseline`; an error (exit 2) when either is missing or not a soig output.
pub fn compare(baseline: &Path, run: &Path, tolerances: &Tolerances) -> anyhow::Result<Comparison> {
    let b = Side::load(baseline, "BASELINE")?;
    let r = Side::load(run, "RUN")?;
    let tampered: Vec<String> = [("BASELINE", &b), ("RUN", &r)]
        .iter()
        .flat_map(|(role, s)| s.tampered.iter().map(move |p| format!("{role}: {p}")))
        .collect();
    let same = b.digest == r.digest && tampered.is_empty();
    let artifacts = match (&b.manifest, &r.manifest) {
        (Some(mb), Some(mr)) if !same => Some(artifacts::diff(&b.dir, mb, &r.dir, mr)?),
        _ => None,
    };
    let metrics = match (&b.report, &r.report) {
        (Some(rb), Some(rr)) => metric_changes(&rb.detectors, &rr.detectors, tolerances),
        _ => Vec::new(),
    };

    let mut reasons = Vec::new();
    if !tampered.is_empty() {
        reasons.push(format!(
            "{} file(s) do not match their manifest (tampered or damaged)",
            tampered.len()
        ));
    }
    if b.campaign_hash != r.campaign_hash {
        reasons.push(format!(
            "different campaigns (campaign hash {} against {}): their metrics measure different things",
            b.campaign_hash, r.campaign_hash
        ));
    }
    let images = |files: &[String]| {
        files
            .iter()
            .filter(|f| f.starts_with("truth/img_") && f.ends_with(".json"))
            .count()
    };
    if let Some(a) = &artifacts {
        let (only_b, only_r) = (images(&a.removed), images(&a.added));
        if only_b + only_r > 0 {
            reasons.push(format!(
                "different image sets: {only_b} image(s) only in the baseline, {only_r} only in the run"
            ));
        }
    }
    if let (Some(rb), Some(rr)) = (&b.report, &r.report)
        && (rb.images, rb.objects) != (rr.images, rr.objects)
    {
        reasons.push(format!(
            "different test sets: {} images and {} objects in the baseline, {} and {} in the run",
            rb.images, rb.objects, rr.images, rr.objects
        ));
    }
    if !same && metrics.is_empty() {
        reasons.push(
            "the outputs differ and they have no metrics to hold within a tolerance (no detect stage on one side)"
                .into(),
        );
    }
    for m in &metrics {
        match m.verdict {
            MetricVerdict::Regression => reasons.push(format!(
                "{} {} fell by {:.4} (tolerance {})",
                m.detector,
                m.metric,
                -m.change.unwrap_or_default(),
                m.tolerance
            )),
            MetricVerdict::Missing => reasons.push(format!(
                "detector {} is in the baseline but not in the run",
                m.detector
            )),
            _ => {}
        }
    }
    reasons.dedup();
    let verdict = if same {
        Verdict::Identical
    } else if reasons.is_empty() {
        Verdict::WithinTolerance
    } else {
        Verdict::Regression
    };
    Ok(Comparison {
        verdict,
        reasons,
        baseline: b.facts(),
        run: r.facts(),
        tampered,
        artifacts,
        metrics,
    })
}

/// Every metric of every detector of either side.
fn metric_changes(
    baseline: &[DetectorMetrics],
    run: &[DetectorMetrics],
    tolerances: &Tolerances,
) -> Vec<MetricChange> {
    let mut names: Vec<&str> = baseline.iter().map(|d| d.detector.as_str()).collect();
    names.extend(
        run.iter()
            .map(|d| d.detector.as_str())
            .filter(|n| !baseline.iter().any(|d| d.detector == *n)),
    );
    let mut out = Vec::new();
    for name in names {
        let (db, dr) = (
            baseline.iter().find(|d| d.detector == name),
            run.iter().find(|d| d.detector == name),
        );
        for metric in Metric::ALL {
            let (vb, vr) = (db.map(|d| metric.of(d)), dr.map(|d| metric.of(d)));
            let tolerance = tolerances.of(metric);
            let change = vb.zip(vr).map(|(b, r)| r - b);
            let verdict = match change {
                None if vr.is_none() => MetricVerdict::Missing,
                None => MetricVerdict::New,
                Some(c) if c < -tolerance => MetricVerdict::Regression,
                Some(c) if c > tolerance => MetricVerdict::Improved,
                Some(_) => MetricVerdict::Within,
            };
            out.push(MetricChange {
                detector: name.to_string(),
                metric: metric.name(),
                baseline: vb,
                run: vr,
                change,
                tolerance,
                verdict,
            });
        }
    }
    out
}

/// The text a person reads, in the order a CI user needs it; the verdict last.
pub fn text(c: &Comparison) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "baseline {} ({})\nrun      {} ({})",
        c.baseline.dir, c.baseline.kind, c.run.dir, c.run.kind
    );
    if !c.tampered.is_empty() {
        let _ = writeln!(s, "tampered ({}):", c.tampered.len());
        list(&mut s, &c.tampered);
    }
    if c.verdict == Verdict::Identical {
        let _ = writeln!(s, "identical: digest {}", c.run.digest);
        return s;
    }
    let same_or = |a: &str, b: &str| {
        if a == b {
            format!("same ({a})")
        } else {
            format!("differs: {a} -> {b}")
        }
    };
    let _ = writeln!(
        s,
        "campaign hash: {}",
        same_or(&c.baseline.campaign_hash, &c.run.campaign_hash)
    );
    let version = match (&c.baseline.version, &c.run.version) {
        (None, None) => "not recorded (results/ rows)".to_string(),
        (b, r) => {
            let or_unknown = |v: &Option<String>| v.clone().unwrap_or("not recorded".into());
            same_or(&or_unknown(b), &or_unknown(r))
        }
    };
    let _ = writeln!(s, "soig version: {version}");
    let _ = writeln!(s, "digest: {}", same_or(&c.baseline.digest, &c.run.digest));
    match &c.artifacts {
        None => {
            let _ = writeln!(
                s,
                "artifacts: not compared (a results/ row holds no artifacts)"
            );
        }
        Some(a) => artifacts::text(&mut s, a),
    }
    if let (Some(b), Some(r)) = (c.baseline.test_images, c.run.test_images)
        && (b != r || c.baseline.test_objects != c.run.test_objects)
    {
        let _ = writeln!(
            s,
            "test set: {b} images, {} objects -> {r} images, {} objects",
            c.baseline.test_objects.unwrap_or_default(),
            c.run.test_objects.unwrap_or_default()
        );
    }
    if !c.metrics.is_empty() {
        let _ = writeln!(
            s,
            "metrics:\n  {:<10} {:<18} {:>9} {:>9} {:>9} {:>9}  verdict",
            "detector", "metric", "baseline", "run", "change", "tolerance"
        );
        let num = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.4}"));
        for m in &c.metrics {
            let _ = writeln!(
                s,
                "  {:<10} {:<18} {:>9} {:>9} {:>9} {:>9}  {}",
                m.detector,
                m.metric,
                num(m.baseline),
                num(m.run),
                m.change.map_or("-".to_string(), |v| format!("{v:+.4}")),
                m.tolerance,
                match m.verdict {
                    MetricVerdict::Within => "ok",
                    MetricVerdict::Regression => "REGRESSION",
                    MetricVerdict::Improved => "improved (update the baseline)",
                    MetricVerdict::Missing => "MISSING in the run",
                    MetricVerdict::New => "new in the run",
                }
            );
        }
    }
    match c.verdict {
        Verdict::Identical => {}
        Verdict::WithinTolerance => {
            let _ = writeln!(
                s,
                "within tolerance: the outputs differ, no metric regressed"
            );
        }
        Verdict::Regression => {
            let _ = writeln!(s, "REGRESSION:");
            list(&mut s, &c.reasons);
        }
    }
    s
}

/// At most `SHOWN` lines of `items`, indented, and how many more there are.
fn list(s: &mut String, items: &[String]) {
    use std::fmt::Write as _;
    for item in items.iter().take(SHOWN) {
        let _ = writeln!(s, "  {item}");
    }
    if items.len() > SHOWN {
        let _ = writeln!(
            s,
            "  ... and {} more (--json lists all)",
            items.len() - SHOWN
        );
    }
}
