//! An accepted scene, everything the renderer needs, and its parts: the trajectory samples,
//! the light curve, the geometry at mid-exposure, its place in a collect. `Scene::assemble` is
//! the one place a scene is put together.

use std::collections::BTreeMap;

use hifitime::Epoch;
use serde::Serialize;

use super::visibility::Snr;
use super::{Body, Pointing, Rejection, Spec};
use crate::atmosphere::{Scintillation, Seeing};
use crate::background::FrameChoice;
use crate::sensor::Sensor;
use crate::sighting::Ephemeris;
use soig_image::psf_shape::Psf;
use soig_sky::photometry::photon_rate;
use soig_sky::projection::Tan;
use soig_sky::stars::Star;

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

/// An accepted scene: everything the renderer needs. Its object in its exposure, as the draw
/// saw them, with what the draw and the frame add to them.
#[derive(Clone, Debug)]
pub struct Scene {
    pub exposure: Exposure,
    pub object: Object,
    /// Draws tried, and why the rejected ones were rejected.
    pub attempts: u32,
    pub rejections: BTreeMap<Rejection, u32>,
    /// Its place in a multi-frame collect (None: a single image).
    pub collect: Option<CollectFrame>,
    /// The objects of an image of a campaign with `[objects]` (possibly none), each a scene of
    /// its own with this one's time, pointing and background and no stars; this scene's own
    /// object then only chose the pointing and is not rendered. None: this scene's object is
    /// the image's one object.
    pub placed: Option<Vec<Scene>>,
    /// In a catalogue scene (`catalogue`): the population's objects in the field that the
    /// checks rejected, with the reason; None in any other scene.
    pub unseen: Option<Vec<super::Unseen>>,
    /// A generated object of a catalogue scene's population (a breakup fragment).
    pub generated: bool,
    /// The observer's GCRS state (km, km/s) at mid-exposure where the scene has no
    /// ephemeris of its own to state it (a catalogue stare): the FITS `OBSPOS-*`, `OBSVEL-*`.
    pub observer_gcrs: Option<(soig_sky::Vec3, soig_sky::Vec3)>,
    /// A ground site's scintillation of this object in this exposure (`scintillation`), its
    /// factor already in the trajectory's expected electrons.
    pub scintillation: Option<Scintillation>,
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
    /// The PSF the renderer draws: the seeing's Moffat where the exposure has seeing, else
    /// the sensor's Gaussian.
    pub fn psf(&self, sensor: &Sensor) -> Psf {
        psf_of(sensor, self.exposure.seeing)
    }

