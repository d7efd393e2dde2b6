//! The values a campaign's scenes are drawn from: the bodies, star source and background
//! frames read before the first image (`Inputs`), and what the campaign asks of its scenes
//! (`Spec`: window, exposure, pointing, photometry, acceptance gate, objects per frame).

use hifitime::Epoch;
use rand::RngExt;
use serde::Serialize;

use crate::background::{BackgroundModel, FrameChoice, RealFrame};
use crate::observer::{GroundGate, Observer};
use soig_base::rng::{Purpose, stream};
use soig_sky::orbit::Propagator;
use soig_sky::stars::{ProceduralSky, Star, StarCatalog};

/// One body of the scene with its propagator, resolved from a campaign's object.
#[derive(Clone, Debug)]
pub struct Body {
    pub name: String,
    /// Its NORAD number, or a generated object's id.
    pub norad: u64,
    pub propagator: Propagator,
    /// A generated object's (a breakup fragment's) own size; None: a catalogued object, its
    /// size drawn by the photometry.
    pub generated: Option<Generated>,
}

/// What a generated object brings of its own.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Generated {
    /// Its average cross-section, m^2: it stands for the drawn area in its brightness.
    pub area_m2: f64,
}

/// What a campaign reads before its first image: the bodies, the star source and the
/// background frames.
pub struct Inputs {
    pub observer: Observer,
    pub debris: Vec<Body>,
    /// The population of a catalogue scene (`Spec::catalogue`), empty without one, and the
    /// cheap orbit of each over the campaign's window (`catalogue::candidates` culls with it).
    pub population: Vec<Body>,
    pub population_coarse: Vec<soig_sky::orbit::CoarseOrbit>,
    pub stars: StarField,
    pub background: BackgroundModel,
}

impl Inputs {
    /// The frame of a background choice.
    pub fn frame(&self, choice: Option<FrameChoice>) -> Option<&RealFrame> {
        match (&self.background, choice) {
            (BackgroundModel::Frames(frames), Some(c)) => frames.get(c.frame),
            _ => None,
        }
    }
}

/// The source of field stars of a campaign, loaded once.
pub enum StarField {
    Procedural(ProceduralSky),
    Catalog(StarCatalog),
}

impl StarField {
    pub(super) fn stars_in_cone(
        &self,
        ra: f64,
        dec: f64,
        radius: f64,
        mag_max: f64,
        at: Epoch,
    ) -> Vec<Star> {
        match self {
            StarField::Procedural(sky) => sky.stars_in_cone(ra, dec, radius, mag_max),
            StarField::Catalog(cat) => cat.stars_in_cone(ra, dec, radius, mag_max, julian_year(at)),
        }
    }
}

/// How the sensor points during the exposure.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, Serialize, schemars::JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum PointingMode {
    /// Inertially fixed on a random direction around the debris.
    #[default]
    Fixed,
    /// Following the observer's nadir-pointing attitude: star trails across the image.
    Survey,
    /// Rate-tracking the image's debris object over the exposure: the object is a point, the
    /// stars streak.
    Track,
}

/// The tumbling light curve's ranges: period uniform in [min, max], amplitude in [0, max].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TumbleRange {
    pub period_min_s: f64,
    pub period_max_s: f64,
    pub amplitude_max: f64,
}

/// What the signal-to-noise gate divides the mean debris ADU per footprint pixel by.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, Serialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum SnrDefinition {
    /// The paper's (3.2.6): the mean level of the combined noise matrices, background plus
    /// bias (~202 ADU per pixel for 5 s; a semisynthetic image's level with its real frame).
    #[default]
    NoiseLevel,
    /// Their standard deviation (~5.8 ADU per pixel for 5 s): a gate ~35x weaker that admits
    /// streaks no eye or detector can see (soig's reading before the paper's was adopted).
    NoiseSigma,
}

