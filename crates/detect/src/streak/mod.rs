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
//!    unit noise, less its median where that is above zero (a sensor's hot pixels skew it). Survey images (trail direction given): structures along the trail direction
//!    are subtracted (one-sided means over `trail_filter_px` pixels along it, see
//!    `remove_trails`). Stars are masked: round local maxima of `z` above `star_mask_sigma`
//!    (ring test, `star_ring_ratio`) are zeroed out to where they fade into the noise. A copy
//!    clipped to `[-clip_sigma, clip_sigma]` limits the weight of what remains bright.
//! 3. **Oriented line filter.** For `n_angles` orientations in [0, 180) and each length in
//!    `line_lengths_px`, the clipped `z` is summed along a digital straight line of that length
//!    centred on every pixel (running sums over rows of the image or of its transpose, O(1) per
//!    pixel and filter, contiguous memory). Each sum is divided by its noise standard deviation
//!    (white pixel noise smoothed by the Gaussian, exact for the digital line), so every filter
//!    output is in sigma; beyond the image counts as zero (conservative near the edges). The
//!    clipped map is first made zero-mean, and each filter's sigma is the larger of the
//!    white-noise value and the one measured on the image (`noise`: real sensors' noise is
//!    correlated and skewed). Per
//!    pixel the maximum over filters and its orientation are kept.
//!    3b. **Long lines** (`radon`): the same filter on the clipped map binned by 2, 4 and 8, so
//!    that a sum covers 100-400 pixels and a streak too faint per pixel for step 3 but long
//!    enough (integrated SNR grows as the square root of its length) still gives a component.
//! 4. **Components.** Pixels with response >= `threshold_sigma` are joined by 8-connectivity,
//!    but only between pixels whose best orientations differ by at most `angle_link_bins`
//!    steps, so that a streak crossing a star trail splits instead of merging with it.
//!    A component is kept if it has `min_pixels` pixels and a peak >= `seed_sigma`; its
//!    centroid and second moments give an axis and extent.
//! 5. **Refinement.** Around each component axis the orientation and lateral offset are refined
//!    by a coarse-to-fine grid search (+-2 filter steps, then finer) maximising `z` clipped at
//!    4 `clip_sigma` summed along the axis. Then the profile `p(t)` along the axis (mean of `z`
//!    at lateral offsets -1, 0, 1 px less that of side bands beyond the cross-section, zero on
//!    background however skewed its noise; survey images' step-3 seeds: without the side
//!    bands, which parallel star trails would fill) is read, the streak level is the median of `p` in the
//!    component's inner part, and each end is the change point maximising the cumulative sum
//!    of `min(p, 1.5 level) - level / 2` outwards (the half-level crossing, robust to noise
//!    dips). Measured on the refined segment: length between the ends; SNR = median over the
//!    segment of the contrast (`p` less the mean of side bands beyond the cross-section, so a
//!    raised patch of background is no streak) times its sample count, divided by the noise
//!    standard deviation of that sum (white-noise model times the measured excess of step 3;
//!    the median keeps a bright star on the axis from making a streak); flux = sum of background-subtracted grey levels within `3 psf_sigma_px` of the
//!    segment; elongation = sqrt(l1 / l2) of the second moments of the pixels within
//!    `3 psf_sigma_px` of the segment weighted by `z` clipped to `[0, clip_sigma]` (a streak of
//!    length L: about L / (sqrt(12) 2.5); a star: about 1).
//! 6. **Rejection and merging.** Fragments aligned with the star-trail direction (when given,
//!    within `star_trail_tolerance_deg` + atan(4 psf_sigma / length)) or shorter than
//!    `min_fragment_px` are dropped; collinear fragments (angle within `merge_angle_deg`,
//!    lateral offsets within `merge_offset_px`, gap along the axis within `merge_gap_px`) are
//!    merged and re-refined until none merge. Candidates need length >= `min_length_px`,
//!    elongation >= `min_elongation` and SNR >= `min_snr`; the trail test is applied again;
//!    and no gap: no chunk of the profile far below its level (a chain of stars, `merge::gap`).
//!    Every segment dropped, and why, is recorded (`explain`, `soig detect --explain`).
//!    Explaining away, best score first: the profile samples of a candidate within
//!    `duplicate_distance_px` of a better candidate are ignored and the rest must still pass
//!    the length and SNR tests (drops duplicates and the off-axis echoes of bright streaks).
//! 7. **Output.** Confidence (monotone increasing in SNR and in elongation, in [0, 1]): the
//!    probability that noise alone gives no candidate that significant in an image this size,
//!    under a Gumbel model calibrated by `confidence_snr` and `confidence_snr_scale`, times
//!    `1 - exp(-(elongation - 1) / confidence_elongation_scale)` (see `output::confidence`).
//!    Box (`fit`): the streak fitted on the refined axis (centre line and brightness piece by
//!    piece, each end where the centre-line profile crosses the level seen half a PSF width
//!    beside the line, which the 8-bit stretch does not move), rendered through a Gaussian PSF
//!    of `psf_sigma_px` by the renderer's code and boxed by the label's rule (the box holding
//!    99 % of the flux, `geometry::flux_box`); where no fit is possible, the refined segment
//!    padded by `box_pad_along_sigma * psf_sigma_px` along the axis and
//!    `box_pad_across_sigma * psf_sigma_px` across it. In the star-aware pass each kept streak
//!    is first followed beyond its ends across the trails that hide it (`reach`). In
//!    pixel-edge coordinates (pixel `i` spans `[i, i + 1]`), clipped to the image. Candidates are sorted by decreasing score, at most
//!    `max_candidates`.
//!
//! Orientations (the output `orientation_deg` and the input `star_trail_angle_deg`) are in
//! image axes: degrees from the +x axis (columns, rightwards) towards +y (rows, downwards),
//! modulo 180, reported in [0, 180).
//!
//! Everything is single-threaded and deterministic: the same input gives the same output.
//!
//! One submodule per step: `background` (1), `smooth`, `trails` and `stars` (2), `lines` (3),
//! `radon` (3b), `components` (4), `refine` and `merge` (5-6), `output`, `fit` and `reach` (7);
//! `stats` holds the robust statistics they share (bilinear sampling is
//! [`soig_image::imaging::bilinear`]). This file holds the parameters and the pipeline.

