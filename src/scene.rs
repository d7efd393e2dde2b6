//! The scene draw (paper 3.2.1-3.2.3): which debris, when, how long, where the sensor points,
//! which stars are in the field, and the visibility checks that reject a draw. A rejected draw
//! retries with the same random stream, so the accepted scene is a pure function of
//! (campaign, image index).

use std::collections::BTreeMap;

use hifitime::{Duration, Epoch};
use rand::RngExt;
use rand_chacha::ChaCha12Rng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;

use crate::campaign::{Campaign, LightCurve, Stars};
use crate::sky::ephemeris::{moon_position_km, sun_position_km};
use crate::sky::orbit::{Mat3, mat_vec, teme_to_gcrs_matrix};
use crate::sky::photometry::{debris_magnitude, photon_rate};
use crate::sky::projection::Tan;
use crate::sky::stars::{ProceduralSky, Star, StarCatalog};
use crate::sky::{Vec3, angle_deg, norm, radec_deg, segment_hits_sphere, sub};

/// WGS84 equatorial radius, km.
pub const EARTH_RADIUS_KM: f64 = 6378.137;

/// The source of field stars of a campaign, loaded once.
pub enum StarField {
    Procedural(ProceduralSky),
    Catalog(StarCatalog),
}

impl StarField {
    pub fn load(campaign: &Campaign) -> Result<StarField, String> {
        Ok(match &campaign.resolved.stars {
            Stars::Procedural { sky_seed, .. } => {
                StarField::Procedural(ProceduralSky::new(*sky_seed))
            }
            Stars::Catalog {
                path, epoch_jyear, ..
            } => StarField::Catalog(
                StarCatalog::from_csv_path(&campaign.base_dir.join(path), *epoch_jyear)
                    .map_err(|e| e.to_string())?,
            ),
        })
    }

    fn stars_in_cone(&self, ra: f64, dec: f64, radius: f64, mag_max: f64, at: Epoch) -> Vec<Star> {
        match self {
            StarField::Procedural(sky) => sky.stars_in_cone(ra, dec, radius, mag_max),
            StarField::Catalog(cat) => cat.stars_in_cone(ra, dec, radius, mag_max, julian_year(at)),
        }
    }
}

/// Julian year (TT) of an instant, e.g. 2016.0 for the Gaia DR3 epoch.
pub fn julian_year(t: Epoch) -> f64 {
    2000.0 + (t.to_jde_tt_days() - 2_451_545.0) / 365.25
}

/// Where the sensor points. Fixed pointing carries only its direction; the survey variant
/// (issue #3) will carry its attitude track.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "mode", rename_all = "lowercase")]
pub enum Pointing {
    Fixed { ra_deg: f64, dec_deg: f64 },
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
    pub trajectory: Vec<TrajectorySample>,
    pub stars: Vec<Star>,
    /// Expected debris signal per footprint pixel over background noise, the acceptance gate.
    pub snr: f64,
    /// Draws tried, and why the rejected ones were rejected.
    pub attempts: u32,
    pub rejections: BTreeMap<&'static str, u32>,
}

impl Scene {
    /// The projection of this scene's pointing.
    pub fn projection(&self, campaign: &Campaign) -> Tan {
        let s = &campaign.resolved.sensor;
        match self.pointing {
            Pointing::Fixed { ra_deg, dec_deg } => Tan::new(
                ra_deg,
                dec_deg,
                pixel_scale_deg(campaign),
                s.width_px,
                s.height_px,
            ),
        }
    }
}

/// Degrees per pixel: the field radius spans half the image width.
pub fn pixel_scale_deg(campaign: &Campaign) -> f64 {
    let s = &campaign.resolved.sensor;
    s.fov_radius_deg / (s.width_px as f64 / 2.0)
}

/// Why no scene could be drawn.
#[derive(Debug, thiserror::Error)]
#[error("image {image}: no acceptable scene in {attempts} draws (rejections: {reasons})")]
pub struct NoScene {
    pub image: u64,
    pub attempts: u32,
    pub reasons: String,
}

/// Background plus bias noise standard deviation per pixel, ADU, for an exposure.
pub fn background_sigma_adu(campaign: &Campaign, exposure_s: f64) -> f64 {
    let s = &campaign.resolved.sensor;
    let k = exposure_s / s.background_exposure_s;
    let bg = (s.background_max_adu - s.background_min_adu) * k;
    let bias = s.bias_max_adu - s.bias_min_adu;
    ((bg * bg + bias * bias) / 12.0).sqrt()
}

