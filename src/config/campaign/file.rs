//! The campaign file as written in TOML: one type per section, every field with its paper
//! default (`defaults`), and the JSON Schema derived from them (`soig schema`).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::{FrameKind, Noise, PointingMode, RenderMethod, SnrDefinition, defaults};
use crate::detect::streak::StreakParams;

/// A campaign as written in TOML. Every section is optional and defaults to the paper's values.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
#[schemars(transform = schema_with_extends)]
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
    /// The debris set; each image shows one of them, drawn uniformly (or by their `weight`).
    pub debris: Vec<ObjectSpec>,
    /// Let `debris` name one object (one NORAD number, whatever its TLE) more than once. Off by
    /// default: a repeated entry is most often a slip, and it silently doubles the object's
    /// weight and lets a frame of `[objects]` show it twice. Omitted when off, so hashes stay.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub allow_duplicates: bool,
    /// `[objects]`: how many debris objects each image shows (issue #34). Not set: exactly one,
    /// the one the pointing is drawn around (the paper's scenes, their bytes unchanged).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub objects: Option<Objects>,
    /// `[population]`: a catalogue scene (issue #45): every object of a TLE population drawn
    /// where its orbit puts it. Omitted from the resolved campaign when absent, so hashes stay.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub population: Option<Population>,
    #[serde(default)]
    pub window: Window,
    #[serde(default)]
    pub exposure: Exposure,
    #[serde(default)]
    pub pointing: Pointing,
    /// `[collect]`: images taken in collects of several frames on one pointing plan; omitted
    /// from the resolved campaign when absent (single frames), so hashes stay.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub collect: Option<Collect>,
    #[serde(default)]
    pub sensor: Sensor,
    #[serde(default)]
    pub stars: Stars,
    #[serde(default)]
    pub background: Background,
    /// `[noise]`: the paper's noise model (default; left out of the resolved campaign) or a
    /// physical one.
    #[serde(default, skip_serializing_if = "Noise::is_paper")]
    pub noise: Noise,
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

/// `extends` is read before the campaign is parsed (see `compose`) and is no field of it; the
/// schema lists it so that editors accept it.
fn schema_with_extends(schema: &mut schemars::Schema) {
    if let Some(properties) = schema.get_mut("properties").and_then(|p| p.as_object_mut()) {
        properties.insert(
            "extends".into(),
            serde_json::json!({
                "description": "A campaign file this one builds on, relative to this file: its settings apply, tables merged key by key, unless this file sets them (arrays are replaced whole). Bases may extend others.",
                "type": "string"
            }),
        );
    }
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
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "two_tle_lines"
    )]
    #[schemars(with = "Option<[String; 2]>")]
    pub tle: Option<[String; 2]>,
    /// A file of 2- or 3-line TLE sets, relative to the campaign file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tle_file: Option<String>,
    /// Mean orbital elements, for objects with no public TLE (the paper's NORAD 40649).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub elements: Option<ElementsSpec>,
    /// Observer only: a telescope on the ground in place of an orbit (`ground::SiteSpec`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub site: Option<super::ground::SiteSpec>,
    /// Debris only: relative weight in the draw of each image's object (default 1, all equal):
    /// an object of weight 2 is shown twice as often as one of weight 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weight: Option<f64>,
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

/// Several debris objects per image, or none. The image's pointing, time and stars are drawn
/// as without this table (around an anchor object that is then not rendered); each of its
/// objects is drawn on its own random streams by the debris weights, keeps its own range,
/// phase angle, brightness and apparent motion at that time, and is placed uniformly within
/// `pointing.placement_fraction` of the field (its sky track turned rigidly onto that place),
/// with its own shadow, magnitude and signal-to-noise checks.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Objects {
    /// Objects per non-empty image: a number, or `{ min, max }` drawn uniformly.
    pub per_frame: PerFrame,
    /// Share of images with no object at all, drawn before `per_frame` (default 0).
    #[serde(default)]
    pub empty_share: f64,
}

/// A number of objects per image, fixed or uniform in [min, max].
#[derive(Clone, Copy, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(untagged)]
pub enum PerFrame {
    Fixed(u32),
    Range { min: u32, max: u32 },
}

impl PerFrame {
    /// (min, max) of the count.
    pub fn bounds(self) -> (u32, u32) {
        match self {
            PerFrame::Fixed(n) => (n, n),
            PerFrame::Range { min, max } => (min, max),
        }
    }
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
    /// With `[population]`: a stare, the sensor fixed on this (RA, Dec) in every image instead
    /// of pointed around a debris object (`mode` must be `fixed`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stare: Option<Stare>,
}

/// A fixed direction on the sky, degrees (GCRS axes, as the FITS WCS). The GEO belt seen from
/// the Earth's centre lies on the celestial equator (`dec_deg = 0`); from a low orbit it is
/// displaced by up to ~1.3 deg of parallax, away from the observer's side of the equator.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Stare {
    pub ra_deg: f64,
    pub dec_deg: f64,
}

