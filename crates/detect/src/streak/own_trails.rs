//! The frame's own star trails: with no catalogue and no trail direction given, the stars of a
//! survey frame are measured on the frame itself. Under a moving pointing every star drifts
//! alike over the exposure, so most bright linear features share one direction; a debris
//! streak is one line, or none. Bright features are the 8-connected pixels above
//! `FEATURE_SIGMA` of the smoothed unit-noise map binned by `BIN` (a faint trail, 1-3 sigma a
//! pixel, stands out of the binned map's noise), each described by its second moments; pieces
//! of one line count once; the direction most lines share (within their orientation
//! uncertainty) is the trails', when enough of them share it. Point stars give round features,
//! and a frame of them no common direction.

use super::components::{label_components, moments_by_label};
use super::output::Candidate;
use super::segment::angle_diff_deg;
use super::stats::median_of;
use soig_image::imaging::robust_stats;

/// The map is clipped to this many sigma (a saturated trail weighs no more than a bright one)
/// and binned by `BIN` x `BIN` pixels, then put in unit noise again.
const CLIP_SIGMA: f32 = 8.0;
const BIN: usize = 4;
/// Binned unit-noise level above which a binned pixel belongs to a bright feature, and the
/// fewest binned pixels of a feature (noise above 3 sigma comes in clumps of a few).
const FEATURE_SIGMA: f32 = 3.0;
const MIN_PIXELS: usize = 8;
/// An elongated feature: at least this long (frame pixels) and this elongated (its length
/// over its moments' width; a star is about 3, a trail of length L and width s L / s; two or
/// three bright stars merged in the binned map reach 4-5, and in a crowded frame of point
/// stars four such blobs shared a direction within their wide tolerance at 3).
const MIN_LENGTH_PX: f64 = 24.0;
const MIN_ELONGATION: f64 = 6.0;
/// Features share a direction within this (degrees) plus their own orientation uncertainty,
/// atan(2 width / length).
const SHARE_DEG: f64 = 1.0;
/// Features whose centroids lie this close across their direction are pieces of one line,
/// frame pixels (a feature's centroid lies within its width, ~2 px, of the line's axis).
const SAME_LINE_PX: f64 = 6.0;
/// A common direction needs this many distinct lines along it, and this share of the lines
/// (a frame with one or two debris streaks has none; soig's survey frames often show only
/// 3-5 trails bright enough, the rest too faint for `FEATURE_SIGMA`).
const MIN_TRAILS: usize = 3;
const MIN_SHARE: f64 = 0.5;
/// Lines sharing a direction scatter about it by their measurement error, a degree or two at
/// most (median 0.1-1.7 degrees on soig's survey frames); chains of bright stars merged in the
/// binned map of a crowded frame of point stars scattered by 4.4.
const MAX_SPREAD_DEG: f64 = 2.5;
/// The direction is settled (`TrailModel::settle`) on the lines found within this many degrees
/// of the features' (their moments on the binned map are off by up to 2-4 degrees where a
/// bright line crosses them).
const SETTLE_DEG: f64 = 5.0;
/// A line within this many degrees of the settled direction (plus its own orientation
/// uncertainty) is a star's trail (`TrailModel::explains`).
const ALONG_DEG: f64 = 1.0;

/// One bright feature of the frame: mean level, centroid, orientation (degrees in [0, 180)),
/// length and width from its second moments (frame pixels), and whether it touches the
/// frame's edge.
#[derive(Clone, Copy, Debug)]
struct Feature {
    level: f64,
    cx: f64,
    cy: f64,
    angle_deg: f64,
    length: f64,
    width: f64,
    at_edge: bool,
}

impl Feature {
    fn elongated(&self) -> bool {
        self.length >= MIN_LENGTH_PX && self.length >= MIN_ELONGATION * self.width
    }
    /// How far its orientation may lie from the direction it shares, degrees.
    fn tolerance_deg(&self) -> f64 {
        SHARE_DEG + (2.0 * self.width / self.length).atan().to_degrees()
    }
}

