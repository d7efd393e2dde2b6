//! The truth's observations as a CCSDS Tracking Data Message (CCSDS 503.0-B-2, KVN), for orbit
//! determination tools: `export/tdm/truth.tdm`, one segment per image (per object of a
//! catalogue scene's image), the debris' (RA, Dec)
//! seen from the observing satellite at the exposure's start, middle and end (`ANGLE_TYPE =
//! RADEC`, `ANGLE_1` right ascension, `ANGLE_2` declination, degrees), from the truth sidecars'
//! `ephemeris`. The angles are topocentric to the observer, on GCRS axes (ICRS to
//! milliarcseconds): geometric, or light-time corrected and aberrated (apparent) when the
//! campaign sets `render.apparent_positions`; the header says which. The visual magnitude at
//! mid-exposure is `MAG` (a TDM 2.0 data keyword); the SNR a comment.
//!
//! A catalogue scene's image (`[population]`) gives one segment per object with an ephemeris.
//! Images with several placed objects (`[objects]`) carry no per-object ephemeris in their
//! truth (each is turned rigidly into the field, its RA/Dec not its orbit's): they are left
//! out, and the header counts them (as it counts an image none of whose objects has one).

use std::path::{Path, PathBuf};

use anyhow::Context;

use crate::store::fs;

/// The file the export writes, inside its folder.
pub const FILE: &str = "truth.tdm";

/// One image's observation from its truth sidecar.
struct Observation {
    image: String,
    object: String,
    norad: u64,
    start: hifitime::Epoch,
    exposure_s: f64,
    radec: [[f64; 2]; 3],
    magnitude: f64,
    snr: f64,
}

/// The observations of truth sidecar `path`: its one object's, or each of its `objects` with
/// an ephemeris (a catalogue scene's); empty for an image of placed objects.
fn observations_of(path: &Path) -> anyhow::Result<Vec<Observation>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let t: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
    match t.get("objects").and_then(|o| o.as_array()) {
        None => Ok(observation_of(path, &t, &t)?.into_iter().collect()),
        Some(objects) => {
            let mut out = Vec::new();
            for o in objects {
                out.extend(observation_of(path, &t, o)?);
            }
            Ok(out)
        }
    }
}

/// The observation of object `o` (the sidecar itself for a one-object image) of sidecar `t`
/// read from `path`; None without an ephemeris.
fn observation_of(
    path: &Path,
    t: &serde_json::Value,
    o: &serde_json::Value,
) -> anyhow::Result<Option<Observation>> {
    let e = &o["ephemeris"];
    if e.is_null() {
        return Ok(None);
    }
    let bad = |field: &str| {
        anyhow::anyhow!(
            "{}: field `{field}` missing or not a number",
            path.display()
        )
    };
    let num = |v: &serde_json::Value, field: &str| v.as_f64().ok_or_else(|| bad(field));
    let pair = |key: &str| -> anyhow::Result<[f64; 2]> {
        Ok([num(&e[key][0], key)?, num(&e[key][1], key)?])
    };
    let start_utc = t["start_utc"].as_str().ok_or_else(|| bad("start_utc"))?;
    let start = parse_utc(start_utc).ok_or_else(|| {
        anyhow::anyhow!(
            "{}: start_utc {start_utc:?} is not YYYY-MM-DDThh:mm:ss.ffffff",
            path.display()
        )
    })?;
    Ok(Some(Observation {
        image: path
            .file_stem()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned(),
        object: o["object"]
            .as_str()
            .ok_or_else(|| bad("object"))?
            .to_string(),
        norad: o["norad"].as_u64().ok_or_else(|| bad("norad"))?,
        start,
        exposure_s: num(&t["exposure_s"], "exposure_s")?,
        radec: [
            pair("debris_radec_start_deg")?,
            pair("debris_radec_mid_deg")?,
            pair("debris_radec_end_deg")?,
        ],
        magnitude: num(&o["magnitude"], "magnitude")?,
        snr: num(&o["snr"], "snr")?,
    }))
}

