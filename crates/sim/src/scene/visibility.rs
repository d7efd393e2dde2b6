//! The checks that reject a draw: visibility at mid-exposure (paper 3.2.2) and the expected
//! signal-to-noise gate (paper 3.2.6).

use hifitime::Epoch;
use soig_sky::ephemeris::moon_position_km;
use soig_sky::night::conditions;
use soig_sky::photometry::debris_magnitude;
use soig_sky::{Vec3, angle_deg, norm, segment_hits_sphere, sub};

use super::{EARTH_RADIUS_KM, Geometry, Rejection, SnrDefinition, Spec, TrajectorySample};
use crate::background::RealFrame;
use crate::sensor::Sensor;
use crate::sighting::Sight;

/// Visibility of the debris at mid-exposure (paper 3.2.2), its geometry then, and whether it
/// sends no light (in the Earth's shadow). Ungated (a later frame of a collect, whose line of
/// sight `draw` judges apart), every check passes, and an object in the shadow or behind the
/// solid Earth sends no light: it is neither drawn nor labelled.
pub(super) fn visibility(
    spec: &Spec,
    sensor: &Sensor,
    sight: &Sight,
    (sun, mid): (Vec3, Epoch),
    area_m2: f64,
    gated: bool,
) -> Result<(Geometry, bool), Rejection> {
    let (obs, deb) = (sight.observer_km, sight.debris_km);
    let los = sub(deb, obs);
    let Angles {
        earth_angle_deg,
        sun_angle_deg,
        moon_angle_deg,
    } = if gated {
        in_sight(spec, sight, (sun, mid))?
    } else {
        angles(sight, (sun, mid))
    };
    let shadowed = segment_hits_sphere(deb, sun, EARTH_RADIUS_KM);
    if gated && shadowed {
        return Err(Rejection::EarthShadow);
    }
    let phase_angle_deg = angle_deg(sub(sun, deb), sub(obs, deb));
    let range_km = norm(los);
    let extinction = spec.ground.as_ref().and_then(|g| g.extinction(mid));
    let magnitude = debris_magnitude(area_m2, spec.albedo, phase_angle_deg.to_radians(), range_km)
        + extinction.map_or(0.0, |e| e.mag(los));
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
    let hidden = !gated
        && match &spec.ground {
            // A site sits inside the equatorial sphere: it is the horizon that hides.
            Some(g) => conditions(&g.site, mid, deb).object_alt_deg < 0.0,
            None => segment_hits_sphere(obs, deb, EARTH_RADIUS_KM),
        };
    Ok((geometry, shadowed || hidden))
}

/// The angles of a line of sight from the Earth's centre, the Sun and the Moon, degrees.
pub(super) struct Angles {
    pub earth_angle_deg: f64,
    pub sun_angle_deg: f64,
    pub moon_angle_deg: f64,
}

fn angles(sight: &Sight, (sun, mid): (Vec3, Epoch)) -> Angles {
    let obs = sight.observer_km;
    let los = sub(sight.debris_km, obs);
    Angles {
        earth_angle_deg: angle_deg(los, sub([0.0; 3], obs)),
        sun_angle_deg: angle_deg(los, sub(sun, obs)),
        moon_angle_deg: angle_deg(los, sub(moon_position_km(mid), obs)),
    }
}

/// The checks of a line of sight (paper 3.2.2) that every frame of a collect must pass, its
/// later frames included: the Earth, Sun and Moon angles, and a line of sight clear of the
/// Earth (an object behind the Earth is not seen, however bright). Shadow and faintness only
/// dim a later frame's object.
pub(super) fn in_sight(
    spec: &Spec,
    sight: &Sight,
    (sun, mid): (Vec3, Epoch),
) -> Result<Angles, Rejection> {
    let a = angles(sight, (sun, mid));
    let v = &spec.gate;
    if let Some(g) = &spec.ground {
        // A ground site: the night's conditions replace the Earth's angle and clearance.
        let c = conditions(&g.site, mid, sight.debris_km);
        if c.sun_alt_deg > g.night.sun_max_alt_deg {
            return Err(Rejection::Daylight);
        }
        if c.object_alt_deg < g.night.object_min_alt_deg {
            return Err(Rejection::BelowHorizon);
        }
    } else if a.earth_angle_deg <= v.earth_min_deg {
        return Err(Rejection::EarthAngle);
    }
    if a.sun_angle_deg <= v.sun_min_deg {
        return Err(Rejection::SunAngle);
    }
    if a.moon_angle_deg <= v.moon_min_deg {
        return Err(Rejection::MoonAngle);
    }
    if spec.ground.is_none()
        && segment_hits_sphere(
            sight.observer_km,
            sight.debris_km,
            EARTH_RADIUS_KM + v.earth_clearance_km,
        )
    {
        return Err(Rejection::ThroughEarth);
    }
    Ok(a)
}

/// An object's expected signal-to-noise ratios (`expected_snr`).
#[derive(Clone, Copy, Debug)]
pub struct Snr {
    /// The one the gate judges, by its definition (one of the two below).
    pub judged: f64,
    /// Over the mean level of background plus bias, and over their standard deviation.
    pub noise_level: f64,
    pub noise_sigma: f64,
}

/// The signal-to-noise gate (paper 3.2.6). Ungated (a later frame of a collect), the ratios
/// are computed and not judged.
pub(super) fn gate_snr(
    spec: &Spec,
    sensor: &Sensor,
    trajectory: &[TrajectorySample],
    exposure_s: f64,
    frame: Option<&RealFrame>,
    gated: bool,
) -> Result<Snr, Rejection> {
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
    Ok(Snr {
        judged: snr,
        noise_level: snr_noise_level,
        noise_sigma: snr_noise_sigma,
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
