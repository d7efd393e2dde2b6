//! Catalogue scenes (issue #45): every object of a population (`Inputs::population`) drawn
//! where its orbit puts it. A frame's pointing is drawn as without a catalogue (around a debris
//! object, which is shown too) or is a stare (`stare`); then every object whose apparent path
//! crosses the field is traced over the exposure with its own motion and brightness and judged
//! by the checks of a scene's object (line of sight, shadow, magnitude limit, signal to noise):
//! an object that passes is shown, one that fails is listed as unseen with the reason.
//!
//! The cost grows with the objects near the field, not the population: each object is placed
//! once, at mid-exposure, by a cheap orbit with a measured error (`CoarseOrbit`), and kept only
//! if it can reach the field within half the exposure (`candidates`); only those are
//! propagated with SGP4 and traced.

use std::collections::BTreeMap;

use hifitime::{Duration, Epoch};
use serde::Serialize;

use super::accepted::{Exposure, Object};
use super::draw::{draw_values, field_stars, on_frame};
use super::object_draws::draw_tumble;
use super::trajectory::{Shot, trajectory};
use super::visibility::{Snr, gate_snr, in_sight, visibility};
use super::{CollectFrame, Geometry, Inputs, NoScene, Pointing, Rejection, Scene, Spec};
use crate::sensor::Sensor;
use crate::sighting::{Sight, Sighting};
use soig_base::rng::{Purpose, stream};
use soig_sky::ephemeris::sun_position_km;
use soig_sky::frames::teme_to_gcrs_matrix;
use soig_sky::orbit::coarse_seconds as seconds;
use soig_sky::{dot, norm, radec_unit, scale, sub};

/// An object of the population in the field that the checks left dark, and why.
#[derive(Clone, Debug, Serialize)]
pub struct Unseen {
    pub object: String,
    pub norad: u64,
    pub reason: Rejection,
}

/// Largest acceleration of one body relative to another in Earth orbit, km/s^2: each feels at
/// most the surface gravity, 9.8e-3 km/s^2 (drag and other forces are thousands of times less).
const MAX_RELATIVE_ACCEL_KM_S2: f64 = 2.0 * 9.81e-3;

/// Extra angle of the coarse test: apparent places (aberration, up to ~26", and light time)
/// move an object from its geometric direction by well under this.
const CULL_MARGIN_DEG: f64 = 0.02;

/// The objects of the population seen in frame `at` (its pointing and time set), in the
/// population's order, and those in the field the checks rejected. `shown` (the frame's own
/// object, in the target mode) is left out: the frame shows it already.
pub(super) fn in_field(
    spec: &Spec,
    sensor: &Sensor,
    inputs: &Inputs,
    seed: u64,
    at: &Scene,
    shown: Option<u64>,
) -> (Vec<Scene>, Vec<Unseen>) {
    let mut seen = Vec::new();
    let mut unseen = Vec::new();
    for i in candidates(sensor, inputs, at) {
        let body = &inputs.population[i];
        if Some(body.norad) == shown {
            continue;
        }
        match sight_object(spec, sensor, inputs, seed, at, i) {
            None => {}
            Some(Ok(scene)) => seen.push(scene),
            Some(Err(reason)) => unseen.push(Unseen {
                object: body.name.clone(),
                norad: body.norad,
                reason,
            }),
        }
    }
    (seen, unseen)
}