/// The epoch of `iso_utc`'s `YYYY-MM-DDThh:mm:ss.ffffff` (UTC).
pub(crate) fn parse_utc(s: &str) -> Option<hifitime::Epoch> {
    let (date, time) = s.split_once('T')?;
    let d: Vec<i64> = date
        .split('-')
        .map(|v| v.parse().ok())
        .collect::<Option<_>>()?;
    let (hms, frac) = time.split_once('.').unwrap_or((time, "0"));
    let t: Vec<u8> = hms
        .split(':')
        .map(|v| v.parse().ok())
        .collect::<Option<_>>()?;
    let ns = format!("{frac:0<9}").get(..9)?.parse::<u32>().ok()?;
    if d.len() != 3 || t.len() != 3 {
        return None;
    }
    let (y, mo, day) = (
        i32::try_from(d[0]).ok()?,
        u8::try_from(d[1]).ok()?,
        u8::try_from(d[2]).ok()?,
    );
    hifitime::Epoch::maybe_from_gregorian_utc(y, mo, day, t[0], t[1], t[2], ns).ok()
}

/// A TDM value: KVN allows no line break, and `=` would end the keyword.
fn kvn_text(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect()
}

/// A segment's metadata, to its `DATA_START`: angles (RA, Dec on ICRF axes) from `observer`
/// (participant 1) to `target` (participant 2, already KVN text) between `times`, `comment`
/// first.
fn segment_start(comment: &str, times: [&str; 2], observer: &str, target: &str) -> String {
    format!(
        "\nMETA_START\n\
         COMMENT {comment}\n\
         TIME_SYSTEM = UTC\n\
         START_TIME = {}\n\
         STOP_TIME = {}\n\
         PARTICIPANT_1 = {}\n\
         PARTICIPANT_2 = {target}\n\
         MODE = SEQUENTIAL\n\
         PATH = 2,1\n\
         ANGLE_TYPE = RADEC\n\
         REFERENCE_FRAME = ICRF\n\
         META_STOP\n\
         DATA_START\n",
        times[0],
        times[1],
        kvn_text(observer),
    )
}

/// The TDM of `observations`, the observer named `observer`, apparent or geometric places.
fn tdm(observer: &str, apparent: bool, observations: &[Observation], skipped: usize) -> String {
    let places = if apparent {
        "astrometric as a plate solution measures them (render.apparent_positions: the debris at\n\
         COMMENT its light-time position, aberrated by the observer's motion, in the stars' catalogue\n\
         COMMENT frame; crates/sky/src/apparent.rs)"
    } else {
        "geometric (no light time, no aberration)"
    };
    let mut s = format!(
        "CCSDS_TDM_VERS = 2.0\n\
         COMMENT soig truth: the debris' RA/Dec seen from the observing satellite (topocentric to it),\n\
         COMMENT on GCRS axes (ICRS to milliarcseconds), {places}; at the\n\
         COMMENT exposure's start, middle and end of each image. Angles in degrees.\n\
         COMMENT {skipped} image(s) of placed objects left out (no per-object ephemeris in their truth)\n\
         CREATION_DATE = {}\n\
         ORIGINATOR = soig\n",
        // The output's contents, not the clock: the same run exports the same bytes.
        observations
            .first()
            .map_or("2000-01-01T00:00:00.000000".to_string(), |o| {
                crate::render::iso_utc(o.start)
            }),
    );
    for o in observations {
        let at = |k: usize| {
            crate::render::iso_utc(
                o.start + hifitime::Duration::from_seconds(o.exposure_s * k as f64 / 2.0),
            )
        };
        s += &segment_start(
            &format!("image {}: SNR {:.3}", o.image, o.snr),
            [&at(0), &at(2)],
            observer,
            &format!("{} (NORAD {})", kvn_text(&o.object), o.norad),
        );
        for (k, [ra, dec]) in o.radec.iter().enumerate() {
            s += &format!(
                "ANGLE_1 = {} {ra:.10}\nANGLE_2 = {} {dec:.10}\n",
                at(k),
                at(k)
            );
            if k == 1 {
                s += &format!("MAG = {} {:.6}\n", at(k), o.magnitude);
            }
        }
        s += "DATA_STOP\n";
    }
    s
}

