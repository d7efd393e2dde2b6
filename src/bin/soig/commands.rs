//! Each verb of the command line: its arguments to the library's call, and what it prints.
//! Exit codes: 0 done, 1 a check failed (verify, compare, an experiment's point), 2 an error.

use std::path::PathBuf;
use std::process::ExitCode;

use soig::campaign::Campaign;
use soig::verbs::plan::Plan;

use crate::args::*;

/// `soig run`.
pub fn run(a: RunArgs) -> ExitCode {
    let RunArgs {
        campaign,
        out,
        shard,
        fresh,
        force,
        quiet,
        python,
        set,
    } = a;
    user_errors(|| {
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
        let options = soig::RunOptions {
            shard,
            fresh,
            force,
        };
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
    })
}

/// `soig merge`.
pub fn merge(a: MergeArgs) -> ExitCode {
    let MergeArgs {
        shards,
        out,
        python,
        quiet,
    } = a;
    user_errors(|| {
        let started = std::time::Instant::now();
        let s = soig::merge::merge(&shards, &out, python.as_deref(), &*progress(quiet))?;
        print!("{}", s.merge_lines(shards.len()));
        print!("{}", s.timing_line(started.elapsed().as_secs_f64()));
        Ok(())
    })
}

/// `soig slurm`.
pub fn slurm(a: SlurmArgs) -> ExitCode {
    let SlurmArgs {
        launch: a,
        partition,
        account,
        time,
        mem,
        cpus_per_task,
        sbatch,
    } = a;
    user_errors(|| {
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
    })
}

/// `soig k8s`.
pub fn k8s(a: K8sArgs) -> ExitCode {
    let K8sArgs {
        launch: a,
        image,
        claim,
        deadline,
    } = a;
    user_errors(|| {
        // At most 30 days: Kubernetes keeps the deadline in an int64, and a Job that long is
        // a typo.
        let deadline_s = match soig::pipeline::parse_budget(&deadline) {
            Ok(s) if s <= 30.0 * 86400.0 => s.ceil() as u64,
            _ => anyhow::bail!(
                "--deadline {deadline:?}: expected a duration of at most 30 days, such as 90m, 3600s or 6h"
            ),
        };
        launch(a, "k8s", Vec::new(), |l| {
            soig::launch::k8s(l, &image, &claim, deadline_s)
        })
    })
}

/// `soig train`.
pub fn train(a: TrainArgs) -> ExitCode {
    let TrainArgs {
        campaign,
        out,
        python,
        quiet,
        set,
        budget,
        chunk_epochs,
        resume,
    } = a;
    user_errors(|| {
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
    })
}

/// `soig verify`.
pub fn verify(a: VerifyArgs) -> ExitCode {
    let VerifyArgs { dir, digest } = a;
    match soig::manifest::verify(&dir) {
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
    }
}

/// `soig export`.
pub fn export(a: ExportArgs) -> ExitCode {
    let ExportArgs {
        output,
        out,
        coco,
        ds9,
        tdm,
    } = a;
    user_errors(|| {
        let dest = out.unwrap_or_else(|| {
            // `components` drops a trailing '/', which would put the folder inside.
            let mut name = output.components().as_path().as_os_str().to_owned();
            name.push("-export");
            PathBuf::from(name)
        });
        // None chosen: COCO and DS9, as before there was a TDM.
        let both = !coco && !ds9 && !tdm;
        let formats = soig::export::Formats {
            coco: coco || both,
            ds9: ds9 || both,
            tdm,
        };
        let files = soig::export::export_output(&output, &dest, formats)?;
        println!("{} files -> {}", files.len(), dest.display());
        Ok(())
    })
}

