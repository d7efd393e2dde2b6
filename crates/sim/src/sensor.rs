//! The sensor model: the optics (image size, pixel scale, PSF, zero point and limiting
//! magnitude), the pointing stability (Brownian jitter) and the detector with its noise
//! (gain, bias, the paper's uniform sky background). A value built once from the campaign;
//! the scene draw and the renderers read it and never the campaign file.

use crate::background::RealFrame;
use crate::noise::Noise;
use soig_sky::projection::Tan;

/// A uniform range of ADU per pixel, drawn uniformly (the paper's background and bias).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AduRange {
    pub min_adu: f64,
    pub max_adu: f64,
}

/// The camera and detector of a campaign.
#[derive(Clone, Debug, PartialEq)]
pub struct Sensor {
    pub width_px: usize,
    pub height_px: usize,
    /// Half the field of view along the image width.
    pub fov_radius_deg: f64,
    /// Gaussian PSF standard deviation on the sky.
    pub psf_sigma_arcsec: f64,
    /// The magnitude that gives 1 photo-electron per second.
    pub zero_point_mag: f64,
    /// Faintest magnitude the sensor detects.
    pub mag_limit: f64,
    /// Brownian pointing jitter (Eq. 2), degrees per sqrt(second).
    pub jitter_deg_per_sqrt_s: f64,
    /// Photo-electrons per ADU.
    pub gain_e_per_adu: f64,
    pub bias: AduRange,
    /// The paper's sky background for `background_exposure_s`, scaled linearly with exposure.
    pub background: AduRange,
    pub background_exposure_s: f64,
    /// The noise model: the paper's (the ranges above) or a physical one.
    pub noise: Noise,
}

impl Sensor {
    /// For tests (this crate's and the detectors'): the campaigns' optics (0.70 arcsec pixels: 0.1 deg over 1024 px, a 1
    /// arcsec PSF), the paper's detector and noise, on a square image of `side_px` with jitter
    /// `jitter_deg_per_sqrt_s` (the paper's: 2e-4 deg per sqrt(s)).
    pub fn for_tests(side_px: usize, jitter_deg_per_sqrt_s: f64) -> Sensor {
        Sensor {
            width_px: side_px,
            height_px: side_px,
            fov_radius_deg: 0.1 * side_px as f64 / 1024.0,
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
            noise: Noise::Paper,
        }
    }
}

impl Sensor {
    /// Degrees per pixel: the field radius spans half the image width.
    pub fn pixel_scale_deg(&self) -> f64 {
        self.fov_radius_deg / (self.width_px as f64 / 2.0)
    }

    /// This sensor under a sky of `sky_v` mag/arcsec^2 (a ground site's, `sky_glow`) in place
    /// of its physical noise model's own; itself when None or with the paper's noise (which
    /// has no sky in magnitudes: the campaign refuses a ground sky with it).
    pub fn under_sky(&self, sky_v: Option<f64>) -> std::borrow::Cow<'_, Sensor> {
        match (&self.noise, sky_v) {
            (Noise::Physical(p), Some(v)) => {
                let scale_arcsec = self.pixel_scale_deg() * 3600.0;
                let sky = crate::noise::sky_e_per_s(v, self.zero_point_mag, scale_arcsec);
                std::borrow::Cow::Owned(Sensor {
                    noise: Noise::Physical(crate::noise::Physical {
                        sky_e_per_s: sky,
                        ..p.clone()
                    }),
                    ..self.clone()
                })
            }
            _ => std::borrow::Cow::Borrowed(self),
        }
    }

    /// The PSF's Gaussian sigma in pixels.
    pub fn psf_sigma_px(&self) -> f64 {
        self.psf_sigma_arcsec / 3600.0 / self.pixel_scale_deg()
    }

    /// The PSF's full width at half maximum in pixels (written out as the scene gate has
    /// always computed it, so its rounding, and so scene acceptance, stays the same).
    pub fn psf_fwhm_px(&self) -> f64 {
        2.3548 * self.psf_sigma_arcsec / 3600.0 / self.pixel_scale_deg()
    }

    /// The gnomonic projection of the image pointed at (ra, dec).
    pub fn projection(&self, ra_deg: f64, dec_deg: f64) -> Tan {
        Tan::new(
            ra_deg,
            dec_deg,
            self.pixel_scale_deg(),
            self.width_px as u32,
            self.height_px as u32,
        )
    }

    /// Whether pixel coordinates fall in the image (pixel centres at integers).
    pub fn contains(&self, x: f64, y: f64) -> bool {
        let (w, h) = (self.width_px as f64, self.height_px as f64);
        x >= -0.5 && x < w - 0.5 && y >= -0.5 && y < h - 0.5
    }

    /// The mean sky level of the uniform background for an exposure, ADU: where a real
    /// frame's fluctuations are put.
    pub fn sky_level_adu(&self, exposure_s: f64) -> f64 {
        (self.background.min_adu + self.background.max_adu) / 2.0 * exposure_s
            / self.background_exposure_s
    }

    /// The mean level of the background and bias noise matrices per pixel, ADU, for an
    /// exposure: what the detector (`render::detector`) adds to every pixel besides the
    /// photo-electrons. The uniform model's mean, or the real frame's scaled level; both plus
    /// the mean bias. The paper's signal-to-noise gate divides
    /// by this (see `scene::SnrDefinition`).
    pub fn noise_level_adu(&self, exposure_s: f64, frame: Option<&RealFrame>) -> f64 {
        // A physical detector's noise matrices are its bias and its sky and dark charge.
        if let Noise::Physical(p) = &self.noise {
            return p.bias_adu
                + (p.sky_e_per_s + p.dark_e_per_s) * exposure_s / self.gain_e_per_adu;
        }
        let bias = (self.bias.min_adu + self.bias.max_adu) / 2.0;
        // A real frame's noise matrix, level included, replaces the uniform background.
        let background = frame.map_or_else(
            || self.sky_level_adu(exposure_s),
            |f| f.level_adu(exposure_s),
        );
        background + bias
    }

    /// Background plus bias noise standard deviation per pixel, ADU, for an exposure: the
    /// uniform model's, or the real frame's robust sigma scaled by exposure; for a physical
    /// detector, its sky and dark shot noise and read noise.
    pub fn background_sigma_adu(&self, exposure_s: f64, frame: Option<&RealFrame>) -> f64 {
        if let Noise::Physical(p) = &self.noise {
            let variance_e = (p.sky_e_per_s + p.dark_e_per_s) * exposure_s + p.read_noise_e.powi(2);
            return variance_e.sqrt() / self.gain_e_per_adu;
        }
        let bias = self.bias.max_adu - self.bias.min_adu;
        let bias_var = bias * bias / 12.0;
        match frame {
            Some(f) => {
                let bg = f.sigma * exposure_s / f.exposure_s;
                (bg * bg + bias_var).sqrt()
            }
            None => {
                let k = exposure_s / self.background_exposure_s;
                let bg = (self.background.max_adu - self.background.min_adu) * k;
                (bg * bg / 12.0 + bias_var).sqrt()
            }
        }
    }
}
