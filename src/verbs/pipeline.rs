//! The scheduler: runs every image of a campaign (in parallel with rayon; each image a pure
//! function of the experiment and its index, see `simulate`), writes the artifacts into a
//! staging directory beside the output (see `output`), journaling each finished image (see
//! `journal`: a killed run resumes), adds `data.yaml`, trains when the campaign has a `train`
//! stage, detects and reports, and writes the manifest last, so a failed run never leaves a
//! half-written output. A shard run (`shard`) renders its share of the images only and seals
//! it with a shard manifest; `merge` gathers the shards and finishes here.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;

use crate::artifacts::{self, WrittenPng};
use crate::campaign::Campaign;
use crate::dataset::{self, Subset};
use crate::detect::yolo::YoloDetector;
use crate::detect_stage::{Written, detect_and_report};
use crate::geometry::FrameKind;
use crate::journal::{self, Identity, Journal, PngRecord, Record};
use crate::manifest::{self, MANIFEST, Manifest};
use crate::output::{Resume, write_resumable};
use crate::progress::Progress;
use crate::report;
use crate::scene::{Pointing, Rejection};
use crate::shard::Shard;
use crate::simulate;
use crate::store;
pub use crate::train::{Chunk, parse_budget};
use crate::train::{TRAIN_DIR, find_python, fit, volatile_files};
use crate::verbs::plan::Plan;

/// What a finished run reports.
#[derive(Debug)]
pub struct RunSummary {
    pub output: PathBuf,
    pub digest: String,
    /// Images rendered by this run.
    pub images: usize,
    /// Images a killed run had finished, which this one resumed.
    pub resumed: usize,
    pub seconds: f64,
    /// The realised debris mix: images of each object, in the campaign's order.
    pub mix: Vec<DebrisCount>,
    /// Wall time of each step this run took (render, dataset, train, detect, manifest),
    /// seconds, in order: the final line gives each one's share of the whole run.
    pub steps: Vec<Step>,
}

/// A step of a run and its wall time, seconds.
pub type Step = (&'static str, f64);

/// How many images of a run show one debris object.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DebrisCount {
    pub object: String,
    pub norad: u64,
    pub images: usize,
}

/// Images per debris object, from the object index of each image.
fn debris_mix(plan: &Plan, shown: impl Iterator<Item = Vec<usize>>) -> Vec<DebrisCount> {
    let mut mix: Vec<DebrisCount> = plan
        .objects
        .debris
        .iter()
        .map(|(name, norad)| DebrisCount {
            object: name.clone(),
            norad: *norad,
            images: 0,
        })
        .collect();
    // A stare points at no debris object (its objects are the population's, in the truth).
    for objects in shown.filter(|_| !plan.objects.stare) {
        let mut objects = objects;
        objects.sort_unstable();
        objects.dedup();
        for i in objects {
            mix[i].images += 1;
        }
    }
    mix
}

/// How [`run_with`] runs a campaign.
#[derive(Clone, Copy, Debug, Default)]
pub struct RunOptions {
    /// Render only this shard's images, into a shard output (see `shard`).
    pub shard: Option<Shard>,
    /// Start afresh rather than resume the staging directory a killed run left.
    pub fresh: bool,
    /// Run even what the work estimate refuses (`work::check_run`).
    pub force: bool,
}

/// Run the campaign into `output`. An existing `output` is replaced only if it is a soig output
/// (it holds a manifest). A `train` stage trains with `python` (default: `find_python`).
pub fn run(
    campaign: &Campaign,
    output: &Path,
    python: Option<&Path>,
    progress: &dyn Progress,
) -> anyhow::Result<RunSummary> {
    run_with(campaign, output, RunOptions::default(), python, progress)
}

/// [`run`], as a shard or without resuming (`options`). The staging directory of a run of the
/// same campaign (and shard) that was killed is resumed: its journaled images are checked
/// against their hashes and only the missing ones rendered.
pub fn run_with(
    campaign: &Campaign,
    output: &Path,
    options: RunOptions,
    python: Option<&Path>,
    progress: &dyn Progress,
) -> anyhow::Result<RunSummary> {
    run_plan(&Plan::new(campaign)?, output, options, python, progress)
}

