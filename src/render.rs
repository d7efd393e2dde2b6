//! Photon mapping (paper 2.2, 3.2.4-3.2.6): expected photons per source (Eq. 3), a Poisson
//! draw, arrival times, Brownian jitter shared by every source (Eq. 2), a Gaussian PSF, the
//! gnomonic projection, counting per pixel (one pixel convention, see `sky::projection`), and
//! the detector (Eq. 11). Also the label box and the truth of the debris as rendered.
//! It reads the sensor and its own settings, never the campaign file.

use rand::RngExt;
use rand_chacha::ChaCha12Rng;
use rand_distr::StandardNormal;
use serde::Serialize;

use crate::background::RealFrame;
use crate::geometry::{BoxPx, Frame, LABEL_SHARE, flux_box};
use crate::rng::poisson;
use crate::scene::{Pointing, Scene};
use crate::sensor::Sensor;
use crate::sky::photometry::photon_rate;

pub mod expected;

/// Above this many packets per source the packet weight grows so that no source traces more
/// (only reached by sources far brighter than a scene allows, e.g. a magnitude -1 star). The
/// debris counts as one source: its trajectory samples share this budget.
pub const MAX_PACKETS_PER_SOURCE: u64 = 50_000_000;

/// Spacing of the time nodes along a survey star trail, pixels.
const SURVEY_NODE_SPACING_PX: f64 = 4.0;

/// How photons reach the detector: `photon_mapping` (the paper's Monte Carlo, with the
/// merging approximation) or `expected` (each source's expected photons per pixel, then one
/// Poisson draw per pixel).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, Serialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum RenderMethod {
    #[default]
    PhotonMapping,
    Expected,
}

impl RenderMethod {
    pub fn is_photon_mapping(&self) -> bool {
        *self == RenderMethod::PhotonMapping
    }

    /// The name a campaign file uses.
    pub fn name(&self) -> &'static str {
        match self {
            RenderMethod::PhotonMapping => "photon_mapping",
            RenderMethod::Expected => "expected",
        }
    }
}

/// The renderer's approximation knobs.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub method: RenderMethod,
    /// Sources with more photons than this are traced in packets of `merge_factor` photons.
    pub merge_threshold: u64,
    pub merge_factor: u32,
    /// Steps of the Brownian jitter path over the exposure.
    pub jitter_steps: usize,
}

/// The truth of one image, written as the JSON sidecar.
#[derive(Clone, Debug, Serialize)]
pub struct Truth {
    pub image_index: u64,
    pub object: String,
    pub norad: u64,
    /// UTC start of the exposure (ISO 8601).
    pub start_utc: String,
    pub exposure_s: f64,
    pub pointing: Pointing,
    /// Mean pointing-jitter shift of every source over the exposure, pixels. The FITS WCS
    /// includes it (CRPIX is moved by it), as an astrometric fit of the image would.
    pub jitter_mean_px: [f64; 2],
    /// Pixel coordinates of the debris at the first and last trajectory samples, jitter
    /// included (may lie outside the image).
    pub streak_start_px: [f64; 2],
    pub streak_end_px: [f64; 2],
    /// The label box of the debris as rendered, in the original image (None when no debris
    /// photon landed).
    pub label_box_px: Option<BoxPx>,
    /// The frame of the final PNG (original, padded or rotated) and the label box in it.
    pub frame: Option<Frame>,
    pub label_box_final_px: Option<BoxPx>,
    pub magnitude: f64,
    pub magnitude_min: f64,
    pub magnitude_max: f64,
    pub area_m2: f64,
    pub range_km: f64,
    pub phase_angle_deg: f64,
    pub earth_angle_deg: f64,
    pub sun_angle_deg: f64,
    pub moon_angle_deg: f64,
    pub tumble: Option<crate::scene::Tumble>,
    pub expected_debris_electrons: f64,
    pub rendered_debris_electrons: u64,
    pub snr: f64,
    pub stars_in_cone: usize,
    pub stars_traced: usize,
    pub background_sigma_adu: f64,
    /// The real frame of a semisynthetic image.
    pub background_frame: Option<String>,
    pub attempts: u32,
    pub rejections: std::collections::BTreeMap<&'static str, u32>,
}

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

/// A rendered exposure.
pub struct Exposure {
    pub width: usize,
    pub height: usize,
    /// Noise-free image: photo-electrons per pixel from all sources.
    pub electrons: Vec<u32>,
    /// Noise-free photo-electrons of the debris alone, for its label box in any frame.
    pub debris_electrons: Vec<u32>,
    /// Noisy image in ADU (Eq. 11).
    pub adu: Vec<f32>,
    pub truth: Truth,
    pub stars: Vec<TracedStar>,
}