/// Draw the scene of one image, retrying rejected draws on the same stream.
pub fn draw(
    campaign: &Campaign,
    stars: &StarField,
    image: u64,
    rng: &mut ChaCha12Rng,
) -> Result<Scene, NoScene> {
    let mut rejections: BTreeMap<&'static str, u32> = BTreeMap::new();
    let max = campaign.resolved.visibility.max_attempts;
    for attempt in 1..=max {
        match try_draw(campaign, stars, image, rng) {
            Ok(mut scene) => {
                scene.attempts = attempt;
                scene.rejections = rejections;
                return Ok(scene);
            }
            Err(reason) => *rejections.entry(reason).or_default() += 1,
        }
    }
    Err(NoScene {
        image,
        attempts: max,
        reasons: rejections
            .iter()
            .map(|(k, v)| format!("{k} x{v}"))
            .collect::<Vec<_>>()
            .join(", "),
    })
}

/// Positions at time t (GCRS km) of observer and debris; None if either cannot be propagated.
/// The TEME -> GCRS rotation changes by far less than a milliarcsecond over an exposure, so one
/// matrix (at mid-exposure) serves the whole exposure.
fn positions(
    campaign: &Campaign,
    debris: usize,
    t: Epoch,
    teme_to_gcrs: &Mat3,
) -> Option<(Vec3, Vec3)> {
    let obs = campaign.observer.propagator.position_teme_km(t).ok()?;
    let deb = campaign.debris[debris]
        .propagator
        .position_teme_km(t)
        .ok()?;
    let (obs, deb) = (mat_vec(teme_to_gcrs, obs), mat_vec(teme_to_gcrs, deb));
    (obs.iter().chain(deb.iter()).all(|x| x.is_finite())).then_some((obs, deb))
}

fn try_draw(
    campaign: &Campaign,
    stars: &StarField,
    image: u64,
    rng: &mut ChaCha12Rng,
) -> Result<Scene, &'static str> {
    let c = &campaign.resolved;
    let debris_index = rng.random_range(0..campaign.debris.len());
    let span_s = (campaign.window_end - campaign.window_start).to_seconds();
    let exposure_s = if c.exposure.max_s > c.exposure.min_s {
        rng.random_range(c.exposure.min_s..=c.exposure.max_s)
    } else {
        c.exposure.min_s
    };
    let start = campaign.window_start + Duration::from_seconds(rng.random_range(0.0..span_s));
    let mid = start + Duration::from_seconds(exposure_s / 2.0);
    let area_m2 = Normal::new(c.photometry.rcs_mean_m2, c.photometry.rcs_std_m2)
        .expect("validated std")
        .sample(rng)
        .abs();
    let placement = (
        rng.random_range(-1.0..1.0) * c.pointing.placement_fraction,
        rng.random_range(-1.0..1.0) * c.pointing.placement_fraction,
    );
    let tumble = match c.photometry.light_curve {
        LightCurve::None => None,
        LightCurve::Tumbling {
            period_min_s,
            period_max_s,
            amplitude_max,
        } => Some(Tumble {
            period_s: if period_max_s > period_min_s {
                rng.random_range(period_min_s..=period_max_s)
            } else {
                period_min_s
            },
            amplitude: rng.random_range(0.0..=amplitude_max),
            phase_rad: rng.random_range(0.0..std::f64::consts::TAU),
        }),
    };

    // Visibility at mid-exposure (paper 3.2.2).
    let frame = teme_to_gcrs_matrix(mid);
    let (obs, deb) = positions(campaign, debris_index, mid, &frame).ok_or("propagation failed")?;
    let los = sub(deb, obs);
    let sun = sun_position_km(mid);
    let moon = moon_position_km(mid);
    let v = &c.visibility;
    let earth_angle_deg = angle_deg(los, sub([0.0; 3], obs));
    if earth_angle_deg <= v.earth_min_deg {
        return Err("earth angle");
    }
    let sun_angle_deg = angle_deg(los, sub(sun, obs));
    if sun_angle_deg <= v.sun_min_deg {
        return Err("sun angle");
    }
    let moon_angle_deg = angle_deg(los, sub(moon, obs));
    if moon_angle_deg <= v.moon_min_deg {
        return Err("moon angle");
    }
    if segment_hits_sphere(obs, deb, EARTH_RADIUS_KM + v.earth_clearance_km) {
        return Err("line of sight through the earth");
    }
    if segment_hits_sphere(deb, sun, EARTH_RADIUS_KM) {
        return Err("debris in earth shadow");
    }
    let phase_angle_deg = angle_deg(sub(sun, deb), sub(obs, deb));
    let range_km = norm(los);
    let magnitude = debris_magnitude(
        area_m2,
        c.photometry.albedo,
        phase_angle_deg.to_radians(),
        range_km,
    );
    if magnitude.is_nan() || magnitude > c.sensor.mag_limit {
        return Err("fainter than the magnitude limit");
    }

    // Pointing: the debris at mid-exposure lands at a random place in the field.
    let (ra_mid, dec_mid) = radec_deg(los);
    let scale = pixel_scale_deg(campaign);
    let around_debris = Tan::new(
        ra_mid,
        dec_mid,
        scale,
        c.sensor.width_px,
        c.sensor.height_px,
    );
    let half_w = c.sensor.width_px as f64 / 2.0;
    let half_h = c.sensor.height_px as f64 / 2.0;
    let (ra_p, dec_p) = around_debris.sky(
        around_debris.cx - placement.0 * half_w,
        around_debris.cy - placement.1 * half_h,
    );
    let pointing = Pointing::Fixed {
        ra_deg: ra_p,
        dec_deg: dec_p,
    };

    // Field stars in the cone; a star brighter than the limit spoils the image (paper 3.2.3).
    let cone = c.stars.cone_radius_deg();
    let field = stars.stars_in_cone(ra_p, dec_p, cone, c.sensor.mag_limit, mid);
    if field.iter().any(|s| s.mag < v.brightest_star_mag) {
        return Err("star brighter than the limit in the field");
    }

    // The trajectory, cut in samples at the centres of equal time slices.
    let n = c.render.trajectory_samples as usize;
    let dt = exposure_s / n as f64;
    let mut trajectory = Vec::with_capacity(n);
    for k in 0..n {
        let t_s = (k as f64 + 0.5) * dt;
        let t = start + Duration::from_seconds(t_s);
        let (o, d) = positions(campaign, debris_index, t, &frame).ok_or("propagation failed")?;
        let los = sub(d, o);
        let (ra_deg, dec_deg) = radec_deg(los);
        let phase = angle_deg(sub(sun, d), sub(o, d)).to_radians();
        let mut mag = debris_magnitude(area_m2, c.photometry.albedo, phase, norm(los));
        if let Some(tb) = tumble {
            let factor = 1.0
                + tb.amplitude * (std::f64::consts::TAU * t_s / tb.period_s + tb.phase_rad).sin();
            mag -= 2.5 * factor.log10();
        }
        let expected_electrons = if mag.is_finite() {
            photon_rate(mag, c.sensor.zero_point_mag) * dt
        } else {
            0.0
        };
        trajectory.push(TrajectorySample {
            t_s,
            ra_deg,
            dec_deg,
            mag,
            expected_electrons,
        });
    }

    let tan = Tan::new(ra_p, dec_p, scale, c.sensor.width_px, c.sensor.height_px);
    let snr = expected_snr(campaign, &tan, &trajectory, exposure_s);
    if snr < campaign.snr_min() {
        return Err("signal to noise below the gate");
    }

    let debris = &campaign.debris[debris_index];
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
        geometry: Geometry {
            range_km,
            phase_angle_deg,
            earth_angle_deg,
            sun_angle_deg,
            moon_angle_deg,
            magnitude,
        },
        trajectory,
        stars: field,
        snr,
        attempts: 0,
        rejections: BTreeMap::new(),
    })
}