/// [`run_with`] of a campaign's plan.
pub(crate) fn run_plan(
    plan: &Plan,
    output: &Path,
    options: RunOptions,
    python: Option<&Path>,
    progress: &dyn Progress,
) -> anyhow::Result<RunSummary> {
    if let Some(s) = options.shard {
        s.check_against(plan.images)?;
    }
    // Find the training Python and load the campaign's model before rendering anything, so a
    // missing interpreter or a bad model fails at once, not after every image. A shard neither
    // trains nor detects (its merge does).
    let whole = options.shard.is_none();
    let python = if whole && plan.stages.train {
        Some(find_python(python)?)
    } else {
        None
    };
    if let (true, Some(model)) = (plan.stages.detect, &plan.detect.model) {
        YoloDetector::load(&model.path, plan.detect.yolo)
            .map_err(|e| plan.error_at("detect.model", e.to_string()))?;
    }
    let n = plan.images;
    let images = options.shard.map_or(n, |s| {
        let share = s.images(n);
        share.end - share.start
    });
    plan.check_work(images, options.force)?;
    plan.check_disk(images, output, &|m| progress.note(m))?;
    let inputs = plan.input_hashes()?;
    let id = Identity::new(
        &plan.hash,
        &crate::hash::hash_json(&inputs),
        options.shard.map(|s| (s.index, s.count)),
    );
    let matches = |dir: &Path| -> anyhow::Result<bool> {
        if options.fresh {
            Ok(false)
        } else {
            journal::resumable(dir, &id)
        }
    };
    let note = |message: &str| progress.note(message);
    let resume = Resume {
        matches: &matches,
        note: &note,
    };
    let keep: Vec<&Path> = plan.keep.iter().map(PathBuf::as_path).collect();
    let summary = write_resumable(output, &keep, &resume, |staging| {
        write_all(
            plan,
            staging,
            &id,
            options.shard,
            python.as_deref(),
            progress,
        )
    })?;
    Ok(RunSummary {
        output: output.to_path_buf(),
        ..summary
    })
}

/// The check of a journal or shard record against `plan` (see `journal::Check`): its
/// index within `share`, its debris object one of the campaign's, its files exactly those
/// its image writes, its PNG there exactly when the campaign enhances, with a finite label
/// inside it, and a finite trail angle.
pub(crate) fn record_check<'p>(
    plan: &'p Plan,
    share: std::ops::Range<u64>,
) -> impl Fn(&Record) -> Result<(), String> + Sync + use<'p> {
    let enhance = plan.stages.enhance;
    let debris = plan.objects.debris.len();
    move |r: &Record| {
        if !share.contains(&r.index) {
            return Err(format!(
                "image {} is not one of images {}..{}",
                r.index, share.start, share.end
            ));
        }
        // A stare points at no debris object; a catalogue scene's objects are the population's.
        if let Some(i) = std::iter::once(r.debris_index)
            .filter(|_| !plan.objects.stare)
            .chain(r.objects.iter().flatten().copied())
            .find(|&i| i >= debris)
        {
            return Err(format!(
                "debris index {i} of image {}, the campaign has {debris} debris object(s)",
                r.index,
            ));
        }
        if r.objects.is_some() != plan.objects.listed {
            return Err(format!(
                "image {}: a list of objects where the campaign has no `[objects]`, or none where it has",
                r.index
            ));
        }
        let subset = plan.subset(r.index);
        let expected = artifacts::expected_files(r.index, subset, &plan.artifacts, enhance);
        if !r.files.keys().eq(expected.iter()) {
            return Err(format!(
                "image {} names files {:?}, not its {:?}",
                r.index,
                r.files.keys().collect::<Vec<_>>(),
                expected
            ));
        }
        if r.files.values().any(|sha| sha.len() != 64) {
            return Err(format!("image {}: a file hash is not a sha256", r.index));
        }
        match (&r.png, enhance) {
            (None, false) => {}
            (Some(p), true) => {
                let inside = |b: &[u64; 4]| {
                    let [x0, y0, x1, y1] = b.map(f64::from_bits);
                    [x0, y0, x1, y1].iter().all(|v| v.is_finite())
                        && 0.0 <= x0
                        && x0 <= x1
                        && x1 <= p.width as f64
                        && 0.0 <= y0
                        && y0 <= y1
                        && y1 <= p.height as f64
                };
                let boxes = p.label_bits.iter().chain(&p.more_label_bits);
                if p.width == 0 || p.height == 0 || !boxes.clone().all(inside) {
                    return Err(format!(
                        "image {}: its PNG size or label box is impossible",
                        r.index
                    ));
                }
            }
            _ => {
                return Err(format!(
                    "image {}: a PNG where the campaign writes none, or none where it does",
                    r.index
                ));
            }
        }
        if r.trail_angle_bits
            .is_some_and(|b| !f64::from_bits(b).is_finite())
        {
            return Err(format!("image {}: its trail angle is not finite", r.index));
        }
        if r.footprint_bits
            .is_some_and(|f| f.iter().flatten().any(|&b| !f64::from_bits(b).is_finite()))
        {
            return Err(format!("image {}: its footprint is not finite", r.index));
        }
        Ok(())
    }
}

