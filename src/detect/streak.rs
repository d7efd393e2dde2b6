//! Classical (model-free) detection of debris streaks in 8-bit space-telescope images.
//!
//! The debris is a straight, often faint streak tens to hundreds of pixels long; stars are round
//! dots (fixed pointing) or parallel trails along a known direction (survey pointing). The
//! detector is a matched filter for faint linear features followed by component analysis:
//!
//! 1. **Background and noise.** The image is cut into a mesh of about `mesh_size` pixel cells.
//!    In each cell the background is the sigma-clipped median and the noise the clipped MAD
//!    (x 1.4826) of the grey levels (histogram based, values treated as uniform within their
//!    grey level). The mesh is 3x3 median filtered and interpolated bilinearly between cell
//!    centres. The noise is floored at `min_noise_sigma`. Residual `q = (I - bg) / sigma`.
//! 2. **Cross-section matched filter.** `q` is smoothed by a Gaussian of `psf_sigma_px` (the
//!    streak's cross-section profile; mirrored edges, with the edge rows and columns rescaled to
//!    the interior noise) and divided by its robust (MAD) standard deviation, giving `z` with
//!    unit noise. Survey images (trail direction given): structures along the trail direction
//!    are subtracted (one-sided means over `trail_filter_px` pixels along it, see
//!    `remove_trails`). Stars are masked: round local maxima of `z` above `star_mask_sigma`
//!    (ring test, `star_ring_ratio`) are zeroed out to where they fade into the noise. A copy
//!    clipped to `[-clip_sigma, clip_sigma]` limits the weight of what remains bright.
//! 3. **Oriented line filter.** For `n_angles` orientations in [0, 180) and each length in
//!    `line_lengths_px`, the clipped `z` is summed along a digital straight line of that length
//!    centred on every pixel (running sums over rows of the image or of its transpose, O(1) per
//!    pixel and filter, contiguous memory). Each sum is divided by its noise standard deviation
//!    (white pixel noise smoothed by the Gaussian, exact for the digital line), so every filter
//!    output is in sigma; beyond the image counts as zero (conservative near the edges). Per
//!    pixel the maximum over filters and its orientation are kept.
//! 4. **Components.** Pixels with response >= `threshold_sigma` are joined by 8-connectivity,
//!    but only between pixels whose best orientations differ by at most `angle_link_bins`
//!    steps, so that a streak crossing a star trail splits instead of merging with it.
//!    A component is kept if it has `min_pixels` pixels and a peak >= `seed_sigma`; its
//!    centroid and second moments give an axis and extent.
//! 5. **Refinement.** Around each component axis the orientation and lateral offset are refined
//!    by a coarse-to-fine grid search (+-2 filter steps, then finer) maximising `z` clipped at
//!    4 `clip_sigma` summed along the axis. Then the profile `p(t)` along the axis (mean of `z`
//!    at lateral offsets -1, 0, 1 px) is read, the streak level is the median of `p` in the
//!    component's inner part, and each end is the change point maximising the cumulative sum
//!    of `min(p, 1.5 level) - level / 2` outwards (the half-level crossing, robust to noise
//!    dips). Measured on the refined segment: length between the ends; SNR = median of `p`
//!    over the segment times its sample count, divided by the noise standard deviation of that
//!    sum (white-noise model; the median keeps a bright star on the axis from making a
//!    streak); flux = sum of background-subtracted grey levels within `3 psf_sigma_px` of the
//!    segment; elongation = sqrt(l1 / l2) of the second moments of the pixels within
//!    `3 psf_sigma_px` of the segment weighted by `z` clipped to `[0, clip_sigma]` (a streak of
//!    length L: about L / (sqrt(12) 2.5); a star: about 1).
//! 6. **Rejection and merging.** Fragments aligned with the star-trail direction (when given,
//!    within `star_trail_tolerance_deg` + atan(4 psf_sigma / length)) or shorter than
//!    `min_fragment_px` are dropped; collinear fragments (angle within `merge_angle_deg`,
//!    lateral offsets within `merge_offset_px`, gap along the axis within `merge_gap_px`) are
//!    merged and re-refined until none merge. Candidates need length >= `min_length_px`,
//!    elongation >= `min_elongation` and SNR >= `min_snr`; the trail test is applied again.
//!    Explaining away, best score first: the profile samples of a candidate within
//!    `duplicate_distance_px` of a better candidate are ignored and the rest must still pass
//!    the length and SNR tests (drops duplicates and the off-axis echoes of bright streaks).
//! 7. **Output.** Score (monotone increasing in SNR and in elongation, in [0, 1)):
//!    `(1 - exp(-snr / score_snr_scale)) * (1 - exp(-(elongation - 1) / score_elongation_scale))`.
//!    Box: the refined segment padded by `box_pad_along_sigma * psf_sigma_px` along the axis and
//!    `box_pad_across_sigma * psf_sigma_px` across it (bounding box of that ellipse-capped
//!    segment), which matches the label convention of the generator (the box holding all but
//!    0.25 % of the debris flux on each side), in pixel-edge coordinates (pixel `i` spans
//!    `[i, i + 1]`), clipped to the image. Candidates are sorted by decreasing score, at most
//!    `max_candidates`.
//!
//! Orientations (the output `orientation_deg` and the input `star_trail_angle_deg`) are in
//! image axes: degrees from the +x axis (columns, rightwards) towards +y (rows, downwards),
//! modulo 180, reported in [0, 180).
//!
//! Everything is single-threaded and deterministic: the same input gives the same output.

use super::Detection;

use std::f64::consts::PI;

/// Every knob of [`detect_streaks`], with its default.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize, PartialEq)]
#[serde(default)]
pub struct StreakParams {
    /// Background mesh cell size in pixels (default 64). Images smaller than a cell use one cell.
    pub mesh_size: usize,
    /// Sigma-clipping factor for the background and noise statistics of each cell (default 3.0).
    pub mesh_clip_sigma: f64,
    /// Floor on the per-pixel noise sigma, grey levels (default 0.5, about the 8-bit quantisation).
    pub min_noise_sigma: f64,
    /// Gaussian sigma of the streak cross-section (the PSF), pixels (default 1.5). Sets the
    /// smoothing kernel and the box padding.
    pub psf_sigma_px: f64,
    /// The smoothed image (unit noise) is clipped to +-this before line filtering (default 4.0).
    pub clip_sigma: f64,
    /// Stars are masked: local maxima of the smoothed image (unit noise) of at least this ...
    /// (default 5.0) ...
    pub star_mask_sigma: f64,
    /// ... whose surrounding ring (radius 2 sqrt(2) psf_sigma) stays below this fraction of the
    /// peak (default 0.5).
    pub star_ring_ratio: f64,
    /// Number of line-filter orientations over [0, 180) (default 24, i.e. 7.5 deg steps; 4..=180).
    pub n_angles: usize,
    /// Line-filter lengths in pixels, each rounded up to odd (default [21, 51]).
    pub line_lengths_px: Vec<usize>,
    /// Line-filter response, in sigma, for a pixel to join a component (default 3.0).
    pub threshold_sigma: f64,
    /// A component must reach this response, in sigma, somewhere (default 5.0).
    pub seed_sigma: f64,
    /// Neighbouring pixels join only if their best orientations differ by at most this many
    /// filter steps (default 1).
    pub angle_link_bins: usize,
    /// Minimum number of pixels of a component (default 15).
    pub min_pixels: usize,
    /// Refined fragments shorter than this (pixels) are dropped before merging (default 8.0).
    pub min_fragment_px: f64,
    /// Minimum refined streak length, pixels (default 20.0).
    pub min_length_px: f64,
    /// Minimum elongation sqrt(l1 / l2) (default 2.5; a round star is about 1).
    pub min_elongation: f64,
    /// Minimum SNR of the whole streak (default 6.5).
    pub min_snr: f64,
    /// Candidates within this angle of the star-trail direction, plus atan(4 psf_sigma / length)
    /// for the orientation uncertainty of short ones, are stars (default 5.0 deg).
    pub star_trail_tolerance_deg: f64,
    /// Survey images: before line filtering each pixel loses the mean along the star-trail
    /// direction over this many pixels (rounded up to odd) just before or just after it (the
    /// larger where significant, else their average), which removes trails longer than about
    /// twice this (default 31; 0 = off).
    pub trail_filter_px: usize,
    /// Fragments merge if their orientations differ by at most this (default 5.0 deg) ...
    pub merge_angle_deg: f64,
    /// ... each one's ends lie within this distance of the other's axis (default 4.0 px) ...
    pub merge_offset_px: f64,
    /// ... and the gap between them along the axis is at most this (default 60.0 px).
    pub merge_gap_px: f64,
    /// Explaining away: a candidate's profile samples within this distance of a higher-scoring
    /// candidate's segment are ignored, and what remains must still reach `min_length_px` and
    /// `min_snr` (default 10.0 px). Drops duplicates and the off-axis echoes of bright streaks.
    pub duplicate_distance_px: f64,
    /// Box padding along the streak axis beyond the ends, in PSF sigmas (default 1.0).
    pub box_pad_along_sigma: f64,
    /// Box padding across the streak axis, in PSF sigmas (default 3.0).
    pub box_pad_across_sigma: f64,
    /// SNR scale of the score (default 10.0).
    pub score_snr_scale: f64,
    /// Elongation scale of the score (default 3.0).
    pub score_elongation_scale: f64,
    /// Class written into the detections (default 0).
    pub class: u32,
    /// At most this many candidates are returned, best first (default 16).
    pub max_candidates: usize,
}

impl Default for StreakParams {
    fn default() -> Self {
        StreakParams {
            mesh_size: 64,
            mesh_clip_sigma: 3.0,
            min_noise_sigma: 0.5,
            psf_sigma_px: 1.5,
            clip_sigma: 4.0,
            star_mask_sigma: 5.0,
            star_ring_ratio: 0.5,
            n_angles: 24,
            line_lengths_px: vec![21, 51],
            threshold_sigma: 3.0,
            seed_sigma: 5.0,
            angle_link_bins: 1,
            min_pixels: 15,
            min_fragment_px: 8.0,
            min_length_px: 20.0,
            min_elongation: 2.5,
            min_snr: 6.5,
            star_trail_tolerance_deg: 5.0,
            trail_filter_px: 31,
            merge_angle_deg: 5.0,
            merge_offset_px: 4.0,
            merge_gap_px: 60.0,
            duplicate_distance_px: 10.0,
            box_pad_along_sigma: 1.0,
            box_pad_across_sigma: 3.0,
            score_snr_scale: 10.0,
            score_elongation_scale: 3.0,
            class: 0,
            max_candidates: 16,
        }
    }
}

/// One detected streak.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Candidate {
    /// Box (pixel-edge coordinates), score in [0, 1) and class.
    pub detection: Detection,
    /// Length between the half-level ends, pixels.
    pub length_px: f64,
    /// Axis orientation, degrees from +x towards +y (image rows down), in [0, 180).
    pub orientation_deg: f64,
    /// sqrt(l1 / l2) of the z-weighted second moments around the segment.
    pub elongation: f64,
    /// Background-subtracted grey levels summed within 3 PSF sigmas of the segment.
    pub flux: f64,
    /// Matched-filter signal-to-noise ratio of the whole streak.
    pub snr: f64,
}

