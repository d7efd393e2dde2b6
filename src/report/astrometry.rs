//! The astrometric report (`[artifacts] astrometry`, issue #45 item 2): each detection's ends
//! (src/product/observations.rs, which knows no truth) against the truth ephemeris of the
//! object it matches, and the observations themselves as ADES PSV and CCSDS TDM
//! (`report/observations/`).
//!
//! - Match: the labelled object whose label box overlaps the detection's most, at IoU >= 0.5
//!   (the metrics' threshold); detections under the report's confidence threshold are left out.
//! - Residuals: the ends at the exposure's start and end against the object's ephemeris there
//!   (`ephemeris.debris_radec_start_deg`, `_end_deg`), in both pairings of the ends with the
//!   instants; the pairing of the smaller RMS is kept, and the share of detections where the
//!   rule's own order (observations.rs) was the kept one is said.
//! - Tables: the separation of each end (arcsec) by detector and by the matched object's
//!   matched-filter SNR (the truth's, so every detector is binned alike; YOLO gives none):
//!   median, 68th and 95th percentiles (linear interpolation, as numpy's default). A row
//!   `truth` puts the truth's own streak ends (`streak_start_px`, `streak_end_px`: the first
//!   and last trajectory samples, half a time slice inside the exposure) through the FITS WCS
//!   at their own instants (`truth_end_times`) against the ephemeris there: the floor of the
//!   chain (the pointing jitter about the WCS's mean); they are written as observations too.
//! - Correlation: each matched detection is given to the object whose truth track (ephemeris
//!   start and end, better pairing) lies nearest its ends, among every object of the frame
//!   with an ephemeris; the share given to the object it matches is the correlation's success.
//!   Objects without an ephemeris (placed `[objects]`, turned into the field) are counted and
//!   left out.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Context;
use serde::Deserialize;

use super::{DetectorRun, TestImage};
use crate::observations::{FrameSky, Observation, end_at, observe, streak_magnitude};
use crate::product::sky_track::interpolate;
use crate::store::fs;

/// The SNR bins' lower edges (matched-filter SNR of the truth).
const SNR_EDGES: [f64; 6] = [0.0, 10.0, 30.0, 100.0, 300.0, 1000.0];

/// What the astrometry needs of the campaign.
pub struct Setup<'a> {
    /// The campaign's `render.trajectory_samples`, the sensor, and whether a ground site's
    /// seeing sets the PSF instead (per image): what the renderer's slice count
    /// (`scene::slice_count`) is derived from, for the times of the truth's ends.
    pub trajectory_samples: usize,
    pub sensor: crate::sensor::Sensor,
    pub seeing: bool,
    /// The streak detector's PSF sigma in PNG pixels (the uncertainty model's).
    pub psf_sigma_px: f64,
    /// The observer's name for the files.
    pub observer: &'a str,
    /// The report's confidence threshold.
    pub conf: f64,
    /// Apparent or geometric places (`render.apparent_positions`), for the files' notes.
    pub apparent: bool,
}

/// One object of a truth sidecar, as far as the astrometry needs it.
#[derive(Clone, Debug)]
pub struct TruthObject {
    pub name: String,
    pub norad: u64,
    /// The object's place in the image's label lines; None without a label.
    pub label: Option<usize>,
    /// (RA, Dec) at the exposure's start, middle and end; None for a placed object.
    pub ephemeris: Option<[[f64; 2]; 3]>,
    pub snr: f64,
    /// Its magnitude at mid-exposure (the truth's `magnitude`).
    pub magnitude: f64,
    /// Its streak's ends in the original image, pixel centres: the first and last
    /// trajectory samples.
    pub ends_px: [[f64; 2]; 2],
    /// The exposure, seconds (the sidecar's own `exposure_s`, which the renderer sliced).
    pub exposure_s: f64,
    /// A ground site's seeing in the image, where the sidecar states it (one-object truth).
    pub seeing: Option<crate::atmosphere::Seeing>,
}

#[derive(Deserialize)]
struct SidecarObject {
    object: String,
    norad: u64,
    snr_matched_filter: f64,
    magnitude: f64,
    streak_start_px: [f64; 2],
    streak_end_px: [f64; 2],
    #[serde(default)]
    label_box_final_px: Option<serde_json::Value>,
    #[serde(default)]
    ephemeris: Option<SidecarEphemeris>,
}

