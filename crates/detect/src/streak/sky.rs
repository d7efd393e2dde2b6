//! Star-aware detection: the catalogued stars' predicted trails in the image (from the frame's
//! WCS, its pointing over the exposure, the exposure timing and the star catalogue; see
//! `render::trails` for how a run predicts them) are subtracted from the smoothed map where they
//! show (the median along each trail at each lateral offset), and a candidate is a star's when
//! predicted trails cover it and it is no brighter than those trails are elsewhere. A debris
//! streak beside, along or across a trail therefore survives where the angle alone
//! (`star_trail_tolerance_deg`) would drop it. A trail is trusted no further than the catalogue
//! allows: one that shows far more than brighter stars do carries something else (a debris
//! streak lying along it) and is neither subtracted nor believed beyond what such a star shows.

use super::params::Sanitized;
use super::runs::Runs;
use super::segment::{Seg, angle_diff_deg, point_segment_distance};
use super::stats::median_of;
use super::trail_light::{across, at_time, heading, jitter_across, shows, walk, wander};
pub use soig_image::hint::StarTrail;
use soig_image::imaging::bilinear;

/// A trail's light is subtracted out to where a Gaussian of its level falls below this.
const FADE_SIGMA: f64 = 1.0;
/// The farthest a trail's measured light is looked for beside it, pixels.
const MAX_REACH_PX: f64 = 24.0;
/// A candidate is a star's if predicted trails lie within their reach (plus `COVER_SLACK_PX`)
/// of this share of its axis samples (the rest: its ends' uncertainty) ...
const COVERED_SHARE: f64 = 0.8;
/// ... and they run along it: within this many degrees (plus its orientation uncertainty), not
/// the pass's whole tolerance. A faint streak a few degrees off the trails passes through a
/// bright trail's reach over hundreds of pixels, where the trail puts next to nothing, and its
/// level there (a fraction of a sigma a sample) is no more than the level test lets through:
/// with 5 degrees, 4 of 22 debris streaks 2-7 degrees off the trails were lost so on 300
/// original semisynthetic survey images (development seed 778), and one more false box was
/// kept on 100 original synthetic ones (seed 777). A star's own segment runs along its trail
/// to a fraction of a degree, a short one within its orientation uncertainty; a bright trail's
/// light measured a few degrees off it is judged by the trails within the pass's tolerance,
/// without the noise slack (`Sky::explains`).
const ALONG_DEG: f64 = 1.5;
/// ... and its level is at most this many times what those trails put there (each one's level
/// elsewhere, through its cross-section), plus `LEVEL_SLACK_SIGMA` in unit noise (a median
/// over at least 75 axis samples: a star trail measured twice agrees far better; debris lying
/// on a faint trail is several times brighter than it). Measured on 200 rotated survey images
/// (seed 9301): of 2306 star segments the test saw, 8 exceed the median 1.5; 20 segments of 7
/// debris streaks lay between 1.5 and 3 (the slack was 3) and were lost as star trails.
const LEVEL_RATIO: f64 = 2.0;
const LEVEL_SLACK_SIGMA: f64 = 1.5;
/// A line is longer than a star's trail of `l` px beyond `LONGER_SHARE * l` plus 4 psf sigmas
/// (its half-level ends; as `unlisted`'s whole-trail length). Covered by trails that are each
/// shorter, it is no one star's (`lone`): two trails end to end at one offset, or debris lying
/// along them, which their own paths then measure (`Prepared::level_beside`). On the rotated
/// semisynthetic development set (seed 778, 150 images) 41 segments of stars that the trails
/// explain were so long, and 8 of three debris streaks 0.15-0.55 degrees off the trails (SNR
/// 8-16, 617-903 px) that they explained as well. At 0.05 a debris streak running along
/// faint trails (refined 510 px, trails of 488) stayed explained there (image 37); at 0.02
/// it is found, mAP50-95 0.9143 -> 0.9176, no false box more, and the same at 0: the rotated
/// semisynthetic seed 777, rotated synthetic 778, original synthetic 777 and original
/// semisynthetic 778 development sets unchanged.
const LONGER_SHARE: f64 = 0.02;
/// A star fainter than another in the catalogue by this factor shows less (the catalogue
/// magnitude and the sky's colour scatter by about a tenth of a magnitude; 1.5 is 0.44 mag).
const FAINTER: f64 = 1.5;
/// A trail bounds what fainter stars show (`catalogue_bounds`) when measured over at least this
/// many pixels of its path, and a bound needs this many such brighter trails.
const BOUNDING_SAMPLES: usize = 64;
const BOUNDING_TRAILS: usize = 4;
/// How far a star's trail wanders from its predicted path, pixels: the pointing jitter, which
/// the prediction (a still pointing shifted by the image's mean jitter) leaves out; 1-1.5 px
/// measured on a 580 px trail of a rotated survey image.
const JITTER_PX: f64 = 1.0;
/// How far the centre of a trail's measured cross-section may lie from its predicted path
/// (followed through the pointing's wander), pixels: the wander's measure is off by 1-2 px
/// where few trails show (within 1 px, trails 2 px off left their far side as false lines: 13
/// false boxes instead of 8 on 200 rotated survey images; within 3 px: 10).
const CENTRE_PX: f64 = 2.0;
/// A trail covers a candidate's axis sample out to its reach and this much beyond: its measured
/// cross-section's centre may lie `CENTRE_PX` from the followed path, and its reach with it. A
/// bright trail's wing just beyond its reach (7.2 px from the path of a saturated trail, reach
/// 7.0) made false lines; with this slack 9 fewer false boxes on the 400 images of the rotated
/// survey row and 2 fewer on 200 held-out ones, recall unchanged (the level test still keeps
/// debris there: it is brighter than the trail's cross-section puts there).
const COVER_SLACK_PX: f64 = CENTRE_PX;

