//! The scene draw (paper 3.2.1-3.2.3): which debris, when, how long, where the sensor points,
//! which stars are in the field, and the visibility checks that reject a draw. The debris
//! object is drawn once per image, from its own stream, by the campaign's weights; a rejected
//! draw retries everything else for that object on the scene stream, so a rarely visible
//! object keeps its share of the images, and the accepted scene is a pure function of (scene
//! spec, sensor, inputs, seed, image index). With `Spec::objects` (several objects per frame,
//! or none) that scene only points the sensor, and each of the frame's objects is drawn and
//! placed in the field on its own streams (`place`; in a collect, the collect's streams, judged
//! on its first frame and followed through the others). The campaign file is never seen here: the
//! config layer (`experiment`) builds the values.

use std::collections::BTreeMap;

use hifitime::{Duration, Epoch};
use rand::RngExt;
use rand_chacha::ChaCha12Rng;
use serde::Serialize;

use crate::background::{BackgroundModel, FrameChoice, RealFrame};
use soig_base::rng::{Purpose, object_stream, stream};
use crate::sensor::Sensor;
use crate::sighting::{Ephemeris, Sight, Sighting};
use soig_sky::ephemeris::{moon_position_km, sun_position_km};
use soig_sky::orbit::Propagator;
use soig_sky::photometry::{debris_magnitude, photon_rate};
use soig_sky::projection::Tan;
pub use soig_sky::pointing::{Pointing, SurveyTrack, TargetTrack};
use soig_sky::stars::{ProceduralSky, Star, StarCatalog};
use soig_sky::{
    Vec3, angle_deg, cross, dot, norm, radec_deg, radec_unit, rotate, scale, segment_hits_sphere,
    sub, unit,
};

/// Most objects an image may show (each is drawn, traced and labelled: the cost grows with it).
/// The campaign's validation refuses more.
pub const MAX_OBJECTS_PER_FRAME: u32 = 100;

/// Largest boresight drift over one survey exposure (the paper's is about 0.5 deg); the
/// campaign's resolution refuses more.
pub const MAX_SURVEY_DRIFT_DEG: f64 = 2.0;

/// WGS84 equatorial radius, km.
pub const EARTH_RADIUS_KM: f64 = 6378.137;

/// One body of the scene with its propagator, resolved from a campaign's object.
#[derive(Clone, Debug)]
pub struct Body {
    pub name: String,
    pub norad: u64,
    pub propagator: Propagator,
}

/// What a campaign reads before its first image: the bodies, the star source and the
/// background frames.
pub struct Inputs {
    pub observer: Body,
    pub debris: Vec<Body>,
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
    fn stars_in_cone(&self, ra: f64, dec: f64, radius: f64, mag_max: f64, at: Epoch) -> Vec<Star> {
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
    /// Points the debris trajectory is cut into (a minimum, see `try_draw`).
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
}

/// How many debris objects an image shows: none with probability `empty_share`, else a number
/// uniform in [min, max].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectCount {
    pub min: u32,
    pub max: u32,
    pub empty_share: f64,
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

/// Largest distance, in pixels, between the debris' directions at two consecutive nodes of a
/// `TargetTrack`: over half a pixel the apparent path's curvature and rate change leave
/// interpolation errors of micro-pixels (the path is a great circle to second order).
const TRACK_NODE_SPACING_PX: f64 = 0.5;

/// The track pointing that follows the debris of `sights` over an exposure of `exposure_s`,
/// with the boresight `(ra, dec)` at mid-exposure; None if the debris direction is not finite.
fn target_track(
    sensor: &Sensor,
    sights: &crate::sighting::Track,
    exposure_s: f64,
    boresight: (f64, f64),
) -> Option<TargetTrack> {
    let at = |t_s: f64| unit(sights.at(t_s).direction);
    // A coarse pass measures the path, which sets the node spacing.
    let coarse = 64;
    let path_deg = |n: usize| -> f64 {
        (0..n)
            .map(|k| {
                let t = exposure_s / n as f64;
                angle_deg(at(k as f64 * t), at((k + 1) as f64 * t))
            })
            .sum()
    };
    let coarse_deg = path_deg(coarse);
    if !coarse_deg.is_finite() {
        return None;
    }
    let segments = ((coarse_deg / sensor.pixel_scale_deg() / TRACK_NODE_SPACING_PX).ceil()
        as usize)
        .max(coarse);
    let step_s = exposure_s / segments as f64;
    let nodes: Vec<Vec3> = (0..=segments).map(|k| at(k as f64 * step_s)).collect();
    let debris_mid = at(exposure_s / 2.0);
    let mut track = TargetTrack::new(boresight, exposure_s, debris_mid, step_s, nodes);
    track.trail_angle_deg = trail_angle_deg(sensor, boresight, exposure_s, &|t_s, ra, dec| {
        track.to_mid_frame(t_s, ra, dec)
    })?;
    Some(track)
}

/// One point of the debris trajectory: a source with its share of the exposure.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct TrajectorySample {
    /// Seconds since the start of the exposure.
    pub t_s: f64,
    pub ra_deg: f64,
    pub dec_deg: f64,
    /// Magnitude including the light-curve modulation at this time.
    pub mag: f64,
    /// Expected photo-electrons of this sample (Eq. 3 over its share of the exposure).
    pub expected_electrons: f64,
    /// Pixel position with the pointing of its own time, before jitter and PSF.
    pub x_px: f64,
    pub y_px: f64,
}

/// Tumbling modulation drawn for this image.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Tumble {
    pub period_s: f64,
    pub amplitude: f64,
    pub phase_rad: f64,
}

/// Geometry at mid-exposure, recorded in the truth sidecar.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Geometry {
    pub range_km: f64,
    pub phase_angle_deg: f64,
    pub earth_angle_deg: f64,
    pub sun_angle_deg: f64,
    pub moon_angle_deg: f64,
    /// Magnitude from Eq. 6 at mid-exposure, before light-curve modulation.
    pub magnitude: f64,
}