    /// The projection at mid-exposure: the one the FITS WCS describes.
    pub fn projection(&self, sensor: &Sensor) -> Tan {
        let (ra, dec) = self.exposure.pointing.mid_radec_deg();
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
        let exposure = Exposure {
            image_index: 0,
            start: Epoch::from_gregorian_utc_at_midnight(2022, 1, 1),
            exposure_s,
            pointing: Pointing::Fixed {
                ra_deg: ra,
                dec_deg: dec,
            },
            stars,
            background: None,
            seeing: None,
            sky_v_mag_per_arcsec2: None,
        };
        let object = Object {
            debris_index: 0,
            debris_name: "test".into(),
            norad: 1,
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
            snr: Snr {
                judged: 1.0,
                noise_level: 1.0,
                noise_sigma: 1.0,
            },
        };
        Scene::assemble(exposure, object).accept(1, BTreeMap::new(), None, None)
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
        match &self.exposure.pointing {
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

/// The PSF of an exposure with `seeing` (`Scene::psf`).
pub fn psf_of(sensor: &Sensor, seeing: Option<Seeing>) -> Psf {
    match seeing {
        Some(s) => Psf::moffat(s.fwhm_arcsec / 3600.0 / sensor.pixel_scale_deg(), s.beta),
        None => Psf::gaussian(sensor.psf_sigma_px()),
    }
}

/// The exposure a scene's object is seen in: which image, when, how long, where the sensor
/// points, its field stars and its real background frame.
#[derive(Clone, Debug)]
pub struct Exposure {
    pub image_index: u64,
    pub start: Epoch,
    pub exposure_s: f64,
    pub pointing: Pointing,
    pub stars: Vec<Star>,
    /// The real background frame of a semisynthetic image.
    pub background: Option<FrameChoice>,
    /// A ground site's seeing over the exposure (None: the sensor's Gaussian PSF).
    pub seeing: Option<Seeing>,
    /// A ground site's sky toward the boresight, V mag/arcsec^2 (`GroundGate::sky`): the
    /// physical noise model's sky for this image.
    pub sky_v_mag_per_arcsec2: Option<f64>,
}

impl Exposure {
    /// Frame `at`'s exposure, for another of its objects (a placed or catalogue one): its
    /// time, pointing and background; its stars stay with the frame's own scene.
    pub(super) fn of_frame(at: &Scene) -> Exposure {
        Exposure {
            pointing: at.exposure.pointing.clone(),
            stars: Vec::new(),
            ..at.exposure
        }
    }
}

/// A scene's object as one draw saw it: which debris, its own draws, and what the visibility
/// checks and the signal-to-noise gate measured.
#[derive(Clone, Debug)]
pub struct Object {
    pub debris_index: usize,
    pub debris_name: String,
    pub norad: u64,
    pub area_m2: f64,
    pub tumble: Option<Tumble>,
    pub geometry: Geometry,
    /// The debris' place at start, middle and end and the states at mid-exposure (None for a
    /// hand-made scene).
    pub ephemeris: Option<Ephemeris>,
    pub trajectory: Vec<TrajectorySample>,
    pub snr: Snr,
}

impl Object {
    /// Body `body`, at `index` in its list (the campaign's debris or the population), with its
    /// own draws (area, tumble) and what its checks measured.
    pub(super) fn of_body(
        (index, body): (usize, &Body),
        (area_m2, tumble): (f64, Option<Tumble>),
        geometry: Geometry,
        ephemeris: Option<Ephemeris>,
        trajectory: Vec<TrajectorySample>,
        snr: Snr,
    ) -> Object {
        Object {
            debris_index: index,
            debris_name: body.name.clone(),
            norad: body.norad,
            area_m2,
            tumble,
            geometry,
            ephemeris,
            trajectory,
            snr,
        }
    }
}

impl Scene {
    /// The one place a scene is put together: an object in its exposure, not yet accepted
    /// (no draws counted, no collect, nothing placed in it: `accept` adds those).
    pub(super) fn assemble(exposure: Exposure, object: Object) -> Scene {
        Scene {
            exposure,
            object,
            attempts: 0,
            rejections: BTreeMap::new(),
            collect: None,
            placed: None,
            unseen: None,
            generated: false,
            observer_gcrs: None,
            scintillation: None,
        }
    }

    /// The scene accepted at draw `attempts`, the earlier ones rejected for `rejections`, with
    /// its place in a collect and the objects placed in it.
    pub(super) fn accept(
        self,
        attempts: u32,
        rejections: BTreeMap<Rejection, u32>,
        collect: Option<CollectFrame>,
        placed: Option<Vec<Scene>>,
    ) -> Scene {
        Scene {
            attempts,
            rejections,
            collect,
            placed,
            ..self
        }
    }
}

impl CollectFrame {
    /// Image `image`'s place in its collect, its object followed as `track_id`; None for a
    /// single image.
    pub(super) fn of(spec: &Spec, image: u64, track_id: u64) -> Option<CollectFrame> {
        let frames = spec.collect_frames.max(1);
        let (collect, frame) = spec.collect_of(image);
        (frames > 1).then_some(CollectFrame {
            collect,
            frame,
            frames,
            track_id,
        })
    }
}