/// A predicted trail prepared for one image: its samples inside the image, the map's level
/// along it and how far its light reaches.
struct Prepared {
    nodes: Vec<(f64, f64)>,
    /// Points along the trail 1 px apart, inside the image, with the map's value there.
    samples: Vec<(f64, f64, f64)>,
    /// Distance from the path within which the trail's light stands above `FADE_SIGMA`.
    reach: f64,
    /// Bounding box of the nodes, grown by `reach` and `COVER_SLACK_PX`.
    bbox: [f64; 4],
    /// The direction from its first node to its last, degrees (-180, 180]: taken once here,
    /// not for every trail at each segment tested (`explained_by`).
    deg: f64,
    /// The map's median along the trail.
    level: f64,
    /// The most a star of this brightness can show (see `catalogue_bounds`), where the map
    /// shows more along it: something else lies on the trail (a debris streak along a faint
    /// star's trail), and the trail is neither measured nor subtracted nor trusted beyond it.
    cap: Option<f64>,
    /// What a star of this brightness shows at most (`catalogue_bounds`), where known.
    bound: Option<f64>,
    /// A moving trail that shows: the median of the map along it at each lateral offset from
    /// `-reach` to `reach` (rounded up), 1 px apart; what `subtract` removes, and the shape of
    /// the cross-section that `explains` expects.
    profile: Option<Vec<f64>>,
}

impl Prepared {
    /// The trail's level away from the segment `e0`-`e1` (a star measured twice agrees): the
    /// map's median along the rest of its path, at most about 256 samples of it (a long bright
    /// trail holds 1500); where the segment covers it whole, its level along the whole path.
    /// Where the segment is `lone` and covers most of it, that level holds the segment's own
    /// light: above `LEVEL_RATIO` times what a brighter star shows (`bound`), it is trimmed to
    /// that (true: trimmed).
    fn level_beside(&self, e0: (f64, f64), e1: (f64, f64), se: f64, lone: bool) -> (f64, bool) {
        let stride = (self.samples.len() / 256).max(1);
        let v: Vec<f64> = self
            .samples
            .iter()
            .step_by(stride)
            .filter(|q| point_segment_distance((q.0, q.1), e0, e1) > self.reach + 2.0 * se)
            .map(|q| q.2)
            .collect();
        let under = 2 * v.len() < self.samples.len().div_ceil(stride);
        let most = self.bound.map(|b| LEVEL_RATIO * b.max(0.0));
        if let Some(most) = most.filter(|&m| lone && under && self.level > m) {
            return (most, true);
        }
        let level = if v.len() < 8 {
            // The trail lies wholly under the segment: nothing of it elsewhere to compare
            // with, but its level along the whole path, which a brighter star bounds
            // (`catalogue_bounds`: capped where the map shows more).
            self.level.max(0.0)
        } else {
            let level = median_of(&v).max(0.0);
            self.cap.map_or(level, |c| level.min(c.max(0.0)))
        };
        (level, false)
    }

    /// The trail's cross-section at distance `d` from its path as a share of its centre: the
    /// measured profile where it shows, else a Gaussian of `se`.
    fn shape(&self, d: f64, se: f64) -> f64 {
        match &self.profile {
            Some(prof) if prof[prof.len() / 2] > 0.0 => {
                let both = profile_at(prof, d) + profile_at(prof, -d);
                (0.5 * both / prof[prof.len() / 2]).clamp(0.0, 1.0)
            }
            _ => (-d * d / (2.0 * se * se)).exp(),
        }
    }
}