/// A catalogue scene's population (issue #45): every object of `tle_file` is propagated with
/// SGP4 over each exposure, and every one whose path crosses the field is rendered where it
/// is, with its own motion, brightness (`[photometry]`, its size drawn once per object) and
/// visibility (shadow, line of sight, magnitude limit and signal-to-noise gate; an object in
/// the field that fails them is listed in the truth's `unseen` with the reason). The pointing
/// is drawn around a debris object as without this table (and that object is shown too), or
/// is a stare (`pointing.stare`).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Population {
    /// A file of 2- or 3-line TLE sets, relative to the campaign file (any size: a full public
    /// catalogue of ~30,000 objects is culled per image). The observer, if in it, is skipped.
    pub tle_file: String,
    /// sha256 of `tle_file`, filled in when the campaign is resolved (so the campaign hash
    /// pins the population); a given one must match.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tle_sha256: Option<String>,
    /// `[population.breakup]`: a breakup cloud added to the population, its fragments drawn
    /// by the NASA Standard Breakup Model (`Breakup`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub breakup: Option<super::Breakup>,
}

impl CampaignFile {
    /// Frames per collect (1 without `[collect]`).
    pub fn collect_frames(&self) -> u32 {
        self.collect.as_ref().map_or(1, |k| k.frames)
    }
}

/// Multi-frame collects: image i is frame `i % frames` of collect `i / frames`. A collect's
/// frames share its draw (object, first start, exposure, placement, background, light curve)
/// and its pointing plan (fixed: one direction; survey: the observer's attitude running on;
/// track: the object followed), frame k starting `k * (exposure + gap_s)` after the first.
/// With `[objects]` the collect's objects too: drawn and judged on its first frame, each
/// followed through the others with its own motion and its own track id.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Collect {
    /// Frames per collect (`images` must be a multiple).
    pub frames: u32,
    /// Seconds between the end of one frame and the start of the next.
    #[serde(default)]
    pub gap_s: f64,
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
    /// `share` (default 1) is the share of images that get a frame, drawn per image; the others
    /// get the uniform background (a training set that mixes both).
    Frames {
        paths: Vec<String>,
        #[serde(
            default = "defaults::share",
            skip_serializing_if = "defaults::is_share"
        )]
        share: f64,
    },
}

/// Debris photometry (Eq. 6-7) and light-curve modulation.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Photometry {
    /// Named photometry from published sources, replacing the area and albedo below:
    /// `nasa-fragments` draws fragments of 0.1-1 m from the NASA Standard Breakup Model's size
    /// distribution and area (Johnson et al. 2001) with NASA ODPO's albedo 0.175 (Mulrooney
    /// et al. 2008); see crates/sky/src/debris_sizes.rs. Default `paper`: the fields below. Omitted
    /// from the resolved campaign when `paper`, so hashes stay.
    #[serde(default, skip_serializing_if = "PhotometryPreset::is_paper")]
    pub preset: PhotometryPreset,
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

/// Named debris photometry (`photometry.preset`).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum PhotometryPreset {
    /// The paper's: `rcs_mean_m2`, `rcs_std_m2` and `albedo` (by default albedo 1 and a mean
    /// area of ~1 m^2: GEO debris of magnitude ~12, far brighter than observed).
    #[default]
    Paper,
    /// Fragments of characteristic length 0.1-1 m (10 cm: the catalogue's usual threshold),
    /// N(> Lc) ~ Lc^-1.71 and A = 0.556945 Lc^2.0047077 m^2 (NASA Standard Breakup Model,
    /// collisions), albedo 0.175 (NASA ODPO).
    NasaFragments,
}