/// `soig train`: train on the dataset in `out` (written first if it is missing or does not
/// verify), then record the run in the manifest. A campaign whose stages include `train` is
/// simply run: the pipeline trains (and detects with the new model) itself. With a budget,
/// one chunk of the schedule runs; the model is `None` until the last chunk.
pub fn train(
    campaign: &Campaign,
    out: &Path,
    python: Option<&Path>,
    chunk: Chunk,
    progress: &dyn Progress,
) -> anyhow::Result<Option<PathBuf>> {
    let plan = Plan::new(campaign)?;
    if plan.stages.train {
        if chunk.budget_s.is_some() || chunk.epochs.is_some() || chunk.resume {
            anyhow::bail!(
                "--budget, --chunk-epochs and --resume train a dataset in chunks: take `train` out of the campaign's stages"
            );
        }
        // The pipeline finds (and checks) the interpreter itself.
        run_plan(&plan, out, RunOptions::default(), python, progress)?;
        return Ok(Some(out.join(TRAIN_DIR).join("model.onnx")));
    }
    // Refused before anything is written: an output that is or holds an input (the starting
    // weights of a chunk trained before, `OUT/train/.../best.pt`), which training replaces.
    let keep: Vec<&Path> = plan.keep.iter().map(PathBuf::as_path).collect();
    crate::output::check_folder(out, &keep)?;
    let python = find_python(python)?;
    let reusable = out.join(MANIFEST).is_file()
        && manifest::verify(out)
            .is_ok_and(|(m, problems)| problems.is_empty() && m.campaign_hash == plan.hash);
    if !reusable {
        progress.note(&format!(
            "soig train: writing the dataset into {}",
            out.display()
        ));
        run_plan(&plan, out, RunOptions::default(), None, progress)?;
    }
    let trained = fit(&plan, out, &python, chunk, progress)?;
    let old = Manifest::read(out)?;
    let mut volatile = volatile_files(out)?;
    volatile.extend(old.volatile.iter().cloned());
    volatile.sort();
    volatile.dedup();
    seal_manifest(
        out,
        &plan,
        old.campaign.clone(),
        &volatile,
        Some(trained.record),
        old.debris_mix.clone(),
    )?;
    Ok(trained.model)
}

/// Hash `dir` into its manifest with the effective values, the training record and the debris
/// mix, and write it.
fn seal_manifest(
    dir: &Path,
    plan: &Plan,
    resolved: serde_json::Value,
    volatile: &[String],
    training: Option<serde_json::Value>,
    debris_mix: Option<serde_json::Value>,
) -> anyhow::Result<Manifest> {
    let mut m = Manifest::build(dir, &plan.hash, resolved, volatile)?;
    m.debris_mix = debris_mix;
    seal(&mut m, dir, plan, training)?;
    Ok(m)
}

/// Add the effective values and the training record to `m`, seal it and write it into `dir`.
fn seal(
    m: &mut Manifest,
    dir: &Path,
    plan: &Plan,
    training: Option<serde_json::Value>,
) -> anyhow::Result<()> {
    m.effective = Some(plan.effective.clone());
    if training.is_some() {
        m.training = training;
    }
    m.inputs = plan.input_hashes()?;
    m.seal();
    m.write(dir)?;
    Ok(())
}

