//! Photon mapping (paper 2.2, 3.2.4-3.2.6): expected photons per source (Eq. 3), a Poisson
//! draw, arrival times, Brownian jitter shared by every source (Eq. 2), a Gaussian PSF, the
//! gnomonic projection, counting per pixel (one pixel convention, see `sky::projection`), and
//! the detector (Eq. 11). Also the label box and the truth of the debris as rendered.
//! It reads the sensor and its own settings, never the campaign file.

use serde::Serialize;
use soig_base::rng::PixelRng;

use crate::background::RealFrame;
use crate::scene::Scene;
use crate::sensor::Sensor;
use soig_base::rng::poisson;
use soig_image::geometry::{BoxPx, LABEL_SHARE, flux_box};

pub mod cost;
mod detector;
pub mod expected;
mod jitter;
mod photons;
#[cfg(test)]
mod seeing_tests;
mod sources;
#[cfg(test)]
mod tests;
pub mod trails;
mod truth;

pub use jitter::Jitter;
use photons::{Canvas, Tally, trace};
pub use sources::TracedStar;
use sources::{Path, Source, for_each_source};
pub use truth::iso_utc;
pub use truth::{FrameTruth, ObjectTruth, Seen, StreakEnds, Truth};

/// Above this many packets per source the packet weight grows so that no source traces more
/// (only reached by sources far brighter than a scene allows, e.g. a magnitude -1 star). The
/// debris counts as one source: its trajectory samples share this budget.
pub const MAX_PACKETS_PER_SOURCE: u64 = 50_000_000;

/// How photons reach the detector: `photon_mapping` (the paper's Monte Carlo, with the
/// merging approximation) or `expected` (each source's expected photons per pixel, then one
/// Poisson draw per pixel).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, Serialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum RenderMethod {
    #[default]
    PhotonMapping,
    Expected,
}

impl RenderMethod {
    pub fn is_photon_mapping(&self) -> bool {
        *self == RenderMethod::PhotonMapping
    }

    /// The name a campaign file uses.
    pub fn name(&self) -> &'static str {
        match self {
            RenderMethod::PhotonMapping => "photon_mapping",
            RenderMethod::Expected => "expected",
        }
    }
}

/// The renderer's approximation knobs.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub method: RenderMethod,
    /// Sources with more photons than this are traced in packets of `merge_factor` photons.
    pub merge_threshold: u64,
    pub merge_factor: u32,
    /// Steps of the Brownian jitter path over the exposure.
    pub jitter_steps: usize,
}

/// A rendered exposure.
pub struct Exposure {
    pub width: usize,
    pub height: usize,
    /// Noise-free image: photo-electrons per pixel from all sources.
    pub electrons: Vec<u32>,
    /// Noise-free photo-electrons of the debris alone, for its label box in any frame.
    pub debris_electrons: Vec<u32>,
    /// Noisy image in ADU (Eq. 11).
    pub adu: Vec<f32>,
    pub truth: Truth,
    pub stars: Vec<TracedStar>,
    /// The placed objects (`Scene::placed`), in their order; None for a scene without.
    pub objects: Option<Vec<ObjectExposure>>,
}

/// One placed object as rendered: its truth (the frame's fields as the image's) and its
/// noise-free photo-electrons alone, for its label box in any frame.
pub struct ObjectExposure {
    pub truth: Truth,
    pub debris: expected::DebrisMap,
}

/// Where the photons of the sources go: traced one by one (the debris' drawn per pixel, the
/// same distribution), or as expected flux per pixel.
enum Photons {
    Mapped(Tally),
    Expected(expected::Flux),
}

/// Render a scene: photons (one stream, the jitter path first), then detector noise (another).
pub fn render(
    sensor: &Sensor,
    settings: &Settings,
    scene: &Scene,
    frame: Option<&RealFrame>,
    photons_rng: &mut PixelRng,
    noise_rng: &mut PixelRng,
) -> Exposure {
    let jitter = Jitter::of_scene(sensor, settings, scene, photons_rng);
    render_with_jitter(
        sensor,
        settings,
        scene,
        frame,
        &jitter,
        photons_rng,
        noise_rng,
        None,
    )
}

/// Whether no debris trajectory sample can draw more photons than the merge threshold (so
/// that photon mapping traces them all singly): the brightest sample's Poisson count exceeds
/// its mean by 12 standard deviations plus 12 with a chance below 1e-25.
fn singles_only(scene: &Scene, merge_threshold: u64) -> bool {
    let most = scene
        .object
        .trajectory
        .iter()
        .map(|p| p.expected_electrons)
        .fold(0.0, f64::max);
    most + 12.0 * most.sqrt() + 12.0 < merge_threshold as f64
}

