//! The command line's grammar: every verb, its arguments and options, each described (`soig
//! VERB --help`). Nothing here runs anything; `commands` does.

use std::path::PathBuf;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "soig",
    version,
    about = "Space optical image generator: campaign file -> reproducible synthetic dataset of space debris images"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
    /// Run a campaign: render, enhance, split, and write the manifest. A run that was killed or
    /// interrupted is resumed by running the same command again: the images it finished are
    /// checked against their hashes and only the missing ones rendered (same digest).
    Run(RunArgs),
    /// Merge the shard outputs of one campaign (`soig run --shard`) into the output a single
    /// run would write, same digest: checks that they are one campaign and soig version, that
    /// each verifies, and that every shard 0..N is given once; then writes data.yaml, runs the
    /// train and detect stages and the report, and writes the manifest.
    Merge(MergeArgs),
    /// Write a Slurm job array that runs the campaign as N shards (`soig run --shard K/N`), a
    /// merge job that depends on it (afterok), and submit.sh, which submits the two.
    Slurm(SlurmArgs),
    /// Write a Kubernetes Indexed Job that runs the campaign as N shards (`soig run --shard
    /// auto/N`) on a shared volume, a merge Job, and submit.sh, which applies them in turn.
    K8s(K8sArgs),
    /// Train a YOLOv8 model on the campaign's dataset through Ultralytics, export ONNX, and
    /// record the run in the manifest (needs `scripts/setup-train.sh`).
    Train(TrainArgs),
    /// Recompute every hash of an output directory against its manifest.
    Verify(VerifyArgs),
    /// Measure what each rendering approximation (renderer, photon merging, trajectory
    /// samples, jitter steps) costs in accuracy and saves in time on one scene of the campaign:
    /// study.csv, study.md, study.png and a manifest.
    Study(StudyArgs),
    /// Compare a run with a baseline (a run folder or a pinned `results/` row): exit 0 when
    /// identical or every metric within tolerance, 1 on a regression, 2 on an error.
    Compare(CompareArgs),
    /// The paper's Tables 3, 5 and 6 from run folders or `results/` rows, beside the paper's
    /// figures: Markdown on stdout.
    Tables(TablesArgs),
    /// Run soig's detectors on real frames (FITS of any numeric type, PNG): detections.csv and
    /// .json (pixel boxes, streak ends, RA/Dec through the frame's WCS), YOLO-format
    /// predictions, previews and a manifest.
    Detect(DetectArgs),
    /// The paper's FITS -> PNG conversion (square root for fixed pointing, log stretch, CLAHE,
    /// gamma, 8-bit PNG) of any FITS, soig's or a real frame's sky region: OUT/<stem>.png per
    /// input, timing.json and a manifest. The original frame only: padding and rotation belong
    /// to `soig run`
    Enhance(EnhanceArgs),
    /// Print the JSON Schema of the campaign format (or, with --experiment, of the experiment
    /// file).
    Schema(SchemaArgs),
    /// Run an experiment: a sweep of campaign fields (an experiment file), one `soig run` per
    /// point into OUT/points/<hash of its values> (the values in <hash>.json beside it), reusing a point whose campaign is unchanged;
    /// writes summary.csv, summary.md, plots/ and experiment.json (the digest of every point).
    /// A malformed experiment is refused before anything runs; a failing point is reported and
    /// the others go on (exit 1 at the end).
    Experiment(ExperimentArgs),
    /// Export a finished output for other tools: the dataset and the detect stage's predictions
    /// as COCO JSON (OUT/coco/) and the truth and detections as DS9 region files over the FITS
    /// (OUT/ds9/), and with --tdm the truth's observations as a CCSDS TDM (OUT/tdm/); see
    /// src/product/export/. COCO and DS9 unless one is chosen.
    Export(ExportArgs),
    /// Score YOLO-format predictions (`cls xc yc w h score`) against YOLO labels, exactly as
    /// Ultralytics and pycocotools compute their metrics.
    Eval(EvalArgs),
}