mod background;
mod components;
mod explain;
mod fit;
mod lines;
mod merge;
mod noise;
mod output;
mod radon;
mod reach;
mod refine;
mod sky;
mod smooth;
mod stars;
mod stats;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_fit;
#[cfg(test)]
mod tests_sky;
mod trails;

use super::Detection;
use background::background;
use components::components;
pub use explain::{Dropped, Reason, Seeds};
use lines::line_filter;
use merge::angle_diff_deg;
use noise::LineNoise;
use output::confidence;
use radon::long_line_components;
use refine::{Ctx, Point, Seed, Seg};
pub use sky::StarTrail;
use smooth::{equalise_edge_noise, gaussian_kernel, smooth};
use stars::mask_stars;
use stats::map_stats;
use trails::remove_trails;

/// Every knob of [`detect_streaks`], with its default: all settable from a campaign's
/// `[detect.streak]` table, each field optional (falls back to [`StreakParams::default`], the
/// one place for the defaults). [`StreakParams::check`] says which values are allowed.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize, schemars::JsonSchema, PartialEq)]
#[serde(default, deny_unknown_fields)]
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
    /// Box padding along the streak axis beyond the ends, in PSF sigmas, of a streak that
    /// cannot be fitted (default 1.0; fitted streaks are boxed by the label's rule).
    pub box_pad_along_sigma: f64,
    /// Box padding across the streak axis, in PSF sigmas, of a streak that cannot be fitted
    /// (default 3.0).
    pub box_pad_across_sigma: f64,
    /// The SNR at which a 1024 x 1024 image's candidate has confidence 0.5: where noise alone
    /// gives a candidate that strong in half of such images (default 9.0).
    pub confidence_snr: f64,
    /// Each step of this much SNR above `confidence_snr` divides the expected number of noise
    /// candidates that strong by e (default 1.0).
    pub confidence_snr_scale: f64,
    /// Elongation scale of the confidence's shape factor `1 - exp(-(elongation - 1) / this)`
    /// (default 3.0).
    pub confidence_elongation_scale: f64,
    /// Calibrate the line filter on the image's own noise (default true): the clipped map made
    /// zero-mean and each filter's noise measured on the image, used where it exceeds the
    /// white-noise model (see `noise`). A frame crowded with real star trails (a raw NEOSSat
    /// frame taken while slewing) raises both so far that its own bright streak no longer
    /// stands out: there, `false` keeps the zero-median map and the white-noise model.
    pub calibrate_noise: bool,
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
            confidence_snr: 9.0,
            confidence_snr_scale: 1.0,
            confidence_elongation_scale: 3.0,
            calibrate_noise: true,
            class: 0,
            max_candidates: 16,
        }
    }
}