#[derive(Deserialize)]
struct SidecarEphemeris {
    debris_radec_start_deg: [f64; 2],
    debris_radec_mid_deg: [f64; 2],
    debris_radec_end_deg: [f64; 2],
}

/// The objects of truth sidecar `path`: the one of a single-object sidecar, or each of its
/// `objects`, the labelled ones numbered in the order of the label lines.
pub fn truth_objects(path: &Path) -> anyhow::Result<Vec<TruthObject>> {
    #[derive(Deserialize)]
    struct Frame {
        exposure_s: f64,
        #[serde(default)]
        seeing: Option<crate::atmosphere::Seeing>,
    }
    let sidecar = crate::truth_sidecar::read::<Frame, SidecarObject>(path)?;
    let frame = sidecar.frame;
    let mut next = 0;
    Ok(sidecar
        .objects
        .into_iter()
        .map(|o| {
            let label = crate::truth_sidecar::labelled(&o.label_box_final_px).then(|| {
                next += 1;
                next - 1
            });
            TruthObject {
                name: o.object,
                norad: o.norad,
                label,
                ephemeris: o.ephemeris.map(|e| {
                    [
                        e.debris_radec_start_deg,
                        e.debris_radec_mid_deg,
                        e.debris_radec_end_deg,
                    ]
                }),
                snr: o.snr_matched_filter,
                magnitude: o.magnitude,
                ends_px: [o.streak_start_px, o.streak_end_px],
                exposure_s: frame.exposure_s,
                seeing: frame.seeing,
            }
        })
        .collect())
}

/// Separation of two (RA, Dec) in degrees, arcsec (the haversine, exact at small angles), and
/// the offset `b - a` east (RA times cos Dec) and north, arcsec.
pub fn offset_arcsec(a: [f64; 2], b: [f64; 2]) -> (f64, f64, f64) {
    let (ra1, d1, ra2, d2) = (
        a[0].to_radians(),
        a[1].to_radians(),
        b[0].to_radians(),
        b[1].to_radians(),
    );
    let h =
        ((d2 - d1) / 2.0).sin().powi(2) + d1.cos() * d2.cos() * ((ra2 - ra1) / 2.0).sin().powi(2);
    let sep = 2.0 * h.sqrt().min(1.0).asin();
    let dra = ((b[0] - a[0] + 540.0).rem_euclid(360.0) - 180.0) * ((d1 + d2) / 2.0).cos();
    (
        sep.to_degrees() * 3600.0,
        dra * 3600.0,
        (b[1] - a[1]) * 3600.0,
    )
}

/// The RMS separation of ends `radec[p]` from `track` for each pairing p over the ends not
/// `cut` (by the image's edge), and the better pairing; None where both ends are cut.
pub fn best_pairing(
    radec: &[[[f64; 2]; 2]; 2],
    track: &[[f64; 2]; 2],
    cut: [bool; 2],
) -> Option<(usize, f64)> {
    let rms = |p: usize| {
        let s: Vec<f64> = (0..2)
            .filter(|&k| !cut[end_at(p, k)])
            .map(|k| offset_arcsec(track[k], radec[p][k]).0)
            .collect();
        (s.iter().map(|v| v * v).sum::<f64>() / s.len() as f64).sqrt()
    };
    if cut[0] && cut[1] {
        return None;
    }
    let (r0, r1) = (rms(0), rms(1));
    Some(if r1 < r0 { (1, r1) } else { (0, r0) })
}

/// One detection's residuals against the object it matches.
#[derive(Clone, Debug)]
pub struct Residual {
    pub detector: String,
    pub image: String,
    pub detection: usize,
    pub object: String,
    pub norad: u64,
    pub snr: f64,
    /// The kept pairing: 0 the rule's order, 1 swapped.
    pub pairing: usize,
    /// Per instant (start, end): separation, east and north offsets, arcsec; None where the
    /// end taken then is cut by the image's edge.
    pub ends: [Option<(f64, f64, f64)>; 2],
    /// The object its ends' nearest truth track belongs to (NORAD), and whether it is the
    /// matched one.
    pub correlated_norad: u64,
    pub correlated: bool,
    /// The model's one-sigma separation of an end, arcsec (along and across in quadrature);
    /// None where the detector gives no SNR.
    pub sigma_arcsec: Option<f64>,
    /// The detection's magnitude less the object's at mid-exposure; None without one.
    pub magnitude_delta: Option<f64>,
}