/// The detectors' observations (src/product/observations.rs) as a TDM: one segment per
/// detection, its two ends' (RA, Dec) at the exposure's start and end in the rule's order (the
/// end of smaller PNG x first: which is first is not known), the model's one-sigma uncertainty
/// a comment (TDM has no per-angle sigma keyword). An end the image's edge cuts is left out; a
/// detection with both cut has no segment.
pub fn detections(
    observations: &[&crate::observations::Observation],
    observer: &str,
    apparent: bool,
    truth: bool,
) -> String {
    let places = if apparent {
        "apparent (render.apparent_positions)"
    } else {
        "geometric"
    };
    let what = if truth {
        "COMMENT soig truth: each labelled object's streak ends (its first and last trajectory samples)\n\
         COMMENT through the image's FITS WCS, each at its own instant (half a time slice inside the\n\
         COMMENT exposure). Angles in degrees, on the WCS's ICRS axes"
    } else {
        "COMMENT soig detections: each detection's two streak ends through the image's FITS WCS,\n\
         COMMENT the first (by PNG x, then y) at the exposure's start, the second at its end: which\n\
         COMMENT end came first is not known. Angles in degrees, on the WCS's ICRS axes"
    };
    let mut s = format!(
        "CCSDS_TDM_VERS = 2.0\n\
         {what} ({places}).\n\
         CREATION_DATE = {}\n\
         ORIGINATOR = soig\n",
        observations
            .first()
            .map_or("2000-01-01T00:00:00.000000".to_string(), |o| {
                crate::render::iso_utc(o.times[0])
            }),
    );
    // The truth's ends are numbered by the image's label lines.
    let item = if truth { "label" } else { "detection" };
    for o in observations.iter().filter(|o| !(o.cut[0] && o.cut[1])) {
        let [t0, t1] = o.times.map(crate::render::iso_utc);
        let sigma = match o.uncertainty {
            Some(u) => format!(
                "one-sigma {:.4}\" along, {:.4}\" across the streak",
                u.along_arcsec, u.across_arcsec
            ),
            None if truth => "the truth's place, no uncertainty".to_string(),
            None => "no uncertainty (the detector gives no SNR)".to_string(),
        };
        s += &segment_start(
            &format!(
                "{} {} {item} {}: score {:.4}, {sigma}",
                o.detector, o.image, o.detection, o.score
            ),
            [&t0, &t1],
            observer,
            &format!(
                "{} {} {item} {}",
                kvn_text(&o.detector),
                o.image,
                o.detection
            ),
        );
        // An end the image's edge cuts is no observation (observations.rs).
        for ((t, [ra, dec]), _) in [&t0, &t1]
            .into_iter()
            .zip(o.radec[0])
            .zip(o.cut)
            .filter(|(_, cut)| !cut)
        {
            s += &format!(
                "ANGLE_1 = {t} {:.10}\nANGLE_2 = {t} {dec:.10}\n",
                ra.rem_euclid(360.0)
            );
        }
        s += "DATA_STOP\n";
    }
    s
}

/// Write the truth's TDM of the output `output`, made by the resolved `campaign`, into `dest`;
/// returns the file written.
pub fn write(
    output: &Path,
    campaign: &serde_json::Value,
    dest: &Path,
) -> anyhow::Result<Vec<PathBuf>> {
    let observer = campaign["observer"]["name"]
        .as_str()
        .map(String::from)
        .or_else(|| {
            campaign["observer"]["norad"]
                .as_u64()
                .map(|n| format!("NORAD {n}"))
        })
        .unwrap_or_else(|| "observer".to_string());
    let apparent = campaign["render"]["apparent_positions"].as_bool() == Some(true);
    let truth = output.join("truth");
    let mut observations = Vec::new();
    let mut skipped = 0;
    for stem in super::stems(&truth, "json")? {
        let found = observations_of(&truth.join(format!("{stem}.json")))?;
        if found.is_empty() {
            skipped += 1;
        }
        observations.extend(found);
    }
    fs::create_dir_all(dest)?;
    let path = dest.join(FILE);
    fs::create(&path, tdm(&observer, apparent, &observations, skipped))?;
    Ok(vec![path])
}
