//! The campaign file: its TOML types (with the JSON Schema derived from them), the paper's defaults
//! (with the corrections of `physics.md`), validation with errors that name file, line and field,
//! and the resolved campaign whose hash pins every output.
//!
//! All paths inside a campaign are relative to the directory of the campaign file.

use std::path::{Path, PathBuf};

use hifitime::Epoch;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::detect::streak::StreakParams;
pub use crate::geometry::FrameKind;
pub use crate::render::RenderMethod;
pub use crate::scene::{Body, PointingMode};
use crate::sky::orbit::{self, OrbitalElements, Propagator, Tle};

/// A campaign as written in TOML. Every section is optional and defaults to the paper's values.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CampaignFile {
    /// Short name of the campaign, used in reports and as the default output folder name.
    pub name: String,
    /// Master seed: every image draws its own random stream from (seed, image index).
    #[serde(default)]
    pub seed: u64,
    /// Number of images to generate (the paper uses 4000 per scenario).
    #[serde(default = "defaults::images")]
    pub images: u32,
    /// Output directory, relative to the campaign file (default `runs/<name>` beside it).
    /// Not part of the campaign hash.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
    /// The observing satellite (the paper: SENTINEL-3A, NORAD 41335).
    pub observer: ObjectSpec,
    /// The debris set; each image shows one of them, drawn uniformly.
    pub debris: Vec<ObjectSpec>,
    #[serde(default)]
    pub window: Window,
    #[serde(default)]
    pub exposure: Exposure,
    #[serde(default)]
    pub pointing: Pointing,
    #[serde(default)]
    pub sensor: Sensor,
    #[serde(default)]
    pub stars: Stars,
    #[serde(default)]
    pub background: Background,
    #[serde(default)]
    pub photometry: Photometry,
    #[serde(default)]
    pub visibility: Visibility,
    #[serde(default)]
    pub render: Render,
    #[serde(default)]
    pub enhance: Enhance,
    #[serde(default)]
    pub split: Split,
    #[serde(default)]
    pub artifacts: Artifacts,
    #[serde(default)]
    pub detect: Detect,
    #[serde(default)]
    pub train: Train,
    /// Pipeline stages to run, in order; each needs the ones before it.
    #[serde(default = "defaults::stages")]
    pub stages: Vec<Stage>,
}

/// A satellite or debris object: give exactly one of `tle`, `tle_file` (with `norad`) or `elements`.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    /// Display name (default: the TLE name line, or `NORAD <id>`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// NORAD catalogue number; selects the object in `tle_file`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub norad: Option<u64>,
    /// The two TLE lines.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tle: Option<[String; 2]>,
    /// A file of 2- or 3-line TLE sets, relative to the campaign file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tle_file: Option<String>,
    /// Mean orbital elements, for objects with no public TLE (the paper's NORAD 40649).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub elements: Option<ElementsSpec>,
}

/// Orbital elements as in the paper's Table 1.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ElementsSpec {
    pub period_min: f64,
    pub inclination_deg: f64,
    pub apogee_km: f64,
    pub perigee_km: f64,
    #[serde(default)]
    pub raan_deg: f64,
    #[serde(default)]
    pub arg_perigee_deg: f64,
    #[serde(default)]
    pub mean_anomaly_deg: f64,
    /// Epoch of the elements, UTC, e.g. `2022-01-01T00:00:00 UTC` (default: start of the window).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub epoch: Option<String>,
}

/// UTC window in which each image's start time is drawn uniformly.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Window {
    /// e.g. `2022-01-01T00:00:00 UTC`
    #[serde(default = "defaults::window_start")]
    pub start: String,
    #[serde(default = "defaults::window_end")]
    pub end: String,
}

/// Exposure time, drawn uniformly per image.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Exposure {
    #[serde(default = "defaults::exposure_min")]
    pub min_s: f64,
    #[serde(default = "defaults::exposure_max")]
    pub max_s: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Pointing {
    #[serde(default)]
    pub mode: PointingMode,
    /// The debris position at mid-exposure is placed uniformly within this fraction of the
    /// field radius (in each axis) from the image centre.
    #[serde(default = "defaults::placement_fraction")]
    pub placement_fraction: f64,
}

/// The camera and detector.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Sensor {
    #[serde(default = "defaults::image_px")]
    pub width_px: u32,
    #[serde(default = "defaults::image_px")]
    pub height_px: u32,
    /// Half the field of view along the image width; the pixel scale is fov_radius / (width/2).
    #[serde(default = "defaults::fov_radius")]
    pub fov_radius_deg: f64,
    /// Instrumental zero point: the magnitude that gives 1 photo-electron per second.
    /// The paper's "ZP = 2.74" in SPIMT's convention `10^(-0.4 (m - 25 + ZP))` is 25 - 2.74 = 22.26.
    #[serde(default = "defaults::zero_point")]
    pub zero_point_mag: f64,
    /// Photo-electrons per ADU (TELEDYNE CCD47-20: 1.6).
    #[serde(default = "defaults::gain")]
    pub gain_e_per_adu: f64,
    /// Sky background per pixel, uniform in [min, max] ADU for `background_exposure_s`,
    /// scaled linearly with exposure.
    #[serde(default = "defaults::background_min")]
    pub background_min_adu: f64,
    #[serde(default = "defaults::background_max")]
    pub background_max_adu: f64,
    #[serde(default = "defaults::background_exposure")]
    pub background_exposure_s: f64,
    /// Bias per pixel, uniform in [min, max] ADU.
    #[serde(default = "defaults::bias_min")]
    pub bias_min_adu: f64,
    #[serde(default = "defaults::bias_max")]
    pub bias_max_adu: f64,
    /// Faintest magnitude the sensor detects (debris and catalogue stars).
    #[serde(default = "defaults::mag_limit")]
    pub mag_limit: f64,
    /// Gaussian PSF standard deviation on the sky.
    #[serde(default = "defaults::psf_sigma")]
    pub psf_sigma_arcsec: f64,
    /// Brownian pointing jitter sigma_A = sigma_D (Eq. 2), degrees per sqrt(second).
    #[serde(default = "defaults::jitter")]
    pub jitter_deg_per_sqrt_s: f64,
}

/// Where field stars come from, and the cone loaded around the pointing.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(tag = "source", rename_all = "lowercase", deny_unknown_fields)]
pub enum Stars {
    /// A procedural sky, deterministic per region: the same sky in every image and campaign
    /// with the same `sky_seed`.
    Procedural {
        #[serde(default)]
        sky_seed: u64,
        /// Radius of the cone of stars loaded around the pointing (fixed pointing: 0.15 deg).
        #[serde(default = "defaults::star_cone")]
        cone_radius_deg: f64,
    },
    /// A CSV catalogue (Gaia archive, VizieR or plain ra,dec,pmra,pmdec,mag columns).
    Catalog {
        /// Path relative to the campaign file.
        path: String,
        /// Epoch of the catalogue positions, Julian year (Gaia DR3: 2016.0).
        #[serde(default = "defaults::catalog_epoch")]
        epoch_jyear: f64,
        #[serde(default = "defaults::star_cone")]
        cone_radius_deg: f64,
    },
}