/// The shared Brownian pointing jitter, as pixel shifts of every source, on a regular time grid.
pub struct Jitter {
    dt: f64,
    shift: Vec<(f64, f64)>,
}

impl Jitter {
    /// The jitter path of a scene, drawn first from the photon stream.
    pub fn of_scene(
        sensor: &Sensor,
        settings: &Settings,
        scene: &Scene,
        rng: &mut ChaCha12Rng,
    ) -> Jitter {
        Jitter::draw(
            rng,
            sensor.jitter_deg_per_sqrt_s,
            scene.exposure_s,
            settings.jitter_steps,
            scene.projection(sensor).scale_deg,
        )
    }

    /// Steps of the path.
    pub fn steps(&self) -> usize {
        self.shift.len() - 1
    }

    /// The same Brownian path seen on a coarser grid of `steps` steps (its values at every
    /// k-th node, linear in between), as a simulation with fewer jitter steps would draw it.
    /// None unless `steps` divides the path's steps.
    pub fn coarsened(&self, steps: usize) -> Option<Jitter> {
        let n = self.steps();
        if steps == 0 || !n.is_multiple_of(steps) {
            return None;
        }
        let k = n / steps;
        Some(Jitter {
            dt: self.dt * k as f64,
            shift: self.shift.iter().step_by(k).copied().collect(),
        })
    }

    fn draw(
        rng: &mut ChaCha12Rng,
        sigma_deg_sqrt_s: f64,
        exposure_s: f64,
        steps: usize,
        scale_deg: f64,
    ) -> Jitter {
        let dt = exposure_s / steps as f64;
        let step_px = sigma_deg_sqrt_s * dt.sqrt() / scale_deg;
        let mut shift = Vec::with_capacity(steps + 1);
        let (mut x, mut y) = (0.0, 0.0);
        shift.push((x, y));
        for _ in 0..steps {
            // The pointing moves by (dA, dD); the sky, and every source on it, moves the other way.
            let da: f64 = rng.sample(StandardNormal);
            let dd: f64 = rng.sample(StandardNormal);
            x -= da * step_px;
            y -= dd * step_px;
            shift.push((x, y));
        }
        Jitter { dt, shift }
    }

    /// Linear interpolation between grid points.
    fn at(&self, t: f64) -> (f64, f64) {
        let u = (t / self.dt).max(0.0);
        let i = (u as usize).min(self.shift.len() - 2);
        let f = (u - i as f64).min(1.0);
        let (a, b) = (self.shift[i], self.shift[i + 1]);
        (a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1))
    }

    /// Time average of the shift over the exposure (trapezoid rule on the grid).
    fn mean(&self) -> (f64, f64) {
        let n = self.shift.len() - 1;
        let (mut x, mut y) = (0.0, 0.0);
        for w in self.shift.windows(2) {
            x += (w[0].0 + w[1].0) / 2.0;
            y += (w[0].1 + w[1].1) / 2.0;
        }
        (x / n as f64, y / n as f64)
    }

    fn max_excursion(&self) -> f64 {
        self.shift
            .iter()
            .map(|(x, y)| x.abs().max(y.abs()))
            .fold(0.0, f64::max)
    }
}

/// Photon counts on the detector, all sources and debris alone.
struct Canvas {
    width: usize,
    height: usize,
    electrons: Vec<u32>,
    debris: Vec<u32>,
    debris_total: u64,
}

impl Canvas {
    fn add(&mut self, x: f64, y: f64, weight: u32, debris: bool) {
        // Pixel = floor(coordinate + 0.5); the image spans [-0.5, n - 0.5).
        let (px, py) = ((x + 0.5).floor(), (y + 0.5).floor());
        if px < 0.0 || py < 0.0 || px >= self.width as f64 || py >= self.height as f64 {
            return;
        }
        let k = py as usize * self.width + px as usize;
        self.electrons[k] = self.electrons[k].saturating_add(weight);
        if debris {
            self.debris[k] = self.debris[k].saturating_add(weight);
            self.debris_total += weight as u64;
        }
    }
}

/// Where a source is over its share of the exposure, before jitter and PSF.
#[derive(Clone, Copy)]
enum Path<'a> {
    /// Fixed on the detector (a star under fixed pointing).
    Still { x: f64, y: f64 },
    /// A survey star trail, linear between nodes `step` seconds apart.
    Trail { nodes: &'a [(f64, f64)], step: f64 },
    /// A debris trajectory sample: all its photons arrive at `t`.
    Instant { t: f64, x: f64, y: f64 },
}