/// The coarse test: the population's objects that may cross the field of `at`. Each is placed
/// at mid-exposure by its cheap orbit (`CoarseOrbit`), within `u = 2 error + 20 km` of SGP4
/// (by SGP4 itself, and its own speed, when the cheap orbit strays beyond `EXACT_BEYOND_KM`);
/// over half the exposure its line of sight moves by at most `d = (v_max + |v_obs|) h +
/// a_max h^2 / 2` (h half the exposure), so its direction lies within `asin((d + u) / range)`
/// of the cheap one (any direction when that reaches the range); it is kept if that cone
/// meets the field's half-diagonal, widened by the boresight's own motion and a margin, about
/// the mid-exposure boresight. All in TEME, the observer by SGP4.
fn candidates(sensor: &Sensor, inputs: &Inputs, at: &Scene) -> Vec<usize> {
    let h = at.exposure.exposure_s / 2.0;
    let mid = at.exposure.start + Duration::from_seconds(h);
    // A population is seen from a satellite (`validate` refuses a ground site with it).
    let Some(Ok((observer_km, observer_km_s))) = inputs
        .observer
        .orbit()
        .map(|o| o.propagator.state_teme(mid))
    else {
        return Vec::new();
    };
    let (ra, dec) = at.exposure.pointing.mid_radec_deg();
    // GCRS -> TEME is the transpose of the rotation.
    let m = teme_to_gcrs_matrix(mid);
    let b = radec_unit(ra, dec);
    let boresight = [0, 1, 2].map(|k| m[0][k] * b[0] + m[1][k] * b[1] + m[2][k] * b[2]);
    let half_diag_deg =
        sensor.pixel_scale_deg() * (sensor.width_px as f64).hypot(sensor.height_px as f64) / 2.0;
    let pointing_reach_deg = match &at.exposure.pointing {
        Pointing::Fixed { .. } => 0.0,
        Pointing::Survey(t) => t.drift_deg / 2.0,
        Pointing::Track(t) => t.reach_deg(),
    };
    let reach_rad = (half_diag_deg + pointing_reach_deg + CULL_MARGIN_DEG).to_radians();
    // The field's cone is degrees wide (a right angle at most here), so field + w stays
    // within a half-turn, where cos(field + w) bounds the angle.
    let (sin_field, cos_field) = reach_rad.min(std::f64::consts::FRAC_PI_2).sin_cos();
    let t_s = seconds(mid);
    let observer_speed = norm(observer_km_s);
    let accel_km = 0.5 * MAX_RELATIVE_ACCEL_KM_S2 * h * h;
    let observer_v = observer_km_s;
    inputs
        .population_coarse
        .iter()
        .enumerate()
        .filter_map(|(i, orbit)| {
            let (los, reach) = if orbit.error_km <= EXACT_BEYOND_KM {
                let los = sub(orbit.position_teme_km(t_s), observer_km);
                let slack = 2.0 * orbit.error_km + COARSE_MARGIN_KM;
                let speed = orbit.speed_max_km_s + observer_speed;
                (los, speed * h + accel_km + slack)
            } else {
                // Too far from SGP4 over the window (drag, long after the epoch): by SGP4
                // itself; an object it cannot propagate then is not shown (`sight_object`).
                let (r, v) = inputs.population[i].propagator.state_teme(mid).ok()?;
                (sub(r, observer_km), norm(sub(v, observer_v)) * h + accel_km)
            };
            let range = norm(los);
            // Near the observer (or an orbit gone non-finite) any direction is possible.
            if reach >= range || range.is_nan() {
                return Some(i);
            }
            // Inside the field's cone widened by w = asin(reach / range), by cosines:
            // cos(off) >= cos(field + w), expanded (no acos, asin or cos per object).
            let sin_w = reach / range;
            let cos_limit = cos_field * (1.0 - sin_w * sin_w).sqrt() - sin_field * sin_w;
            (dot(los, boresight) >= cos_limit * range).then_some(i)
        })
        .collect()
}

/// A cheap orbit further than this from SGP4 over the window, km, would widen the test so much
/// that SGP4 at mid-exposure is cheaper than the objects it would let through.
const EXACT_BEYOND_KM: f64 = 200.0;

/// Slack on a cheap orbit's distance from SGP4 beyond twice its largest measured one, km.
const COARSE_MARGIN_KM: f64 = 20.0;