/// Write the campaign (or its shard) into staging directory `dir`, resuming what its journal
/// holds. The summary's `output` is `dir`.
fn write_all(
    plan: &Plan,
    dir: &Path,
    id: &Identity,
    shard: Option<Shard>,
    python: Option<&Path>,
    progress: &dyn Progress,
) -> anyhow::Result<RunSummary> {
    // Killed while moving a finished output into place: it only needs the move.
    if let Some(m) = journal::complete(dir, id) {
        progress.note("the run killed earlier had finished; moving its output into place");
        let mix = m
            .debris_mix
            .and_then(|v| serde_json::from_value(v).ok())
            .unwrap_or_default();
        return Ok(RunSummary {
            output: dir.to_path_buf(),
            digest: m.digest,
            images: 0,
            resumed: 0,
            seconds: 0.0,
            mix,
            steps: Vec::new(),
        });
    }
    let n = plan.images;
    let share = shard.map_or(0..n, |s| s.images(n));
    let check = record_check(plan, share.clone());
    let (journal, done) = Journal::open(dir, id, &check)?;
    let resumed = done.len();
    let (records, rendered, seconds) = render(plan, dir, &journal, done, share, progress)?;
    let mut steps = vec![("render", seconds)];
    let (digest, mix) = match shard {
        Some(s) => {
            let started = Instant::now();
            let seal = crate::shard::Seal {
                hash: &plan.hash,
                resolved: &plan.resolved,
                images: plan.images,
                campaign_dir: &plan.campaign_dir,
                inputs: plan.input_hashes()?,
            };
            let digest = crate::shard::seal(&seal, dir, s, &records)?;
            steps.push(("manifest", started.elapsed().as_secs_f64()));
            (digest, Vec::new())
        }
        None => {
            let (digest, mix, finished) = finish(plan, dir, &records, python, progress)?;
            steps.extend(finished);
            (digest, mix)
        }
    };
    journal::remove(dir)?;
    Ok(RunSummary {
        output: dir.to_path_buf(),
        digest,
        images: rendered,
        resumed,
        seconds,
        mix,
        steps,
    })
}

/// Render the images of `share` that `done` lacks into `dir`, journaling each. Returns the
/// records of every image of `share`, by index, how many were rendered and the time taken.
fn render(
    plan: &Plan,
    dir: &Path,
    journal: &Journal,
    mut done: Vec<Record>,
    share: std::ops::Range<u64>,
    progress: &dyn Progress,
) -> anyhow::Result<(Vec<Record>, usize, f64)> {
    let enhance_stage = plan.stages.enhance;
    let dataset_stage = plan.stages.dataset;

    let mut dirs = vec![dir.join("truth")];
    if plan.artifacts.fits || plan.artifacts.noise_free_fits {
        dirs.push(dir.join("fits"));
    }
    if enhance_stage {
        if dataset_stage {
            for s in [Subset::Train, Subset::Val, Subset::Test] {
                dirs.push(dir.join("images").join(s.name()));
                dirs.push(dir.join("labels").join(s.name()));
            }
        } else {
            dirs.push(dir.join("images"));
            dirs.push(dir.join("labels"));
        }
        let streak_sets = crate::streak_labels::dirs(&plan.artifacts, dataset_stage);
        dirs.extend(streak_sets.iter().map(|d| dir.join(d)));
    }
    for d in &dirs {
        store::fs::create_dir_all(d)?;
    }

    let x = &plan.experiment;
    let inputs = plan.inputs()?;
    let have: std::collections::BTreeSet<u64> = done.iter().map(|r| r.index).collect();
    let todo: Vec<u64> = share.filter(|i| !have.contains(i)).collect();
    progress.start("render", todo.len() as u64);
    let journaled = std::sync::atomic::AtomicUsize::new(0);
    let started = Instant::now();
    let rendered: Vec<Record> = todo
        .par_iter()
        .map(|&i| -> anyhow::Result<Record> {
            crate::progress::check(progress)?;
            let subset = plan.subset(i);
            let products = simulate::image(x, &inputs, i).map_err(|e| {
                // Draws meet the checks in turn, so a rare reason can be the one that matters.
                let fields: Vec<String> = e
                    .reasons_by_count()
                    .into_iter()
                    .map(|r| format!("{r}: {}", rejection_fields(r)))
                    .collect();
                let at = plan.error_at(
                    &format!("debris[{}]", e.debris_index),
                    format!(
                        "{e}; remove the object, lower its `weight` or relax the rules (an object no draw shows is an error, not a silently smaller share); what decides each rejection: {}",
                        fields.join("; ")
                    ),
                );
                anyhow::anyhow!("{at}")
            })?;
            // Never a non-finite pixel in an output (an extreme gain or frame could make one).
            let bad = products
                .exposure
                .adu
                .iter()
                .filter(|v| !v.is_finite())
                .count();
            if bad > 0 {
                return Err(plan.non_finite_pixels(i, bad));
            }
            let image = artifacts::write_image(
                dir,
                i,
                &products,
                subset,
                &plan.artifacts,
                &plan.provenance,
                &x.sensor,
            )?;
            let conversion_s = products.product.as_ref().map_or(0.0, |p| p.seconds)
                + image.png.as_ref().map_or(0.0, |p| p.seconds);
            let trail_angle_deg: Option<f64> = match (&products.scene.exposure.pointing, plan.frame) {
                (Pointing::Fixed { .. }, _) => None,
                (_, FrameKind::Rotated) => Some(0.0),
                (p, _) => p.trail_angle_deg(),
            };
            let record = Record {
                index: i,
                debris_index: products.scene.object.debris_index,
                // A catalogue scene's objects are in its truth, not the campaign's debris.
                objects: products
                    .scene
                    .placed
                    .as_ref()
                    .filter(|_| products.scene.unseen.is_none())
                    .map(|placed| placed.iter().map(|s| s.object.debris_index).collect()),
                files: journal::hash_files(dir, &image.files)?,
                png: image
                    .png
                    .map(|p| PngRecord::new(p.width, p.height, &p.labels)),
                trail_angle_bits: trail_angle_deg.map(f64::to_bits),
                footprint_bits: products
                    .product
                    .as_ref()
                    .and_then(|p| p.frame.footprint(products.exposure.width, products.exposure.height))
                    .map(|f| f.map(|c| c.map(f64::to_bits))),
                conversion_s: Some(conversion_s),
            };
            journal.append(&record)?;
            let k = journaled.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1;
            journal::abort_if_testing(&format!("render:{k}"));
            progress.advance();
            Ok(record)
        })
        .collect::<anyhow::Result<_>>()?;
    progress.finish();
    let seconds = started.elapsed().as_secs_f64();
    let count = rendered.len();
    done.extend(rendered);
    done.sort_by_key(|r| r.index);
    Ok((done, count, seconds))
}