/// An accepted scene: everything the renderer needs.
#[derive(Clone, Debug, Serialize)]
pub struct Scene {
    pub image_index: u64,
    pub debris_index: usize,
    pub debris_name: String,
    pub norad: u64,
    pub start: Epoch,
    pub exposure_s: f64,
    pub pointing: Pointing,
    pub area_m2: f64,
    pub tumble: Option<Tumble>,
    pub geometry: Geometry,
    /// The debris' place at start, middle and end and the states at mid-exposure (None for a
    /// hand-made scene).
    pub ephemeris: Option<Ephemeris>,
    pub trajectory: Vec<TrajectorySample>,
    pub stars: Vec<Star>,
    /// The real background frame of a semisynthetic image.
    pub background: Option<FrameChoice>,
    /// The signal-to-noise ratio the gate judged, by its definition (one of the two below).
    pub snr: f64,
    /// Expected debris ADU per footprint pixel over the mean level of background plus bias
    /// (`SnrDefinition::NoiseLevel`), and over their standard deviation (`NoiseSigma`).
    pub snr_noise_level: f64,
    pub snr_noise_sigma: f64,
    /// Draws tried, and why the rejected ones were rejected.
    pub attempts: u32,
    pub rejections: BTreeMap<Rejection, u32>,
    /// Its place in a multi-frame collect (None: a single image).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub collect: Option<CollectFrame>,
    /// The objects of an image of a campaign with `[objects]` (possibly none), each a scene of
    /// its own with this one's time, pointing and background and no stars; this scene's own
    /// object then only chose the pointing and is not rendered. None: this scene's object is
    /// the image's one object.
    #[serde(skip)]
    pub placed: Option<Vec<Scene>>,
}

/// A frame's place in its collect, recorded in the truth: the object keeps its `track_id`
/// over the collect's frames (one object per image: the collect's number).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, serde::Deserialize)]
pub struct CollectFrame {
    pub collect: u64,
    /// 0-based, in time order.
    pub frame: u64,
    pub frames: u64,
    pub track_id: u64,
}

impl Scene {
    /// The projection at mid-exposure: the one the FITS WCS describes.
    pub fn projection(&self, sensor: &Sensor) -> Tan {
        let (ra, dec) = self.pointing.mid_radec_deg();
        sensor.projection(ra, dec)
    }

    /// A hand-made fixed-pointing scene (for tests, or to inject a known streak): the sensor
    /// pointed at (ra, dec) from 2022-01-01T00:00 UTC, the given stars, and debris of constant
    /// magnitude moving uniformly from pixel `from` to pixel `to` over the exposure, cut into
    /// 200 trajectory samples at the centres of equal time slices.
    pub fn fixed_streak(
        sensor: &Sensor,
        (ra, dec): (f64, f64),
        stars: Vec<Star>,
        debris_mag: f64,
        (from, to): ((f64, f64), (f64, f64)),
        exposure_s: f64,
    ) -> Scene {
        let tan = sensor.projection(ra, dec);
        let n = 200;
        let trajectory = (0..n)
            .map(|k| {
                let f = (k as f64 + 0.5) / n as f64;
                let (x, y) = (from.0 + f * (to.0 - from.0), from.1 + f * (to.1 - from.1));
                let (ra_deg, dec_deg) = tan.sky(x, y);
                TrajectorySample {
                    t_s: f * exposure_s,
                    ra_deg,
                    dec_deg,
                    mag: debris_mag,
                    expected_electrons: photon_rate(debris_mag, sensor.zero_point_mag) * exposure_s
                        / n as f64,
                    x_px: x,
                    y_px: y,
                }
            })
            .collect();
        Scene {
            image_index: 0,
            debris_index: 0,
            debris_name: "test".into(),
            norad: 1,
            start: Epoch::from_gregorian_utc_at_midnight(2022, 1, 1),
            exposure_s,
            pointing: Pointing::Fixed {
                ra_deg: ra,
                dec_deg: dec,
            },
            area_m2: 1.0,
            tumble: None,
            geometry: Geometry {
                range_km: 1000.0,
                phase_angle_deg: 90.0,
                earth_angle_deg: 120.0,
                sun_angle_deg: 90.0,
                moon_angle_deg: 90.0,
                magnitude: debris_mag,
            },
            ephemeris: None,
            trajectory,
            stars,
            background: None,
            snr: 1.0,
            snr_noise_level: 1.0,
            snr_noise_sigma: 1.0,
            attempts: 1,
            rejections: BTreeMap::new(),
            collect: None,
            placed: None,
        }
    }

    /// The objects the image shows: the placed ones, or this scene itself.
    pub fn shown(&self) -> Vec<&Scene> {
        match &self.placed {
            Some(placed) => placed.iter().collect(),
            None => vec![self],
        }
    }

    /// Pixel coordinates of a sky position with the pointing of `t_s` seconds after the start.
    pub fn pixel_at(&self, tan: &Tan, t_s: f64, ra_deg: f64, dec_deg: f64) -> Option<(f64, f64)> {
        match &self.pointing {
            Pointing::Fixed { .. } => tan.pixel(ra_deg, dec_deg),
            Pointing::Survey(track) => {
                let (ra, dec) = track.to_mid_frame(t_s, ra_deg, dec_deg);
                tan.pixel(ra, dec)
            }
            Pointing::Track(track) => {
                let (ra, dec) = track.to_mid_frame(t_s, ra_deg, dec_deg);
                tan.pixel(ra, dec)
            }
        }
    }
}

/// Why one scene draw was rejected (`try_draw`). Its words (`as_str`, also its `Display`,
/// `Debug` and serialised form) are the ones truth files and messages have always held, and
/// it orders by them, so a map of rejections keeps its order and bytes.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub enum Rejection {
    EarthAngle,
    SunAngle,
    MoonAngle,
    ThroughEarth,
    EarthShadow,
    TooFaint,
    BrightStar,
    LowSnr,
    PropagationFailed,
    TooFast,
    TrackTooFast,
}