impl StreakParams {
    /// Whether every knob is [`StreakParams::default`] (a campaign then leaves `[detect.streak]`
    /// out of its resolved form, so its hash does not change).
    pub fn is_default(&self) -> bool {
        *self == StreakParams::default()
    }

    /// Checks every knob's range: the first one outside it, as (field, what is allowed).
    /// [`detect_streaks`] itself clamps out-of-range values to something it can run; a campaign
    /// must instead run what it says, so it refuses them.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        let at_least = |v: f64, lo: f64| v.is_finite() && v >= lo;
        let within = |v: f64, lo: f64, hi: f64| v.is_finite() && (lo..=hi).contains(&v);
        let fin = |v: f64| v.is_finite();
        let nonneg = "must be a finite number >= 0";
        let checks = [
            (
                "mesh_size",
                self.mesh_size >= 8,
                "must be at least 8 pixels",
            ),
            (
                "mesh_clip_sigma",
                at_least(self.mesh_clip_sigma, 1.0),
                "must be a finite number >= 1",
            ),
            (
                "min_noise_sigma",
                at_least(self.min_noise_sigma, 1e-3),
                "must be a finite number >= 0.001",
            ),
            (
                "psf_sigma_px",
                within(self.psf_sigma_px, 0.3, 20.0),
                "must be between 0.3 and 20 pixels",
            ),
            (
                "clip_sigma",
                at_least(self.clip_sigma, 0.5),
                "must be a finite number >= 0.5",
            ),
            (
                "star_mask_sigma",
                at_least(self.star_mask_sigma, 1.0),
                "must be a finite number >= 1",
            ),
            (
                "star_ring_ratio",
                within(self.star_ring_ratio, 0.0, 1.0),
                "must be in [0, 1]",
            ),
            (
                "n_angles",
                (4..=180).contains(&self.n_angles),
                "must be between 4 and 180",
            ),
            (
                "line_lengths_px",
                !self.line_lengths_px.is_empty()
                    && self.line_lengths_px.iter().all(|k| (3..=4001).contains(k)),
                "give at least one length, each between 3 and 4001 pixels",
            ),
            (
                "threshold_sigma",
                fin(self.threshold_sigma),
                "must be a finite number",
            ),
            (
                "seed_sigma",
                fin(self.seed_sigma),
                "must be a finite number",
            ),
            ("min_pixels", self.min_pixels >= 1, "must be >= 1"),
            (
                "min_fragment_px",
                at_least(self.min_fragment_px, 0.0),
                nonneg,
            ),
            ("min_length_px", at_least(self.min_length_px, 0.0), nonneg),
            ("min_elongation", at_least(self.min_elongation, 0.0), nonneg),
            ("min_snr", at_least(self.min_snr, 0.0), nonneg),
            (
                "star_trail_tolerance_deg",
                within(self.star_trail_tolerance_deg, 0.0, 90.0),
                "must be between 0 and 90 degrees",
            ),
            (
                "trail_filter_px",
                self.trail_filter_px <= 4001,
                "must be at most 4001 pixels (0 turns it off)",
            ),
            (
                "merge_angle_deg",
                within(self.merge_angle_deg, 0.0, 90.0),
                "must be between 0 and 90 degrees",
            ),
            (
                "merge_offset_px",
                at_least(self.merge_offset_px, 0.0),
                nonneg,
            ),
            ("merge_gap_px", at_least(self.merge_gap_px, 0.0), nonneg),
            (
                "duplicate_distance_px",
                at_least(self.duplicate_distance_px, 0.0),
                nonneg,
            ),
            (
                "box_pad_along_sigma",
                at_least(self.box_pad_along_sigma, 0.0),
                nonneg,
            ),
            (
                "box_pad_across_sigma",
                at_least(self.box_pad_across_sigma, 0.0),
                nonneg,
            ),
            (
                "confidence_snr",
                fin(self.confidence_snr),
                "must be a finite number",
            ),
            (
                "confidence_snr_scale",
                fin(self.confidence_snr_scale) && self.confidence_snr_scale > 0.0,
                "must be a positive finite number",
            ),
            (
                "confidence_elongation_scale",
                fin(self.confidence_elongation_scale) && self.confidence_elongation_scale > 0.0,
                "must be a positive finite number",
            ),
            ("max_candidates", self.max_candidates >= 1, "must be >= 1"),
        ];
        match checks.into_iter().find(|c| !c.1) {
            Some((field, _, msg)) => Err((field, msg.to_string())),
            None => Ok(()),
        }
    }
}

