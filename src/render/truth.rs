//! The truth of one image as rendered: the JSON sidecar's contents.

use serde::Serialize;

use crate::geometry::{BoxPx, Frame};
use crate::scene::Pointing;

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
    /// The real frame of a semisynthetic image: its file name and sha256 (not its path, which
    /// depends on the directory soig runs from).
    pub background_frame: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub background_frame_sha256: Option<String>,
    pub attempts: u32,
    pub rejections: std::collections::BTreeMap<&'static str, u32>,
}

/// ISO 8601 UTC with milliseconds, e.g. `2022-03-04T05:06:07.891`.
pub(crate) fn iso_utc(t: hifitime::Epoch) -> String {
    let (y, mo, d, h, mi, s, ns) = t.to_gregorian_utc();
    format!(
        "{y:04}-{mo:02}-{d:02}T{h:02}:{mi:02}:{s:02}.{:03}",
        ns / 1_000_000
    )
}
