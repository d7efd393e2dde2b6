//! The light sources of a scene in the order photon mapping consumes its stream: field stars
//! (fixed on the detector, or along survey trails sampled on a time grid) and the debris'
//! trajectory samples, each with its expected photo-electrons and path over the exposure.

use rand::RngExt;
use serde::Serialize;
use soig_base::rng::PixelRng;

use super::Jitter;
use crate::scene::{Pointing, Scene, SurveyTrack, TargetTrack};
use crate::sensor::Sensor;
use soig_sky::photometry::photon_rate;
use soig_sky::projection::Tan;
use soig_sky::stars::Star;
use soig_sky::{Turn, Vec3, angle_deg, dot, radec_deg, radec_unit};

/// Spacing of the time nodes along a survey star trail, pixels.
pub(super) const SURVEY_NODE_SPACING_PX: f64 = 4.0;
/// Nodes projected beyond those of a survey star that can be near the image, on each side:
/// `Path::at` over the star's exposure reads at most two beyond its near ones (the node before
/// the first and after the last, and a time's rounding one more); three to spare.
const NODE_MARGIN: usize = 3;

/// A star as traced in an image.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct TracedStar {
    pub ra_deg: f64,
    pub dec_deg: f64,
    pub mag: f64,
    /// Mean pixel coordinates over the exposure (0-based, pixel centres at integers): the
    /// nominal position plus the mean jitter shift, where the FITS WCS puts the star.
    pub x: f64,
    pub y: f64,
    pub expected_electrons: f64,
}

/// Where a source is over its share of the exposure, before jitter and PSF.
#[derive(Clone, Copy)]
pub(super) enum Path<'a> {
    /// Fixed on the detector (a star under fixed pointing).
    Still { x: f64, y: f64 },
    /// A survey star trail, linear between nodes `step` seconds apart.
    Trail { nodes: &'a [(f64, f64)], step: f64 },
    /// A debris trajectory sample: all its photons arrive at `t`.
    Instant { t: f64, x: f64, y: f64 },
}

impl Path<'_> {
    pub(super) fn at(&self, t: f64) -> (f64, f64) {
        match *self {
            Path::Still { x, y } | Path::Instant { x, y, .. } => (x, y),
            Path::Trail { nodes, step } => {
                let u = t / step;
                let i = (u as usize).min(nodes.len() - 2);
                let f = u - i as f64;
                let (p, q) = (nodes[i], nodes[i + 1]);
                (p.0 + f * (q.0 - p.0), p.1 + f * (q.1 - p.1))
            }
        }
    }
}

/// The time grid of a turning pointing's star trails: each node's camera turn (None: not
/// turned), and how far from the tangent point a direction can lie and still be near the
/// image (`far_deg` at some node, `cos_reach` at a given one).
struct TrailGrid {
    turns: Vec<Option<Turn>>,
    step: f64,
    centre: Vec3,
    far_deg: f64,
    cos_reach: f64,
}

