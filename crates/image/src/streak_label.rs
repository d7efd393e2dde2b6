//! Streak-shaped labels: the oriented box around a streak (Ultralytics' YOLO-OBB format) and
//! its two ends as keypoints (Ultralytics' pose format). The box is the axis-aligned label's
//! rule (`geometry::flux_box`: the tightest box of flux quantiles holding `LABEL_SHARE` of the
//! rendered streak) taken in the streak's own axes, along the line between its ends as the
//! truth gives them: its length and cross-section width are the rendered photons' (PSF, pixel
//! and pointing jitter together). An axis-aligned box around a long diagonal streak is mostly
//! background; this box follows the streak.

use crate::geometry::{BoxPx, Frame, LABEL_SHARE};

/// One streak's oriented box and ends, in the final frame's pixel-centre coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct StreakLabel {
    /// The box's corners, in order around it.
    pub corners: [[f64; 2]; 4],
    /// The ends of the streak's part inside the image, first then last in time, each with
    /// whether it is the streak's own end (else where the streak leaves the image); None when
    /// the streak's centre line misses the image (only its PSF wings land on it).
    pub ends: Option<[([f64; 2], bool); 2]>,
}

/// The range of t in [a, b] for which `lo <= s + t d + c <= hi` on both axes, for every offset
/// `c` of `offsets`; None when empty.
fn feasible(
    (s, d): ([f64; 2], [f64; 2]),
    offsets: &[[f64; 2]],
    (lo, hi): ([f64; 2], [f64; 2]),
    (mut a, mut b): (f64, f64),
) -> Option<(f64, f64)> {
    for c in offsets {
        for k in 0..2 {
            let (from, to) = (lo[k] - s[k] - c[k], hi[k] - s[k] - c[k]);
            if d[k].abs() < 1e-12 {
                if from > 0.0 || to < 0.0 {
                    return None;
                }
            } else {
                let (t0, t1) = (from / d[k], to / d[k]);
                a = a.max(t0.min(t1));
                b = b.min(t0.max(t1));
            }
        }
    }
    (a <= b).then_some((a, b))
}

/// Weighted values, sorted, with their running sums: quantiles by flux.
struct Quantiles {
    values: Vec<f64>,
    cumulative: Vec<f64>,
}

impl Quantiles {
    fn new(mut pairs: Vec<(f64, f64)>) -> Quantiles {
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut sum = 0.0;
        let cumulative = pairs
            .iter()
            .map(|p| {
                sum += p.1;
                sum
            })
            .collect();
        Quantiles {
            values: pairs.into_iter().map(|p| p.0).collect(),
            cumulative,
        }
    }

    /// The value below which `q` of the flux lies (the first reaching it).
    fn at(&self, q: f64) -> f64 {
        let total = self.cumulative.last().copied().unwrap_or(0.0);
        let i = self.cumulative.partition_point(|&c| c < q * total);
        self.values[i.min(self.values.len() - 1)]
    }
}

/// The box in axes (u along, n across) between the `t` and `1 - t` flux quantiles of each, with
/// the largest tail `t` for which it still holds `share` of the flux (as `flux_box`), each
/// edge half a pixel out from the pixel centres it bounds: (along, across) ranges.
fn quantile_box(pixels: &[(f64, f64, f64)], share: f64) -> Option<([f64; 2], [f64; 2])> {
    let total: f64 = pixels.iter().map(|p| p.2).sum();
    if pixels.is_empty() || total <= 0.0 {
        return None;
    }
    let along = Quantiles::new(pixels.iter().map(|p| (p.0, p.2)).collect());
    let across = Quantiles::new(pixels.iter().map(|p| (p.1, p.2)).collect());
    let range = |t: f64| {
        (
            [along.at(t), along.at(1.0 - t)],
            [across.at(t), across.at(1.0 - t)],
        )
    };
    let holds = |(s, r): ([f64; 2], [f64; 2])| {
        let within = |v: f64, [a, b]: [f64; 2]| v >= a && v <= b;
        let held: f64 = pixels
            .iter()
            .filter(|p| within(p.0, s) && within(p.1, r))
            .map(|p| p.2)
            .sum();
        held >= share * total
    };
    // Bisection on the tail: t = 0 holds everything.
    let (mut ok, mut bad) = (0.0, (1.0 - share).max(0.0));
    if holds(range(bad)) {
        ok = bad;
    } else {
        for _ in 0..40 {
            let mid = (ok + bad) / 2.0;
            if holds(range(mid)) {
                ok = mid;
            } else {
                bad = mid;
            }
        }
    }
    let (s, r) = range(ok);
    Some(([s[0] - 0.5, s[1] + 0.5], [r[0] - 0.5, r[1] + 0.5]))
}

