//! The shared Brownian pointing jitter (paper Eq. 2): one random path per exposure, applied
//! on the sky so it is isotropic, as pixel shifts of every source on a regular time grid.

use rand::RngExt;
use rand_distr::StandardNormal;
use soig_base::rng::PixelRng;

use super::Settings;
use crate::scene::Scene;
use crate::sensor::Sensor;

/// The shared Brownian pointing jitter, as pixel shifts of every source, on a regular time grid.
pub struct Jitter {
    pub(super) dt: f64,
    shift: Vec<(f64, f64)>,
}

impl Jitter {
    /// The jitter path of a scene, drawn first from the photon stream.
    pub fn of_scene(
        sensor: &Sensor,
        settings: &Settings,
        scene: &Scene,
        rng: &mut PixelRng,
    ) -> Jitter {
        Jitter::draw(
            rng,
            sensor.jitter_deg_per_sqrt_s,
            scene.exposure.exposure_s,
            settings.jitter_steps,
            scene.projection(sensor).scale_deg,
        )
    }

    /// No jitter: every source where the pointing puts it (a prediction adds the image's
    /// recorded mean shift instead, `trails::star_trails`).
    pub(super) fn still(exposure_s: f64) -> Jitter {
        Jitter {
            dt: exposure_s.max(f64::MIN_POSITIVE),
            shift: vec![(0.0, 0.0); 2],
        }
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
        rng: &mut PixelRng,
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
    pub(super) fn at(&self, t: f64) -> (f64, f64) {
        self.at_step((t / self.dt).max(0.0))
    }

    /// The shift at `u` grid steps from the start (u >= 0; past the end, the last shift):
    /// `at(u dt)` without the division, for photons whose arrival is drawn on the grid.
    pub(super) fn at_step(&self, u: f64) -> (f64, f64) {
        let i = (u as usize).min(self.shift.len() - 2);
        let f = (u - i as f64).min(1.0);
        let (a, b) = (self.shift[i], self.shift[i + 1]);
        (a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1))
    }

    /// Time average of the shift over the exposure (trapezoid rule on the grid).
    pub(super) fn mean(&self) -> (f64, f64) {
        let n = self.shift.len() - 1;
        let (mut x, mut y) = (0.0, 0.0);
        for w in self.shift.windows(2) {
            x += (w[0].0 + w[1].0) / 2.0;
            y += (w[0].1 + w[1].1) / 2.0;
        }
        (x / n as f64, y / n as f64)
    }

    pub(super) fn max_excursion(&self) -> f64 {
        self.shift
            .iter()
            .map(|(x, y)| x.abs().max(y.abs()))
            .fold(0.0, f64::max)
    }
}
