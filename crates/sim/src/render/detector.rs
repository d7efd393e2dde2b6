//! The detector (paper Eq. 11): ADU = photo-electrons / gain + background + bias, the
//! background the paper's uniform one (its range scaled linearly with exposure) or a real
//! frame's noise matrix scaled by exposure (`background`), the bias uniform per pixel; or the
//! physical model of `noise`.

use rand::RngExt;
use soig_base::rng::PixelRng;

use crate::background::RealFrame;
use crate::noise::Noise;
use crate::scene::Scene;
use crate::sensor::Sensor;

/// The noisy image in ADU of the noise-free photo-electrons of a scene.
pub(super) fn adu(
    sensor: &Sensor,
    electrons: &[u32],
    scene: &Scene,
    frame: Option<&RealFrame>,
    noise_rng: &mut PixelRng,
) -> Vec<f32> {
    let s = sensor;
    let (width, height) = (s.width_px, s.height_px);
    let t_exp = scene.exposure.exposure_s;
    // A physical detector has its own sky (validation keeps real frames to the paper's model).
    if let Noise::Physical(p) = &s.noise {
        return p.adu(
            electrons,
            width,
            height,
            t_exp,
            s.gain_e_per_adu,
            scene.exposure.image_index,
        );
    }
    let (b_lo, b_hi) = (s.bias.min_adu, s.bias.max_adu);
    let uniform = |r: &mut PixelRng, lo: f64, hi: f64| {
        if hi > lo { r.random_range(lo..hi) } else { lo }
    };
    match (frame, scene.exposure.background) {
        (Some(f), Some(choice)) => {
            let bg = f.background(width, height, t_exp, choice.offset, noise_rng);
            electrons
                .iter()
                .zip(bg)
                .map(|(&e, bg)| {
                    let bias = uniform(noise_rng, b_lo, b_hi);
                    (e as f64 / s.gain_e_per_adu + bg as f64 + bias) as f32
                })
                .collect()
        }
        _ => {
            let k = t_exp / s.background_exposure_s;
            let (bg_lo, bg_hi) = (s.background.min_adu * k, s.background.max_adu * k);
            // Background and bias from the two halves of one 64-bit draw (one draw per pixel
            // instead of two): 32 bits resolve 5e-9 ADU of a 20 ADU range, far below a
            // float32 pixel's 1.5e-5 at 200 ADU.
            let (bg_span, b_span) = (bg_hi - bg_lo, b_hi - b_lo);
            electrons
                .iter()
                .map(|&e| {
                    let bits: u64 = noise_rng.random();
                    let bg = bg_lo + unit(bits >> 32) * bg_span;
                    let bias = b_lo + unit(bits & 0xffff_ffff) * b_span;
                    (e as f64 / s.gain_e_per_adu + bg + bias) as f32
                })
                .collect()
        }
    }
}

/// A uniform draw in [0, 1) from 32 random bits.
fn unit(bits: u64) -> f64 {
    bits as f64 * (1.0 / 4_294_967_296.0)
}