impl Path<'_> {
    fn at(&self, t: f64) -> (f64, f64) {
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

/// One light source of the scene: its expected photo-electrons, arriving uniformly over
/// [t_a, t_b) along `path` (or all at once for a debris sample).
struct Source<'a> {
    expected: f64,
    path: Path<'a>,
    t_a: f64,
    t_b: f64,
    debris: bool,
}

impl Source<'_> {
    /// Arrival time of one photon.
    fn arrival(&self, rng: &mut ChaCha12Rng) -> f64 {
        match self.path {
            Path::Instant { t, .. } => t,
            _ if self.t_b > self.t_a => rng.random_range(self.t_a..self.t_b),
            _ => self.t_a,
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
fn trace(
    canvas: &mut Canvas,
    rng: &mut ChaCha12Rng,
    count: u64,
    merge: (u64, u32),
    max_packets: u64,
    jitter: &Jitter,
    psf_px: f64,
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
    for n in 0..packets + singles + tail {
        let t = source.arrival(rng);
        let (x0, y0) = source.path.at(t);
        let (jx, jy) = jitter.at(t);
        let gx: f64 = rng.sample(StandardNormal);
        let gy: f64 = rng.sample(StandardNormal);
        let w = if n < packets {
            w32
        } else if tail == 1 {
            rest as u32
        } else {
            1
        };
        canvas.add(
            x0 + jx + gx * psf_px,
            y0 + jy + gy * psf_px,
            w,
            source.debris,
        );
    }
}

/// Where the photons of the sources go: traced one by one, or as expected flux per pixel.
enum Photons {
    Mapped(Canvas),
    Expected(expected::Flux),
}

/// Every source of a scene that can put photons in the image, in a fixed order (the order
/// in which photon mapping consumes its stream), and the stars as traced.
fn for_each_source(
    sensor: &Sensor,
    scene: &Scene,
    jitter: &Jitter,
    mut add: impl FnMut(&Source),
) -> Vec<TracedStar> {
    let s = sensor;
    let (width, height) = (s.width_px as f64, s.height_px as f64);
    let tan = scene.projection(sensor);
    let scale = tan.scale_deg;
    let psf_px = sensor.psf_sigma_px();
    let t_exp = scene.exposure_s;
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
    match scene.pointing {
        Pointing::Fixed { .. } => {
            // Fixed on the sky, photons uniform over the exposure.
            for star in &scene.stars {
                let Some((x0, y0)) = tan.pixel(star.ra_deg, star.dec_deg) else {
                    continue;
                };
                if !near(x0, y0) {
                    continue;
                }
                let expected = photon_rate(star.mag, s.zero_point_mag) * t_exp;
                traced.push(TracedStar {
                    ra_deg: star.ra_deg,
                    dec_deg: star.dec_deg,
                    mag: star.mag,
                    x: x0 + jitter_mean.0,
                    y: y0 + jitter_mean.1,
                    expected_electrons: expected,
                });
                add(&Source {
                    expected,
                    path: Path::Still { x: x0, y: y0 },
                    t_a: 0.0,
                    t_b: t_exp,
                    debris: false,
                });
            }
        }
        Pointing::Survey(track) => {
            // Each star's trail is sampled on a time grid fine enough that linear interpolation
            // between nodes is exact to well under 0.01 px (the trail is straight to second
            // order in the drift), and every photon takes the position of its arrival time.
            let drift_px = track.drift_deg / scale;
            let nodes = ((drift_px / SURVEY_NODE_SPACING_PX).ceil() as usize + 1).max(2);
            let step = t_exp / (nodes - 1) as f64;
            let mut trail = vec![(f64::NAN, f64::NAN); nodes];
            for star in &scene.stars {
                let (mut first, mut last) = (None, None);
                for (i, node) in trail.iter_mut().enumerate() {
                    *node = scene
                        .pixel_at(&tan, i as f64 * step, star.ra_deg, star.dec_deg)
                        .unwrap_or((f64::NAN, f64::NAN));
                    if near(node.0, node.1) {
                        first.get_or_insert(i);
                        last = Some(i);
                    }
                }
                let (Some(a), Some(b)) = (first, last) else {
                    continue;
                };
                // One node of slack on each side covers a trail entering between nodes.
                let t_a = a.saturating_sub(1) as f64 * step;
                let t_b = ((b + 1).min(nodes - 1)) as f64 * step;
                let expected = photon_rate(star.mag, s.zero_point_mag) * (t_b - t_a);
                let (xm, ym) = tan
                    .pixel(star.ra_deg, star.dec_deg)
                    .unwrap_or((f64::NAN, f64::NAN));
                traced.push(TracedStar {
                    ra_deg: star.ra_deg,
                    dec_deg: star.dec_deg,
                    mag: star.mag,
                    x: xm + jitter_mean.0,
                    y: ym + jitter_mean.1,
                    expected_electrons: expected,
                });
                add(&Source {
                    expected,
                    path: Path::Trail {
                        nodes: &trail,
                        step,
                    },
                    t_a,
                    t_b,
                    debris: false,
                });
            }
        }
    }

    // Debris: each trajectory sample is a source whose photons arrive at its time.
    for p in &scene.trajectory {
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

/// Render a scene: photons (one stream, the jitter path first), then detector noise (another).
pub fn render(
    sensor: &Sensor,
    settings: &Settings,
    scene: &Scene,
    frame: Option<&RealFrame>,
    photons_rng: &mut ChaCha12Rng,
    noise_rng: &mut ChaCha12Rng,
) -> Exposure {
    let jitter = Jitter::of_scene(sensor, settings, scene, photons_rng);
    render_with_jitter(
        sensor,
        settings,
        scene,
        frame,
        &jitter,
        photons_rng,
        noise_rng,
    )
}

/// Render a scene for a given jitter path.
pub fn render_with_jitter(
    sensor: &Sensor,
    settings: &Settings,
    scene: &Scene,
    frame: Option<&RealFrame>,
    jitter: &Jitter,
    photons_rng: &mut ChaCha12Rng,
    noise_rng: &mut ChaCha12Rng,
) -> Exposure {
    let s = sensor;
    let (width, height) = (s.width_px, s.height_px);
    let psf_px = sensor.psf_sigma_px();
    let t_exp = scene.exposure_s;
    let jitter_mean = jitter.mean();
    let merge = (settings.merge_threshold, settings.merge_factor);
    let mut photons = match settings.method {
        RenderMethod::PhotonMapping => Photons::Mapped(Canvas {
            width,
            height,
            electrons: vec![0; width * height],
            debris: vec![0; width * height],
            debris_total: 0,
        }),
        RenderMethod::Expected => Photons::Expected(expected::Flux::new(width, height, psf_px)),
    };
    // The debris' trajectory samples share one source's packet budget (2000 samples of a
    // magnitude -1 debris would otherwise trace 2e9 packets).
    let debris_packets = (MAX_PACKETS_PER_SOURCE / scene.trajectory.len().max(1) as u64).max(1);
    let traced = for_each_source(sensor, scene, jitter, |source| match &mut photons {
        Photons::Mapped(canvas) => {
            let count = poisson(photons_rng, source.expected);
            let budget = if source.debris {
                debris_packets
            } else {
                MAX_PACKETS_PER_SOURCE
            };
            trace(
                canvas,
                photons_rng,
                count,
                merge,
                budget,
                jitter,
                psf_px,
                source,
            );
        }
        Photons::Expected(flux) => flux.add(source, jitter),
    });
    let canvas = match photons {
        Photons::Mapped(canvas) => canvas,
        Photons::Expected(flux) => flux.draw(photons_rng),
    };
    let (expected_debris, mag_min, mag_max) = scene
        .trajectory
        .iter()
        .fold((0.0, f64::INFINITY, f64::NEG_INFINITY), |(e, lo, hi), p| {
            (e + p.expected_electrons, lo.min(p.mag), hi.max(p.mag))
        });

    // Detector, Eq. 11: ADU = electrons / gain + background + bias. The background is the
    // paper's uniform one (its range scaled linearly with exposure) or a real frame's.
    let (b_lo, b_hi) = (s.bias.min_adu, s.bias.max_adu);
    let uniform = |r: &mut ChaCha12Rng, lo: f64, hi: f64| {
        if hi > lo { r.random_range(lo..hi) } else { lo }
    };
    let adu: Vec<f32> = match (frame, scene.background) {
        (Some(f), Some(choice)) => {
            let level = s.sky_level_adu(t_exp);
            let bg = f.background(width, height, t_exp, choice.offset, level);
            canvas
                .electrons
                .iter()
                .zip(bg)
                .map(|(&e, bg)| {
                    let bias = uniform(noise_rng, b_lo, b_hi);
                    (e as f64 / s.gain_e_per_adu + bg as f64 + bias) as f32
                })
                .collect()
        }
        _ => {
            let k = t_exp / s.background_exposure_s;
            let (bg_lo, bg_hi) = (s.background.min_adu * k, s.background.max_adu * k);
            canvas
                .electrons
                .iter()
                .map(|&e| {
                    let bg = uniform(noise_rng, bg_lo, bg_hi);
                    let bias = uniform(noise_rng, b_lo, b_hi);
                    (e as f64 / s.gain_e_per_adu + bg + bias) as f32
                })
                .collect()
        }
    };

    let at = |p: Option<&crate::scene::TrajectorySample>| {
        p.map(|p| {
            let (jx, jy) = jitter.at(p.t_s);
            [p.x_px + jx, p.y_px + jy]
        })
    };
    let first = at(scene.trajectory.first());
    let last = at(scene.trajectory.last());
    let g = &scene.geometry;
    let truth = Truth {
        image_index: scene.image_index,
        object: scene.debris_name.clone(),
        norad: scene.norad,
        start_utc: iso_utc(scene.start),
        exposure_s: t_exp,
        pointing: scene.pointing.clone(),
        jitter_mean_px: [jitter_mean.0, jitter_mean.1],
        streak_start_px: first.unwrap_or([f64::NAN; 2]),
        streak_end_px: last.unwrap_or([f64::NAN; 2]),
        label_box_px: flux_box(
            &canvas.debris.iter().map(|&v| v as f32).collect::<Vec<_>>(),
            width,
            height,
            LABEL_SHARE,
        ),
        frame: None,
        label_box_final_px: None,
        magnitude: g.magnitude,
        magnitude_min: mag_min,
        magnitude_max: mag_max,
        area_m2: scene.area_m2,
        range_km: g.range_km,
        phase_angle_deg: g.phase_angle_deg,
        earth_angle_deg: g.earth_angle_deg,
        sun_angle_deg: g.sun_angle_deg,
        moon_angle_deg: g.moon_angle_deg,
        tumble: scene.tumble,
        expected_debris_electrons: expected_debris,
        rendered_debris_electrons: canvas.debris_total,
        snr: scene.snr,
        stars_in_cone: scene.stars.len(),
        stars_traced: traced.len(),
        background_sigma_adu: sensor.background_sigma_adu(t_exp, frame),
        background_frame: frame.map(|f| f.path.display().to_string()),
        attempts: scene.attempts,
        rejections: scene.rejections.clone(),
    };
    Exposure {
        width,
        height,
        electrons: canvas.electrons,
        debris_electrons: canvas.debris,
        adu,
        truth,
        stars: traced,
    }
}

/// ISO 8601 UTC with milliseconds, e.g. `2022-03-04T05:06:07.891`.
pub(crate) fn iso_utc(t: hifitime::Epoch) -> String {
    let (y, mo, d, h, mi, s, ns) = t.to_gregorian_utc();
    format!(
        "{y:04}-{mo:02}-{d:02}T{h:02}:{mi:02}:{s:02}.{:03}",
        ns / 1_000_000
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, stream};
    use crate::sensor::AduRange;
    use crate::sky::stars::Star;

    /// The sensor and render settings of the tests.
    struct Fixture {
        sensor: Sensor,
        render: Settings,
    }

    /// The paper's detector, optics and render settings on a 128 px image with a 0.0125 deg
    /// field radius, and the given jitter (the paper's: 2e-4 deg per sqrt(s)).
    fn fixture(jitter_deg_per_sqrt_s: f64) -> Fixture {
        Fixture {
            sensor: Sensor {
                width_px: 128,
                height_px: 128,
                fov_radius_deg: 0.0125,
                psf_sigma_arcsec: 1.0,
                zero_point_mag: 22.26,
                mag_limit: 16.5,
                jitter_deg_per_sqrt_s,
                gain_e_per_adu: 1.6,
                bias: AduRange {
                    min_adu: 2.0,
                    max_adu: 3.0,
                },
                background: AduRange {
                    min_adu: 190.0,
                    max_adu: 210.0,
                },
                background_exposure_s: 5.0,
            },
            render: Settings {
                method: RenderMethod::PhotonMapping,
                merge_threshold: 100_000,
                merge_factor: 5,
                jitter_steps: 2000,
            },
        }
    }

    /// The projection of the test scenes: centred on (10, 20), 128 px.
    fn tan_of(c: &Fixture) -> crate::sky::projection::Tan {
        c.sensor.projection(10.0, 20.0)
    }

    /// A scene centred on (10, 20) with the given stars and a debris streak along +x.
    fn scene(c: &Fixture, stars: Vec<Star>, debris_mag: f64, exposure_s: f64) -> Scene {
        let ends = ((30.0, 40.0), (90.0, 40.0));
        Scene::fixed_streak(&c.sensor, (10.0, 20.0), stars, debris_mag, ends, exposure_s)
    }

    #[test]
    fn mean_photons_match_eq3_within_poisson_error() {
        // One star in the middle, far from the edges, and a debris streak: over many seeds the
        // mean of the rendered photo-electrons matches t 10^(-0.4 (m - ZP)) within Poisson error.
        let c = fixture(2e-4);
        let tan = tan_of(&c);
        let (ra, dec) = tan.sky(90.0, 90.0);
        let star_mag = 15.0;
        let debris_mag = 14.0;
        let exposure = 5.0;
        let s = scene(
            &c,
            vec![Star {
                ra_deg: ra,
                dec_deg: dec,
                mag: star_mag,
            }],
            debris_mag,
            exposure,
        );
        let zp = c.sensor.zero_point_mag;
        let star_expected = exposure * 10f64.powf(-0.4 * (star_mag - zp));
        let debris_expected = exposure * 10f64.powf(-0.4 * (debris_mag - zp));
        let runs = 200;
        let (mut star_sum, mut debris_sum) = (0.0, 0.0);
        for i in 0..runs {
            let e = render(
                &c.sensor,
                &c.render,
                &s,
                None,
                &mut stream(1, i, Purpose::Photons),
                &mut stream(1, i, Purpose::Noise),
            );
            let total: u64 = e.electrons.iter().map(|&v| v as u64).sum();
            debris_sum += e.truth.rendered_debris_electrons as f64;
            star_sum += (total - e.truth.rendered_debris_electrons) as f64;
            assert!(
                (e.truth.expected_debris_electrons - debris_expected).abs()
                    < 1e-6 * debris_expected
            );
        }
        for (sum, expected) in [(star_sum, star_expected), (debris_sum, debris_expected)] {
            let mean = sum / runs as f64;
            let sigma_of_mean = (expected / runs as f64).sqrt();
            assert!(
                (mean - expected).abs() < 4.0 * sigma_of_mean,
                "mean {mean} vs Eq. 3 {expected} (sigma of mean {sigma_of_mean})"
            );
        }
    }

    #[test]
    fn merged_packets_keep_the_total_and_the_label_holds_the_streak() {
        // A source above the merge threshold is traced in packets; the count stays exact.
        let mut c = fixture(2e-4);
        c.render.merge_threshold = 1000;
        c.render.merge_factor = 5;
        let s = scene(&c, vec![], 10.0, 2.0);
        let e = render(
            &c.sensor,
            &c.render,
            &s,
            None,
            &mut stream(2, 0, Purpose::Photons),
            &mut stream(2, 0, Purpose::Noise),
        );
        let total: u64 = e.electrons.iter().map(|&v| v as u64).sum();
        assert_eq!(total, e.truth.rendered_debris_electrons);
        let b = e.truth.label_box_px.unwrap();
        // The streak runs from x = 30 to 90 at y = 40; the box holds it with PSF margins.
        assert!(b.x_min <= 30.0 && b.x_max >= 89.5, "{b:?}");
        assert!(
            b.y_min <= 40.0 && b.y_max >= 40.0 && b.y_max - b.y_min < 12.0,
            "{b:?}"
        );
        // Background and bias scale as Eq. 11: with no source the mean ADU is the mean of
        // background (scaled to 2 s) plus bias.
        let mean_adu = e.adu.iter().map(|&a| a as f64).sum::<f64>() / e.adu.len() as f64;
        let expected_bg = 200.0 * 2.0 / 5.0 + 2.5 + total as f64 / 1.6 / e.adu.len() as f64;
        assert!(
            (mean_adu - expected_bg).abs() < 0.1,
            "{mean_adu} vs {expected_bg}"
        );
    }

    #[test]
    fn star_centroid_lands_where_the_wcs_says() {
        // With the pointing jitter on, a bright star's flux centroid is the traced position
        // (nominal + mean jitter), which is where the FITS WCS (CRPIX shifted) puts it.
        let c = fixture(3e-4);
        let tan = tan_of(&c);
        let (ra, dec) = tan.sky(64.3, 70.8);
        let s = scene(
            &c,
            vec![Star {
                ra_deg: ra,
                dec_deg: dec,
                mag: 12.0,
            }],
            30.0,
            8.0,
        );
        for i in 0..5 {
            let e = render(
                &c.sensor,
                &c.render,
                &s,
                None,
                &mut stream(3, i, Purpose::Photons),
                &mut stream(3, i, Purpose::Noise),
            );
            let st = e.stars[0];
            let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
            for y in 0..128 {
                for x in 0..128 {
                    let v = e.electrons[y * 128 + x] as f64;
                    sx += v * x as f64;
                    sy += v * y as f64;
                    sw += v;
                }
            }
            let (cx, cy) = (sx / sw, sy / sw);
            assert!(
                (cx - st.x).abs() < 0.05 && (cy - st.y).abs() < 0.05,
                "centroid {cx},{cy} vs {},{}",
                st.x,
                st.y
            );
            let wcs = s
                .projection(&c.sensor)
                .shifted(e.truth.jitter_mean_px[0], e.truth.jitter_mean_px[1]);
            let (wx, wy) = wcs.pixel(ra, dec).unwrap();
            assert!((wx - st.x).abs() < 1e-9 && (wy - st.y).abs() < 1e-9);
        }
    }

    /// Per-pixel sums over seeds: count, mean, second and fourth central moments.
    struct PixelStats {
        n: f64,
        mean: Vec<f64>,
        var: Vec<f64>,
        /// Standard error of each sample variance (from the fourth central moment).
        var_se: Vec<f64>,
    }

    fn pixel_stats(images: &[Vec<u32>]) -> PixelStats {
        let n = images.len() as f64;
        let len = images[0].len();
        let mut st = PixelStats {
            n,
            mean: vec![0.0; len],
            var: vec![0.0; len],
            var_se: vec![0.0; len],
        };
        for k in 0..len {
            let m = images.iter().map(|im| im[k] as f64).sum::<f64>() / n;
            let m2 = images
                .iter()
                .map(|im| (im[k] as f64 - m).powi(2))
                .sum::<f64>()
                / n;
            let m4 = images
                .iter()
                .map(|im| (im[k] as f64 - m).powi(4))
                .sum::<f64>()
                / n;
            st.mean[k] = m;
            st.var[k] = m2 * n / (n - 1.0);
            st.var_se[k] = ((m4 - m2 * m2 * (n - 3.0) / (n - 1.0)) / n).max(0.0).sqrt();
        }
        st
    }

    /// Chi-square of the per-pixel differences (a - b) / se over the pixels `on`, and its
    /// z-score against chi-square with as many degrees of freedom.
    fn chi2_z(on: &[usize], diff_se: impl Fn(usize) -> (f64, f64)) -> (f64, f64) {
        let chi2: f64 = on
            .iter()
            .map(|&k| {
                let (d, se) = diff_se(k);
                (d / se).powi(2)
            })
            .sum();
        let dof = on.len() as f64;
        (chi2, (chi2 - dof) / (2.0 * dof).sqrt())
    }

    /// The noise-free images of `runs` seeds, for a fixed jitter path.
    fn noise_free(c: &Fixture, s: &Scene, jitter: &Jitter, runs: u64) -> Vec<Vec<u32>> {
        (0..runs)
            .map(|i| {
                render_with_jitter(
                    &c.sensor,
                    &c.render,
                    s,
                    None,
                    jitter,
                    &mut stream(11, i, Purpose::Photons),
                    &mut stream(11, i, Purpose::Noise),
                )
                .electrons
            })
            .collect()
    }

    #[test]
    fn expected_and_photon_mapping_agree_in_mean_and_variance_per_pixel() {
        // A star and a debris streak, a fixed (non-trivial) jitter path, merging off: for every
        // pixel with signal, the mean and the variance over seeds of the two renderers agree
        // within their standard errors (chi-square over pixels), and merging 5 photons per
        // packet inflates the variance about 5 times (packets of F land like N / F photons of
        // weight F: variance ~ F x mean, less where one pixel holds much of a source and for the
        // remainder traced singly) as the exact formula below predicts, without biasing the mean.
        let mut exact = fixture(4e-4);
        exact.render.jitter_steps = 50;
        exact.render.merge_threshold = 1_000_000_000_000;
        let mut expected = fixture(4e-4);
        expected.render.jitter_steps = 50;
        expected.render.merge_threshold = 1_000_000_000_000;
        expected.render.method = RenderMethod::Expected;
        let mut merged = fixture(4e-4);
        merged.render.jitter_steps = 50;
        merged.render.merge_threshold = 1;
        merged.render.merge_factor = 5;
        let tan = tan_of(&exact);
        let (ra, dec) = tan.sky(80.3, 70.6);
        let star = Star {
            ra_deg: ra,
            dec_deg: dec,
            mag: 15.5,
        };
        let s = scene(&exact, vec![star], 14.5, 2.0);
        let jitter = Jitter::of_scene(
            &exact.sensor,
            &exact.render,
            &s,
            &mut stream(10, 0, Purpose::Photons),
        );
        assert!(
            jitter.max_excursion() > 0.5,
            "the jitter path moves the sources"
        );
        let runs = 300;
        let a = pixel_stats(&noise_free(&exact, &s, &jitter, runs));
        let b = pixel_stats(&noise_free(&expected, &s, &jitter, runs));
        let m = pixel_stats(&noise_free(&merged, &s, &jitter, runs));
        // Pixels where the Poisson counts are near normal.
        let on: Vec<usize> = (0..a.mean.len()).filter(|&k| b.mean[k] >= 5.0).collect();
        assert!(on.len() > 100, "{} pixels with signal", on.len());
        let n = a.n;
        let (chi2, z) = chi2_z(&on, |k| {
            (a.mean[k] - b.mean[k], ((a.var[k] + b.var[k]) / n).sqrt())
        });
        eprintln!("means: chi2 {chi2:.1} over {} pixels (z {z:.2})", on.len());
        assert!(
            z.abs() < 4.0,
            "means: chi2 {chi2} over {} pixels (z {z})",
            on.len()
        );
        let (chi2, z) = chi2_z(&on, |k| {
            (a.var[k] - b.var[k], a.var_se[k].hypot(b.var_se[k]))
        });
        eprintln!(
            "variances: chi2 {chi2:.1} over {} pixels (z {z:.2})",
            on.len()
        );
        assert!(
            z.abs() < 4.0,
            "variances: chi2 {chi2} over {} pixels (z {z})",
            on.len()
        );
        // Both are Poisson: variance = mean, summed over the pixels.
        let ratio = |st: &PixelStats| {
            on.iter().map(|&k| st.var[k]).sum::<f64>() / on.iter().map(|&k| st.mean[k]).sum::<f64>()
        };
        for st in [&a, &b] {
            assert!(
                (ratio(st) - 1.0).abs() < 0.03,
                "variance/mean {}",
                ratio(st)
            );
        }
        // Merging: the mean is unbiased, the variance 5 times the Poisson one.
        let (chi2, z) = chi2_z(&on, |k| {
            (m.mean[k] - b.mean[k], ((m.var[k] + b.var[k]) / n).sqrt())
        });
        assert!(z.abs() < 4.0, "merged means: chi2 {chi2} (z {z})");
        // The exact merged variance of a pixel, per source with N ~ Poisson(lambda) photons in
        // P = N div F packets and S = N mod F singles, each landing in the pixel with chance p:
        // p (1 - p) (F^2 E[P] + E[S]) + p^2 lambda. Summed over the pixels with signal.
        let f = 5.0;
        let psf_px = exact.sensor.psf_sigma_px();
        let mut predicted = vec![0.0; a.mean.len()];
        for_each_source(&merged.sensor, &s, &jitter, |source| {
            let mut flux = expected::Flux::new(128, 128, psf_px);
            flux.add(source, &jitter);
            let lambda = source.expected;
            // The Poisson pmf in logs (exp(-lambda) underflows for a bright star).
            let (mut e_p, mut e_s, mut ln_pmf) = (0.0, 0.0, -lambda);
            for count in 0..(lambda + 12.0 * lambda.sqrt() + 30.0) as u64 {
                e_p += ln_pmf.exp() * (count / 5) as f64;
                e_s += ln_pmf.exp() * (count % 5) as f64;
                ln_pmf += (lambda / (count + 1) as f64).ln();
            }
            for (k, v) in predicted.iter_mut().enumerate() {
                let p = (flux.stars[k] + flux.debris[k]) / lambda;
                *v += p * (1.0 - p) * (f * f * e_p + e_s) + p * p * lambda;
            }
        });
        let predicted_ratio = on.iter().map(|&k| predicted[k]).sum::<f64>()
            / on.iter().map(|&k| b.mean[k]).sum::<f64>();
        eprintln!(
            "{} pixels, {runs} seeds: variance/mean exact {:.4}, expected {:.4}, merged {:.4} (theory {predicted_ratio:.4})",
            on.len(),
            ratio(&a),
            ratio(&b),
            ratio(&m)
        );
        assert!(
            (ratio(&m) / predicted_ratio - 1.0).abs() < 0.05 && predicted_ratio > 4.0,
            "merged variance/mean {} vs theory {predicted_ratio}",
            ratio(&m)
        );
    }
}