/// The residuals of observation `o` against `objects` of its frame, matched by its box to the
/// label boxes `truth` (pixel-edge xyxy): None where it matches no labelled object with an
/// ephemeris.
pub fn residual(o: &Observation, truth: &[[f64; 4]], objects: &[TruthObject]) -> Option<Residual> {
    let (best, iou) = truth
        .iter()
        .enumerate()
        .map(|(k, t)| (k, crate::metrics::iou(t, &o.detection_box)))
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    if iou < 0.5 {
        return None;
    }
    let object = objects.iter().find(|t| t.label == Some(best))?;
    let track = start_end(object.ephemeris?);
    let (pairing, _) = best_pairing(&o.radec, &track, o.cut)?;
    let end = |k: usize| {
        (!o.cut[end_at(pairing, k)]).then(|| offset_arcsec(track[k], o.radec[pairing][k]))
    };
    let nearest = objects
        .iter()
        .filter_map(|t| {
            let e = start_end(t.ephemeris?);
            Some((t.norad, best_pairing(&o.radec, &e, o.cut)?.1))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(n, _)| n)
        .unwrap_or(object.norad);
    Some(Residual {
        detector: o.detector.clone(),
        image: o.image.clone(),
        detection: o.detection,
        object: object.name.clone(),
        norad: object.norad,
        snr: object.snr,
        pairing,
        ends: [end(0), end(1)],
        correlated_norad: nearest,
        correlated: nearest == object.norad,
        sigma_arcsec: o.uncertainty.map(|u| u.along_arcsec.hypot(u.across_arcsec)),
        magnitude_delta: o.magnitude.map(|m| m - object.magnitude),
    })
}

/// The ephemeris' places at the exposure's start and end (a detection's instants).
fn start_end(e: [[f64; 2]; 3]) -> [[f64; 2]; 2] {
    [e[0], e[2]]
}

/// The instants of the truth's ends (its first and last trajectory samples), seconds after
/// the exposure's start: the centres of the first and last of the slices the renderer cut the
/// exposure into. Their number is the renderer's own (`scene::slice_count`) from the
/// campaign's samples, the spacing of those samples in the image and the PSF's core; the
/// spacing is taken as the ends' distance over the samples less one (exact for a uniform
/// motion; the renderer takes the largest spacing, which a bending track makes larger, and
/// the two decide alike unless the spacing lies within that difference of a refinement
/// step). None where the PSF is not known (a ground site's seeing on a frame whose sidecar
/// does not state it) or the renderer would have refused the draw.
pub fn truth_end_times(o: &TruthObject, setup: &Setup) -> Option<[f64; 2]> {
    let psf = match (o.seeing, setup.seeing) {
        (Some(s), _) => crate::scene::psf_of(&setup.sensor, Some(s)),
        (None, false) => crate::scene::psf_of(&setup.sensor, None),
        (None, true) => return None,
    };
    let n0 = setup.trajectory_samples;
    let [a, b] = o.ends_px;
    let spacing = (b[0] - a[0]).hypot(b[1] - a[1]) / (n0.max(2) - 1) as f64;
    let n = crate::scene::slice_count(n0, spacing, psf.core_sigma_px()).ok()?;
    let t = |k| crate::scene::sample_time_s(k, n, o.exposure_s);
    Some([t(0), t(n - 1)])
}

/// The truth's ends of object `o` (label `label` of the frame's boxes `boxes`) as an
/// observation at their own instants `at_s` (`truth_end_times`), through the WCS of those
/// instants: the `truth` rows of the report and `report/observations/truth.*`.
fn truth_observation(
    image: &str,
    o: &TruthObject,
    boxes: &[[f64; 4]],
    at_s: [f64; 2],
    sky: &FrameSky,
) -> Observation {
    let radec = [0, 1].map(|k| sky.radec_image_at(o.ends_px[k], at_s[k]));
    let label = o.label.unwrap_or_default();
    Observation {
        image: image.to_string(),
        detector: "truth".into(),
        detection: label,
        score: 1.0,
        detection_box: boxes.get(label).copied().unwrap_or([f64::NAN; 4]),
        ends_px: o.ends_px.map(|p| sky.png_pixel(p)),
        cut: [false, false],
        radec: [radec, [radec[1], radec[0]]],
        times: at_s.map(|t| sky.start + hifitime::Duration::from_seconds(t)),
        at_s,
        observer_km: sky
            .observer_at_s(at_s[0])
            .zip(sky.observer_at_s(at_s[1]))
            .map(|(a, b)| [a, b]),
        snr: None,
        uncertainty: None,
        magnitude: None,
        from_box: false,
    }
}

/// The `q`-quantile (0..1) of sorted `v`, linear between ranks (numpy's default).
pub fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let r = q * (v.len() - 1) as f64;
    let (lo, hi) = (r.floor() as usize, r.ceil() as usize);
    v[lo] + (v[hi] - v[lo]) * (r - lo as f64)
}

