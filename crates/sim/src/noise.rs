//! The detector's noise model: the paper's (a uniform background and bias in ADU, in
//! `render::detector`), or a physical one, in electrons: a Poisson sky, dark current and hot
//! pixels, cosmic-ray tracks, full-well saturation, Gaussian read noise, then gain, bias and
//! an ADC that rounds and clips to its range. No charge bleeds: a full pixel stays full.
//!
//! Each component draws from its own stream (`rng::Purpose`), so turning one on or changing it
//! leaves the draws of the others as they were; a component at zero costs nothing. Hot pixels
//! are a property of the sensor: their positions come from the campaign seed alone, the same in
//! every image; their charge is drawn per image.

use rand::RngExt;
use rand_distr::{Distribution, Normal, Poisson, StandardNormal};
use soig_base::rng::PixelRng;

use soig_base::rng::{PixelPurpose, pixel_stream, poisson};

/// How the detector turns photo-electrons into ADU.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Noise {
    /// The paper's: ADU = e-/gain + uniform background + uniform bias (the sensor's ranges).
    #[default]
    Paper,
    Physical(Physical),
}

/// A physical detector.
#[derive(Clone, Debug, PartialEq)]
pub struct Physical {
    /// The campaign seed: image i's streams are `rng::stream(seed, i, purpose)`, and the hot
    /// pixels' positions derive from it alone.
    pub seed: u64,
    /// Sky background, photo-electrons per second per pixel (Poisson).
    pub sky_e_per_s: f64,
    /// Dark current, electrons per second per pixel (Poisson).
    pub dark_e_per_s: f64,
    /// Read noise, electrons rms (Gaussian).
    pub read_noise_e: f64,
    /// Bias level, ADU.
    pub bias_adu: f64,
    /// Full-well capacity, electrons: a pixel holds at most this much charge.
    pub full_well_e: f64,
    /// Largest ADC output, ADU (65535 for 16 bits).
    pub adc_max_adu: f64,
    pub hot_pixels: Option<HotPixels>,
    pub cosmic_rays: Option<CosmicRays>,
}

/// Pixels with a high dark current.
#[derive(Clone, Debug, PartialEq)]
pub struct HotPixels {
    /// Share of the sensor's pixels that are hot.
    pub fraction: f64,
    /// Their dark current, electrons per second, on top of the sensor's.
    pub dark_e_per_s: f64,
}

/// Cosmic-ray hits.
#[derive(Clone, Debug, PartialEq)]
pub struct CosmicRays {
    /// Hits per cm^2 of sensor per second.
    pub rate_per_cm2_s: f64,
    /// Pixel pitch, micrometres: the sensor's area, and the track length in pixels.
    pub pixel_size_um: f64,
}

/// Depth of silicon that collects charge, micrometres (a thinned CCD's 10-20 um).
pub const COLLECTION_DEPTH_UM: f64 = 15.0;
/// Most probable charge a minimum-ionising particle frees per micrometre of silicon, electrons
/// (~0.26 keV per um at 3.6 eV per pair).
pub const CHARGE_MPV_E_PER_UM: f64 = 72.0;
/// Width of the charge's Landau-like spread, as a share of the most probable value.
const CHARGE_SPREAD: f64 = 0.25;
/// Steepest incidence drawn, degrees from the normal: grazing tracks (longer than
/// `COLLECTION_DEPTH_UM` x tan 85 deg, 11 px at 13 um) are left out.
const MAX_INCIDENCE_DEG: f64 = 85.0;
/// Image index of the hot-pixel map's stream: not an image, the sensor (images stop at 1e7).
const SENSOR_STREAM: u64 = u64::MAX;

/// A sky surface brightness in mag/arcsec^2 as photo-electrons per second per pixel, with the
/// zero point (the magnitude that gives 1 e-/s) and the pixel scale.
pub fn sky_e_per_s(mag_per_arcsec2: f64, zero_point_mag: f64, pixel_scale_arcsec: f64) -> f64 {
    10f64.powf(-0.4 * (mag_per_arcsec2 - zero_point_mag)) * pixel_scale_arcsec * pixel_scale_arcsec
}

/// One cosmic-ray track: its ends in pixel coordinates and the charge it frees.
#[derive(Clone, Debug, PartialEq)]
pub struct Track {
    pub start_px: [f64; 2],
    pub end_px: [f64; 2],
    pub electrons: f64,
}