impl Rejection {
    pub fn as_str(self) -> &'static str {
        match self {
            Rejection::EarthAngle => "earth angle",
            Rejection::SunAngle => "sun angle",
            Rejection::MoonAngle => "moon angle",
            Rejection::ThroughEarth => "line of sight through the earth",
            Rejection::EarthShadow => "debris in earth shadow",
            Rejection::TooFaint => "fainter than the magnitude limit",
            Rejection::BrightStar => "star brighter than the limit in the field",
            Rejection::LowSnr => "signal to noise below the gate",
            Rejection::PropagationFailed => "propagation failed",
            Rejection::TooFast => "streak too fast to sample (over 1e6 trajectory samples)",
            Rejection::TrackTooFast => "tracking drift beyond the survey drift limit",
        }
    }
}

impl std::fmt::Display for Rejection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl std::fmt::Debug for Rejection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Debug::fmt(self.as_str(), f)
    }
}

impl Ord for Rejection {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.as_str().cmp(other.as_str())
    }
}

impl PartialOrd for Rejection {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Serialize for Rejection {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

/// Why no scene could be drawn: the image's debris object was never visible.
#[derive(Debug, thiserror::Error)]
#[error(
    "image {image}: {object} (NORAD {norad}, debris[{debris_index}]) was never visible in {attempts} draws (rejections: {reasons})"
)]
pub struct NoScene {
    pub image: u64,
    /// The object drawn for the image: its index in the campaign's debris, name and number.
    pub debris_index: usize,
    pub object: String,
    pub norad: u64,
    pub attempts: u32,
    pub reasons: String,
    /// Draws rejected for each reason.
    pub rejections: BTreeMap<Rejection, u32>,
}

impl NoScene {
    /// The reasons draws were rejected for, the most frequent first.
    pub fn reasons_by_count(&self) -> Vec<Rejection> {
        let mut r: Vec<(Rejection, u32)> = self.rejections.iter().map(|(k, v)| (*k, *v)).collect();
        r.sort_by_key(|&(_, n)| std::cmp::Reverse(n));
        r.into_iter().map(|(k, _)| k).collect()
    }
}

/// The debris object of image `image`, by the spec's weights, from the image's own debris
/// stream (so the retries of the scene draw never change which object an image shows).
pub fn choose_debris(spec: &Spec, debris: usize, seed: u64, image: u64) -> usize {
    pick_debris(spec, debris, &mut stream(seed, image, Purpose::Debris))
}

/// A debris index by the spec's weights, from `rng`.
fn pick_debris(spec: &Spec, debris: usize, rng: &mut ChaCha12Rng) -> usize {
    let weight = |i: usize| spec.debris_weights.get(i).copied().unwrap_or(1.0);
    let total: f64 = (0..debris).map(weight).sum();
    let mut u = rng.random_range(0.0..total);
    for i in 0..debris {
        if u < weight(i) {
            return i;
        }
        u -= weight(i);
    }
    // Rounding of the subtractions can leave u just above the last weight.
    debris - 1
}

/// Draw the scene of image `image` of a campaign with this seed: the debris object first,
/// then the rest, retried on the scene stream until the gate accepts it. In collects the
/// streams are the collect's, the gate judges its first frame, and a later frame follows the
/// first's pointing plan whatever it shows (the object may leave a fixed field or fade).
pub fn draw(
    spec: &Spec,
    sensor: &Sensor,
    inputs: &Inputs,
    seed: u64,
    image: u64,
) -> Result<Scene, NoScene> {
    let frames = spec.collect_frames.max(1);
    let (collect, frame) = (image / frames, image % frames);
    let debris_index = choose_debris(spec, inputs.debris.len(), seed, collect);
    // Drawn only in a mixed campaign, so that every other keeps its streams.
    let on_frame = spec.frame_share >= 1.0
        || stream(seed, collect, Purpose::BackgroundKind).random::<f64>() < spec.frame_share;
    let rng = &mut stream(seed, collect, Purpose::Scene);
    let mut rejections: BTreeMap<Rejection, u32> = BTreeMap::new();
    let max = spec.gate.max_attempts;
    let no_scene = |attempts: u32, rejections: BTreeMap<Rejection, u32>| {
        NoScene::of(inputs, image, debris_index, attempts, rejections)
    };
    for attempt in 1..=max {
        let d = draw_values(spec, inputs, on_frame, rng);
        match try_draw(spec, sensor, inputs, image, debris_index, &d, Plan::First) {
            Ok(first) => {
                let later = if frame == 0 {
                    None
                } else {
                    let plan = Plan::Later {
                        frame,
                        first: &first,
                    };
                    match try_draw(spec, sensor, inputs, image, debris_index, &d, plan) {
                        Ok(s) => Some(s),
                        // The collect was accepted by its first frame: no retry here.
                        Err(reason) => {
                            *rejections.entry(reason).or_default() += 1;
                            return Err(no_scene(attempt, rejections));
                        }
                    }
                };
                // A collect's objects: drawn and judged on its first frame, then followed
                // into this one.
                let placed = match spec.objects {
                    Some(count) => Some(
                        (0..count.draw(seed, collect) as u64)
                            .map(|k| place(spec, sensor, inputs, seed, (&first, later.as_ref()), k))
                            .collect::<Result<Vec<_>, _>>()?,
                    ),
                    None => None,
                };
                let mut scene = later.unwrap_or(first);
                scene.attempts = attempt;
                scene.rejections = rejections;
                if frames > 1 {
                    scene.collect = Some(CollectFrame {
                        collect,
                        frame,
                        frames,
                        track_id: collect,
                    });
                }
                scene.placed = placed;
                return Ok(scene);
            }
            Err(reason) => *rejections.entry(reason).or_default() += 1,
        }
    }
    Err(no_scene(max, rejections))
}