/// Population object `index` in frame `at`: None if its path does not cross the field (or it
/// cannot be propagated over the exposure), else the scene of it or why the checks reject it.
/// Its size and light curve come from its own stream, keyed by its NORAD number.
fn sight_object(
    spec: &Spec,
    sensor: &Sensor,
    inputs: &Inputs,
    seed: u64,
    at: &Scene,
    index: usize,
) -> Option<Result<Scene, Rejection>> {
    let body = &inputs.population[index];
    let (start, exposure_s) = (at.exposure.start, at.exposure.exposure_s);
    let mid = start + Duration::from_seconds(exposure_s / 2.0);
    let sighting = Sighting::new(
        inputs.observer.viewpoint(),
        &body.propagator,
        mid,
        spec.apparent_positions,
    );
    let rng = &mut stream(seed, body.norad, Purpose::CatalogueObject);
    // A generated object has its own size; a catalogued one draws it (the stream's first draw).
    let area_m2 = match body.generated {
        Some(g) => g.area_m2,
        None => spec.area.draw(rng),
    };
    let tumble = draw_tumble(spec, rng);
    let sun = sun_position_km(mid);
    let track = sighting.track(start, exposure_s)?;
    let shot = Shot::in_frame(spec, sensor, at, (sun, mid), (area_m2, tumble), false);
    // A path too fast to sample has samples in the field (`trajectory`): it crossed it.
    let trajectory = match trajectory(spec, sensor, &|t_s| track.at(t_s), &shot) {
        Ok(t) => t,
        Err(reason) => return Some(Err(reason)),
    };
    if !trajectory.iter().any(|p| sensor.contains(p.x_px, p.y_px)) {
        return None;
    }
    let sight = sighting.at(mid)?;
    let judged =
        visibility(spec, sensor, &sight, (sun, mid), area_m2, true).and_then(|(geometry, _)| {
            let frame = inputs.frame(at.exposure.background);
            let sensor = sensor.under_sky(at.exposure.sky_v_mag_per_arcsec2);
            let snr = gate_snr(spec, &sensor, &trajectory, exposure_s, frame, true)?;
            Ok((geometry, snr))
        });
    let (geometry, snr) = match judged {
        Ok(g) => g,
        Err(reason) => return Some(Err(reason)),
    };
    let exposure = Exposure::of_frame(at);
    let object = Object::of_body(
        (index, body),
        (area_m2, tumble),
        geometry,
        sighting.ephemeris(start, exposure_s),
        trajectory,
        snr,
    );
    // Across a collect's frames an object keeps its NORAD number as its track id.
    let collect = CollectFrame::of(spec, at.exposure.image_index, body.norad);
    let mut scene = Scene::assemble(exposure, object).accept(1, BTreeMap::new(), collect, None);
    scene.generated = body.generated.is_some();
    Some(Ok(scene))
}

/// Far enough along the boresight to stand for it in the line-of-sight checks: a ray from a
/// satellite that clears the Earth within this clears it for good.
const BORESIGHT_REACH_KM: f64 = 1.0e6;

