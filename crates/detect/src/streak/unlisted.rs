//! Stars the catalogue did not list, or misplaced: the star-aware pass drops a line only where
//! a predicted trail explains it, so every trail a catalogue lacks (a star it missed, one
//! placed an arcsecond off) would be reported as debris. But every star drifts alike over the
//! exposure: a star's trail lies along the trails' direction and is as long as theirs, or
//! shorter where the frame's edge cuts it. A line that fits that shape is a star's, listed or
//! not; debris along the trails is kept when its length or its ends tell it apart (longer than
//! a trail, or shorter with both ends inside the frame).
//!
//! Measured with `python3 scripts/catalog-robustness.py --images 40 --seed 7001` (40 images of
//! paper-survey-original, a development seed; results/catalog-robustness.md); the rules for
//! where a trail really ends (`TrailShape::of`, `EDGE_MARGIN_PX`, `goes_on`) on seeds 7001 and 7002 (50).

use super::lone_line::{profile, profile_at};
use super::output::Candidate;
use super::segment::angle_diff_deg;
use super::sky::StarTrail;
use super::stats::median_of;

/// A line within this many degrees of the trails near it (plus its orientation uncertainty,
/// atan(2 psf_sigma / length)) lies along them. The trails' direction turns across a wide field
/// (the unlisted trails of the robustness run lay up to 0.4 degrees from the mean direction),
/// so a line is held against the `NEAREST` predicted trails around it; a debris streak 0.55
/// degrees off the trails, across the whole frame, was taken for a star with 1 degree
/// from the mean direction.
const ALONG_DEG: f64 = 0.3;
const NEAREST: usize = 3;
/// A half-level end this close to the frame's edge (pixels, along the line) may be where the edge
/// cuts a trail: the detector's ends of trails that leave the frame lay up to 37 px inside it (a
/// trail's last pixels, under the background mesh's edge cells, fall below half its level). At
/// 40, a catalogue missing 10% of its stars gave 7 false boxes in 40 images, at 48 two; the
/// price: debris ending 42 px inside the frame along a trail's direction and shorter than a
/// trail is taken for a cut trail (`tests_sky`).
const EDGE_PX: f64 = 48.0;
/// ... or comes within this many pixels of the edge there: a trail at a shallow angle to an
/// edge fades before it reaches it (the background mesh's edge cells, the smoothing's mirrored
/// edge): one at 11.6 degrees to the top edge lost its last 55 px, within 16 px of it, and
/// carried on 48 px its detected end came to 6.4 px from the edge.
const EDGE_MARGIN_PX: f64 = 8.0;
/// A whole trail's measured length is the predicted one within this share plus 4 psf sigmas
/// (half-level ends; measured 0.2-4.2% short on the robustness run; at 6%, debris 430 px long
/// beside a 400 px trail, `tests_sky`, was taken for one).
const LENGTH_SHARE: f64 = 0.05;
/// A line's light goes on beyond an end where the `BEYOND_PX` beyond it hold at least
/// `GOES_ON` of its level (`goes_on`).
const BEYOND_PX: f64 = 64.0;
const GOES_ON: f64 = 0.5;

/// The stars' trail shape in an image: the direction, and the length of a trail the frame does
/// not cut (None when every predicted trail is cut: the drift is longer than the frame).
pub(super) struct TrailShape {
    angle_deg: f64,
    length_px: Option<f64>,
    /// Each predicted trail's chord: midpoint and direction (degrees), where it has one.
    chords: Vec<([f64; 2], f64)>,
}

