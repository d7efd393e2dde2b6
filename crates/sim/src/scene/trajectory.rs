//! The debris trajectory of one object over its exposure: samples at the centres of equal
//! time slices, with their magnitudes, expected electrons and pixel places, refined where a
//! streak would render as a row of dots.

use soig_sky::photometry::{debris_magnitude, photon_rate};
use soig_sky::projection::Tan;
use soig_sky::{Vec3, angle_deg, norm, radec_deg, sub};

use hifitime::Epoch;

use super::{Pointing, Rejection, Scene, Spec, TrajectorySample, Tumble};
use crate::observer::Extinction;
use crate::sensor::Sensor;
use crate::sighting::Sight;

/// What the trajectory of one object needs of its frame and draw.
pub(super) struct Shot<'a> {
    pub exposure_s: f64,
    pub sun: Vec3,
    pub area_m2: f64,
    pub tumble: Option<Tumble>,
    pub pointing: &'a Pointing,
    pub mid_tan: Tan,
    /// In the Earth's shadow (a later frame of a collect): the object sends no light.
    pub shadowed: bool,
    /// A ground site's air, which dims the object by its airmass at each sample.
    pub extinction: Option<Extinction>,
    /// The core sigma of the PSF drawn (`Psf::core_sigma_px`), pixels: the sensor's own, or
    /// the seeing's.
    pub psf_core_px: f64,
}

impl<'a> Shot<'a> {
    /// The shot of one more object in the frame `at` already drawn (a placed or catalogue
    /// object): the frame's exposure, pointing, mid-exposure projection and PSF, and the
    /// site's air at `mid`, with the Sun there at `sun`.
    pub(super) fn in_frame(
        spec: &Spec,
        sensor: &Sensor,
        at: &'a Scene,
        (sun, mid): (Vec3, Epoch),
        (area_m2, tumble): (f64, Option<Tumble>),
        shadowed: bool,
    ) -> Self {
        Shot {
            exposure_s: at.exposure.exposure_s,
            sun,
            area_m2,
            tumble,
            pointing: &at.exposure.pointing,
            mid_tan: at.projection(sensor),
            shadowed,
            extinction: spec.ground.as_ref().and_then(|g| g.extinction(mid)),
            psf_core_px: at.psf(sensor).core_sigma_px(),
        }
    }
}

/// The trajectory of one object, cut in samples at the centres of equal time slices, sampled
/// finer where the samples would render a row of dots (see the comment inside).
pub(super) fn trajectory(
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
        extinction,
        ..
    } = *shot;
    let sample = |n: usize| -> Result<Vec<TrajectorySample>, Rejection> {
        let dt = exposure_s / n as f64;
        let mut trajectory = Vec::with_capacity(n);
        for k in 0..n {
            let t_s = sample_time_s(k, n, exposure_s);
            let sight = at(t_s);
            let (o, d) = (sight.observer_km, sight.debris_km);
            let los = sub(d, o);
            let (ra_deg, dec_deg) = radec_deg(sight.direction);
            let phase = angle_deg(sub(sun, d), sub(o, d)).to_radians();
            let mut mag = debris_magnitude(area_m2, spec.albedo, phase, norm(los));
            if let Some(e) = extinction {
                mag += e.mag(los);
            }
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
    let spacing = max_sample_spacing_px(sensor, &trajectory);
    let slices = slice_count(n, spacing, shot.psf_core_px)?;
    if slices != n {
        trajectory = sample(slices)?;
    }
    Ok(trajectory)
}

/// The instant of sample `k` of a trajectory cut into `n` equal time slices of an exposure of
/// `exposure_s`, seconds from its start: the slice's centre. (The first and last samples, the
/// truth's `streak_start_px` and `streak_end_px`, are half a slice inside the exposure.)
pub fn sample_time_s(k: usize, n: usize, exposure_s: f64) -> f64 {
    (k as f64 + 0.5) * (exposure_s / n as f64)
}

/// The number of slices of a trajectory first cut into `n` whose consecutive samples lie up to
/// `spacing_px` apart in the image ([`max_sample_spacing_px`]) under a PSF of core sigma
/// `psf_core_px`. Samples farther apart than two PSF sigmas render a row of dots, not a streak
/// (a 600 s exposure of LEO debris with 2000 samples: one dot per 128 px; 0.7% of the
/// quickstart draws: 4-8 px). Such a trajectory is sampled again, finer by the factor that
/// brings the spacing to two sigmas; beyond MAX_TRAJECTORY_SAMPLES the draw is rejected.
pub fn slice_count(n: usize, spacing_px: f64, psf_core_px: f64) -> Result<usize, Rejection> {
    if spacing_px > MAX_SAMPLE_SPACING_PSF_SIGMAS * psf_core_px {
        let factor = (spacing_px / (MAX_SAMPLE_SPACING_PSF_SIGMAS * psf_core_px)).ceil() as usize;
        let finer = n.saturating_mul(factor);
        if finer > MAX_TRAJECTORY_SAMPLES {
            return Err(Rejection::TooFast);
        }
        return Ok(finer);
    }
    Ok(n)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Samples within two PSF sigmas keep their count; farther apart, the count grows by the
    /// factor that brings them to two sigmas; past the limit, the draw is refused. The first
    /// and last samples sit half a slice inside the exposure.
    #[test]
    fn slices_and_their_instants() {
        assert_eq!(slice_count(2000, 2.0, 1.0), Ok(2000));
        assert_eq!(slice_count(2000, 2.01, 1.0), Ok(4000));
        assert_eq!(slice_count(2000, 9.0, 1.5), Ok(6000));
        assert_eq!(slice_count(2000, 1e4, 1.0), Err(Rejection::TooFast));
        assert_eq!(sample_time_s(0, 2000, 10.0), 0.0025);
        assert!((sample_time_s(1999, 2000, 10.0) - 9.9975).abs() < 1e-12);
    }
}