impl PhotometryPreset {
    pub fn is_paper(&self) -> bool {
        *self == PhotometryPreset::Paper
    }
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
    /// Minimum debris signal / noise (see `scene::expected_snr`); default 0.15 for fixed
    /// pointing, 0.035 for survey.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub snr_min: Option<f64>,
    /// The noise `snr_min` divides by: `noise_level`, the mean level of background plus bias
    /// per pixel (the paper's reading, ~202 ADU for 5 s), or `noise_sigma`, their standard
    /// deviation (~5.8 ADU for 5 s: a gate ~35x weaker that admits invisible streaks).
    #[serde(default)]
    pub snr_definition: SnrDefinition,
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
    /// Apparent positions: the debris at its light-time position, stars and debris aberrated by
    /// the observer's motion, placed in the stars' catalogue frame (the image's WCS). Off in the
    /// paper's model; omitted from the resolved campaign when off, so hashes stay.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub apparent_positions: bool,
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
    /// The dataset as COCO JSON, `export/coco/<split>.json`, and the detect stage's
    /// predictions in COCO's results format, `export/coco/detections_<detector>.json`
    /// (src/product/export/coco.rs); needs the `enhance` stage. Omitted from the resolved campaign when
    /// off, so hashes stay.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub coco: bool,
    /// DS9 region files over the FITS images: the truth, `export/ds9/truth/<image>.reg`, and
    /// each detector's boxes, `export/ds9/<detector>/<image>.reg` (src/product/export/ds9.rs). Omitted
    /// from the resolved campaign when off, so hashes stay.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub ds9_regions: bool,
    /// The debris' brightness over the exposure as rendered, one row per trajectory sample
    /// (time, magnitude with the tumbling modulation, expected photo-electrons, pixel), as
    /// `truth/<image>_light_curve.csv` (columns in src/product/light_curve.rs). Omitted from the
    /// resolved campaign when off, so hashes stay.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub light_curve: bool,
    /// Streak-shaped labels beside the axis-aligned ones: each object's oriented box
    /// (Ultralytics' YOLO-OBB) as `obb/labels/...`, the PNGs hard-linked as `obb/images/...` and
    /// `obb/data.yaml`, so `yolo obb train data=obb/data.yaml` reads it unedited
    /// (crates/image/src/streak_label.rs); needs the `enhance` stage. Omitted from the resolved
    /// campaign when off, so hashes stay.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub obb_labels: bool,
    /// The streak's two ends as keypoints (Ultralytics' pose format, `kpt_shape: [2, 3]`) with
    /// the axis-aligned box, as `keypoints/labels/...` beside hard-linked `keypoints/images/...`
    /// and `keypoints/data.yaml`; needs the `enhance` stage. Omitted from the resolved campaign
    /// when off, so hashes stay.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub keypoint_labels: bool,
    /// The truth's observations as a CCSDS Tracking Data Message (RA/Dec angles seen from the
    /// observer), `export/tdm/truth.tdm` (src/product/export/tdm.rs). Omitted from the
    /// resolved campaign when off, so hashes stay.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub tdm: bool,
    /// Observations for orbit work from the detectors' streak ends and their astrometric
    /// report: `report/astrometry.md` and `.csv` (each detection's ends against the truth
    /// ephemeris, in arcsec, by detector and SNR; the share correlated to the right object),
    /// `report/observations/<detector>.psv` (IAU ADES PSV) and `.tdm` (CCSDS TDM angles)
    /// (src/product/observations.rs, src/report/astrometry.rs); needs the `detect` stage and
    /// the FITS. Omitted from the resolved campaign when off, so hashes stay.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub astrometry: bool,
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
    /// Ultralytics' image cache: `ram` (decoded images held in memory) or `disk` (as .npy
    /// beside the PNGs); left out, each epoch decodes every PNG again (models/README.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cache: Option<TrainCache>,
    /// Mixed precision on a CUDA GPU, without Ultralytics' AMP check (it downloads weights
    /// to compare with); left out or false, full precision (`amp=False`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub amp: Option<bool>,
    /// `false`: validate only at the schedule's end (and when Ultralytics stops it), not after
    /// every epoch; left out, every epoch (Ultralytics' default).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub val: Option<bool>,
    /// Network input channels: 1 trains on the grey frames as they are (a third of the bytes
    /// the loader and the GPU feed move; a 3-channel `.pt` is converted exactly, see
    /// `python/train.py`); left out, 3 (grey replicated to BGR, Ultralytics' default). The
    /// exported ONNX takes the same channels, and soig's YOLO runs either.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub channels: Option<u8>,
}

/// Where Ultralytics keeps decoded training images between epochs.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum TrainCache {
    Ram,
    Disk,
}

impl TrainCache {
    /// Ultralytics' name for it.
    pub fn as_str(self) -> &'static str {
        match self {
            TrainCache::Ram => "ram",
            TrainCache::Disk => "disk",
        }
    }
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
    /// What the classical detector is told of the stars. Left out of the resolved campaign
    /// while it is the default, so a campaign's hash is the same as before it existed.
    #[serde(default, skip_serializing_if = "StarHint::is_default")]
    pub stars: StarHint,
}

/// What the classical streak detector of the detect stage is told of the stars in an image.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum StarHint {
    /// The campaign's knowledge, as a plate-solved frame gives it: survey images get the
    /// catalogued stars' trails, predicted from the commanded pointing and the star catalogue
    /// (each placed by the pointing offset measured on the image); other images get the trail
    /// direction of the pointing.
    #[default]
    Catalogue,
    /// Nothing: the detector measures the star trails on the frame itself (their direction,
    /// length and profile), as `soig detect` does on a bare frame with no catalogue or angle.
    Frame,
}

impl StarHint {
    fn is_default(&self) -> bool {
        *self == StarHint::default()
    }
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

/// `tle`: exactly two lines (read as a fixed-size array, a third line would be dropped unseen).
pub(super) fn two_tle_lines<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<Option<[String; 2]>, D::Error> {
    let lines: Option<Vec<String>> = Option::deserialize(d)?;
    lines
        .map(|l| {
            <[String; 2]>::try_from(l)
                .map_err(|l| serde::de::Error::invalid_length(l.len(), &"the two lines of a TLE"))
        })
        .transpose()
}