impl TrailShape {
    /// From the predicted trails `stars` in a `w` x `h` image: the median chord of the trails
    /// whose ends both lie inside (`EDGE_PX`) and, where their nodes carry times, whose nodes
    /// span the whole exposure (the earliest to the latest node time of any trail). A trail's
    /// nodes are those on the image: one leaving it across an edge it runs nearly along ends
    /// a few pixels inside, where `runs_out` does not see a cut (on a survey image whose trails
    /// were 1572 px long, a 279 px piece along its right edge was the only "whole" trail, and a
    /// missed star's trail 707 px long, cut by the bottom edge, was taken for debris).
    pub(super) fn of(stars: &[StarTrail], angle_deg: f64, w: usize, h: usize) -> TrailShape {
        let timed = |t: &StarTrail| t.times_s.len() == t.nodes.len() && !t.nodes.is_empty();
        let (t_lo, t_hi) = stars
            .iter()
            .filter(|t| timed(t))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| {
                (lo.min(t.times_s[0]), hi.max(t.times_s[t.times_s.len() - 1]))
            });
        // Node times are the exposure's grid: a whole trail's first and last are its ends.
        let slack = 1e-9 * (t_hi - t_lo).abs().max(1.0);
        let spans = |t: &StarTrail| {
            !timed(t)
                || (t.times_s[0] <= t_lo + slack && t.times_s[t.times_s.len() - 1] >= t_hi - slack)
        };
        let mut whole: Vec<f64> = stars
            .iter()
            .filter_map(|t| {
                let (a, b) = (t.nodes.first()?, t.nodes.last()?);
                let (a, b) = ([a.0, a.1], [b.0, b.1]);
                let chord = (b[0] - a[0]).hypot(b[1] - a[1]);
                // A star seen at one node (entering at a corner) has no length to tell.
                let whole = chord > 1.0
                    && !runs_out(a, b, w, h, 0.0)
                    && !runs_out(b, a, w, h, 0.0)
                    && spans(t);
                whole.then_some(chord)
            })
            .collect();
        whole.sort_by(f64::total_cmp);
        let chords = stars
            .iter()
            .filter_map(|t| {
                let (a, b) = (t.nodes.first()?, t.nodes.last()?);
                let (dx, dy) = (b.0 - a.0, b.1 - a.1);
                (dx.hypot(dy) > 1.0).then(|| {
                    let mid = [0.5 * (a.0 + b.0), 0.5 * (a.1 + b.1)];
                    (mid, dy.atan2(dx).to_degrees().rem_euclid(180.0))
                })
            })
            .collect();
        TrailShape {
            angle_deg,
            length_px: whole.get(whole.len() / 2).copied(),
            chords,
        }
    }

    /// The trails' direction near `p`: the doubled-angle mean of the `NEAREST` chords' (the
    /// given direction where the trails have no chord).
    fn direction_near(&self, p: [f64; 2]) -> f64 {
        let mut by_distance: Vec<(f64, f64)> = self
            .chords
            .iter()
            .map(|(m, a)| ((m[0] - p[0]).hypot(m[1] - p[1]), *a))
            .collect();
        if by_distance.is_empty() {
            return self.angle_deg;
        }
        by_distance.sort_by(|x, y| x.0.total_cmp(&y.0));
        let (c, s) = by_distance
            .iter()
            .take(NEAREST)
            .fold((0.0, 0.0), |(c, s), (_, a)| {
                let t = 2.0 * a.to_radians();
                (c + t.cos(), s + t.sin())
            });
        (s.atan2(c) / 2.0).to_degrees().rem_euclid(180.0)
    }

    /// Whether the line `c` has a star trail's shape: along the trails, and as long as a whole
    /// trail, or shorter with an end where the frame's edge may cut it, or beyond which its
    /// light goes on (`goes_on`) on the unit-noise map `z` (`w` x `h`).
    pub(super) fn fits(
        &self,
        c: &Candidate,
        psf_sigma: f64,
        z: &[f32],
        w: usize,
        h: usize,
    ) -> bool {
        let slack = (2.0 * psf_sigma / c.length_px.max(1.0)).atan().to_degrees();
        let mid = [
            0.5 * (c.ends[0][0] + c.ends[1][0]),
            0.5 * (c.ends[0][1] + c.ends[1][1]),
        ];
        if angle_diff_deg(c.orientation_deg, self.direction_near(mid)) > ALONG_DEG + slack {
            return false;
        }
        let [a, b] = c.ends;
        let m = EDGE_MARGIN_PX;
        // Read only where the length leaves it open: `goes_on` reads two profiles on the map.
        let cut = || runs_out(a, b, w, h, m) || runs_out(b, a, w, h, m) || goes_on(c, z, w, h);
        match self.length_px {
            Some(l) => {
                let tol = LENGTH_SHARE * l + 4.0 * psf_sigma;
                c.length_px <= l + tol && (c.length_px >= l - tol || cut())
            }
            // Every trail runs off the frame: a star's line has an end at its edge.
            None => cut(),
        }
    }
}

