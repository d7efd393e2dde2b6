//! The config layer: a resolved campaign becomes the values the core works on, built once
//! (GalSim's split: profiles, images and noise never see the config). The sensor, the scene
//! spec, the render and enhancement settings and the final frame are plain values gathered in
//! an [`Experiment`]; the pipeline, `soig study`, the benchmarks and an embedding program all
//! render through `simulate::image` with them, and vary a clone when they vary a knob.

use std::path::PathBuf;

use serde::Serialize;

use crate::background::BackgroundModel;
use crate::campaign::{self, Background, Campaign, LightCurve, PhotometryPreset, Stars};
use crate::enhance;
use crate::error::Error;
use crate::geometry::Frame;
use crate::noise::{self, Noise};
use crate::render;
use crate::scene::{self, Gate, Inputs, PointingMode, StarField, TumbleRange};
use crate::sensor::{AduRange, Sensor};
pub use crate::simulate::{Experiment, Product};
use crate::sky::debris_sizes;
use crate::sky::stars::{ProceduralSky, StarCatalog};

/// Values resolved late from several campaign fields (or from none): recorded in the manifest
/// so a run says what it used.
#[derive(Clone, Debug, Serialize)]
pub struct Effective {
    pub pixel_scale_arcsec: f64,
    pub psf_sigma_px: f64,
    pub psf_fwhm_px: f64,
    /// The signal-to-noise gate of the pointing mode (`visibility.snr_min` or its default).
    pub snr_min: f64,
    /// Square-root compression as applied (the paper's: fixed pointing only).
    pub sqrt: Option<bool>,
    /// Size of the final PNG frame, pixels.
    pub frame_px: Option<[usize; 2]>,
    /// Training image size and batch (`train.imgsz` / `train.batch` or the paper's).
    pub train_imgsz: u32,
    pub train_batch: u32,
    /// The physical noise model's sky, photo-electrons per second per pixel (absent for the
    /// paper's model).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sky_e_per_s: Option<f64>,
}

/// The values a campaign renders with (the config layer's one reading of the campaign for the
/// simulator).
pub fn of(campaign: &Campaign) -> Experiment {
    let c = &campaign.resolved;
    let s = &c.sensor;
    let sensor = Sensor {
        width_px: s.width_px as usize,
        height_px: s.height_px as usize,
        fov_radius_deg: s.fov_radius_deg,
        psf_sigma_arcsec: s.psf_sigma_arcsec,
        zero_point_mag: s.zero_point_mag,
        mag_limit: s.mag_limit,
        jitter_deg_per_sqrt_s: s.jitter_deg_per_sqrt_s,
        gain_e_per_adu: s.gain_e_per_adu,
        bias: AduRange {
            min_adu: s.bias_min_adu,
            max_adu: s.bias_max_adu,
        },
        background: AduRange {
            min_adu: s.background_min_adu,
            max_adu: s.background_max_adu,
        },
        background_exposure_s: s.background_exposure_s,
        noise: Noise::Paper,
    };
    let sensor = Sensor {
        noise: noise_of(c, &sensor),
        ..sensor
    };
    let v = &c.visibility;
    let scene = scene::Spec {
        window_start: campaign.world.window_start,
        window_end: campaign.world.window_end,
        exposure_min_s: c.exposure.min_s,
        exposure_max_s: c.exposure.max_s,
        pointing: c.pointing.mode,
        debris_weights: c.debris.iter().map(|d| d.weight.unwrap_or(1.0)).collect(),
        placement_fraction: c.pointing.placement_fraction,
        area: photometry_area(&c.photometry),
        albedo: match c.photometry.preset {
            PhotometryPreset::Paper => c.photometry.albedo,
            PhotometryPreset::NasaFragments => debris_sizes::ODPO_ALBEDO,
        },
        tumble: match c.photometry.light_curve {
            LightCurve::None => None,
            LightCurve::Tumbling {
                period_min_s,
                period_max_s,
                amplitude_max,
            } => Some(TumbleRange {
                period_min_s,
                period_max_s,
                amplitude_max,
            }),
        },
        gate: Gate {
            earth_min_deg: v.earth_min_deg,
            sun_min_deg: v.sun_min_deg,
            moon_min_deg: v.moon_min_deg,
            earth_clearance_km: v.earth_clearance_km,
            brightest_star_mag: v.brightest_star_mag,
            snr_min: campaign.snr_min(),
            snr_definition: v.snr_definition,
            max_attempts: v.max_attempts,
        },
        star_cone_deg: c.stars.cone_radius_deg(),
        trajectory_samples: c.render.trajectory_samples as usize,
        apparent_positions: c.render.apparent_positions,
        frame_share: match &c.background {
            Background::Frames { share, .. } => *share,
            Background::Uniform => 1.0,
        },
        collect_frames: c.collect_frames() as u64,
        collect_gap_s: c.collect.as_ref().map_or(0.0, |k| k.gap_s),
        ground: campaign.world.ground.clone(),
        objects: c.objects.as_ref().map(|o| {
            let (min, max) = o.per_frame.bounds();
            scene::ObjectCount {
                min,
                max,
                empty_share: o.empty_share,
            }
        }),
        catalogue: c.population.as_ref().map(|_| match c.pointing.stare {
            Some(s) => scene::CatalogueScene::Stare {
                ra_deg: s.ra_deg,
                dec_deg: s.dec_deg,
            },
            None => scene::CatalogueScene::Target,
        }),
    };
    let render = render::Settings {
        method: c.render.method,
        merge_threshold: c.render.merge_threshold,
        merge_factor: c.render.merge_factor,
        jitter_steps: c.render.jitter_steps as usize,
    };
    let e = &c.enhance;
    let product = c
        .stages
        .contains(&crate::campaign::Stage::Enhance)
        .then(|| Product {
            frame: e.geometry,
            pad_px: e.pad_px as usize,
            enhance: enhance_settings(Some(campaign)),
        });
    Experiment {
        seed: c.seed,
        sensor,
        scene,
        render,
        product,
    }
}