/// Detect streaks in an 8-bit image (`pixels` row-major, `width * height` values).
/// `star_trail_angle_deg`: in survey images the known direction of star trails (from the
/// attitude), in the image-axis convention of the module docs; candidates aligned with it
/// within the tolerance are stars, not debris. `None` for fixed pointing (stars are round,
/// rejected by length and elongation). Panics if `pixels.len() != width * height`.
pub fn detect_streaks(
    pixels: &[u8],
    width: usize,
    height: usize,
    params: &StreakParams,
    star_trail_angle_deg: Option<f64>,
) -> Vec<Candidate> {
    assert_eq!(
        pixels.len(),
        width * height,
        "pixels.len() must be width * height"
    );
    if width < 2 || height < 2 {
        return Vec::new();
    }
    let p = Sanitized::new(params);
    let (w, h) = (width, height);

    // 1. Background and noise.
    let (bg, sigma) = background(pixels, w, h, &p);
    let q: Vec<f32> = pixels
        .iter()
        .zip(bg.iter().zip(sigma.iter()))
        .map(|(&v, (&b, &s))| (v as f32 - b) / s)
        .collect();

    // 2. Cross-section matched filter, normalised to unit noise.
    let kernel = gaussian_kernel(p.psf_sigma);
    let mut z = smooth(&q, w, h, &kernel);
    drop(q);
    equalise_edge_noise(&mut z, w, h, &kernel);
    let kappa_white: f64 = kernel.iter().map(|&k| (k as f64) * (k as f64)).sum();
    let kappa = robust_sigma(&z, w, h).max(0.5 * kappa_white);
    let inv_kappa = (1.0 / kappa) as f32;
    z.iter_mut().for_each(|v| *v *= inv_kappa);
    if let Some(a) = star_trail_angle_deg.filter(|a| a.is_finite()) {
        remove_trails(&mut z, w, h, a.to_radians(), &p);
    }
    mask_stars(&mut z, w, h, &p);
    let clip = p.clip as f32;
    let zc: Vec<f32> = z.iter().map(|&v| v.clamp(-clip, clip)).collect();

    // 3. Oriented line filter.
    let (best, arg) = line_filter(&zc, w, h, &p);

    // 4. Components.
    let comps = components(&best, &arg, w, h, &p);

    // 5-6. Refinement, rejection, merging.
    let ctx = Ctx {
        w,
        h,
        pixels,
        bg: &bg,
        z: &z,
        p: &p,
    };
    let trail = star_trail_angle_deg.filter(|a| a.is_finite());
    // A short segment's orientation is uncertain by about its width over its length, so the
    // tolerance grows by atan(4 psf_sigma / length).
    let aligned = |s: &Seg| match trail {
        Some(a) => {
            let slack = (4.0 * p.psf_sigma / s.length.max(1.0)).atan().to_degrees();
            angle_diff_deg(s.theta.to_degrees(), a) <= p.trail_tol + slack
        }
        None => false,
    };
    let kmax = p.half_lengths.iter().copied().max().unwrap_or(10) as f64 * 2.0 + 1.0;
    let mut frags: Vec<Seg> = Vec::new();
    for c in &comps {
        let shrink = (kmax / 2.0).min(c.half_len / 2.0);
        let seed = Seed {
            cx: c.cx,
            cy: c.cy,
            theta: c.theta,
            half: c.half_len,
            shrink,
            ext: kmax,
        };
        if let Some(s) = ctx.refine(&seed)
            && s.length >= p.min_fragment
            && !aligned(&s)
        {
            frags.push(s);
        }
    }
    let merged = ctx.merge(frags, &aligned);

    // 7. Acceptance, scoring, duplicates.
    let mut cands: Vec<(Seg, f64)> = merged
        .into_iter()
        .filter(|s| {
            s.length >= p.min_length
                && s.elongation >= p.min_elongation
                && s.snr >= p.min_snr
                && !aligned(s)
        })
        .map(|s| {
            let score = score(s.snr, s.elongation, &p);
            (s, score)
        })
        .collect();
    cands.sort_by(|a, b| {
        b.1.total_cmp(&a.1)
            .then(a.0.cx.total_cmp(&b.0.cx))
            .then(a.0.cy.total_cmp(&b.0.cy))
    });
    // Explaining away: a candidate must still be long and significant enough outside the
    // neighbourhood of every better one (drops duplicates and the off-axis responses of
    // bright streaks).
    let mut kept: Vec<(Seg, f64)> = Vec::new();
    for (s, sc) in cands {
        if kept.len() >= p.max_candidates {
            break;
        }
        let others: Vec<(Point, Point)> = kept.iter().map(|(k, _)| k.ends()).collect();
        if !others.is_empty() && !ctx.survives(&s, &others) {
            continue;
        }
        kept.push((s, sc));
    }
    kept.into_iter()
        .map(|(s, sc)| ctx.candidate(&s, sc))
        .collect()
}

/// Parameters checked and converted once.
struct Sanitized {
    mesh: usize,
    mesh_clip: f64,
    min_sigma: f64,
    psf_sigma: f64,
    clip: f64,
    star_z: f64,
    star_ring_ratio: f64,
    n_angles: usize,
    half_lengths: Vec<usize>,
    threshold: f32,
    seed: f32,
    link_bins: usize,
    min_pixels: usize,
    min_fragment: f64,
    min_length: f64,
    min_elongation: f64,
    min_snr: f64,
    trail_tol: f64,
    trail_half: usize,
    merge_angle: f64,
    merge_offset: f64,
    merge_gap: f64,
    dup_dist: f64,
    pad_along: f64,
    pad_across: f64,
    snr_scale: f64,
    elong_scale: f64,
    class: u32,
    max_candidates: usize,
}

impl Sanitized {
    fn new(p: &StreakParams) -> Self {
        let fin = |v: f64, d: f64| if v.is_finite() { v } else { d };
        let mut half_lengths: Vec<usize> = p
            .line_lengths_px
            .iter()
            .map(|&k| (k.clamp(3, 4001)) / 2)
            .collect();
        half_lengths.sort_unstable();
        half_lengths.dedup();
        if half_lengths.is_empty() {
            half_lengths.push(10);
        }
        Sanitized {
            mesh: p.mesh_size.max(8),
            mesh_clip: fin(p.mesh_clip_sigma, 3.0).max(1.0),
            min_sigma: fin(p.min_noise_sigma, 0.5).max(1e-3),
            psf_sigma: fin(p.psf_sigma_px, 1.5).clamp(0.3, 20.0),
            clip: fin(p.clip_sigma, 4.0).max(0.5),
            star_z: fin(p.star_mask_sigma, 5.0).max(1.0),
            star_ring_ratio: fin(p.star_ring_ratio, 0.5).clamp(0.0, 1.0),
            n_angles: p.n_angles.clamp(4, 180),
            half_lengths,
            threshold: fin(p.threshold_sigma, 3.0) as f32,
            seed: fin(p.seed_sigma, 5.0) as f32,
            link_bins: p.angle_link_bins,
            min_pixels: p.min_pixels.max(1),
            min_fragment: fin(p.min_fragment_px, 8.0),
            min_length: fin(p.min_length_px, 20.0),
            min_elongation: fin(p.min_elongation, 2.5),
            min_snr: fin(p.min_snr, 6.5),
            trail_tol: fin(p.star_trail_tolerance_deg, 5.0).abs(),
            trail_half: p.trail_filter_px.min(4001) / 2,
            merge_angle: fin(p.merge_angle_deg, 5.0).abs(),
            merge_offset: fin(p.merge_offset_px, 4.0).abs(),
            merge_gap: fin(p.merge_gap_px, 60.0),
            dup_dist: fin(p.duplicate_distance_px, 10.0),
            pad_along: fin(p.box_pad_along_sigma, 1.0).max(0.0),
            pad_across: fin(p.box_pad_across_sigma, 3.0).max(0.0),
            snr_scale: fin(p.score_snr_scale, 10.0).max(1e-9),
            elong_scale: fin(p.score_elongation_scale, 3.0).max(1e-9),
            class: p.class,
            max_candidates: p.max_candidates,
        }
    }
}

/// Score in [0, 1): increasing in SNR and in elongation.
fn score(snr: f64, elongation: f64, p: &Sanitized) -> f64 {
    let a = 1.0 - (-snr.max(0.0) / p.snr_scale).exp();
    let b = 1.0 - (-(elongation - 1.0).max(0.0) / p.elong_scale).exp();
    (a * b).clamp(0.0, 1.0)
}

/// Absolute difference of two axis orientations in degrees, modulo 180 (result in [0, 90]).
fn angle_diff_deg(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(180.0);
    d.min(180.0 - d)
}