/// The predicted trails of one image, measured on its smoothed unit-noise map `z` before
/// subtraction.
pub(super) struct Sky {
    trails: Vec<Prepared>,
    /// Each trail's path in runs of segments, for `Runs::distance_within`.
    runs: Vec<Runs>,
    /// Smoothed PSF sigma (the PSF convolved with the matched filter's Gaussian), pixels.
    se: f64,
}

impl Sky {
    pub(super) fn new(trails: &[StarTrail], z: &[f32], w: usize, h: usize, p: &Sanitized) -> Sky {
        let se = std::f64::consts::SQRT_2 * p.psf_sigma;
        let inside =
            |x: f64, y: f64| x >= 0.0 && y >= 0.0 && x <= (w - 1) as f64 && y <= (h - 1) as f64;
        // The pointing's wander across the trails over the exposure, which every trail with
        // node times then follows.
        let followed: Vec<StarTrail> = match jitter_across(trails, z, w, h) {
            Some(knots) => trails
                .iter()
                .map(|t| StarTrail {
                    nodes: across(t, |time| at_time(&knots, time)),
                    ..t.clone()
                })
                .collect(),
            None => trails.to_vec(),
        };
        // Each trail's samples inside the image and the map's median along them.
        let measured: Vec<Measured> = followed
            .iter()
            .filter(|t| {
                !t.nodes.is_empty() && t.nodes.iter().all(|n| n.0.is_finite() && n.1.is_finite())
            })
            .filter_map(|t| {
                let mut samples = Vec::new();
                walk(&t.nodes, w, h, |x, y, _, _| {
                    samples.push((x, y, bilinear(z, w, h, x, y) as f64));
                });
                if samples.is_empty() {
                    return None;
                }
                let mut t = t.clone();
                if let Some(d) = wander(&t.nodes, &samples, z, w, h) {
                    // Follow the trail to where its light is (see `wander`).
                    let ((ux, uy), _) = heading(&t.nodes);
                    let (nx, ny) = (-uy * d, ux * d);
                    t.nodes.iter_mut().for_each(|n| *n = (n.0 + nx, n.1 + ny));
                    samples = samples
                        .iter()
                        .map(|q| (q.0 + nx, q.1 + ny))
                        .filter(|q| inside(q.0, q.1))
                        .map(|q| (q.0, q.1, bilinear(z, w, h, q.0, q.1) as f64))
                        .collect();
                    if samples.is_empty() {
                        return None;
                    }
                }
                let vals: Vec<f64> = samples.iter().map(|s| s.2).collect();
                let level = median_of(&vals);
                Some((t, samples, level))
            })
            .collect();
        let caps = catalogue_bounds(&measured);
        let trails = measured
            .into_iter()
            .zip(caps)
            .map(|((t, samples, measured_level), bound)| {
                let cap = bound.filter(|&b| measured_level > LEVEL_RATIO * b + LEVEL_SLACK_SIGMA);
                let level = cap.unwrap_or(measured_level);
                // Where a Gaussian of the smoothed PSF's width and this peak falls to the fade
                // level, plus the pointing jitter's wander.
                let mut reach =
                    se * (2.0 * (level / FADE_SIGMA).max(1.0).ln()).sqrt() + se + JITTER_PX;
                // A trail that shows is measured instead: the median of the map along it at
                // each lateral offset, out to three times that (the 8-bit stretch raises a
                // bright trail's wings far above a Gaussian's: 5-7 px beside trails of 2e5 e-,
                // their residue made 6 of 20 false boxes on 200 rotated survey images), and its
                // reach is where that falls below the fade level, plus the jitter's wander.
                let profile = (cap.is_none() && shows(&t.nodes, &samples)).then(|| {
                    let ((ux, uy), _) = heading(&t.nodes);
                    let big = (3.0 * reach).ceil().min(MAX_REACH_PX) as i64;
                    let prof: Vec<f64> = (-big..=big)
                        .map(|d| {
                            let v: Vec<f64> = samples
                                .iter()
                                .map(|q| {
                                    let (x, y) = (q.0 - d as f64 * uy, q.1 + d as f64 * ux);
                                    bilinear(z, w, h, x, y) as f64
                                })
                                .collect();
                            median_of(&v)
                        })
                        .collect();
                    let prof = symmetric(&prof);
                    let c = big as usize;
                    let lit = (1..=c)
                        .take_while(|&d| 0.5 * (prof[c + d] + prof[c - d]) >= FADE_SIGMA)
                        .last()
                        .unwrap_or(0);
                    reach = reach.max(lit as f64 + 1.0 + JITTER_PX).min(big as f64);
                    let r = reach.ceil() as usize;
                    prof[c - r..=c + r].to_vec()
                });
                let cover = reach + COVER_SLACK_PX;
                let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
                for &(x, y) in &t.nodes {
                    (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
                }
                let (a, b) = (t.nodes[0], t.nodes[t.nodes.len() - 1]);
                let deg = (b.1 - a.1).atan2(b.0 - a.0).to_degrees();
                Prepared {
                    deg,
                    nodes: t.nodes.clone(),
                    samples,
                    reach,
                    bbox: [x0 - cover, y0 - cover, x1 + cover, y1 + cover],
                    level,
                    cap,
                    bound,
                    profile,
                }
            })
            .collect();
        let mut sky = Sky {
            trails,
            runs: Vec::new(),
            se,
        };
        sky.runs = sky.trails.iter().map(|t| Runs::of(&t.nodes)).collect();
        sky
    }

    /// Subtract every moving trail that shows (three quarters of its samples at least
    /// `SHOWS_SIGMA`) from the map: at each lateral offset out to its reach, the median of the
    /// map along the whole trail at that offset. A debris streak crossing the trail, or running
    /// beside or along part of it, covers too little of it to move a median and keeps its
    /// light. Returns which pixels lie within the reach of a subtracted trail: there a streak
    /// crossing it shows less than elsewhere (the 8-bit stretch compresses light added to a
    /// bright trail), which is no gap in the streak; and how much was subtracted at each pixel
    /// (where that is more than half a streak's level, the streak is hidden: see `reach`).
    pub(super) fn subtract(&self, z: &mut [f32], w: usize, h: usize) -> (Vec<bool>, Vec<f32>) {
        // The last trail that visited each pixel: 4 bytes a pixel (a usize's 8 were 8 MB to
        // fill an image).
        let mut stamp = vec![u32::MAX; w * h];
        let mut under = vec![false; w * h];
        let mut removed = vec![0.0f32; w * h];
        let ids = (0..u32::MAX).zip(&self.trails);
        for (id, t) in ids {
            let Some(profile) = &t.profile else {
                continue;
            };
            let ((ux, uy), _) = heading(&t.nodes);
            let r = t.reach.ceil() as i64;
            // Each pixel within the reach of the trail's samples, once, by its lateral offset.
            for q in &t.samples {
                for d in -(r + 1)..=(r + 1) {
                    let (x, y) = ((q.0 - d as f64 * uy).round(), (q.1 + d as f64 * ux).round());
                    if x < 0.0 || y < 0.0 || x >= w as f64 || y >= h as f64 {
                        continue;
                    }
                    let i = y as usize * w + x as usize;
                    if stamp[i] == id {
                        continue;
                    }
                    stamp[i] = id;
                    let off = (x - q.0) * -uy + (y - q.1) * ux;
                    let k = off + r as f64;
                    if k < 0.0 || k > (2 * r) as f64 {
                        continue;
                    }
                    under[i] |= off.abs() <= t.reach;
                    let v = profile_at(profile, off) as f32;
                    z[i] -= v;
                    removed[i] += v;
                }
            }
        }
        (under, removed)
    }

    /// Whether catalogued stars explain the segment `s`: predicted trails along its
    /// direction (within `ALONG_DEG`, at most `tolerance_deg`, plus the orientation uncertainty
    /// of a short segment)
    /// lie within their reach (plus `COVER_SLACK_PX`) of `COVERED_SHARE` of its axis samples,
    /// and its level on the map `z` exceeds `LEVEL_RATIO` times what those trails put there
    /// (each one's level elsewhere through its cross-section) by at most `LEVEL_SLACK_SIGMA`
    /// (median over the samples). Or the same with the trails within `tolerance_deg` and no
    /// slack: a piece of a trail's own light, measured a few degrees off it. On saturated
    /// trails the star-aware pass found lines 2.5-4.7 degrees off the trail, lying in its light
    /// from one side of its path at one end to the other at the other end (where the light
    /// drifts across the predicted path: 1.75 px over 435 px on one of them); on the
    /// faint-limit set (seed 9401) 8 of its 9 false boxes at confidence 0.5 were such lines, the
    /// trails putting 0.8-6 sigma where they lay and their median excess -0.9 to -6.6. A faint
    /// debris streak crossing a trail a few degrees off it lies mostly where the trail puts
    /// next to nothing, its excess its own level: above zero, and kept.
    pub(super) fn explains(
        &self,
        s: &Seg,
        z: &[f32],
        w: usize,
        h: usize,
        tolerance_deg: f64,
    ) -> bool {
        let along = tolerance_deg.min(ALONG_DEG);
        self.explained_by(s, z, w, h, along, LEVEL_SLACK_SIGMA)
            || (tolerance_deg > along && self.explained_by(s, z, w, h, tolerance_deg, 0.0))
    }

    /// The test of `explains` with the trails within `along_deg` of `s` (plus its orientation
    /// uncertainty) and `slack_sigma` the noise allowed above what they put there.
    fn explained_by(
        &self,
        s: &Seg,
        z: &[f32],
        w: usize,
        h: usize,
        along_deg: f64,
        slack_sigma: f64,
    ) -> bool {
        let (e0, e1) = s.ends();
        let slack = (4.0 * self.se / std::f64::consts::SQRT_2 / s.length.max(1.0))
            .atan()
            .to_degrees();
        let seg_deg = s.theta.to_degrees();
        let bbox = [
            e0.0.min(e1.0),
            e0.1.min(e1.1),
            e0.0.max(e1.0),
            e0.1.max(e1.1),
        ];
        // Trails near the segment, moving along it.
        let (near, near_runs): (Vec<&Prepared>, Vec<&Runs>) = self
            .trails
            .iter()
            .zip(&self.runs)
            .filter(|(t, _)| {
                t.nodes.len() >= 2
                    && t.bbox[0] <= bbox[2]
                    && t.bbox[2] >= bbox[0]
                    && t.bbox[1] <= bbox[3]
                    && t.bbox[3] >= bbox[1]
            })
            .filter(|(t, _)| angle_diff_deg(t.deg, seg_deg) <= along_deg + slack)
            .unzip();
        if near.is_empty() {
            return false;
        }
        // The trails within reach of each axis sample.
        let n = (s.length / 2.0).ceil().max(1.0) as usize;
        let mut covering: Vec<Covering> = Vec::with_capacity(n + 1);
        let mut used = vec![false; near.len()];
        for k in 0..=n {
            let f = k as f64 / n as f64;
            let q = (e0.0 + f * (e1.0 - e0.0), e0.1 + f * (e1.1 - e0.1));
            let inside = q.0 >= 0.0 && q.1 >= 0.0 && q.0 <= (w - 1) as f64 && q.1 <= (h - 1) as f64;
            let value = inside.then(|| bilinear(z, w, h, q.0, q.1) as f64);
            let mut ids = Vec::new();
            for (i, (t, runs)) in near.iter().zip(&near_runs).enumerate() {
                // A crowded field has thousands of trails: most lie beyond this sample's box.
                let outside =
                    q.0 < t.bbox[0] || q.0 > t.bbox[2] || q.1 < t.bbox[1] || q.1 > t.bbox[3];
                if outside {
                    continue;
                }
                if let Some(d) = runs.distance_within(q, &t.nodes, t.reach + COVER_SLACK_PX) {
                    ids.push((i, d));
                    used[i] = true;
                }
            }
            covering.push((value, ids));
        }
        let covered = covering.iter().filter(|c| !c.1.is_empty()).count();
        if (covered as f64) < COVERED_SHARE * (n + 1) as f64 {
            return false;
        }
        // A line longer than every trail that covers it is no one star's trail (`lone`).
        let longest = near
            .iter()
            .zip(&used)
            .filter(|(_, u)| **u)
            .map(|(t, _)| t.samples.len())
            .max()
            .unwrap_or(0);
        let lone = longer_than_trail(s.length, longest as f64, self.se / std::f64::consts::SQRT_2);
        let (theirs, trimmed): (Vec<f64>, Vec<bool>) = near
            .iter()
            .zip(&used)
            .map(|(t, &u)| match u {
                true => t.level_beside(e0, e1, self.se, lone),
                false => (0.0, false),
            })
            .unzip();
        // What the covering trails put at each sample: each one's level elsewhere times its
        // cross-section (`Prepared::shape`) at the sample's distance, less a pixel for the
        // pointing jitter's wander from the predicted path. Per sample, so that beside a
        // bright trail a faint one elsewhere on the segment does not lower what the segment may
        // show, and a debris streak leaving a bright trail is not explained by it (one median
        // over all covering trails' samples, dominated by the faint ones, let lines from one of
        // two parallel trails to the other, 0.3-2 degrees off them, through: 38 of 52 false
        // boxes on 200 rotated survey images).
        let mut excess = Vec::new();
        for (value, ids) in &covering {
            if let (Some(v), false) = (value, ids.is_empty()) {
                // The most of them, not their sum: trails running side by side are each
                // measured with the others' light (five overlapping trails summed explained a
                // SNR-64 streak 1.5 degrees off them).
                let expected: f64 = ids
                    .iter()
                    .map(|&(i, d)| theirs[i] * near[i].shape((d - JITTER_PX).max(0.0), self.se))
                    .fold(0.0, f64::max);
                excess.push(v - LEVEL_RATIO * expected);
            }
        }
        if excess.is_empty() {
            return true;
        }
        // Where a lone line's trails show more than their stars can, that light is the line's:
        // the noise slack, which covers a star's segment measured against its own trail, is not
        // given (a trail whose light lies beside its predicted path, level -0.2, explained a
        // line 45 px longer than it on original synthetic development image 40 only with it).
        let slack = if trimmed.contains(&true) {
            0.0
        } else {
            slack_sigma
        };
        median_of(&excess) <= slack
    }
}

/// Whether a line `length` px long is longer than a trail of `trail_px` (`LONGER_SHARE`).
fn longer_than_trail(length: f64, trail_px: f64, psf_sigma: f64) -> bool {
    length > (1.0 + LONGER_SHARE) * trail_px + 4.0 * psf_sigma
}

/// A star's cross-section as the median profile `prof` (offsets `-r..=r` from the path, 1 px
/// apart) shows it, without what lies beside the star: the smaller of the two sides at each
/// distance from the profile's centre (a star's light is symmetric about its path). The
/// centre is the profile's peak within `CENTRE_PX` of the path (the highest sample there,
/// refined by a parabola through it and its neighbours). A debris streak running 4-6 px
/// beside a trail along its whole length is in the median at every offset on its side, and
/// was subtracted with the star (4 of 39 false boxes on the 400 images of the rotated survey
/// row, before its new fill, were such debris boxed too short). Two trails side by side are
/// each subtracted once, not with each other's light too.
fn symmetric(prof: &[f64]) -> Vec<f64> {
    let r = prof.len() / 2;
    let reach = (CENTRE_PX as usize).min(r.saturating_sub(1));
    let k = (r - reach..=r + reach).fold(r, |k, j| if prof[j] > prof[k] { j } else { k });
    let centre = if k > 0 && k + 1 < prof.len() {
        let curve = prof[k - 1] - 2.0 * prof[k] + prof[k + 1];
        let sub = if curve < 0.0 {
            (0.5 * (prof[k - 1] - prof[k + 1]) / curve).clamp(-0.5, 0.5)
        } else {
            0.0
        };
        (k as f64 - r as f64 + sub).clamp(-CENTRE_PX, CENTRE_PX)
    } else {
        0.0
    };
    (0..prof.len())
        .map(|k| prof[k].min(profile_at(prof, 2.0 * centre - (k as f64 - r as f64))))
        .collect()
}

/// A cross-section profile (offsets `-r..=r` from the path, 1 px apart) at lateral offset
/// `offset`: linear between its samples, its end values beyond them.
fn profile_at(prof: &[f64], offset: f64) -> f64 {
    let r = (prof.len() / 2) as f64;
    let k = (offset + r).clamp(0.0, 2.0 * r);
    let (k0, f) = (k.floor() as usize, k - k.floor());
    let k1 = (k0 + 1).min(prof.len() - 1);
    prof[k0] * (1.0 - f) + prof[k1] * f
}

/// A trail followed to its light (`wander`), its samples inside the image with the map's value
/// at each, and the map's median along them.
type Measured = (StarTrail, Vec<(f64, f64, f64)>, f64);

/// An axis sample of a segment: the map's value there (None: outside the image) and the trails
/// within reach, as (index, distance).
type Covering = (Option<f64>, Vec<(usize, f64)>);

/// For each moving trail, what a star of its brightness shows at most: the lower quartile of
/// the levels measured on trails brighter in the catalogue by at least `FAINTER` (None: fewer
/// than `BOUNDING_TRAILS` of them). The stretch is monotone, so a star cannot show more than a
/// brighter one; where the map shows far more along a trail, something else lies on it. (A
/// debris streak 0.15 degrees off the trails lay along a 1 e-/px star's trail for half its
/// length; measured as that star, the trail was subtracted with the streak's light and then
/// explained what was left of it: half of a SNR-185 streak was lost.) A quartile, not the least:
/// a trail's prediction can run where the image has no light of it (beyond a rotated frame's
/// footprint, into the fill), and the least level of 127 e-/px trail measured over 8 such
/// samples was 0.03, which would have capped every trail of its image.
fn catalogue_bounds(measured: &[Measured]) -> Vec<Option<f64>> {
    // Trails measured along enough of their path to bound others, brightest first.
    let mut bright: Vec<(f64, f64)> = measured
        .iter()
        .filter(|(t, samples, _)| t.nodes.len() >= 2 && samples.len() >= BOUNDING_SAMPLES)
        .map(|(t, _, level)| (per_px(t), *level))
        .collect();
    bright.sort_by(|a, b| b.0.total_cmp(&a.0));
    // The lower quartile of the levels of the first k + 1 of them, for each k.
    let mut sorted: Vec<f64> = Vec::with_capacity(bright.len());
    let quartile: Vec<f64> = bright
        .iter()
        .map(|&(_, l)| {
            let at = sorted.partition_point(|&v| v < l);
            sorted.insert(at, l);
            sorted[(sorted.len() - 1) / 4]
        })
        .collect();
    measured
        .iter()
        .map(|(t, _, _)| {
            if t.nodes.len() < 2 {
                return None;
            }
            // Its brightness once, not at each step of the search (a sum over its nodes).
            let fainter = FAINTER * per_px(t);
            let n = bright.partition_point(|b| b.0 >= fainter);
            (n >= BOUNDING_TRAILS).then(|| quartile[n - 1])
        })
        .collect()
}

/// A trail's brightness in the catalogue per pixel of its path (electrons).
fn per_px(t: &StarTrail) -> f64 {
    let path: f64 = t
        .nodes
        .windows(2)
        .map(|p| (p[1].0 - p[0].0).hypot(p[1].1 - p[0].1))
        .sum();
    t.electrons / path.max(1.0)
}

#[cfg(test)]
mod symmetric_tests {
    use super::*;

