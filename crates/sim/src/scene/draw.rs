//! The scene draw of one image (paper 3.2.1-3.2.3): its debris object by the campaign's
//! weights, then the exposure, placement, background and light curve, retried on the scene
//! stream until the visibility checks and the gate accept them. A later frame of a collect
//! follows its first frame's plan; the gate judges the first frame, and the attempt stands only
//! if every later frame starts in the window and sees the object (`judge_later_frames`).

use std::collections::BTreeMap;

use hifitime::{Duration, Epoch};
use rand::RngExt;
use rand_chacha::ChaCha12Rng;

use super::accepted::psf_of;
use super::accepted::{Exposure, Object};
use super::catalogue::{draw_stare, in_field};
use super::object_draws::{draw_tumble, pick_debris};
use super::place::place;
use super::pointing::point_sensor;
use super::scintillation::scintillate;
use super::trajectory::{Shot, trajectory};
use super::visibility::{gate_snr, in_sight, visibility};
use super::{
    CatalogueScene, CollectFrame, Inputs, NoScene, Pointing, Rejection, Scene, Spec, Tumble,
};
use crate::background::{BackgroundModel, FrameChoice};
use crate::sensor::Sensor;
use crate::sighting::{Sight, Sighting};
use soig_base::rng::{Purpose, stream};
use soig_sky::ephemeris::sun_position_km;
use soig_sky::stars::Star;
use soig_sky::{Vec3, radec_deg, radec_unit};

/// The debris object of image `image`, by the spec's weights, from the image's own debris
/// stream (so the retries of the scene draw never change which object an image shows).
pub fn choose_debris(spec: &Spec, debris: usize, seed: u64, image: u64) -> usize {
    pick_debris(spec, debris, &mut stream(seed, image, Purpose::Debris))
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
    draw_accepted(spec, sensor, inputs, seed, image).map(|s| scintillate(spec, seed, s))
}

/// `draw` before the air's scintillation of the accepted scene's objects.
fn draw_accepted(
    spec: &Spec,
    sensor: &Sensor,
    inputs: &Inputs,
    seed: u64,
    image: u64,
) -> Result<Scene, NoScene> {
    if let Some(CatalogueScene::Stare { ra_deg, dec_deg }) = spec.catalogue {
        return draw_stare(spec, sensor, inputs, seed, image, (ra_deg, dec_deg));
    }
    let (collect, frame) = spec.collect_of(image);
    let debris_index = choose_debris(spec, inputs.debris.len(), seed, collect);
    let on_frame = on_frame(spec, seed, collect);
    let rng = &mut stream(seed, collect, Purpose::Scene);
    let mut rejections: BTreeMap<Rejection, u32> = BTreeMap::new();
    let max = spec.gate.max_attempts;
    let no_scene = |attempts: u32, rejections: BTreeMap<Rejection, u32>| {
        NoScene::of(inputs, image, debris_index, attempts, rejections)
    };
    for attempt in 1..=max {
        let d = draw_values(spec, inputs, (debris_index, on_frame), rng);
        let first = try_draw(spec, sensor, inputs, image, debris_index, &d, Plan::First).and_then(
            |first| {
                judge_later_frames(spec, inputs, debris_index, &d)?;
                Ok(first)
            },
        );
        match first {
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
                let scene = later.unwrap_or(first);
                let collect_frame = CollectFrame::of(spec, image, collect);
                let scene = scene.accept(attempt, rejections, collect_frame, placed);
                if spec.catalogue.is_some() {
                    return Ok(with_population(spec, sensor, inputs, seed, scene));
                }
                return Ok(scene);
            }
            Err(reason) => *rejections.entry(reason).or_default() += 1,
        }
    }
    Err(no_scene(max, rejections))
}

/// Whether image `image`'s collect has a real frame under it: drawn only in a mixed campaign,
/// so that every other keeps its streams.
pub(super) fn on_frame(spec: &Spec, seed: u64, collect: u64) -> bool {
    spec.frame_share >= 1.0
        || stream(seed, collect, Purpose::BackgroundKind).random::<f64>() < spec.frame_share
}