impl TrailGrid {
    /// A star's trail: its nodes written into `trail` (`dirs` is scratch, one per node), and
    /// the part of the exposure (t_a, t_b) while it is near the image; None where it is near
    /// at no node.
    fn trace(
        &self,
        star: &Star,
        tan: &Tan,
        near: &impl Fn(f64, f64) -> bool,
        dirs: &mut [Vec3],
        trail: &mut [(f64, f64)],
    ) -> Option<(f64, f64)> {
        let nodes = trail.len();
        let (mut first, mut last) = (None, None);
        let v = radec_unit(star.ra_deg, star.dec_deg);
        if angle_deg(v, self.centre) > self.far_deg {
            return None;
        }
        let (mut lo, mut hi) = (None, None);
        for (i, (dir, turn)) in dirs.iter_mut().zip(&self.turns).enumerate() {
            *dir = match turn {
                Some(turn) => turn.apply(v),
                None => v,
            };
            if dot(*dir, self.centre) >= self.cos_reach {
                lo.get_or_insert(i);
                hi = Some(i);
            }
        }
        let (Some(lo), Some(hi)) = (lo, hi) else {
            return None;
        };
        // Projected from `NODE_MARGIN` nodes before the first that can be near to as
        // many after the last: every node a photon's time reads (`Path::at` between
        // the node before the first near one and the node after the last) and
        // `render::trails` keeps; the others are never read (NaN, as off the sky).
        let range = lo.saturating_sub(NODE_MARGIN)..=(hi + NODE_MARGIN).min(nodes - 1);
        for (i, (node, turn)) in trail.iter_mut().zip(&self.turns).enumerate() {
            if !range.contains(&i) {
                *node = (f64::NAN, f64::NAN);
                continue;
            }
            // `Scene::pixel_at`, to the bit.
            let (ra, dec) = match turn {
                Some(_) => radec_deg(dirs[i]),
                None => (star.ra_deg, star.dec_deg),
            };
            *node = tan.pixel(ra, dec).unwrap_or((f64::NAN, f64::NAN));
            if near(node.0, node.1) {
                first.get_or_insert(i);
                last = Some(i);
            }
        }
        let (Some(a), Some(b)) = (first, last) else {
            return None;
        };
        // One node of slack on each side covers a trail entering between nodes.
        let t_a = a.saturating_sub(1) as f64 * self.step;
        let t_b = ((b + 1).min(nodes - 1)) as f64 * self.step;
        Some((t_a, t_b))
    }
}

/// One light source of the scene: its expected photo-electrons, arriving uniformly over
/// [t_a, t_b) along `path` (or all at once for a debris sample).
pub(super) struct Source<'a> {
    pub(super) expected: f64,
    pub(super) path: Path<'a>,
    pub(super) t_a: f64,
    pub(super) t_b: f64,
    pub(super) debris: bool,
}

impl Source<'_> {
    /// Arrival time of one photon.
    pub(super) fn arrival(&self, rng: &mut PixelRng) -> f64 {
        match self.path {
            Path::Instant { t, .. } => t,
            _ if self.t_b > self.t_a => rng.random_range(self.t_a..self.t_b),
            _ => self.t_a,
        }
    }
}

