//! Training through Ultralytics (the tool the field uses), driven by soig: on a dataset the
//! pipeline wrote, `python/train.py` (embedded in the binary)
//! trains offline with the campaign's hyperparameters and exports ONNX, and the run is recorded
//! in the manifest: the model's sha256, the Ultralytics and torch versions, the log.
//!
//! Training runs whole, or in chunks (`soig train --budget 9m`, then `--resume`): each chunk
//! ends at an epoch boundary before its budget, so that a schedule longer than one command may
//! run (the lent GPU machine's 10 minutes) still runs as one schedule; the record lists every
//! chunk.
//!
//! The Python side is installed by `scripts/setup-train.sh` into `.venv-train/`.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, bail};

use crate::hash::sha256_file;
use crate::manifest;
use crate::progress::Progress;
use crate::store::fs;
use crate::verbs::plan::{Plan, TrainPlan};

/// The training driver, shipped inside the binary so a run records exactly what trained it.
pub const TRAIN_PY: &str = include_str!("../../python/train.py");

/// Where a run's training outputs go, inside the output directory.
pub const TRAIN_DIR: &str = "train";

/// The Python interpreter with Ultralytics: `--python`, else `$SOIG_TRAIN_PYTHON`, else
/// `.venv-train` in the current directory or beside the executable's repository.
pub fn find_python(explicit: Option<&Path>) -> anyhow::Result<PathBuf> {
    // An interpreter named by the user is the only one tried: falling back would train with
    // another environment than the one asked for.
    let named = explicit
        .map(Path::to_path_buf)
        .or_else(|| std::env::var_os("SOIG_TRAIN_PYTHON").map(PathBuf::from));
    let candidates: Vec<PathBuf> = match named {
        Some(p) => vec![p],
        None => vec![
            PathBuf::from(".venv-train/bin/python3"),
            Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv-train/bin/python3"),
        ],
    };
    for c in &candidates {
        if crate::python::succeeds(c, "import ultralytics") {
            return Ok(c.clone());
        }
    }
    bail!(
        "no Python with Ultralytics found (tried {}): run `bash scripts/setup-train.sh`, or pass --python",
        candidates
            .iter()
            .map(|c| c.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// How much of the schedule one `soig train` runs: all of it, or a chunk that ends before
/// `budget_s`; `resume` continues the schedule a previous chunk left.
#[derive(Clone, Copy, Debug, Default)]
pub struct Chunk {
    pub budget_s: Option<f64>,
    /// At most this many epochs in the chunk.
    pub epochs: Option<u32>,
    pub resume: bool,
}

/// A duration such as `9m`, `540s`, `540` (seconds) or `1.5h`, in seconds.
pub fn parse_budget(text: &str) -> anyhow::Result<f64> {
    let t = text.trim();
    let (number, unit) = match t.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => (&t[..i], c),
        _ => (t, 's'),
    };
    let scale = match unit {
        's' => 1.0,
        'm' => 60.0,
        'h' => 3600.0,
        _ => bail!("--budget {text:?}: the unit must be s, m or h"),
    };
    match number.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v * scale),
        _ => bail!("--budget {text:?}: expected a positive duration such as 9m, 540s or 1.5h"),
    }
}

/// A model trained in an output directory (none while chunks of its schedule are left), and
/// the record that goes into its manifest.
pub struct Trained {
    pub model: Option<PathBuf>,
    pub record: serde_json::Value,
}

/// Training outputs whose bytes depend on the machine (weights, plots, logs: GPU training is
/// not bit-reproducible) and the label caches Ultralytics leaves beside the labels: listed as
/// volatile in the manifest. The model and the script are hashed.
pub fn volatile_files(out: &Path) -> anyhow::Result<Vec<String>> {
    Ok(manifest::list_files(out)?
        .into_iter()
        .filter(|f| {
            (f.starts_with("train/") && f != "train/model.onnx" && f != "train/train.py")
                || (f.starts_with("labels/") && f.ends_with(".cache"))
        })
        .collect())
}