impl Stars {
    pub fn cone_radius_deg(&self) -> f64 {
        match self {
            Stars::Procedural {
                cone_radius_deg, ..
            }
            | Stars::Catalog {
                cone_radius_deg, ..
            } => *cone_radius_deg,
        }
    }
}

/// The sky background: the paper's uniform synthetic background (parameters in `sensor`), or
/// real frames whose noise replaces it (semisynthetic images, paper 3.4).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq, Default)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum Background {
    #[default]
    Uniform,
    /// FITS frames (with EXPTIME or EXPOSURE), relative to the campaign file; each image takes one at
    /// random, normalised by its exposure, scaled to the image's and tiled (see `background`).
    Frames { paths: Vec<String> },
}

/// Debris photometry (Eq. 6-7) and light-curve modulation.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Photometry {
    /// Effective area A = |N(mean, std)| m^2, drawn per image.
    #[serde(default = "defaults::rcs_mean")]
    pub rcs_mean_m2: f64,
    #[serde(default = "defaults::rcs_std")]
    pub rcs_std_m2: f64,
    /// Reflection coefficient rho.
    #[serde(default = "defaults::albedo")]
    pub albedo: f64,
    #[serde(default)]
    pub light_curve: LightCurve,
}

/// Brightness modulation over the exposure.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum LightCurve {
    /// Constant brightness.
    None,
    /// A tumbling object: flux times (1 + a sin(2 pi t / P + phase)), with P uniform in
    /// [period_min_s, period_max_s], a uniform in [0, amplitude_max] and a uniform phase.
    Tumbling {
        #[serde(default = "defaults::tumble_period_min")]
        period_min_s: f64,
        #[serde(default = "defaults::tumble_period_max")]
        period_max_s: f64,
        #[serde(default = "defaults::tumble_amplitude")]
        amplitude_max: f64,
    },
}

impl Default for LightCurve {
    fn default() -> Self {
        LightCurve::Tumbling {
            period_min_s: defaults::tumble_period_min(),
            period_max_s: defaults::tumble_period_max(),
            amplitude_max: defaults::tumble_amplitude(),
        }
    }
}

/// Scene acceptance rules (paper 3.2.2 and 3.2.6).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Visibility {
    /// Minimum angle between the line of sight and the direction to the Earth's centre.
    #[serde(default = "defaults::earth_min")]
    pub earth_min_deg: f64,
    #[serde(default = "defaults::sun_min")]
    pub sun_min_deg: f64,
    #[serde(default = "defaults::moon_min")]
    pub moon_min_deg: f64,
    /// The line of sight must clear the Earth's surface by this height (atmosphere).
    #[serde(default = "defaults::clearance")]
    pub earth_clearance_km: f64,
    /// An image is rejected when a star brighter than this is in the star cone.
    #[serde(default = "defaults::brightest_star")]
    pub brightest_star_mag: f64,
    /// Minimum debris signal / background noise (see `scene::snr`); default 0.15 for fixed
    /// pointing, 0.035 for survey.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub snr_min: Option<f64>,
    /// Scene draws tried per image before the campaign fails.
    #[serde(default = "defaults::max_attempts")]
    pub max_attempts: u32,
}

/// Photon-mapping settings (each an approximation knob).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Render {
    /// Points the debris trajectory is cut into over the exposure.
    #[serde(default = "defaults::trajectory_samples")]
    pub trajectory_samples: u32,
    /// Sources with more photons than this are traced in packets of `merge_factor` photons.
    #[serde(default = "defaults::merge_threshold")]
    pub merge_threshold: u64,
    #[serde(default = "defaults::merge_factor")]
    pub merge_factor: u32,
    /// Steps of the Brownian jitter path over the exposure.
    #[serde(default = "defaults::jitter_steps")]
    pub jitter_steps: u32,
    /// How photons reach the detector: `photon_mapping` (the paper's Monte Carlo, with the
    /// merging approximation) or `expected` (each source's expected photons per pixel, the PSF
    /// integrated over pixels along its path, then one Poisson draw per pixel: the same
    /// distribution as photon mapping without merging). Omitted from the resolved campaign
    /// when it is the default, so existing campaign hashes stay.
    #[serde(default, skip_serializing_if = "RenderMethod::is_photon_mapping")]
    pub method: RenderMethod,
}

/// FITS -> PNG enhancement (paper 3.3).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Enhance {
    /// Square-root compression first (the paper applies it to fixed pointing only).
    #[serde(default = "defaults::yes")]
    pub sqrt: bool,
    /// CLAHE clip limit and tile grid, as `cv2.createCLAHE(clipLimit, tileGridSize)`.
    #[serde(default = "defaults::clahe_clip")]
    pub clahe_clip_limit: f64,
    #[serde(default = "defaults::clahe_tiles")]
    pub clahe_tiles: [u32; 2],
    /// Power-law correction O = I^gamma on [0, 1].
    #[serde(default = "defaults::gamma")]
    pub gamma: f64,
    /// Frame of the PNGs and labels: `original`, `padded` (noise border of `pad_px` on each
    /// side: 1024 -> 1088) or `rotated` (survey only: star trails horizontal, 1024 -> 1472).
    #[serde(default)]
    pub geometry: FrameKind,
    #[serde(default = "defaults::pad_px")]
    pub pad_px: u32,
}

/// Dataset split ratios; they must sum to 1.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Split {
    #[serde(default = "defaults::split_train")]
    pub train: f64,
    #[serde(default = "defaults::split_val")]
    pub val: f64,
    #[serde(default = "defaults::split_test")]
    pub test: f64,
}

/// Optional artifacts.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Artifacts {
    /// The noisy image as FITS (float32 ADU) with WCS.
    #[serde(default = "defaults::yes")]
    pub fits: bool,
    /// The noise-free image (photon counts) as FITS.
    #[serde(default)]
    pub noise_free_fits: bool,
    /// The stars traced in each image (ra, dec, mag, pixel x, y) as `truth/<image>_stars.csv`,
    /// for astrometric checks.
    #[serde(default)]
    pub star_list: bool,
}