/// The target mode of a catalogue scene (accepted): the frame's own object first, as it was
/// drawn, then the population's objects in its field, the frame's own left out.
fn with_population(
    spec: &Spec,
    sensor: &Sensor,
    inputs: &Inputs,
    seed: u64,
    scene: Scene,
) -> Scene {
    let (mut seen, unseen) = in_field(spec, sensor, inputs, seed, &scene, Some(scene.object.norad));
    seen.insert(0, scene.clone());
    Scene {
        placed: Some(seen),
        unseen: Some(unseen),
        ..scene
    }
}

/// Whether every later frame of the collect that starts with the draws `d` starts inside the
/// campaign's window and sees its object (`in_sight`): judged by every image of the collect
/// alike, so that all its frames take the same attempt. A single image has none.
fn judge_later_frames(
    spec: &Spec,
    inputs: &Inputs,
    debris_index: usize,
    d: &Draws,
) -> Result<(), Rejection> {
    let frames = spec.collect_frames.max(1);
    let step_s = d.exposure_s + spec.collect_gap_s;
    for k in 1..frames {
        let start = d.start + Duration::from_seconds(k as f64 * step_s);
        if start >= spec.window_end {
            return Err(Rejection::CollectPastWindow);
        }
        let mid = start + Duration::from_seconds(d.exposure_s / 2.0);
        let (_, sight) = sighting_at(spec, inputs, debris_index, mid)?;
        in_sight(spec, &sight, (sun_position_km(mid), mid))?;
    }
    Ok(())
}

/// How debris object `debris_index` is seen from the observer around `mid`, and where it is
/// at `mid`.
fn sighting_at<'a>(
    spec: &Spec,
    inputs: &'a Inputs,
    debris_index: usize,
    mid: Epoch,
) -> Result<(Sighting<'a>, Sight), Rejection> {
    let sighting = Sighting::new(
        inputs.observer.viewpoint(),
        &inputs.debris[debris_index].propagator,
        mid,
        spec.apparent_positions,
    );
    let sight = sighting.at(mid).ok_or(Rejection::PropagationFailed)?;
    Ok((sighting, sight))
}

/// The random values of one draw attempt, in the scene stream's order.
pub(super) struct Draws {
    pub exposure_s: f64,
    pub start: Epoch,
    area_m2: f64,
    placement: (f64, f64),
    pub background: Option<FrameChoice>,
    tumble: Option<Tumble>,
}

/// Which frame of its collect a scene is: the first (a single image is one), judged by the
/// gate, or a later one, which follows the first's pointing plan and is not judged.
#[derive(Clone, Copy)]
enum Plan<'a> {
    First,
    Later { frame: u64, first: &'a Scene },
}

