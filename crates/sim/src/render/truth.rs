//! The truth of one image as rendered: the JSON sidecar's contents.

use serde::Serialize;

use crate::scene::Pointing;
use soig_image::geometry::{BoxPx, Frame};

/// The truth of one image, written as the JSON sidecar.
#[derive(Clone, Debug, Serialize)]
pub struct Truth {
    /// What the coordinates below mean: [`COORDINATES`], and in survey pointing
    /// [`SURVEY_COORDINATES`] too.
    pub coordinates: String,
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
    #[serde(flatten)]
    pub streak: StreakEnds,
    /// The label box of the debris as rendered, in the original image (None when no debris
    /// photon landed).
    pub label_box_px: Option<BoxPx>,
    /// The frame of the final PNG (original, padded or rotated) and the label box in it.
    pub frame: Option<Frame>,
    pub label_box_final_px: Option<BoxPx>,
    #[serde(flatten)]
    pub seen: Seen,
    /// The streak's integrated matched-filter SNR, `sqrt(sum_i s_i^2 / sigma_i^2)` over pixels
    /// with shot noise (`render::expected::matched_filter_snr`): below ~7 it is hard to find.
    pub snr_matched_filter: f64,
    pub stars_in_cone: usize,
    pub stars_traced: usize,
    pub background_sigma_adu: f64,
    /// The real frame of a semisynthetic image: its file name and sha256 (not its path, which
    /// depends on the directory soig runs from).
    pub background_frame: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub background_frame_sha256: Option<String>,
    pub attempts: u32,
    pub rejections: std::collections::BTreeMap<crate::scene::Rejection, u32>,
    /// The debris' RA/Dec at start, middle and end, and the GCRS states at mid-exposure.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ephemeris: Option<crate::sighting::Ephemeris>,
    /// The image's place in its multi-frame collect, with the object's track id.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub collect: Option<crate::scene::CollectFrame>,
    /// A ground site's seeing in this image: the Moffat's FWHM, beta and the boresight's
    /// airmass.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seeing: Option<crate::atmosphere::Seeing>,
    /// A ground site's scintillation of the object: its relative rms, the flux factor drawn
    /// (already in `expected_debris_electrons`) and the object's airmass.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scintillation: Option<crate::atmosphere::Scintillation>,
    /// A ground site's sky toward the boresight, V mag/arcsec^2 (dark sky, twilight, Moon).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sky_v_mag_per_arcsec2: Option<f64>,
}

/// Where an object's streak runs, in a [`Truth`] and an [`ObjectTruth`] (flattened: the
/// sidecar's fields keep their names and order).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct StreakEnds {
    /// Pixel coordinates of the debris at the first and last trajectory samples, jitter
    /// included (may lie outside the image).
    #[serde(rename = "streak_start_px")]
    pub start_px: [f64; 2],
    #[serde(rename = "streak_end_px")]
    pub end_px: [f64; 2],
    /// The (RA, Dec), degrees, that the image's FITS WCS gives at `start_px` and `end_px`:
    /// what an astrometric measurement of the streak's ends reads. In survey pointing they
    /// differ from the ephemeris' start and end (see [`SURVEY_COORDINATES`]).
    #[serde(rename = "streak_start_wcs_radec_deg")]
    pub start_wcs_radec_deg: [f64; 2],
    #[serde(rename = "streak_end_wcs_radec_deg")]
    pub end_wcs_radec_deg: [f64; 2],
}

/// How an object was seen, in a [`Truth`] and an [`ObjectTruth`] (flattened): its brightness,
/// size, geometry and tumble at mid-exposure, its electrons and the gate's signal-to-noise.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Seen {
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
    /// The signal-to-noise ratio the scene gate judged (`visibility.snr_definition`), and
    /// both ratios: expected debris ADU per footprint pixel over the mean level of background
    /// plus bias (the paper's) and over their standard deviation (`scene::expected_snr`).
    pub snr: f64,
    pub snr_noise_level: f64,
    pub snr_noise_sigma: f64,
}