/// One detected streak.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Candidate {
    /// Box (pixel-edge coordinates), score in [0, 1) and class.
    pub detection: Detection,
    /// The half-level ends of the streak, in the box's pixel-edge coordinates (pixel `i` spans
    /// `[i, i + 1]`, so a pixel centre is at `i + 0.5`), not clipped to the image.
    pub ends: [[f64; 2]; 2],
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
    detect(pixels, width, height, params, star_trail_angle_deg).0
}

/// [`detect_streaks`], and every refined segment that did not become a candidate, with why
/// (`soig detect --explain`).
pub fn detect_streaks_explained(
    pixels: &[u8],
    width: usize,
    height: usize,
    params: &StreakParams,
    star_trail_angle_deg: Option<f64>,
) -> (Vec<Candidate>, Vec<Dropped>) {
    detect(pixels, width, height, params, star_trail_angle_deg)
}

/// [`detect_streaks`] knowing the catalogued stars' predicted trails in the image (`stars`,
/// see [`StarTrail`]). [`detect_streaks`] subtracts everything along `star_trail_angle_deg`
/// and drops every candidate within `star_trail_tolerance_deg` of it, which loses debris
/// moving nearly with the stars. A second pass keeps the trails (no subtraction), masks the
/// predicted ones where they show (subtracts each one's median cross-section) and drops a
/// candidate only where they explain it (module `sky`); of it, the candidates the first pass
/// could not have given (aligned with the trails), and those a little beyond that the first
/// pass did not find, join the first pass's. The first pass stays, because a trail that is not
/// subtracted splits a bright streak crossing it into fragments that do not always join
/// again. `None`, or no trail direction: as [`detect_streaks`].
pub fn detect_streaks_among_stars(
    pixels: &[u8],
    width: usize,
    height: usize,
    params: &StreakParams,
    star_trail_angle_deg: Option<f64>,
    stars: Option<&[StarTrail]>,
) -> Vec<Candidate> {
    let trail = star_trail_angle_deg.filter(|a| a.is_finite());
    let (Some(stars), Some(trail)) = (stars, trail) else {
        return detect(pixels, width, height, params, star_trail_angle_deg).0;
    };
    assert_eq!(
        pixels.len(),
        width * height,
        "pixels.len() must be width * height"
    );
    if width < 2 || height < 2 {
        return Vec::new();
    }
    let p = Sanitized::new(params);
    // Both passes start from the same background and unit-noise map.
    let (bg, z) = unit_noise_map(pixels, width, height, &p);
    let mut found = detect_on(
        pixels,
        width,
        height,
        &p,
        bg.clone(),
        z.clone(),
        Some(trail),
        None,
    )
    .0;
    // The second pass finds what the first cannot, along the trails, so it searches only there.
    let along = Sanitized {
        along: Some(trail),
        ..p.clone()
    };
    let second = detect_on(
        pixels,
        width,
        height,
        &along,
        bg,
        z,
        Some(trail),
        Some(stars),
    )
    .0;
    let near_trail = |c: &Candidate| {
        let slack = (4.0 * p.psf_sigma / c.length_px.max(1.0))
            .atan()
            .to_degrees();
        angle_diff_deg(c.orientation_deg, trail) <= p.trail_tol + slack
    };
    // Beyond the tolerance the second pass adds the streaks the first missed, and replaces
    // the first's box of the same streak where it scores higher. The first pass's trail filter
    // (`trail_filter_px` along the trails) removes most of a line up to about 10 degrees off
    // them, which the tolerance (5 degrees plus slack) does not cover: 4 debris streaks at
    // 5.6-7 degrees, SNR 60-110, were lost on 200 rotated survey images; and 9 of 21 streaks
    // missed on the 400 of the rotated row, 7.1-9.8 degrees off, SNR 49-350, were boxed by the
    // first pass but scored 0.001-0.47 on what its filter had left of them.
    let (mut within, beyond): (Vec<Candidate>, Vec<Candidate>) =
        second.into_iter().partition(near_trail);
    for c in beyond {
        let same = |k: &Candidate| lies_along(&c, k, p.dup_dist) || lies_along(k, &c, p.dup_dist);
        match found.iter().position(same) {
            None => within.push(c),
            // The same streak, as long (a piece of it scoring higher does not replace the
            // whole: 3 debris boxes 11-18 degrees off fell to IoU 0.12-0.27 so).
            Some(i)
                if found[i].detection.score < c.detection.score
                    && c.length_px >= SAME_LENGTH * found[i].length_px
                    && lies_along(&found[i], &c, p.dup_dist) =>
            {
                found[i] = c
            }
            Some(_) => {}
        }
    }
    found.extend(within);
    // One streak, one box: a candidate lying mostly along a longer one (the same streak from
    // both passes, or a piece of it) is dropped, whatever its score.
    found.sort_by(|a, b| b.length_px.total_cmp(&a.length_px));
    let mut kept: Vec<Candidate> = Vec::new();
    for c in found {
        if !kept.iter().any(|k| lies_along(&c, k, p.dup_dist)) {
            kept.push(c);
        }
    }
    found = kept;
    found.sort_by(|a, b| b.detection.score.total_cmp(&a.detection.score));
    found.truncate(p.max_candidates);
    found
}