/// The trails' model measured on the frame: their common direction (degrees from +x towards
/// +y, in [0, 180); settled on the lines the detector finds along it), length (px: the upper
/// quartile of the lines not cut by the frame's edge, a lower bound where faint trails break),
/// cross-section (the moments' sigma across them, px) and level (median of the features' mean
/// binned level, unit noise); how many distinct lines lie along it, of how many (`share`: how
/// sure), and how far their directions scatter (`spread_deg`, the median absolute difference).
/// `width_px` and `level_sigma` are None where the features were too few and the direction
/// came from the lines the detector found (`from_lines`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TrailModel {
    pub angle_deg: f64,
    pub length_px: f64,
    pub width_px: Option<f64>,
    pub level_sigma: Option<f64>,
    pub count: usize,
    pub lines: usize,
    pub share: f64,
    pub spread_deg: f64,
}

/// What the frame shows of its stars' trails.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "kebab-case", tag = "verdict")]
pub enum OwnTrails {
    /// Enough lines share one direction.
    Common(TrailModel),
    /// No common trail direction: `lines` elongated lines, at most `best` along one direction.
    NoCommonDirection { lines: usize, best: usize },
}

impl OwnTrails {
    pub fn model(&self) -> Option<&TrailModel> {
        match self {
            OwnTrails::Common(m) => Some(m),
            OwnTrails::NoCommonDirection { .. } => None,
        }
    }
}

impl std::fmt::Display for OwnTrails {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            OwnTrails::Common(m) => {
                write!(
                    f,
                    "direction {:.2} deg (spread {:.2}), length {:.0} px or more, ",
                    m.angle_deg, m.spread_deg, m.length_px
                )?;
                if let (Some(w), Some(l)) = (m.width_px, m.level_sigma) {
                    write!(f, "width {w:.1} px, level {l:.1} sigma, ")?;
                }
                write!(
                    f,
                    "{} of {} lines ({:.0}%)",
                    m.count,
                    m.lines,
                    100.0 * m.share
                )
            }
            OwnTrails::NoCommonDirection { lines, best } => write!(
                f,
                "no common trail direction ({lines} elongated lines, at most {best} along one direction)"
            ),
        }
    }
}

/// Measure the trails of the smoothed unit-noise map `z` (`w` x `h`).
pub(super) fn own_trails(z: &[f32], w: usize, h: usize) -> OwnTrails {
    let (bw, bh) = (w / BIN, h / BIN);
    if bw < 2 || bh < 2 {
        return OwnTrails::NoCommonDirection { lines: 0, best: 0 };
    }
    let feats = features(&binned(z, w, bw, bh), bw, bh);
    let long: Vec<&Feature> = feats.iter().filter(|f| f.elongated()).collect();
    // Pieces of one line (a long faint streak breaks into many) count once, as its longest.
    let lines = lines(&long);
    let along = |c: f64| -> Vec<&Feature> {
        lines
            .iter()
            .copied()
            .filter(|f| angle_diff_deg(f.angle_deg, c) <= f.tolerance_deg())
            .collect()
    };
    // The direction most lines share, each line's orientation tried as the centre.
    let (best, centre) = lines
        .iter()
        .map(|f| (along(f.angle_deg).len(), f.angle_deg))
        .fold((0, 0.0), |m, c| if c.0 > m.0 { c } else { m });
    if best < MIN_TRAILS || (best as f64) < MIN_SHARE * lines.len() as f64 {
        return OwnTrails::NoCommonDirection {
            lines: lines.len(),
            best,
        };
    }
    let members = along(centre);
    // The mean of the doubled angles, weighted by length (a long line's orientation is the
    // surer), about the centre so that 179 and 1 degrees average to 0.
    let (mut sx, mut sy) = (0.0f64, 0.0f64);
    for f in &members {
        let d = (f.angle_deg - centre + 90.0).rem_euclid(180.0) - 90.0;
        let a = 2.0 * d.to_radians();
        sx += f.length * a.cos();
        sy += f.length * a.sin();
    }
    let angle_deg = (centre + 0.5 * sy.atan2(sx).to_degrees()).rem_euclid(180.0);
    let mut whole: Vec<f64> = members
        .iter()
        .filter(|f| !f.at_edge)
        .map(|f| f.length)
        .collect();
    if whole.is_empty() {
        whole = members.iter().map(|f| f.length).collect();
    }
    whole.sort_by(f64::total_cmp);
    let med = |v: Vec<f64>| median_of(&v);
    let spread_deg = med(members
        .iter()
        .map(|f| angle_diff_deg(f.angle_deg, angle_deg))
        .collect());
    if spread_deg > MAX_SPREAD_DEG {
        return OwnTrails::NoCommonDirection {
            lines: lines.len(),
            best,
        };
    }
    OwnTrails::Common(TrailModel {
        angle_deg,
        length_px: whole[(3 * whole.len()) / 4],
        width_px: Some(med(members.iter().map(|f| f.width).collect())),
        level_sigma: Some(med(members.iter().map(|f| f.level).collect())),
        count: best,
        lines: lines.len(),
        share: best as f64 / lines.len() as f64,
        spread_deg,
    })
}