/// Training through Ultralytics (`soig train`); the paper's hyperparameters by default.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Train {
    /// Ultralytics model: a YAML trains from scratch (no download needed); a .pt (relative to
    /// the campaign file) fine-tunes those weights.
    #[serde(default = "defaults::train_model")]
    pub model: String,
    #[serde(default = "defaults::train_epochs")]
    pub epochs: u32,
    /// Batch size (the paper: 16, and 10 for the 1472 px rotated images); default by frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub batch: Option<u32>,
    /// Training image size; default: the PNG frame's width (1024, 1088 or 1472).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub imgsz: Option<u32>,
    #[serde(default = "defaults::train_optimizer")]
    pub optimizer: String,
    /// `auto` (a CUDA GPU when present), `cpu`, or a GPU index such as `0`.
    #[serde(default = "defaults::train_device")]
    pub device: String,
    #[serde(default)]
    pub seed: u64,
    #[serde(default = "defaults::train_workers")]
    pub workers: u32,
    #[serde(default = "defaults::train_patience")]
    pub patience: u32,
    /// Stop after this many hours (Ultralytics' `time`), keeping the best weights so far.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_hours: Option<f64>,
}

/// Detection and evaluation on the test split (stage `detect`).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Detect {
    /// A YOLOv8 ONNX model (Ultralytics export), relative to the campaign file. Without one,
    /// only the classical streak detector runs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    /// sha256 of the model, filled in when the campaign is resolved (so the campaign hash
    /// pins the model); if given, it must match.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model_sha256: Option<String>,
    /// Confidence and NMS IoU thresholds (the paper: 0.5 and 0.5).
    #[serde(default = "defaults::detect_conf")]
    pub conf: f64,
    #[serde(default = "defaults::detect_iou")]
    pub iou: f64,
    #[serde(default = "defaults::max_det")]
    pub max_det: u32,
    /// Also run the classical streak detector, the model-free baseline.
    #[serde(default = "defaults::yes")]
    pub classical: bool,
    /// `[detect.streak]`: the classical detector's knobs, each optional (defaults and meaning in
    /// `detect::streak::StreakParams`). Left out of the resolved campaign while all are default.
    #[serde(default, skip_serializing_if = "StreakParams::is_default")]
    pub streak: StreakParams,
}

#[derive(Clone, Copy, Debug, Serialize, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Stage {
    /// Scene draw and photon mapping: FITS, truth sidecars.
    Render,
    /// FITS -> enhanced 8-bit PNG and YOLO labels.
    Enhance,
    /// Split into the Ultralytics layout with data.yaml.
    Dataset,
    /// Train a YOLOv8 on the dataset through Ultralytics (`[train]`); the detect stage then
    /// uses the new model. Optional; needs `scripts/setup-train.sh`.
    Train,
    /// Run the detectors on the test split, evaluate, write the report.
    Detect,
}

/// The paper's values; one place lists every knob.
pub mod defaults {
    use super::Stage;
    pub fn images() -> u32 {
        4000
    }
    pub fn stages() -> Vec<Stage> {
        vec![Stage::Render, Stage::Enhance, Stage::Dataset]
    }
    pub fn window_start() -> String {
        "2022-01-01T00:00:00 UTC".into()
    }
    pub fn window_end() -> String {
        "2023-01-01T06:00:00 UTC".into()
    }
    pub fn exposure_min() -> f64 {
        2.0
    }
    pub fn exposure_max() -> f64 {
        8.0
    }
    pub fn placement_fraction() -> f64 {
        0.8
    }
    pub fn image_px() -> u32 {
        1024
    }
    pub fn fov_radius() -> f64 {
        0.1
    }
    pub fn zero_point() -> f64 {
        22.26
    }
    pub fn gain() -> f64 {
        1.6
    }
    pub fn background_min() -> f64 {
        190.0
    }
    pub fn background_max() -> f64 {
        210.0
    }
    pub fn background_exposure() -> f64 {
        5.0
    }
    pub fn bias_min() -> f64 {
        2.0
    }
    pub fn bias_max() -> f64 {
        3.0
    }
    pub fn mag_limit() -> f64 {
        16.5
    }
    pub fn psf_sigma() -> f64 {
        1.0
    }
    pub fn jitter() -> f64 {
        0.0002
    }
    pub fn catalog_epoch() -> f64 {
        2016.0
    }
    pub fn star_cone() -> f64 {
        0.15
    }
    pub fn rcs_mean() -> f64 {
        0.956
    }
    pub fn rcs_std() -> f64 {
        2.291
    }
    pub fn albedo() -> f64 {
        1.0
    }
    pub fn tumble_period_min() -> f64 {
        1.0
    }
    pub fn tumble_period_max() -> f64 {
        20.0
    }
    pub fn tumble_amplitude() -> f64 {
        0.5
    }
    pub fn earth_min() -> f64 {
        105.0
    }
    pub fn sun_min() -> f64 {
        20.0
    }
    pub fn moon_min() -> f64 {
        15.0
    }
    pub fn clearance() -> f64 {
        100.0
    }
    pub fn brightest_star() -> f64 {
        6.0
    }
    pub fn snr_fixed() -> f64 {
        0.15
    }
    pub fn snr_survey() -> f64 {
        0.035
    }
    pub fn max_attempts() -> u32 {
        10_000
    }
    pub fn trajectory_samples() -> u32 {
        2000
    }
    pub fn merge_threshold() -> u64 {
        100_000
    }
    pub fn merge_factor() -> u32 {
        5
    }
    pub fn jitter_steps() -> u32 {
        2000
    }
    pub fn yes() -> bool {
        true
    }
    pub fn clahe_clip() -> f64 {
        2.0
    }
    pub fn clahe_tiles() -> [u32; 2] {
        [8, 8]
    }
    pub fn gamma() -> f64 {
        0.7
    }
    pub fn pad_px() -> u32 {
        32
    }
    pub fn split_train() -> f64 {
        0.7
    }
    pub fn split_val() -> f64 {
        0.2
    }
    pub fn split_test() -> f64 {
        0.1
    }
    pub fn train_model() -> String {
        "yolov8n.yaml".into()
    }
    pub fn train_epochs() -> u32 {
        200
    }
    pub fn train_optimizer() -> String {
        "auto".into()
    }
    pub fn train_device() -> String {
        "auto".into()
    }
    pub fn train_workers() -> u32 {
        2
    }
    pub fn train_patience() -> u32 {
        100
    }
    // The YOLO thresholds live with the detector, which must not depend on the campaign.
    pub fn detect_conf() -> f64 {
        crate::detect::yolo::DEFAULT_CONF
    }
    pub fn detect_iou() -> f64 {
        crate::detect::yolo::DEFAULT_IOU
    }
    pub fn max_det() -> u32 {
        crate::detect::yolo::DEFAULT_MAX_DET
    }
}

macro_rules! default_from_serde {
    ($($t:ty),*) => {$(
        impl Default for $t {
            fn default() -> Self {
                // Every field has a serde default, so an empty table gives the paper's values.
                toml::from_str("").expect("all fields have defaults")
            }
        }
    )*};
}
default_from_serde!(
    Window, Exposure, Pointing, Sensor, Photometry, Visibility, Render, Enhance, Split, Artifacts,
    Detect, Train
);