/// Every source of a scene that can put photons in the image, in a fixed order (the order
/// in which photon mapping consumes its stream), and the stars as traced.
pub(super) fn for_each_source(
    sensor: &Sensor,
    scene: &Scene,
    jitter: &Jitter,
    mut add: impl FnMut(&Source),
) -> Vec<TracedStar> {
    let s = sensor;
    let (width, height) = (s.width_px as f64, s.height_px as f64);
    let tan = scene.projection(sensor);
    let scale = tan.scale_deg;
    // The core's sigma: a seeing PSF's wing beyond 8 of them (3.4 FWHM) holds at most 2 % of
    // a star's light (beta 2.5; 0.01 % at 4.765), and the star is outside the image.
    let psf_px = scene.psf(sensor).core_sigma_px();
    let t_exp = scene.exposure.exposure_s;
    let jitter_mean = jitter.mean();

    // Stars too far outside the image for any photon to land are skipped, and in survey
    // images a star is exposed only while its trail is in the field (no work a scene does not
    // need).
    let margin = 8.0 * psf_px + jitter.max_excursion() + 1.0;
    let near = |x: f64, y: f64| {
        x > -0.5 - margin
            && y > -0.5 - margin
            && x < width - 0.5 + margin
            && y < height - 0.5 + margin
    };
    let mut traced = Vec::new();
    // A star exposed from `t_a` to `t_b` on `path`, traced at (x, y) (before jitter).
    let mut star_source = |star: &Star, (x, y): (f64, f64), path: Path<'_>, t_a: f64, t_b: f64| {
        let expected = photon_rate(star.mag, s.zero_point_mag) * (t_b - t_a);
        traced.push(TracedStar {
            ra_deg: star.ra_deg,
            dec_deg: star.dec_deg,
            mag: star.mag,
            x: x + jitter_mean.0,
            y: y + jitter_mean.1,
            expected_electrons: expected,
        });
        add(&Source {
            expected,
            path,
            t_a,
            t_b,
            debris: false,
        });
    };
    match &scene.exposure.pointing {
        Pointing::Fixed { .. } => {
            // Fixed on the sky, photons uniform over the exposure.
            for star in &scene.exposure.stars {
                let Some((x0, y0)) = tan.pixel(star.ra_deg, star.dec_deg) else {
                    continue;
                };
                if !near(x0, y0) {
                    continue;
                }
                star_source(star, (x0, y0), Path::Still { x: x0, y: y0 }, 0.0, t_exp);
            }
        }
        Pointing::Survey(SurveyTrack { drift_deg, .. })
        | Pointing::Track(TargetTrack { drift_deg, .. }) => {
            // Each star's trail is sampled on a time grid fine enough that linear interpolation
            // between nodes is exact to well under 0.01 px (the trail is straight to second
            // order in the drift), and every photon takes the position of its arrival time.
            let drift_px = drift_deg / scale;
            let nodes = ((drift_px / SURVEY_NODE_SPACING_PX).ceil() as usize + 1).max(2);
            let step = t_exp / (nodes - 1) as f64;
            let mut trail = vec![(f64::NAN, f64::NAN); nodes];
            // The camera's turn at each node, once for all stars (its sines and cosines were
            // most of this loop's work when taken per star); None: not turned.
            let turns: Vec<Option<Turn>> = (0..nodes)
                .map(|i| match &scene.exposure.pointing {
                    Pointing::Survey(t) => Some(t.turn_back(i as f64 * step)),
                    Pointing::Track(t) => t.turn_back(i as f64 * step),
                    Pointing::Fixed { .. } => unreachable!("a fixed pointing has no trails"),
                })
                .collect();
            // A star farther from the tangent point than the near rectangle's reach plus the
            // largest turn is near at no node (a turn moves a direction by at most its angle):
            // it is passed over before its nodes are traced (more than half the catalogue's
            // stars of a survey image). Two pixels of slack cover the rounding.
            let centre = radec_unit(tan.ra0_deg, tan.dec0_deg);
            let turned = turns
                .iter()
                .flatten()
                .map(|t| t.angle().abs())
                .fold(0.0, f64::max);
            let (x0, y0) = (-0.5 - margin - 2.0, -0.5 - margin - 2.0);
            let (x1, y1) = (width - 0.5 + margin + 2.0, height - 0.5 + margin + 2.0);
            let reach_deg = tan.reach_deg([x0, x1], [y0, y1]);
            let far_deg = reach_deg + turned.to_degrees();
            // The same test node by node, as a dot product: a node whose direction lies
            // farther than `reach_deg` from the tangent point is near no pixel, and only the
            // nodes around those that can be near are projected (the arc tangents and sines of
            // the projection were most of this loop; over half a survey star's nodes lie off
            // the image). The two pixels of slack in `reach_deg` cover the rounding.
            let cos_reach = reach_deg.to_radians().cos();
            let grid = TrailGrid {
                turns,
                step,
                centre,
                far_deg,
                cos_reach,
            };
            let mut dirs: Vec<Vec3> = vec![[0.0; 3]; nodes];
            for star in &scene.exposure.stars {
                let Some((t_a, t_b)) = grid.trace(star, &tan, &near, &mut dirs, &mut trail) else {
                    continue;
                };
                let pixel = tan
                    .pixel(star.ra_deg, star.dec_deg)
                    .unwrap_or((f64::NAN, f64::NAN));
                let path = Path::Trail {
                    nodes: &trail,
                    step,
                };
                star_source(star, pixel, path, t_a, t_b);
            }
        }
    }

    // Debris: each trajectory sample is a source whose photons arrive at its time.
    for p in &scene.object.trajectory {
        if near(p.x_px, p.y_px) {
            add(&Source {
                expected: p.expected_electrons,
                path: Path::Instant {
                    t: p.t_s,
                    x: p.x_px,
                    y: p.y_px,
                },
                t_a: p.t_s,
                t_b: p.t_s,
                debris: true,
            });
        }
    }
    traced
}