impl CosmicRays {
    /// Expected hits on a `width` x `height` sensor in `exposure_s`.
    pub fn expected_hits(&self, width: usize, height: usize, exposure_s: f64) -> f64 {
        let cm = self.pixel_size_um * 1e-4;
        self.rate_per_cm2_s * (width as f64 * cm) * (height as f64 * cm) * exposure_s
    }

    /// The tracks of one exposure: a Poisson number of hits, each at a uniform point, a uniform
    /// azimuth and an incidence angle of an isotropic flux through a plane (sin^2 of the angle
    /// uniform, up to `MAX_INCIDENCE_DEG`). The track's length on the sensor is
    /// `COLLECTION_DEPTH_UM` tan(angle); its charge `CHARGE_MPV_E_PER_UM` per um of path in
    /// the silicon times (1 + `CHARGE_SPREAD` x), x Moyal-distributed (the closed-form
    /// approximation of Landau's: x = -ln z^2, z standard normal), at least a tenth of it.
    pub fn tracks(
        &self,
        width: usize,
        height: usize,
        exposure_s: f64,
        rng: &mut PixelRng,
    ) -> Vec<Track> {
        let hits = poisson(rng, self.expected_hits(width, height, exposure_s));
        let max_sin2 = MAX_INCIDENCE_DEG.to_radians().sin().powi(2);
        (0..hits)
            .map(|_| {
                let x = rng.random_range(-0.5..width as f64 - 0.5);
                let y = rng.random_range(-0.5..height as f64 - 0.5);
                let azimuth = rng.random_range(0.0..std::f64::consts::TAU);
                let incidence = rng.random_range(0.0..max_sin2).sqrt().asin();
                let length_px = COLLECTION_DEPTH_UM * incidence.tan() / self.pixel_size_um;
                let z: f64 = StandardNormal.sample(rng);
                let spread = (1.0 - CHARGE_SPREAD * (z * z).ln()).max(0.1);
                let path_um = COLLECTION_DEPTH_UM / incidence.cos();
                Track {
                    start_px: [x, y],
                    end_px: [x + length_px * azimuth.cos(), y + length_px * azimuth.sin()],
                    electrons: CHARGE_MPV_E_PER_UM * path_um * spread,
                }
            })
            .collect()
    }
}

/// Spread a track's charge evenly along it, in steps of a quarter pixel.
fn deposit(charge: &mut [f64], width: usize, height: usize, t: &Track) {
    let (dx, dy) = (t.end_px[0] - t.start_px[0], t.end_px[1] - t.start_px[1]);
    let steps = (dx.hypot(dy) * 4.0).ceil() as usize + 1;
    let share = t.electrons / steps as f64;
    for k in 0..steps {
        let f = if steps > 1 {
            k as f64 / (steps - 1) as f64
        } else {
            0.0
        };
        let (x, y) = (
            (t.start_px[0] + f * dx + 0.5).floor(),
            (t.start_px[1] + f * dy + 0.5).floor(),
        );
        if x >= 0.0 && y >= 0.0 && (x as usize) < width && (y as usize) < height {
            charge[y as usize * width + x as usize] += share;
        }
    }
}

/// Add a Poisson draw of `mean` to every pixel, the same draws as `rng::poisson` with the
/// distribution built once rather than per pixel (a 1024 px image: ~100 -> ~70 ms).
fn add_poisson(charge: &mut [f64], mean: f64, rng: &mut PixelRng) {
    if mean >= Poisson::<f64>::MAX_LAMBDA {
        charge.iter_mut().for_each(|c| *c += mean.round());
        return;
    }
    let d = Poisson::new(mean).expect("positive finite mean");
    charge.iter_mut().for_each(|c| *c += d.sample(rng));
}

impl HotPixels {
    /// The hot pixels of a `width` x `height` sensor: `fraction` of them, rounded, distinct,
    /// drawn from the campaign seed alone.
    pub fn positions(&self, seed: u64, width: usize, height: usize) -> Vec<usize> {
        let n = width * height;
        let count = ((self.fraction * n as f64).round() as usize).min(n);
        let mut rng = pixel_stream(seed, SENSOR_STREAM, PixelPurpose::HotPixels);
        let mut at = rand::seq::index::sample(&mut rng, n, count).into_vec();
        at.sort_unstable();
        at
    }
}

