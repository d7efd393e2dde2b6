//! The detectors' observations (src/product/observations.rs) as IAU ADES PSV, the pipe-separated
//! form of the Astrometry Data Exchange Standard (ADES description, version 2017, the
//! `# version=2017` its PSV files begin with; field names and units as its tables:
//! `obsTime` ISO 8601 UTC ending in `Z`, `ra` and `dec` decimal degrees, `rmsRA` (of
//! RA cos Dec) and `rmsDec` arcsec, `rmsCorr`, and for a space-based observer `sys = ICRF_KM`,
//! `ctr = 399` (geocentre) and `pos1..3` its position, km).
//!
//! - `stn`: soig's observers have no MPC observatory code, so the file says `XXX` (the code of
//!   an unassigned station); the same reason keeps the MPC 80-column format out: its lines
//!   need an assigned code (and for a satellite its position on a second line fixed to it).
//! - `trkSub`: one tracklet per detection (`s` or `y` for the detector, then a running number),
//!   its two ends two records; `remarks` name the image and the detection, and say the end
//!   order is the rule's (observations.rs), not known. An end the image's edge cuts is no
//!   observation and is left out (a detection with both cut has no record).
//! - `astCat`: `UNK`: the places come from the simulation's own WCS, not from a fit to a star
//!   catalogue.
//! - `mag`, `band`: the aperture photometry of the streak on the FITS
//!   (`observations::streak_magnitude`, through `MAGZERO`), in soig's visual band (`V`, as the
//!   truth's `magnitude`); absent where an end is cut. `rmsRA`, `rmsDec`, `rmsCorr` absent where
//!   the detector gives no SNR (YOLO).

use crate::observations::Observation;

/// The PSV's column names, in order (ADES field names).
pub const COLUMNS: [&str; 17] = [
    "trkSub", "mode", "stn", "sys", "ctr", "pos1", "pos2", "pos3", "obsTime", "ra", "dec", "rmsRA",
    "rmsDec", "rmsCorr", "astCat", "mag", "band",
];

/// The column after [`COLUMNS`]: free text.
pub const REMARKS: &str = "remarks";

/// ADES `obsTime` of an epoch: ISO 8601 UTC, microseconds, `Z`.
fn obs_time(t: hifitime::Epoch) -> String {
    crate::render::iso_utc(t) + "Z"
}

/// A PSV value: no `|`, no line break.
fn psv_text(s: &str) -> String {
    s.chars()
        .map(|c| if c == '|' || c.is_control() { ' ' } else { c })
        .collect()
}

/// The ADES PSV of `observations`, the observer named `observer`; `truth`: the truth's own
/// ends (the astrometric report's `truth` rows), each at its own instant.
pub fn psv(observations: &[&Observation], observer: &str, truth: bool) -> String {
    let mut s = String::from("# version=2017\n# observatory\n! mpcCode XXX\n");
    s += &format!("! name {}\n", psv_text(observer));
    s += "# submitter\n! name soig\n# measurers\n! name soig\n# telescope\n! design simulated\n! detector CCD\n";
    if truth {
        s += "# comment\n! line soig truth: each labelled object's streak ends, its first and last trajectory\n";
        s += "! line samples, at their own instants (half a time slice inside the exposure).\n";
    } else {
        s += "# comment\n! line soig simulated images: each detection's two ends, the first (by image x, then y)\n";
        s += "! line at the exposure's start, the second at its end; which end is first is not known.\n";
    }
    let mut header: Vec<&str> = COLUMNS.to_vec();
    header.push(REMARKS);
    s += &header.join("|");
    s.push('\n');
    // The truth's ends are numbered by the image's label lines.
    let item = if truth { "label" } else { "detection" };
    for (n, o) in observations.iter().enumerate() {
        let letter = o
            .detector
            .chars()
            .next()
            .unwrap_or('d')
            .to_ascii_lowercase();
        let trk = format!("{letter}{:07}", n % 10_000_000);
        for k in (0..2).filter(|&k| !o.cut[k]) {
            let [ra, dec] = o.radec[0][k];
            let (sys, ctr, pos) = match o.observer_km {
                Some(p) => (
                    "ICRF_KM".to_string(),
                    "399".to_string(),
                    p[k].map(|v| format!("{v:.4}")),
                ),
                None => (
                    String::new(),
                    String::new(),
                    [String::new(), String::new(), String::new()],
                ),
            };
            let (rms_ra, rms_dec, corr) = match o.uncertainty {
                Some(u) => (
                    format!("{:.4}", u.ra_arcsec),
                    format!("{:.4}", u.dec_arcsec),
                    format!("{:.4}", u.corr),
                ),
                None => (String::new(), String::new(), String::new()),
            };
            let row = [
                trk.clone(),
                "CCD".into(),
                "XXX".into(),
                sys,
                ctr,
                pos[0].clone(),
                pos[1].clone(),
                pos[2].clone(),
                obs_time(o.times[k]),
                format!("{:.9}", ra.rem_euclid(360.0)),
                format!("{dec:.9}"),
                rms_ra,
                rms_dec,
                corr,
                "UNK".into(),
                o.magnitude.map_or(String::new(), |m| format!("{m:.2}")),
                (if o.magnitude.is_some() { "V" } else { "" }).to_string(),
                psv_text(&format!(
                    "{} {} {item} {} end {}",
                    o.detector,
                    o.image,
                    o.detection,
                    if k == 0 { "first" } else { "second" }
                )),
            ];
            s += &row.join("|");
            s.push('\n');
        }
    }
    s
}
