//! `[noise]`: the detector's noise model as written in a campaign. `model = "paper"` (the
//! default, left out of the resolved campaign so existing hashes stay) is the paper's uniform
//! background and bias of `[sensor]`; `model = "physical"` a detector in electrons (see
//! `crate::noise`). Each physical component at zero is off and costs nothing.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::{Background, defaults};

/// The detector's noise model.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq, Default)]
#[serde(tag = "model", rename_all = "lowercase")]
pub enum Noise {
    /// The paper's: uniform background (`sensor.background_*`) and bias (`sensor.bias_*`).
    #[default]
    Paper,
    /// A physical detector: Poisson sky, dark current, hot pixels, cosmic rays, full well,
    /// Gaussian read noise, bias and an ADC; the gain is `sensor.gain_e_per_adu`.
    Physical(PhysicalNoise),
}

impl Noise {
    pub fn is_paper(&self) -> bool {
        *self == Noise::Paper
    }

    /// Field checks; `background` must be the uniform one (a real frame brings its own sky).
    pub fn check(&self, background: &Background) -> Result<(), (&'static str, String)> {
        let Noise::Physical(p) = self else {
            return Ok(());
        };
        let check = |ok: bool, field: &'static str, msg: &str| {
            if ok {
                Ok(())
            } else {
                Err((field, msg.to_string()))
            }
        };
        let within = |x: f64, lo: f64, hi: f64| x.is_finite() && x >= lo && x <= hi;
        check(
            *background == Background::Uniform,
            "model",
            "the physical model draws its own sky: it needs `background.kind = \"uniform\"` (real frames bring theirs)",
        )?;
        check(
            !(p.sky_e_per_s.is_some() && p.sky_mag_per_arcsec2.is_some()),
            "sky_mag_per_arcsec2",
            "give the sky either as `sky_e_per_s` or as `sky_mag_per_arcsec2`, not both",
        )?;
        // Each field's range, in the order they are checked; the sky's only where given.
        #[rustfmt::skip]
        let sky = [
            p.sky_e_per_s.map(|e| (e, 0.0, 1e7, "sky_e_per_s", "must be in [0, 1e7] e-/s per pixel")),
            p.sky_mag_per_arcsec2.map(|m| (m, 0.0, 40.0, "sky_mag_per_arcsec2", "must be a surface brightness in [0, 40] mag/arcsec^2")),
        ];
        #[rustfmt::skip]
        let detector = [
            (p.dark_e_per_s, 0.0, 1e6, "dark_e_per_s", "must be in [0, 1e6] e-/s per pixel"),
            (p.read_noise_e, 0.0, 1e4, "read_noise_e", "must be in [0, 10000] e- rms"),
            (p.full_well_e, 1.0, 1e9, "full_well_e", "must be in [1, 1e9] e-"),
            (p.adc_max_adu, 1.0, 4294967295.0, "adc_max_adu", "must be in [1, 4294967295] ADU (65535 for a 16-bit ADC)"),
            (p.bias_adu, 0.0, p.adc_max_adu, "bias_adu", "must be in [0, adc_max_adu] ADU"),
            (p.hot_pixel_fraction, 0.0, 1.0, "hot_pixel_fraction", "must be a share of the pixels in [0, 1]"),
            (p.hot_pixel_dark_e_per_s, 0.0, 1e7, "hot_pixel_dark_e_per_s", "must be in [0, 1e7] e-/s"),
            (p.cosmic_rate_per_cm2_s, 0.0, 1e5, "cosmic_rate_per_cm2_s", "must be in [0, 1e5] hits per cm^2 per s"),
            (p.pixel_size_um, 0.5, 100.0, "pixel_size_um", "must be a pixel pitch in [0.5, 100] um"),
        ];
        for (x, lo, hi, field, msg) in sky.into_iter().flatten().chain(detector) {
            check(within(x, lo, hi), field, msg)?;
        }
        Ok(())
    }
}

