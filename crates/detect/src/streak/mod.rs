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
//!    3c. **Full lines** (`full_lines`, the star-aware pass only): a Radon transform of the
//!    clipped map binned by 4, every line through the frame at every angle more than 2 degrees
//!    from the predicted trails (`PREDICTED_SKIP_DEG`; they are subtracted first), each against the bins beside it; the best segment of each of the most
//!    significant lines seeds step 5, which finds its ends as the most significant stretch of
//!    its profile and measures its SNR with a clipped mean (a frame-crossing survey streak is
//!    600-1100 px long, and each of its pixels far below the noise).
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
//! The driver ([`detect_streaks_among_stars`]) runs a first pass, the star-aware pass where the
//! hint has predicted trails, and their union (`union`). Told nothing of the stars,
//! [`detect_streaks_on_frame`] measures their trails on the frame (`own_trails`) and, where
//! they share a direction, runs both passes along it. A pass (`pass`) runs its stages in
//! order, each a function of its own file: `unit_noise` (1-2: `background`, `smooth`),
//! `flatten` (2: `trails`, `sky`, `stars`), `seeds` (3-4: `noise`, `lines`, `components`) and
//! `radon` (3b), `full_lines` (3c), `fragments` (5: `refine`), `merge` (6), `accept`, `explain_away`, then the
//! boxes (7: `reach`, `output`, `fit`). The later stages read the pass's maps through
//! `maps::Maps`; `params` holds the knobs, `segment` the geometry they share, `star_test`
//! whether a segment is a star's trail, and `stats` the robust statistics (bilinear sampling
//! is [`soig_image::imaging::bilinear`]).

#[macro_use]
mod simd;
mod accept;
mod background;
mod components;
mod digital_line;
mod explain;
mod explain_away;
mod fit;
mod flatten;
mod fragments;
mod full_lines;
mod gather;
mod linearise;
mod lines;
mod lone_line;
mod maps;
mod merge;
mod noise;
mod output;
mod own_trails;
mod params;
mod pass;
mod radon;
mod reach;
mod refine;
mod runs;
mod seam_cut;
mod seeds;
mod segment;
mod sky;
mod slant;
mod smooth;
mod star_test;
mod stars;
mod stats;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_fit;
#[cfg(test)]
mod tests_gaps;
#[cfg(test)]
mod tests_sky;
#[cfg(test)]
mod tests_stages;
mod trail_light;
mod trails;
mod union;
mod unit_noise;
mod unlisted;

use std::borrow::Cow;

pub use explain::{Dropped, Reason, Seeds};
use linearise::rank_normal;
use lone_line::{NEAR_DEG, Seams, like_others, trail_length};
pub use output::Candidate;
use output::boxed;
pub use own_trails::{OwnTrails, TrailModel};
use own_trails::{from_lines, own_trails};
pub(crate) use params::Sanitized;
pub use params::{Footprint, StreakParams};
use pass::{box_all, pass};
use segment::Seg;
use segment::angle_diff_deg;
pub use sky::StarTrail;
use union::union;
use unit_noise::unit_noise_map;
use unlisted::TrailShape;

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
    detect_streaks_explained(pixels, width, height, params, star_trail_angle_deg).0
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
    let p = Sanitized::new(params);
    among_stars(pixels, width, height, &p, star_trail_angle_deg, stars)
}

/// [`detect_streaks_among_stars`] with its parameters sanitized (and a footprint).
pub(crate) fn among_stars(
    pixels: &[u8],
    width: usize,
    height: usize,
    p: &Sanitized,
    star_trail_angle_deg: Option<f64>,
    stars: Option<&[StarTrail]>,
) -> Vec<Candidate> {
    let trail = star_trail_angle_deg.filter(|a| a.is_finite());
    let (Some(stars), Some(trail)) = (stars, trail) else {
        return explained(pixels, width, height, p, star_trail_angle_deg).0;
    };
    assert_eq!(
        pixels.len(),
        width * height,
        "pixels.len() must be width * height"
    );
    if width < 2 || height < 2 {
        return Vec::new();
    }
    // Both passes start from the same background and unit-noise map, of the image linearised
    // where asked (`linearise`).
    let linear = p
        .linearise
        .then(|| rank_normal(pixels, width, height, p.footprint.as_ref()));
    let pixels = linear.as_deref().unwrap_or(pixels);
    let (bg, z) = unit_noise_map(pixels, width, height, p);
    two_passes(pixels, width, height, p, (bg, z), trail, stars)
}

