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

/// Run an experiment (already checked by `Experiment::load`) into `out`.
pub fn run(
    experiment: &Experiment,
    out: &Path,
    progress: &dyn Progress,
) -> anyhow::Result<Finished> {
    std::fs::create_dir_all(out)?;
    let outcomes = run::run_points(experiment, out, progress)?;
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
    std::fs::write(out.join("summary.md"), md)?;
    std::fs::write(
        out.join(MANIFEST),
        serde_json::to_string_pretty(&manifest)? + "\n",
    )?;
    std::fs::write(out.join("digest.txt"), format!("{}\n", manifest.digest))?;
    Ok(Finished {
        out: out.to_path_buf(),
        digest: manifest.digest.clone(),
        points: outcomes.len(),
        reused: outcomes.iter().filter(|o| o.reused).count(),
        failures,
    })
}

/// The JSON Schema of the experiment file format, generated from the Rust types.
pub fn schema_json() -> String {
    let schema = schemars::schema_for!(ExperimentFile);
    serde_json::to_string_pretty(&schema).expect("schema serialises")
}
