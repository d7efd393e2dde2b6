//! The `soig` command: a thin CLI over the library.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use soig::campaign::Campaign;

// Each image allocates and frees several multi-MB buffers; glibc's malloc returns such blocks
// to the kernel at every free, so every image paid their page faults again (12% of a run).
// mimalloc keeps freed blocks for reuse.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

#[derive(Parser)]
#[command(
    name = "soig",
    version,
    about = "Space optical image generator: campaign file -> reproducible synthetic dataset of space debris images"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a campaign: render, enhance, split, and write the manifest. A run that was killed or
    /// interrupted is resumed by running the same command again: the images it finished are
    /// checked against their hashes and only the missing ones rendered (same digest).
    Run {
        /// The campaign TOML file.
        campaign: PathBuf,
        /// Output directory (default: the campaign's `output`, else `runs/<name>` beside it;
        /// with --shard, that with `-shard-K-of-N` appended).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Render only shard K of N (0 <= K < N): the contiguous block of images K*n/N ..
        /// (K+1)*n/N, into a shard output for `soig merge`. `auto` takes K and N from a Slurm
        /// job array (SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_COUNT); `auto/N` takes K from a
        /// Kubernetes Indexed Job (JOB_COMPLETION_INDEX) with N its completions.
        #[arg(long, value_name = "K/N|auto|auto/N")]
        shard: Option<String>,
        /// Do not resume: discard the work a killed run of this output left, and start afresh.
        #[arg(long)]
        fresh: bool,
        /// No progress bar.
        #[arg(long, short)]
        quiet: bool,
        /// Python with Ultralytics, for a `train` stage (default: .venv-train/bin/python3).
        #[arg(long)]
        python: Option<PathBuf>,
        /// Override a campaign setting, after `extends`: `key.path=value`, the value a TOML
        /// value (`512`, `true`, `[8, 8]`) or else a string. Repeatable.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
    },
    /// Merge the shard outputs of one campaign (`soig run --shard`) into the output a single
    /// run would write, same digest: checks that they are one campaign and soig version, that
    /// each verifies, and that every shard 0..N is given once; then writes data.yaml, runs the
    /// train and detect stages and the report, and writes the manifest.
    Merge {
        /// The shard outputs, in any order.
        #[arg(required = true)]
        shards: Vec<PathBuf>,
        /// Output directory of the merged run.
        #[arg(long)]
        out: PathBuf,
        /// Python with Ultralytics, for a `train` stage (default: .venv-train/bin/python3).
        #[arg(long)]
        python: Option<PathBuf>,
        /// No progress bar.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Write a Slurm job array that runs the campaign as N shards (`soig run --shard K/N`), a
    /// merge job that depends on it (afterok), and submit.sh, which submits the two.
    Slurm {
        #[command(flatten)]
        launch: LaunchArgs,
        /// The partition of every job (`#SBATCH --partition`).
        #[arg(long)]
        partition: Option<String>,
        /// The account charged for every job (`#SBATCH --account`).
        #[arg(long)]
        account: Option<String>,
        /// Wall-time limit of each job: MM, MM:SS, HH:MM:SS, D-HH, D-HH:MM or D-HH:MM:SS.
        #[arg(long, value_name = "TIME")]
        time: Option<String>,
        /// Memory of each job: megabytes, or with a unit suffix K, M, G or T (e.g. 4G).
        #[arg(long, value_name = "SIZE")]
        mem: Option<String>,
        /// CPUs of each task; soig then runs that many threads (SLURM_CPUS_PER_TASK).
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
        cpus_per_task: Option<u32>,
        /// Any other sbatch option, written as `#SBATCH ARG` in every job, e.g.
        /// `--sbatch=--qos=high`. Repeatable.
        #[arg(long, value_name = "ARG", allow_hyphen_values = true)]
        sbatch: Vec<String>,
    },
    /// Write a Kubernetes Indexed Job that runs the campaign as N shards (`soig run --shard
    /// auto/N`) on a shared volume, a merge Job, and submit.sh, which applies them in turn.
    K8s {
        #[command(flatten)]
        launch: LaunchArgs,
        /// The container image holding `soig` on its PATH (the repository's Containerfile
        /// builds one: `podman build -t soig:latest .`).
        #[arg(long, default_value = "soig:latest")]
        image: String,
        /// The PersistentVolumeClaim mounted at /data in every pod, the pods' working directory:
        /// campaign and output paths are taken relative to it.
        #[arg(long, default_value = "soig-data")]
        claim: String,
    },
    /// Train a YOLOv8 model on the campaign's dataset through Ultralytics, export ONNX, and
    /// record the run in the manifest (needs `scripts/setup-train.sh`).
    Train {
        /// The campaign TOML file (its `[train]` table sets epochs, batch and image size).
        campaign: PathBuf,
        /// Output directory (default: the campaign's `output`, else `runs/<name>` beside it).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Python interpreter with Ultralytics (default: .venv-train/bin/python3).
        #[arg(long)]
        python: Option<PathBuf>,
        /// No progress bar.
        #[arg(long, short)]
        quiet: bool,
        /// Override a campaign setting, after `extends`: `key.path=value`, the value a TOML
        /// value (`512`, `true`, `[8, 8]`) or else a string. Repeatable.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Train one chunk: stop at the last epoch boundary before this much time (`9m`,
        /// `540s`, `1.5h`), keeping what `--resume` needs to go on.
        #[arg(long, value_name = "DURATION")]
        budget: Option<String>,
        /// Train one chunk of at most this many epochs (with or without --budget).
        #[arg(long, value_name = "N")]
        chunk_epochs: Option<u32>,
        /// Continue the schedule a chunk left in the output (same epochs, learning rates, seed).
        #[arg(long)]
        resume: bool,
    },
    /// Recompute every hash of an output directory against its manifest.
    Verify {
        /// An output directory of `soig run`.
        dir: PathBuf,
        /// The digest pinned for it (e.g. in CI): verify fails unless the recomputed digest is
        /// this one, so a manifest rewritten with consistent hashes is caught.
        #[arg(long, value_name = "HEX")]
        digest: Option<String>,
    },
    /// Measure what each rendering approximation (renderer, photon merging, trajectory
    /// samples, jitter steps) costs in accuracy and saves in time on one scene of the campaign:
    /// study.csv, study.md, study.png and a manifest.
    Study {
        /// The campaign TOML file.
        campaign: PathBuf,
        /// Output directory (default: `<campaign output>-study`).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Photon seeds per setting (at least 2).
        #[arg(long, default_value_t = 8)]
        seeds: u32,
        /// The image of the campaign whose scene is studied.
        #[arg(long, default_value_t = 0)]
        image: u64,
        /// Fewer values per knob (a smoke test).
        #[arg(long)]
        quick: bool,
        /// Override a campaign setting, after `extends`: `key.path=value`, the value a TOML
        /// value (`512`, `true`, `[8, 8]`) or else a string. Repeatable.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
    },
    /// Compare a run with a baseline (a run folder or a pinned `results/` row): exit 0 when
    /// identical or every metric within tolerance, 1 on a regression, 2 on an error.
    Compare {
        /// The baseline: a run folder or a `results/` row.
        baseline: PathBuf,
        /// The run compared with it: a run folder or a `results/` row.
        run: PathBuf,
        /// Allowed fall of a metric, `NAME=VALUE` (`map50-95=0.01`, `all=0.05`; default 0.002,
        /// see src/compare/tolerance.rs). Repeatable.
        #[arg(long, value_name = "NAME=VALUE")]
        tolerance: Vec<String>,
        /// Print the same facts as JSON.
        #[arg(long)]
        json: bool,
    },
    /// The paper's Tables 3, 5 and 6 from run folders or `results/` rows, beside the paper's
    /// figures: Markdown on stdout.
    Tables {
        /// Run folders or `results/` rows, one per row of the tables.
        #[arg(required = true)]
        runs: Vec<PathBuf>,
        /// Also write tables.md, metrics.csv (Tables 3, 5) and timing.csv (Table 6) here.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Replace the generated block of this Markdown file (e.g. results/README.md): the
        /// lines between `<!-- soig tables begin: generated by `soig tables`, do not edit -->`
        /// and `<!-- soig tables end -->`, which it must already hold.
        #[arg(long)]
        readme: Option<PathBuf>,
        /// The model queue (models/queue.toml): add a table of what trained each row's model
        /// (file, epochs, stages) and its gap to the paper.
        #[arg(long)]
        models: Option<PathBuf>,
    },
    /// Run soig's detectors on real frames (FITS of any numeric type, PNG): detections.csv and
    /// .json (pixel boxes, streak ends, RA/Dec through the frame's WCS), YOLO-format
    /// predictions, previews and a manifest.
    Detect {
        /// FITS or PNG frames.
        #[arg(required = true)]
        inputs: Vec<PathBuf>,
        /// A YOLOv8 ONNX model (Ultralytics export); without one only the streak detector runs.
        #[arg(long)]
        model: Option<PathBuf>,
        /// Which detectors (default: all with --model, else streak).
        #[arg(long, value_enum)]
        detector: Option<DetectorChoice>,
        /// Output directory.
        #[arg(long, default_value = "detections")]
        out: PathBuf,
        /// Take the enhancement (`[enhance]`) and detector settings (`[detect]`) of this campaign.
        #[arg(long)]
        campaign: Option<PathBuf>,
        /// Streak-detector knobs (the keys of a campaign's `[detect.streak]`) from a TOML file,
        /// replacing the campaign's.
        #[arg(long, value_name = "FILE.toml")]
        streak: Option<PathBuf>,
        /// The frame's PSF FWHM in pixels (sets the streak detector's cross-section).
        #[arg(long)]
        psf_fwhm_px: Option<f64>,
        /// The frame's PSF FWHM in arcseconds, over the pixel scale.
        #[arg(long)]
        psf_fwhm_arcsec: Option<f64>,
        /// Pixel scale, arcsec per pixel (default: the WCS's).
        #[arg(long)]
        pixel_scale_arcsec: Option<f64>,
        /// Direction of star trails, degrees from +x towards +y (image rows down), if known.
        #[arg(long, allow_negative_numbers = true)]
        star_trail_angle_deg: Option<f64>,
        /// YOLO confidence threshold (default: the campaign's, else 0.5).
        #[arg(long)]
        conf: Option<f64>,
        /// Say why the streak detector dropped each segment it refined (stage and test), on
        /// stdout and as each frame's `dropped` in detections.json.
        #[arg(long)]
        explain: bool,
        /// A star catalogue CSV (Gaia archive, VizieR or plain ra,dec[,pmra,pmdec],mag columns,
        /// as `stars.source = "catalog"`): the streak detector predicts every star's trail from
        /// the FITS header (WCS, DATE-OBS, EXPTIME, the WCS at the exposure's start and end)
        /// and drops only the lines that catalogued stars explain.
        #[arg(long, value_name = "FILE.csv")]
        catalog: Option<PathBuf>,
        /// Julian year of the catalogue's positions.
        #[arg(long, default_value_t = soig::detect_frames::GAIA_DR3_EPOCH)]
        catalog_epoch: f64,
    },
    /// The paper's FITS -> PNG conversion (square root for fixed pointing, log stretch, CLAHE,
    /// gamma, 8-bit PNG) of any FITS, soig's or a real frame's sky region: OUT/<stem>.png per
    /// input, timing.json and a manifest. The original frame only: padding and rotation belong
    /// to `soig run`
    Enhance {
        /// FITS files.
        #[arg(required = true)]
        inputs: Vec<PathBuf>,
        /// Output directory.
        #[arg(long, default_value = "enhanced")]
        out: PathBuf,
        /// Take the enhancement of this campaign (`[enhance]`; the square root for fixed
        /// pointing only), else soig's defaults; the flags below replace single settings.
        #[arg(long)]
        campaign: Option<PathBuf>,
        /// Square-root compression first: true or false.
        #[arg(long)]
        sqrt: Option<bool>,
        /// CLAHE clip limit (as OpenCV's clipLimit; 0 turns the clip off).
        #[arg(long)]
        clahe_clip_limit: Option<f64>,
        /// CLAHE tile grid, columns x rows, e.g. 8x8.
        #[arg(long, value_name = "COLSxROWS")]
        clahe_tiles: Option<String>,
        /// Power-law correction O = I^gamma.
        #[arg(long)]
        gamma: Option<f64>,
    },
    /// Print the JSON Schema of the campaign format (or, with --experiment, of the experiment
    /// file).
    Schema {
        /// The experiment file's schema rather than the campaign's.
        #[arg(long)]
        experiment: bool,
    },
    /// Run an experiment: a sweep of campaign fields (an experiment file), one `soig run` per
    /// point into OUT/points/<parameter values>, reusing a point whose campaign is unchanged;
    /// writes summary.csv, summary.md, plots/ and experiment.json (the digest of every point).
    /// A malformed experiment is refused before anything runs; a failing point is reported and
    /// the others go on (exit 1 at the end).
    Experiment {
        /// The experiment TOML file.
        experiment: PathBuf,
        /// Output directory (default: `runs/<file stem>` beside the experiment file).
        #[arg(long)]
        out: Option<PathBuf>,
        /// No progress bar.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Export a finished output for other tools: the dataset and the detect stage's predictions
    /// as COCO JSON (OUT/coco/) and the truth and detections as DS9 region files over the FITS
    /// (OUT/ds9/); see src/export/. Both unless one is chosen.
    Export {
        /// An output directory of `soig run` (it must verify).
        output: PathBuf,
        /// Where the exports go, outside the output (default: `<output>-export`).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Only COCO JSON.
        #[arg(long)]
        coco: bool,
        /// Only DS9 regions.
        #[arg(long)]
        ds9: bool,
    },
    /// Score YOLO-format predictions (`cls xc yc w h score`) against YOLO labels, exactly as
    /// Ultralytics and pycocotools compute their metrics.
    Eval {
        /// Directory of label files (`cls xc yc w h`, normalised), one per image.
        #[arg(long)]
        labels: PathBuf,
        /// Directory of prediction files, paired with labels by file stem.
        #[arg(long)]
        predictions: PathBuf,
        /// Which convention to report: Ultralytics' `ap_per_class` or pycocotools' COCOeval.
        #[arg(long, value_enum, default_value = "ultralytics")]
        mode: EvalMode,
        /// Images, to scale boxes to their pixel size (Ultralytics' IoU has a 1e-7 term, so
        /// units matter at the last digit); default: every image `--image-size` square.
        #[arg(long)]
        images: Option<PathBuf>,
        /// Side of every image in pixels, when --images is not given.
        #[arg(long, default_value_t = 1024)]
        image_size: u32,
        /// Confidence threshold of the fixed-threshold precision and recall.
        #[arg(long, default_value_t = 0.5)]
        conf: f64,
        /// IoU threshold of the fixed-threshold precision and recall.
        #[arg(long, default_value_t = 0.5)]
        iou: f64,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum DetectorChoice {
    Streak,
    Yolo,
    All,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum EvalMode {
    Ultralytics,
    Coco,
}

/// What `soig slurm` and `soig k8s` take.
#[derive(clap::Args)]
struct LaunchArgs {
    /// The campaign TOML file.
    campaign: PathBuf,
    /// How many shards (array tasks, completion indexes).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    shards: u64,
    /// The merged output (default: the campaign's); shard K writes `OUT-shard-K-of-N`.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Where the job files are written (default: `OUT-slurm` or `OUT-k8s`).
    #[arg(long)]
    scripts: Option<PathBuf>,
    /// Override a campaign setting in every shard, as `soig run --set`. Repeatable.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
}

/// Check the campaign loads, then write the launcher's files; `local` jobs (Slurm) get
/// absolute paths and this `soig`, pods their paths as given and the `soig` on their PATH.
fn launch(
    a: LaunchArgs,
    engine: &str,
    sbatch: Vec<String>,
    files: impl FnOnce(&soig::launch::Launch) -> Vec<soig::launch::File>,
) -> anyhow::Result<()> {
    let local = engine == "slurm";
    let campaign = Campaign::load_with_overrides(&a.campaign, &a.set)?;
    let images = u64::from(campaign.resolved.images);
    if a.shards > images {
        anyhow::bail!(
            "--shards {}: more shards than the campaign's {images} images (at most one shard per image)",
            a.shards
        );
    }
    let out = a.out.unwrap_or_else(|| campaign.output_dir.clone());
    if !local {
        // The pods see the claim at /data and nothing else: paths are taken relative to it.
        for (what, p) in [("campaign", &a.campaign), ("output", &out)] {
            let outside = p.is_absolute()
                || p.components()
                    .any(|c| matches!(c, std::path::Component::ParentDir));
            if outside {
                eprintln!(
                    "warning: the {what} path {} is {} the volume: the pods run in {} (the claim) and will not find it; give paths relative to the volume's root",
                    p.display(),
                    if p.is_absolute() {
                        "absolute, not within"
                    } else {
                        "outside"
                    },
                    soig::launch::MOUNT
                );
            }
        }
    }
    let path = |p: PathBuf| {
        if local {
            std::path::absolute(&p)
        } else {
            Ok(p)
        }
    };
    let l = soig::launch::Launch {
        soig: if local {
            std::env::current_exe()?
        } else {
            "soig".into()
        },
        campaign: path(a.campaign)?,
        sets: a.set,
        out: path(out.clone())?,
        shards: a.shards,
        name: campaign.resolved.name.clone(),
        sbatch,
    };
    let dir = a.scripts.unwrap_or_else(|| {
        let mut d = out.into_os_string();
        d.push(format!("-{engine}"));
        d.into()
    });
    soig::launch::write(&dir, &files(&l), &[&campaign.source])?;
    println!("{}", dir.join("submit.sh").display());
    Ok(())
}

fn main() -> ExitCode {
    stop_cleanly_on_signals();
    threads_from_slurm();
    let cli = Cli::parse();
    match cli.command {
        Command::Run {
            campaign,
            out,
            shard,
            fresh,
            quiet,
            python,
            set,
        } => user_errors(|| {
            let started = std::time::Instant::now();
            let campaign = Campaign::load_with_overrides(&campaign, &set)?;
            let shard = shard
                .map(|s| soig::shard::Shard::parse(&s, |k| std::env::var(k).ok()))
                .transpose()
                .map_err(anyhow::Error::msg)?;
            let output = out.unwrap_or_else(|| match shard {
                Some(s) => s.output_dir(&campaign.output_dir),
                None => campaign.output_dir.clone(),
            });
            let options = soig::RunOptions { shard, fresh };
            let s = soig::run_with(
                &campaign,
                &output,
                options,
                python.as_deref(),
                &*progress(quiet),
            )?;
            if let Some(k) = shard {
                print!("shard {} of {}: ", k.index, k.count);
            }
            print!("{}", s.final_lines());
            print!("{}", s.timing_line(started.elapsed().as_secs_f64()));
            Ok(())
        }),
        Command::Merge {
            shards,
            out,
            python,
            quiet,
        } => user_errors(|| {
            let started = std::time::Instant::now();
            let s = soig::merge::merge(&shards, &out, python.as_deref(), &*progress(quiet))?;
            print!("{}", s.merge_lines(shards.len()));
            print!("{}", s.timing_line(started.elapsed().as_secs_f64()));
            Ok(())
        }),
        Command::Slurm {
            launch: a,
            partition,
            account,
            time,
            mem,
            cpus_per_task,
            sbatch,
        } => user_errors(|| {
            let resources = soig::launch::SlurmResources {
                partition,
                account,
                time,
                mem,
                cpus_per_task,
                raw: sbatch,
            };
            let options = soig::launch::sbatch_options(&resources)?;
            launch(a, "slurm", options, soig::launch::slurm)
        }),
        Command::K8s {
            launch: a,
            image,
            claim,
        } => user_errors(|| {
            launch(a, "k8s", Vec::new(), |l| {
                soig::launch::k8s(l, &image, &claim)
            })
        }),
        Command::Train {
            campaign,
            out,
            python,
            quiet,
            set,
            budget,
            chunk_epochs,
            resume,
        } => user_errors(|| {
            let campaign = Campaign::load_with_overrides(&campaign, &set)?;
            let output = out.unwrap_or_else(|| campaign.output_dir.clone());
            let chunk = soig::pipeline::Chunk {
                budget_s: budget
                    .as_deref()
                    .map(soig::pipeline::parse_budget)
                    .transpose()?,
                epochs: chunk_epochs,
                resume,
            };
            let python = python.as_deref();
            match soig::pipeline::train(&campaign, &output, python, chunk, &*progress(quiet))? {
                Some(model) => println!("model {}", model.display()),
                None => println!(
                    "training unfinished (budget reached): run the same command with --resume to go on ({})",
                    campaign.source.display()
                ),
            }
            Ok(())
        }),
        Command::Verify { dir, digest } => match soig::manifest::verify(&dir) {
            Ok((m, mut problems)) if problems.is_empty() => {
                if let Some(pinned) = digest.filter(|d| *d != m.digest) {
                    problems.push(soig::manifest::Problem::Pinned {
                        pinned,
                        found: m.digest.clone(),
                    });
                    for p in &problems {
                        eprintln!("{p}");
                    }
                    eprintln!("verify failed: {} is not the pinned output", dir.display());
                    return ExitCode::from(1);
                }
                println!("ok: {} files match, digest {}", m.files.len(), m.digest);
                ExitCode::SUCCESS
            }
            Ok((_, problems)) => {
                for p in &problems {
                    eprintln!("{p}");
                }
                eprintln!(
                    "verify failed: {} problem(s) in {}",
                    problems.len(),
                    dir.display()
                );
                ExitCode::from(1)
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::from(2)
            }
        },
        Command::Export {
            output,
            out,
            coco,
            ds9,
        } => user_errors(|| {
            let dest = out.unwrap_or_else(|| {
                // `components` drops a trailing '/', which would put the folder inside.
                let mut name = output.components().as_path().as_os_str().to_owned();
                name.push("-export");
                PathBuf::from(name)
            });
            let both = !coco && !ds9;
            let formats = soig::export::Formats {
                coco: coco || both,
                ds9: ds9 || both,
            };
            let files = soig::export::export_output(&output, &dest, formats)?;
            println!("{} files -> {}", files.len(), dest.display());
            Ok(())
        }),
        Command::Eval {
            labels,
            predictions,
            mode,
            images,
            image_size,
            conf,
            iou,
            json,
        } => user_errors(|| {
            let text = eval(
                &labels,
                &predictions,
                mode,
                images.as_deref(),
                image_size,
                conf,
                iou,
                json,
            )?;
            println!("{text}");
            Ok(())
        }),
        Command::Study {
            campaign,
            out,
            seeds,
            image,
            quick,
            set,
        } => user_errors(|| {
            let campaign = Campaign::load_with_overrides(&campaign, &set)?;
            let output = out.unwrap_or_else(|| {
                let mut name = campaign.output_dir.as_os_str().to_owned();
                name.push("-study");
                PathBuf::from(name)
            });
            let opts = soig::study::Options {
                seeds,
                image,
                quick,
            };
            let s = soig::study::run(&campaign, &output, &opts)?;
            println!(
                "{} settings in {:.1} s -> {}",
                s.rows.len(),
                s.seconds,
                output.display()
            );
            Ok(())
        }),
        Command::Compare {
            baseline,
            run,
            tolerance,
            json,
        } => {
            let compared = soig::compare::Tolerances::parse(&tolerance)
                .and_then(|t| soig::compare::compare(&baseline, &run, &t));
            match compared {
                Ok(c) if json => {
                    println!("{}", serde_json::to_string_pretty(&c).expect("json"));
                    ExitCode::from(c.exit_code())
                }
                Ok(c) => {
                    print!("{}", soig::compare::text(&c));
                    ExitCode::from(c.exit_code())
                }
                Err(e) => {
                    eprintln!("error: {e:#}");
                    ExitCode::from(2)
                }
            }
        }
        Command::Tables {
            runs,
            out,
            readme,
            models,
        } => user_errors(|| {
            soig::tables::write(&runs, models.as_deref(), out.as_deref(), readme.as_deref())
        }),
        Command::Enhance {
            inputs,
            out,
            campaign,
            sqrt,
            clahe_clip_limit,
            clahe_tiles,
            gamma,
        } => user_errors(|| {
            let loaded = campaign.as_deref().map(Campaign::load).transpose()?;
            let mut settings = soig::experiment::enhance_settings(loaded.as_ref());
            if let Some(v) = sqrt {
                settings.sqrt = v;
            }
            if let Some(v) = clahe_clip_limit {
                anyhow::ensure!(
                    v.is_finite() && v >= 0.0,
                    "--clahe-clip-limit {v}: must be a number >= 0"
                );
                settings.clahe_clip_limit = v;
            }
            if let Some(t) = clahe_tiles {
                settings.clahe_tiles = parse_tiles(&t)?;
            }
            if let Some(v) = gamma {
                anyhow::ensure!(
                    soig::enhance::GAMMA.contains(&v),
                    "--gamma {v}: must be within 0.05..=20"
                );
                settings.gamma = v;
            }
            let s = soig::convert::run(&inputs, &out, &settings, campaign.as_deref())?;
            for f in &s.frames {
                println!(
                    "{} -> {} ({} x {}, {:.1} ms)",
                    f.file,
                    f.png,
                    f.width,
                    f.height,
                    f.seconds * 1e3
                );
            }
            println!("-> {}\ndigest {}", out.display(), s.digest);
            Ok(())
        }),
        Command::Detect {
            inputs,
            model,
            detector,
            out,
            campaign,
            streak,
            psf_fwhm_px,
            psf_fwhm_arcsec,
            pixel_scale_arcsec,
            star_trail_angle_deg,
            conf,
            explain,
            catalog,
            catalog_epoch,
        } => user_errors(|| {
            use soig::detect_frames::{Optics, Options, Which};
            let campaign = campaign.map(|c| Campaign::load(&c)).transpose()?;
            let which = match (detector, &model) {
                (Some(DetectorChoice::Streak), _) | (None, None) => Which::Streak,
                (Some(DetectorChoice::Yolo), _) => Which::Yolo,
                (Some(DetectorChoice::All), _) | (None, Some(_)) => Which::All,
            };
            let mut opts = Options::new(campaign.as_ref(), which, model);
            opts.optics = Optics {
                psf_fwhm_px,
                psf_fwhm_arcsec,
                pixel_scale_arcsec,
            };
            opts.star_trail_angle_deg = star_trail_angle_deg;
            opts.explain = explain;
            opts.catalog = catalog;
            opts.catalog_epoch_jyear = catalog_epoch;
            if let Some(path) = streak {
                opts.streak = soig::detect_frames::streak_params_file(&path)?;
            }
            if let Some(c) = conf {
                opts.yolo.conf = c;
            }
            let s = soig::detect_frames::run(&inputs, &out, &opts)?;
            for f in &s.frames {
                println!("{}: {} detection(s)", f.file, f.detections.len());
                for d in &f.dropped {
                    println!("  dropped {d}");
                }
            }
            println!("-> {}\ndigest {}", s.output.display(), s.digest);
            Ok(())
        }),
        Command::Schema { experiment } => {
            if experiment {
                println!("{}", soig::sweep::schema_json());
            } else {
                println!("{}", soig::campaign::schema_json());
            }
            ExitCode::SUCCESS
        }
        Command::Experiment {
            experiment,
            out,
            quiet,
        } => experiment_command(&experiment, out, quiet),
    }
}

/// Ctrl-C and SIGTERM (Slurm's scancel, a Kubernetes pod stop) stop cleanly: a thread waits
/// for them (blocked in every other thread, which inherit the mask; children get an empty one
/// from std), removes the locks and non-resumable staging directories, keeps a run's staging
/// directory and says how to resume it, and exits 128 + the signal: 130 and 143, the shells'.
fn stop_cleanly_on_signals() {
    use nix::sys::signal::{SigSet, Signal};
    let mut set = SigSet::empty();
    set.add(Signal::SIGINT);
    set.add(Signal::SIGTERM);
    if set.thread_block().is_err() {
        return;
    }
    std::thread::spawn(move || {
        let Ok(signal) = set.wait() else { return };
        for dir in soig::output::interrupt() {
            eprintln!(
                "interrupted ({signal}): the images finished so far are kept in {}; run the same command again to resume (only the missing images are rendered)",
                dir.display()
            );
        }
        std::process::exit(128 + signal as i32);
    });
}

/// In a Slurm job, as many threads as CPUs the task was given (`--cpus-per-task`), not as
/// the node has; `RAYON_NUM_THREADS`, when set, still decides.
fn threads_from_slurm() {
    let given = std::env::var("SLURM_CPUS_PER_TASK")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
        .filter(|&n| n > 0);
    if let (None, Some(n)) = (std::env::var_os("RAYON_NUM_THREADS"), given) {
        // Fails only if a pool exists already, which at the start of main it cannot.
        let _ = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global();
    }
}

/// Progress bars on stderr, or nothing with `--quiet`.
fn progress(quiet: bool) -> Box<dyn soig::progress::Progress> {
    if quiet {
        Box::new(soig::progress::Silent)
    } else {
        Box::new(soig::progress::Bars::default())
    }
}

/// A CLAHE tile grid `COLSxROWS`, each within `enhance::CLAHE_TILES` as a campaign's.
fn parse_tiles(text: &str) -> anyhow::Result<[u32; 2]> {
    let bad =
        || anyhow::anyhow!("--clahe-tiles {text}: expected COLSxROWS, each 1 to 64, e.g. 8x8");
    let (a, b) = text.split_once(['x', 'X']).ok_or_else(bad)?;
    let n = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|n| soig::enhance::CLAHE_TILES.contains(n))
    };
    Ok([n(a).ok_or_else(bad)?, n(b).ok_or_else(bad)?])
}

/// Run a command; a failure (bad input, missing file) prints its message and exits 2.
fn user_errors(f: impl FnOnce() -> anyhow::Result<()>) -> ExitCode {
    match f() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

/// `soig experiment`: exit 2 for a refused experiment, 1 when some point failed.
fn experiment_command(path: &std::path::Path, out: Option<PathBuf>, quiet: bool) -> ExitCode {
    let mut failed = false;
    let code = user_errors(|| {
        let experiment = soig::sweep::Experiment::load(path)?;
        let out = out.unwrap_or_else(|| {
            let stem = path.file_stem().unwrap_or_default();
            path.parent()
                .unwrap_or(std::path::Path::new("."))
                .join("runs")
                .join(stem)
        });
        let f = soig::sweep::run(&experiment, &out, &*progress(quiet))?;
        for (name, e) in &f.failures {
            eprintln!("point {name} failed: {e}");
        }
        failed = !f.failures.is_empty();
        println!(
            "{} point(s), {} reused, {} failed -> {}\ndigest {}",
            f.points,
            f.reused,
            f.failures.len(),
            f.out.display(),
            f.digest
        );
        Ok(())
    });
    if failed { ExitCode::from(1) } else { code }
}

#[allow(clippy::too_many_arguments)]
fn eval(
    labels: &std::path::Path,
    predictions: &std::path::Path,
    mode: EvalMode,
    images: Option<&std::path::Path>,
    image_size: u32,
    conf: f64,
    iou: f64,
    json: bool,
) -> anyhow::Result<String> {
    use soig::metrics;
    let pairs = metrics::read_yolo_dirs(labels, predictions)?;
    let mut scaled = Vec::with_capacity(pairs.len());
    for (stem, e) in &pairs {
        let (w, h) = match images {
            Some(dir) => {
                let path = ["png", "jpg", "jpeg"]
                    .iter()
                    .map(|ext| dir.join(format!("{stem}.{ext}")))
                    .find(|p| p.is_file())
                    .ok_or_else(|| anyhow::anyhow!("no image for {stem} in {}", dir.display()))?;
                image::image_dimensions(&path)
                    .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?
            }
            None => (image_size, image_size),
        };
        scaled.push(e.scaled(w as f64, h as f64));
    }
    let fixed = metrics::at_threshold(&scaled, conf, iou);
    let fixed_json = serde_json::json!({
        "conf": conf, "iou": iou, "precision": fixed.precision, "recall": fixed.recall,
        "tp": fixed.tp, "fp": fixed.fp, "fn": fixed.fn_,
    });
    Ok(match mode {
        EvalMode::Ultralytics => {
            let m = metrics::ultralytics(&scaled);
            if json {
                serde_json::to_string_pretty(&serde_json::json!({
                    "mode": "ultralytics", "images": scaled.len(), "objects": m.n_truth,
                    "detections": m.n_detections, "precision": m.precision, "recall": m.recall,
                    "map50": m.map50, "map50_95": m.map50_95, "f1_conf": m.f1_conf,
                    "at_threshold": fixed_json,
                }))?
            } else {
                format!(
                    "ultralytics: {} images, {} objects, {} detections\nP {:.4}  R {:.4}  mAP50 {:.4}  mAP50-95 {:.4}  (P, R at max-F1 confidence {:.3})\nat conf {conf}, IoU {iou}: P {:.4}  R {:.4}  (TP {}, FP {}, FN {})",
                    scaled.len(),
                    m.n_truth,
                    m.n_detections,
                    m.precision,
                    m.recall,
                    m.map50,
                    m.map50_95,
                    m.f1_conf,
                    fixed.precision,
                    fixed.recall,
                    fixed.tp,
                    fixed.fp,
                    fixed.fn_
                )
            }
        }
        EvalMode::Coco => {
            let m = metrics::coco(&scaled);
            if json {
                serde_json::to_string_pretty(&serde_json::json!({
                    "mode": "coco", "images": scaled.len(), "ap": m.ap, "ap50": m.ap50,
                    "ap75": m.ap75, "ar100": m.ar100, "at_threshold": fixed_json,
                }))?
            } else {
                format!(
                    "coco: {} images\nAP {:.4}  AP50 {:.4}  AP75 {:.4}  AR100 {:.4}\nat conf {conf}, IoU {iou}: P {:.4}  R {:.4}  (TP {}, FP {}, FN {})",
                    scaled.len(),
                    m.ap,
                    m.ap50,
                    m.ap75,
                    m.ar100,
                    fixed.precision,
                    fixed.recall,
                    fixed.tp,
                    fixed.fp,
                    fixed.fn_
                )
            }
        }
    })
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