impl NoScene {
    fn of(
        inputs: &Inputs,
        image: u64,
        debris_index: usize,
        attempts: u32,
        rejections: BTreeMap<Rejection, u32>,
    ) -> NoScene {
        let debris = &inputs.debris[debris_index];
        NoScene {
            image,
            debris_index,
            object: debris.name.clone(),
            norad: debris.norad,
            attempts,
            reasons: rejections
                .iter()
                .map(|(k, v)| format!("{k} x{v}"))
                .collect::<Vec<_>>()
                .join(", "),
            rejections,
        }
    }
}

/// Object `k` of a frame (`Spec::objects`): its debris by the weights and its draw, from its
/// own stream, both retried until its own checks accept it (the time is the frame's, so an
/// object in the Earth's shadow then gives way to another: the weights hold among the objects
/// visible at that time). The object keeps its own range, phase
/// angle, brightness and apparent motion at the frame's time; its positions are turned rigidly
/// about the observer so that at mid-exposure it lies at a uniform place within the
/// placement fraction of the field (a catalogued object is rarely in another's field; this
/// puts it there with its own kinematics). It then meets the checks of the pointing's own
/// object there: Earth, Sun and Moon angles, line of sight, shadow, magnitude limit and
/// signal to noise (the bright-star check is the frame's). In a collect (`first` and a
/// `later` frame) the object is the one its first frame accepted (the collect's stream),
/// turned by the same rotation and rendered at the later frame's time unjudged, as the
/// pointing's own object is; it keeps its track id (`object_track_id`).
fn place(
    spec: &Spec,
    sensor: &Sensor,
    inputs: &Inputs,
    seed: u64,
    (first, later): (&Scene, Option<&Scene>),
    k: u64,
) -> Result<Scene, NoScene> {
    let image = later.unwrap_or(first).image_index;
    let frames = spec.collect_frames.max(1);
    let (collect, frame) = (image / frames, image % frames);
    let rng = &mut object_stream(seed, collect, k, Purpose::ObjectScene);
    let mut rejections: BTreeMap<Rejection, u32> = BTreeMap::new();
    let max = spec.gate.max_attempts;
    let mut debris_index = 0;
    for attempt in 1..=max {
        debris_index = pick_debris(spec, inputs.debris.len(), rng);
        let draws = PlaceDraws {
            area_m2: spec.area.draw(rng),
            placement: (
                rng.random_range(-1.0..1.0) * spec.placement_fraction,
                rng.random_range(-1.0..1.0) * spec.placement_fraction,
            ),
            tumble: draw_tumble(spec, rng),
        };
        let shot = |at: &Scene| try_place(spec, sensor, inputs, (first, at), debris_index, &draws);
        match shot(first) {
            Ok(judged) => {
                // A later frame of a collect follows the object accepted on its first, unjudged.
                let mut scene = match later {
                    None => judged,
                    Some(at) => shot(at).map_err(|reason| {
                        rejections.insert(reason, 1);
                        NoScene::of(inputs, image, debris_index, attempt, rejections.clone())
                    })?,
                };
                scene.attempts = attempt;
                scene.rejections = rejections;
                if frames > 1 {
                    scene.collect = Some(CollectFrame {
                        collect,
                        frame,
                        frames,
                        track_id: object_track_id(collect, k),
                    });
                }
                return Ok(scene);
            }
            Err(reason) => *rejections.entry(reason).or_default() += 1,
        }
    }
    Err(NoScene::of(inputs, image, debris_index, max, rejections))
}

/// The track id of object `k` of a collect with `[objects]`: unique in the campaign, the same
/// in every frame of the collect.
pub fn object_track_id(collect: u64, k: u64) -> u64 {
    collect * MAX_OBJECTS_PER_FRAME as u64 + k
}

/// A placed object's own draws, in its stream's order after its debris.
struct PlaceDraws {
    area_m2: f64,
    placement: (f64, f64),
    tumble: Option<Tumble>,
}

/// A rigid turn about the observer (`place`): the debris' place relative to the observer, and
/// its direction, are rotated by `angle_rad` about `axis`.
#[derive(Clone, Copy)]
struct Turn {
    axis: Vec3,
    angle_rad: f64,
}

impl Turn {
    /// The turn that takes direction `from` onto direction `to`.
    fn between(from: Vec3, to: Vec3) -> Turn {
        let axis = cross(from, to);
        if norm(axis) == 0.0 {
            return Turn {
                axis: [0.0, 0.0, 1.0],
                angle_rad: 0.0,
            };
        }
        Turn {
            axis: unit(axis),
            angle_rad: angle_deg(from, to).to_radians(),
        }
    }

    fn apply(&self, sight: Sight) -> Sight {
        let o = sight.observer_km;
        let rel = rotate(sub(sight.debris_km, o), self.axis, self.angle_rad);
        Sight {
            observer_km: o,
            debris_km: [o[0] + rel[0], o[1] + rel[1], o[2] + rel[2]],
            direction: rotate(sight.direction, self.axis, self.angle_rad),
        }
    }
}