/// The truth sidecar of an image of a campaign with `[objects]` (#34): the frame's fields of
/// [`Truth`] and a list of its objects, possibly empty. (Campaigns without `[objects]` keep the
/// one-object [`Truth`], their bytes unchanged.)
#[derive(Serialize)]
pub struct FrameTruth<'a> {
    pub coordinates: &'a str,
    pub image_index: u64,
    pub start_utc: &'a str,
    pub exposure_s: f64,
    pub pointing: &'a Pointing,
    pub jitter_mean_px: [f64; 2],
    pub frame: &'a Option<Frame>,
    /// The object the pointing was drawn around (not rendered unless also in `objects`), as
    /// "NAME (NORAD n)".
    pub pointing_object: String,
    pub stars_in_cone: usize,
    pub stars_traced: usize,
    pub background_sigma_adu: f64,
    pub background_frame: &'a Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub background_frame_sha256: &'a Option<String>,
    /// The pointing draw's attempts and rejections.
    pub attempts: u32,
    pub rejections: &'a std::collections::BTreeMap<crate::scene::Rejection, u32>,
    /// The image's place in its multi-frame collect; each object has its own `track_id`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub collect: Option<CollectPlace>,
    pub objects: Vec<ObjectTruth<'a>>,
    /// A catalogue scene's objects in the field that the checks left dark, with the reason
    /// (`scene::catalogue`); absent in any other scene.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unseen: Option<&'a [crate::scene::Unseen]>,
}

/// A frame's place in its collect (a [`crate::scene::CollectFrame`] without the pointing
/// object's track id: with `[objects]` each object has its own).
#[derive(Serialize)]
pub struct CollectPlace {
    pub collect: u64,
    pub frame: u64,
    pub frames: u64,
}

/// One object of a [`FrameTruth`]: the object's fields of [`Truth`] (same meanings), its
/// place in the campaign's debris list, and its own draws. A placed object has no
/// ephemeris: its positions are turned into the field (see `scene::place`); its sky
/// positions are the light curve's and `streak_*_wcs_radec_deg`.
#[derive(Serialize)]
pub struct ObjectTruth<'a> {
    pub object: &'a str,
    pub norad: u64,
    /// In a catalogue scene, the index in the population when `source` says so.
    pub debris_index: usize,
    /// `placed` (`[objects]`: turned into the field, not where its orbit puts it), or in a
    /// catalogue scene `debris` (the object the pointing was drawn around, index in the
    /// campaign's debris), `population` (index in `[population]`'s file, observer left out)
    /// or `generated` (a breakup fragment, index among the population's bodies, which follow
    /// the file's; `norad` is its generated id).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub source: Option<&'static str>,
    /// In a multi-frame collect: the object's id, the same in every frame of the collect
    /// (`scene::object_track_id`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub track_id: Option<u64>,
    #[serde(flatten)]
    pub streak: &'a StreakEnds,
    pub label_box_px: Option<BoxPx>,
    pub label_box_final_px: Option<BoxPx>,
    #[serde(flatten)]
    pub seen: &'a Seen,
    pub snr_matched_filter: f64,
    pub attempts: u32,
    pub rejections: &'a std::collections::BTreeMap<crate::scene::Rejection, u32>,
    /// A catalogue scene's object's place at start, middle and end and the states at
    /// mid-exposure, as in [`Truth`] (a placed object has none: it is turned into the field).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ephemeris: Option<crate::sighting::Ephemeris>,
}

impl<'a> FrameTruth<'a> {
    /// The frame's truth of `scene` (with placed or catalogue objects) from the image's own
    /// (`image`) and its objects' as rendered, in `scene.placed`'s order, each with its source
    /// (placed; in a catalogue scene the pointing's debris object first, none in a stare, then
    /// the population's), and a catalogue scene's unseen objects.
    pub fn of_scene(
        image: &'a Truth,
        objects: impl Iterator<Item = &'a Truth>,
        scene: &'a crate::scene::Scene,
    ) -> Self {
        let placed = scene.placed.as_deref().unwrap_or_default();
        let source = |k: usize, s: &crate::scene::Scene| {
            Some(match (&scene.unseen, k, scene.object.norad) {
                // `[objects]`: turned into the field, not where its orbit puts it.
                (None, _, _) => "placed",
                // NORAD 0: a stare, which points at no object.
                (Some(_), 0, n) if n != 0 => "debris",
                // A breakup fragment of the population: its id is no NORAD number.
                (Some(_), _, _) if s.generated => "generated",
                (Some(_), _, _) => "population",
            })
        };
        let mut truth = FrameTruth::new(
            image,
            objects
                .zip(placed)
                .enumerate()
                .map(|(k, (t, s))| (t, s.object.debris_index, source(k, s))),
        );
        truth.unseen = scene.unseen.as_deref();
        truth
    }