/// A second-pass box replaces the first pass's box of the same streak (beyond the trails'
/// tolerance) only if at least this long.
const SAME_LENGTH: f64 = 0.9;

/// Whether half of `c`'s axis lies within `dist` of `other`'s segment.
fn lies_along(c: &Candidate, other: &Candidate, dist: f64) -> bool {
    let [a, b] = c.ends;
    let (o0, o1) = (
        (other.ends[0][0], other.ends[0][1]),
        (other.ends[1][0], other.ends[1][1]),
    );
    let n = c.length_px.ceil().max(1.0) as usize;
    let near = (0..=n)
        .filter(|&k| {
            let f = k as f64 / n as f64;
            let q = (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]));
            refine::point_segment_distance(q, o0, o1) <= dist
        })
        .count();
    2 * near > n
}

/// The detector's pipeline, angle-only: the candidates and the segments dropped on the way,
/// with why.
fn detect(
    pixels: &[u8],
    width: usize,
    height: usize,
    params: &StreakParams,
    star_trail_angle_deg: Option<f64>,
) -> (Vec<Candidate>, Vec<Dropped>) {
    assert_eq!(
        pixels.len(),
        width * height,
        "pixels.len() must be width * height"
    );
    if width < 2 || height < 2 {
        return (Vec::new(), Vec::new());
    }
    let p = Sanitized::new(params);
    let (bg, z) = unit_noise_map(pixels, width, height, &p);
    detect_on(pixels, width, height, &p, bg, z, star_trail_angle_deg, None)
}