/// The physical detector's parameters (the defaults: a TELEDYNE CCD47-20-like sensor with the
/// sky, dark current, hot pixels and cosmic rays off).
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PhysicalNoise {
    /// Sky background, photo-electrons per second per pixel (Poisson)...
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sky_e_per_s: Option<f64>,
    /// ...or as a surface brightness, converted with `sensor.zero_point_mag` and the pixel
    /// scale (give one of the two; neither: no sky).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sky_mag_per_arcsec2: Option<f64>,
    /// Dark current, electrons per second per pixel (Poisson).
    #[serde(default)]
    pub dark_e_per_s: f64,
    /// Read noise, electrons rms (Gaussian).
    #[serde(default = "defaults::read_noise")]
    pub read_noise_e: f64,
    /// Bias level, ADU.
    #[serde(default = "defaults::bias_level")]
    pub bias_adu: f64,
    /// Full-well capacity, electrons: charge beyond it is lost (no bleeding).
    #[serde(default = "defaults::full_well")]
    pub full_well_e: f64,
    /// Largest ADC output, ADU: the image is rounded to whole ADU and clipped to [0, this].
    #[serde(default = "defaults::adc_max")]
    pub adc_max_adu: f64,
    /// Share of pixels that are hot, fixed per sensor (per campaign seed), not per image.
    #[serde(default)]
    pub hot_pixel_fraction: f64,
    /// Dark current of a hot pixel, electrons per second, on top of `dark_e_per_s`.
    #[serde(default = "defaults::hot_pixel_dark")]
    pub hot_pixel_dark_e_per_s: f64,
    /// Cosmic-ray hits per cm^2 of sensor per second (LEO away from the South Atlantic
    /// Anomaly: about 1-5).
    #[serde(default)]
    pub cosmic_rate_per_cm2_s: f64,
    /// Pixel pitch, micrometres: the sensor's area for cosmic rays, and their track length.
    #[serde(default = "defaults::pixel_size")]
    pub pixel_size_um: f64,
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use crate::campaign::Campaign;
    use crate::noise;

    const ORBIT: &str = "elements = { period_min = 375.48, inclination_deg = 52.78, apogee_km = 20490.0, perigee_km = 1235.0 }";

    fn campaign(noise: &str) -> Result<Campaign, String> {
        let text = format!(
            "name = \"t\"\n[observer]\nnorad = 1\n{ORBIT}\n[[debris]]\nnorad = 40649\n{ORBIT}\n{noise}"
        );
        Campaign::from_toml(&text, Path::new("/nowhere/c.toml")).map_err(|e| e.to_string())
    }

    #[test]
    fn the_papers_model_stays_out_of_the_hash() {
        let paper = campaign("").unwrap();
        assert_eq!(
            campaign("[noise]\nmodel = \"paper\"\n").unwrap().hash,
            paper.hash
        );
        let json = serde_json::to_string(&paper.resolved).unwrap();
        assert!(!json.contains("\"noise\""), "{json}");
        let physical = campaign("[noise]\nmodel = \"physical\"\n").unwrap();
        assert_ne!(physical.hash, paper.hash);
    }

    #[test]
    fn a_sky_in_mag_per_arcsec2_becomes_electrons_per_pixel() {
        let c = campaign("[noise]\nmodel = \"physical\"\nsky_mag_per_arcsec2 = 21.0\n").unwrap();
        let x = crate::experiment::of(&c);
        let crate::noise::Noise::Physical(p) = &x.sensor.noise else {
            panic!("physical model expected")
        };
        // 0.1 deg over 512 px: 0.703 arcsec pixels; see noise::tests for the figure.
        assert!((p.sky_e_per_s - 1.5778).abs() < 1e-4, "{}", p.sky_e_per_s);
        assert_eq!(p.seed, c.resolved.seed);
        assert!(p.hot_pixels.is_none() && p.cosmic_rays.is_none());
        let c = campaign(
            "[noise]\nmodel = \"physical\"\nhot_pixel_fraction = 1e-4\ncosmic_rate_per_cm2_s = 2.0\n",
        )
        .unwrap();
        let x = crate::experiment::of(&c);
        let crate::noise::Noise::Physical(p) = &x.sensor.noise else {
            panic!("physical model expected")
        };
        assert_eq!(
            p.hot_pixels,
            Some(noise::HotPixels {
                fraction: 1e-4,
                dark_e_per_s: 50.0
            })
        );
        assert_eq!(p.cosmic_rays.as_ref().unwrap().pixel_size_um, 13.0);
    }

    #[test]
    fn bad_values_name_line_and_field() {
        // The last line of each holds the bad value: the error names its line and its key.
        let cases = [
            "read_noise_e = -1.0",
            "dark_e_per_s = inf",
            "sky_e_per_s = 1.0\nsky_mag_per_arcsec2 = 21.0",
            "hot_pixel_fraction = 1.5",
            "bias_adu = 70000.0",
            "adc_max_adu = 0.0",
            "full_well_e = 0.0",
            "cosmic_rate_per_cm2_s = -2.0",
            "pixel_size_um = 0.0",
        ];
        for lines in cases {
            // The case follows `[noise]` (line 8 of the campaign) and `model` (line 9).
            let at = 9 + lines.lines().count();
            let (key, _) = lines.lines().last().unwrap().split_once(" = ").unwrap();
            let e = campaign(&format!("[noise]\nmodel = \"physical\"\n{lines}\n")).unwrap_err();
            assert!(
                e.starts_with(&format!("/nowhere/c.toml:{at}: field `noise.{key}`: ")),
                "{e}"
            );
        }
        let e = campaign("[noise]\nmodel = \"physical\"\nread_nois_e = 3.0\n").unwrap_err();
        assert!(e.contains("read_nois_e"), "{e}");
        let e = campaign(
            "[background]\nkind = \"frames\"\npaths = [\"f.fits\"]\n[noise]\nmodel = \"physical\"\n",
        )
        .unwrap_err();
        assert!(e.contains("noise.model") && e.contains("uniform"), "{e}");
    }
}
