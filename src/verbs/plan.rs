//! What a run of a campaign does, derived once: [`Plan::new`] reads the campaign (its stages,
//! split, artifacts, detectors, training and the `Experiment` the core is given) and the verbs
//! take a `&Plan`, reading no campaign field themselves. What still goes back to the campaign is
//! what must: its error messages, which name its file, line and field ([`Plan::error_at`]), and
//! the files a run reads when it starts ([`Plan::inputs`], [`Plan::input_hashes`]).
//!
//! The plan holds values of the product layer (the split, the provenance), so it sits with the
//! verbs that take it, above `product`, not in `config`.

use std::path::{Path, PathBuf};

use crate::artifacts::Provenance;
use crate::campaign::{
    Artifacts, Background, Campaign, CampaignError, Detect, PointingMode, Render, Stage, StarHint,
    Train,
};
use crate::dataset::{self, Subset};
use crate::detect::streak::StreakParams;
use crate::detect::yolo::YoloParams;
use crate::enhance;
use crate::experiment;
use crate::geometry::FrameKind;
use crate::scene::{Body, Inputs};
use crate::simulate::Experiment;

/// A campaign's run, derived once from it.
pub struct Plan<'c> {
    campaign: &'c Campaign,
    pub name: String,
    /// sha256 of the campaign's canonical JSON.
    pub hash: String,
    pub seed: u64,
    pub images: u64,
    pub stages: Stages,
    /// Frames per collect (1 without `[collect]`).
    pub collect_frames: u32,
    /// Each image's subset of the split (collects kept together); None without a dataset stage.
    pub subsets: Option<Vec<Subset>>,
    pub artifacts: Artifacts,
    /// What each image's files say of where they come from.
    pub provenance: Provenance,
    /// What the core is given: sensor, scene, render and enhancement settings.
    pub experiment: Experiment,
    /// The campaign with its defaults filled, as manifests record it.
    pub resolved: serde_json::Value,
    /// The values resolved late (pixel scale, PSF, frame, training size), for the manifest.
    pub effective: serde_json::Value,
    /// The frame the PNGs are drawn in.
    pub frame: FrameKind,
    /// The enhancement of the PNGs, which `soig detect` also applies to the frames it is given.
    pub enhance: enhance::Settings,
    /// The campaign's `[render]` as written (`soig study` states it).
    pub render: Render,
    pub objects: Objects,
    pub detect: DetectPlan,
    pub train: TrainPlan,
    /// What an output may not be or contain: the campaign's folder and its input files.
    pub keep: Vec<PathBuf>,
    /// The campaign's folder, against which its relative paths resolve.
    pub campaign_dir: PathBuf,
    /// The campaign file, for the record of where settings came from.
    pub source: PathBuf,
}

/// Which of the stages after `render` a run has (the campaign's list is a prefix of them in
/// order, checked when it loads).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stages {
    pub enhance: bool,
    pub dataset: bool,
    pub train: bool,
    pub detect: bool,
}

/// The objects a campaign names.
pub struct Objects {
    /// The debris objects `(name, norad)`, in the campaign's order: the images' debris indices
    /// point here.
    pub debris: Vec<(String, u64)>,
    /// Whether the campaign places several objects a frame (`[objects]`): its records list them.
    pub listed: bool,
    /// A stare points at no debris object (its objects are the population's, in the truth).
    pub stare: bool,
}

/// What the detect stage runs.
pub struct DetectPlan {
    /// The run has the classical streak detector (`[detect] classical`).
    pub classical: bool,
    /// The campaign's `[detect.streak]`: the run's classical detector, and what `soig detect`
    /// runs with the campaign whether or not the run has it.
    pub streak: StreakParams,
    /// The streak detector is told of the stars (`stars = "catalogue"`); otherwise it measures
    /// the trails on each frame.
    pub told: bool,
    /// Survey pointing told of the stars: each image's predicted star trails (`star_trails`).
    pub star_trails: bool,
    pub yolo: YoloParams,
    /// The campaign's model (`detect.model`); a train stage's replaces it.
    pub model: Option<CampaignModel>,
    /// The report's confidence threshold.
    pub conf: f64,
    /// The report's row kind: pointing, frame and background.
    pub row_kind: String,
    /// Observations from the detections (`artifacts.astrometry`).
    pub astrometry: Option<AstrometryPlan>,
}