/// The label of a streak from `start` to `end` (original pixel-centre coordinates, as the
/// truth's `streak_start_px` and `streak_end_px`) whose rendered photons are `flux` (pixel
/// centre x, y and count, original frame) on a `width` x `height` image, in the final
/// `frame`. The box's ends are drawn in where a corner would leave the image, so that
/// Ultralytics, which refuses coordinates off the image, reads it as drawn. Without flux or
/// such a box it is `fallback`, the axis-aligned label box in the final frame.
pub fn streak_label(
    (start, end): ([f64; 2], [f64; 2]),
    flux: &[(f64, f64, f64)],
    (width, height): (usize, usize),
    frame: &Frame,
    fallback: &BoxPx,
) -> StreakLabel {
    let bounds = ([-0.5, -0.5], [width as f64 - 0.5, height as f64 - 0.5]);
    let d = [end[0] - start[0], end[1] - start[1]];
    let len = d[0].hypot(d[1]);
    let finite = start.iter().chain(&end).all(|v| v.is_finite());
    // A point source (track mode): any direction; along +x.
    let u = if finite && len > 1e-9 {
        [d[0] / len, d[1] / len]
    } else {
        [1.0, 0.0]
    };
    let n = [-u[1], u[0]];
    let origin = if finite { start } else { [0.0, 0.0] };
    let axes: Vec<(f64, f64, f64)> = flux
        .iter()
        .filter(|p| p.2 > 0.0)
        .map(|&(x, y, w)| {
            let (dx, dy) = (x - origin[0], y - origin[1]);
            (dx * u[0] + dy * u[1], dx * n[0] + dy * n[1], w)
        })
        .collect();
    let map = |p: [f64; 2]| {
        let (x, y) = frame.map(p[0], p[1]);
        [x, y]
    };
    let fitted = quantile_box(&axes, LABEL_SHARE).and_then(|(s, r)| {
        // The centre line of the box, and its half-width across.
        let (mid, half) = ((r[0] + r[1]) / 2.0, (r[1] - r[0]) / 2.0);
        let line = ([origin[0] + mid * n[0], origin[1] + mid * n[1]], u);
        let side = |sign: f64| [sign * half * n[0], sign * half * n[1]];
        let (a, b) = feasible(line, &[side(1.0), side(-1.0)], bounds, (s[0], s[1]))?;
        let at = |t: f64, sign: f64| {
            let c = side(sign);
            map([line.0[0] + t * u[0] + c[0], line.0[1] + t * u[1] + c[1]])
        };
        Some([at(a, 1.0), at(b, 1.0), at(b, -1.0), at(a, -1.0)])
    });
    let corners = fitted.unwrap_or([
        [fallback.x_min, fallback.y_min],
        [fallback.x_max, fallback.y_min],
        [fallback.x_max, fallback.y_max],
        [fallback.x_min, fallback.y_max],
    ]);
    let ends = feasible((start, d), &[[0.0, 0.0]], bounds, (0.0, 1.0))
        .filter(|_| finite)
        .map(|(t0, t1)| {
            let at = |t: f64| map([start[0] + t * d[0], start[1] + t * d[1]]);
            [(at(t0), t0 == 0.0), (at(t1), t1 == 1.0)]
        });
    StreakLabel { corners, ends }
}