fn point_segment_distance(p: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 {
        (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let (ex, ey) = (a.0 + t * dx - p.0, a.1 + t * dy - p.1);
    (ex * ex + ey * ey).sqrt()
}

// ---------------------------------------------------------------------------------------------
// 1. Background and noise
// ---------------------------------------------------------------------------------------------

/// Continuous CDF and quantiles of an 8-bit histogram, each grey level spread uniformly over
/// [v - 0.5, v + 0.5).
struct Hist {
    counts: [u32; 256],
    cum: [u64; 257],
}

impl Hist {
    fn new(counts: [u32; 256]) -> Self {
        let mut cum = [0u64; 257];
        for v in 0..256 {
            cum[v + 1] = cum[v] + counts[v] as u64;
        }
        Hist { counts, cum }
    }
    fn total(&self) -> u64 {
        self.cum[256]
    }
    fn cdf(&self, x: f64) -> f64 {
        let b = (x + 0.5).floor();
        if b < 0.0 {
            return 0.0;
        }
        if b > 255.0 {
            return self.total() as f64;
        }
        let bi = b as usize;
        self.cum[bi] as f64 + self.counts[bi] as f64 * (x + 0.5 - b)
    }
    fn quantile(&self, q: f64) -> f64 {
        let target = q * self.total() as f64;
        // First bin whose cumulative count reaches the target.
        let mut b = 0;
        while b < 255 && (self.cum[b + 1] as f64) < target {
            b += 1;
        }
        let c = self.counts[b].max(1) as f64;
        b as f64 - 0.5 + ((target - self.cum[b] as f64) / c).clamp(0.0, 1.0)
    }
    /// Median absolute deviation around `m`.
    fn mad(&self, m: f64) -> f64 {
        let half = 0.5 * self.total() as f64;
        let (mut lo, mut hi) = (0.0f64, 256.0f64);
        for _ in 0..40 {
            let r = 0.5 * (lo + hi);
            if self.cdf(m + r) - self.cdf(m - r) < half {
                lo = r;
            } else {
                hi = r;
            }
        }
        0.5 * (lo + hi)
    }
}

/// Sigma-clipped median and MAD-sigma of a cell histogram.
fn cell_stats(counts: &[u32; 256], clip: f64) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (-1.0f64, 256.0f64);
    let mut out = None;
    for _ in 0..4 {
        let mut c = [0u32; 256];
        for v in 0..256 {
            let fv = v as f64;
            if fv >= lo && fv <= hi {
                c[v] = counts[v];
            }
        }
        let hist = Hist::new(c);
        if hist.total() == 0 {
            break;
        }
        let med = hist.quantile(0.5);
        let sig = 1.4826 * hist.mad(med);
        out = Some((med, sig));
        let s = sig.max(0.5);
        lo = med - clip * s;
        hi = med + clip * s;
    }
    out
}

/// Cell boundaries: `n` nearly equal cells of about `mesh` pixels over `len` pixels.
fn cell_edges(len: usize, mesh: usize) -> Vec<usize> {
    let n = ((len + mesh / 2) / mesh).max(1);
    (0..=n).map(|i| i * len / n).collect()
}

fn median_of(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn median_filter_mesh(m: &[f64], nx: usize, ny: usize) -> Vec<f64> {
    let mut out = vec![0.0; m.len()];
    let mut buf = Vec::with_capacity(9);
    for j in 0..ny {
        for i in 0..nx {
            buf.clear();
            for jj in j.saturating_sub(1)..=(j + 1).min(ny - 1) {
                for ii in i.saturating_sub(1)..=(i + 1).min(nx - 1) {
                    buf.push(m[jj * nx + ii]);
                }
            }
            out[j * nx + i] = median_of(&mut buf);
        }
    }
    out
}

/// Per-axis interpolation weights between cell centres: (i0, i1, f) per pixel.
fn interp_axis(edges: &[usize], len: usize) -> Vec<(usize, usize, f32)> {
    let n = edges.len() - 1;
    let centres: Vec<f64> = (0..n)
        .map(|i| 0.5 * (edges[i] + edges[i + 1]) as f64 - 0.5)
        .collect();
    (0..len)
        .map(|x| {
            let xf = x as f64;
            if n == 1 || xf <= centres[0] {
                return (0, 0, 0.0);
            }
            if xf >= centres[n - 1] {
                return (n - 1, n - 1, 0.0);
            }
            let mut i = 0;
            while i + 1 < n && centres[i + 1] < xf {
                i += 1;
            }
            let f = (xf - centres[i]) / (centres[i + 1] - centres[i]);
            (i, i + 1, f as f32)
        })
        .collect()
}

/// Background and noise maps (grey levels), full resolution.
#[inline(never)]
fn background(pixels: &[u8], w: usize, h: usize, p: &Sanitized) -> (Vec<f32>, Vec<f32>) {
    let ex = cell_edges(w, p.mesh);
    let ey = cell_edges(h, p.mesh);
    let (nx, ny) = (ex.len() - 1, ey.len() - 1);
    let mut mb = vec![0.0; nx * ny];
    let mut ms = vec![0.0; nx * ny];
    for j in 0..ny {
        for i in 0..nx {
            let mut counts = [0u32; 256];
            for y in ey[j]..ey[j + 1] {
                for &v in &pixels[y * w + ex[i]..y * w + ex[i + 1]] {
                    counts[v as usize] += 1;
                }
            }
            let (m, s) = cell_stats(&counts, p.mesh_clip).unwrap_or((0.0, p.min_sigma));
            mb[j * nx + i] = m;
            ms[j * nx + i] = s;
        }
    }
    let mb = median_filter_mesh(&mb, nx, ny);
    let ms = median_filter_mesh(&ms, nx, ny);
    let ix = interp_axis(&ex, w);
    let iy = interp_axis(&ey, h);
    let mut bg = vec![0f32; w * h];
    let mut sg = vec![0f32; w * h];
    let min_sigma = p.min_sigma as f32;
    let mut rb = vec![0f32; nx];
    let mut rs = vec![0f32; nx];
    for (y, &(j0, j1, fy)) in iy.iter().enumerate() {
        for i in 0..nx {
            rb[i] = (1.0 - fy) * mb[j0 * nx + i] as f32 + fy * mb[j1 * nx + i] as f32;
            rs[i] = (1.0 - fy) * ms[j0 * nx + i] as f32 + fy * ms[j1 * nx + i] as f32;
        }
        let row = y * w;
        for (x, &(i0, i1, fx)) in ix.iter().enumerate() {
            bg[row + x] = (1.0 - fx) * rb[i0] + fx * rb[i1];
            sg[row + x] = ((1.0 - fx) * rs[i0] + fx * rs[i1]).max(min_sigma);
        }
    }
    (bg, sg)
}

// ---------------------------------------------------------------------------------------------
// 2. Smoothing and noise normalisation
// ---------------------------------------------------------------------------------------------

fn gaussian_kernel(sigma: f64) -> Vec<f32> {
    let r = (3.0 * sigma).ceil() as i64;
    let k: Vec<f64> = (-r..=r)
        .map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let s: f64 = k.iter().sum();
    k.iter().map(|v| (v / s) as f32).collect()
}

/// Mirror (reflect-101) index into [0, n).
fn reflect(i: isize, n: usize) -> usize {
    if n == 1 {
        return 0;
    }
    let period = 2 * (n as isize - 1);
    let m = i.rem_euclid(period);
    if m >= n as isize {
        (period - m) as usize
    } else {
        m as usize
    }
}

/// Separable convolution with mirrored borders.
#[inline(never)]
fn smooth(src: &[f32], w: usize, h: usize, k: &[f32]) -> Vec<f32> {
    let r = (k.len() / 2) as isize;
    let ru = r as usize;
    let mut tmp = vec![0f32; w * h];
    for y in 0..h {
        let row = &src[y * w..(y + 1) * w];
        let out = &mut tmp[y * w..(y + 1) * w];
        // Interior: one shifted slice per tap (vectorised).
        if w > 2 * ru {
            let n = w - 2 * ru;
            for (kk, &kv) in k.iter().enumerate() {
                for (o, &v) in out[ru..ru + n].iter_mut().zip(&row[kk..kk + n]) {
                    *o += kv * v;
                }
            }
        }
        // Edges: mirrored.
        for x in (0..ru.min(w)).chain(w.saturating_sub(ru).max(ru.min(w))..w) {
            let xi = x as isize;
            out[x] = k
                .iter()
                .enumerate()
                .map(|(kk, &kv)| kv * row[reflect(xi + kk as isize - r, w)])
                .sum();
        }
    }
    let mut out = vec![0f32; w * h];
    for y in 0..h {
        let orow = &mut out[y * w..(y + 1) * w];
        for (kk, &kv) in k.iter().enumerate() {
            let yy = reflect(y as isize + kk as isize - r, h);
            let irow = &tmp[yy * w..(yy + 1) * w];
            for (o, &v) in orow.iter_mut().zip(irow) {
                *o += kv * v;
            }
        }
    }
    out
}

/// Median of a map, from a regular subsample.
fn robust_median(v: &[f32], w: usize, h: usize) -> f64 {
    let step = if w * h > 40_000 { 3 } else { 1 };
    let mut s: Vec<f32> = Vec::with_capacity((w / step + 1) * (h / step + 1));
    for y in (0..h).step_by(step) {
        for x in (0..w).step_by(step) {
            s.push(v[y * w + x]);
        }
    }
    if s.is_empty() {
        return 0.0;
    }
    let mid = s.len() / 2;
    *s.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1 as f64
}

/// Near the edges the mirrored smoothing counts some pixels twice, which raises the noise (up
/// to about 1.4 times on the edge row for sigma 1.5) and would make lines along the edges.
/// Divide by the exact noise ratio of the folded kernel, per row and per column.
#[inline(never)]
fn equalise_edge_noise(z: &mut [f32], w: usize, h: usize, k: &[f32]) {
    let ratio = |n: usize| -> Vec<f32> {
        let r = (k.len() / 2) as isize;
        let base: f64 = k.iter().map(|&v| (v as f64).powi(2)).sum();
        (0..n)
            .map(|i| {
                let mut folded = vec![0f64; n];
                for (kk, &kv) in k.iter().enumerate() {
                    folded[reflect(i as isize + kk as isize - r, n)] += kv as f64;
                }
                let var: f64 = folded.iter().map(|v| v * v).sum();
                (base / var).sqrt() as f32
            })
            .collect()
    };
    let (fx, fy) = (ratio(w), ratio(h));
    for (y, row) in z.chunks_mut(w).enumerate() {
        for (v, &f) in row.iter_mut().zip(&fx) {
            *v *= f * fy[y];
        }
    }
}

/// Robust (1.4826 MAD) standard deviation of a map, from a regular subsample.
#[inline(never)]
fn robust_sigma(v: &[f32], w: usize, h: usize) -> f64 {
    let step = if w * h > 40_000 { 3 } else { 1 };
    let mut s: Vec<f32> = Vec::with_capacity((w / step + 1) * (h / step + 1));
    for y in (0..h).step_by(step) {
        for x in (0..w).step_by(step) {
            s.push(v[y * w + x]);
        }
    }
    if s.is_empty() {
        return 0.0;
    }
    let mid = s.len() / 2;
    let med = *s.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
    s.iter_mut().for_each(|x| *x = (*x - med).abs());
    let mad = *s.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
    1.4826 * mad as f64
}

/// Correlation of the smoothed unit-noise map at distance d (white noise through a Gaussian).
fn corr(d2: f64, psf_sigma: f64) -> f64 {
    (-d2 / (4.0 * psf_sigma * psf_sigma)).exp()
}

/// Zero the smoothed map around round compact sources (stars): local maxima of `z` of at least
/// `star_mask_sigma` whose ring at radius 2 sqrt(2) psf_sigma (twice the smoothed PSF sigma)
/// stays below `star_ring_ratio` of the peak everywhere. A streak point has the ridge on its ring
/// and is kept. The disk zeroed reaches z = 1 of the smoothed star profile, plus 1 px.
#[inline(never)]
fn mask_stars(z: &mut [f32], w: usize, h: usize, p: &Sanitized) -> usize {
    let thr = p.star_z as f32;
    let se = std::f64::consts::SQRT_2 * p.psf_sigma;
    let ring_r = 2.0 * se;
    const NR: usize = 16;
    let ring: Vec<(f64, f64)> = (0..NR)
        .map(|k| {
            let a = 2.0 * PI * k as f64 / NR as f64;
            (ring_r * a.cos(), ring_r * a.sin())
        })
        .collect();
    let mut stars = Vec::new();
    let (wi, hi) = (w as isize, h as isize);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let v = z[i];
            if v.is_nan() || v < thr {
                continue;
            }
            // Local maximum (neighbours inside the image); ties go to the first pixel in raster
            // order.
            let mut is_max = true;
            'nb: for dy in -1isize..=1 {
                for dx in -1isize..=1 {
                    let (xx, yy) = (x as isize + dx, y as isize + dy);
                    if (dx == 0 && dy == 0) || xx < 0 || yy < 0 || xx >= wi || yy >= hi {
                        continue;
                    }
                    let nv = z[yy as usize * w + xx as usize];
                    let earlier = dy < 0 || (dy == 0 && dx < 0);
                    if nv > v || (earlier && nv >= v) {
                        is_max = false;
                        break 'nb;
                    }
                }
            }
            if !is_max {
                continue;
            }
            // Ring points outside the image are left out (a star cut by the edge is still a
            // star); at least half of the ring must be inside.
            let (xf, yf) = (x as f64, y as f64);
            let mut ring_max = f64::NEG_INFINITY;
            let mut inside = 0;
            for &(dx, dy) in &ring {
                let (px, py) = (xf + dx, yf + dy);
                if px < 0.0 || py < 0.0 || px > (w - 1) as f64 || py > (h - 1) as f64 {
                    continue;
                }
                inside += 1;
                ring_max = ring_max.max(bilinear(z, w, h, px, py));
            }
            if inside * 2 >= NR && ring_max < p.star_ring_ratio * v as f64 {
                stars.push((x, y, v as f64));
            }
        }
    }
    for &(x, y, v) in &stars {
        let r = se * (2.0 * v.max(1.0).ln()).sqrt() + 1.0;
        let ri = r.ceil() as usize;
        for yy in y.saturating_sub(ri)..=(y + ri).min(h - 1) {
            for xx in x.saturating_sub(ri)..=(x + ri).min(w - 1) {
                let d2 = (xx as f64 - x as f64).powi(2) + (yy as f64 - y as f64).powi(2);
                if d2 <= r * r {
                    z[yy * w + xx] = 0.0;
                }
            }
        }
    }
    stars.len()
}

// ---------------------------------------------------------------------------------------------
// 3. Oriented line filter
// ---------------------------------------------------------------------------------------------