/// The trails' model from the lines `found` by a pass told of no trails, where the frame's
/// features were too few (a frame whose trails are faint but for one or two): the direction
/// most of them share, within `ALONG_DEG` plus their orientation uncertainty, if at least
/// `MIN_TRAILS` and `MIN_SHARE` of them do. Debris in a frame of point stars is one or two
/// lines: no model.
pub(super) fn from_lines(found: &[Candidate], psf_sigma: f64) -> Option<TrailModel> {
    let tolerance =
        |c: &Candidate| ALONG_DEG + (4.0 * psf_sigma / c.length_px.max(1.0)).atan().to_degrees();
    let along = |deg: f64| -> Vec<&Candidate> {
        found
            .iter()
            .filter(|c| angle_diff_deg(c.orientation_deg, deg) <= tolerance(c))
            .collect()
    };
    let centre = found
        .iter()
        .map(|c| (along(c.orientation_deg).len(), c.orientation_deg))
        .fold((0, 0.0), |m, c| if c.0 > m.0 { c } else { m })
        .1;
    let members = along(centre);
    let best = members.len();
    if best < MIN_TRAILS || (best as f64) < MIN_SHARE * found.len() as f64 {
        return None;
    }
    let mut lengths: Vec<f64> = members.iter().map(|c| c.length_px).collect();
    lengths.sort_by(f64::total_cmp);
    let mut m = TrailModel {
        angle_deg: centre,
        length_px: lengths[(3 * lengths.len()) / 4],
        width_px: None,
        level_sigma: None,
        count: best,
        lines: found.len(),
        share: best as f64 / found.len() as f64,
        spread_deg: 0.0,
    };
    m.settle(found);
    m.spread_deg = median_of(
        &members
            .iter()
            .map(|c| angle_diff_deg(c.orientation_deg, m.angle_deg))
            .collect::<Vec<f64>>(),
    );
    Some(m)
}

impl TrailModel {
    /// The direction settled on the lines `found` along the trails (within `SETTLE_DEG`; the
    /// line filter measures a long line's orientation to a tenth of a degree): their median
    /// orientation weighted by length (most of them are stars), where at least `MIN_TRAILS`.
    pub(super) fn settle(&mut self, found: &[Candidate]) {
        let mut off: Vec<(f64, f64)> = found
            .iter()
            .map(|c| {
                let d = (c.orientation_deg - self.angle_deg + 90.0).rem_euclid(180.0) - 90.0;
                (d, c.length_px)
            })
            .filter(|(d, _)| d.abs() <= SETTLE_DEG)
            .collect();
        if off.len() < MIN_TRAILS {
            return;
        }
        off.sort_by(|a, b| a.0.total_cmp(&b.0));
        let half = 0.5 * off.iter().map(|o| o.1).sum::<f64>();
        let mut run = 0.0;
        let d = off
            .iter()
            .find(|o| {
                run += o.1;
                run >= half
            })
            .map_or(0.0, |o| o.0);
        self.angle_deg = (self.angle_deg + d).rem_euclid(180.0);
    }

    /// Whether the model explains the line `c` as a star's trail: it lies along the trails
    /// within `ALONG_DEG` plus a short line's orientation uncertainty, atan(4 psf_sigma /
    /// length) as in the first pass. On the independent frames of `tests/own_trails.rs` this
    /// keeps 2 of 12 debris streaks 1.5-5 degrees off the trails, with 3 false boxes in 24
    /// frames; 2 psf_sigma: 4 of 12, 7 false boxes; 1 psf_sigma: 4 of 12, 18 (star trails
    /// cut short). The misses are lost before this test: with no trail subtracted, a streak
    /// a few degrees off crosses the trails along tens of pixels and joins them. Debris a degree or more off the trails is not explained; a line closer to
    /// them is a star's unless its length and profile say otherwise (`lone_line`). (Their length is no test here: in soig's survey frames trails
    /// often run across the whole frame, 1000 px in 1024, and every one is cut by its edge.)
    pub(super) fn explains(&self, c: &Candidate, psf_sigma: f64) -> bool {
        let slack = (4.0 * psf_sigma / c.length_px.max(1.0)).atan().to_degrees();
        angle_diff_deg(c.orientation_deg, self.angle_deg) <= ALONG_DEG + slack
    }
}