pub(super) fn draw_values(
    spec: &Spec,
    inputs: &Inputs,
    (debris_index, on_frame): (usize, bool),
    rng: &mut ChaCha12Rng,
) -> Draws {
    let span_s = (spec.window_end - spec.window_start).to_seconds();
    let exposure_s = if spec.exposure_max_s > spec.exposure_min_s {
        rng.random_range(spec.exposure_min_s..=spec.exposure_max_s)
    } else {
        spec.exposure_min_s
    };
    // A ground site draws its start within the object's night spans (the same one draw).
    let start = match &spec.ground {
        None => spec.window_start + Duration::from_seconds(rng.random_range(0.0..span_s)),
        Some(g) => g
            .instant(debris_index, rng.random_range(0.0..1.0))
            .unwrap_or(spec.window_start),
    };
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

/// One draw of image `image`'s debris object, frame `plan` of its collect, with the draws
/// `d`: its visibility at mid-exposure, the pointing, the field stars, the trajectory and the
/// signal-to-noise gate, or the first reason it was rejected.
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
    let (sighting, sight) = sighting_at(spec, inputs, debris_index, mid)?;
    let sun = sun_position_km(mid);
    // A later frame of a collect is not judged (`gated` false); in it the object may have
    // entered the shadow, and then sends no light.
    let (geometry, shadowed) = visibility(spec, sensor, &sight, (sun, mid), area_m2, gated)?;

    let (ra_p, dec_p) = boresight(sensor, sight.direction, placement, plan, offset_s);
    let (pointing, cone) = point_sensor(
        spec,
        sensor,
        &sighting,
        (start, mid, exposure_s),
        (ra_p, dec_p),
    )?;
    let stars = field_stars(spec, sensor, inputs, (ra_p, dec_p, cone), mid, gated)?;

    let mid_tan = sensor.projection(ra_p, dec_p);
    let seeing = spec
        .ground
        .as_ref()
        .and_then(|g| g.seeing(mid, radec_unit(ra_p, dec_p)));
    let sky = spec
        .ground
        .as_ref()
        .and_then(|g| g.sky(mid, radec_unit(ra_p, dec_p)))
        .map(|(v, _)| v);
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
            mid_tan,
            shadowed,
            extinction: spec.ground.as_ref().and_then(|g| g.extinction(mid)),
            psf_core_px: psf_of(sensor, seeing).core_sigma_px(),
        },
    )?;

    let snr = gate_snr(
        spec,
        &sensor.under_sky(sky),
        &trajectory,
        exposure_s,
        inputs.frame(background),
        gated,
    )?;

    let ephemeris = sighting.ephemeris(start, exposure_s);
    let exposure = Exposure {
        image_index: image,
        start,
        exposure_s,
        pointing,
        stars,
        background,
        seeing,
        sky_v_mag_per_arcsec2: sky,
    };
    let object = Object::of_body(
        (debris_index, &inputs.debris[debris_index]),
        (area_m2, tumble),
        geometry,
        ephemeris,
        trajectory,
        snr,
    );
    Ok(Scene::assemble(exposure, object))
}

/// The boresight at mid-exposure, with the debris then in `direction`: the debris lands at a
/// random place in the field (`placement`). A later frame keeps the first's plan: a fixed
/// direction, the survey attitude running on (the first frame's rotation, continued, to
/// `offset_s` after it), or the object held on its pixel.
fn boresight(
    sensor: &Sensor,
    direction: Vec3,
    placement: (f64, f64),
    plan: Plan,
    offset_s: f64,
) -> (f64, f64) {
    let (ra_mid, dec_mid) = radec_deg(direction);
    let around_debris = sensor.projection(ra_mid, dec_mid);
    let half_w = sensor.width_px as f64 / 2.0;
    let half_h = sensor.height_px as f64 / 2.0;
    let placed = around_debris.sky(
        around_debris.cx - placement.0 * half_w,
        around_debris.cy - placement.1 * half_h,
    );
    match plan {
        Plan::Later { first, .. } => match &first.exposure.pointing {
            Pointing::Fixed { ra_deg, dec_deg } => (*ra_deg, *dec_deg),
            Pointing::Survey(t0) => t0.radec_at(t0.t_mid_s + offset_s),
            Pointing::Track(_) => placed,
        },
        Plan::First => placed,
    }
}

/// Field stars in the cone `(ra, dec, radius)` at mid-exposure; a star brighter than the limit
/// spoils the image (paper 3.2.3).
pub(super) fn field_stars(
    spec: &Spec,
    sensor: &Sensor,
    inputs: &Inputs,
    (ra, dec, cone): (f64, f64, f64),
    mid: Epoch,
    gated: bool,
) -> Result<Vec<Star>, Rejection> {
    let mut field = inputs
        .stars
        .stars_in_cone(ra, dec, cone, sensor.mag_limit, mid);
    // A ground site's air dims the field by the boresight's airmass (the field's few tenths
    // of a degree change it little).
    if let Some(e) = spec.ground.as_ref().and_then(|g| g.extinction(mid)) {
        let dm = e.mag(radec_unit(ra, dec));
        field.iter_mut().for_each(|s| s.mag += dm);
    }
    if gated && field.iter().any(|s| s.mag < spec.gate.brightest_star_mag) {
        return Err(Rejection::BrightStar);
    }
    Ok(field)
}