impl Default for Stars {
    fn default() -> Self {
        Stars::Procedural {
            sky_seed: 0,
            cone_radius_deg: defaults::star_cone(),
        }
    }
}

/// Largest boresight drift over one survey exposure (the paper's is about 0.5 deg).
pub const MAX_SURVEY_DRIFT_DEG: f64 = 2.0;

/// A user error in a campaign: which file, where, which field, what is allowed.
#[derive(Debug, thiserror::Error)]
#[error("{}{}: {}{}", file.display(), line.map(|l| format!(":{l}")).unwrap_or_default(), field.as_ref().map(|f| format!("field `{f}`: ")).unwrap_or_default(), message)]
pub struct CampaignError {
    pub file: PathBuf,
    pub line: Option<usize>,
    pub field: Option<String>,
    pub message: String,
}

/// A validated campaign with every default filled in, files read, and its hash.
#[derive(Debug)]
pub struct Campaign {
    /// The campaign with defaults filled and TLE files replaced by their lines: what the hash covers.
    pub resolved: CampaignFile,
    /// sha256 of the canonical JSON of `resolved` (without `output`).
    pub hash: String,
    pub observer: Body,
    pub debris: Vec<Body>,
    pub window_start: Epoch,
    pub window_end: Epoch,
    /// Where outputs go.
    pub output_dir: PathBuf,
    /// Directory of the campaign file, for relative paths.
    pub base_dir: PathBuf,
}

impl Campaign {
    /// Read, parse, validate and resolve a campaign file.
    pub fn load(path: &Path) -> Result<Campaign, CampaignError> {
        let text = std::fs::read_to_string(path).map_err(|e| CampaignError {
            file: path.to_path_buf(),
            line: None,
            field: None,
            message: format!("cannot read campaign file: {e}"),
        })?;
        Campaign::from_toml(&text, path)
    }

    /// Parse and validate campaign text; `path` is used for messages and relative paths.
    pub fn from_toml(text: &str, path: &Path) -> Result<Campaign, CampaignError> {
        let file: CampaignFile = toml::from_str(text).map_err(|e| {
            let line = e.span().map(|s| line_of_offset(text, s.start));
            CampaignError {
                file: path.to_path_buf(),
                line,
                field: None,
                message: e.message().trim().to_string(),
            }
        })?;
        let base_dir = path
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_else(|| PathBuf::from("."));
        let base_dir = if base_dir.as_os_str().is_empty() {
            PathBuf::from(".")
        } else {
            base_dir
        };
        let err = |field: &str, message: String| CampaignError {
            file: path.to_path_buf(),
            line: line_of_field(text, field),
            field: Some(field.to_string()),
            message,
        };
        validate(&file).map_err(|(field, msg)| err(&field, msg))?;

        let window_start = parse_epoch(&file.window.start).map_err(|m| err("window.start", m))?;
        let window_end = parse_epoch(&file.window.end).map_err(|m| err("window.end", m))?;
        if window_end <= window_start {
            return Err(err(
                "window.end",
                format!("must be after window.start ({})", file.window.start),
            ));
        }

        let mut resolved = file.clone();
        let observer = resolve_object(&mut resolved.observer, &base_dir, window_start)
            .map_err(|(f, m)| err(&format!("observer{f}"), m))?;
        let mut debris = Vec::new();
        for (i, spec) in resolved.debris.iter_mut().enumerate() {
            debris.push(
                resolve_object(spec, &base_dir, window_start)
                    .map_err(|(f, m)| err(&format!("debris[{i}]{f}"), m))?,
            );
        }
        // An object SGP4 cannot propagate anywhere in the window (decayed before it opens,
        // or diverged) would fail every scene draw, ending in "no acceptable scene" after
        // max_attempts draws: refuse it here, naming its field and its TLE.
        let specs = std::iter::once(("observer".to_string(), &file.observer, &observer)).chain(
            file.debris
                .iter()
                .zip(&debris)
                .enumerate()
                .map(|(i, (spec, body))| (format!("debris[{i}]"), spec, body)),
        );
        for (field, spec, body) in specs {
            if let Err(e) = check_propagates(body, window_start, window_end) {
                let (suffix, source) = match (&spec.tle_file, &spec.tle, &spec.elements) {
                    (Some(f), _, _) => {
                        let full = base_dir.join(f);
                        let line = std::fs::read_to_string(&full).ok().and_then(|t| {
                            let [l1, _] = resolved_tle(&resolved, &field)?;
                            t.lines().position(|l| l.trim_end() == l1).map(|n| n + 1)
                        });
                        let at = line.map(|n| format!("line {n} of ")).unwrap_or_default();
                        (".tle_file", format!(" (the TLE at {at}{})", full.display()))
                    }
                    (_, Some(_), _) => (".tle", String::new()),
                    _ => (".elements", String::new()),
                };
                return Err(err(
                    &format!("{field}{suffix}"),
                    format!(
                        "{e}{source}: the object cannot be propagated anywhere in the window {} .. {}",
                        file.window.start, file.window.end
                    ),
                ));
            }
        }
        if let Background::Frames { paths } = &resolved.background {
            if paths.is_empty() {
                return Err(err("background.paths", "name at least one frame".into()));
            }
            for (i, p) in paths.iter().enumerate() {
                let full = base_dir.join(p);
                if !full.is_file() {
                    return Err(err(
                        &format!("background.paths[{i}]"),
                        format!("background frame {} does not exist", full.display()),
                    ));
                }
            }
        }
        if let Some(model) = &resolved.detect.model {
            let full = base_dir.join(model);
            let sha = crate::manifest::sha256_file(&full)
                .map_err(|e| {
                    err(
                        "detect.model",
                        format!("cannot read model {}: {e}", full.display()),
                    )
                })?
                .0;
            if let Some(given) = &resolved.detect.model_sha256
                && *given != sha
            {
                return Err(err(
                    "detect.model_sha256",
                    format!("is {given} but {} has sha256 {sha}", full.display()),
                ));
            }
            resolved.detect.model_sha256 = Some(sha);
        }
        if let Stars::Catalog { path: p, .. } = &resolved.stars {
            let full = base_dir.join(p);
            if !full.is_file() {
                return Err(err(
                    "stars.path",
                    format!("star catalogue {} does not exist", full.display()),
                ));
            }
        }
        if resolved.pointing.mode == PointingMode::Survey {
            // The boresight turns at the observer's orbital rate: beyond a few degrees of drift
            // the star cone and the trails grow without bound, so refuse it up front.
            let p = &observer.propagator;
            let t1 = window_start + hifitime::Duration::from_seconds(1.0);
            if let (Ok(a), Ok(b)) = (p.position_teme_km(window_start), p.position_teme_km(t1)) {
                let drift = crate::sky::angle_deg(a, b) * resolved.exposure.max_s;
                if drift > MAX_SURVEY_DRIFT_DEG {
                    return Err(err(
                        "exposure.max_s",
                        format!(
                            "survey pointing would drift {drift:.1} deg in {} s (the observer turns {:.3} deg/s); \
                             at most {MAX_SURVEY_DRIFT_DEG} deg is supported: shorten the exposure",
                            resolved.exposure.max_s,
                            drift / resolved.exposure.max_s
                        ),
                    ));
                }
            }
        }
        let output_dir = match &file.output {
            Some(o) => base_dir.join(o),
            None => base_dir.join("runs").join(&file.name),
        };
        resolved.output = None;
        let hash = hash_json(&resolved);
        Ok(Campaign {
            resolved,
            hash,
            observer,
            debris,
            window_start,
            window_end,
            output_dir,
            base_dir,
        })
    }