/// The distinct lines among the elongated features `feats`, each as its longest piece: a
/// feature within another's tolerance of its direction whose centroid lies within
/// `SAME_LINE_PX` of that one's axis is a piece of the same line (11 pieces of one faint debris
/// streak across a 1024 px frame outvoted 4 star trails as features).
fn lines<'a>(feats: &[&'a Feature]) -> Vec<&'a Feature> {
    let mut by_length = feats.to_vec();
    by_length.sort_by(|a, b| b.length.total_cmp(&a.length));
    let mut lines: Vec<&Feature> = Vec::new();
    for f in by_length {
        let same = lines.iter().any(|l| {
            let (s, c) = l.angle_deg.to_radians().sin_cos();
            let across = (-s * (f.cx - l.cx) + c * (f.cy - l.cy)).abs();
            angle_diff_deg(f.angle_deg, l.angle_deg) <= f.tolerance_deg() + l.tolerance_deg()
                && across <= SAME_LINE_PX
        });
        if !same {
            lines.push(f);
        }
    }
    lines
}

/// `z` (`w` wide) clipped to `CLIP_SIGMA`, in blocks of `BIN` x `BIN` (`bw` x `bh` of them)
/// summed, in unit noise (less the median, over the robust sigma).
fn binned(z: &[f32], w: usize, bw: usize, bh: usize) -> Vec<f32> {
    let mut b = vec![0f32; bw * bh];
    for y in 0..bh * BIN {
        let row = &z[y * w..y * w + bw * BIN];
        let out = &mut b[(y / BIN) * bw..(y / BIN + 1) * bw];
        for (o, block) in out.iter_mut().zip(row.chunks_exact(BIN)) {
            *o += block
                .iter()
                .map(|v| v.clamp(-CLIP_SIGMA, CLIP_SIGMA))
                .sum::<f32>();
        }
    }
    let (med, sd) = robust_stats(&b);
    let (med, inv) = (med as f32, 1.0 / sd.max(1e-6) as f32);
    b.iter_mut().for_each(|v| *v = (*v - med) * inv);
    b
}

/// The bright features of the binned map `z` (`w` x `h`): 8-connected pixels of at least
/// `FEATURE_SIGMA`, of at least `MIN_PIXELS`, in the frame's pixels.
fn features(z: &[f32], w: usize, h: usize) -> Vec<Feature> {
    let (label, roots) = label_components(
        w,
        h,
        |i| !(z[i].is_nan() || z[i] < FEATURE_SIGMA),
        |_, _| true,
    );
    // Per root, beside its moments: the sum of levels and whether it reaches the edge.
    let (mut levels, mut edges) = (vec![0f64; roots], vec![false; roots]);
    let moments = moments_by_label(&label, roots, w, h, |root, i, x, y| {
        levels[root] += z[i] as f64;
        edges[root] |= x == 0 || y == 0 || x + 1 == w || y + 1 == h;
    });
    // Block (i, j) covers the frame's pixels BIN i ..= BIN (i + 1) - 1.
    let b = BIN as f64;
    moments
        .iter()
        .enumerate()
        .filter(|(_, m)| m.n >= MIN_PIXELS)
        .map(|(root, m)| {
            let s = m.shape();
            Feature {
                level: levels[root] / m.n as f64,
                cx: b * s.cx + 0.5 * (b - 1.0),
                cy: b * s.cy + 0.5 * (b - 1.0),
                angle_deg: s.theta.to_degrees().rem_euclid(180.0),
                // A uniform line of length L has variance L^2 / 12 along it.
                length: b * (12.0 * s.major).sqrt(),
                width: b * s.minor.max(0.0).sqrt(),
                at_edge: edges[root],
            }
        })
        .collect()
}