/// Train on the dataset already in `out` (its `data.yaml`), the whole schedule or one chunk of
/// it; once the schedule is done, export ONNX to `out/train/model.onnx` and check that the
/// detector loads it.
pub fn fit(
    plan: &Plan,
    out: &Path,
    python: &Path,
    chunk: Chunk,
    progress: &dyn Progress,
) -> anyhow::Result<Trained> {
    let data = out.join("data.yaml");
    if !data.is_file() {
        bail!(
            "{} has no data.yaml: the campaign's stages must include `dataset`",
            out.display()
        );
    }
    // Checked before the last training is removed.
    let (model_arg, start_weights) = start_weights(&plan.train)?;
    let tdir = out.join(TRAIN_DIR);
    let chunk_no = if chunk.resume {
        resumable_chunks(&tdir)? + 1
    } else {
        if tdir.exists() {
            fs::remove_dir_all(&tdir)?;
        }
        1
    };
    fs::create_dir_all(&tdir)?;
    let script = tdir.join("train.py");
    // A resumed chunk runs the script the schedule started with, in case this binary differs.
    if !chunk.resume {
        fs::write(&script, TRAIN_PY)?;
    } else if std::fs::read_to_string(&script)? != TRAIN_PY {
        bail!(
            "{} is not this soig's train.py: resume with the soig that started the schedule",
            script.display()
        );
    }
    let args = script_args(&script, &data, &tdir, model_arg, &plan.train, chunk);
    // One log per chunk: the first keeps the name whole runs always had.
    let log_name = if chunk_no == 1 {
        "train.log".to_string()
    } else {
        format!("train-chunk-{chunk_no}.log")
    };
    let log_path = tdir.join(&log_name);
    run_logged(python, &args, &log_path, progress)?;
    let summary_path = tdir.join("run/summary.json");
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(&summary_path)
            .with_context(|| format!("reading {}", summary_path.display()))?,
    )?;
    let chunks = chunk_records(&summary, &tdir, chunk_no, &log_name)?;
    if summary["finished"] == false {
        return Ok(Trained {
            model: None,
            record: serde_json::json!({
                "finished": false,
                "epochs_completed": summary["epochs_completed"],
                "epochs_planned": summary["epochs_planned_final"],
                "chunks": chunks,
                "resume_checkpoint": "train/run/train/weights/resume.pt",
                "ultralytics": summary["ultralytics"],
                "torch": summary["torch"],
                "summary": "train/run/summary.json",
                "start_weights": start_weights,
            }),
        });
    }
    let onnx = summary["onnx"]["path"]
        .as_str()
        .map(PathBuf::from)
        .ok_or_else(|| anyhow::anyhow!("{} names no ONNX model", summary_path.display()))?;
    let model = tdir.join("model.onnx");
    fs::copy(&onnx, &model)?;
    // The model is checked by loading it the way the detect stage will.
    crate::detect::yolo::YoloDetector::load(&model, Default::default())
        .with_context(|| format!("the exported model {} does not load", model.display()))?;

    Ok(Trained {
        record: serde_json::json!({
            "finished": true,
            "epochs_completed": summary["epochs_completed"],
            "chunks": chunks,
            "model": "train/model.onnx",
            "model_sha256": sha256_file(&model)?.0,
            "ultralytics": summary["ultralytics"],
            "torch": summary["torch"],
            "metrics": summary["metrics"],
            "log": "train/train.log",
            "summary": "train/run/summary.json",
            "start_weights": start_weights,
        }),
        model: Some(model),
    })
}

/// The `--model` argument and, for starting weights (a .pt beside the campaign, hashed into the
/// record), their path and sha256; a model YAML names an architecture that Ultralytics builds
/// from scratch.
fn start_weights(train: &TrainPlan) -> anyhow::Result<(String, Option<serde_json::Value>)> {
    let t = &train.settings;
    Ok(if let Some(pt) = &train.weights {
        if !pt.is_file() {
            bail!(
                "train.model: starting weights {} not found (relative to the campaign file)",
                pt.display()
            );
        }
        let sha = sha256_file(pt)?.0;
        (
            pt.display().to_string(),
            Some(serde_json::json!({"path": t.model, "sha256": sha})),
        )
    } else {
        (t.model.clone(), None)
    })
}

/// The training script's command line: the campaign's `[train]` settings and the chunk's.
fn script_args(
    script: &Path,
    data: &Path,
    tdir: &Path,
    model_arg: String,
    train: &TrainPlan,
    chunk: Chunk,
) -> Vec<String> {
    let t = &train.settings;
    let (imgsz, batch) = (train.imgsz, train.batch);
    let mut args: Vec<String> = vec![
        script.display().to_string(),
        "--data".into(),
        data.display().to_string(),
        "--out".into(),
        tdir.join("run").display().to_string(),
        "--model".into(),
        model_arg,
        "--epochs".into(),
        t.epochs.to_string(),
        "--batch".into(),
        batch.to_string(),
        "--imgsz".into(),
        imgsz.to_string(),
        "--optimizer".into(),
        t.optimizer.clone(),
        "--device".into(),
        t.device.clone(),
        "--seed".into(),
        t.seed.to_string(),
        "--workers".into(),
        t.workers.to_string(),
        "--patience".into(),
        t.patience.to_string(),
    ];
    if let Some(h) = t.time_hours {
        args.extend(["--time-hours".into(), h.to_string()]);
    }
    if let Some(cache) = t.cache {
        args.extend(["--cache".into(), cache.as_str().into()]);
    }
    // Only when set, so that the command line of a campaign without them is what it was.
    if t.amp == Some(true) {
        args.push("--amp".into());
    }
    if t.val == Some(false) {
        args.push("--no-val".into());
    }
    if let Some(c) = t.channels {
        args.extend(["--channels".into(), c.to_string()]);
    }
    if let Some(b) = chunk.budget_s {
        args.extend(["--budget-s".into(), b.to_string()]);
    }
    if let Some(n) = chunk.epochs {
        args.extend(["--chunk-epochs".into(), n.to_string()]);
    }
    if chunk.resume {
        args.push("--resume".into());
    }
    args
}