/// `soig eval`.
pub fn eval(a: EvalArgs) -> ExitCode {
    let EvalArgs {
        labels,
        predictions,
        mode,
        images,
        image_size,
        conf,
        iou,
        json,
    } = a;
    user_errors(|| {
        use soig::metrics::{EvalOptions, eval_dirs};
        let options = EvalOptions {
            mode: match mode {
                EvalMode::Ultralytics => soig::metrics::EvalMode::Ultralytics,
                EvalMode::Coco => soig::metrics::EvalMode::Coco,
                EvalMode::UltralyticsObb => soig::metrics::EvalMode::UltralyticsObb,
            },
            images: images.as_deref(),
            image_size,
            conf,
            iou,
        };
        let e = eval_dirs(&labels, &predictions, options)?;
        if json {
            println!("{}", serde_json::to_string_pretty(&e.to_json())?);
        } else {
            println!("{}", e.text());
        }
        Ok(())
    })
}

/// `soig study`.
pub fn study(a: StudyArgs) -> ExitCode {
    let StudyArgs {
        campaign,
        out,
        seeds,
        image,
        quick,
        force,
        set,
    } = a;
    user_errors(|| {
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
            force,
        };
        let s = soig::study::run(&campaign, &output, &opts)?;
        println!(
            "{} settings in {:.1} s -> {}",
            s.rows.len(),
            s.seconds,
            output.display()
        );
        Ok(())
    })
}

/// `soig compare`.
pub fn compare(a: CompareArgs) -> ExitCode {
    let CompareArgs {
        baseline,
        run,
        tolerance,
        json,
    } = a;
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

/// `soig tables`.
pub fn tables(a: TablesArgs) -> ExitCode {
    let TablesArgs {
        runs,
        out,
        readme,
        models,
    } = a;
    user_errors(|| soig::tables::write(&runs, models.as_deref(), out.as_deref(), readme.as_deref()))
}

/// `soig enhance`.
pub fn enhance(a: EnhanceArgs) -> ExitCode {
    let EnhanceArgs {
        inputs,
        out,
        campaign,
        sqrt,
        clahe_clip_limit,
        clahe_tiles,
        gamma,
    } = a;
    user_errors(|| {
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
    })
}

/// `soig detect`.
pub fn detect(a: DetectArgs) -> ExitCode {
    let DetectArgs {
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
    } = a;
    user_errors(|| {
        use soig::detect_frames::{Optics, Options, Which};
        let campaign = campaign.map(|c| Campaign::load(&c)).transpose()?;
        let which = match (detector, &model) {
            (Some(DetectorChoice::Streak), _) | (None, None) => Which::Streak,
            (Some(DetectorChoice::Yolo), _) => Which::Yolo,
            (Some(DetectorChoice::All), _) | (None, Some(_)) => Which::All,
        };
        let plan = campaign.as_ref().map(Plan::new).transpose()?;
        let mut opts = Options::new(plan.as_ref(), which, model);
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
            if let Some(own) = &f.own_trails {
                println!("  star trails measured on the frame: {own}");
            }
            for d in &f.dropped {
                println!("  dropped {d}");
            }
        }
        println!("-> {}\ndigest {}", s.output.display(), s.digest);
        Ok(())
    })
}

/// `soig schema`.
pub fn schema(a: SchemaArgs) -> ExitCode {
    let SchemaArgs { experiment } = a;
    if experiment {
        println!("{}", soig::sweep::schema_json());
    } else {
        println!("{}", soig::campaign::schema_json());
    }
    ExitCode::SUCCESS
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

/// Progress bars on stderr, or nothing with `--quiet`.
pub fn progress(quiet: bool) -> Box<dyn soig::progress::Progress> {
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
pub fn experiment(a: ExperimentArgs) -> ExitCode {
    let ExperimentArgs {
        experiment: path,
        out,
        quiet,
        force,
    } = a;
    let mut failed = false;
    let code = user_errors(|| {
        let experiment = soig::sweep::Experiment::load(&path)?;
        let out = out.unwrap_or_else(|| {
            let stem = path.file_stem().unwrap_or_default();
            path.parent()
                .unwrap_or(std::path::Path::new("."))
                .join("runs")
                .join(stem)
        });
        let f = soig::sweep::run(&experiment, &out, &*progress(quiet), force)?;
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
