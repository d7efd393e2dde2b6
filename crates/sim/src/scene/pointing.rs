//! Where the sensor points over a draw's exposure: inertially fixed, the observer's survey
//! attitude drifting across the sky, or rate-tracking the debris, with the star cone each
//! needs.

use hifitime::{Duration, Epoch};
use soig_sky::{Vec3, angle_deg, cross, dot, norm, radec_unit, scale, sub, unit};

use super::{
    MAX_SURVEY_DRIFT_DEG, Pointing, PointingMode, Rejection, Spec, SurveyTrack, TargetTrack,
};
use crate::sensor::Sensor;
use crate::sighting::{Sighting, Track};

/// How the sensor points over the exposure `(start, mid, exposure_s)` with the boresight
/// `(ra, dec)` at mid-exposure, and the radius of the star cone that covers its field.
pub(super) fn point_sensor(
    spec: &Spec,
    sensor: &Sensor,
    sighting: &Sighting,
    (start, mid, exposure_s): (Epoch, Epoch, f64),
    (ra_p, dec_p): (f64, f64),
) -> Result<(Pointing, f64), Rejection> {
    let half_diag_deg =
        sensor.pixel_scale_deg() * (sensor.width_px as f64).hypot(sensor.height_px as f64) / 2.0;
    Ok(match spec.pointing {
        PointingMode::Fixed => (
            Pointing::Fixed {
                ra_deg: ra_p,
                dec_deg: dec_p,
            },
            spec.star_cone_deg,
        ),
        PointingMode::Survey => {
            let track = survey_track(sensor, sighting, mid, exposure_s, (ra_p, dec_p))
                .ok_or(Rejection::PropagationFailed)?;
            // The star cone covers the field along the whole drift and nothing more.
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
            let cone = track.reach_deg() + half_diag_deg + STAR_CONE_MARGIN_DEG;
            (Pointing::Track(track), cone)
        }
    })
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
    let (axis, rate_deg_s) = match sighting.stare_axis(mid) {
        // A ground telescope held in altitude and azimuth: a GEO stare.
        Some(stare) => stare,
        None => {
            // Orbit normal and rate from the observer's velocity by a central difference.
            let h = 0.5;
            let r0 = sighting.observer_km(mid - Duration::from_seconds(h))?;
            let r1 = sighting.observer_km(mid + Duration::from_seconds(h))?;
            let r = sighting.observer_km(mid)?;
            let v = scale(sub(r1, r0), 1.0 / (2.0 * h));
            let n = cross(r, v);
            (unit(n), (norm(n) / dot(r, r)).to_degrees())
        }
    };
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

/// Largest distance, in pixels, between the debris' directions at two consecutive nodes of a
/// `TargetTrack`: over half a pixel the apparent path's curvature and rate change leave
/// interpolation errors of micro-pixels (the path is a great circle to second order).
const TRACK_NODE_SPACING_PX: f64 = 0.5;

/// The track pointing that follows the debris of `sights` over an exposure of `exposure_s`,
/// with the boresight `(ra, dec)` at mid-exposure; None if the debris direction is not finite.
fn target_track(
    sensor: &Sensor,
    sights: &Track,
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
