//! Step 2, what the line filter sees: the star trails subtracted (the predicted ones in the
//! star-aware pass, everything along their direction in a survey image), the stars masked, and
//! a copy clipped to `clip_sigma` and made zero-mean.

use super::params::Sanitized;
use super::sky::Sky;
use super::stars::mask_stars;
use super::trails::remove_trails;

/// The maps after step 2.
pub(super) struct Flat {
    /// The unit-noise map, trails subtracted and stars masked.
    pub(super) z: Vec<f32>,
    /// `z` clipped to `[-clip_sigma, clip_sigma]` (and zero-mean where the noise is calibrated).
    pub(super) zc: Vec<f32>,
    /// The star-aware pass: which pixels lie under a subtracted trail, and what was subtracted
    /// at each (see `Sky::subtract`).
    pub(super) under_trails: Option<Vec<bool>>,
    pub(super) removed: Option<Vec<f32>>,
}

/// `z` with the predicted trails of `sky` subtracted, or else everything along `trail`
/// (degrees), then the stars masked; and its clipped copy.
pub(super) fn flatten(
    mut z: Vec<f32>,
    w: usize,
    h: usize,
    p: &Sanitized,
    trail: Option<f64>,
    sky: Option<&Sky>,
) -> Flat {
    let (mut under_trails, mut removed) = (None, None);
    if let Some(sky) = sky {
        let (u, r) = sky.subtract(&mut z, w, h);
        (under_trails, removed) = (Some(u), Some(r));
    } else if let Some(a) = trail {
        remove_trails(&mut z, w, h, a.to_radians(), p);
    }
    mask_stars(&mut z, w, h, p);
    let clip = p.clip as f32;
    let mut zc: Vec<f32> = z.iter().map(|&v| v.clamp(-clip, clip)).collect();
    // The line filter sums zc, so zc must have zero mean, not only zero median: a real
    // sensor's skewed noise (warm pixels) has its mean above its median (0.2 sigma on the
    // NEOSSat dark frame), which summed over 51 pixels made every line a "5 sigma" fragment.
    // A streak covers too few pixels to move the mean.
    if p.calibrate_noise {
        let mean = zc.iter().map(|&v| v as f64).sum::<f64>() / zc.len() as f64;
        zc.iter_mut().for_each(|v| *v -= mean as f32);
    }
    Flat {
        z,
        zc,
        under_trails,
        removed,
    }
}
