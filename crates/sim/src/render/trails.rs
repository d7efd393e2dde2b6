//! Where each field star of a scene lies in its image over the exposure, and how bright: the
//! prediction a star-aware detector compares its candidates with. It is the renderer's own star
//! model (`sources::for_each_source`: the scene's stars, projection and pointing over the
//! exposure, the same time nodes), traced without photons or jitter; the image's recorded mean
//! jitter shift (the truth's `jitter_mean_px`, which the FITS WCS includes) moves it where the
//! WCS puts it.

use super::Jitter;
use super::sources::{Path, for_each_source};
use crate::scene::Scene;
use crate::sensor::Sensor;

/// One star's predicted path in the original image, at the renderer's time nodes (its
/// expected electrons always known).
pub use soig_image::hint::PredictedTrail;

/// Every star of `scene` that can put light in the image, as the renderer traces it, shifted by
/// the image's mean jitter `jitter_mean_px`.
pub fn star_trails(
    sensor: &Sensor,
    scene: &Scene,
    jitter_mean_px: [f64; 2],
) -> Vec<PredictedTrail> {
    let still = Jitter::still(scene.exposure.exposure_s);
    let [jx, jy] = jitter_mean_px;
    let mut paths: Vec<(Vec<[f64; 2]>, Vec<f64>, f64)> = Vec::new();
    let traced = for_each_source(sensor, scene, &still, |source| {
        if source.debris {
            return;
        }
        let (nodes, times) = match source.path {
            Path::Still { x, y } => (
                vec![[x + jx, y + jy]],
                vec![0.5 * scene.exposure.exposure_s],
            ),
            Path::Trail { nodes, step } => {
                // The source's photons arrive over [t_a, t_b], which are node times.
                let a = (source.t_a / step).round() as usize;
                let b = ((source.t_b / step).round() as usize).min(nodes.len() - 1);
                let a = a.min(b);
                (
                    nodes[a..=b]
                        .iter()
                        .map(|&(x, y)| [x + jx, y + jy])
                        .collect(),
                    (a..=b).map(|k| k as f64 * step).collect(),
                )
            }
            Path::Instant { .. } => unreachable!("only debris samples are instants"),
        };
        paths.push((nodes, times, source.expected));
    });
    // `for_each_source` traces the stars in the order it adds their sources.
    traced
        .into_iter()
        .zip(paths)
        .map(|(star, (nodes, times_s, electrons))| PredictedTrail {
            ra_deg: star.ra_deg,
            dec_deg: star.dec_deg,
            mag: star.mag,
            nodes,
            times_s,
            electrons: Some(electrons),
        })
        .collect()
}