/// The model a campaign names (`detect.model`).
pub struct CampaignModel {
    /// Resolved against the campaign's folder.
    pub path: PathBuf,
    /// As the campaign names it, for the report.
    pub name: String,
    /// `detect.model_sha256`, filled in when the campaign is resolved.
    pub sha256: Option<String>,
}

/// What the astrometric report needs of the campaign.
pub struct AstrometryPlan {
    /// The streak detector's PSF sigma in PNG pixels.
    pub psf_sigma_px: f64,
    /// The observer's name for the files.
    pub observer: String,
    /// Apparent or geometric places, for the files' notes.
    pub apparent: bool,
}

/// What a train stage (or `soig train`) runs.
pub struct TrainPlan {
    /// The campaign's `[train]`.
    pub settings: Train,
    /// Network input side and batch (the campaign's or the paper's for the frame).
    pub imgsz: u32,
    pub batch: u32,
    /// Starting weights (`train.model` ending in `.pt`), resolved against the campaign's folder.
    pub weights: Option<PathBuf>,
}

impl<'c> Plan<'c> {
    /// The run `campaign` asks for.
    pub fn new(campaign: &'c Campaign) -> anyhow::Result<Plan<'c>> {
        let c = &campaign.resolved;
        let has = |s: Stage| c.stages.contains(&s);
        let stages = Stages {
            enhance: has(Stage::Enhance),
            dataset: has(Stage::Dataset),
            train: has(Stage::Train),
            detect: has(Stage::Detect),
        };
        let subsets = stages.dataset.then(|| {
            dataset::assign_collects(
                c.seed,
                c.images as usize,
                c.collect_frames() as usize,
                c.split.train,
                c.split.val,
            )
        });
        let experiment = experiment::of(campaign);
        let effective = serde_json::to_value(experiment::effective(&experiment, campaign))?;
        let d = &c.detect;
        let astrometry = c.artifacts.astrometry.then(|| {
            let observer = serde_json::to_value(&c.observer).unwrap_or_default();
            AstrometryPlan {
                psf_sigma_px: d.streak.psf_sigma_px,
                observer: observer["name"]
                    .as_str()
                    .map(String::from)
                    .or_else(|| observer["norad"].as_u64().map(|n| format!("NORAD {n}")))
                    .unwrap_or_else(|| "observer".to_string()),
                apparent: c.render.apparent_positions,
            }
        });
        let told = d.stars == StarHint::Catalogue;
        let detect = DetectPlan {
            classical: d.classical,
            streak: d.streak.clone(),
            told,
            star_trails: told && c.pointing.mode == PointingMode::Survey,
            yolo: yolo_params(d),
            model: d.model.as_ref().map(|m| CampaignModel {
                path: campaign.base_dir.join(m),
                name: m.clone(),
                sha256: d.model_sha256.clone(),
            }),
            conf: d.conf,
            row_kind: row_kind(c),
            astrometry,
        };
        let (imgsz, batch) = experiment::train_size_and_batch(campaign);
        let train = TrainPlan {
            settings: c.train.clone(),
            imgsz,
            batch,
            weights: c
                .train
                .model
                .ends_with(".pt")
                .then(|| campaign.base_dir.join(&c.train.model)),
        };
        let mut keep = vec![campaign.base_dir.clone()];
        keep.extend(campaign.input_paths());
        Ok(Plan {
            campaign,
            name: c.name.clone(),
            hash: campaign.hash.clone(),
            seed: c.seed,
            images: u64::from(c.images),
            stages,
            collect_frames: c.collect_frames(),
            subsets,
            artifacts: c.artifacts.clone(),
            provenance: Provenance::of(campaign),
            experiment,
            resolved: serde_json::to_value(c)?,
            effective,
            frame: c.enhance.geometry,
            enhance: experiment::enhance_settings(Some(campaign)),
            render: c.render.clone(),
            objects: Objects {
                debris: campaign
                    .world
                    .debris
                    .iter()
                    .map(|b| (b.name.clone(), b.norad))
                    .collect(),
                listed: c.objects.is_some(),
                stare: c.pointing.stare.is_some(),
            },
            detect,
            train,
            keep,
            campaign_dir: campaign.base_dir.clone(),
            source: campaign.source.clone(),
        })
    }

    /// The objects of `[population]` (a catalogue's or a breakup cloud's; empty without),
    /// borrowed: a catalogue of tens of thousands is not copied into the plan.
    pub fn population(&self) -> &'c [Body] {
        &self.campaign.world.population
    }