/// What each image of `records` left for the detect stage, its files in `dir` (a run's
/// staging directory, a merge's, or a shard's).
pub(crate) fn written(plan: &Plan, dir: &Path, records: &[Record]) -> Vec<Written> {
    records
        .iter()
        .map(|r| {
            let subset = plan.subset(r.index);
            Written {
                index: r.index,
                subset,
                png: r.png.as_ref().map(|p| WrittenPng {
                    path: dir.join(artifacts::dataset_paths(r.index, subset).0),
                    width: p.width,
                    height: p.height,
                    labels: p.labels(),
                    seconds: 0.0,
                }),
                conversion_s: r.conversion_s,
                trail_angle_deg: r.trail_angle_bits.map(f64::from_bits),
                footprint: r.footprint_bits.map(|f| f.map(|c| c.map(f64::from_bits))),
            }
        })
        .collect()
}

/// The steps after rendering, on the images of `records` (every image of the campaign, by
/// index) in `dir`: `data.yaml`, training, detection and report, and the manifest, whose
/// digest is returned with the debris mix and each step's wall time. A single run and a merge
/// of shards both end here.
pub(crate) fn finish(
    plan: &Plan,
    dir: &Path,
    records: &[Record],
    python: Option<&Path>,
    progress: &dyn Progress,
) -> anyhow::Result<(String, Vec<DebrisCount>, Vec<Step>)> {
    let mut steps = Vec::new();
    let mut step = Instant::now();
    let mut lap = |name: &'static str| {
        steps.push((name, step.elapsed().as_secs_f64()));
        step = Instant::now();
    };
    let written = written(plan, dir, records);

    if plan.stages.dataset {
        store::fs::create(
            &dir.join("data.yaml"),
            dataset::data_yaml(&plan.name, &plan.hash),
        )?;
        for set in crate::streak_labels::sets(&plan.artifacts) {
            store::fs::create(
                &dir.join(set.dir()).join("data.yaml"),
                set.data_yaml(&plan.name, &plan.hash),
            )?;
        }
    }
    // A breakup cloud's fragments: their fitted orbits, for an independent propagation.
    crate::population_omm::write(dir, plan.population())?;
    if plan.collect_frames > 1 {
        let indices: Vec<u64> = records.iter().map(|r| r.index).collect();
        crate::collect::write_manifests(dir, &indices, |i| plan.subset(i))?;
    }
    journal::abort_if_testing("dataset");
    // The dataset's own digest goes into the report: taken before training and detection add
    // their files.
    // The images' files were hashed as they were written (or checked at a resume or merge).
    let known: BTreeMap<&str, &str> = records
        .iter()
        .flat_map(|r| r.files.iter().map(|(f, sha)| (f.as_str(), sha.as_str())))
        .collect();
    let dataset_digest = if plan.stages.detect {
        Manifest::build_knowing(dir, &plan.hash, plan.resolved.clone(), &[], &known)?.digest
    } else {
        String::new()
    };
    lap("dataset");
    let trained = match python {
        Some(python) => Some(fit(plan, dir, python, Chunk::default(), progress)?),
        None => None,
    };
    if trained.is_some() {
        lap("train");
    }
    if plan.stages.detect {
        // A train stage's model, else the campaign's (validation allows one, not both).
        let model = match &trained {
            Some(t) => t.model.clone(),
            None => plan.detect.model.as_ref().map(|m| m.path.clone()),
        };
        detect_and_report(
            plan,
            dir,
            &written,
            &dataset_digest,
            model.as_deref(),
            progress,
        )?;
        lap("detect");
    }
    // The exports read the labels and the predictions back, so they come after the report.
    let a = &plan.artifacts;
    if a.coco || a.ds9_regions || a.tdm {
        let formats = crate::export::Formats {
            coco: a.coco,
            ds9: a.ds9_regions,
            tdm: a.tdm,
        };
        crate::export::write(
            dir,
            &plan.resolved,
            &dir.join(crate::export::EXPORT_DIR),
            formats,
        )?;
    }
    let mut volatile: Vec<String> = report::VOLATILE
        .iter()
        .filter(|v| dir.join(v).is_file())
        .map(|v| v.to_string())
        .collect();
    if trained.is_some() {
        volatile.extend(volatile_files(dir)?);
    }
    let mix = debris_mix(plan, records.iter().map(Record::shown));
    let mut manifest =
        Manifest::build_knowing(dir, &plan.hash, plan.resolved.clone(), &volatile, &known)?;
    manifest.debris_mix = Some(serde_json::to_value(&mix)?);
    seal(&mut manifest, dir, plan, trained.map(|t| t.record))?;
    journal::abort_if_testing("manifest");
    lap("manifest");
    Ok((manifest.digest, mix, steps))
}