/// Object `debris_index` with `draws` in frame `at` of its collect (the first, judged, or a
/// later one, not judged): turned about the observer so that at the first frame's
/// mid-exposure it lies at its placement, and moving on from there with its own motion.
fn try_place(
    spec: &Spec,
    sensor: &Sensor,
    inputs: &Inputs,
    (first, at): (&Scene, &Scene),
    debris_index: usize,
    draws: &PlaceDraws,
) -> Result<Scene, Rejection> {
    let PlaceDraws {
        area_m2,
        placement,
        tumble,
    } = *draws;
    // The first frame is judged; a later one (another scene) follows it.
    let gated = std::ptr::eq(first, at);
    let mid_of = |s: &Scene| s.start + Duration::from_seconds(s.exposure_s / 2.0);
    let sighting_at = |mid: Epoch| {
        Sighting::new(
            &inputs.observer.propagator,
            &inputs.debris[debris_index].propagator,
            mid,
            spec.apparent_positions,
        )
    };
    let first_mid = mid_of(first);
    let first_sighting = sighting_at(first_mid);
    let sight = first_sighting
        .at(first_mid)
        .ok_or(Rejection::PropagationFailed)?;
    let first_tan = first.projection(sensor);
    let (ra_t, dec_t) = first_tan.sky(
        first_tan.cx + placement.0 * sensor.width_px as f64 / 2.0,
        first_tan.cy + placement.1 * sensor.height_px as f64 / 2.0,
    );
    // The camera's mid-exposure frame is the sky's in fixed pointing, and survey pointing is
    // at its mid-exposure attitude then: the place is the same direction in both.
    let turn = Turn::between(unit(sight.direction), radec_unit(ra_t, dec_t));
    let (start, exposure_s, mid) = (at.start, at.exposure_s, mid_of(at));
    let (sighting, sight) = if gated {
        (first_sighting, sight)
    } else {
        let sighting = sighting_at(mid);
        let sight = sighting.at(mid).ok_or(Rejection::PropagationFailed)?;
        (sighting, sight)
    };
    let sight = turn.apply(sight);
    let sun = sun_position_km(mid);
    let (geometry, shadowed) = visibility(spec, sensor, &sight, (sun, mid), area_m2, gated)?;
    let track = sighting
        .track(start, exposure_s)
        .ok_or(Rejection::PropagationFailed)?;
    let trajectory = trajectory(
        spec,
        sensor,
        &|t_s| turn.apply(track.at(t_s)),
        &Shot {
            exposure_s,
            sun,
            area_m2,
            tumble,
            pointing: &at.pointing,
            mid_tan: &at.projection(sensor),
            shadowed,
        },
    )?;
    let (snr, snr_noise_level, snr_noise_sigma) = gate_snr(
        spec,
        sensor,
        &trajectory,
        exposure_s,
        inputs.frame(at.background),
        gated,
    )?;
    let debris = &inputs.debris[debris_index];
    Ok(Scene {
        image_index: at.image_index,
        debris_index,
        debris_name: debris.name.clone(),
        norad: debris.norad,
        start,
        exposure_s,
        pointing: at.pointing.clone(),
        area_m2,
        tumble,
        geometry,
        // The object's own ephemeris is not where the image shows it.
        ephemeris: None,
        trajectory,
        stars: Vec::new(),
        background: at.background,
        snr,
        snr_noise_level,
        snr_noise_sigma,
        attempts: 0,
        rejections: BTreeMap::new(),
        collect: None,
        placed: None,
    })
}

/// The tumbling modulation of one object's draw.
fn draw_tumble(spec: &Spec, rng: &mut ChaCha12Rng) -> Option<Tumble> {
    spec.tumble.map(|r| Tumble {
        period_s: if r.period_max_s > r.period_min_s {
            rng.random_range(r.period_min_s..=r.period_max_s)
        } else {
            r.period_min_s
        },
        amplitude: rng.random_range(0.0..=r.amplitude_max),
        phase_rad: rng.random_range(0.0..std::f64::consts::TAU),
    })
}

/// Visibility of the debris at mid-exposure (paper 3.2.2), its geometry then, and whether it
/// is in the Earth's shadow. Ungated (a later frame of a collect, which the gate does not
/// judge), every check passes and a shadowed object sends no light.
fn visibility(
    spec: &Spec,
    sensor: &Sensor,
    sight: &Sight,
    (sun, mid): (Vec3, Epoch),
    area_m2: f64,
    gated: bool,
) -> Result<(Geometry, bool), Rejection> {
    let (obs, deb) = (sight.observer_km, sight.debris_km);
    let los = sub(deb, obs);
    let moon = moon_position_km(mid);
    let v = &spec.gate;
    let earth_angle_deg = angle_deg(los, sub([0.0; 3], obs));
    if gated && earth_angle_deg <= v.earth_min_deg {
        return Err(Rejection::EarthAngle);
    }
    let sun_angle_deg = angle_deg(los, sub(sun, obs));
    if gated && sun_angle_deg <= v.sun_min_deg {
        return Err(Rejection::SunAngle);
    }
    let moon_angle_deg = angle_deg(los, sub(moon, obs));
    if gated && moon_angle_deg <= v.moon_min_deg {
        return Err(Rejection::MoonAngle);
    }
    if gated && segment_hits_sphere(obs, deb, EARTH_RADIUS_KM + v.earth_clearance_km) {
        return Err(Rejection::ThroughEarth);
    }
    let shadowed = segment_hits_sphere(deb, sun, EARTH_RADIUS_KM);
    if gated && shadowed {
        return Err(Rejection::EarthShadow);
    }
    let phase_angle_deg = angle_deg(sub(sun, deb), sub(obs, deb));
    let range_km = norm(los);
    let magnitude = debris_magnitude(area_m2, spec.albedo, phase_angle_deg.to_radians(), range_km);
    if gated && (magnitude.is_nan() || magnitude > sensor.mag_limit) {
        return Err(Rejection::TooFaint);
    }
    let geometry = Geometry {
        range_km,
        phase_angle_deg,
        earth_angle_deg,
        sun_angle_deg,
        moon_angle_deg,
        magnitude,
    };
    Ok((geometry, shadowed))
}

/// What the trajectory of one object needs of its frame and draw.
struct Shot<'a> {
    exposure_s: f64,
    sun: Vec3,
    area_m2: f64,
    tumble: Option<Tumble>,
    pointing: &'a Pointing,
    mid_tan: &'a Tan,
    /// In the Earth's shadow (a later frame of a collect): the object sends no light.
    shadowed: bool,
}