/// A coordinate of a `size`-pixel axis as Ultralytics reads it: normalised by the size from
/// the image's edge, held to [0, 1] against rounding at the edge.
fn normalised(v: f64, size: usize) -> f64 {
    ((v + 0.5) / size as f64).clamp(0.0, 1.0)
}

impl StreakLabel {
    /// The YOLO-OBB line `0 x1 y1 x2 y2 x3 y3 x4 y4` on a `width` x `height` final image.
    pub fn obb_line(&self, width: usize, height: usize) -> String {
        let mut line = String::from("0");
        for [x, y] in self.corners {
            line += &format!(" {:.6} {:.6}", normalised(x, width), normalised(y, height));
        }
        line + "\n"
    }

    /// The YOLO pose line: `label`'s box, then each end as `x y v` (v = 2 for the streak's own
    /// end, 1 where it leaves the image, and `0 0 0` for both when the centre line misses it).
    pub fn keypoint_line(&self, label: &BoxPx, width: usize, height: usize) -> String {
        let mut line = label.yolo_line(width, height).trim_end().to_string();
        match self.ends {
            Some(ends) => {
                for ([x, y], own) in ends {
                    let v = if own { 2 } else { 1 };
                    line += &format!(
                        " {:.6} {:.6} {v}",
                        normalised(x, width),
                        normalised(y, height)
                    );
                }
            }
            None => line += " 0 0 0 0 0 0",
        }
        line + "\n"
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::FrameKind;

    fn boxed() -> BoxPx {
        BoxPx {
            x_min: 1.0,
            y_min: 2.0,
            x_max: 3.0,
            y_max: 4.0,
        }
    }

    /// A streak from `a` to `b` through a Gaussian PSF of `sigma` px on a `w` x `h` image:
    /// 200 point samples, each pixel's flux at its centre.
    fn streak(
        a: [f64; 2],
        b: [f64; 2],
        sigma: f64,
        (w, h): (usize, usize),
    ) -> Vec<(f64, f64, f64)> {
        let mut flux = Vec::new();
        for j in 0..h {
            for i in 0..w {
                let (x, y) = (i as f64, j as f64);
                let f: f64 = (0..200)
                    .map(|k| {
                        let t = k as f64 / 199.0;
                        let (px, py) = (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]));
                        (-((x - px).powi(2) + (y - py).powi(2)) / (2.0 * sigma * sigma)).exp()
                    })
                    .sum();
                if f > 1e-9 {
                    flux.push((x, y, f));
                }
            }
        }
        flux
    }

    fn inside(c: &[[f64; 2]; 4], p: [f64; 2]) -> bool {
        let side = |k: usize| {
            let (a, b) = (c[k], c[(k + 1) % 4]);
            (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
        };
        (0..4).all(|k| side(k) >= 0.0) || (0..4).all(|k| side(k) <= 0.0)
    }

    fn share(c: &[[f64; 2]; 4], flux: &[(f64, f64, f64)]) -> f64 {
        let total: f64 = flux.iter().map(|p| p.2).sum();
        flux.iter()
            .filter(|p| inside(c, [p.0, p.1]))
            .map(|p| p.2)
            .sum::<f64>()
            / total
    }

    #[test]
    fn a_diagonal_streak_inside_the_image() {
        let frame = Frame::new(FrameKind::Original, 100, 100, 0, 0.0);
        let (a, b) = ([20.0, 20.0], [60.0, 50.0]);
        let flux = streak(a, b, 1.0, (100, 100));
        let l = streak_label((a, b), &flux, (100, 100), &frame, &boxed());
        // Along (0.8, 0.6): the long sides are parallel to the streak.
        let [c0, c1, c2, c3] = l.corners;
        let along = [c1[0] - c0[0], c1[1] - c0[1]];
        assert!(
            (along[0] * 0.6 - along[1] * 0.8).abs() < 1e-9,
            "{:?}",
            l.corners
        );
        let length = along[0].hypot(along[1]);
        let width = (c2[0] - c1[0]).hypot(c2[1] - c1[1]);
        // 50 px long plus the PSF past each end; +-2.6 sigma across (99% of a Gaussian),
        // in whole pixels plus half a pixel each side.
        assert!((52.0..58.0).contains(&length), "{length}");
        assert!((5.0..8.0).contains(&width), "{width}");
        assert!((c3[0] - c0[0] - (c2[0] - c1[0])).abs() < 1e-9);
        let held = share(&l.corners, &flux);
        assert!(held >= 0.99, "{held}");
        assert_eq!(l.ends, Some([(a, true), (b, true)]));
        assert_eq!(l.obb_line(100, 100).split(' ').count(), 9);
        assert_eq!(
            l.keypoint_line(&boxed(), 100, 100),
            "0 0.025000 0.035000 0.020000 0.020000 0.205000 0.205000 2 0.605000 0.505000 2\n"
        );
    }

    #[test]
    fn a_streak_leaving_the_image_is_drawn_in() {
        let frame = Frame::new(FrameKind::Original, 100, 80, 0, 0.0);
        let (a, b) = ([-30.0, 40.0], [150.0, 40.0]);
        let flux = streak(a, b, 2.0, (100, 80));
        let l = streak_label((a, b), &flux, (100, 80), &frame, &boxed());
        let xs: Vec<f64> = l.corners.iter().map(|c| c[0]).collect();
        assert!(
            (xs[0] + 0.5).abs() < 1e-9 && (xs[1] - 99.5).abs() < 1e-9,
            "{xs:?}"
        );
        let [(p, own_a), (q, own_b)] = l.ends.unwrap();
        assert!(!own_a && !own_b);
        assert!((p[0] + 0.5).abs() < 1e-9 && (q[0] - 99.5).abs() < 1e-9 && p[1] == 40.0);
        let line = l.obb_line(100, 80);
        assert!(
            line.trim()
                .split(' ')
                .skip(1)
                .all(|v| (0.0..=1.0).contains(&v.parse::<f64>().unwrap()))
        );
        // Along the edge: the box is drawn in to the image, and holds what the image holds.
        let edge = streak([-30.0, 1.0], [150.0, 1.0], 2.0, (100, 80));
        let e = streak_label(
            ([-30.0, 1.0], [150.0, 1.0]),
            &edge,
            (100, 80),
            &frame,
            &boxed(),
        );
        assert!(
            e.corners.iter().all(|c| c[1] >= -0.5 - 1e-9),
            "{:?}",
            e.corners
        );
        // No flux: the axis-aligned box; a centre line off the image: no ends.
        let off = streak_label(
            ([-30.0, -9.0], [150.0, -9.0]),
            &[],
            (100, 80),
            &frame,
            &boxed(),
        );
        assert_eq!(
            off.corners,
            [[1.0, 2.0], [3.0, 2.0], [3.0, 4.0], [1.0, 4.0]]
        );
        assert_eq!(off.ends, None);
        assert!(
            off.keypoint_line(&boxed(), 100, 80)
                .ends_with(" 0 0 0 0 0 0\n")
        );
    }

    #[test]
    fn the_rotated_frame_maps_the_box() {
        // A streak along the star-trail angle comes out horizontal in the rotated frame.
        let frame = Frame::new(FrameKind::Rotated, 120, 120, 0, 30.0);
        let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let (a, b) = (
            [60.0 - 40.0 * c, 60.0 - 40.0 * s],
            [60.0 + 40.0 * c, 60.0 + 40.0 * s],
        );
        let flux = streak(a, b, 1.0, (120, 120));
        let l = streak_label((a, b), &flux, (120, 120), &frame, &boxed());
        let [p, q, r, _] = l.corners;
        assert!(
            (p[1] - q[1]).abs() < 1e-9 && (q[0] - r[0]).abs() < 1e-9,
            "{:?}",
            l.corners
        );
        assert!(
            (82.0..88.0).contains(&(q[0] - p[0]).abs()),
            "{:?}",
            l.corners
        );
    }
}