    /// The signal-to-noise gate for this campaign's pointing mode.
    pub fn snr_min(&self) -> f64 {
        self.resolved
            .visibility
            .snr_min
            .unwrap_or(match self.resolved.pointing.mode {
                PointingMode::Fixed => defaults::snr_fixed(),
                PointingMode::Survey => defaults::snr_survey(),
            })
    }
}

/// sha256 of the canonical (key-sorted, compact) JSON of a value.
pub fn hash_json<T: Serialize>(value: &T) -> String {
    let v = serde_json::to_value(value).expect("campaign serialises");
    let text = serde_json::to_string(&v).expect("json value serialises");
    hex(&Sha256::digest(text.as_bytes()))
}

pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Parse a UTC instant such as `2022-01-01T00:00:00 UTC` or `2022-01-01T00:00:00Z`.
pub fn parse_epoch(s: &str) -> Result<Epoch, String> {
    let t = s.trim();
    let normalized = if let Some(stripped) = t.strip_suffix('Z') {
        format!("{stripped} UTC")
    } else if t.ends_with("UTC") {
        t.to_string()
    } else {
        return Err(format!(
            "`{s}` is not a UTC instant: write it like `2022-01-01T00:00:00 UTC` or `2022-01-01T00:00:00Z`"
        ));
    };
    normalized
        .parse::<Epoch>()
        .map_err(|e| format!("`{s}` is not a valid UTC instant ({e})"))
}