/// The trajectory of one object, cut in samples at the centres of equal time slices, sampled
/// finer where the samples would render a row of dots (see the comment inside).
fn trajectory(
    spec: &Spec,
    sensor: &Sensor,
    at: &dyn Fn(f64) -> Sight,
    shot: &Shot,
) -> Result<Vec<TrajectorySample>, Rejection> {
    let Shot {
        exposure_s,
        sun,
        area_m2,
        tumble,
        pointing,
        mid_tan,
        shadowed,
    } = *shot;
    let sample = |n: usize| -> Result<Vec<TrajectorySample>, Rejection> {
        let dt = exposure_s / n as f64;
        let mut trajectory = Vec::with_capacity(n);
        for k in 0..n {
            let t_s = (k as f64 + 0.5) * dt;
            let sight = at(t_s);
            let (o, d) = (sight.observer_km, sight.debris_km);
            let los = sub(d, o);
            let (ra_deg, dec_deg) = radec_deg(sight.direction);
            let phase = angle_deg(sub(sun, d), sub(o, d)).to_radians();
            let mut mag = debris_magnitude(area_m2, spec.albedo, phase, norm(los));
            if let Some(tb) = tumble {
                let factor = 1.0
                    + tb.amplitude
                        * (std::f64::consts::TAU * t_s / tb.period_s + tb.phase_rad).sin();
                mag -= 2.5 * factor.log10();
            }
            let expected_electrons = if mag.is_finite() && !shadowed {
                photon_rate(mag, sensor.zero_point_mag) * dt
            } else {
                0.0
            };
            let (ra_cam, dec_cam) = match pointing {
                Pointing::Fixed { .. } => (ra_deg, dec_deg),
                Pointing::Survey(track) => track.to_mid_frame(t_s, ra_deg, dec_deg),
                Pointing::Track(track) => track.to_mid_frame(t_s, ra_deg, dec_deg),
            };
            let (x_px, y_px) = mid_tan
                .pixel(ra_cam, dec_cam)
                .unwrap_or((f64::NAN, f64::NAN));
            trajectory.push(TrajectorySample {
                t_s,
                ra_deg,
                dec_deg,
                mag,
                expected_electrons,
                x_px,
                y_px,
            });
        }
        Ok(trajectory)
    };
    let n = spec.trajectory_samples;
    let mut trajectory = sample(n)?;
    // Samples farther apart in the image than two PSF sigmas render a row of dots, not a
    // streak (a 600 s exposure of LEO debris with 2000 samples: one dot per 128 px; 0.7% of the
    // quickstart draws: 4-8 px). Such a trajectory is sampled again, finer by the factor that
    // brings the spacing to two sigmas; beyond MAX_TRAJECTORY_SAMPLES the draw is rejected.
    let psf_px = sensor.psf_sigma_px();
    let spacing = max_sample_spacing_px(sensor, &trajectory);
    if spacing > MAX_SAMPLE_SPACING_PSF_SIGMAS * psf_px {
        let factor = (spacing / (MAX_SAMPLE_SPACING_PSF_SIGMAS * psf_px)).ceil() as usize;
        let finer = n.saturating_mul(factor);
        if finer > MAX_TRAJECTORY_SAMPLES {
            return Err(Rejection::TooFast);
        }
        trajectory = sample(finer)?;
    }
    Ok(trajectory)
}

/// The signal-to-noise gate (paper 3.2.6): (the judged ratio, by level, by sigma). Ungated (a
/// later frame of a collect), the ratios are computed and not judged.
fn gate_snr(
    spec: &Spec,
    sensor: &Sensor,
    trajectory: &[TrajectorySample],
    exposure_s: f64,
    frame: Option<&RealFrame>,
    gated: bool,
) -> Result<(f64, f64, f64), Rejection> {
    let snr_noise_level = expected_snr(
        sensor,
        trajectory,
        sensor.noise_level_adu(exposure_s, frame),
    );
    let snr_noise_sigma = expected_snr(
        sensor,
        trajectory,
        sensor.background_sigma_adu(exposure_s, frame),
    );
    let snr = match spec.gate.snr_definition {
        SnrDefinition::NoiseLevel => snr_noise_level,
        SnrDefinition::NoiseSigma => snr_noise_sigma,
    };
    if gated && snr < spec.gate.snr_min {
        return Err(Rejection::LowSnr);
    }
    Ok((snr, snr_noise_level, snr_noise_sigma))
}

/// The random values of one draw attempt, in the scene stream's order.
struct Draws {
    exposure_s: f64,
    start: Epoch,
    area_m2: f64,
    placement: (f64, f64),
    background: Option<FrameChoice>,
    tumble: Option<Tumble>,
}

/// Which frame of its collect a scene is: the first (a single image is one), judged by the
/// gate, or a later one, which follows the first's pointing plan and is not judged.
#[derive(Clone, Copy)]
enum Plan<'a> {
    First,
    Later { frame: u64, first: &'a Scene },
}

fn draw_values(spec: &Spec, inputs: &Inputs, on_frame: bool, rng: &mut ChaCha12Rng) -> Draws {
    let span_s = (spec.window_end - spec.window_start).to_seconds();
    let exposure_s = if spec.exposure_max_s > spec.exposure_min_s {
        rng.random_range(spec.exposure_min_s..=spec.exposure_max_s)
    } else {
        spec.exposure_min_s
    };
    let start = spec.window_start + Duration::from_seconds(rng.random_range(0.0..span_s));
    let area_m2 = spec.area.draw(rng);
    let placement = (
        rng.random_range(-1.0..1.0) * spec.placement_fraction,
        rng.random_range(-1.0..1.0) * spec.placement_fraction,
    );
    let background = match &inputs.background {
        BackgroundModel::Frames(frames) if on_frame => {
            let frame = rng.random_range(0..frames.len());
            let f = &frames[frame];
            Some(FrameChoice {
                frame,
                offset: (rng.random_range(0..f.width), rng.random_range(0..f.height)),
            })
        }
        _ => None,
    };
    let tumble = draw_tumble(spec, rng);
    Draws {
        exposure_s,
        start,
        area_m2,
        placement,
        background,
        tumble,
    }
}