    /// The subset of image `i`, where the run splits its images.
    pub fn subset(&self, i: u64) -> Option<Subset> {
        self.subsets.as_ref().map(|s| s[i as usize])
    }

    /// An error at `field` of the campaign, with its file and line.
    pub fn error_at(&self, field: &str, message: String) -> CampaignError {
        self.campaign.error_at(field, message)
    }

    /// Read what the run needs before its first image: bodies, stars and background frames.
    pub fn inputs(&self) -> Result<Inputs, crate::Error> {
        experiment::inputs(self.campaign)
    }

    /// The hashes of the files the run reads besides the campaign, read now.
    pub fn input_hashes(&self) -> anyhow::Result<std::collections::BTreeMap<String, String>> {
        Ok(self.campaign.input_hashes()?)
    }

    /// Refuse a run of `images` images whose work is beyond the limits, unless `force`.
    pub fn check_work(&self, images: u64, force: bool) -> Result<(), CampaignError> {
        crate::work::check_run(self.campaign, images, force)
    }

    /// Refuse a run of `images` images into `output` when its disk cannot hold them.
    pub fn check_disk(
        &self,
        images: u64,
        output: &Path,
        note: &dyn Fn(&str),
    ) -> anyhow::Result<()> {
        crate::disk::check(self.campaign, images, output, note)
    }

    /// The error for non-finite pixels in image `i`'s noisy image (an extreme gain or frame),
    /// naming the settings that make them.
    pub fn non_finite_pixels(&self, i: u64, bad: usize) -> anyhow::Error {
        let c = &self.campaign.resolved;
        anyhow::anyhow!(
            "image {i}: {bad} non-finite pixels in the noisy image (sensor.gain_e_per_adu {}, background {:?})",
            c.sensor.gain_e_per_adu,
            c.background
        )
    }
}

/// The YOLO detector's settings of a `[detect]` table.
pub fn yolo_params(d: &Detect) -> YoloParams {
    YoloParams {
        conf: d.conf,
        iou: d.iou,
        max_det: d.max_det as usize,
        ..YoloParams::default()
    }
}

/// The report's row kind: pointing, frame and background (`survey, rotated and expanded
/// frame, semisynthetic`).
fn row_kind(c: &crate::campaign::CampaignFile) -> String {
    let geometry = match c.enhance.geometry {
        FrameKind::Original => "original frame",
        FrameKind::Padded => "padded frame",
        FrameKind::Rotated => "rotated and expanded frame",
    };
    let kind = match c.background {
        Background::Uniform => "synthetic",
        Background::Frames { .. } => "semisynthetic",
    };
    let mode = match c.pointing.mode {
        PointingMode::Fixed => "fixed",
        PointingMode::Survey => "survey",
        PointingMode::Track => "track",
    };
    format!("{mode}, {geometry}, {kind}")
}
