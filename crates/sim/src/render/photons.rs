//! Photon mapping proper: photons of a source traced one by one (or in packets) to their
//! arrival time, position, jitter and PSF, and counted per pixel; the debris' photons, when
//! none can be merged, drawn per pixel from its expected flux (`DebrisFlux::draw`).

use rand_distr::{Binomial, StandardNormal};
use soig_base::rng::PixelRng;

use super::{Jitter, Path, Source};
use rand::RngExt;
use soig_image::psf_shape::Psf;

/// Photon counts on the detector, all sources and debris alone.
pub(super) struct Canvas {
    pub(super) electrons: Vec<u32>,
    pub(super) debris: Vec<u32>,
    pub(super) debris_total: u64,
}

/// Photon counts while tracing: the debris' apart from every other source's, so that a debris
/// photon is counted once (a second scattered increment per photon was 2% of an image's CPU);
/// `canvas` adds them up.
pub(super) struct Tally {
    width: usize,
    height: usize,
    others: Vec<u32>,
    debris: Vec<u32>,
    debris_total: u64,
}

impl Tally {
    pub(super) fn new(width: usize, height: usize) -> Tally {
        Tally {
            width,
            height,
            others: vec![0; width * height],
            debris: vec![0; width * height],
            debris_total: 0,
        }
    }

    fn add(&mut self, x: f64, y: f64, weight: u32, debris: bool) {
        // Pixel = floor(coordinate + 0.5); the image spans [-0.5, n - 0.5). On the kept range
        // (>= 0) floor is truncation, which `as` does in one instruction; `floor` itself is a
        // libm call on baseline x86-64 (no SSE4.1), 6% of a render.
        let (u, v) = (x + 0.5, y + 0.5);
        if !(u >= 0.0 && v >= 0.0 && u < self.width as f64 && v < self.height as f64) {
            return;
        }
        let k = v as usize * self.width + u as usize;
        if debris {
            self.debris[k] = self.debris[k].saturating_add(weight);
            self.debris_total += weight as u64;
        } else {
            self.others[k] = self.others[k].saturating_add(weight);
        }
    }

    /// The debris' photons drawn per pixel instead of traced (`DebrisFlux::draw`).
    pub(super) fn draw_debris(&mut self, flux: &super::expected::DebrisFlux, rng: &mut PixelRng) {
        self.debris_total += flux.draw(rng, &mut self.debris, self.width);
    }

    /// All sources per pixel (saturating sums of non-negative counts: the same in any order).
    pub(super) fn canvas(self) -> Canvas {
        let mut electrons = self.others;
        for (e, &d) in electrons.iter_mut().zip(&self.debris) {
            *e = e.saturating_add(d);
        }
        Canvas {
            electrons,
            debris: self.debris,
            debris_total: self.debris_total,
        }
    }
}

