//! `soig experiment`: a declarative sweep over any campaign field. An experiment file
//! (`file`) names a base campaign, axes of values and seed replicates; every point is a
//! campaign (the base with `--set`-style overrides) run like `soig run` into its own folder
//! (`run`), and the points are tabulated and plotted against each axis (`summary`) under a
//! manifest whose digest covers every point's digest.

pub mod file;
pub mod run;
pub mod summary;

use std::path::{Path, PathBuf};

pub use file::{Experiment, ExperimentFile};

use crate::progress::Progress;
use crate::store::fs;

/// The result of `soig experiment`.
pub struct Finished {
    pub out: PathBuf,
    pub digest: String,
    pub points: usize,
    pub reused: usize,
    /// The failed points: name and why.
    pub failures: Vec<(String, String)>,
}

/// The manifest of an experiment, beside `summary.csv`.
pub const MANIFEST: &str = "experiment.json";

/// Run an experiment (already checked by `Experiment::load`) into `out`; one whose work the
/// estimate refuses (`Experiment::check_work`) runs only with `force`.
pub fn run(
    experiment: &Experiment,
    out: &Path,
    progress: &dyn Progress,
    force: bool,
) -> anyhow::Result<Finished> {
    if !force {
        experiment.check_work()?;
    }
    check_output(experiment, out)?;
    let made = fs::create_dirs(out)?;
    let outcomes = match run::run_points(experiment, out, progress, force) {
        Ok(o) => o,
        Err(e) => {
            // Nothing of a point is kept but what it finished (or can resume).
            fs::remove_empty_dirs(&made);
            return Err(e);
        }
    };
    let summary = summary::Summary::new(experiment, &outcomes);
    summary.write_csv(&out.join("summary.csv"))?;
    let plots = summary.plots(&out.join("plots"))?;
    let manifest = run::ExperimentManifest::new(experiment, &outcomes);
    let mut md = format!(
        "# Experiment {}\n\nBase campaign `{}`, {} point(s), {} seed replicate(s) each; mean ± sample standard deviation over the replicates.\n\n",
        experiment.source.display(),
        experiment.file.base,
        summary.rows.len(),
        experiment.file.seeds
    );
    md += &summary.markdown();
    let missing = summary::missing(experiment, &summary);
    if !missing.is_empty() {
        md += &format!(
            "\nCollected but produced by no point (no detect stage?): {}.\n",
            missing.join(", ")
        );
    }
    let failures: Vec<(String, String)> = outcomes
        .iter()
        .filter_map(|o| o.error.as_ref().map(|e| (o.name.clone(), e.clone())))
        .collect();
    for (name, e) in &failures {
        md += &format!("\nFailed point `{name}`: {e}\n");
    }
    for p in &plots {
        md += &format!("\n![{p}](plots/{p})\n");
    }
    md += &format!("\ndigest {}\n", manifest.digest);
    fs::write(&out.join("summary.md"), md)?;
    fs::write(
        &out.join(MANIFEST),
        serde_json::to_string_pretty(&manifest)? + "\n",
    )?;
    fs::write(&out.join("digest.txt"), format!("{}\n", manifest.digest))?;
    Ok(Finished {
        out: out.to_path_buf(),
        digest: manifest.digest.clone(),
        points: outcomes.len(),
        reused: outcomes.iter().filter(|o| o.reused).count(),
        failures,
    })
}

/// What `run` writes at the top of its output: anything else there is not soig's.
const WRITTEN: [&str; 7] = [
    "points",
    "plots",
    "summary.csv",
    "summary.md",
    MANIFEST,
    "digest.txt",
    "times.json",
];

/// Whether `name`, at the top of an experiment's output, is one of [`WRITTEN`] or the
/// temporary file of one that a killed run left (`fs::write` removes it when it writes the
/// file again).
fn written(name: &str) -> bool {
    WRITTEN
        .iter()
        .any(|w| name == *w || name.starts_with(&format!(".{w}.tmp-")))
}

/// Refuse an output that is `/`, the current directory, the experiment's folder or an ancestor,
/// lies inside a soig output, or exists and is not an experiment's output (its manifest, and
/// nothing at its top but what `run` writes): `run` rewrites its files in place.
fn check_output(experiment: &Experiment, out: &Path) -> anyhow::Result<()> {
    let folder = experiment.source.parent().unwrap_or(Path::new("."));
    crate::output::check_folder(out, &[folder, &experiment.source])?;
    let Ok(entries) = std::fs::read_dir(out) else {
        if out.exists() {
            anyhow::bail!(
                "{} exists and is not a folder; refusing to write into it",
                out.display()
            );
        }
        return Ok(());
    };
    let names: Vec<String> = entries
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    if names.is_empty() {
        return Ok(());
    }
    let ours = crate::hash::read_regular_to_string(&out.join(MANIFEST))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .is_some_and(|m| m["tool"] == "soig" && m["points"].is_array() && m["digest"].is_string());
    if !ours && !interrupted(experiment, out, &names) {
        anyhow::bail!(
            "{} exists and is not an experiment's output (no {MANIFEST} that soig wrote); refusing to write into it",
            out.display()
        );
    }
    if let Some(foreign) = names.iter().find(|n| !written(n)) {
        anyhow::bail!(
            "{} holds {foreign}, which soig experiment does not write; refusing to write into it (move it out, or choose another output)",
            out.display()
        );
    }
    Ok(())
}

/// Whether `out` is an experiment killed before it wrote its manifest: nothing at its top but
/// what `run` writes, and `points/` holding only soig outputs, the staging folders, locks
/// and set-aside outputs of the points' runs (which the rerun resumes or removes), and this
/// experiment's point value files (`FOLDER.json`) with the temporaries a kill left of them.
fn interrupted(experiment: &Experiment, out: &Path, names: &[String]) -> bool {
    let Ok(points) = std::fs::read_dir(out.join("points")) else {
        return false;
    };
    let points: Vec<std::fs::DirEntry> = points.flatten().collect();
    let values_file = |n: &str| {
        experiment.points.iter().any(|p| {
            let file = format!("{}.json", p.folder);
            n == file || n.starts_with(&format!(".{file}.tmp-"))
        })
    };
    let soigs = |e: &std::fs::DirEntry| {
        let n = e.file_name().to_string_lossy().into_owned();
        let is_dir = e.file_type().is_ok_and(|t| t.is_dir());
        let is_file = e.file_type().is_ok_and(|t| t.is_file());
        (is_file && values_file(&n))
            || (n.starts_with('.') && n.ends_with(".lock") && is_file)
            || (n.starts_with('.') && (n.contains(".partial-") || n.contains(".old-")) && is_dir)
            || (is_dir
                && crate::manifest::Manifest::read(&e.path()).is_ok_and(|m| m.tool == "soig"))
    };
    names.iter().all(|n| written(n)) && !points.is_empty() && points.iter().all(soigs)
}

/// The JSON Schema of the experiment file format, generated from the Rust types.
pub fn schema_json() -> String {
    let schema = schemars::schema_for!(ExperimentFile);
    serde_json::to_string_pretty(&schema).expect("schema serialises")
}