/// Render a scene for a given jitter path. A scene with placed objects (`Scene::placed`) needs
/// `object_photons`: each of its objects traces its photons on its own stream,
/// `object_photons(k)`, after the frame's stars, with the same jitter path, and the pointing's
/// own object is then not rendered.
#[allow(clippy::too_many_arguments)]
pub fn render_with_jitter(
    sensor: &Sensor,
    settings: &Settings,
    scene: &Scene,
    frame: Option<&RealFrame>,
    jitter: &Jitter,
    photons_rng: &mut PixelRng,
    noise_rng: &mut PixelRng,
    object_photons: Option<&dyn Fn(u64) -> PixelRng>,
) -> Exposure {
    // A ground site's sky for this image, in the detector's noise and the truth's sigma.
    let sensor = &*sensor.under_sky(scene.exposure.sky_v_mag_per_arcsec2);
    let (width, height) = (sensor.width_px, sensor.height_px);
    let unrendered;
    let own = match &scene.placed {
        Some(_) => {
            let mut bare = Scene {
                placed: None,
                ..scene.clone()
            };
            bare.object.trajectory = Vec::new();
            unrendered = bare;
            &unrendered
        }
        None => scene,
    };
    let (mut canvas, traced, debris_flux) = photons(sensor, settings, own, jitter, photons_rng);
    let objects = scene.placed.as_ref().map(|placed| {
        placed
            .iter()
            .enumerate()
            .map(|(k, object)| {
                let object_photons = object_photons
                    .expect("a scene with placed objects is rendered with their streams");
                let rng = &mut object_photons(k as u64);
                let flux = expected::debris_flux(sensor, object, jitter);
                // An object alone, its photons all single: drawn per pixel as `photons` would
                // (the same draws) into a map of the box they can reach, and added to the
                // image there: no whole image of zeros to fill, add and search an object.
                let (debris, total) = if settings.method.is_photon_mapping()
                    && singles_only(object, settings.merge_threshold)
                {
                    flux.draw_own_box(rng)
                } else {
                    let (c, _, _) = photons(sensor, settings, object, jitter, rng);
                    (expected::DebrisMap::crop(&c.debris, width), c.debris_total)
                };
                for (to, from) in debris.rows(width) {
                    for (e, &d) in canvas.electrons[to].iter_mut().zip(&debris.counts[from]) {
                        *e = e.saturating_add(d);
                    }
                }
                let label_box = debris.label_box(LABEL_SHARE);
                let truth = truth_of(sensor, object, frame, jitter, (label_box, total), &flux, 0);
                ObjectExposure { truth, debris }
            })
            .collect()
    });
    let adu = detector::adu(sensor, &canvas.electrons, scene, frame, noise_rng);
    // With placed objects the pointing's own object is not rendered: no photon, no box.
    let label_box = match scene.placed {
        Some(_) => None,
        None => flux_box(&canvas.debris, width, height, LABEL_SHARE),
    };
    let truth = truth_of(
        sensor,
        own,
        frame,
        jitter,
        (label_box, canvas.debris_total),
        &debris_flux,
        traced.len(),
    );
    Exposure {
        width,
        height,
        electrons: canvas.electrons,
        debris_electrons: canvas.debris,
        adu,
        truth,
        stars: traced,
        objects,
    }
}

/// The photons of a scene's stars and debris on the detector, the stars traced, and the
/// debris' expected flux.
fn photons(
    sensor: &Sensor,
    settings: &Settings,
    scene: &Scene,
    jitter: &Jitter,
    photons_rng: &mut PixelRng,
) -> (Canvas, Vec<TracedStar>, expected::DebrisFlux) {
    let s = sensor;
    let (width, height) = (s.width_px, s.height_px);
    let psf = scene.psf(sensor);
    let merge = (settings.merge_threshold, settings.merge_factor);
    let mut photons = match settings.method {
        RenderMethod::PhotonMapping => Photons::Mapped(Tally::new(width, height)),
        RenderMethod::Expected => {
            Photons::Expected(expected::Flux::with_psf(width, height, psf.clone()))
        }
    };
    // The debris' trajectory samples share one source's packet budget (2000 samples of a
    // magnitude -1 debris would otherwise trace 2e9 packets).
    let debris_packets =
        (MAX_PACKETS_PER_SOURCE / scene.object.trajectory.len().max(1) as u64).max(1);
    let debris_flux = expected::debris_flux(sensor, scene, jitter);
    // Where no trajectory sample can be merged into packets, all its photons are single and
    // drawn per pixel from the debris' expected flux: the same distribution as tracing them
    // (`DebrisFlux::draw`), at a fraction of the cost.
    let debris_per_pixel =
        settings.method.is_photon_mapping() && singles_only(scene, settings.merge_threshold);
    let traced = for_each_source(sensor, scene, jitter, |source| match &mut photons {
        Photons::Mapped(_) if source.debris && debris_per_pixel => {}
        Photons::Mapped(tally) => {
            let count = poisson(photons_rng, source.expected);
            let budget = if source.debris {
                debris_packets
            } else {
                MAX_PACKETS_PER_SOURCE
            };
            trace(
                tally,
                photons_rng,
                count,
                merge,
                budget,
                jitter,
                &psf,
                source,
            );
        }
        Photons::Expected(flux) => flux.add(source, jitter),
    });
    let canvas = match photons {
        Photons::Mapped(mut tally) => {
            if debris_per_pixel {
                tally.draw_debris(&debris_flux, photons_rng);
            }
            tally.canvas()
        }
        Photons::Expected(flux) => flux.draw(photons_rng),
    };
    (canvas, traced, debris_flux)
}