/// Field-level checks that need no files. Returns (field path, message).
fn validate(c: &CampaignFile) -> Result<(), (String, String)> {
    fn check(ok: bool, field: &str, msg: &str) -> Result<(), (String, String)> {
        if ok {
            Ok(())
        } else {
            Err((field.to_string(), msg.to_string()))
        }
    }
    let pos = |x: f64| x.is_finite() && x > 0.0;
    let nonneg = |x: f64| x.is_finite() && x >= 0.0;
    check(!c.name.trim().is_empty(), "name", "must not be empty")?;
    check(
        c.name
            .chars()
            .all(|ch| ch.is_ascii_alphanumeric() || "-_.".contains(ch)),
        "name",
        "use only letters, digits, '-', '_' and '.' (it names folders)",
    )?;
    check(
        (1..=10_000_000).contains(&c.images),
        "images",
        "must be between 1 and 10000000",
    )?;
    check(
        !c.debris.is_empty(),
        "debris",
        "name at least one debris object",
    )?;
    let e = &c.exposure;
    check(
        pos(e.min_s),
        "exposure.min_s",
        "must be a positive number of seconds",
    )?;
    check(
        pos(e.max_s),
        "exposure.max_s",
        "must be a positive number of seconds",
    )?;
    check(
        e.max_s >= e.min_s,
        "exposure.max_s",
        "must be >= exposure.min_s",
    )?;
    check(
        e.max_s <= 3600.0,
        "exposure.max_s",
        "must be at most 3600 s",
    )?;
    check(
        c.pointing.placement_fraction > 0.0 && c.pointing.placement_fraction <= 1.0,
        "pointing.placement_fraction",
        "must be in (0, 1]",
    )?;
    let s = &c.sensor;
    check(
        (16..=16384).contains(&s.width_px),
        "sensor.width_px",
        "must be between 16 and 16384",
    )?;
    check(
        (16..=16384).contains(&s.height_px),
        "sensor.height_px",
        "must be between 16 and 16384",
    )?;
    check(
        pos(s.fov_radius_deg) && s.fov_radius_deg <= 10.0,
        "sensor.fov_radius_deg",
        "must be in (0, 10] degrees (the gnomonic projection is used)",
    )?;
    check(
        s.zero_point_mag.is_finite(),
        "sensor.zero_point_mag",
        "must be finite",
    )?;
    check(
        pos(s.gain_e_per_adu),
        "sensor.gain_e_per_adu",
        "must be positive",
    )?;
    check(
        nonneg(s.background_min_adu),
        "sensor.background_min_adu",
        "must be >= 0",
    )?;
    check(
        nonneg(s.background_max_adu) && s.background_max_adu >= s.background_min_adu,
        "sensor.background_max_adu",
        "must be >= sensor.background_min_adu",
    )?;
    check(
        pos(s.background_exposure_s),
        "sensor.background_exposure_s",
        "must be positive",
    )?;
    check(
        nonneg(s.bias_min_adu),
        "sensor.bias_min_adu",
        "must be >= 0",
    )?;
    check(
        nonneg(s.bias_max_adu) && s.bias_max_adu >= s.bias_min_adu,
        "sensor.bias_max_adu",
        "must be >= sensor.bias_min_adu",
    )?;
    check(
        s.mag_limit.is_finite() && s.mag_limit <= 30.0,
        "sensor.mag_limit",
        "must be a magnitude <= 30",
    )?;
    check(
        pos(s.psf_sigma_arcsec),
        "sensor.psf_sigma_arcsec",
        "must be positive",
    )?;
    check(
        nonneg(s.jitter_deg_per_sqrt_s),
        "sensor.jitter_deg_per_sqrt_s",
        "must be >= 0",
    )?;
    check(
        pos(c.stars.cone_radius_deg()) && c.stars.cone_radius_deg() <= 10.0,
        "stars.cone_radius_deg",
        "must be in (0, 10] degrees",
    )?;
    if let Stars::Catalog { epoch_jyear, .. } = c.stars {
        check(
            (1000.0..=3000.0).contains(&epoch_jyear),
            "stars.epoch_jyear",
            "must be a Julian year such as 2016.0",
        )?;
    }
    let p = &c.photometry;
    check(
        p.rcs_mean_m2.is_finite(),
        "photometry.rcs_mean_m2",
        "must be finite",
    )?;
    check(
        nonneg(p.rcs_std_m2),
        "photometry.rcs_std_m2",
        "must be >= 0",
    )?;
    check(
        p.rcs_mean_m2 != 0.0 || p.rcs_std_m2 > 0.0,
        "photometry.rcs_std_m2",
        "with rcs_mean_m2 = 0 the area is always 0: give a positive std",
    )?;
    check(pos(p.albedo), "photometry.albedo", "must be positive")?;
    if let LightCurve::Tumbling {
        period_min_s,
        period_max_s,
        amplitude_max,
    } = p.light_curve
    {
        check(
            pos(period_min_s),
            "photometry.light_curve.period_min_s",
            "must be positive",
        )?;
        check(
            pos(period_max_s) && period_max_s >= period_min_s,
            "photometry.light_curve.period_max_s",
            "must be >= period_min_s",
        )?;
        check(
            (0.0..1.0).contains(&amplitude_max),
            "photometry.light_curve.amplitude_max",
            "must be in [0, 1): the flux factor 1 + a sin(..) must stay positive",
        )?;
    }
    let v = &c.visibility;
    for (f, x) in [
        ("visibility.earth_min_deg", v.earth_min_deg),
        ("visibility.sun_min_deg", v.sun_min_deg),
        ("visibility.moon_min_deg", v.moon_min_deg),
    ] {
        check(
            (0.0..=180.0).contains(&x),
            f,
            "must be an angle in [0, 180] degrees",
        )?;
    }
    check(
        nonneg(v.earth_clearance_km),
        "visibility.earth_clearance_km",
        "must be >= 0",
    )?;
    check(
        v.brightest_star_mag.is_finite(),
        "visibility.brightest_star_mag",
        "must be finite",
    )?;
    if let Some(snr) = v.snr_min {
        check(nonneg(snr), "visibility.snr_min", "must be >= 0")?;
    }
    check(
        v.max_attempts >= 1,
        "visibility.max_attempts",
        "must be >= 1",
    )?;
    let r = &c.render;
    check(
        (2..=crate::scene::MAX_TRAJECTORY_SAMPLES as u32).contains(&r.trajectory_samples),
        "render.trajectory_samples",
        "must be between 2 and 1000000",
    )?;
    check(
        r.merge_threshold >= 1,
        "render.merge_threshold",
        "must be >= 1",
    )?;
    check(
        (1..=1000).contains(&r.merge_factor),
        "render.merge_factor",
        "must be between 1 and 1000",
    )?;
    check(
        (1..=1_000_000).contains(&r.jitter_steps),
        "render.jitter_steps",
        "must be between 1 and 1000000",
    )?;
    let en = &c.enhance;
    check(
        nonneg(en.clahe_clip_limit),
        "enhance.clahe_clip_limit",
        "must be >= 0",
    )?;
    check(
        en.clahe_tiles.iter().all(|&t| (1..=64).contains(&t)),
        "enhance.clahe_tiles",
        "each must be between 1 and 64",
    )?;
    check(pos(en.gamma), "enhance.gamma", "must be positive")?;
    check(en.pad_px <= 4096, "enhance.pad_px", "must be at most 4096")?;
    check(
        en.geometry != FrameKind::Rotated || c.pointing.mode == PointingMode::Survey,
        "enhance.geometry",
        "`rotated` needs survey pointing (fixed images have no star trails to align)",
    )?;
    let t = &c.train;
    check(
        (1..=100_000).contains(&t.epochs),
        "train.epochs",
        "must be between 1 and 100000",
    )?;
    check(
        t.batch.is_none_or(|b| b >= 1),
        "train.batch",
        "must be >= 1",
    )?;
    check(
        t.imgsz
            .is_none_or(|s| (32..=8192).contains(&s) && s % 32 == 0),
        "train.imgsz",
        "must be a multiple of 32 between 32 and 8192",
    )?;
    check(
        t.time_hours.is_none_or(|h| h > 0.0),
        "train.time_hours",
        "must be positive",
    )?;
    let d = &c.detect;
    check(
        d.conf > 0.0 && d.conf <= 1.0,
        "detect.conf",
        "must be in (0, 1]",
    )?;
    check(
        d.iou > 0.0 && d.iou <= 1.0,
        "detect.iou",
        "must be in (0, 1]",
    )?;
    check(d.max_det >= 1, "detect.max_det", "must be >= 1")?;
    d.streak
        .check()
        .map_err(|(field, msg)| (format!("detect.streak.{field}"), msg))?;
    let training = c.stages.contains(&Stage::Train);
    check(
        d.model.is_some() || training || d.classical || !c.stages.contains(&Stage::Detect),
        "detect",
        "the detect stage needs a `model`, a `train` stage or `classical = true`",
    )?;
    check(
        !(training && d.model.is_some()),
        "detect.model",
        "a campaign with a `train` stage detects with the model it trains: remove `detect.model`",
    )?;
    let sp = &c.split;
    for (f, x) in [
        ("split.train", sp.train),
        ("split.val", sp.val),
        ("split.test", sp.test),
    ] {
        check(nonneg(x) && x <= 1.0, f, "must be in [0, 1]")?;
    }
    let sum = sp.train + sp.val + sp.test;
    check(
        (sum - 1.0).abs() < 1e-9,
        "split",
        &format!("train + val + test must sum to 1 (they sum to {sum})"),
    )?;
    // `train` is optional, between dataset and detect; the others form a prefix.
    let order = [
        Stage::Render,
        Stage::Enhance,
        Stage::Dataset,
        Stage::Train,
        Stage::Detect,
    ];
    let in_order = c.stages.windows(2).all(|w| {
        let pos = |s: &Stage| order.iter().position(|o| o == s);
        pos(&w[0]) < pos(&w[1])
    });
    let core: Vec<Stage> = c
        .stages
        .iter()
        .copied()
        .filter(|s| *s != Stage::Train)
        .collect();
    check(
        !c.stages.is_empty()
            && in_order
            && core
                .iter()
                .zip(order.iter().filter(|s| **s != Stage::Train))
                .all(|(a, b)| a == b)
            && (!training || core.contains(&Stage::Dataset)),
        "stages",
        "must be a prefix of [\"render\", \"enhance\", \"dataset\", \"train\", \"detect\"], `train` optional (each stage needs the ones before it)",
    )?;
    Ok(())
}

