//! The detector's knobs: [`StreakParams`], one field per knob (its doc gives the default,
//! [`Default`] sets it, [`StreakParams::check`] gives its allowed range), and [`Sanitized`], the
//! same converted once for the passes.

use super::segment::angle_diff_deg;

/// Every knob of [`super::detect_streaks`], with its default: all settable from a campaign's
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
    /// Where stars are predicted trails (a catalogue), detect on the image linearised (default
    /// false): each grey level mapped to its rank's normal quantile (`linearise`), which undoes
    /// the enhancement's compression of the sky's upper half, so that a faint streak adds to the
    /// sky as on the sensor. More faint streaks found; boxes fitted on the linearised map,
    /// whose ends and edges the fit was not tuned on (see `linearise` for what it measured).
    pub linearise: bool,
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
            linearise: false,
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
    /// [`super::detect_streaks`] itself clamps out-of-range values to something it can run; a campaign
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

/// Where a frame holds data: the original image's outline in a rotated or padded frame (the
/// conversion's fill outside it is noise with no streak in it), its four corners in order around
/// it, in the frame's pixel-centre coordinates.
pub type Footprint = [[f64; 2]; 4];

/// Parameters checked and converted once, and where the frame holds data.
#[derive(Clone)]
pub(crate) struct Sanitized {
    pub(super) mesh: usize,
    pub(super) mesh_clip: f64,
    pub(super) min_sigma: f64,
    pub(super) psf_sigma: f64,
    pub(super) clip: f64,
    pub(super) star_z: f64,
    pub(super) star_ring_ratio: f64,
    pub(super) n_angles: usize,
    pub(super) half_lengths: Vec<usize>,
    pub(super) threshold: f32,
    pub(super) seed: f32,
    pub(super) link_bins: usize,
    pub(super) min_pixels: usize,
    pub(super) min_fragment: f64,
    pub(super) min_length: f64,
    pub(super) min_elongation: f64,
    pub(super) min_snr: f64,
    pub(super) trail_tol: f64,
    pub(super) trail_half: usize,
    pub(super) merge_angle: f64,
    pub(super) merge_offset: f64,
    pub(super) merge_gap: f64,
    pub(super) dup_dist: f64,
    pub(super) pad_along: f64,
    pub(super) pad_across: f64,
    pub(super) confidence_snr: f64,
    pub(super) confidence_scale: f64,
    pub(super) elongation_scale: f64,
    pub(super) class: u32,
    pub(super) max_candidates: usize,
    pub(super) calibrate_noise: bool,
    pub(super) linearise: bool,
    /// The star-aware pass: the trails' direction (degrees), whose neighbourhood alone the
    /// line filters search (see [`Sanitized::uses`]); `None`: every orientation.
    pub(super) along: Option<f64>,
    /// The pass along the frame's own trails (no trail predicted): the gap test reads each
    /// sample's contrast against its quieter side band (see `accept::gap`).
    pub(super) quiet_side: bool,
    /// Where the frame holds data ([`Footprint`]); `None`: all of it.
    pub(super) footprint: Option<Footprint>,
}

impl Sanitized {
    /// These parameters on a frame that holds data only inside `footprint`.
    pub(crate) fn within(self, footprint: Option<Footprint>) -> Self {
        Sanitized { footprint, ..self }
    }

    pub(crate) fn new(p: &StreakParams) -> Self {
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
            linearise: p.linearise,
            along: None,
            quiet_side: false,
            footprint: None,
        }
    }

    /// Whether the line filters use orientation `j` of `n_angles`: every one, or in the
    /// star-aware pass (`along`) those within `star_trail_tolerance_deg` and one filter step
    /// of the trails, the only candidates that pass keeps.
    pub(super) fn uses(&self, j: usize) -> bool {
        let step = 180.0 / self.n_angles as f64;
        self.along
            .is_none_or(|a| angle_diff_deg(j as f64 * step, a) <= self.trail_tol + step)
    }
}