/// The observations of every detector and the truth's ends, with their residuals.
pub struct Astrometry {
    pub observations: Vec<Observation>,
    pub residuals: Vec<Residual>,
    /// Detections at or above the threshold with no matched object with an ephemeris.
    pub unmatched: Vec<(String, usize)>,
    /// Labelled objects without an ephemeris (placed).
    pub placed: usize,
    /// Labelled objects with one whose ends' instants are not known (`truth_end_times`).
    pub untimed: usize,
}

/// Observe every confident detection of `runs` on `images` (their FITS under `dir/fits`)
/// and score it against the truth; a run's streaks where its detector gives them (`lines`).
pub fn measure(
    dir: &Path,
    images: &[TestImage],
    runs: &[DetectorRun],
    setup: &Setup,
) -> anyhow::Result<Astrometry> {
    let mut out = Astrometry {
        observations: Vec::new(),
        residuals: Vec::new(),
        unmatched: Vec::new(),
        placed: 0,
        untimed: 0,
    };
    let mut unmatched = vec![0; runs.len()];
    for (i, img) in images.iter().enumerate() {
        let sky = FrameSky::read(&dir.join("fits").join(format!("{}.fits", img.stem)))?;
        let objects = truth_objects(&dir.join("truth").join(format!("{}.json", img.stem)))?;
        out.placed += objects
            .iter()
            .filter(|o| o.label.is_some() && o.ephemeris.is_none())
            .count();
        let fits = dir.join("fits").join(format!("{}.fits", img.stem));
        let (adu, _, fits_width) =
            crate::fits::read_f32(&fits).map_err(|e| anyhow::anyhow!("{}: {e}", fits.display()))?;
        let pixels = image::open(&img.png)
            .with_context(|| format!("reading {}", img.png.display()))?
            .to_luma8()
            .into_raw();
        // The truth's own ends through the same WCS, each against the ephemeris at its own
        // instant: the floor of the chain.
        for o in objects.iter().filter(|o| o.label.is_some()) {
            let Some(track) = o.ephemeris else { continue };
            let Some(at_s) = truth_end_times(o, setup) else {
                out.untimed += 1;
                continue;
            };
            let obs = truth_observation(&img.stem, o, &img.truth, at_s, &sky);
            let radec = obs.radec[0];
            let truth_at = at_s.map(|t| interpolate(track, o.exposure_s, t));
            out.observations.push(obs);
            out.residuals.push(Residual {
                detector: "truth".into(),
                image: img.stem.clone(),
                detection: o.label.unwrap_or_default(),
                object: o.name.clone(),
                norad: o.norad,
                snr: o.snr,
                pairing: 0,
                ends: [0, 1].map(|k| Some(offset_arcsec(truth_at[k], radec[k]))),
                correlated_norad: o.norad,
                correlated: true,
                sigma_arcsec: None,
                magnitude_delta: None,
            });
        }
        for (r, run) in runs.iter().enumerate() {
            for (k, d) in run.detections[i].iter().enumerate() {
                if d.score < setup.conf {
                    continue;
                }
                let line = run.lines.as_ref().map(|l| l[i][k]);
                let mut o = observe(
                    &img.stem,
                    &run.name,
                    k,
                    d,
                    line,
                    &pixels,
                    (img.width, img.height),
                    &sky,
                    setup.psf_sigma_px,
                );
                if !o.cut[0] && !o.cut[1] {
                    let ends = o.ends_px.map(|p| sky.image_pixel(p));
                    let sigma = setup.psf_sigma_px * sky.image_px_per_png_px();
                    o.magnitude = streak_magnitude(&adu, fits_width, ends, sigma, &sky);
                }
                match residual(&o, &img.truth, &objects) {
                    Some(res) => out.residuals.push(res),
                    None => unmatched[r] += 1,
                }
                out.observations.push(o);
            }
        }
    }
    out.unmatched = runs
        .iter()
        .zip(unmatched)
        .map(|(r, n)| (r.name.clone(), n))
        .collect();
    Ok(out)
}