/// Run the training script with its output in `log_path`; a failure says the log's last lines.
fn run_logged(
    python: &Path,
    args: &[String],
    log_path: &Path,
    progress: &dyn Progress,
) -> anyhow::Result<()> {
    let log = fs::create_log(log_path)?;
    progress.note(&format!(
        "soig train: {} {} (log: {})",
        python.display(),
        args.join(" "),
        log_path.display()
    ));
    let status = Command::new(python)
        .args(args)
        .stdout(log.try_clone()?)
        .stderr(log)
        .status()
        .with_context(|| format!("running {}", python.display()))?;
    if !status.success() {
        let text = std::fs::read_to_string(log_path).unwrap_or_default();
        let tail: Vec<&str> = text.lines().rev().take(15).collect();
        bail!(
            "training failed ({status}); last lines of {}:\n{}",
            log_path.display(),
            tail.into_iter().rev().collect::<Vec<_>>().join("\n")
        );
    }
    Ok(())
}

/// How many chunks of the schedule in `tdir` have run, checking that one can follow.
fn resumable_chunks(tdir: &Path) -> anyhow::Result<usize> {
    let summary_path = tdir.join("run/summary.json");
    let summary: serde_json::Value = match std::fs::read_to_string(&summary_path) {
        Ok(text) => serde_json::from_str(&text)?,
        Err(_) => bail!(
            "--resume: {} holds no training to resume (no {}); run without --resume first",
            tdir.display(),
            summary_path.display()
        ),
    };
    if summary["finished"] != false {
        bail!(
            "--resume: the training in {} is finished; nothing to resume",
            tdir.display()
        );
    }
    Ok(summary["chunks"].as_array().map_or(0, Vec::len))
}

/// The record of every chunk so far: train.py's (epochs, seconds per epoch, wall time), with
/// this chunk's log and the checkpoints it left, and their sizes.
fn chunk_records(
    summary: &serde_json::Value,
    tdir: &Path,
    chunk_no: usize,
    log_name: &str,
) -> anyhow::Result<serde_json::Value> {
    let mut chunks = summary["chunks"].as_array().cloned().unwrap_or_default();
    let previous: Vec<serde_json::Value> = if chunk_no > 1 {
        let m = manifest::Manifest::read(tdir.parent().unwrap_or(tdir))?;
        m.training
            .and_then(|t| t["chunks"].as_array().cloned())
            .unwrap_or_default()
    } else {
        Vec::new()
    };
    let weights = tdir.join("run/train/weights");
    let mut files = vec![serde_json::json!({"path": format!("train/{log_name}")})];
    for f in manifest::list_files(&weights).unwrap_or_default() {
        let bytes = std::fs::metadata(weights.join(&f))?.len();
        files.push(
            serde_json::json!({"path": format!("train/run/train/weights/{f}"), "bytes": bytes}),
        );
    }
    for (i, c) in chunks.iter_mut().enumerate() {
        // Earlier chunks keep what the manifest recorded of them; this one gets its files.
        if let Some(prev) = previous.get(i) {
            *c = prev.clone();
        } else if i + 1 == chunk_no {
            c["files"] = serde_json::Value::Array(files.clone());
        }
    }
    Ok(serde_json::Value::Array(chunks))
}

#[cfg(test)]
mod tests {
    use super::parse_budget;

    #[test]
    fn budgets_read_in_seconds_minutes_and_hours() {
        assert_eq!(parse_budget("9m").unwrap(), 540.0);
        assert_eq!(parse_budget("540s").unwrap(), 540.0);
        assert_eq!(parse_budget("540").unwrap(), 540.0);
        assert_eq!(parse_budget("1.5h").unwrap(), 5400.0);
        for bad in ["", "m", "-3m", "0s", "9d", "nan"] {
            assert!(parse_budget(bad).is_err(), "{bad:?}");
        }
    }
}