/// Turn an `ObjectSpec` into a body, replacing a `tle_file` by the TLE lines it holds (so the
/// campaign hash covers the orbit, not a path). Errors: (field suffix, message).
fn resolve_object(
    spec: &mut ObjectSpec,
    base_dir: &Path,
    default_epoch: Epoch,
) -> Result<Body, (String, String)> {
    let given = [
        spec.tle.is_some(),
        spec.tle_file.is_some(),
        spec.elements.is_some(),
    ]
    .iter()
    .filter(|&&b| b)
    .count();
    if given != 1 {
        return Err((
            String::new(),
            "give exactly one of `tle`, `tle_file` (with `norad`) or `elements`".into(),
        ));
    }
    if let Some(file) = spec.tle_file.take() {
        let norad = spec.norad.ok_or_else(|| {
            (
                ".norad".to_string(),
                "`tle_file` needs `norad` to pick the object".to_string(),
            )
        })?;
        let full = base_dir.join(&file);
        let text = std::fs::read_to_string(&full).map_err(|e| {
            (
                ".tle_file".to_string(),
                format!("cannot read {}: {e}", full.display()),
            )
        })?;
        let tles = orbit::parse_tles(&text)
            .map_err(|e| (".tle_file".to_string(), format!("{}: {e}", full.display())))?;
        let tle = tles
            .into_iter()
            .find(|t| t.norad_id == norad)
            .ok_or_else(|| {
                (
                    ".norad".to_string(),
                    format!("NORAD {norad} is not in {}", full.display()),
                )
            })?;
        if spec.name.is_none() {
            spec.name = tle.name.clone();
        }
        spec.tle = Some([tle.line1.clone(), tle.line2.clone()]);
    }
    if let Some([l1, l2]) = &spec.tle {
        let text = format!("{l1}\n{l2}\n");
        let tle: Tle = orbit::parse_tles(&text)
            .map_err(|e| (".tle".to_string(), e.to_string()))?
            .into_iter()
            .next()
            .ok_or_else(|| (".tle".to_string(), "no TLE found".to_string()))?;
        if let Some(n) = spec.norad
            && n != tle.norad_id
        {
            return Err((
                ".norad".into(),
                format!("is {n} but the TLE is for NORAD {}", tle.norad_id),
            ));
        }
        spec.norad = Some(tle.norad_id);
        let propagator =
            Propagator::from_tle(&tle).map_err(|e| (".tle".to_string(), e.to_string()))?;
        let name = spec
            .name
            .clone()
            .unwrap_or_else(|| format!("NORAD {}", tle.norad_id));
        spec.name = Some(name.clone());
        return Ok(Body {
            name,
            norad: tle.norad_id,
            propagator,
        });
    }
    let el = spec.elements.as_mut().expect("counted above");
    let norad = spec.norad.ok_or_else(|| {
        (
            ".norad".to_string(),
            "objects given by `elements` need a `norad` number".to_string(),
        )
    })?;
    let epoch = match &el.epoch {
        Some(s) => parse_epoch(s).map_err(|m| (".elements.epoch".to_string(), m))?,
        None => default_epoch,
    };
    el.epoch = Some(format!("{epoch}"));
    let elements = OrbitalElements {
        period_min: el.period_min,
        inclination_deg: el.inclination_deg,
        apogee_km: el.apogee_km,
        perigee_km: el.perigee_km,
        raan_deg: el.raan_deg,
        arg_perigee_deg: el.arg_perigee_deg,
        mean_anomaly_deg: el.mean_anomaly_deg,
        epoch,
    };
    let propagator = Propagator::from_elements(&elements, norad)
        .map_err(|e| (".elements".to_string(), e.to_string()))?;
    let name = spec
        .name
        .clone()
        .unwrap_or_else(|| format!("NORAD {norad}"));
    spec.name = Some(name.clone());
    Ok(Body {
        name,
        norad,
        propagator,
    })
}

/// Instants at which `check_propagates` tries an object, evenly over the window.
const PROPAGATION_CHECKS: u32 = 65;

/// Ok if the body propagates at one of `PROPAGATION_CHECKS` instants of the window; else the
/// first failure (at the window start). An object that decays inside the window is kept:
/// draws after its decay are rejected as "propagation failed".
fn check_propagates(body: &Body, start: Epoch, end: Epoch) -> Result<(), orbit::OrbitError> {
    let span = (end - start).to_seconds();
    let mut first = None;
    for k in 0..PROPAGATION_CHECKS {
        let f = k as f64 / (PROPAGATION_CHECKS - 1) as f64;
        let t = start + hifitime::Duration::from_seconds(span * f);
        match body.propagator.position_teme_km(t) {
            Ok(_) => return Ok(()),
            Err(e) => {
                first.get_or_insert(e);
            }
        }
    }
    Err(first.expect("at least one check"))
}

/// The resolved TLE lines of `observer` or `debris[i]`.
fn resolved_tle<'a>(resolved: &'a CampaignFile, field: &str) -> Option<&'a [String; 2]> {
    let spec = match field.strip_prefix("debris[") {
        Some(rest) => resolved
            .debris
            .get(rest.trim_end_matches(']').parse::<usize>().ok()?)?,
        None => &resolved.observer,
    };
    spec.tle.as_ref()
}

/// 1-based line of a byte offset.
fn line_of_offset(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())].matches('\n').count() + 1
}

/// Line where a field path such as `exposure.min_s` or `debris[1].elements` is written, if it is.
/// Falls back to the nearest enclosing table that is written.
fn line_of_field(text: &str, field: &str) -> Option<usize> {
    let doc = toml::de::DeTable::parse(text).ok()?;
    let mut keys: Vec<(String, Option<usize>)> = Vec::new();
    for part in field.split('.') {
        match part.find('[') {
            Some(i) => {
                let idx = part[i + 1..].trim_end_matches(']').parse().ok();
                keys.push((part[..i].to_string(), idx));
            }
            None => keys.push((part.to_string(), None)),
        }
    }
    let mut table = doc.get_ref();
    let mut best = None;
    // Walk as deep as the text goes; a field left to its default reports its enclosing table.
    for (k, (key, idx)) in keys.iter().enumerate() {
        let Some((span_key, value)) = table.get_key_value(key.as_str()) else {
            break;
        };
        best = Some(span_key.span().start);
        let mut value = value;
        if let Some(i) = idx {
            let Some(item) = value.get_ref().as_array().and_then(|a| a.get(*i)) else {
                break;
            };
            value = item;
            best = Some(value.span().start);
        }
        if k + 1 < keys.len() {
            let Some(t) = value.get_ref().as_table() else {
                break;
            };
            table = t;
        }
    }
    best.map(|o| line_of_offset(text, o))
}