/// Trace `count` photons of one source: positions at their arrival times, plus jitter and
/// PSF. Sources above the merge threshold are traced in packets of `merge_factor` photons
/// (the paper's approximation); any source beyond `max_packets` photons in heavier packets
/// to stay within `max_packets` (whatever the threshold); a remainder of
/// at most `merge_factor` photons is traced singly, a larger one as one packet, so the total
/// is exact and the loop bounded (it once traced up to 3.7e11 singles for a saturated Poisson
/// draw: a hang).
#[allow(clippy::too_many_arguments)]
pub(super) fn trace(
    canvas: &mut Tally,
    rng: &mut PixelRng,
    count: u64,
    merge: (u64, u32),
    max_packets: u64,
    jitter: &Jitter,
    psf: &Psf,
    source: &Source,
) {
    let (threshold, factor) = merge;
    // Packets carry at most u32::MAX photons (a pixel's capacity): beyond max_packets such
    // packets (2.1e17 photons for one source) every pixel the source touches is saturated
    // anyway, so the count is clamped there.
    let count = count.min(max_packets.saturating_mul(u32::MAX as u64));
    let weight = if count > threshold { factor as u64 } else { 1 };
    let weight = weight.max(count.div_ceil(max_packets));
    let packets = count / weight;
    let rest = count % weight;
    let (singles, tail) = if rest <= factor as u64 {
        (rest, 0)
    } else {
        (0, 1)
    };
    let w32 = weight as u32; // <= u32::MAX by the clamp above
    // The full packets, then the singles or the tail: (count, weight of each).
    let rest_weight = if tail == 1 { rest as u32 } else { 1 };
    let batches = [(packets, w32), (singles + tail, rest_weight)];
    // Each batch's packets split among the PSF's Gaussians (`split_by_weight`): a packet goes
    // through one of them, so landing each Gaussian's share with its own sigma draws what a
    // component drawn per packet would, without a draw and a search per packet (they were 12 %
    // of a seeing render). A single Gaussian draws nothing more (its stream unchanged).
    let groups: Vec<(u64, u32, f64)> = match psf.components() {
        [(_, s)] => batches.iter().map(|&(n, w)| (n, w, *s)).collect(),
        components => batches
            .iter()
            .flat_map(|&(n, w)| {
                split_by_weight(rng, n, components)
                    .into_iter()
                    .zip(components)
                    .map(move |(k, &(_, s))| (k, w, s))
            })
            .collect(),
    };
    // Every packet lands at its source's position at its arrival time (`at`, which draws the
    // arrival if it needs one), plus its Gaussian. Generic, so each path's loop is compiled
    // apart.
    fn land(
        canvas: &mut Tally,
        rng: &mut PixelRng,
        groups: &[(u64, u32, f64)],
        debris: bool,
        mut at: impl FnMut(&mut PixelRng) -> (f64, f64),
    ) {
        for &(count, weight, psf_px) in groups {
            for _ in 0..count {
                let (x0, y0) = at(rng);
                let gx: f64 = rng.sample(StandardNormal);
                let gy: f64 = rng.sample(StandardNormal);
                canvas.add(x0 + gx * psf_px, y0 + gy * psf_px, weight, debris);
            }
        }
    }
    let debris = source.debris;
    match source.path {
        // All of a trajectory sample's photons arrive at one time, so one jittered position:
        // computed once, not per packet (the same sums in the same order, so the same pixels).
        Path::Instant { t, x, y } => {
            let (jx, jy) = jitter.at(t);
            let (x0, y0) = (x + jx, y + jy);
            land(canvas, rng, &groups, debris, |_| (x0, y0));
        }
        // A fixed star's photons arrive uniformly over the whole exposure, which the jitter
        // grid spans: the arrival drawn in grid steps gives the cell and fraction directly.
        Path::Still { x, y } => {
            let steps = jitter.steps() as f64;
            land(canvas, rng, &groups, debris, |rng| {
                let (jx, jy) = jitter.at_step(rng.random_range(0.0..steps));
                (x + jx, y + jy)
            });
        }
        _ => land(canvas, rng, &groups, debris, |rng| {
            let t = source.arrival(rng);
            let (x0, y0) = source.path.at(t);
            let (jx, jy) = jitter.at(t);
            (x0 + jx, y0 + jy)
        }),
    }
}

/// `n` packets split among a mixture's Gaussians `(weight, sigma)` as `n` independent draws
/// of one would fall (multinomial): each count binomial of the packets left and the Gaussian's
/// share of the weight left.
fn split_by_weight(rng: &mut PixelRng, n: u64, components: &[(f64, f64)]) -> Vec<u64> {
    let mut counts = vec![0; components.len()];
    let (mut left, mut weight_left) = (n, 1.0);
    for (count, &(w, _)) in counts.iter_mut().zip(components) {
        if left == 0 {
            break;
        }
        let p = (w / weight_left).clamp(0.0, 1.0);
        // p is in [0, 1], so the binomial exists; the last Gaussian's share rounds to 1.
        *count = Binomial::new(left, p).map_or(left, |b| rng.sample(b));
        left -= *count;
        weight_left -= w;
    }
    // Rounding may leave a packet or two beyond the last share: the last Gaussian takes them.
    if let Some(last) = counts.last_mut() {
        *last += left;
    }
    counts
}

#[cfg(test)]
mod tests {
    use super::*;
    use soig_base::rng::{PixelPurpose, pixel_stream};

    #[test]
    fn packets_split_among_the_gaussians_by_weight() {
        let psf = Psf::moffat(3.0, 2.5);
        let components = psf.components();
        let mut rng = pixel_stream(7, 1, PixelPurpose::Photons);
        let (n, rounds) = (10_000u64, 200);
        let mut sums = vec![0u64; components.len()];
        for _ in 0..rounds {
            let counts = split_by_weight(&mut rng, n, components);
            // Every packet goes through exactly one Gaussian.
            assert_eq!(counts.iter().sum::<u64>(), n);
            sums.iter_mut().zip(&counts).for_each(|(s, c)| *s += c);
        }
        let total = (n * rounds) as f64;
        for (&s, &(w, _)) in sums.iter().zip(components) {
            // A multinomial share of 2e6 draws: its standard deviation sqrt(w (1 - w) / 2e6);
            // 5 of them (and 2 draws for the lightest Gaussians) before it can fail by chance.
            let tolerance = 5.0 * (w * (1.0 - w) / total).sqrt() + 2.0 / total;
            assert!(
                (s as f64 / total - w).abs() <= tolerance,
                "{w}: {}",
                s as f64 / total
            );
        }
        // No packets, no counts; one Gaussian takes them all.
        assert!(
            split_by_weight(&mut rng, 0, components)
                .iter()
                .all(|&c| c == 0)
        );
        assert_eq!(split_by_weight(&mut rng, 5, &[(1.0, 2.0)]), vec![5]);
    }
}