/// Expected debris signal over noise, the paper's acceptance gate (3.2.6), defined here as the
/// mean debris ADU per footprint pixel over the per-pixel standard deviation of background plus
/// bias. The footprint is the in-image streak length times the PSF FWHM, plus one FWHM square:
/// `(L + w) w`. Computed from expected values, before any photon is traced.
pub fn expected_snr(
    campaign: &Campaign,
    tan: &Tan,
    trajectory: &[TrajectorySample],
    exposure_s: f64,
) -> f64 {
    let s = &campaign.resolved.sensor;
    let (w, h) = (s.width_px as f64, s.height_px as f64);
    let inside = |x: f64, y: f64| x >= -0.5 && x < w - 0.5 && y >= -0.5 && y < h - 0.5;
    let mut electrons = 0.0;
    let mut length_px = 0.0;
    let mut last: Option<(f64, f64)> = None;
    for p in trajectory {
        let Some((x, y)) = tan.pixel(p.ra_deg, p.dec_deg) else {
            last = None;
            continue;
        };
        if inside(x, y) {
            electrons += p.expected_electrons;
            if let Some((lx, ly)) = last {
                length_px += ((x - lx).powi(2) + (y - ly).powi(2)).sqrt();
            }
            last = Some((x, y));
        } else {
            last = None;
        }
    }
    let fwhm_px = 2.3548 * s.psf_sigma_arcsec / 3600.0 / tan.scale_deg;
    let footprint = (length_px + fwhm_px) * fwhm_px;
    let signal_adu = electrons / s.gain_e_per_adu / footprint.max(1.0);
    let noise = background_sigma_adu(campaign, exposure_s);
    if noise > 0.0 {
        signal_adu / noise
    } else if signal_adu > 0.0 {
        f64::INFINITY
    } else {
        0.0
    }
}