    /// The frame's truth from the image's own (`image`) and its objects' with their indices
    /// in the campaign's debris.
    pub fn new(
        image: &'a Truth,
        objects: impl Iterator<Item = (&'a Truth, usize, Option<&'static str>)>,
    ) -> Self {
        FrameTruth {
            coordinates: &image.coordinates,
            image_index: image.image_index,
            start_utc: &image.start_utc,
            exposure_s: image.exposure_s,
            pointing: &image.pointing,
            jitter_mean_px: image.jitter_mean_px,
            frame: &image.frame,
            // NORAD 0: no object, a stare (`scene::catalogue`).
            pointing_object: match image.norad {
                0 => image.object.clone(),
                n => format!("{} (NORAD {n})", image.object),
            },
            stars_in_cone: image.stars_in_cone,
            stars_traced: image.stars_traced,
            background_sigma_adu: image.background_sigma_adu,
            background_frame: &image.background_frame,
            background_frame_sha256: &image.background_frame_sha256,
            attempts: image.attempts,
            rejections: &image.rejections,
            collect: image.collect.map(|k| CollectPlace {
                collect: k.collect,
                frame: k.frame,
                frames: k.frames,
            }),
            objects: objects
                .map(|(t, debris_index, source)| ObjectTruth {
                    object: &t.object,
                    norad: t.norad,
                    debris_index,
                    source,
                    track_id: t.collect.map(|k| k.track_id),
                    streak: &t.streak,
                    label_box_px: t.label_box_px,
                    label_box_final_px: t.label_box_final_px,
                    seen: &t.seen,
                    snr_matched_filter: t.snr_matched_filter,
                    attempts: t.attempts,
                    rejections: &t.rejections,
                    ephemeris: t.ephemeris,
                })
                .collect(),
            unseen: None,
        }
    }
}

/// The pixel and sky conventions of every truth, written into it so that it says them itself.
pub const COORDINATES: &str = "pixels (*_px): 0-based, pixel centres at integers: pixel i spans \
[i - 0.5, i + 0.5), FITS pixel p is at p - 1, row 0 is the first row of the FITS array and the \
top row of the PNG (YOLO labels and soig detect's outputs use pixel edges instead: pixel i spans \
[i, i + 1], +0.5 from these); streak_*_px, label_box_px in the original image, \
label_box_final_px in the PNG's frame (frame.matrix maps one to the other). RA/Dec in degrees \
on GCRS axes (ICRS to milliarcseconds), geometric unless render.apparent_positions; the FITS \
WCS is the pointing at mid-exposure.";

/// The survey addendum: why the ephemeris' start and end do not land on the streak's ends.
pub const SURVEY_COORDINATES: &str = "Survey pointing: the boresight drifts during the \
exposure, so ephemeris.debris_radec_start_deg and _end_deg (where the debris is on the sky at \
those instants) fall away from streak_start_px and streak_end_px through the mid-exposure WCS \
(by the drift over half the exposure); streak_start_wcs_radec_deg and streak_end_wcs_radec_deg \
are what that WCS gives at the streak's ends.";

/// The track addendum: the boresight follows the debris, so its streak is a point.
pub const TRACK_COORDINATES: &str = "Track pointing: the boresight follows the debris over the \
exposure (pointing.boresight_radec_start_deg, mid_*, _end_deg), so the debris stays where it is \
at mid-exposure (streak_start_px and streak_end_px differ by the jitter alone) while \
ephemeris.debris_radec_start_deg and _end_deg move with it on the sky; the stars trail along \
pointing.trail_angle_deg.";

/// ISO 8601 UTC with microseconds, e.g. `2022-03-04T05:06:07.891234` (a millisecond is 6 px
/// of LEO motion; the FITS `DATE-OBS` and the truth's `start_utc`). Truncated, not rounded, so
/// the second never rolls over.
pub fn iso_utc(t: hifitime::Epoch) -> String {
    let (y, mo, d, h, mi, s, ns) = t.to_gregorian_utc();
    format!(
        "{y:04}-{mo:02}-{d:02}T{h:02}:{mi:02}:{s:02}.{:06}",
        ns / 1_000
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn iso_utc_keeps_microseconds() {
        let t = hifitime::Epoch::from_gregorian_utc(2022, 3, 4, 5, 6, 7, 891_234_567);
        assert_eq!(super::iso_utc(t), "2022-03-04T05:06:07.891234");
        let t = hifitime::Epoch::from_gregorian_utc(2022, 12, 31, 23, 59, 59, 999_999_999);
        assert_eq!(super::iso_utc(t), "2022-12-31T23:59:59.999999");
    }
}
