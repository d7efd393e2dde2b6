//! The draws of one object that depend only on the spec: which debris object, and its tumble.
//! An image's object (`draw`) and each placed object of a frame (`place`) draw them alike.

use rand::RngExt;
use rand_chacha::ChaCha12Rng;

use super::Spec;
use super::accepted::Tumble;

/// A debris index by the spec's weights, from `rng`.
pub(super) fn pick_debris(spec: &Spec, debris: usize, rng: &mut ChaCha12Rng) -> usize {
    let weight = |i: usize| spec.debris_weights.get(i).copied().unwrap_or(1.0);
    let total: f64 = (0..debris).map(weight).sum();
    let mut u = rng.random_range(0.0..total);
    for i in 0..debris {
        if u < weight(i) {
            return i;
        }
        u -= weight(i);
    }
    // Rounding of the subtractions can leave u just above the last weight.
    debris - 1
}

/// The tumbling modulation of one object's draw.
pub(super) fn draw_tumble(spec: &Spec, rng: &mut ChaCha12Rng) -> Option<Tumble> {
    spec.tumble.map(|r| Tumble {
        period_s: if r.period_max_s > r.period_min_s {
            rng.random_range(r.period_min_s..=r.period_max_s)
        } else {
            r.period_min_s
        },
        amplitude: rng.random_range(0.0..=r.amplitude_max),
        phase_rad: rng.random_range(0.0..std::f64::consts::TAU),
    })
}