/// The table's statistics of separations `v` (unsorted): n, median, p68, p95.
fn stats(mut v: Vec<f64>) -> (usize, f64, f64, f64) {
    v.sort_by(f64::total_cmp);
    (
        v.len(),
        quantile(&v, 0.5),
        quantile(&v, 0.68),
        quantile(&v, 0.95),
    )
}

/// The bin label of SNR `s`.
fn snr_bin(s: f64) -> String {
    let k = SNR_EDGES.iter().rposition(|e| s >= *e).unwrap_or(0);
    match SNR_EDGES.get(k + 1) {
        Some(hi) => format!("{}-{}", SNR_EDGES[k], hi),
        None => format!(">={}", SNR_EDGES[k]),
    }
}

/// The report's markdown.
pub fn markdown(a: &Astrometry, setup: &Setup) -> String {
    let mut detectors: Vec<String> = vec!["truth".into()];
    for name in a.unmatched.iter().map(|u| &u.0) {
        if !detectors.contains(name) {
            detectors.push(name.clone());
        }
    }
    let mut s = String::from(
        "# Astrometry\n\nEach confident detection's ends (src/product/observations.rs: the detector's own \
         ends, or a YOLO box's diagonal chosen by the light's second moments) through the FITS WCS \
         at the exposure's start and end, against the truth ephemeris of the object its box \
         matches (IoU >= 0.5). Both pairings of the ends with the two instants are tried; the \
         better is kept. `truth`: the truth's own streak ends (its first and last trajectory \
         samples, half a time slice inside the exposure) through the WCS of their own instants, \
         against the ephemeris at those instants (the chain's floor). Separation per end, arcsec; SNR bins by the object's matched-filter SNR. \
         The last column holds the model's uncertainty (src/product/observations.rs) to the \
         measurement: its median lies between 0.67 and 0.83 where the model holds.\n\n",
    );
    let _ = writeln!(
        s,
        "Places: {}; confidence threshold {}.\n",
        if setup.apparent {
            "apparent (render.apparent_positions)"
        } else {
            "geometric"
        },
        setup.conf
    );
    s += "| detector | SNR | ends | median \" | p68 \" | p95 \" |\n|---|---|---|---|---|---|\n";
    for det in &detectors {
        let rows: Vec<&Residual> = a.residuals.iter().filter(|r| &r.detector == det).collect();
        let mut bins: Vec<String> = rows.iter().map(|r| snr_bin(r.snr)).collect();
        bins.sort_by(|x, y| bin_key(x).total_cmp(&bin_key(y)));
        bins.dedup();
        bins.insert(0, "all".into());
        for bin in bins {
            let seps: Vec<f64> = rows
                .iter()
                .filter(|r| bin == "all" || snr_bin(r.snr) == bin)
                .flat_map(|r| r.ends.iter().flatten().map(|e| e.0))
                .collect();
            let (n, med, p68, p95) = stats(seps);
            if n == 0 {
                let _ = writeln!(s, "| {det} | {bin} | 0 | - | - | - |");
                continue;
            }
            let _ = writeln!(
                s,
                "| {det} | {bin} | {n} | {med:.3} | {p68:.3} | {p95:.3} |"
            );
        }
    }
    s += "\n| detector | matched | ends cut by the edge | rule's end order kept | correlated to the right object | unmatched (no labelled object with an ephemeris) or both ends cut | median separation / model sigma | magnitude - truth's: n, median, p68 of abs |\n|---|---|---|---|---|---|---|---|\n";
    for det in detectors.iter().filter(|d| *d != "truth") {
        let rows: Vec<&Residual> = a.residuals.iter().filter(|r| &r.detector == det).collect();
        let n = rows.len();
        let kept = rows.iter().filter(|r| r.pairing == 0).count();
        let right = rows.iter().filter(|r| r.correlated).count();
        let unmatched = a.unmatched.iter().find(|u| &u.0 == det).map_or(0, |u| u.1);
        let cut: usize = rows
            .iter()
            .map(|r| r.ends.iter().filter(|e| e.is_none()).count())
            .sum();
        let share = |k: usize| {
            if n > 0 {
                format!("{:.3}", k as f64 / n as f64)
            } else {
                "-".into()
            }
        };
        // The uncertainty model against the measurement: where it holds, the separation over
        // its RMS (sigma along and across in quadrature) has a median between 0.67 (one axis
        // dominates: |N(0, 1)|) and 0.83 (isotropic: sqrt(ln 2)).
        let mut z: Vec<f64> = rows
            .iter()
            .filter_map(|r| r.sigma_arcsec.map(|s| (r, s)))
            .flat_map(|(r, sigma)| r.ends.iter().flatten().map(move |e| e.0 / sigma))
            .collect();
        z.sort_by(f64::total_cmp);
        let z = if z.is_empty() {
            "-".to_string()
        } else {
            format!("{:.2}", quantile(&z, 0.5))
        };
        let mut dm: Vec<f64> = rows.iter().filter_map(|r| r.magnitude_delta).collect();
        dm.sort_by(f64::total_cmp);
        let mut abs: Vec<f64> = dm.iter().map(|d| d.abs()).collect();
        abs.sort_by(f64::total_cmp);
        let mag = if dm.is_empty() {
            "0".to_string()
        } else {
            format!(
                "{}, {:+.3}, {:.3}",
                dm.len(),
                quantile(&dm, 0.5),
                quantile(&abs, 0.68)
            )
        };
        let _ = writeln!(
            s,
            "| {det} | {n} | {cut} | {kept} ({}) | {right} ({}) | {unmatched} | {z} | {mag} |",
            share(kept),
            share(right)
        );
    }
    let _ = writeln!(
        s,
        "\n{} labelled object(s) without an ephemeris (placed `[objects]`) left out.",
        a.placed
    );
    if a.untimed > 0 {
        let _ = writeln!(
            s,
            "{} labelled object(s) left out of the `truth` rows: the instants of their ends are \
             not known (a ground site's seeing that their sidecar does not state).",
            a.untimed
        );
    }
    s
}