    /// A Gaussian cross-section (sigma 2 px, peak 10) centred `c` px from the path, plus a
    /// bump of `bump` peak 5 px beyond it, sampled at offsets -12..=12.
    fn profile(c: f64, bump: f64) -> Vec<f64> {
        (-12..=12)
            .map(|o| {
                let o = o as f64;
                10.0 * (-(o - c).powi(2) / 8.0).exp() + bump * (-(o - c - 5.0).powi(2) / 8.0).exp()
            })
            .collect()
    }

    /// A star alone is kept, and what lies beside it (a bump of 8, 5 px beyond its centre)
    /// left out, where the centre is within `CENTRE_PX` of the path: 0, 0.6 and 0.9 px off
    /// (the wander's error). The star's own sides lose at most what linear interpolation
    /// between 1 px samples of a 2 px Gaussian misses (0.2 of its peak of 10, computed); with
    /// the bump, the bump's wing on the star pulls the peak 0.1-0.3 px towards it, and the
    /// far side is then trimmed by up to 1.9 (computed: 1.46-1.86 of the peak of 10).
    #[test]
    fn the_star_is_kept_and_what_lies_beside_it_left_out() {
        for c in [0.0, 0.6, -0.9] {
            let star = profile(c, 0.0);
            let got = symmetric(&profile(c, 8.0));
            for (k, (g, s)) in got.iter().zip(&star).enumerate() {
                assert!(
                    (g - s).abs() < 2.0,
                    "centre {c}, offset {}: {g:.2} against the star's {s:.2}",
                    k as i64 - 12
                );
            }
            let alone = symmetric(&star);
            for (g, s) in alone.iter().zip(&star) {
                assert!(
                    *g <= *s && s - g < 0.25,
                    "centre {c}: {g:.2} against {s:.2}"
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::streak::StreakParams;
    use crate::streak::lone_line::tests::{flat, map};

    /// A segment from `a` to `b` (pixel centres).
    fn seg(a: (f64, f64), b: (f64, f64)) -> Seg {
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        Seg {
            cx: 0.5 * (a.0 + b.0),
            cy: 0.5 * (a.1 + b.1),
            theta: dy.atan2(dx),
            length: dx.hypot(dy),
            snr: 10.0,
            flux: 1.0,
            elongation: 10.0,
            contrast: false,
        }
    }

    /// The sky of one catalogued trail along row `y` from x = 40 to 360, of `electrons`, on the
    /// map `z` (`w` x `h`), and the default parameters it was made with.
    fn sky_of_trail(y: f64, electrons: f64, z: &[f32], w: usize, h: usize) -> (Sky, Sanitized) {
        let trails = [StarTrail {
            nodes: vec![(40.0, y), (360.0, y)],
            times_s: Vec::new(),
            electrons,
        }];
        let p = Sanitized::new(&StreakParams::default());
        (Sky::new(&trails, z, w, h, &p), p)
    }

    #[test]
    fn a_trail_explains_what_runs_along_it_not_a_faint_line_a_few_degrees_off() {
        // A bright trail (level 30) on row 200, and a faint line (0.8, a fraction of a sigma a
        // sample, as a streak of line SNR 10 over 900 px) 4 degrees off it, crossing it
        // mid-way: within the trail's reach over most of its length, where the trail puts
        // nothing. Its level is no more than the trail may leave there (`LEVEL_SLACK_SIGMA`),
        // so with every trail within the pass's tolerance (5 degrees) of it taken as running
        // along it, the trail explained it (development seed 778: 4 of 22 debris streaks 2-7
        // degrees off the trails on 300 original semisynthetic survey images were lost so).
        let (w, h) = (400, 400);
        let rise = 120.0 * 4f64.to_radians().tan();
        let (y0, y1) = (200.0 - rise, 200.0 + rise);
        let z = map(
            w,
            h,
            &[flat(40, 360, 200.0, 30.0), ((80, y0), (320, y1), 0.8)],
        );
        let (sky, p) = sky_of_trail(200.0, 1e5, &z, w, h);
        let explains = |s: &Seg| sky.explains(s, &z, w, h, p.trail_tol);
        assert!(
            explains(&seg((100.0, 200.0), (300.0, 200.0))),
            "along the trail"
        );
        assert!(!explains(&seg((80.0, y0), (320.0, y1))), "4 degrees off it");
    }

    /// Four bright catalogued trails (125 e-/px) that show 0.1, and two faint ones (2.5 e-/px),
    /// 400 px each, overlapping end to end 3 px apart, with a line of `level` drawn along both
    /// from x = 90 to 810, `dy` px below them: the sky, its map and the line (720 px, 0.28
    /// degrees off them).
    fn faint_pair_under(level: f32, dy: f64) -> (Sky, Vec<f32>, Seg, Sanitized) {
        let (w, h) = (1000, 200);
        let mut drawn: Vec<_> = [20.0, 40.0, 60.0, 80.0]
            .into_iter()
            .map(|y| flat(100, 900, y, 0.1))
            .collect();
        drawn.push(((90, 150.0 + dy), (810, 153.5 + dy), level));
        let z = map(w, h, &drawn);
        let trail = |a: (f64, f64), b: (f64, f64), electrons: f64| StarTrail {
            nodes: vec![a, b],
            times_s: Vec::new(),
            electrons,
        };
        let mut trails: Vec<StarTrail> = [20.0, 40.0, 60.0, 80.0]
            .into_iter()
            .map(|y| trail((100.0, y), (900.0, y), 1e5))
            .collect();
        trails.push(trail((100.0, 150.0), (500.0, 150.0), 1e3));
        trails.push(trail((400.0, 153.0), (800.0, 153.0), 1e3));
        let p = Sanitized::new(&StreakParams::default());
        let sky = Sky::new(&trails, &z, w, h, &p);
        (sky, z, seg((90.0, 150.0 + dy), (810.0, 153.5 + dy)), p)
    }

    #[test]
    fn a_line_longer_than_the_trails_under_it_is_theirs_only_as_bright_as_their_stars() {
        // Debris (1.6 a sample, as on rotated semisynthetic development image 66: a SNR-16
        // streak 903 px long, 0.55 degrees off the trails) along two faint trails, each
        // shorter than it: measured along their own paths they show the debris' light, which
        // explained it (their level 1.6, within twice theirs plus the noise slack). Their
        // stars show no more than the brighter ones' 0.1: it is not theirs.
        let explains = |(sky, z, s, p): (Sky, Vec<f32>, Seg, Sanitized)| {
            sky.explains(&s, &z, 1000, 200, p.trail_tol)
        };
        assert!(!explains(faint_pair_under(1.6, 0.0)), "debris");
        // The same line where the faint pair shows what their stars may (0.15): theirs.
        assert!(
            explains(faint_pair_under(0.15, 0.0)),
            "two trails end to end"
        );
        // A line of 0.8 3 px beside the pair, which shows nothing on its paths: no more than
        // their stars may show, so the noise slack stands (the light of a star whose predicted
        // path is off, as on original synthetic development image 40).
        assert!(explains(faint_pair_under(0.8, -3.0)), "beside their paths");
    }

    #[test]
    fn a_broad_trail_explains_its_own_light_measured_a_few_degrees_off_it() {
        // A broad bright trail (level 30, rows 192-209) and a segment through its light from
        // one side to the other, 2.9 degrees off it: more than `ALONG_DEG` and the segment's
        // orientation uncertainty (2.6 degrees together), as the star-aware pass measured
        // pieces of saturated trails whose subtraction left light on one side at one end and
        // on the other at the other end. Wherever the segment lies the trail puts there more
        // than half of what the map shows: it is the trail's.
        let (w, h) = (400, 400);
        let rows: Vec<_> = (0..6)
            .map(|k| flat(40, 360, 193.0 + 3.0 * k as f64, 30.0))
            .collect();
        let z = map(w, h, &rows);
        let (sky, p) = sky_of_trail(200.5, 1e6, &z, w, h);
        let s = seg((50.0, 193.0), (350.0, 208.0));
        assert!(
            !sky.explained_by(&s, &z, w, h, ALONG_DEG, LEVEL_SLACK_SIGMA),
            "no trail within ALONG_DEG"
        );
        assert!(
            sky.explains(&s, &z, w, h, p.trail_tol),
            "the trail's own light"
        );
    }
}