/// The campaign fields that decide a scene-draw rejection (`scene::try_draw`).
fn rejection_fields(reason: Rejection) -> &'static str {
    match reason {
        Rejection::EarthAngle => "`visibility.earth_min_deg` (and the observer's attitude)",
        Rejection::SunAngle => "`visibility.sun_min_deg`",
        Rejection::MoonAngle => "`visibility.moon_min_deg`",
        Rejection::ThroughEarth => {
            "`visibility.earth_clearance_km` and the observer's and debris' orbits"
        }
        Rejection::EarthShadow => "the `window` and the debris' orbits (rarely sunlit)",
        Rejection::TooFaint => "`sensor.mag_limit`, `photometry` and the debris' ranges",
        Rejection::BrightStar => "`visibility.brightest_star_mag`",
        Rejection::LowSnr => "`visibility.snr_min`, `visibility.snr_definition` and `exposure`",
        Rejection::PropagationFailed => "the `window` and the orbits' epochs",
        Rejection::TooFast => "`exposure.max_s` and `render.trajectory_samples`",
        Rejection::TrackTooFast => {
            "`exposure.max_s` (track pointing follows the debris' apparent motion)"
        }
        Rejection::CollectPastWindow => "`collect.frames`, `collect.gap_s` and the `window`",
        Rejection::Daylight => "`observer.site.sun_max_alt_deg` and the `window`",
        Rejection::BelowHorizon => "`observer.site.min_alt_deg` and the debris' orbits",
    }
}