/// Steps 1-2 up to the trails: the background and the smoothed map in unit noise.
fn unit_noise_map(pixels: &[u8], w: usize, h: usize, p: &Sanitized) -> (Vec<f32>, Vec<f32>) {
    // 1. Background and noise.
    let (bg, sigma) = background(pixels, w, h, p);
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
    let (z_med, z_sd) = map_stats(&z, w, h);
    let kappa = z_sd.max(0.5 * kappa_white);
    let inv_kappa = (1.0 / kappa) as f32;
    // Centred on the map's own median where that is above zero. A real sensor's warm and hot
    // pixels skew its noise to the right, and smoothing moves the map's centre from the pixels'
    // median towards their mean: 2 sigma above zero on the raw 187 s NEOSSat frame, which left
    // a bright streak, clipped at `clip_sigma`, 2 sigma of headroom, no more than the warm
    // pixels around it, and it was lost. Synthetic maps sit a little below zero (-0.5 to -1.7
    // sigma), which leaves more headroom than `clip_sigma`; they stay as tuned (centring them too
    // raised their false boxes at confidence 0.5 from 63 to 100 in 100 fixed-pointing images).
    let centre = z_med.max(0.0) as f32;
    z.iter_mut().for_each(|v| *v = (*v - centre) * inv_kappa);
    (bg, z)
}