/// Scene acceptance rules (paper 3.2.2 and 3.2.6), with the effective signal-to-noise gate.
#[derive(Clone, Debug, PartialEq)]
pub struct Gate {
    pub earth_min_deg: f64,
    pub sun_min_deg: f64,
    pub moon_min_deg: f64,
    pub earth_clearance_km: f64,
    pub brightest_star_mag: f64,
    pub snr_min: f64,
    pub snr_definition: SnrDefinition,
    pub max_attempts: u32,
}

/// What a campaign asks of its scenes: when, how long, how the sensor points, the debris
/// photometry and the acceptance gate.
#[derive(Clone, Debug, PartialEq)]
pub struct Spec {
    pub window_start: Epoch,
    pub window_end: Epoch,
    pub exposure_min_s: f64,
    pub exposure_max_s: f64,
    pub pointing: PointingMode,
    /// Relative weight of each debris object, in the order of `Inputs::debris`: an image shows
    /// object i with probability w_i / sum(w) (an object without a weight here weighs 1).
    pub debris_weights: Vec<f64>,
    /// The debris at mid-exposure is placed uniformly within this fraction of the half-field.
    pub placement_fraction: f64,
    /// Debris area and albedo (Eq. 6-7): the paper's |N(mean, std)| m^2, or a preset's.
    pub area: soig_sky::debris_sizes::AreaModel,
    pub albedo: f64,
    pub tumble: Option<TumbleRange>,
    pub gate: Gate,
    /// Star cone radius of fixed pointing (survey cones follow the drift).
    pub star_cone_deg: f64,
    /// Points the debris trajectory is cut into (a minimum, see `trajectory`).
    pub trajectory_samples: usize,
    /// Light-time and aberration (`sighting`); off in the paper's model.
    pub apparent_positions: bool,
    /// The share of images with a real frame under them when the inputs have frames (1: all);
    /// the others get the uniform model.
    pub frame_share: f64,
    /// Frames per collect (1: single images) and the gap between frames, seconds (`[collect]`).
    pub collect_frames: u64,
    pub collect_gap_s: f64,
    /// How many objects each image shows (`[objects]`); None: the one the pointing is drawn
    /// around (the paper's scenes).
    pub objects: Option<ObjectCount>,
    /// A catalogue scene (`[population]`): every object of `Inputs::population` in the field
    /// is shown where its orbit puts it; None: the debris objects as drawn.
    pub catalogue: Option<CatalogueScene>,
    /// A ground observer's site, night and observable spans (`[observer] site`); None for a
    /// satellite observer.
    pub ground: Option<GroundGate>,
}

/// Where a catalogue scene points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CatalogueScene {
    /// As without a catalogue: around an image's debris object drawn by the weights (which is
    /// shown with the population's objects in the field).
    Target,
    /// A stare: the sensor fixed on (RA, Dec), degrees, in every image.
    Stare { ra_deg: f64, dec_deg: f64 },
}

/// How many debris objects an image shows: none with probability `empty_share`, else a number
/// uniform in [min, max].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectCount {
    pub min: u32,
    pub max: u32,
    pub empty_share: f64,
}

impl Spec {
    /// Image `image`'s collect and its frame in it, 0-based (a single image is a collect of
    /// one frame).
    pub(super) fn collect_of(&self, image: u64) -> (u64, u64) {
        let frames = self.collect_frames.max(1);
        (image / frames, image % frames)
    }
}

impl ObjectCount {
    /// The number of objects of collect `collect` (an image, without `[collect]`), from its
    /// own stream.
    pub fn draw(&self, seed: u64, collect: u64) -> u32 {
        let rng = &mut stream(seed, collect, Purpose::ObjectCount);
        if rng.random::<f64>() < self.empty_share {
            return 0;
        }
        rng.random_range(self.min..=self.max)
    }
}

/// Julian year (TT) of an instant, e.g. 2016.0 for the Gaia DR3 epoch.
pub fn julian_year(t: Epoch) -> f64 {
    2000.0 + (t.to_jde_tt_days() - 2_451_545.0) / 365.25
}