/// Best response (sigma) and best orientation index per pixel.
#[inline(never)]
fn line_filter(zc: &[f32], w: usize, h: usize, p: &Sanitized) -> (Vec<f32>, Vec<u8>) {
    let n = p.n_angles;
    let hmax = *p.half_lengths.last().unwrap();
    let kmax = 2 * hmax + 1;
    // Steep (y-major) lines advance one row per step in the image itself; flat (x-major) lines
    // advance one row per step in the transposed image.
    let mut zt = vec![0f32; w * h];
    transpose(zc, &mut zt, w, h);
    let mut best = vec![f32::NEG_INFINITY; w * h];
    let mut best_t = vec![f32::NEG_INFINITY; w * h];
    let mut accs: Vec<Vec<f32>> = vec![Vec::new(); p.half_lengths.len()];
    for j in 0..n {
        let th = j as f64 * PI / n as f64;
        let (c, s) = (th.cos(), th.sin());
        let x_major = c.abs() >= s.abs() - 1e-12;
        let t = if x_major { s / c } else { c / s };
        // Noise sd of a sum of the first m terms of this digital line, m = 0..=kmax.
        let pts: Vec<(f64, f64)> = (0..kmax)
            .map(|k| (k as f64, (k as f64 * t).round()))
            .collect();
        let mut sd = vec![1f64; kmax + 1];
        let mut var = 0.0;
        for m in 0..kmax {
            let mut add = 1.0;
            for q in &pts[..m] {
                let (dx, dy) = (pts[m].0 - q.0, pts[m].1 - q.1);
                add += 2.0 * corr(dx * dx + dy * dy, p.psf_sigma);
            }
            var += add;
            sd[m + 1] = var.sqrt();
        }
        let inv: Vec<f32> = p
            .half_lengths
            .iter()
            .map(|&hk| (1.0 / sd[2 * hk + 1]) as f32)
            .collect();
        let sw = Sweep {
            halves: &p.half_lengths,
            inv: &inv,
            j: j as u8,
            t,
        };
        if x_major {
            sw.run(&zt, w, h, &mut best_t, &mut accs);
        } else {
            sw.run(zc, h, w, &mut best, &mut accs);
        }
    }
    // Merge the transposed results, then unpack the orientation index.
    transpose(&best_t, &mut zt, h, w);
    drop(best_t);
    let mut arg = vec![0u8; w * h];
    for ((b, a), &bt) in best.iter_mut().zip(arg.iter_mut()).zip(&zt) {
        let v = b.max(bt);
        *a = (v.to_bits() & 0xFF) as u8;
        *b = v;
    }
    (best, arg)
}

/// Survey images: remove structures elongated along the star-trail direction. From each pixel
/// of `z` the mean along that direction over the `trail_filter_px` pixels before it or the
/// ones after it is subtracted (the larger one where it is significant, at a trail and its
/// ends; their average elsewhere; see [`subtract_side_means`]), then the map's median is
/// restored to zero. A trail longer than the window vanishes up to its ends; a streak crossing
/// it at angle `a` keeps most of its signal (its crossing is about 5 psf_sigma / sin(a) pixels
/// of the window).
#[inline(never)]
fn remove_trails(z: &mut [f32], w: usize, h: usize, angle: f64, p: &Sanitized) {
    let hk = p.trail_half;
    if hk == 0 {
        return;
    }
    let (c, s) = (angle.cos(), angle.sin());
    let x_major = c.abs() >= s.abs();
    let t = if x_major { s / c } else { c / s };
    if x_major {
        let mut zt = vec![0f32; w * h];
        transpose(z, &mut zt, w, h);
        subtract_side_means(&mut zt, w, h, t, hk, p.psf_sigma);
        transpose(&zt, z, h, w);
    } else {
        subtract_side_means(z, h, w, t, hk, p.psf_sigma);
    }
    let med = robust_median(z, w, h) as f32;
    z.iter_mut().for_each(|v| *v -= med);
}

/// `src -= max(mean before, mean after)` along exact lines advancing one row per step (line
/// through (row i, position p + i t)); rows are split between the two nearest lines by linear
/// weights, so that bright trails at any angle leave no aliasing residual. Windows: the
/// `2 hk + 1` rows on each side, in-map pixels only (a side with fewer than 3 is missing).
/// The larger side mean is subtracted when it exceeds 3 sigma of its noise (a trail, including
/// its ends), otherwise the average of the two (unbiased on noise; removes faint trails).
fn subtract_side_means(src: &mut [f32], rows: usize, m: usize, t: f64, hk: usize, psf_sigma: f64) {
    let k = 2 * hk + 1;
    // Line coordinate of pixel (i, pos): pos + base[i].0 + base[i].1 (integer + fraction).
    let top = (0..rows).map(|i| i as f64 * t).fold(0.0, f64::max).ceil();
    let base: Vec<(usize, f32)> = (0..rows)
        .map(|i| {
            let a = top - i as f64 * t;
            let l = a.floor();
            (l as usize, (a - l) as f32)
        })
        .collect();
    let span = base.iter().map(|b| b.0).max().unwrap_or(0) + m + 2;
    // Noise sd of a window mean of n in-map terms: sqrt(c / n).
    let c_noise = line_correlation_sum(t, psf_sigma) as f32;
    // Window means and their significance (mean / noise sd) for the last 2 hk + 3 centres, by
    // line; NaN where fewer than 3 pixels.
    let ring_len = 2 * hk + 3;
    let slot = |q: isize| (q + hk as isize + 1) as usize % ring_len;
    let mut ring = vec![0f32; ring_len * span];
    let mut ring_z = vec![0f32; ring_len * span];
    let mut acc = vec![0f32; span];
    let mut cnt = vec![0f32; span];
    let splat = |acc: &mut [f32], cnt: &mut [f32], row: &[f32], (l, f): (usize, f32), sign: f32| {
        let (a0, a1) = (sign * (1.0 - f), sign * f);
        for (a, &v) in acc[l..l + m].iter_mut().zip(row) {
            *a += a0 * v;
        }
        for (a, &v) in acc[l + 1..l + 1 + m].iter_mut().zip(row) {
            *a += a1 * v;
        }
        cnt[l..l + m].iter_mut().for_each(|c| *c += a0);
        cnt[l + 1..l + 1 + m].iter_mut().for_each(|c| *c += a1);
    };
    let (hk_i, k_i, rows_i) = (hk as isize, k as isize, rows as isize);
    let mut side = vec![0f32; m];
    let lerp = |r: &[f32], l: usize, f: f32| -> Vec<f32> {
        r[l..l + m]
            .iter()
            .zip(&r[l + 1..l + 1 + m])
            .map(|(&a, &b)| (1.0 - f) * a + f * b)
            .collect()
    };
    for i in -1..=(rows_i + 2 * hk_i) {
        if (0..rows_i).contains(&i) {
            let iu = i as usize;
            splat(
                &mut acc,
                &mut cnt,
                &src[iu * m..(iu + 1) * m],
                base[iu],
                1.0,
            );
        }
        if (0..rows_i).contains(&(i - k_i)) {
            let qu = (i - k_i) as usize;
            splat(
                &mut acc,
                &mut cnt,
                &src[qu * m..(qu + 1) * m],
                base[qu],
                -1.0,
            );
        }
        // Means of the window centred on row q = i - hk (rows q - hk ..= q + hk).
        let q = i - hk_i;
        let sq = slot(q);
        for (((mv, zv), &a), &n) in ring[sq * span..(sq + 1) * span]
            .iter_mut()
            .zip(ring_z[sq * span..(sq + 1) * span].iter_mut())
            .zip(&acc)
            .zip(&cnt)
        {
            if n >= 3.0 {
                *mv = a / n;
                *zv = *mv * (n / c_noise).sqrt();
            } else {
                *mv = f32::NAN;
                *zv = f32::NAN;
            }
        }
        // Row c = q - hk - 1 now has both side windows (centres c - hk - 1 and c + hk + 1).
        let c = q - hk_i - 1;
        if (0..rows_i).contains(&c) {
            let cu = c as usize;
            let (l, f) = base[cu];
            let sb = slot(c - hk_i - 1);
            let (mb, zb) = (
                lerp(&ring[sb * span..], l, f),
                lerp(&ring_z[sb * span..], l, f),
            );
            let (ma, za) = (
                lerp(&ring[sq * span..], l, f),
                lerp(&ring_z[sq * span..], l, f),
            );
            for (j, v) in side.iter_mut().enumerate() {
                *v = match (mb[j].is_nan(), ma[j].is_nan()) {
                    (false, false) => {
                        if zb[j].max(za[j]) > 3.0 {
                            mb[j].max(ma[j])
                        } else {
                            0.5 * (mb[j] + ma[j])
                        }
                    }
                    (false, true) => mb[j],
                    (true, false) => ma[j],
                    (true, true) => 0.0,
                };
            }
            for (v, &sv) in src[cu * m..(cu + 1) * m].iter_mut().zip(&side) {
                *v -= sv;
            }
        }
    }
}

/// Sum over all lags of the noise correlation between the pixels of a digital line of slope
/// `t` (|t| <= 1): the variance of a long line sum per term.
fn line_correlation_sum(t: f64, psf_sigma: f64) -> f64 {
    let lags = (12.0 * psf_sigma).ceil() as i64;
    let mut c = 1.0;
    for k in 1..=lags {
        let (dx, dy) = (k as f64, (k as f64 * t).round());
        c += 2.0 * corr(dx * dx + dy * dy, psf_sigma);
    }
    c
}

/// Blocked transpose of a `w` x `h` row-major map into `h` x `w`.
#[inline(never)]
fn transpose(src: &[f32], dst: &mut [f32], w: usize, h: usize) {
    const B: usize = 32;
    for y0 in (0..h).step_by(B) {
        for x0 in (0..w).step_by(B) {
            for y in y0..(y0 + B).min(h) {
                for x in x0..(x0 + B).min(w) {
                    dst[x * h + y] = src[y * w + x];
                }
            }
        }
    }
}

/// One orientation of the line filter over a map of `rows` rows of `m` values, for lines that
/// advance one row per step: line `r` passes through (row `i`, position `r + round(i t)`),
/// |t| <= 1. Window sums are running sums over rows, so every memory access is a contiguous
/// row. Values beyond the map are zero (responses within half a window of an edge are
/// conservative).
struct Sweep<'a> {
    halves: &'a [usize],
    inv: &'a [f32],
    j: u8,
    t: f64,
}