fn try_draw(
    spec: &Spec,
    sensor: &Sensor,
    inputs: &Inputs,
    image: u64,
    debris_index: usize,
    d: &Draws,
    plan: Plan,
) -> Result<Scene, Rejection> {
    let Draws {
        exposure_s,
        area_m2,
        placement,
        background,
        tumble,
        ..
    } = *d;
    let gated = matches!(plan, Plan::First);
    // Frame k of a collect starts k (exposure + gap) after the first.
    let offset_s = match plan {
        Plan::First => 0.0,
        Plan::Later { frame, .. } => frame as f64 * (exposure_s + spec.collect_gap_s),
    };
    let start = match plan {
        Plan::First => d.start,
        Plan::Later { .. } => d.start + Duration::from_seconds(offset_s),
    };
    let mid = start + Duration::from_seconds(exposure_s / 2.0);

    // Visibility at mid-exposure (paper 3.2.2).
    let sighting = Sighting::new(
        &inputs.observer.propagator,
        &inputs.debris[debris_index].propagator,
        mid,
        spec.apparent_positions,
    );
    let sight = sighting.at(mid).ok_or(Rejection::PropagationFailed)?;
    let sun = sun_position_km(mid);
    // A later frame of a collect is not judged (`gated` false); in it the object may have
    // entered the shadow, and then sends no light.
    let (geometry, shadowed) = visibility(spec, sensor, &sight, (sun, mid), area_m2, gated)?;

    // Pointing: the debris at mid-exposure lands at a random place in the field.
    let (ra_mid, dec_mid) = radec_deg(sight.direction);
    let scale = sensor.pixel_scale_deg();
    let around_debris = sensor.projection(ra_mid, dec_mid);
    let half_w = sensor.width_px as f64 / 2.0;
    let half_h = sensor.height_px as f64 / 2.0;
    let placed = around_debris.sky(
        around_debris.cx - placement.0 * half_w,
        around_debris.cy - placement.1 * half_h,
    );
    // A later frame keeps the first's plan: a fixed direction, the survey attitude running on
    // (the first frame's rotation, continued), or the object held on its pixel.
    let (ra_p, dec_p) = match plan {
        Plan::Later { first, .. } => match &first.pointing {
            Pointing::Fixed { ra_deg, dec_deg } => (*ra_deg, *dec_deg),
            Pointing::Survey(t0) => t0.radec_at(t0.t_mid_s + offset_s),
            Pointing::Track(_) => placed,
        },
        Plan::First => placed,
    };
    let (pointing, cone) = match spec.pointing {
        PointingMode::Fixed => (
            Pointing::Fixed {
                ra_deg: ra_p,
                dec_deg: dec_p,
            },
            spec.star_cone_deg,
        ),
        PointingMode::Survey => {
            let track = survey_track(sensor, &sighting, mid, exposure_s, (ra_p, dec_p))
                .ok_or(Rejection::PropagationFailed)?;
            // The star cone covers the field along the whole drift and nothing more.
            let half_diag_deg =
                scale * (sensor.width_px as f64).hypot(sensor.height_px as f64) / 2.0;
            (
                Pointing::Survey(track),
                track.drift_deg / 2.0 + half_diag_deg + STAR_CONE_MARGIN_DEG,
            )
        }
        PointingMode::Track => {
            let sights = sighting
                .track(start, exposure_s)
                .ok_or(Rejection::PropagationFailed)?;
            let track = target_track(sensor, &sights, exposure_s, (ra_p, dec_p))
                .ok_or(Rejection::PropagationFailed)?;
            // The star budget of the campaign (`campaign::validate`) allows a survey's drift.
            if track.drift_deg > MAX_SURVEY_DRIFT_DEG {
                return Err(Rejection::TrackTooFast);
            }
            // The boresight at t is the mid one turned by R(t), by the debris' angle from
            // mid-exposure to t (at most the reach; between nodes, half a pixel more at most,
            // within the margin): the cone around the mid boresight.
            let half_diag_deg =
                scale * (sensor.width_px as f64).hypot(sensor.height_px as f64) / 2.0;
            let cone = track.reach_deg() + half_diag_deg + STAR_CONE_MARGIN_DEG;
            (Pointing::Track(track), cone)
        }
    };

    // Field stars in the cone; a star brighter than the limit spoils the image (paper 3.2.3).
    let field = inputs
        .stars
        .stars_in_cone(ra_p, dec_p, cone, sensor.mag_limit, mid);
    if gated && field.iter().any(|s| s.mag < spec.gate.brightest_star_mag) {
        return Err(Rejection::BrightStar);
    }

    let mid_tan = sensor.projection(ra_p, dec_p);
    let track = sighting
        .track(start, exposure_s)
        .ok_or(Rejection::PropagationFailed)?;
    let trajectory = trajectory(
        spec,
        sensor,
        &|t_s| track.at(t_s),
        &Shot {
            exposure_s,
            sun,
            area_m2,
            tumble,
            pointing: &pointing,
            mid_tan: &mid_tan,
            shadowed,
        },
    )?;

    let (snr, snr_noise_level, snr_noise_sigma) = gate_snr(
        spec,
        sensor,
        &trajectory,
        exposure_s,
        inputs.frame(background),
        gated,
    )?;

    let ephemeris = sighting.ephemeris(start, exposure_s);
    let debris = &inputs.debris[debris_index];
    Ok(Scene {
        image_index: image,
        debris_index,
        debris_name: debris.name.clone(),
        norad: debris.norad,
        start,
        exposure_s,
        pointing,
        area_m2,
        tumble,
        geometry,
        ephemeris,
        trajectory,
        stars: field,
        background,
        snr,
        snr_noise_level,
        snr_noise_sigma,
        attempts: 0,
        rejections: BTreeMap::new(),
        collect: None,
        placed: None,
    })
}