/// Sort key of a bin label.
fn bin_key(b: &str) -> f64 {
    b.trim_start_matches(">=")
        .split('-')
        .next()
        .and_then(|v| v.parse().ok())
        .unwrap_or(f64::INFINITY)
}

/// One row per residual end.
pub fn csv(a: &Astrometry) -> anyhow::Result<Vec<u8>> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "detector",
        "image",
        "detection",
        "object",
        "norad",
        "snr_matched_filter",
        "pairing",
        "end",
        "separation_arcsec",
        "east_arcsec",
        "north_arcsec",
        "correlated_norad",
    ])?;
    for r in &a.residuals {
        for (k, e) in r.ends.iter().enumerate() {
            let Some(e) = e else { continue };
            w.write_record([
                r.detector.clone(),
                r.image.clone(),
                r.detection.to_string(),
                r.object.clone(),
                r.norad.to_string(),
                format!("{:.3}", r.snr),
                (if r.pairing == 0 { "rule" } else { "swapped" }).to_string(),
                (if k == 0 { "start" } else { "end" }).to_string(),
                format!("{:.4}", e.0),
                format!("{:.4}", e.1),
                format!("{:.4}", e.2),
                r.correlated_norad.to_string(),
            ])?;
        }
    }
    Ok(w.into_inner().map_err(|e| e.into_error())?)
}