/// The values resolved late, for the manifest.
pub fn effective(x: &Experiment, campaign: &Campaign) -> Effective {
    let (train_imgsz, train_batch) = train_size_and_batch(campaign);
    let frame = x.product.as_ref().map(|p| {
        let f = Frame::new(
            p.frame,
            x.sensor.width_px,
            x.sensor.height_px,
            p.pad_px,
            0.0,
        );
        [f.width, f.height]
    });
    Effective {
        pixel_scale_arcsec: x.sensor.pixel_scale_deg() * 3600.0,
        psf_sigma_px: x.sensor.psf_sigma_px(),
        psf_fwhm_px: x.sensor.psf_fwhm_px(),
        snr_min: x.scene.gate.snr_min,
        sqrt: x.product.as_ref().map(|p| p.enhance.sqrt),
        frame_px: frame,
        train_imgsz,
        train_batch,
        sky_e_per_s: match &x.sensor.noise {
            Noise::Physical(p) => Some(p.sky_e_per_s),
            Noise::Paper => None,
        },
    }
}

/// The detector's noise model; a physical sky given in mag/arcsec^2 becomes e-/s per pixel
/// with the sensor's zero point and pixel scale.
fn noise_of(c: &crate::campaign::CampaignFile, sensor: &Sensor) -> Noise {
    let campaign::Noise::Physical(p) = &c.noise else {
        return Noise::Paper;
    };
    let sky = match (p.sky_e_per_s, p.sky_mag_per_arcsec2) {
        (Some(e), _) => e,
        (None, Some(mag)) => noise::sky_e_per_s(
            mag,
            sensor.zero_point_mag,
            sensor.pixel_scale_deg() * 3600.0,
        ),
        (None, None) => 0.0,
    };
    Noise::Physical(noise::Physical {
        seed: c.seed,
        sky_e_per_s: sky,
        dark_e_per_s: p.dark_e_per_s,
        read_noise_e: p.read_noise_e,
        bias_adu: p.bias_adu,
        full_well_e: p.full_well_e,
        adc_max_adu: p.adc_max_adu,
        hot_pixels: (p.hot_pixel_fraction > 0.0 && p.hot_pixel_dark_e_per_s > 0.0).then_some(
            noise::HotPixels {
                fraction: p.hot_pixel_fraction,
                dark_e_per_s: p.hot_pixel_dark_e_per_s,
            },
        ),
        cosmic_rays: (p.cosmic_rate_per_cm2_s > 0.0).then_some(noise::CosmicRays {
            rate_per_cm2_s: p.cosmic_rate_per_cm2_s,
            pixel_size_um: p.pixel_size_um,
        }),
    })
}