impl Physical {
    /// The noisy image in ADU of image `image`'s photo-electrons, exposed `exposure_s`.
    pub fn adu(
        &self,
        electrons: &[u32],
        width: usize,
        height: usize,
        exposure_s: f64,
        gain_e_per_adu: f64,
        image: u64,
    ) -> Vec<f32> {
        let rng = |purpose| pixel_stream(self.seed, image, purpose);
        let mut charge: Vec<f64> = electrons.iter().map(|&e| e as f64).collect();
        for (rate, purpose) in [
            (self.sky_e_per_s, PixelPurpose::Sky),
            (self.dark_e_per_s, PixelPurpose::Dark),
        ] {
            let mean = rate * exposure_s;
            if mean > 0.0 {
                add_poisson(&mut charge, mean, &mut rng(purpose));
            }
        }
        if let Some(hot) = &self.hot_pixels {
            let mut r = rng(PixelPurpose::HotPixels);
            let mean = hot.dark_e_per_s * exposure_s;
            for at in hot.positions(self.seed, width, height) {
                charge[at] += poisson(&mut r, mean) as f64;
            }
        }
        if let Some(cosmic) = &self.cosmic_rays {
            for t in cosmic.tracks(
                width,
                height,
                exposure_s,
                &mut rng(PixelPurpose::CosmicRays),
            ) {
                deposit(&mut charge, width, height, &t);
            }
        }
        let read = (self.read_noise_e > 0.0).then(|| {
            (
                Normal::new(0.0, self.read_noise_e).expect("validated read noise"),
                rng(PixelPurpose::ReadNoise),
            )
        });
        let to_adu = |c: f64| {
            (c / gain_e_per_adu + self.bias_adu)
                .round()
                .clamp(0.0, self.adc_max_adu) as f32
        };
        let full = self.full_well_e;
        match read {
            Some((normal, mut r)) => charge
                .into_iter()
                .map(|c| to_adu(c.min(full) + normal.sample(&mut r)))
                .collect(),
            None => charge.into_iter().map(|c| to_adu(c.min(full))).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A detector with nothing on: gain 1, no bias, no saturation within reach.
    fn quiet() -> Physical {
        Physical {
            seed: 7,
            sky_e_per_s: 0.0,
            dark_e_per_s: 0.0,
            read_noise_e: 0.0,
            bias_adu: 0.0,
            full_well_e: 1e9,
            adc_max_adu: 1e9,
            hot_pixels: None,
            cosmic_rays: None,
        }
    }

    const W: usize = 256;

    fn mean_var(v: &[f32]) -> (f64, f64) {
        let n = v.len() as f64;
        let m = v.iter().map(|&x| x as f64).sum::<f64>() / n;
        (
            m,
            v.iter().map(|&x| (x as f64 - m).powi(2)).sum::<f64>() / (n - 1.0),
        )
    }

    fn image(p: &Physical, exposure_s: f64, index: u64) -> Vec<f32> {
        p.adu(&vec![0; W * W], W, W, exposure_s, 1.0, index)
    }

    // Tolerances below: with n = 65,536 pixels the relative standard error of a sample variance
    // is sqrt((2 + 1/mean) / n) < 0.6% for a Poisson or Gaussian variable; 3% is five of them.
    // The ADC rounds to whole ADU, which adds 1/12 ADU^2 of variance (uniform rounding error).

    #[test]
    fn poisson_sky_has_variance_equal_to_its_mean() {
        let p = Physical {
            sky_e_per_s: 40.0,
            ..quiet()
        };
        let (m, v) = mean_var(&image(&p, 5.0, 0));
        assert!((m / 200.0 - 1.0).abs() < 0.005, "mean {m}");
        assert!(
            ((v - 1.0 / 12.0) / m - 1.0).abs() < 0.03,
            "variance {v}, mean {m}"
        );
    }

    #[test]
    fn read_noise_is_gaussian_with_its_variance_and_adds_no_level() {
        let p = Physical {
            read_noise_e: 8.0,
            bias_adu: 1000.0,
            ..quiet()
        };
        let img = image(&p, 5.0, 0);
        let (m, v) = mean_var(&img);
        assert!((m - 1000.0).abs() < 0.1, "mean {m}");
        assert!(((v - 1.0 / 12.0) / 64.0 - 1.0).abs() < 0.03, "variance {v}");
        // Gaussian: whole ADU within 8 of the bias are read-outs within 8.5 e-, which holds
        // erf(8.5 / 8 / sqrt 2) = 71.2% of a normal (binomial standard error 0.2%).
        let within = img
            .iter()
            .filter(|&&a| (a as f64 - 1000.0).abs() <= 8.0)
            .count();
        let share = within as f64 / img.len() as f64;
        assert!((share - 0.712).abs() < 0.01, "{share}");
    }

    #[test]
    fn dark_current_grows_with_t_and_its_noise_with_sqrt_t() {
        let p = Physical {
            dark_e_per_s: 20.0,
            ..quiet()
        };
        for t in [1.0, 10.0, 60.0] {
            let (m, v) = mean_var(&image(&p, t, 3));
            let expect = 20.0 * t;
            assert!((m / expect - 1.0).abs() < 0.01, "{t} s: mean {m}");
            assert!(
                ((v - 1.0 / 12.0) / expect - 1.0).abs() < 0.03,
                "{t} s: variance {v}"
            );
        }
    }

    #[test]
    fn full_well_and_adc_clip_without_bleeding() {
        let mut e = vec![0u32; W * W];
        e[100 * W + 100] = 1_000_000;
        let p = Physical {
            full_well_e: 100_000.0,
            bias_adu: 500.0,
            ..quiet()
        };
        let img = p.adu(&e, W, W, 1.0, 2.0, 0);
        assert_eq!(img[100 * W + 100], 50_500.0); // 1e5 e- / 2 + 500
        // No bleeding: the neighbours hold the bias alone.
        for k in [99 * W + 100, 101 * W + 100, 100 * W + 99, 100 * W + 101] {
            assert_eq!(img[k], 500.0);
        }
        // The ADC clips at its maximum, and a negative read-out at 0.
        let p = Physical {
            full_well_e: 1e7,
            adc_max_adu: 65_535.0,
            read_noise_e: 20.0,
            ..quiet()
        };
        let img = p.adu(&e, W, W, 1.0, 1.0, 0);
        assert_eq!(img[100 * W + 100], 65_535.0);
        assert!(img.iter().all(|&a| a >= 0.0) && img.contains(&0.0));
    }

    #[test]
    fn hot_pixels_sit_in_the_same_place_in_every_image() {
        let p = Physical {
            hot_pixels: Some(HotPixels {
                fraction: 1e-3,
                dark_e_per_s: 500.0,
            }),
            ..quiet()
        };
        let hot = |img: Vec<f32>| -> Vec<usize> {
            img.iter()
                .enumerate()
                .filter(|(_, a)| **a > 0.0)
                .map(|(k, _)| k)
                .collect()
        };
        let first = hot(image(&p, 5.0, 0));
        assert_eq!(first.len(), 66); // 0.1% of 65,536, rounded
        for index in [1, 17, 4000] {
            assert_eq!(hot(image(&p, 5.0, index)), first);
        }
        // Another campaign seed, another sensor.
        let other = Physical {
            seed: 8,
            ..p.clone()
        };
        assert_ne!(hot(image(&other, 5.0, 0)), first);
        // Their charge is Poisson: mean 2500 e-, drawn per image.
        let other_image = image(&p, 5.0, 2);
        let (m, _) = mean_var(&first.iter().map(|&k| other_image[k]).collect::<Vec<_>>());
        assert!((m - 2500.0).abs() < 5.0 * (2500.0f64 / 66.0).sqrt(), "{m}");
    }

    #[test]
    fn cosmic_ray_hits_follow_rate_times_area_times_t() {
        // 256 px of 13 um: 0.333 cm a side, 0.111 cm^2; 5 hits per cm^2 per s for 10 s: 5.54
        // expected hits an image.
        let c = CosmicRays {
            rate_per_cm2_s: 5.0,
            pixel_size_um: 13.0,
        };
        let expect = c.expected_hits(W, W, 10.0);
        assert!((expect - 5.0 * 0.3328 * 0.3328 * 10.0).abs() < 1e-9);
        let images = 400;
        let mut hits = 0;
        let mut lengths = Vec::new();
        for i in 0..images {
            let tracks = c.tracks(
                W,
                W,
                10.0,
                &mut pixel_stream(1, i, PixelPurpose::CosmicRays),
            );
            hits += tracks.len();
            lengths.extend(
                tracks
                    .iter()
                    .map(|t| (t.end_px[0] - t.start_px[0]).hypot(t.end_px[1] - t.start_px[1])),
            );
        }
        // The total over 400 images is Poisson with mean 2215: within 5 sigma (235).
        let mean = expect * images as f64;
        assert!(
            (hits as f64 - mean).abs() < 5.0 * mean.sqrt(),
            "{hits} hits, {mean} expected"
        );
        // Tracks of a few pixels: 15 um tan(angle) / 13 um, median at 45 deg: 1.15 px.
        lengths.sort_by(f64::total_cmp);
        let median = lengths[lengths.len() / 2];
        assert!((median - 1.15).abs() < 0.1, "median track {median} px");
        assert!(*lengths.last().unwrap() <= 15.0 * 85f64.to_radians().tan() / 13.0 + 1e-9);
        // A track's charge lands in the image.
        let p = Physical {
            cosmic_rays: Some(c),
            ..quiet()
        };
        assert!(image(&p, 10.0, 0).iter().any(|&a| a > 500.0));
    }

    #[test]
    fn components_draw_from_their_own_streams() {
        let base = Physical {
            sky_e_per_s: 40.0,
            read_noise_e: 5.0,
            bias_adu: 100.0,
            ..quiet()
        };
        let with_more = Physical {
            dark_e_per_s: 0.0,
            hot_pixels: Some(HotPixels {
                fraction: 1e-3,
                dark_e_per_s: 500.0,
            }),
            ..base.clone()
        };
        let (a, b) = (image(&base, 5.0, 9), image(&with_more, 5.0, 9));
        let hot = HotPixels {
            fraction: 1e-3,
            dark_e_per_s: 500.0,
        }
        .positions(7, W, W);
        // Only the hot pixels differ: the sky and read noise drew the same numbers.
        let differ: Vec<usize> = (0..a.len()).filter(|&k| a[k] != b[k]).collect();
        assert!(!differ.is_empty() && differ.iter().all(|k| hot.binary_search(k).is_ok()));
    }

    #[test]
    fn sky_brightness_converts_with_zero_point_and_pixel_scale() {
        // At the zero point, 1 e-/s per arcsec^2; 2.5 mag fainter, a tenth.
        assert!((sky_e_per_s(22.26, 22.26, 1.0) - 1.0).abs() < 1e-12);
        assert!((sky_e_per_s(24.76, 22.26, 1.0) - 0.1).abs() < 1e-12);
        // The paper's sensor: 0.1 deg over 512 px = 0.703 arcsec; 21 mag/arcsec^2 gives
        // 10^(0.4 x 1.26) x 0.703^2 = 1.578 e-/s.
        let e = sky_e_per_s(21.0, 22.26, 0.1 * 3600.0 / 512.0);
        assert!((e - 1.5778).abs() < 1e-4, "{e}");
    }

    /// The run time of each component on a 1024 x 1024, 5 s exposure (the README's figures):
    /// `cargo test --release --lib noise_component_cost -- --ignored --nocapture`. Interleaved,
    /// median of 5 rounds.
    #[test]
    #[ignore = "a measurement, not a check"]
    fn noise_component_cost() {
        let w = 1024;
        let e = vec![0u32; w * w];
        let none = Physical {
            read_noise_e: 0.0,
            ..quiet()
        };
        let variants = [
            ("nothing on (charge, ADC)", none.clone()),
            (
                "sky 5 e-/s",
                Physical {
                    sky_e_per_s: 5.0,
                    ..none.clone()
                },
            ),
            (
                "sky 200 e-/s",
                Physical {
                    sky_e_per_s: 200.0,
                    ..none.clone()
                },
            ),
            (
                "dark 0.5 e-/s",
                Physical {
                    dark_e_per_s: 0.5,
                    ..none.clone()
                },
            ),
            (
                "read noise 5 e-",
                Physical {
                    read_noise_e: 5.0,
                    ..none.clone()
                },
            ),
            (
                "hot pixels 1e-4",
                Physical {
                    hot_pixels: Some(HotPixels {
                        fraction: 1e-4,
                        dark_e_per_s: 50.0,
                    }),
                    ..none.clone()
                },
            ),
            (
                "cosmic rays 5 /cm2/s",
                Physical {
                    cosmic_rays: Some(CosmicRays {
                        rate_per_cm2_s: 5.0,
                        pixel_size_um: 13.0,
                    }),
                    ..none.clone()
                },
            ),
        ];
        let mut times = vec![Vec::new(); variants.len()];
        for round in 0..5 {
            for (k, (_, p)) in variants.iter().enumerate() {
                let t = std::time::Instant::now();
                std::hint::black_box(p.adu(&e, w, w, 5.0, 1.6, round));
                times[k].push(t.elapsed().as_secs_f64() * 1e3);
            }
        }
        for ((name, _), mut t) in variants.iter().zip(times) {
            t.sort_by(f64::total_cmp);
            println!("{name}: {:.1} ms", t[2]);
        }
    }
}