/// The pipeline from the unit-noise map `z` (and the background `bg`) of [`unit_noise_map`] on;
/// with `stars`, the star-aware variant of [`detect_streaks_among_stars`]' second pass.
#[allow(clippy::too_many_arguments)]
fn detect_on(
    pixels: &[u8],
    w: usize,
    h: usize,
    p: &Sanitized,
    bg: Vec<f32>,
    mut z: Vec<f32>,
    star_trail_angle_deg: Option<f64>,
    stars: Option<&[StarTrail]>,
) -> (Vec<Candidate>, Vec<Dropped>) {
    // The map before any trail is subtracted: what the star-aware test compares levels on.
    let sky = stars.map(|t| (sky::Sky::new(t, &z, w, h, p), z.clone()));
    let (mut under_trails, mut removed) = (None, None);
    if let Some((sky, _)) = &sky {
        let (u, r) = sky.subtract(&mut z, w, h);
        (under_trails, removed) = (Some(u), Some(r));
    } else if let Some(a) = star_trail_angle_deg.filter(|a| a.is_finite()) {
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

    // 3. Oriented line filter, in units of its measured noise.
    let noise = if p.calibrate_noise {
        LineNoise::measure(&zc, w, h, p)
    } else {
        LineNoise::white(p)
    };
    let (best, arg) = line_filter(&zc, w, h, p, &noise);

    // 4. Components, of the local filters and of the long-line stage (3b).
    let kmax = p.half_lengths.iter().copied().max().unwrap_or(10) as f64 * 2.0 + 1.0;
    let local: Vec<(components::Component, f64)> = components(&best, &arg, w, h, p)
        .into_iter()
        .map(|c| (c, kmax))
        .collect();
    let long = long_line_components(&zc, w, h, p);

    // 5-6. Refinement, rejection, merging.
    let ctx = Ctx {
        w,
        h,
        pixels,
        bg: &bg,
        z: &z,
        p,
        noise: &noise,
        under_trails: under_trails.as_deref(),
        removed: removed.as_deref(),
    };
    let trail = star_trail_angle_deg.filter(|a| a.is_finite());
    // A short segment's orientation is uncertain by about its width over its length, so the
    // tolerance grows by atan(4 psf_sigma / length).
    let aligned = |s: &Seg| match (&sky, trail) {
        (Some((sky, z_sky)), _) => sky.explains(s, z_sky, w, h, p.trail_tol),
        (None, Some(a)) => {
            let slack = (4.0 * p.psf_sigma / s.length.max(1.0)).atan().to_degrees();
            angle_diff_deg(s.theta.to_degrees(), a) <= p.trail_tol + slack
        }
        (None, None) => false,
    };
    let mut dropped: Vec<Dropped> = Vec::new();
    let mut fragments =
        |comps: &[(components::Component, f64)], contrast: bool, seeds: Seeds| -> Vec<Seg> {
            let mut frags = Vec::new();
            for &(ref c, kmax) in comps {
                let shrink = (kmax / 2.0).min(c.half_len / 2.0);
                let seed = Seed {
                    cx: c.cx,
                    cy: c.cy,
                    theta: c.theta,
                    half: c.half_len,
                    shrink,
                    ext: kmax,
                    contrast,
                };
                let Some(s) = ctx.refine(&seed) else {
                    dropped.push(Dropped::of_axis((c.cx, c.cy), c.theta, c.half_len, seeds));
                    continue;
                };
                if s.length < p.min_fragment {
                    let r = Reason::ShortFragment {
                        length_px: s.length,
                        limit: p.min_fragment,
                    };
                    dropped.push(Dropped::of_seg(&s, seeds, r));
                } else if aligned(&s) {
                    dropped.push(Dropped::of_seg(&s, seeds, Reason::StarTrail));
                } else {
                    frags.push(s);
                }
            }
            frags
        };
    // The two stages' fragments are merged apart: a long-line fragment overlapping a local
    // one (the same streak, its ends less sharp) would otherwise re-refine it into a segment
    // that can fail where the local one passed. Where both find a streak, explaining away
    // (below) keeps the better scoring one.
    // Profiles by contrast (see `refine`), except for the local seeds of survey images, where
    // parallel star trails fall in the side bands (a false candidate at confidence 0.66 in
    // `survey_trails_rejected_and_debris_found`).
    let local_frags = fragments(&local, trail.is_none(), Seeds::Local);
    let long_frags = fragments(&long, true, Seeds::LongLine);
    let mut merged: Vec<(Seg, Seeds)> = ctx
        .merge(local_frags, &aligned)
        .into_iter()
        .map(|s| (s, Seeds::Local))
        .collect();
    merged.extend(
        ctx.merge(long_frags, &aligned)
            .into_iter()
            .map(|s| (s, Seeds::LongLine)),
    );

    // 7. Acceptance, scoring, duplicates.
    let mut cands: Vec<(Seg, Seeds, f64)> = Vec::new();
    for (s, seeds) in merged {
        let failed = if s.length < p.min_length {
            Some(Reason::TooShort {
                length_px: s.length,
                limit: p.min_length,
            })
        } else if s.elongation < p.min_elongation {
            Some(Reason::NotElongated {
                elongation: s.elongation,
                limit: p.min_elongation,
            })
        } else if s.snr < p.min_snr {
            Some(Reason::LowSnr {
                snr: s.snr,
                limit: p.min_snr,
            })
        } else if aligned(&s) {
            Some(Reason::StarTrail)
        } else {
            ctx.gap(&s).map(|g| Reason::Gap {
                chunk: g.chunk,
                chunks: g.chunks,
                level: g.level,
                sigma: g.sigma,
            })
        };
        match failed {
            Some(r) => dropped.push(Dropped::of_seg(&s, seeds, r)),
            None => {
                let score = confidence(s.snr, s.elongation, (w * h) as f64, p);
                cands.push((s, seeds, score));
            }
        }
    }
    cands.sort_by(|a, b| {
        b.2.total_cmp(&a.2)
            .then(a.0.cx.total_cmp(&b.0.cx))
            .then(a.0.cy.total_cmp(&b.0.cy))
    });
    // Explaining away: a candidate must still be long and significant enough outside the
    // neighbourhood of every better one (drops duplicates and the off-axis responses of
    // bright streaks).
    let mut kept: Vec<(Seg, f64)> = Vec::new();
    for (s, seeds, sc) in cands {
        if kept.len() >= p.max_candidates {
            let r = Reason::OverCap {
                limit: p.max_candidates,
            };
            dropped.push(Dropped::of_seg(&s, seeds, r));
            continue;
        }
        let others: Vec<(Point, Point)> = kept.iter().map(|(k, _)| k.ends()).collect();
        if !others.is_empty() && !ctx.survives(&s, &others) {
            dropped.push(Dropped::of_seg(&s, seeds, Reason::Duplicate));
            continue;
        }
        kept.push((s, sc));
    }
    // The star-aware pass: each streak followed across the trails that hide it (`reach`).
    let found = kept
        .into_iter()
        .map(|(s, sc)| ctx.candidate(&ctx.reach(&s), sc))
        .collect();
    (found, dropped)
}

/// Parameters checked and converted once.
#[derive(Clone)]
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
    confidence_snr: f64,
    confidence_scale: f64,
    elongation_scale: f64,
    class: u32,
    max_candidates: usize,
    calibrate_noise: bool,
    /// The star-aware pass: the trails' direction (degrees), whose neighbourhood alone the
    /// line filters search (see [`Sanitized::uses`]); `None`: every orientation.
    along: Option<f64>,
}

