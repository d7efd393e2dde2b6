//! Several objects per frame (`Spec::objects`): each drawn on its own stream, turned rigidly
//! about the observer into the field the image's scene points at, and judged by the same
//! checks; in a collect, followed from its first frame into the later ones.

use std::collections::BTreeMap;

use hifitime::{Duration, Epoch};
use rand::RngExt;

use super::accepted::{Exposure, Object};
use super::object_draws::{draw_tumble, pick_debris};
use super::trajectory::{Shot, trajectory};
use super::visibility::{gate_snr, visibility};
use super::{CollectFrame, Inputs, MAX_OBJECTS_PER_FRAME, NoScene, Rejection, Scene, Spec, Tumble};
use crate::sensor::Sensor;
use crate::sighting::{Sight, Sighting};
use soig_base::rng::{Purpose, object_stream};
use soig_sky::ephemeris::sun_position_km;
use soig_sky::{Vec3, angle_deg, cross, norm, radec_unit, rotate, sub, unit};

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
pub(super) fn place(
    spec: &Spec,
    sensor: &Sensor,
    inputs: &Inputs,
    seed: u64,
    (first, later): (&Scene, Option<&Scene>),
    k: u64,
) -> Result<Scene, NoScene> {
    let image = later.unwrap_or(first).exposure.image_index;
    let (collect, _) = spec.collect_of(image);
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
                let scene = match later {
                    None => judged,
                    Some(at) => shot(at).map_err(|reason| {
                        rejections.insert(reason, 1);
                        NoScene::of(inputs, image, debris_index, attempt, rejections.clone())
                    })?,
                };
                let collect_frame = CollectFrame::of(spec, image, object_track_id(collect, k));
                return Ok(scene.accept(attempt, rejections, collect_frame, None));
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
    let mid_of = |s: &Scene| s.exposure.start + Duration::from_seconds(s.exposure.exposure_s / 2.0);
    let sighting_at = |mid: Epoch| {
        Sighting::new(
            inputs.observer.viewpoint(),
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
    let (start, exposure_s, mid) = (at.exposure.start, at.exposure.exposure_s, mid_of(at));
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
        &Shot::in_frame(spec, sensor, at, (sun, mid), (area_m2, tumble), shadowed),
    )?;
    let snr = gate_snr(
        spec,
        &sensor.under_sky(at.exposure.sky_v_mag_per_arcsec2),
        &trajectory,
        exposure_s,
        inputs.frame(at.exposure.background),
        gated,
    )?;
    let exposure = Exposure::of_frame(at);
    let object = Object::of_body(
        (debris_index, &inputs.debris[debris_index]),
        (area_m2, tumble),
        geometry,
        // The object's own ephemeris is not where the image shows it.
        None,
        trajectory,
        snr,
    );
    Ok(Scene::assemble(exposure, object))
}