/// `soig run`.
#[derive(clap::Args)]
pub struct RunArgs {
    /// The campaign TOML file.
    pub campaign: PathBuf,
    /// Output directory (default: the campaign's `output`, else `runs/<name>` beside it;
    /// with --shard, that with `-shard-K-of-N` appended).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Render only shard K of N (0 <= K < N): the contiguous block of images K*n/N ..
    /// (K+1)*n/N, into a shard output for `soig merge`. `auto` takes K and N from a Slurm
    /// job array (SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_COUNT); `auto/N` takes K from a
    /// Kubernetes Indexed Job (JOB_COMPLETION_INDEX) with N its completions.
    #[arg(long, value_name = "K/N|auto|auto/N")]
    pub shard: Option<String>,
    /// Do not resume: discard the work a killed run of this output left, and start afresh.
    #[arg(long)]
    pub fresh: bool,
    /// Run even what the work estimate refuses: an image estimated beyond 5 minutes of one
    /// core, or a run (shard) beyond 30 days (see src/config/work.rs).
    #[arg(long)]
    pub force: bool,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
    /// Python with Ultralytics, for a `train` stage (default: .venv-train/bin/python3).
    #[arg(long)]
    pub python: Option<PathBuf>,
    /// Override a campaign setting, after `extends`: `key.path=value`, the value a TOML
    /// value (`512`, `true`, `[8, 8]`) or else a string. Repeatable.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

/// `soig merge`.
#[derive(clap::Args)]
pub struct MergeArgs {
    /// The shard outputs, in any order.
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// Output directory of the merged run.
    #[arg(long)]
    pub out: PathBuf,
    /// Python with Ultralytics, for a `train` stage (default: .venv-train/bin/python3).
    #[arg(long)]
    pub python: Option<PathBuf>,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

/// `soig slurm`.
#[derive(clap::Args)]
pub struct SlurmArgs {
    #[command(flatten)]
    pub launch: LaunchArgs,
    /// The partition of every job (`#SBATCH --partition`).
    #[arg(long)]
    pub partition: Option<String>,
    /// The account charged for every job (`#SBATCH --account`).
    #[arg(long)]
    pub account: Option<String>,
    /// Wall-time limit of each job: MM, MM:SS, HH:MM:SS, D-HH, D-HH:MM or D-HH:MM:SS.
    #[arg(long, value_name = "TIME")]
    pub time: Option<String>,
    /// Memory of each job: megabytes, or with a unit suffix K, M, G or T (e.g. 4G).
    #[arg(long, value_name = "SIZE")]
    pub mem: Option<String>,
    /// CPUs of each task; soig then runs that many threads (SLURM_CPUS_PER_TASK).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub cpus_per_task: Option<u32>,
    /// Any other sbatch option, written as `#SBATCH ARG` in every job, e.g.
    /// `--sbatch=--qos=high`. Repeatable.
    #[arg(long, value_name = "ARG", allow_hyphen_values = true)]
    pub sbatch: Vec<String>,
}

/// `soig k8s`.
#[derive(clap::Args)]
pub struct K8sArgs {
    #[command(flatten)]
    pub launch: LaunchArgs,
    /// The container image holding `soig` on its PATH (the repository's Containerfile
    /// builds one: `podman build -t soig:latest .`).
    #[arg(long, default_value = "soig:latest")]
    pub image: String,
    /// The PersistentVolumeClaim mounted at /data in every pod, the pods' working directory:
    /// campaign and output paths are taken relative to it.
    #[arg(long, default_value = "soig-data")]
    pub claim: String,
    /// How long each Job may take, pods Pending included (e.g. 90m, 6h): Kubernetes fails it
    /// after that (activeDeadlineSeconds) and submit.sh gives up on it with its pods' state.
    #[arg(long, default_value = "24h")]
    pub deadline: String,
}

/// `soig train`.
#[derive(clap::Args)]
pub struct TrainArgs {
    /// The campaign TOML file (its `[train]` table sets epochs, batch and image size).
    pub campaign: PathBuf,
    /// Output directory (default: the campaign's `output`, else `runs/<name>` beside it).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Python interpreter with Ultralytics (default: .venv-train/bin/python3).
    #[arg(long)]
    pub python: Option<PathBuf>,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
    /// Override a campaign setting, after `extends`: `key.path=value`, the value a TOML
    /// value (`512`, `true`, `[8, 8]`) or else a string. Repeatable.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Train one chunk: stop at the last epoch boundary before this much time (`9m`,
    /// `540s`, `1.5h`), keeping what `--resume` needs to go on.
    #[arg(long, value_name = "DURATION")]
    pub budget: Option<String>,
    /// Train one chunk of at most this many epochs (with or without --budget).
    #[arg(long, value_name = "N")]
    pub chunk_epochs: Option<u32>,
    /// Continue the schedule a chunk left in the output (same epochs, learning rates, seed).
    #[arg(long)]
    pub resume: bool,
}

/// `soig verify`.
#[derive(clap::Args)]
pub struct VerifyArgs {
    /// An output directory of `soig run`.
    pub dir: PathBuf,
    /// The digest pinned for it (e.g. in CI): verify fails unless the recomputed digest is
    /// this one, so a manifest rewritten with consistent hashes is caught.
    #[arg(long, value_name = "HEX")]
    pub digest: Option<String>,
}

/// `soig study`.
#[derive(clap::Args)]
pub struct StudyArgs {
    /// The campaign TOML file.
    pub campaign: PathBuf,
    /// Output directory (default: `<campaign output>-study`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Photon seeds per setting (at least 2).
    #[arg(long, default_value_t = 8)]
    pub seeds: u32,
    /// The image of the campaign whose scene is studied.
    #[arg(long, default_value_t = 0)]
    pub image: u64,
    /// Fewer values per knob (a smoke test).
    #[arg(long)]
    pub quick: bool,
    /// Run even what the work estimate refuses: a study beyond 30 days of one core.
    #[arg(long)]
    pub force: bool,
    /// Override a campaign setting, after `extends`: `key.path=value`, the value a TOML
    /// value (`512`, `true`, `[8, 8]`) or else a string. Repeatable.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

/// `soig compare`.
#[derive(clap::Args)]
pub struct CompareArgs {
    /// The baseline: a run folder or a `results/` row.
    pub baseline: PathBuf,
    /// The run compared with it: a run folder or a `results/` row.
    pub run: PathBuf,
    /// Allowed fall of a metric, `NAME=VALUE` (`map50-95=0.01`, `all=0.05`; default 0.002,
    /// see src/verbs/compare/tolerance.rs). Repeatable.
    #[arg(long, value_name = "NAME=VALUE")]
    pub tolerance: Vec<String>,
    /// Print the same facts as JSON.
    #[arg(long)]
    pub json: bool,
}

/// `soig tables`.
#[derive(clap::Args)]
pub struct TablesArgs {
    /// Run folders or `results/` rows, one per row of the tables.
    #[arg(required = true)]
    pub runs: Vec<PathBuf>,
    /// Also write tables.md, metrics.csv (Tables 3, 5) and timing.csv (Table 6) here.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the generated block of this Markdown file (e.g. results/README.md): the
    /// lines between `<!-- soig tables begin: generated by `soig tables`, do not edit -->`
    /// and `<!-- soig tables end -->`, which it must already hold.
    #[arg(long)]
    pub readme: Option<PathBuf>,
    /// The model queue (models/queue.toml): add a table of what trained each row's model
    /// (file, epochs, stages) and its gap to the paper.
    #[arg(long)]
    pub models: Option<PathBuf>,
}

/// `soig detect`.
#[derive(clap::Args)]
pub struct DetectArgs {
    /// FITS or PNG frames.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// A YOLOv8 ONNX model (Ultralytics export); without one only the streak detector runs.
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Which detectors (default: all with --model, else streak).
    #[arg(long, value_enum)]
    pub detector: Option<DetectorChoice>,
    /// Output directory.
    #[arg(long, default_value = "detections")]
    pub out: PathBuf,
    /// Take the enhancement (`[enhance]`) and detector settings (`[detect]`) of this campaign.
    #[arg(long)]
    pub campaign: Option<PathBuf>,
    /// Streak-detector knobs (the keys of a campaign's `[detect.streak]`) from a TOML file,
    /// replacing the campaign's.
    #[arg(long, value_name = "FILE.toml")]
    pub streak: Option<PathBuf>,
    /// The frame's PSF FWHM in pixels (sets the streak detector's cross-section).
    #[arg(long)]
    pub psf_fwhm_px: Option<f64>,
    /// The frame's PSF FWHM in arcseconds, over the pixel scale.
    #[arg(long)]
    pub psf_fwhm_arcsec: Option<f64>,
    /// Pixel scale, arcsec per pixel (default: the WCS's).
    #[arg(long)]
    pub pixel_scale_arcsec: Option<f64>,
    /// Direction of star trails, degrees from +x towards +y (image rows down), if known.
    #[arg(long, allow_negative_numbers = true)]
    pub star_trail_angle_deg: Option<f64>,
    /// YOLO confidence threshold (default: the campaign's, else 0.5).
    #[arg(long)]
    pub conf: Option<f64>,
    /// Say why the streak detector dropped each segment it refined (stage and test), on
    /// stdout and as each frame's `dropped` in detections.json.
    #[arg(long)]
    pub explain: bool,
    /// A star catalogue CSV (Gaia archive, VizieR or plain ra,dec[,pmra,pmdec],mag columns,
    /// as `stars.source = "catalog"`): the streak detector predicts every star's trail from
    /// the FITS header (WCS, DATE-OBS, EXPTIME, the WCS at the exposure's start and end)
    /// and drops only the lines that catalogued stars explain.
    #[arg(long, value_name = "FILE.csv")]
    pub catalog: Option<PathBuf>,
    /// Julian year of the catalogue's positions.
    #[arg(long, default_value_t = soig::detect_frames::GAIA_DR3_EPOCH)]
    pub catalog_epoch: f64,
}

/// `soig enhance`.
#[derive(clap::Args)]
pub struct EnhanceArgs {
    /// FITS files.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Output directory.
    #[arg(long, default_value = "enhanced")]
    pub out: PathBuf,
    /// Take the enhancement of this campaign (`[enhance]`; the square root for fixed
    /// pointing only), else soig's defaults; the flags below replace single settings.
    #[arg(long)]
    pub campaign: Option<PathBuf>,
    /// Square-root compression first: true or false.
    #[arg(long)]
    pub sqrt: Option<bool>,
    /// CLAHE clip limit (as OpenCV's clipLimit; 0 turns the clip off).
    #[arg(long)]
    pub clahe_clip_limit: Option<f64>,
    /// CLAHE tile grid, columns x rows, e.g. 8x8.
    #[arg(long, value_name = "COLSxROWS")]
    pub clahe_tiles: Option<String>,
    /// Power-law correction O = I^gamma.
    #[arg(long)]
    pub gamma: Option<f64>,
}

/// `soig schema`.
#[derive(clap::Args)]
pub struct SchemaArgs {
    /// The experiment file's schema rather than the campaign's.
    #[arg(long)]
    pub experiment: bool,
}

/// `soig experiment`.
#[derive(clap::Args)]
pub struct ExperimentArgs {
    /// The experiment TOML file.
    pub experiment: PathBuf,
    /// Output directory (default: `runs/<file stem>` beside the experiment file).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
    /// Run even what the work estimate refuses: points beyond 30 days of one core in all, or
    /// a point `soig run` would refuse.
    #[arg(long)]
    pub force: bool,
}

/// `soig export`.
#[derive(clap::Args)]
pub struct ExportArgs {
    /// An output directory of `soig run` (it must verify).
    pub output: PathBuf,
    /// Where the exports go, outside the output (default: `<output>-export`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Only COCO JSON.
    #[arg(long)]
    pub coco: bool,
    /// Only DS9 regions.
    #[arg(long)]
    pub ds9: bool,
    /// The truth's observations as a CCSDS TDM (`tdm/truth.tdm`, RA/Dec angles); with --coco
    /// or --ds9, those too.
    #[arg(long)]
    pub tdm: bool,
}

/// `soig eval`.
#[derive(clap::Args)]
pub struct EvalArgs {
    /// Directory of label files (`cls xc yc w h`, normalised; with `--mode ultralytics-obb`
    /// YOLO-OBB corners `cls x1 y1 x2 y2 x3 y3 x4 y4`), one per image.
    #[arg(long)]
    pub labels: PathBuf,
    /// Directory of prediction files, paired with labels by file stem.
    #[arg(long)]
    pub predictions: PathBuf,
    /// Which convention to report: Ultralytics' `ap_per_class`, pycocotools' COCOeval, or
    /// Ultralytics' OBB validator (oriented boxes, probabilistic IoU).
    #[arg(long, value_enum, default_value = "ultralytics")]
    pub mode: EvalMode,
    /// Images, to scale boxes to their pixel size (Ultralytics' IoU has a 1e-7 term, so
    /// units matter at the last digit); default: every image `--image-size` square.
    #[arg(long)]
    pub images: Option<PathBuf>,
    /// Side of every image in pixels, when --images is not given (1 to 65536).
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub image_size: u32,
    /// Confidence threshold of the fixed-threshold precision and recall, in [0, 1].
    #[arg(long, default_value_t = 0.5, value_parser = share_of_one)]
    pub conf: f64,
    /// IoU threshold of the fixed-threshold precision and recall, in (0, 1].
    #[arg(long, default_value_t = 0.5, value_parser = overlap)]
    pub iou: f64,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// A number in [0, 1] (a confidence): NaN and anything outside are refused by clap, naming
/// the option.
fn share_of_one(text: &str) -> Result<f64, String> {
    let x: f64 = text.trim().parse().map_err(|e| format!("{e}"))?;
    if (0.0..=1.0).contains(&x) {
        Ok(x)
    } else {
        Err("must be a number in [0, 1]".into())
    }
}

/// A number in (0, 1] (an IoU threshold).
fn overlap(text: &str) -> Result<f64, String> {
    let x: f64 = text.trim().parse().map_err(|e| format!("{e}"))?;
    if x > 0.0 && x <= 1.0 {
        Ok(x)
    } else {
        Err("must be a number in (0, 1]".into())
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum DetectorChoice {
    Streak,
    Yolo,
    All,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum EvalMode {
    Ultralytics,
    Coco,
    UltralyticsObb,
}

/// What `soig slurm` and `soig k8s` take.
#[derive(clap::Args)]
pub struct LaunchArgs {
    /// The campaign TOML file.
    pub campaign: PathBuf,
    /// How many shards (array tasks, completion indexes).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    pub shards: u64,
    /// The merged output (default: the campaign's); shard K writes `OUT-shard-K-of-N`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Where the job files are written (default: `OUT-slurm` or `OUT-k8s`).
    #[arg(long)]
    pub scripts: Option<PathBuf>,
    /// Override a campaign setting in every shard, as `soig run --set`. Repeatable.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    /// `soig VERB --help` says what every verb, argument and option does.
    #[test]
    fn every_help_entry_has_a_description() {
        let cli = super::Cli::command();
        let mut missing = Vec::new();
        for verb in cli.get_subcommands() {
            if verb.get_about().is_none() {
                missing.push(verb.get_name().to_string());
            }
            for arg in verb.get_arguments() {
                if arg.get_help().is_none() && arg.get_long_help().is_none() {
                    missing.push(format!("{} {}", verb.get_name(), arg.get_id()));
                }
            }
        }
        assert!(missing.is_empty(), "no description: {missing:?}");
    }
}