/// Image size and batch of a campaign's training: the paper's (frame width; batch 16, 10 for
/// the 1472 px rotated frame) unless the campaign sets them.
pub fn train_size_and_batch(campaign: &Campaign) -> (u32, u32) {
    let c = &campaign.resolved;
    let f = Frame::new(
        c.enhance.geometry,
        c.sensor.width_px as usize,
        c.sensor.height_px as usize,
        c.enhance.pad_px as usize,
        0.0,
    );
    let frame = f.width.max(f.height) as u32;
    let imgsz = c.train.imgsz.unwrap_or(frame.div_ceil(32) * 32);
    let batch = c.train.batch.unwrap_or(if imgsz > 1024 { 10 } else { 16 });
    (imgsz, batch)
}

/// Read what a campaign needs before its first image: bodies, stars and background frames.
pub fn inputs(campaign: &Campaign) -> Result<Inputs, Error> {
    let c = &campaign.resolved;
    let stars = match &c.stars {
        Stars::Procedural { sky_seed, .. } => StarField::Procedural(ProceduralSky::new(*sky_seed)),
        Stars::Catalog {
            path, epoch_jyear, ..
        } => StarField::Catalog(
            StarCatalog::from_csv_path(&campaign.base_dir.join(path), *epoch_jyear)
                .map_err(|e| campaign.error_at("stars.path", e.to_string()))?,
        ),
    };
    let frames: Vec<PathBuf> = match &c.background {
        Background::Uniform => Vec::new(),
        Background::Frames { paths, .. } => {
            paths.iter().map(|p| campaign.base_dir.join(p)).collect()
        }
    };
    Ok(Inputs {
        observer: campaign.world.observer.clone(),
        debris: campaign.world.debris.clone(),
        population: campaign.world.population.clone(),
        population_coarse: coarse_orbits(campaign),
        stars,
        background: BackgroundModel::load(&frames)
            .map_err(|e| campaign.error_at("background.paths", e.to_string()))?,
    })
}

/// The enhancement of a campaign's PNGs (its `[enhance]`, the square root for fixed pointing
/// only, paper 3.3), or soig's defaults without a campaign.
pub fn enhance_settings(campaign: Option<&Campaign>) -> enhance::Settings {
    let default = crate::campaign::Enhance::default();
    let (e, fixed) = match campaign {
        Some(c) => (
            &c.resolved.enhance,
            c.resolved.pointing.mode == PointingMode::Fixed,
        ),
        None => (&default, true),
    };
    enhance::Settings {
        sqrt: e.sqrt && fixed,
        clahe_clip_limit: e.clahe_clip_limit,
        clahe_tiles: e.clahe_tiles,
        gamma: e.gamma,
    }
}

/// The area model of a campaign's photometry (its preset's, else the paper's normal).
fn photometry_area(p: &crate::campaign::Photometry) -> debris_sizes::AreaModel {
    match p.preset {
        PhotometryPreset::Paper => debris_sizes::AreaModel::Normal {
            mean_m2: p.rcs_mean_m2,
            std_m2: p.rcs_std_m2,
        },
        PhotometryPreset::NasaFragments => debris_sizes::AreaModel::Breakup {
            lc_min_m: 0.1,
            lc_max_m: 1.0,
            exponent: debris_sizes::SBM_COLLISION_EXPONENT,
        },
    }
}

/// The cheap orbit of each object of the population, measured against SGP4 over every instant
/// an exposure may cover (the window and one longest exposure after it).
fn coarse_orbits(campaign: &Campaign) -> Vec<crate::sky::orbit::CoarseOrbit> {
    use rayon::prelude::*;
    let end = campaign.world.window_end
        + hifitime::Duration::from_seconds(campaign.resolved.exposure.max_s);
    campaign
        .world
        .population
        .par_iter()
        .map(|b| {
            crate::sky::orbit::CoarseOrbit::new(&b.propagator, (campaign.world.window_start, end))
        })
        .collect()
}