impl Sanitized {
    fn new(p: &StreakParams) -> Self {
        // Non-finite values fall back to the defaults.
        let d = StreakParams::default();
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
            mesh_clip: fin(p.mesh_clip_sigma, d.mesh_clip_sigma).max(1.0),
            min_sigma: fin(p.min_noise_sigma, d.min_noise_sigma).max(1e-3),
            psf_sigma: fin(p.psf_sigma_px, d.psf_sigma_px).clamp(0.3, 20.0),
            clip: fin(p.clip_sigma, d.clip_sigma).max(0.5),
            star_z: fin(p.star_mask_sigma, d.star_mask_sigma).max(1.0),
            star_ring_ratio: fin(p.star_ring_ratio, d.star_ring_ratio).clamp(0.0, 1.0),
            n_angles: p.n_angles.clamp(4, 180),
            half_lengths,
            threshold: fin(p.threshold_sigma, d.threshold_sigma) as f32,
            seed: fin(p.seed_sigma, d.seed_sigma) as f32,
            link_bins: p.angle_link_bins,
            min_pixels: p.min_pixels.max(1),
            min_fragment: fin(p.min_fragment_px, d.min_fragment_px),
            min_length: fin(p.min_length_px, d.min_length_px),
            min_elongation: fin(p.min_elongation, d.min_elongation),
            min_snr: fin(p.min_snr, d.min_snr),
            trail_tol: fin(p.star_trail_tolerance_deg, d.star_trail_tolerance_deg).abs(),
            trail_half: p.trail_filter_px.min(4001) / 2,
            merge_angle: fin(p.merge_angle_deg, d.merge_angle_deg).abs(),
            merge_offset: fin(p.merge_offset_px, d.merge_offset_px).abs(),
            merge_gap: fin(p.merge_gap_px, d.merge_gap_px),
            dup_dist: fin(p.duplicate_distance_px, d.duplicate_distance_px),
            pad_along: fin(p.box_pad_along_sigma, d.box_pad_along_sigma).max(0.0),
            pad_across: fin(p.box_pad_across_sigma, d.box_pad_across_sigma).max(0.0),
            confidence_snr: fin(p.confidence_snr, d.confidence_snr),
            confidence_scale: fin(p.confidence_snr_scale, d.confidence_snr_scale).max(1e-9),
            elongation_scale: fin(p.confidence_elongation_scale, d.confidence_elongation_scale)
                .max(1e-9),
            class: p.class,
            max_candidates: p.max_candidates,
            calibrate_noise: p.calibrate_noise,
            along: None,
        }
    }

    /// Whether the line filters use orientation `j` of `n_angles`: every one, or in the
    /// star-aware pass (`along`) those within `star_trail_tolerance_deg` and one filter step
    /// of the trails, the only candidates that pass keeps.
    fn uses(&self, j: usize) -> bool {
        let step = 180.0 / self.n_angles as f64;
        self.along
            .is_none_or(|a| angle_diff_deg(j as f64 * step, a) <= self.trail_tol + step)
    }
}
