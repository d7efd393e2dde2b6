//! Running an experiment: every point through `pipeline::run_with`, as `soig run` would, into
//! its own folder; a folder whose manifest already pins the point's campaign hash is reused
//! without rendering, so adding or removing a point leaves the others alone. A failing point
//! is recorded with its parameter values and the rest go on.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::file::{Experiment, Point, Setting};
use crate::hash::hash_json;
use crate::progress::Progress;
use crate::report::{Efficiency, HalfRecall, Report};
use crate::store::fs;

/// What one point gave.
#[derive(Debug, Serialize)]
pub struct Outcome {
    pub name: String,
    /// Its folder under `points/`.
    pub folder: String,
    pub group: String,
    pub settings: Vec<Setting>,
    pub replicate: u32,
    pub campaign_hash: String,
    /// The run's digest, or None when the point failed.
    pub digest: Option<String>,
    /// Why it failed.
    pub error: Option<String>,
    /// Whether an earlier run of the same campaign was reused.
    #[serde(skip)]
    pub reused: bool,
    /// Figure name (with `/detector` for a detector metric) to value.
    #[serde(skip)]
    pub figures: BTreeMap<String, f64>,
}

/// Run times of the points, kept beside them (they are volatile, so outside every manifest),
/// so a reused point still reports the time it took.
const TIMES: &str = "times.json";

#[derive(Default, Serialize, Deserialize)]
struct Times(BTreeMap<String, f64>);

/// Run every point of `experiment` under `out/points/`.
pub fn run_points(
    experiment: &Experiment,
    out: &Path,
    progress: &dyn Progress,
    force: bool,
) -> anyhow::Result<Vec<Outcome>> {
    let points_dir = out.join("points");
    fs::create_dir_all(&points_dir)?;
    let times_path = out.join(TIMES);
    let mut times: Times = std::fs::read_to_string(&times_path)
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or_default();
    let mut outcomes = Vec::new();
    for point in &experiment.points {
        let dir = points_dir.join(&point.folder);
        // The folder's values, readable beside it (its name is a hash of them).
        let values = serde_json::json!({
            "name": point.name,
            "settings": point.settings,
            "replicate": point.replicate,
        });
        fs::write(
            &points_dir.join(format!("{}.json", point.folder)),
            serde_json::to_string_pretty(&values)? + "\n",
        )?;
        let mut o = Outcome {
            name: point.name.clone(),
            folder: point.folder.clone(),
            group: point.group.clone(),
            settings: point.settings.clone(),
            replicate: point.replicate,
            campaign_hash: point.campaign.hash.clone(),
            digest: None,
            error: None,
            reused: false,
            figures: BTreeMap::new(),
        };
        match run_point(point, &dir, progress, force) {
            Ok((digest, reused, seconds)) => {
                if let Some(s) = seconds {
                    times.0.insert(point.name.clone(), s);
                }
                o.digest = Some(digest);
                o.reused = reused;
                if let Some(s) = times.0.get(&point.name) {
                    o.figures.insert("seconds".into(), *s);
                }
                if let Err(e) = read_report(&dir, &mut o.figures) {
                    o.error = Some(format!("{e:#}"));
                }
            }
            Err(e) => o.error = Some(format!("{e:#}")),
        }
        outcomes.push(o);
    }
    fs::write(&times_path, serde_json::to_string_pretty(&times)? + "\n")?;
    Ok(outcomes)
}

/// Run one point, or reuse its folder: (digest, reused, run seconds when it ran).
fn run_point(
    point: &Point,
    dir: &Path,
    progress: &dyn Progress,
    force: bool,
) -> anyhow::Result<(String, bool, Option<f64>)> {
    // Reused only if it verifies (an edited report must not reach summary.csv) and was made
    // from input files of the same content.
    if let Ok((m, problems)) = crate::manifest::verify(dir)
        && problems.is_empty()
        && m.campaign_hash == point.campaign.hash
        && m.shard.is_none()
        && point
            .campaign
            .input_hashes()
            .is_ok_and(|inputs| inputs == m.inputs)
    {
        return Ok((m.digest, true, None));
    }
    let options = crate::RunOptions {
        shard: None,
        fresh: false,
        force,
    };
    let s = crate::run_with(&point.campaign, dir, options, None, progress)?;
    Ok((s.digest, false, Some(s.seconds)))
}

/// The figures of a run's report (none when the run has no detect stage).
fn read_report(dir: &Path, figures: &mut BTreeMap<String, f64>) -> anyhow::Result<()> {
    let path = dir.join("report").join("report.json");
    if !path.is_file() {
        return Ok(());
    }
    let report = Report::read(&path)?;
    figures.insert("objects".into(), report.objects as f64);
    for d in &report.detectors {
        let u = &d.ultralytics;
        for (name, v) in [
            ("map50", u.map50),
            ("map50_95", u.map50_95),
            ("precision", u.precision),
            ("recall", u.recall),
            ("coco_ap", d.coco.ap),
        ] {
            figures.insert(format!("{name}/{}", d.detector), v);
        }
    }
    let path = dir.join("report").join("efficiency.json");
    if path.is_file() {
        let text = std::fs::read_to_string(&path)?;
        let all: Vec<Efficiency> =
            serde_json::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        for e in all {
            if let HalfRecall::At { magnitude } = e.half_recall {
                figures.insert(format!("mag50/{}", e.detector), magnitude);
            }
        }
    }
    Ok(())
}

/// The experiment's manifest: every point with its campaign hash and digest; the digest covers
/// them all (and the experiment file's settings), not the volatile run times.
#[derive(Serialize)]
pub struct ExperimentManifest<'a> {
    pub tool: &'static str,
    pub version: &'static str,
    pub experiment: &'a super::file::ExperimentFile,
    pub points: &'a [Outcome],
    pub digest: String,
}

impl<'a> ExperimentManifest<'a> {
    pub fn new(experiment: &'a Experiment, points: &'a [Outcome]) -> ExperimentManifest<'a> {
        let mut m = ExperimentManifest {
            tool: "soig",
            version: env!("CARGO_PKG_VERSION"),
            experiment: &experiment.file,
            points,
            digest: String::new(),
        };
        m.digest = hash_json(&m);
        m
    }
}