/// Detect streaks in a frame told nothing of its stars: with no trail direction and no
/// predicted trails given, the frame's own trails are measured (`own_trails`); where many
/// share a direction, the first pass runs along it, and the star-aware pass, with no trail
/// predicted, finds every line along the trails; of those, the lines off the direction that
/// most of them share (`TrailModel::settle`, `explains`), or along it but no trail's
/// (`lone_line`), join the first pass's; a box whose halves' light runs along the trails is
/// two trails side by side (`slant`). Where they share none (point stars), as
/// [`detect_streaks`], unchanged. A direction or trails given: as
/// [`detect_streaks_among_stars`], and nothing measured (None).
pub fn detect_streaks_on_frame(
    pixels: &[u8],
    width: usize,
    height: usize,
    params: &StreakParams,
    star_trail_angle_deg: Option<f64>,
    stars: Option<&[StarTrail]>,
) -> (Vec<Candidate>, Option<OwnTrails>) {
    let p = Sanitized::new(params);
    on_frame(pixels, width, height, &p, star_trail_angle_deg, stars)
}

/// [`detect_streaks_on_frame`] with its parameters sanitized (and a footprint).
pub(crate) fn on_frame(
    pixels: &[u8],
    width: usize,
    height: usize,
    p: &Sanitized,
    star_trail_angle_deg: Option<f64>,
    stars: Option<&[StarTrail]>,
) -> (Vec<Candidate>, Option<OwnTrails>) {
    let told = star_trail_angle_deg.is_some_and(f64::is_finite) || stars.is_some();
    if told || width < 2 || height < 2 {
        let found = among_stars(pixels, width, height, p, star_trail_angle_deg, stars);
        return (found, None);
    }
    assert_eq!(
        pixels.len(),
        width * height,
        "pixels.len() must be width * height"
    );
    let (bg, z) = unit_noise_map(pixels, width, height, p);
    let (w, h) = (width, height);
    let mut own = own_trails(&z, w, h);
    if let OwnTrails::Common(m) = &mut own {
        let found = along_own_trails(pixels, w, h, p, (bg, z), m);
        return (found, Some(own));
    }
    // Too few bright features: the lines a pass told of no trails finds may still share a
    // direction (a frame whose trails are faint but for one or two).
    let found = pass(
        pixels,
        w,
        h,
        p,
        &bg,
        Cow::Borrowed(&z),
        (None, None),
        box_all,
    )
    .0;
    match from_lines(&found, p.psf_sigma) {
        Some(mut m) => {
            let found = along_own_trails(pixels, w, h, p, (bg, z), &mut m);
            (found, Some(OwnTrails::Common(m)))
        }
        None => (found, Some(own)),
    }
}

/// The two passes along the frame's own trails `m`: the first along their direction, and the
/// star-aware pass with no trail predicted, which finds every line along them; most of those
/// are stars, whose direction settles `m`'s (`TrailModel::settle`), and the lines off it are
/// debris (`TrailModel::explains`); they join the first pass's.
fn along_own_trails(
    pixels: &[u8],
    w: usize,
    h: usize,
    p: &Sanitized,
    (bg, z): (Vec<f32>, Vec<f32>),
    m: &mut TrailModel,
) -> Vec<Candidate> {
    let trail = m.angle_deg;
    let first = pass(
        pixels,
        w,
        h,
        p,
        &bg,
        Cow::Borrowed(&z),
        (Some(trail), None),
        box_all,
    )
    .0;
    // The star trails are among the lines, so beyond `max_candidates`.
    let along = Sanitized {
        along: Some(trail),
        max_candidates: p.max_candidates.max(ALL_LINES),
        quiet_side: true,
        ..p.clone()
    };
    let second = pass(
        pixels,
        w,
        h,
        &along,
        &bg,
        Cow::Borrowed(&z),
        (Some(trail), Some(&[])),
        box_all,
    )
    .0;
    m.settle(&second);
    // Within a degree of the trails a line is debris where its length and profile say that no
    // trail, nor two end to end, explains it; a few degrees off them, where two trails side by
    // side do not (`lone_line`).
    let star: Vec<bool> = second.iter().map(|c| m.explains(c, p.psf_sigma)).collect();
    let along: Vec<&Candidate> = second
        .iter()
        .zip(&star)
        .filter(|s| *s.1)
        .map(|s| s.0)
        .collect();
    let trail_px = trail_length(&along);
    // A line as long as two others along the trails is a trail like them (`like_others`).
    let alike: Vec<bool> = second.iter().map(|c| like_others(c, &along)).collect();
    // A line's seams are read only where a rule asks for them (a profile along it each).
    let seams = |c: &Candidate| trail_px.map(|t| Seams::of(c, t, &z, w, h));
    // A few degrees off the trails, a line joined to a trail at an end is first cut at the
    // seam (`seam_cut`) and judged as what is left. (Not along them: there the lone rule's
    // two trails are fitted from the line's own ends, which a cut would move; a line of two
    // trails end to end, cut by 21 px, then passed it.)
    let near = |c: &Candidate| angle_diff_deg(c.orientation_deg, m.angle_deg) <= NEAR_DEG;
    let debris = second
        .into_iter()
        .zip(star.into_iter().zip(alike))
        .map(|(c, (star, alike))| {
            let piece = match trail_px {
                Some(t) if !star && near(&c) => seam_cut::cut(&c, t, &z, (w, h), p).unwrap_or(c),
                _ => c,
            };
            (piece, star, alike)
        })
        .filter(|(c, star, alike)| {
            if *star {
                !alike
                    && seams(c).is_some_and(|s| {
                        s.lone() || (s.short_lone() && slant::own_way(c, m.angle_deg, &z, (w, h)))
                    })
            } else {
                !near(c) || !seams(c).is_some_and(|s| s.pair())
            }
        })
        .map(|(c, _, _)| c)
        .collect();
    // Two trails side by side whose light runs along the trails' direction in each half are
    // no debris, however evenly lit and at whatever angle the pass found their chord (`slant`).
    let mut out = union(first, debris, trail, p);
    out.retain(|c| !seams(c).is_some_and(|s| slant::side_by_side(c, &s, m.angle_deg, &z, (w, h))));
    out
}