/// Expected debris signal over noise, the paper's acceptance gate (3.2.6): the mean debris ADU
/// per footprint pixel over `noise_adu`, the per-pixel level of background plus bias (the
/// paper's reading) or their standard deviation (see `SnrDefinition`). The footprint is the
/// in-image streak length times the PSF FWHM, plus one FWHM square: `(L + w) w`. Computed from
/// expected values, before any photon is traced.
pub fn expected_snr(sensor: &Sensor, trajectory: &[TrajectorySample], noise_adu: f64) -> f64 {
    let mut electrons = 0.0;
    let mut length_px = 0.0;
    let mut last: Option<(f64, f64)> = None;
    for p in trajectory {
        let (x, y) = (p.x_px, p.y_px);
        if sensor.contains(x, y) {
            electrons += p.expected_electrons;
            if let Some((lx, ly)) = last {
                length_px += ((x - lx).powi(2) + (y - ly).powi(2)).sqrt();
            }
            last = Some((x, y));
        } else {
            last = None;
        }
    }
    let fwhm_px = sensor.psf_fwhm_px();
    let footprint = (length_px + fwhm_px) * fwhm_px;
    let signal_adu = electrons / sensor.gain_e_per_adu / footprint.max(1.0);
    if noise_adu > 0.0 {
        signal_adu / noise_adu
    } else if signal_adu > 0.0 {
        f64::INFINITY
    } else {
        0.0
    }
}

/// Largest in-image distance between consecutive trajectory samples, in PSF sigmas, before the
/// trajectory is sampled more finely: a sum of Gaussians 2 sigma apart ripples by 1.4%.
pub const MAX_SAMPLE_SPACING_PSF_SIGMAS: f64 = 2.0;

/// Most trajectory samples a refined trajectory may have (the campaign's own limit).
pub const MAX_TRAJECTORY_SAMPLES: usize = 1_000_000;

/// Largest pixel distance between consecutive trajectory samples of which at least one lies in
/// the image (0 when none does).
pub fn max_sample_spacing_px(sensor: &Sensor, trajectory: &[TrajectorySample]) -> f64 {
    let inside = |p: &TrajectorySample| sensor.contains(p.x_px, p.y_px);
    trajectory
        .windows(2)
        .filter(|pair| inside(&pair[0]) || inside(&pair[1]))
        .map(|pair| (pair[1].x_px - pair[0].x_px).hypot(pair[1].y_px - pair[0].y_px))
        .filter(|d| d.is_finite())
        .fold(0.0, f64::max)
}

/// Extra radius of the survey star cone beyond the field along the drift.
const STAR_CONE_MARGIN_DEG: f64 = 0.01;

/// The survey track of the observer at mid-exposure, with the boresight `(ra, dec)` then.
fn survey_track(
    sensor: &Sensor,
    sighting: &Sighting,
    mid: Epoch,
    exposure_s: f64,
    boresight: (f64, f64),
) -> Option<SurveyTrack> {
    // Orbit normal and rate from the observer's velocity by a central difference.
    let h = 0.5;
    let r0 = sighting.observer_km(mid - Duration::from_seconds(h))?;
    let r1 = sighting.observer_km(mid + Duration::from_seconds(h))?;
    let r = sighting.observer_km(mid)?;
    let v = scale(sub(r1, r0), 1.0 / (2.0 * h));
    let n = cross(r, v);
    let rate_deg_s = (norm(n) / dot(r, r)).to_degrees();
    let axis = unit(n);
    // The boresight moves on a small circle about the orbit normal.
    let sin_from_axis = angle_deg(radec_unit(boresight.0, boresight.1), axis)
        .to_radians()
        .sin();
    let mut track = SurveyTrack {
        mid_ra_deg: boresight.0,
        mid_dec_deg: boresight.1,
        axis,
        rate_deg_s,
        t_mid_s: exposure_s / 2.0,
        drift_deg: rate_deg_s * exposure_s * sin_from_axis,
        trail_angle_deg: 0.0,
    };
    track.trail_angle_deg = trail_angle_deg(sensor, boresight, exposure_s, &|t_s, ra, dec| {
        track.to_mid_frame(t_s, ra, dec)
    })?;
    Some(track)
}

/// Eq. 13 with atan2: how a star at the mid-exposure boresight moves across the image, from
/// the start to the end of the exposure, given how the pointing maps a direction at time t
/// into the mid-exposure camera frame.
fn trail_angle_deg(
    sensor: &Sensor,
    boresight: (f64, f64),
    exposure_s: f64,
    to_mid_frame: &dyn Fn(f64, f64, f64) -> (f64, f64),
) -> Option<f64> {
    let tan = sensor.projection(boresight.0, boresight.1);
    let (ra0, dec0) = to_mid_frame(0.0, boresight.0, boresight.1);
    let (ra1, dec1) = to_mid_frame(exposure_s, boresight.0, boresight.1);
    let (x0, y0) = tan.standard(ra0, dec0)?;
    let (x1, y1) = tan.standard(ra1, dec1)?;
    Some((y1 - y0).atan2(x1 - x0).to_degrees())
}

#[cfg(test)]
mod rejection_tests {
    use super::Rejection;
    use std::collections::BTreeMap;

    /// Truth files hold rejections as a map from these words, in their alphabetical order.
    #[test]
    fn rejections_keep_their_words_and_order() {
        let mut m = BTreeMap::new();
        for r in [
            Rejection::SunAngle,
            Rejection::EarthAngle,
            Rejection::LowSnr,
        ] {
            m.insert(r, 1u32);
        }
        assert_eq!(
            serde_json::to_string(&m).unwrap(),
            r#"{"earth angle":1,"signal to noise below the gate":1,"sun angle":1}"#
        );
        assert_eq!(
            format!("{:?}", m),
            r#"{"earth angle": 1, "signal to noise below the gate": 1, "sun angle": 1}"#
        );
        assert_eq!(
            Rejection::TooFaint.to_string(),
            "fainter than the magnitude limit"
        );
    }
}