/// The scene of image `image` of a stare at `(ra, dec)`: its time, exposure and background
/// drawn on the scene stream as without a catalogue, retried until the boresight passes the
/// checks of a line of sight (Earth, Sun and Moon angles, clear of the Earth) and no star in
/// the field is brighter than the limit, judged on the collect's first frame; then every
/// object of the population in the field (`in_field`). A frame of a collect starts
/// `k (exposure + gap)` after its first, all inside the window.
pub(super) fn draw_stare(
    spec: &Spec,
    sensor: &Sensor,
    inputs: &Inputs,
    seed: u64,
    image: u64,
    (ra, dec): (f64, f64),
) -> Result<Scene, NoScene> {
    let (collect, frame) = spec.collect_of(image);
    let on_frame = on_frame(spec, seed, collect);
    let rng = &mut stream(seed, collect, Purpose::Scene);
    let mut rejections: BTreeMap<Rejection, u32> = BTreeMap::new();
    let name = format!("stare at RA {ra} deg, Dec {dec} deg");
    for attempt in 1..=spec.gate.max_attempts {
        // No debris object: a ground site's spans are refused with a population (`validate`).
        let d = draw_values(spec, inputs, (0, on_frame), rng);
        let step_s = d.exposure_s + spec.collect_gap_s;
        let at = |k: u64| d.start + Duration::from_seconds(k as f64 * step_s);
        let judged = if at(spec.collect_frames.max(1) - 1) >= spec.window_end {
            Err(Rejection::CollectPastWindow)
        } else {
            judge_boresight(spec, sensor, inputs, (ra, dec), at(0), d.exposure_s)
        };
        let geometry = match judged {
            Ok(g) => g,
            Err(reason) => {
                *rejections.entry(reason).or_default() += 1;
                continue;
            }
        };
        let start = at(frame);
        let mid = start + Duration::from_seconds(d.exposure_s / 2.0);
        // The same direction in every frame: the first frame's check holds for them all.
        let stars = field_stars(
            spec,
            sensor,
            inputs,
            (ra, dec, spec.star_cone_deg),
            mid,
            false,
        )
        .unwrap_or_default();
        let exposure = Exposure {
            image_index: image,
            start,
            exposure_s: d.exposure_s,
            pointing: Pointing::Fixed {
                ra_deg: ra,
                dec_deg: dec,
            },
            stars,
            background: d.background,
            seeing: spec
                .ground
                .as_ref()
                .and_then(|g| g.seeing(mid, radec_unit(ra, dec))),
            sky_v_mag_per_arcsec2: spec
                .ground
                .as_ref()
                .and_then(|g| g.sky(mid, radec_unit(ra, dec)))
                .map(|(v, _)| v),
        };
        // The stare's own "object" is the boresight: no light, no path, NORAD 0.
        let object = Object {
            debris_index: 0,
            debris_name: name.clone(),
            norad: 0,
            area_m2: 0.0,
            tumble: None,
            geometry,
            ephemeris: None,
            trajectory: Vec::new(),
            snr: Snr {
                judged: 0.0,
                noise_level: 0.0,
                noise_sigma: 0.0,
            },
        };
        let pointed = Scene::assemble(exposure, object);
        let (seen, unseen) = in_field(spec, sensor, inputs, seed, &pointed, None);
        let collect_frame = CollectFrame::of(spec, image, collect);
        let mut scene = pointed.accept(attempt, rejections, collect_frame, Some(seen));
        scene.unseen = Some(unseen);
        // The observer's place for the FITS, as a frame with an object of its own states it
        // (ADES requires a space-based observer's position).
        scene.observer_gcrs =
            crate::sighting::observer_state_at_mid(inputs.observer.viewpoint(), mid);
        return Ok(scene);
    }
    Err(NoScene::named(
        image,
        (0, name, 0),
        spec.gate.max_attempts,
        rejections,
    ))
}

/// The checks of the stare's boresight at the mid-exposure of the exposure from `start`: the
/// line of sight's, and no star brighter than the limit in the field; the geometry of the
/// boresight (its angles; no range, no light) for the truth.
fn judge_boresight(
    spec: &Spec,
    sensor: &Sensor,
    inputs: &Inputs,
    (ra, dec): (f64, f64),
    start: Epoch,
    exposure_s: f64,
) -> Result<Geometry, Rejection> {
    let mid = start + Duration::from_seconds(exposure_s / 2.0);
    let observer_km = inputs
        .observer
        .orbit()
        .ok_or(Rejection::PropagationFailed)?
        .propagator
        .position_gcrs_km(mid)
        .map_err(|_| Rejection::PropagationFailed)?;
    let direction = radec_unit(ra, dec);
    let far = scale(direction, BORESIGHT_REACH_KM);
    let sight = Sight {
        observer_km,
        debris_km: [
            observer_km[0] + far[0],
            observer_km[1] + far[1],
            observer_km[2] + far[2],
        ],
        direction,
    };
    let angles = in_sight(spec, &sight, (sun_position_km(mid), mid))?;
    field_stars(
        spec,
        sensor,
        inputs,
        (ra, dec, spec.star_cone_deg),
        mid,
        true,
    )?;
    Ok(Geometry {
        range_km: 0.0,
        phase_angle_deg: 0.0,
        earth_angle_deg: angles.earth_angle_deg,
        sun_angle_deg: angles.sun_angle_deg,
        moon_angle_deg: angles.moon_angle_deg,
        // No object: no light.
        magnitude: f64::INFINITY,
    })
}