/// The most lines along the trails that the star-aware pass keeps when told of none (a
/// crowded survey frame shows tens of trails; each costs its refinement and box).
const ALL_LINES: usize = 256;

/// The first pass (everything along `trail` subtracted and dropped) and the star-aware pass
/// (the trails `stars` subtracted where they show, and what they explain dropped) on the
/// background and unit-noise map `maps`, and their union.
#[allow(clippy::too_many_arguments)]
fn two_passes(
    pixels: &[u8],
    w: usize,
    h: usize,
    p: &Sanitized,
    (bg, z): (Vec<f32>, Vec<f32>),
    trail: f64,
    stars: &[StarTrail],
) -> Vec<Candidate> {
    // The second pass finds what the first cannot, along the trails, so it searches only there.
    let along = Sanitized {
        along: Some(trail),
        ..p.clone()
    };
    // What the catalogue does not explain but has a star trail's shape is a star it did not
    // list, or misplaced (`unlisted`).
    let shape = TrailShape::of(stars, trail, w, h);
    // Only the candidates the union keeps are boxed, each on its own pass's maps: a fitted box
    // is most of a candidate's time, and 162 were fitted for the 98 kept on dev-os.
    let z_ref = Cow::Borrowed(&z[..]);
    let first_pass = (Some(trail), None);
    pass(
        pixels,
        w,
        h,
        p,
        &bg,
        z_ref.clone(),
        first_pass,
        |maps1, first| {
            let second_pass = (Some(trail), Some(stars));
            pass(
                pixels,
                w,
                h,
                &along,
                &bg,
                z_ref,
                second_pass,
                |maps2, second| {
                    let of = |pass: Pass| move |(seg, c)| Unboxed { c, seg, pass };
                    let first: Vec<Unboxed> = first.into_iter().map(of(Pass::First)).collect();
                    let mut second: Vec<Unboxed> =
                        second.into_iter().map(of(Pass::Second)).collect();
                    second.retain(|u| !shape.fits(&u.c, p.psf_sigma, &z, w, h));
                    let kept = union(first, second, trail, p);
                    let maps = |u: &Unboxed| if u.pass == Pass::First { maps1 } else { maps2 };
                    kept.iter().map(|u| boxed(maps(u), &u.seg, u.c)).collect()
                },
            )
            .0
        },
    )
    .0
}

/// Which of [`two_passes`] found a candidate.
#[derive(Clone, Copy, PartialEq)]
enum Pass {
    First,
    Second,
}

/// A candidate of [`two_passes`] before its box: its segment, and the pass whose maps box it.
struct Unboxed {
    c: Candidate,
    seg: Seg,
    pass: Pass,
}

impl std::borrow::Borrow<Candidate> for Unboxed {
    fn borrow(&self) -> &Candidate {
        &self.c
    }
}

/// [`detect_streaks`], and every refined segment that did not become a candidate, with why
/// (`soig detect --explain`): the first pass alone (the trails known by their direction only).
pub fn detect_streaks_explained(
    pixels: &[u8],
    width: usize,
    height: usize,
    params: &StreakParams,
    star_trail_angle_deg: Option<f64>,
) -> (Vec<Candidate>, Vec<Dropped>) {
    let p = Sanitized::new(params);
    explained(pixels, width, height, &p, star_trail_angle_deg)
}

/// [`detect_streaks_explained`] with its parameters sanitized (and a footprint).
pub(crate) fn explained(
    pixels: &[u8],
    width: usize,
    height: usize,
    p: &Sanitized,
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
    let (bg, z) = unit_noise_map(pixels, width, height, p);
    pass(
        pixels,
        width,
        height,
        p,
        &bg,
        Cow::Owned(z),
        (star_trail_angle_deg, None),
        box_all,
    )
}