impl Sweep<'_> {
    #[inline(never)]
    fn run(&self, src: &[f32], rows: usize, m: usize, best: &mut [f32], accs: &mut [Vec<f32>]) {
        let shift: Vec<usize> = {
            let s: Vec<isize> = (0..rows)
                .map(|i| (i as f64 * self.t).round() as isize)
                .collect();
            let smax = s.iter().copied().max().unwrap_or(0).max(0);
            // Offset of row i's values in the accumulators: index = pos - s[i] + smax.
            s.iter().map(|&v| (smax - v) as usize).collect()
        };
        let span = shift.iter().copied().max().unwrap_or(0) + m;
        for acc in accs.iter_mut() {
            acc.clear();
            acc.resize(span, 0.0);
        }
        let hmax = *self.halves.iter().max().unwrap_or(&0);
        for i in 0..rows + hmax {
            for (l, &hk) in self.halves.iter().enumerate() {
                let k = 2 * hk + 1;
                let acc = &mut accs[l];
                if i < rows {
                    let o = shift[i];
                    for (a, &v) in acc[o..o + m].iter_mut().zip(&src[i * m..(i + 1) * m]) {
                        *a += v;
                    }
                }
                if i >= k && i - k < rows {
                    let q = i - k;
                    let o = shift[q];
                    for (a, &v) in acc[o..o + m].iter_mut().zip(&src[q * m..(q + 1) * m]) {
                        *a -= v;
                    }
                }
                if i >= hk && i - hk < rows {
                    let c = i - hk;
                    let o = shift[c];
                    let f = self.inv[l];
                    let j = self.j as u32;
                    let brow = &mut best[c * m..(c + 1) * m];
                    // The orientation index rides in the 8 low mantissa bits, so the update is
                    // a plain (vectorised) max.
                    for (b, &v) in brow.iter_mut().zip(&acc[o..o + m]) {
                        let r = f32::from_bits(((v * f).to_bits() & !0xFF) | j);
                        *b = b.max(r);
                    }
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 4. Connected components
// ---------------------------------------------------------------------------------------------

struct Component {
    cx: f64,
    cy: f64,
    theta: f64,
    half_len: f64,
}

fn find(parent: &mut [u32], mut a: u32) -> u32 {
    while parent[a as usize] != a {
        let g = parent[parent[a as usize] as usize];
        parent[a as usize] = g;
        a = g;
    }
    a
}

#[derive(Default, Clone, Copy)]
struct Acc {
    n: u64,
    peak: f32,
    sx: f64,
    sy: f64,
    sxx: f64,
    sxy: f64,
    syy: f64,
}

#[inline(never)]
fn components(best: &[f32], arg: &[u8], w: usize, h: usize, p: &Sanitized) -> Vec<Component> {
    const NONE: u32 = u32::MAX;
    let n_ang = p.n_angles;
    let link = p.link_bins.min(n_ang / 2);
    let compat = |a: u8, b: u8| {
        let d = (a as isize - b as isize).unsigned_abs();
        d.min(n_ang - d) <= link
    };
    let thr = p.threshold;
    let mut label = vec![NONE; w * h];
    let mut parent: Vec<u32> = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if best[i].is_nan() || best[i] < thr {
                continue;
            }
            let a = arg[i];
            let mut l = NONE;
            let consider = |ni: usize, l: &mut u32, parent: &mut Vec<u32>| {
                let nl = label[ni];
                if nl != NONE && compat(arg[ni], a) {
                    let r = find(parent, nl);
                    if *l == NONE {
                        *l = r;
                    } else if r != *l {
                        let (lo, hi) = if r < *l { (r, *l) } else { (*l, r) };
                        parent[hi as usize] = lo;
                        *l = lo;
                    }
                }
            };
            if x > 0 {
                consider(i - 1, &mut l, &mut parent);
            }
            if y > 0 {
                if x > 0 {
                    consider(i - w - 1, &mut l, &mut parent);
                }
                consider(i - w, &mut l, &mut parent);
                if x + 1 < w {
                    consider(i - w + 1, &mut l, &mut parent);
                }
            }
            if l == NONE {
                l = parent.len() as u32;
                parent.push(l);
            }
            label[i] = l;
        }
    }
    let mut accs = vec![Acc::default(); parent.len()];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if label[i] == NONE {
                continue;
            }
            let r = find(&mut parent, label[i]) as usize;
            let a = &mut accs[r];
            let (xf, yf) = (x as f64, y as f64);
            a.n += 1;
            a.peak = a.peak.max(best[i]);
            a.sx += xf;
            a.sy += yf;
            a.sxx += xf * xf;
            a.sxy += xf * yf;
            a.syy += yf * yf;
        }
    }
    let mut out = Vec::new();
    for a in accs {
        if (a.n as usize) < p.min_pixels || a.peak < p.seed {
            continue;
        }
        let n = a.n as f64;
        let (cx, cy) = (a.sx / n, a.sy / n);
        let mxx = a.sxx / n - cx * cx + 1.0 / 12.0;
        let myy = a.syy / n - cy * cy + 1.0 / 12.0;
        let mxy = a.sxy / n - cx * cy;
        let theta = 0.5 * (2.0 * mxy).atan2(mxx - myy);
        let tr = 0.5 * (mxx + myy);
        let det = (0.25 * (mxx - myy) * (mxx - myy) + mxy * mxy).sqrt();
        let l1 = tr + det;
        let half_len = (3.0 * l1).sqrt();
        if 2.0 * half_len < p.min_fragment {
            continue;
        }
        out.push(Component {
            cx,
            cy,
            theta,
            half_len,
        });
    }
    out
}

// ---------------------------------------------------------------------------------------------
// 5-6. Refinement and merging
// ---------------------------------------------------------------------------------------------

/// A starting axis for refinement: centre, orientation (rad), half extent, how much of each end
/// to leave out when measuring the level, and how far beyond the extent to look for the ends.
struct Seed {
    cx: f64,
    cy: f64,
    theta: f64,
    half: f64,
    shrink: f64,
    ext: f64,
}

/// A point (x, y) in pixel-centre coordinates.
type Point = (f64, f64);

/// A refined segment: centre, orientation (rad), length and measurements.
#[derive(Clone, Copy, Debug)]
struct Seg {
    cx: f64,
    cy: f64,
    theta: f64,
    length: f64,
    snr: f64,
    flux: f64,
    elongation: f64,
}

impl Seg {
    fn dir(&self) -> (f64, f64) {
        (self.theta.cos(), self.theta.sin())
    }
    fn ends(&self) -> ((f64, f64), (f64, f64)) {
        let (ux, uy) = self.dir();
        let hl = 0.5 * self.length;
        (
            (self.cx - hl * ux, self.cy - hl * uy),
            (self.cx + hl * ux, self.cy + hl * uy),
        )
    }
}

struct Ctx<'a> {
    w: usize,
    h: usize,
    pixels: &'a [u8],
    bg: &'a [f32],
    z: &'a [f32],
    p: &'a Sanitized,
}

fn bilinear(m: &[f32], w: usize, h: usize, x: f64, y: f64) -> f64 {
    let x = x.clamp(0.0, (w - 1) as f64);
    let y = y.clamp(0.0, (h - 1) as f64);
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
    let a = m[y0 * w + x0] * (1.0 - fx) + m[y0 * w + x1] * fx;
    let b = m[y1 * w + x0] * (1.0 - fx) + m[y1 * w + x1] * fx;
    (a * (1.0 - fy) + b * fy) as f64
}