/// Measure and write `report/astrometry.md`, `.csv` and `report/observations/`.
pub fn write(
    dir: &Path,
    images: &[TestImage],
    runs: &[DetectorRun],
    setup: &Setup,
) -> anyhow::Result<()> {
    let a = measure(dir, images, runs, setup)?;
    let rdir = dir.join("report");
    fs::create(&rdir.join("astrometry.md"), markdown(&a, setup))?;
    fs::create(&rdir.join("astrometry.csv"), csv(&a)?)?;
    let odir = rdir.join("observations");
    fs::create_dir_all(&odir)?;
    let names = std::iter::once("truth").chain(runs.iter().map(|r| r.name.as_str()));
    for name in names {
        let obs: Vec<&Observation> = a
            .observations
            .iter()
            .filter(|o| o.detector == name)
            .collect();
        fs::create(
            &odir.join(format!("{name}.psv")),
            crate::export::ades::psv(&obs, setup.observer, name == "truth"),
        )?;
        fs::create(
            &odir.join(format!("{name}.tdm")),
            crate::export::tdm::detections(&obs, setup.observer, setup.apparent, name == "truth"),
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The separation of two places a known angle apart, and its east/north parts.
    #[test]
    fn offsets() {
        let (s, e, n) = offset_arcsec([10.0, 60.0], [10.0 + 2.0 / 3600.0, 60.0]);
        assert!(
            (s - 1.0).abs() < 1e-6,
            "2 s of RA at Dec 60 is 1 arcsec: {s}"
        );
        assert!((e - 1.0).abs() < 1e-6 && n.abs() < 1e-9);
        let (s, _, n) = offset_arcsec([359.9999, -10.0], [359.9999, -10.0 + 3.0 / 3600.0]);
        assert!((s - 3.0).abs() < 1e-6 && (n - 3.0).abs() < 1e-6);
        let (_, e, _) = offset_arcsec([359.9999, 0.0], [0.0001, 0.0]);
        assert!((e - 0.72).abs() < 1e-6, "across RA 0: {e}");
    }

    /// The pairing: ends given in the wrong order are swapped, with ~0 residual.
    #[test]
    fn pairing_takes_the_better_order() {
        let track = [[10.0, 5.0], [10.01, 5.02]];
        let rule = [[[10.01, 5.02], [10.0, 5.0]], [[10.0, 5.0], [10.01, 5.02]]];
        let (p, rms) = best_pairing(&rule, &track, [false, false]).unwrap();
        assert_eq!(p, 1);
        assert!(rms < 1e-9);
        let swapped = [rule[1], rule[0]];
        assert_eq!(best_pairing(&swapped, &track, [false, false]).unwrap().0, 0);
        // One end cut by the edge: the other alone decides; both cut: no pairing.
        // radec[p] of physical ends e0, e1: pairing 0 takes e0 at the start, 1 at the end.
        let pairs = |e0: [f64; 2], e1: [f64; 2]| [[e0, e1], [e1, e0]];
        let one = pairs([10.0, 5.0], [11.0, 6.0]);
        assert_eq!(best_pairing(&one, &track, [false, true]).unwrap().0, 0);
        let one = pairs([10.01, 5.02], [11.0, 6.0]);
        assert_eq!(best_pairing(&one, &track, [false, true]).unwrap().0, 1);
        let one = pairs([11.0, 6.0], [10.0, 5.0]);
        assert_eq!(best_pairing(&one, &track, [true, false]).unwrap().0, 1);
        assert!(best_pairing(&one, &track, [true, true]).is_none());
    }

    #[test]
    fn quantiles_as_numpy() {
        // numpy.percentile([1, 2, 3, 4, 10], [50, 68, 95]) = 3.0, 3.72, 8.8
        let v = [1.0, 2.0, 3.0, 4.0, 10.0];
        assert!((quantile(&v, 0.5) - 3.0).abs() < 1e-12);
        assert!((quantile(&v, 0.68) - 3.72).abs() < 1e-12);
        assert!((quantile(&v, 0.95) - 8.8).abs() < 1e-12);
        assert_eq!(snr_bin(5.0), "0-10");
        assert_eq!(snr_bin(150.0), "100-300");
        assert_eq!(snr_bin(5000.0), ">=1000");
    }
}