/// The truth of a scene's debris as rendered (its label box and photo-electrons in all;
/// `stars_traced`: the stars of the image).
fn truth_of(
    sensor: &Sensor,
    scene: &Scene,
    frame: Option<&RealFrame>,
    jitter: &Jitter,
    (label_box_px, debris_total): (Option<BoxPx>, u64),
    debris_flux: &expected::DebrisFlux,
    stars_traced: usize,
) -> Truth {
    let t_exp = scene.exposure.exposure_s;
    let jitter_mean = jitter.mean();
    let (expected_debris, mag_min, mag_max) = scene
        .object
        .trajectory
        .iter()
        .fold((0.0, f64::INFINITY, f64::NEG_INFINITY), |(e, lo, hi), p| {
            (e + p.expected_electrons, lo.min(p.mag), hi.max(p.mag))
        });

    let at = |p: Option<&crate::scene::TrajectorySample>| {
        p.map(|p| {
            let (jx, jy) = jitter.at(p.t_s);
            [p.x_px + jx, p.y_px + jy]
        })
    };
    let sigma_adu = sensor.background_sigma_adu(t_exp, frame);
    let first = at(scene.object.trajectory.first());
    let last = at(scene.object.trajectory.last());
    let g = &scene.object.geometry;
    // The FITS WCS: the mid-exposure projection moved by the mean jitter (artifacts).
    let wcs = scene
        .projection(sensor)
        .shifted(jitter_mean.0, jitter_mean.1);
    let through_wcs = |p: Option<[f64; 2]>| {
        p.map_or([f64::NAN; 2], |[x, y]| {
            let (ra, dec) = wcs.sky(x, y);
            [ra, dec]
        })
    };
    let coordinates = match scene.exposure.pointing {
        crate::scene::Pointing::Survey(_) => {
            format!("{} {}", truth::COORDINATES, truth::SURVEY_COORDINATES)
        }
        crate::scene::Pointing::Track(_) => {
            format!("{} {}", truth::COORDINATES, truth::TRACK_COORDINATES)
        }
        crate::scene::Pointing::Fixed { .. } => truth::COORDINATES.to_string(),
    };
    Truth {
        coordinates,
        image_index: scene.exposure.image_index,
        object: scene.object.debris_name.clone(),
        norad: scene.object.norad,
        start_utc: iso_utc(scene.exposure.start),
        exposure_s: t_exp,
        pointing: scene.exposure.pointing.clone(),
        jitter_mean_px: [jitter_mean.0, jitter_mean.1],
        streak: StreakEnds {
            start_px: first.unwrap_or([f64::NAN; 2]),
            end_px: last.unwrap_or([f64::NAN; 2]),
            start_wcs_radec_deg: through_wcs(first),
            end_wcs_radec_deg: through_wcs(last),
        },
        label_box_px,
        frame: None,
        label_box_final_px: None,
        seen: Seen {
            magnitude: g.magnitude,
            magnitude_min: mag_min,
            magnitude_max: mag_max,
            area_m2: scene.object.area_m2,
            range_km: g.range_km,
            phase_angle_deg: g.phase_angle_deg,
            earth_angle_deg: g.earth_angle_deg,
            sun_angle_deg: g.sun_angle_deg,
            moon_angle_deg: g.moon_angle_deg,
            tumble: scene.object.tumble,
            expected_debris_electrons: expected_debris,
            rendered_debris_electrons: debris_total,
            snr: scene.object.snr.judged,
            snr_noise_level: scene.object.snr.noise_level,
            snr_noise_sigma: scene.object.snr.noise_sigma,
        },
        snr_matched_filter: debris_flux.matched_filter_snr(sensor.gain_e_per_adu, sigma_adu),
        stars_in_cone: scene.exposure.stars.len(),
        stars_traced,
        background_sigma_adu: sigma_adu,
        background_frame: frame.map(|f| f.name.clone()),
        background_frame_sha256: frame.map(|f| f.sha256.clone()),
        attempts: scene.attempts,
        rejections: scene.rejections.clone(),
        ephemeris: scene.object.ephemeris,
        collect: scene.collect,
        seeing: scene.exposure.seeing,
        scintillation: scene.scintillation,
        sky_v_mag_per_arcsec2: scene.exposure.sky_v_mag_per_arcsec2,
    }
}