/// Whether the light of the line `c` goes on beyond one of its ends along it: over the
/// `BEYOND_PX` beyond (on the frame), the median of the unit-noise map `z` (`w` x `h`) across
/// -1..1 px is at least `GOES_ON` of the line's own median. The end is then no end of the light
/// but where the detector lost it (beside a listed trail, or under its subtraction), as where
/// the frame's edge cuts a trail: a star trail the catalogue missed, 460 px long with both of
/// its detected ends inside the frame, went on at its level for another 480 px to the frame's
/// edge. A debris streak ends where its light does.
fn goes_on(c: &Candidate, z: &[f32], w: usize, h: usize) -> bool {
    let level = median_of(&profile(c, z, w, h));
    if level.is_nan() || level <= 0.0 {
        return false;
    }
    let [a, b] = c.ends;
    [(a, b), (b, a)].iter().any(|&(end, from)| {
        let (dx, dy) = (end[0] - from[0], end[1] - from[1]);
        let l = dx.hypot(dy).max(1e-9);
        let far = [end[0] + BEYOND_PX * dx / l, end[1] + BEYOND_PX * dy / l];
        let inside =
            |q: [f64; 2]| q[0] >= 0.0 && q[1] >= 0.0 && q[0] <= w as f64 && q[1] <= h as f64;
        if !inside(far) {
            return false;
        }
        let beyond = profile_at(end, far, 0.0, 0.0, z, w, h);
        !beyond.is_empty() && median_of(&beyond) >= GOES_ON * level
    })
}

/// Whether the line from `from` to `end` (pixel-edge coordinates), carried on `EDGE_PX` beyond
/// `end`, leaves the frame or comes within `m` px of its edge (`EDGE_MARGIN_PX` for a line the
/// detector found; 0 for a predicted trail, whose nodes run to the frame's edge): `end` may be where the
/// frame's edge cuts it. (A line running along an edge, farther from it, is not cut by it.)
fn runs_out(end: [f64; 2], from: [f64; 2], w: usize, h: usize, m: f64) -> bool {
    let (dx, dy) = (end[0] - from[0], end[1] - from[1]);
    let l = dx.hypot(dy).max(1e-9);
    let q = [end[0] + EDGE_PX * dx / l, end[1] + EDGE_PX * dy / l];
    q[0] < m || q[1] < m || q[0] > w as f64 - m || q[1] > h as f64 - m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Detection;

    fn line(ends: [[f64; 2]; 2]) -> Candidate {
        let (dx, dy) = (ends[1][0] - ends[0][0], ends[1][1] - ends[0][1]);
        Candidate {
            detection: Detection {
                x1: 0.0,
                y1: 0.0,
                x2: 1.0,
                y2: 1.0,
                score: 0.9,
                class: 0,
            },
            ends,
            length_px: dx.hypot(dy),
            orientation_deg: dy.atan2(dx).to_degrees().rem_euclid(180.0),
            elongation: 10.0,
            flux: 0.0,
            snr: 10.0,
        }
    }

    fn trail(a: (f64, f64), b: (f64, f64)) -> StarTrail {
        StarTrail {
            nodes: vec![a, b],
            times_s: Vec::new(),
            electrons: 1.0,
        }
    }

    /// Horizontal trails 300 px long in a 1000 px frame, one cut by the left edge: a line along
    /// them of their length, or shorter at the edge, is a star's; one shorter inside the frame,
    /// longer, or 1 degree off is not.
    #[test]
    fn a_star_trail_has_the_trails_direction_and_length() {
        let stars = [
            trail((100.0, 100.0), (400.0, 100.0)),
            trail((500.0, 600.0), (800.0, 600.0)),
            trail((300.0, 300.0), (600.0, 300.0)),
            trail((0.0, 800.0), (150.0, 800.0)),
        ];
        let shape = TrailShape::of(&stars, 0.0, 1000, 1000);
        assert_eq!(shape.length_px, Some(300.0));
        // A dark map: no line's light goes on beyond its ends.
        let z = vec![0f32; 1000 * 1000];
        let fits = |ends| shape.fits(&line(ends), 1.5, &z, 1000, 1000);
        assert!(fits([[200.0, 500.0], [498.0, 500.2]]));
        assert!(fits([[2.0, 900.0], [120.0, 900.0]]), "cut by the edge");
        assert!(
            !fits([[200.0, 500.0], [350.0, 500.0]]),
            "half a trail, both ends inside"
        );
        assert!(
            !fits([[100.0, 500.0], [600.0, 500.0]]),
            "longer than a trail"
        );
        let off = 300.0 * 1f64.to_radians().tan();
        assert!(
            !fits([[200.0, 500.0], [500.0, 500.0 + off]]),
            "1 degree off"
        );
        // Trails longer than the frame: only a line with an end at the edge is a star's.
        let long = TrailShape::of(&[trail((0.0, 10.0), (999.0, 10.0))], 0.0, 1000, 1000);
        assert_eq!(long.length_px, None);
        assert!(long.fits(&line([[1.0, 500.0], [700.0, 500.0]]), 1.5, &z, 1000, 1000));
        assert!(!long.fits(&line([[100.0, 500.0], [700.0, 500.0]]), 1.5, &z, 1000, 1000));
    }
}