/// The JSON Schema of the campaign format, generated from the Rust types.
pub fn schema_json() -> String {
    let schema = schemars::schema_for!(CampaignFile);
    serde_json::to_string_pretty(&schema).expect("schema serialises")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(text: &str) -> Result<Campaign, CampaignError> {
        Campaign::from_toml(text, Path::new("/nowhere/c.toml"))
    }

    const ELEMENTS: &str = "elements = { period_min = 375.48, inclination_deg = 52.78, apogee_km = 20490.0, perigee_km = 1235.0 }";

    fn minimal(extra: &str) -> String {
        format!(
            "name = \"t\"\n[observer]\nnorad = 1\n{ELEMENTS}\n[[debris]]\nnorad = 40649\n{ELEMENTS}\n{extra}"
        )
    }

    #[test]
    fn defaults_are_the_papers() {
        let c = load(&minimal("")).unwrap();
        let r = &c.resolved;
        assert_eq!(r.images, 4000);
        assert_eq!((r.sensor.width_px, r.sensor.height_px), (1024, 1024));
        assert_eq!(r.sensor.fov_radius_deg, 0.1);
        assert_eq!(r.sensor.zero_point_mag, 22.26);
        assert_eq!(r.sensor.gain_e_per_adu, 1.6);
        assert_eq!((r.exposure.min_s, r.exposure.max_s), (2.0, 8.0));
        assert_eq!(r.stars.cone_radius_deg(), 0.15);
        assert_eq!(r.render.trajectory_samples, 2000);
        assert_eq!((r.split.train, r.split.val, r.split.test), (0.7, 0.2, 0.1));
        assert_eq!(c.snr_min(), 0.15);
        assert_eq!(
            c.resolved.debris[0]
                .elements
                .as_ref()
                .unwrap()
                .epoch
                .as_deref(),
            Some("2022-01-01T00:00:00 UTC")
        );
        // The hash ignores the output directory but not the physics.
        let other_out = load(&minimal("")).unwrap();
        assert_eq!(c.hash, other_out.hash);
        let with_out = load(&format!("output = \"x\"\n{}", minimal(""))).unwrap();
        assert_eq!(c.hash, with_out.hash);
        let other = load(&minimal("[sensor]\ngain_e_per_adu = 2.0\n")).unwrap();
        assert_ne!(c.hash, other.hash);
    }

    #[test]
    fn errors_name_file_line_and_field() {
        let e = load(&minimal("[exposure]\nmin_s = 2.0\nmax_s = -3.0\n")).unwrap_err();
        let msg = e.to_string();
        assert!(msg.starts_with("/nowhere/c.toml:"), "{msg}");
        assert_eq!(e.field.as_deref(), Some("exposure.max_s"));
        assert_eq!(e.line, Some(10), "{msg}");

        let e = load(&minimal("[sensor]\nwidth = 3\n")).unwrap_err();
        assert_eq!(e.line, Some(9), "{e}");
        assert!(e.to_string().contains("unknown field `width`"), "{e}");

        let e = load(&minimal("[split]\ntest = 0.3\n")).unwrap_err();
        assert!(e.to_string().contains("sum to 1"), "{e}");
        assert_eq!(e.line, Some(8), "{e}");

        let e = load(&minimal("[window]\nstart = \"2022-13-01T00:00:00 UTC\"\n")).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("window.start"));

        let e = load(&minimal("[enhance]\ngeometry = \"rotated\"\n")).unwrap_err();
        assert!(e.to_string().contains("needs survey pointing"), "{e}");
        assert!(
            load(&minimal(
                "[pointing]\nmode = \"survey\"\n[enhance]\ngeometry = \"rotated\"\n"
            ))
            .is_ok()
        );

        let e = load("name = \"t\"\n[observer]\nnorad = 1\n[[debris]]\nnorad = 2\n").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("observer"));
        assert!(e.to_string().contains("exactly one of"), "{e}");

        // A survey exposure so long that the camera would turn by degrees is refused.
        let e = load(&minimal(
            "[pointing]\nmode = \"survey\"\n[exposure]\nmax_s = 600.0\n",
        ))
        .unwrap_err();
        assert_eq!(e.field.as_deref(), Some("exposure.max_s"), "{e}");
        assert!(e.to_string().contains("drift"), "{e}");

        let e = load(&minimal("[stages]\n")).unwrap_err();
        assert!(e.line.is_some(), "{e}");
    }

    #[test]
    fn streak_detector_knobs_are_optional_and_checked() {
        let c = load(&minimal(
            "[detect.streak]\nthreshold_sigma = 3.5\nmin_snr = 7.0\n",
        ))
        .unwrap();
        let s = &c.resolved.detect.streak;
        assert_eq!((s.threshold_sigma, s.min_snr), (3.5, 7.0));
        assert_eq!(s.n_angles, StreakParams::default().n_angles);
        // Left at the defaults the table is not in the resolved campaign: hashes do not move.
        let plain = load(&minimal("")).unwrap();
        let json = serde_json::to_value(&plain.resolved).unwrap();
        assert!(json["detect"].get("streak").is_none(), "{json}");
        let same = load(&minimal("[detect.streak]\nthreshold_sigma = 3.0\n")).unwrap();
        assert_eq!(same.hash, plain.hash);
        assert_ne!(c.hash, plain.hash);

        let e = load(&minimal(
            "[detect]\nclassical = true\n[detect.streak]\nmin_snr = 5.0\nthreshold_sigma = nan\n",
        ))
        .unwrap_err();
        assert_eq!(
            e.field.as_deref(),
            Some("detect.streak.threshold_sigma"),
            "{e}"
        );
        assert_eq!(e.line, Some(12), "{e}");
        assert!(
            e.to_string().starts_with(
                "/nowhere/c.toml:12: field `detect.streak.threshold_sigma`: must be a finite number"
            ),
            "{e}"
        );
        let e = load(&minimal("[detect.streak]\nn_angles = 0\n")).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("detect.streak.n_angles"), "{e}");
        let e = load(&minimal("[detect.streak]\nthreshold = 3.0\n")).unwrap_err();
        assert!(e.to_string().contains("unknown field `threshold`"), "{e}");
        assert_eq!(e.line, Some(9), "{e}");
    }

    #[test]
    fn stages_are_a_prefix_with_an_optional_train_stage() {
        let with =
            |stages: &str, extra: &str| load(&format!("stages = [{stages}]\n{}", minimal(extra)));
        let classical = "[detect]\nclassical = true\n";
        for ok in [
            r#""render""#,
            r#""render", "enhance", "dataset""#,
            r#""render", "enhance", "dataset", "train""#,
            r#""render", "enhance", "dataset", "train", "detect""#,
        ] {
            assert!(with(ok, "").is_ok(), "{ok}: {:?}", with(ok, "").err());
        }
        assert!(with(r#""render", "enhance", "dataset", "detect""#, classical).is_ok());
        for bad in [
            r#""enhance""#,
            r#""render", "render""#,
            r#""render", "enhance", "train""#,
            r#""render", "enhance", "dataset", "detect", "train""#,
            r#""render", "enhance", "dataset", "train", "train""#,
        ] {
            let e = with(bad, classical).unwrap_err();
            assert_eq!(e.field.as_deref(), Some("stages"), "{bad}: {e}");
        }
        // A train stage detects with the model it trains, not a second one.
        let e = with(
            r#""render", "enhance", "dataset", "train", "detect""#,
            "[detect]\nmodel = \"m.onnx\"\n",
        )
        .unwrap_err();
        assert_eq!(e.field.as_deref(), Some("detect.model"), "{e}");
    }

    #[test]
    fn epochs_parse() {
        assert!(parse_epoch("2022-01-01T00:00:00Z").is_ok());
        assert!(parse_epoch("2022-01-01T00:00:00 UTC").is_ok());
        assert!(parse_epoch("2022-01-01").is_err());
    }
}