impl Ctx<'_> {
    /// Range of t for which (cx, cy) + t (ux, uy) lies inside the pixel-centre rectangle.
    fn t_range(&self, cx: f64, cy: f64, ux: f64, uy: f64) -> (f64, f64) {
        let mut lo = f64::NEG_INFINITY;
        let mut hi = f64::INFINITY;
        for (c, u, max) in [(cx, ux, (self.w - 1) as f64), (cy, uy, (self.h - 1) as f64)] {
            if u.abs() < 1e-12 {
                if c < 0.0 || c > max {
                    return (1.0, 0.0);
                }
            } else {
                let (a, b) = ((0.0 - c) / u, (max - c) / u);
                lo = lo.max(a.min(b));
                hi = hi.min(a.max(b));
            }
        }
        (lo, hi)
    }

    /// z clipped to +-`clip` summed along the axis over integer t in [-half, half] inside the
    /// image.
    fn axis_score(&self, cx: f64, cy: f64, theta: f64, half: f64, clip: f64) -> f64 {
        let (ux, uy) = (theta.cos(), theta.sin());
        let (lo, hi) = self.t_range(cx, cy, ux, uy);
        let a = (-half).max(lo).ceil() as i64;
        let b = half.min(hi).floor() as i64;
        let mut s = 0.0;
        for t in a..=b {
            let t = t as f64;
            s += bilinear(self.z, self.w, self.h, cx + t * ux, cy + t * uy).clamp(-clip, clip);
        }
        s
    }

    fn refine(&self, seed: &Seed) -> Option<Seg> {
        let p = self.p;
        let step = PI / p.n_angles as f64;
        let (mut cx, mut cy, mut th) = (seed.cx, seed.cy, seed.theta);
        let half = seed.half.max(2.0);
        // Coarse-to-fine search of orientation and lateral offset. z is clipped at 4 times
        // `clip_sigma` (bright stars are masked already): the core of a bright streak, not a
        // flat clipped band, sets the axis.
        let clip = 4.0 * p.clip;
        for (dth, nth, du, nu) in [
            (step / 4.0, 8i32, 0.5, 4i32),
            (step / 16.0, 3, 0.25, 2),
            (step / 64.0, 3, 0.125, 2),
            (step / 256.0, 3, 0.125, 1),
        ] {
            let (mut bs, mut bx, mut by, mut bt) = (f64::NEG_INFINITY, cx, cy, th);
            for i in -nth..=nth {
                let t2 = th + i as f64 * dth;
                let (nx, ny) = (-t2.sin(), t2.cos());
                for k in -nu..=nu {
                    let (x, y) = (cx + k as f64 * du * nx, cy + k as f64 * du * ny);
                    let s = self.axis_score(x, y, t2, half, clip);
                    if s > bs {
                        (bs, bx, by, bt) = (s, x, y, t2);
                    }
                }
            }
            (cx, cy, th) = (bx, by, bt);
        }
        let (ux, uy) = (th.cos(), th.sin());
        let (nx, ny) = (-uy, ux);
        let (lo, hi) = self.t_range(cx, cy, ux, uy);
        let reach = half + seed.ext;
        let ta = (-reach).max(lo).ceil() as i64;
        let tb = reach.min(hi).floor() as i64;
        if ta > 0 || tb < 0 {
            return None;
        }
        // Profile along the axis: mean of z at lateral offsets -1, 0, 1.
        let prof: Vec<f64> = (ta..=tb)
            .map(|t| {
                let (x, y) = (cx + t as f64 * ux, cy + t as f64 * uy);
                (bilinear(self.z, self.w, self.h, x - nx, y - ny)
                    + bilinear(self.z, self.w, self.h, x, y)
                    + bilinear(self.z, self.w, self.h, x + nx, y + ny))
                    / 3.0
            })
            .collect();
        let at = |t: i64| prof[(t - ta) as usize];
        let inner = (half - seed.shrink).max(1.0);
        let ia = (-inner).ceil().max(ta as f64) as i64;
        let ib = inner.floor().min(tb as f64) as i64;
        let mut vals: Vec<f64> = (ia..=ib).map(at).collect();
        if vals.is_empty() {
            return None;
        }
        let level = median_of(&mut vals);
        if level <= 0.0 {
            return None;
        }
        let cap = 1.5 * level;
        let gain = |t: i64| at(t).min(cap) - 0.5 * level;
        // Change points: the ends maximising the cumulative half-level excess from the centre.
        let (mut acc, mut bacc, mut e) = (0.0, 0.0, 0i64);
        for t in 1..=tb {
            acc += gain(t);
            if acc > bacc {
                bacc = acc;
                e = t;
            }
        }
        let (mut acc, mut bacc, mut s) = (0.0, 0.0, 0i64);
        for t in (ta..=-1).rev() {
            acc += gain(t);
            if acc > bacc {
                bacc = acc;
                s = t;
            }
        }
        // Robust SNR: the median level over the segment times its sample count, so that a
        // bright star on the axis does not make a streak.
        let mut seg_vals: Vec<f64> = (s..=e).map(at).collect();
        let n = seg_vals.len();
        let snr = median_of(&mut seg_vals) * n as f64 / self.profile_sum_sd(n);
        let (t0, t1) = (s as f64 - 0.5, e as f64 + 0.5);
        let mid = 0.5 * (t0 + t1);
        let mut seg = Seg {
            cx: cx + mid * ux,
            cy: cy + mid * uy,
            theta: th,
            length: t1 - t0,
            snr,
            flux: 0.0,
            elongation: 1.0,
        };
        let (flux, elong) = self.flux_and_elongation(&seg);
        seg.flux = flux;
        seg.elongation = elong;
        Some(seg)
    }

    /// Whether the profile samples of `s` farther than `duplicate_distance_px` from all `others`
    /// still make `min_length_px` samples and `min_snr` (median level times count over the
    /// noise sd of that many samples).
    fn survives(&self, s: &Seg, others: &[(Point, Point)]) -> bool {
        let (ux, uy) = s.dir();
        let (nx, ny) = (-uy, ux);
        let hl = 0.5 * s.length;
        let ta = (-hl + 0.5).ceil() as i64;
        let tb = (hl - 0.5).floor() as i64;
        let mut vals = Vec::new();
        for t in ta..=tb {
            let (x, y) = (s.cx + t as f64 * ux, s.cy + t as f64 * uy);
            if others
                .iter()
                .any(|&(a, b)| point_segment_distance((x, y), a, b) <= self.p.dup_dist)
            {
                continue;
            }
            vals.push(
                (bilinear(self.z, self.w, self.h, x - nx, y - ny)
                    + bilinear(self.z, self.w, self.h, x, y)
                    + bilinear(self.z, self.w, self.h, x + nx, y + ny))
                    / 3.0,
            );
        }
        let n = vals.len();
        if (n as f64) < self.p.min_length || n == 0 {
            return false;
        }
        median_of(&mut vals) * n as f64 / self.profile_sum_sd(n) >= self.p.min_snr
    }

    /// Noise sd of the sum of `n` consecutive profile samples (white-noise model).
    fn profile_sum_sd(&self, n: usize) -> f64 {
        let sp = self.p.psf_sigma;
        let c = |dt: f64| {
            let mut s = 0.0;
            for a in -1..=1 {
                for b in -1..=1 {
                    let du = (a - b) as f64;
                    s += corr(dt * dt + du * du, sp);
                }
            }
            s / 9.0
        };
        let nf = n as f64;
        let mut var = nf * c(0.0);
        let dmax = ((12.0 * sp).ceil() as usize).min(n.saturating_sub(1));
        for d in 1..=dmax {
            var += 2.0 * (nf - d as f64) * c(d as f64);
        }
        var.max(1e-12).sqrt()
    }

    /// Flux (grey levels) and weighted elongation within 3 PSF sigmas of the segment.
    fn flux_and_elongation(&self, s: &Seg) -> (f64, f64) {
        let r = 3.0 * self.p.psf_sigma;
        let (a, b) = s.ends();
        let x0 = (a.0.min(b.0) - r).floor().max(0.0) as usize;
        let x1 = (a.0.max(b.0) + r).ceil().min((self.w - 1) as f64).max(0.0) as usize;
        let y0 = (a.1.min(b.1) - r).floor().max(0.0) as usize;
        let y1 = (a.1.max(b.1) + r).ceil().min((self.h - 1) as f64).max(0.0) as usize;
        let clip = self.p.clip;
        let (mut flux, mut sw, mut sx, mut sy) = (0.0, 0.0, 0.0, 0.0);
        let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let pt = (x as f64, y as f64);
                if point_segment_distance(pt, a, b) > r {
                    continue;
                }
                let i = y * self.w + x;
                flux += self.pixels[i] as f64 - self.bg[i] as f64;
                let wgt = (self.z[i] as f64).clamp(0.0, clip);
                // Moments relative to the segment centre for accuracy.
                let (dx, dy) = (pt.0 - s.cx, pt.1 - s.cy);
                sw += wgt;
                sx += wgt * dx;
                sy += wgt * dy;
                sxx += wgt * dx * dx;
                sxy += wgt * dx * dy;
                syy += wgt * dy * dy;
            }
        }
        if sw <= 0.0 {
            return (flux, 1.0);
        }
        let (mx, my) = (sx / sw, sy / sw);
        let cxx = sxx / sw - mx * mx + 1.0 / 12.0;
        let cyy = syy / sw - my * my + 1.0 / 12.0;
        let cxy = sxy / sw - mx * my;
        let tr = 0.5 * (cxx + cyy);
        let det = (0.25 * (cxx - cyy) * (cxx - cyy) + cxy * cxy).sqrt();
        let (l1, l2) = (tr + det, (tr - det).max(1e-9));
        (flux, (l1 / l2).sqrt())
    }

    /// Merge collinear fragments until none merge.
    fn merge(&self, mut segs: Vec<Seg>, aligned: &dyn Fn(&Seg) -> bool) -> Vec<Seg> {
        let p = self.p;
        loop {
            let mut merged_any = false;
            'outer: for i in 0..segs.len() {
                for j in (i + 1)..segs.len() {
                    if !self.collinear(&segs[i], &segs[j]) {
                        continue;
                    }
                    let (a0, a1) = segs[i].ends();
                    let (b0, b1) = segs[j].ends();
                    // The two farthest ends span the merged segment.
                    let pts = [a0, a1, b0, b1];
                    let (mut bd, mut e0, mut e1) = (-1.0, a0, a1);
                    for u in 0..4 {
                        for v in (u + 1)..4 {
                            let d = (pts[u].0 - pts[v].0).hypot(pts[u].1 - pts[v].1);
                            if d > bd {
                                (bd, e0, e1) = (d, pts[u], pts[v]);
                            }
                        }
                    }
                    let seed = Seed {
                        cx: 0.5 * (e0.0 + e1.0),
                        cy: 0.5 * (e0.1 + e1.1),
                        theta: (e1.1 - e0.1).atan2(e1.0 - e0.0),
                        half: 0.5 * bd,
                        shrink: 0.0,
                        ext: 4.0 * p.psf_sigma + 4.0,
                    };
                    if let Some(m) = self.refine(&seed)
                        && !aligned(&m)
                    {
                        segs[i] = m;
                        segs.remove(j);
                        merged_any = true;
                        break 'outer;
                    }
                }
            }
            if !merged_any {
                return segs;
            }
        }
    }

    fn collinear(&self, a: &Seg, b: &Seg) -> bool {
        let p = self.p;
        if angle_diff_deg(a.theta.to_degrees(), b.theta.to_degrees()) > p.merge_angle {
            return false;
        }
        let off = |s: &Seg, q: (f64, f64)| {
            let (ux, uy) = s.dir();
            ((q.0 - s.cx) * -uy + (q.1 - s.cy) * ux).abs()
        };
        let (a0, a1) = a.ends();
        let (b0, b1) = b.ends();
        if off(a, b0).max(off(a, b1)) > p.merge_offset
            || off(b, a0).max(off(b, a1)) > p.merge_offset
        {
            return false;
        }
        // Gap along a's axis.
        let (ux, uy) = a.dir();
        let proj = |q: (f64, f64)| (q.0 - a.cx) * ux + (q.1 - a.cy) * uy;
        let (pa0, pa1) = (-0.5 * a.length, 0.5 * a.length);
        let (pb0, pb1) = {
            let (u, v) = (proj(b0), proj(b1));
            (u.min(v), u.max(v))
        };
        let gap = (pb0 - pa1).max(pa0 - pb1).max(0.0);
        gap <= p.merge_gap
    }

    fn candidate(&self, s: &Seg, score: f64) -> Candidate {
        let p = self.p;
        let (a, b) = s.ends();
        let (ux, uy) = s.dir();
        let along = p.pad_along * p.psf_sigma;
        let across = p.pad_across * p.psf_sigma;
        // Support of an ellipse (semi-axes along/across) in the x and y directions.
        let ex = ((along * ux).powi(2) + (across * uy).powi(2)).sqrt();
        let ey = ((along * uy).powi(2) + (across * ux).powi(2)).sqrt();
        let (w, h) = (self.w as f64, self.h as f64);
        let detection = Detection {
            x1: (a.0.min(b.0) - ex + 0.5).clamp(0.0, w),
            y1: (a.1.min(b.1) - ey + 0.5).clamp(0.0, h),
            x2: (a.0.max(b.0) + ex + 0.5).clamp(0.0, w),
            y2: (a.1.max(b.1) + ey + 0.5).clamp(0.0, h),
            score,
            class: p.class,
        };
        Candidate {
            detection,
            length_px: s.length,
            orientation_deg: s.theta.to_degrees().rem_euclid(180.0),
            elongation: s.elongation,
            flux: s.flux,
            snr: s.snr,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    const BG: f64 = 100.0;
    const NOISE: f64 = 8.0;
    const PSF: f64 = 1.5;

    /// Abramowitz & Stegun 7.1.26 (|error| < 1.5e-7).
    fn erf(x: f64) -> f64 {
        let s = x.signum();
        let x = x.abs();
        let t = 1.0 / (1.0 + 0.3275911 * x);
        let y = 1.0
            - (((((1.061405429 * t - 1.453152027) * t) + 1.421413741) * t - 0.284496736) * t
                + 0.254829592)
                * t
                * (-x * x).exp();
        s * y
    }

    fn phi(x: f64) -> f64 {
        0.5 * (1.0 + erf(x / std::f64::consts::SQRT_2))
    }

    fn add_star(img: &mut [f64], w: usize, h: usize, x: f64, y: f64, amp: f64) {
        let r = (PSF * (2.0 * (amp / 0.1).max(1.0).ln()).sqrt()).ceil() as i64 + 1;
        for yy in (y as i64 - r).max(0)..=(y as i64 + r).min(h as i64 - 1) {
            for xx in (x as i64 - r).max(0)..=(x as i64 + r).min(w as i64 - 1) {
                let d2 = (xx as f64 - x).powi(2) + (yy as f64 - y).powi(2);
                img[yy as usize * w + xx as usize] += amp * (-d2 / (2.0 * PSF * PSF)).exp();
            }
        }
    }

    /// A trail from (x0, y0) to (x1, y1): Gaussian cross-section of peak `amp`, erf ends.
    #[allow(clippy::too_many_arguments)]
    fn add_segment(
        img: &mut [f64],
        w: usize,
        h: usize,
        x0: f64,
        y0: f64,
        x1: f64,
        y1: f64,
        amp: f64,
    ) {
        let len = (x1 - x0).hypot(y1 - y0);
        let (ux, uy) = ((x1 - x0) / len, (y1 - y0) / len);
        let r = 6.0 * PSF;
        let xa = (x0.min(x1) - r).floor().max(0.0) as usize;
        let xb = (x0.max(x1) + r).ceil().min(w as f64 - 1.0).max(0.0) as usize;
        let ya = (y0.min(y1) - r).floor().max(0.0) as usize;
        let yb = (y0.max(y1) + r).ceil().min(h as f64 - 1.0).max(0.0) as usize;
        for y in ya..=yb {
            for x in xa..=xb {
                let (dx, dy) = (x as f64 - x0, y as f64 - y0);
                let t = dx * ux + dy * uy;
                let u = -dx * uy + dy * ux;
                if u.abs() > r || t < -r || t > len + r {
                    continue;
                }
                let along = phi(t / PSF) - phi((t - len) / PSF);
                img[y * w + x] += amp * (-u * u / (2.0 * PSF * PSF)).exp() * along;
            }
        }
    }

    /// The label box of the generator: all but 0.25 % of the flux on each side of each axis,
    /// whole pixels, in pixel-edge coordinates.
    fn truth_box(streak: &[f64], w: usize, h: usize) -> [f64; 4] {
        let mut mx = vec![0.0; w];
        let mut my = vec![0.0; h];
        for y in 0..h {
            for x in 0..w {
                mx[x] += streak[y * w + x];
                my[y] += streak[y * w + x];
            }
        }
        let range = |m: &[f64]| {
            let tot: f64 = m.iter().sum();
            let cut = 0.0025 * tot;
            let mut acc = 0.0;
            let mut lo = 0;
            for (i, &v) in m.iter().enumerate() {
                acc += v;
                if acc > cut {
                    lo = i;
                    break;
                }
            }
            acc = 0.0;
            let mut hi = m.len() - 1;
            for (i, &v) in m.iter().enumerate().rev() {
                acc += v;
                if acc > cut {
                    hi = i;
                    break;
                }
            }
            (lo as f64, hi as f64 + 1.0)
        };
        let (x1, x2) = range(&mx);
        let (y1, y2) = range(&my);
        [x1, y1, x2, y2]
    }

    fn iou(a: &[f64; 4], d: &Detection) -> f64 {
        let ix = (a[2].min(d.x2) - a[0].max(d.x1)).max(0.0);
        let iy = (a[3].min(d.y2) - a[1].max(d.y1)).max(0.0);
        let inter = ix * iy;
        let ua = (a[2] - a[0]) * (a[3] - a[1]) + (d.x2 - d.x1) * (d.y2 - d.y1) - inter;
        if ua > 0.0 { inter / ua } else { 0.0 }
    }

    fn quantise(img: &[f64], rng: &mut ChaCha8Rng) -> Vec<u8> {
        let n = Normal::new(0.0, NOISE).unwrap();
        img.iter()
            .map(|&v| (v + BG + n.sample(rng)).round().clamp(0.0, 255.0) as u8)
            .collect()
    }

    fn add_stars(img: &mut [f64], w: usize, h: usize, n: usize, rng: &mut ChaCha8Rng) {
        for _ in 0..n {
            let x = rng.random_range(0.0..w as f64);
            let y = rng.random_range(0.0..h as f64);
            let amp = NOISE * 10f64.powf(rng.random_range(-0.3..1.5));
            add_star(img, w, h, x, y, amp);
        }
    }

    struct Truth {
        boxx: [f64; 4],
        angle_deg: f64,
    }

    /// A 1024 x 1024 fixed-pointing image: stars, and one streak of `amp_sigma` noise sigmas
    /// per pixel (peak) fully inside the image when `amp_sigma > 0`.
    fn fixed_image(seed: u64, amp_sigma: f64) -> (Vec<u8>, Option<Truth>) {
        fixed_image_len(seed, amp_sigma, 40.0..600.0)
    }

    fn fixed_image_len(
        seed: u64,
        amp_sigma: f64,
        lens: std::ops::Range<f64>,
    ) -> (Vec<u8>, Option<Truth>) {
        let (w, h) = (1024, 1024);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut img = vec![0.0; w * h];
        let n_stars = rng.random_range(50..=300);
        add_stars(&mut img, w, h, n_stars, &mut rng);
        let mut truth = None;
        if amp_sigma > 0.0 {
            let len = rng.random_range(lens);
            let th = rng.random_range(0.0..PI);
            let (hx, hy) = (0.5 * len * th.cos(), 0.5 * len * th.sin());
            let m = 12.0;
            let cx = rng.random_range(hx.abs() + m..w as f64 - hx.abs() - m);
            let cy = rng.random_range(hy.abs() + m..h as f64 - hy.abs() - m);
            let mut s = vec![0.0; w * h];
            add_segment(
                &mut s,
                w,
                h,
                cx - hx,
                cy - hy,
                cx + hx,
                cy + hy,
                amp_sigma * NOISE,
            );
            truth = Some(Truth {
                boxx: truth_box(&s, w, h),
                angle_deg: th.to_degrees(),
            });
            img.iter_mut().zip(&s).for_each(|(a, b)| *a += b);
        }
        (quantise(&img, &mut rng), truth)
    }

    /// A survey-like image: `n` parallel star trails at `trail_deg` (lengths 60-200 px, various
    /// brightness) and one debris streak of `amp_sigma` at least 20 deg away from the trails.
    fn survey_image(
        seed: u64,
        size: usize,
        amp_sigma: f64,
        trail_deg: f64,
    ) -> (Vec<u8>, Option<Truth>) {
        let (w, h) = (size, size);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut img = vec![0.0; w * h];
        let n_trails = rng.random_range(50..=300);
        let tl = rng.random_range(60.0..200.0);
        let (tx, ty) = (trail_deg.to_radians().cos(), trail_deg.to_radians().sin());
        for _ in 0..n_trails {
            let x = rng.random_range(-tl..w as f64 + tl);
            let y = rng.random_range(-tl..h as f64 + tl);
            // Same photons spread along the trail: peak fainter than a point star.
            let amp = NOISE * 10f64.powf(rng.random_range(-0.5..1.2));
            add_segment(&mut img, w, h, x, y, x + tl * tx, y + tl * ty, amp);
        }
        let mut truth = None;
        if amp_sigma > 0.0 {
            let len = rng.random_range(40.0..600.0);
            let off = rng.random_range(20.0..160.0);
            let th = (trail_deg + off).to_radians();
            let (hx, hy) = (0.5 * len * th.cos(), 0.5 * len * th.sin());
            let m = 12.0;
            let cx = rng.random_range(hx.abs() + m..w as f64 - hx.abs() - m);
            let cy = rng.random_range(hy.abs() + m..h as f64 - hy.abs() - m);
            let mut s = vec![0.0; w * h];
            add_segment(
                &mut s,
                w,
                h,
                cx - hx,
                cy - hy,
                cx + hx,
                cy + hy,
                amp_sigma * NOISE,
            );
            truth = Some(Truth {
                boxx: truth_box(&s, w, h),
                angle_deg: th.to_degrees().rem_euclid(180.0),
            });
            img.iter_mut().zip(&s).for_each(|(a, b)| *a += b);
        }
        (quantise(&img, &mut rng), truth)
    }

    #[derive(Default, Debug)]
    struct BinStats {
        images: usize,
        detected: usize,
        false_pos: usize,
        ious: Vec<f64>,
        angle_err: Vec<f64>,
        /// Scores of the matched detections and of the false positives.
        tp_scores: Vec<f64>,
        fp_scores: Vec<f64>,
    }

    impl BinStats {
        fn rate(&self) -> f64 {
            self.detected as f64 / self.images.max(1) as f64
        }
        fn fp_per_image(&self) -> f64 {
            self.false_pos as f64 / self.images.max(1) as f64
        }
        fn iou_at_least(&self, v: f64) -> f64 {
            self.ious.iter().filter(|&&x| x >= v).count() as f64 / self.ious.len().max(1) as f64
        }
    }

    fn test_params() -> StreakParams {
        let mut p = StreakParams::default();
        if let Some(v) = std::env::var("STREAK_MIN_SNR")
            .ok()
            .and_then(|v| v.parse().ok())
        {
            p.min_snr = v;
        }
        p
    }

    /// Runs the detector and scores it against the truth: a match is the first candidate with
    /// IoU >= 0.5; a candidate with IoU < 0.1 is a false positive.
    fn evaluate(
        pix: &[u8],
        (w, h): (usize, usize),
        truth: Option<&Truth>,
        trail: Option<f64>,
        st: &mut BinStats,
    ) -> Vec<Candidate> {
        let c = detect_streaks(pix, w, h, &test_params(), trail);
        st.images += 1;
        let mut matched = false;
        for cand in &c {
            let io = truth.map(|t| iou(&t.boxx, &cand.detection)).unwrap_or(0.0);
            if io >= 0.5 && !matched {
                matched = true;
                st.detected += 1;
                st.ious.push(io);
                st.tp_scores.push(cand.detection.score);
                let t = truth.unwrap();
                st.angle_err
                    .push(angle_diff_deg(cand.orientation_deg, t.angle_deg));
            } else if io < 0.1 {
                st.false_pos += 1;
                st.fp_scores.push(cand.detection.score);
            }
        }
        c
    }

    fn run_bin(amp: f64, n: usize, seed0: u64, lens: std::ops::Range<f64>) -> BinStats {
        let mut st = BinStats::default();
        for k in 0..n {
            let (pix, truth) = fixed_image_len(seed0 + k as u64, amp, lens.clone());
            evaluate(&pix, (1024, 1024), truth.as_ref(), None, &mut st);
        }
        st
    }

    fn quantile(v: &[f64], q: f64) -> f64 {
        if v.is_empty() {
            return f64::NAN;
        }
        let mut s = v.to_vec();
        s.sort_by(|a, b| a.total_cmp(b));
        s[((s.len() - 1) as f64 * q).round() as usize]
    }

    fn check_boxes(c: &[Candidate], w: usize, h: usize) {
        for cand in c {
            let d = &cand.detection;
            assert!(0.0 <= d.x1 && d.x1 < d.x2 && d.x2 <= w as f64, "{d:?}");
            assert!(0.0 <= d.y1 && d.y1 < d.y2 && d.y2 <= h as f64, "{d:?}");
            assert!((0.0..1.0).contains(&d.score), "{d:?}");
            assert!((0.0..180.0).contains(&cand.orientation_deg), "{cand:?}");
            assert!(
                cand.length_px >= StreakParams::default().min_length_px,
                "{cand:?}"
            );
        }
    }

    #[test]
    fn detects_streaks_of_two_sigma_and_more() {
        let mut all = BinStats::default();
        for (i, amp) in [2.0, 3.0].into_iter().enumerate() {
            let st = run_bin(amp, 12, 100 + 100 * i as u64, 40.0..600.0);
            println!(
                "amp {amp}: rate {:.2}, fp/img {:.2}, IoU p10 {:.2}, angle error p90 {:.2} deg",
                st.rate(),
                st.fp_per_image(),
                quantile(&st.ious, 0.1),
                quantile(&st.angle_err, 0.9)
            );
            all.images += st.images;
            all.detected += st.detected;
            all.false_pos += st.false_pos;
            all.ious.extend(st.ious);
            all.angle_err.extend(st.angle_err);
        }
        assert!(all.rate() >= 0.95, "{all:?}");
        assert!(all.iou_at_least(0.7) >= 0.9, "{all:?}");
        assert!(quantile(&all.angle_err, 0.5) < 1.0, "{all:?}");
        assert!(all.fp_per_image() <= 0.25, "{all:?}");
    }

    #[test]
    fn detects_most_one_sigma_streaks() {
        let st = run_bin(1.0, 10, 300, 40.0..600.0);
        println!("amp 1: {st:?}");
        assert!(st.rate() >= 0.8, "{st:?}");
    }

    #[test]
    fn few_false_positives_on_star_fields() {
        let mut st = BinStats::default();
        for k in 0..12 {
            let (pix, _) = fixed_image(900 + k, 0.0);
            let c = evaluate(&pix, (1024, 1024), None, None, &mut st);
            check_boxes(&c, 1024, 1024);
        }
        println!("star fields: {st:?}");
        assert!(st.false_pos <= 2, "{st:?}");
        assert!(st.fp_scores.iter().all(|&s| s < 0.5), "{st:?}");
    }

    #[test]
    fn streak_crossing_the_border() {
        let (w, h) = (1024usize, 1024usize);
        // Start inside, run 250 px out through each edge and a corner.
        let cases = [
            (100.0, 500.0, 200.0f64),
            (900.0, 400.0, 20.0),
            (500.0, 120.0, 250.0),
            (300.0, 900.0, 80.0),
            (880.0, 880.0, 45.0),
        ];
        for (k, &(x0, y0, deg)) in cases.iter().enumerate() {
            let mut rng = ChaCha8Rng::seed_from_u64(50 + k as u64);
            let mut img = vec![0.0; w * h];
            add_stars(&mut img, w, h, 150, &mut rng);
            let th = deg.to_radians();
            let (x1, y1) = (x0 + 250.0 * th.cos(), y0 + 250.0 * th.sin());
            let mut s = vec![0.0; w * h];
            add_segment(&mut s, w, h, x0, y0, x1, y1, 2.0 * NOISE);
            let truth = truth_box(&s, w, h);
            img.iter_mut().zip(&s).for_each(|(a, b)| *a += b);
            let pix = quantise(&img, &mut rng);
            let c = detect_streaks(&pix, w, h, &StreakParams::default(), None);
            check_boxes(&c, w, h);
            let best = c
                .iter()
                .map(|c| (iou(&truth, &c.detection), c))
                .max_by(|a, b| a.0.total_cmp(&b.0))
                .unwrap_or_else(|| panic!("case {k}: nothing found"));
            println!("case {k}: truth {truth:?} IoU {:.2} {:?}", best.0, best.1);
            assert!(best.0 >= 0.7, "case {k}: {best:?}");
            let d = &best.1.detection;
            let touches =
                d.x1 <= 1.0 || d.y1 <= 1.0 || d.x2 >= w as f64 - 1.0 || d.y2 >= h as f64 - 1.0;
            assert!(touches, "case {k}: the box should reach the edge: {d:?}");
        }
    }

    #[test]
    fn survey_trails_rejected_and_debris_found() {
        let mut st = BinStats::default();
        for (k, trail) in [0.0, 30.0, 77.0, 135.0].into_iter().enumerate() {
            let (pix, truth) = survey_image(700 + k as u64, 1472, 2.0, trail);
            let c = evaluate(&pix, (1472, 1472), truth.as_ref(), Some(trail), &mut st);
            check_boxes(&c, 1472, 1472);
            let tol = StreakParams::default().star_trail_tolerance_deg;
            for cand in &c {
                assert!(
                    angle_diff_deg(cand.orientation_deg, trail) > tol,
                    "{cand:?}"
                );
            }
        }
        println!("survey: {st:?}");
        assert_eq!(st.detected, 4, "{st:?}");
        assert!(st.iou_at_least(0.7) >= 0.75, "{st:?}");
        assert!(st.false_pos <= 1, "{st:?}");
        // Without the trail direction the trails themselves come out as streaks.
        let (pix, _) = survey_image(700, 1472, 2.0, 0.0);
        let c = detect_streaks(&pix, 1472, 1472, &StreakParams::default(), None);
        let trails = c
            .iter()
            .filter(|c| angle_diff_deg(c.orientation_deg, 0.0) < 3.0)
            .count();
        assert!(trails >= 3, "{c:?}");
    }

    #[test]
    fn constant_and_empty_images() {
        let p = StreakParams::default();
        for v in [0u8, 100, 255] {
            assert!(detect_streaks(&vec![v; 1024 * 1024], 1024, 1024, &p, None).is_empty());
            assert!(detect_streaks(&vec![v; 300 * 200], 300, 200, &p, Some(10.0)).is_empty());
        }
        assert!(detect_streaks(&[], 0, 0, &p, None).is_empty());
        assert!(detect_streaks(&[], 0, 7, &p, None).is_empty());
        assert!(detect_streaks(&[9; 7], 7, 1, &p, None).is_empty());
        // Noise-free: a lone streak on a flat background is still found.
        let (w, h) = (400, 300);
        let mut s = vec![0.0; w * h];
        add_segment(&mut s, w, h, 50.0, 60.0, 300.0, 200.0, 40.0);
        let pix: Vec<u8> = s.iter().map(|v| (BG + v).round() as u8).collect();
        let c = detect_streaks(&pix, w, h, &p, None);
        assert_eq!(c.len(), 1, "{c:?}");
        assert!(iou(&truth_box(&s, w, h), &c[0].detection) >= 0.8, "{c:?}");
    }

    #[test]
    #[should_panic(expected = "width * height")]
    fn wrong_buffer_size_panics() {
        detect_streaks(&[0; 10], 4, 4, &StreakParams::default(), None);
    }

    #[test]
    fn tiny_images() {
        let p = StreakParams::default();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for (w, h) in [(1, 1), (2, 2), (3, 7), (16, 16), (40, 30), (63, 5)] {
            let img = vec![0.0; w * h];
            let pix = quantise(&img, &mut rng);
            let c = detect_streaks(&pix, w, h, &p, None);
            check_boxes(&c, w, h);
            assert!(c.is_empty(), "{w}x{h}: {c:?}");
        }
        // Smaller than one mesh cell, with a bright streak.
        let (w, h) = (60, 48);
        let mut s = vec![0.0; w * h];
        add_segment(&mut s, w, h, 8.0, 20.0, 50.0, 30.0, 4.0 * NOISE);
        let pix = quantise(&s, &mut rng);
        let c = detect_streaks(&pix, w, h, &p, None);
        check_boxes(&c, w, h);
        assert_eq!(c.len(), 1, "{c:?}");
        assert!(iou(&truth_box(&s, w, h), &c[0].detection) >= 0.7, "{c:?}");
    }

    #[test]
    fn non_square_image_and_odd_params() {
        let (w, h) = (700usize, 400usize);
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut img = vec![0.0; w * h];
        add_stars(&mut img, w, h, 80, &mut rng);
        let mut s = vec![0.0; w * h];
        add_segment(&mut s, w, h, 100.0, 300.0, 500.0, 120.0, 2.0 * NOISE);
        let truth = truth_box(&s, w, h);
        img.iter_mut().zip(&s).for_each(|(a, b)| *a += b);
        let pix = quantise(&img, &mut rng);
        let c = detect_streaks(&pix, w, h, &StreakParams::default(), None);
        check_boxes(&c, w, h);
        assert_eq!(c.len(), 1, "{c:?}");
        assert!(iou(&truth, &c[0].detection) >= 0.8, "{c:?}");
        let deg = (-180.0f64).atan2(400.0).to_degrees().rem_euclid(180.0);
        assert!(angle_diff_deg(c[0].orientation_deg, deg) < 1.0, "{c:?}");
        // Degenerate knobs are tolerated.
        let odd = StreakParams {
            n_angles: 0,
            line_lengths_px: vec![],
            mesh_size: 0,
            psf_sigma_px: f64::NAN,
            max_candidates: 0,
            ..StreakParams::default()
        };
        assert!(detect_streaks(&pix, w, h, &odd, Some(f64::NAN)).is_empty());
        let one = StreakParams {
            max_candidates: 1,
            ..StreakParams::default()
        };
        assert_eq!(detect_streaks(&pix, w, h, &one, None).len(), 1);
    }

    #[test]
    fn deterministic() {
        let (pix, _) = fixed_image(4242, 1.5);
        let p = StreakParams::default();
        let a = detect_streaks(&pix, 1024, 1024, &p, None);
        let b = detect_streaks(&pix, 1024, 1024, &p, None);
        assert!(!a.is_empty());
        assert_eq!(a, b);
        let (pix, _) = survey_image(4243, 1024, 1.5, 30.0);
        let a = detect_streaks(&pix, 1024, 1024, &p, Some(30.0));
        let b = detect_streaks(&pix, 1024, 1024, &p, Some(30.0));
        assert_eq!(a, b);
    }

    #[test]
    fn score_is_monotone_and_bounded() {
        let p = Sanitized::new(&StreakParams::default());
        let mut prev = -1.0;
        for i in 0..200 {
            let snr = i as f64 * 0.5;
            let s = score(snr, 8.0, &p);
            assert!((0.0..1.0).contains(&s) && s >= prev);
            prev = s;
        }
        let mut prev = -1.0;
        for i in 0..200 {
            let s = score(12.0, 1.0 + i as f64 * 0.25, &p);
            assert!((0.0..1.0).contains(&s) && s >= prev);
            prev = s;
        }
        assert_eq!(score(0.0, 10.0, &p), 0.0);
        assert_eq!(score(10.0, 1.0, &p), 0.0);
    }

    #[test]
    fn side_means_remove_a_full_trail() {
        let (rows, m, hk) = (200, 3, 20);
        let mut src = vec![0f32; rows * m];
        for i in 0..rows {
            src[i * m + 1] = 50.0;
        }
        subtract_side_means(&mut src, rows, m, 0.0, hk, 1.5);
        let col: Vec<f32> = (0..rows).map(|i| src[i * m + 1]).collect();
        assert!(col.iter().all(|v| v.abs() < 1e-3), "{col:?}");
        // A finite diagonal trail (slope -1) in a 120 x 120 map.
        let (rows, m) = (120, 120);
        let mut src = vec![0f32; rows * m];
        for i in 20..100 {
            src[i * m + (110 - i)] = 50.0;
        }
        subtract_side_means(&mut src, rows, m, -1.0, hk, 1.5);
        let on: Vec<f32> = (20..100).map(|i| src[i * m + (110 - i)]).collect();
        // Removed wherever a full window fits on one side (trail of 80 px, windows of 41).
        assert!(on.iter().all(|v| v.abs() < 2.0), "{on:?}");
        assert!(
            on[..38].iter().chain(&on[42..]).all(|v| v.abs() < 1e-3),
            "{on:?}"
        );
    }

    /// The figures of the report: `cargo test --release --lib report -- --ignored --nocapture`
    /// (`STREAK_N` images per bin, default 40; `STREAK_LEN=lo,hi` streak lengths).
    #[test]
    #[ignore]
    fn report_detection_rate() {
        let n: usize = std::env::var("STREAK_N")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(40);
        let (lo, hi): (f64, f64) = match std::env::var("STREAK_LEN") {
            Ok(v) => {
                let mut it = v.split(',').map(|x| x.parse().unwrap());
                (it.next().unwrap(), it.next().unwrap())
            }
            Err(_) => (40.0, 600.0),
        };
        println!("fixed pointing 1024 px, streak lengths {lo}..{hi} px, {n} images per bin");
        println!("amp/sigma  rate  rate@score0.5  fp/img  IoU>=0.7  IoU_p10  IoU_med  ang_err_p90");
        for (i, &amp) in [0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0].iter().enumerate() {
            let st = run_bin(amp, n, 1000 * (i as u64 + 1), lo..hi);
            println!(
                "{amp:9.2} {:5.2} {:14.2} {:7.2} {:9.2} {:8.2} {:8.2} {:12.2}",
                st.rate(),
                st.tp_scores.iter().filter(|&&s| s >= 0.5).count() as f64 / st.images as f64,
                st.fp_per_image(),
                st.iou_at_least(0.7),
                quantile(&st.ious, 0.1),
                quantile(&st.ious, 0.5),
                quantile(&st.angle_err, 0.9),
            );
        }
        let mut st = BinStats::default();
        for k in 0..n {
            let (pix, _) = fixed_image(90_000 + k as u64, 0.0);
            evaluate(&pix, (1024, 1024), None, None, &mut st);
        }
        println!(
            "star-only: fp/img {:.3} (score >= 0.5: {:.3})",
            st.fp_per_image(),
            st.fp_scores.iter().filter(|&&s| s >= 0.5).count() as f64 / st.images as f64
        );
        for &amp in &[1.0, 2.0, 3.0] {
            let mut st = BinStats::default();
            for k in 0..n {
                let trail = [0.0, 30.0, 77.0, 135.0][k % 4];
                let (pix, truth) = survey_image(70_000 + k as u64, 1472, amp, trail);
                evaluate(&pix, (1472, 1472), truth.as_ref(), Some(trail), &mut st);
            }
            println!(
                "survey 1472 px amp {amp}: rate {:.2} fp/img {:.3} IoU>=0.7 {:.2} IoU_p10 {:.2}",
                st.rate(),
                st.fp_per_image(),
                st.iou_at_least(0.7),
                quantile(&st.ious, 0.1),
            );
        }
    }

    /// CPU time of this thread, seconds (Linux; 10 ms ticks), for timings on a busy machine.
    fn thread_cpu_s() -> f64 {
        let st = std::fs::read_to_string("/proc/thread-self/stat").unwrap_or_default();
        let rest = st.rsplit(')').next().unwrap_or("");
        let f: Vec<&str> = rest.split_whitespace().collect();
        let tick = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
        (tick(11) + tick(12)) / 100.0
    }

    /// `cargo test --release --lib timing -- --ignored --nocapture`
    #[test]
    #[ignore]
    fn timing() {
        let p = StreakParams::default();
        for (size, survey) in [(1024usize, false), (1472, true)] {
            let imgs: Vec<Vec<u8>> = (0..4)
                .map(|k| {
                    if survey {
                        survey_image(6000 + k, size, 2.0, 0.0).0
                    } else {
                        fixed_image(5000 + k, 2.0).0
                    }
                })
                .collect();
            let trail = survey.then_some(0.0);
            let _ = detect_streaks(&imgs[0], size, size, &p, trail);
            let reps = if survey { 3 } else { 6 };
            let (t0, c0) = (std::time::Instant::now(), thread_cpu_s());
            for _ in 0..reps {
                for im in &imgs {
                    std::hint::black_box(detect_streaks(im, size, size, &p, trail));
                }
            }
            let n = (reps * imgs.len()) as f64;
            println!(
                "{size}x{size}{}: {:.1} ms wall, {:.1} ms CPU per image",
                if survey { " survey" } else { "" },
                t0.elapsed().as_secs_f64() / n * 1e3,
                (thread_cpu_s() - c0) / n * 1e3
            );
        }
    }
}
