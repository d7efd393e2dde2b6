//! A ground site's scintillation (issue #46): each object an image shows gets one flux factor
//! for the exposure, log-normal of mean 1 and the relative rms of Young's formula with Osborn
//! et al.'s correction (`atmosphere::scintillation_variance`) at its airmass, drawn from its
//! own stream (keyed by the image and its place among the objects shown), so that no other
//! draw of the campaign moves. Applied to an accepted scene: the gate judged the object's
//! mean brightness.

use hifitime::Duration;
use rand::RngExt;
use rand_distr::StandardNormal;

use super::{Scene, Spec};
use crate::atmosphere::{Scintillation, scintillation_factor};
use soig_base::rng::{Purpose, object_stream};
use soig_sky::radec_unit;

/// `scene` with every object it shows scintillated; unchanged without scintillation.
pub(super) fn scintillate(spec: &Spec, seed: u64, mut scene: Scene) -> Scene {
    let Some(gate) = spec.ground.as_ref().filter(|g| g.scintillation.is_some()) else {
        return scene;
    };
    let apply = |k: u64, s: &mut Scene| {
        let Some(middle) = s.object.trajectory.get(s.object.trajectory.len() / 2) else {
            return;
        };
        let mid = s.exposure.start + Duration::from_seconds(s.exposure.exposure_s / 2.0);
        let dir = radec_unit(middle.ra_deg, middle.dec_deg);
        let Some((variance, airmass)) = gate.scintillation(mid, dir, s.exposure.exposure_s) else {
            return;
        };
        let rng = &mut object_stream(seed, s.exposure.image_index, k, Purpose::Scintillation);
        let factor = scintillation_factor(variance, rng.sample(StandardNormal));
        s.object
            .trajectory
            .iter_mut()
            .for_each(|p| p.expected_electrons *= factor);
        s.scintillation = Some(Scintillation {
            sigma: variance.sqrt(),
            factor,
            airmass,
        });
    };
    match &mut scene.placed {
        // The frame's own object only chose the pointing: not shown, not scintillated.
        Some(placed) => placed
            .iter_mut()
            .enumerate()
            .for_each(|(k, s)| apply(k as u64, s)),
        None => apply(0, &mut scene),
    }
    scene
}
