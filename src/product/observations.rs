//! Observations for orbit work from the detectors' streaks (`[artifacts] astrometry`, issue
//! #45 item 2): each detection's two ends, from the PNG back to the original image (the FITS
//! `GEOA` cards), through the FITS WCS to (RA, Dec) at the exposure's start and end. Nothing
//! here reads the truth: what a detection gives is its ends and what the FITS header says.
//!
//! - The ends: the streak detector's half-level ends ([`crate::detect::streak::Candidate`]);
//!   for a detector that gives an axis-aligned box alone (YOLO), the streak lies along one of
//!   the box's diagonals, chosen by the sign of the light's xy second moment in the box, and
//!   its ends are where the light along that diagonal crosses half its level ([`line_in_box`]).
//! - The times: a streak does not say which end came first. The ends are ordered by a rule that
//!   knows no truth (the end of smaller PNG x first, then of smaller y), the first taken at the
//!   exposure's start; the swapped pairing is kept beside it ([`Observation::radec`]), and the
//!   astrometric report (src/report/astrometry.rs) keeps the better of the two and says how
//!   often the rule was right.
//! - The sky: the FITS WCS is the pointing at mid-exposure; a survey or track image also
//!   carries the WCS at the start and end (alternate WCS `S`, `E`, `sky::motion`), which the
//!   end taken at that instant goes through. A fixed pointing has the one WCS.
//! - The uncertainty (background-limited, Gaussian PSF of `psf_sigma_px`, a line of length `L`
//!   and matched-filter SNR `S`, the streak detector's): along the track an end is the edge of
//!   an erf step, whose position's Fisher information gives `sqrt(2 sqrt(pi) sigma L) / S`
//!   pixels; across it, a line's centroid is known to `sqrt(2) sigma / S` and an end of a fitted
//!   line to twice that. A detector that gives no SNR (YOLO) gets no uncertainty: none is
//!   invented.
//! - The magnitude: the detectors' flux is summed on the enhanced 8-bit PNG, whose stretch is
//!   not photometric, so the streak's light is measured again on the FITS between the
//!   detection's ends ([`streak_magnitude`]), absent where an end is cut (part of the light is
//!   outside the image).

use std::collections::HashMap;
use std::path::Path;

use anyhow::Context;
use hifitime::{Duration, Epoch};

use crate::detect::Detection;
use crate::sky::motion::{END, START};
use crate::sky::wcs::TanWcs;

/// A detection's streak: its ends in the PNG, pixel-edge coordinates (pixel `i` spans
/// `[i, i + 1]`, the detectors' convention), and the detector's matched-filter SNR of it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    pub ends: [[f64; 2]; 2],
    pub snr: Option<f64>,
}

/// What an image's FITS header says of its sky: the WCS at mid-exposure, at the start and
/// end where the pointing moves, the exposure, and the PNG's frame.
#[derive(Clone, Debug)]
pub struct FrameSky {
    pub mid: TanWcs,
    /// The WCS at the exposure's start and end (survey and track); None for a fixed pointing.
    pub start_end: Option<(TanWcs, TanWcs)>,
    pub start: Epoch,
    pub exposure_s: f64,
    /// The original image's pixel of a PNG pixel (0-based centres): the inverse of the
    /// `GEOA` cards' `PNG = A (x, y, 1)`.
    pub png_to_image: [[f64; 3]; 2],
    /// The `GEOA` cards themselves: the PNG pixel (0-based centres) of an original pixel.
    pub image_to_png: [[f64; 3]; 2],
    /// The original image's size, pixels (`NAXIS1`, `NAXIS2`).
    pub size: [f64; 2],
    /// Electrons per ADU (`GAIN`) and the magnitude of 1 e-/s (`MAGZERO`), where given.
    pub gain: Option<f64>,
    pub zero_point_mag: Option<f64>,
    /// The observer's GCRS position (km) and velocity (km/s) at mid-exposure (`OBSPOS-*`,
    /// `OBSVEL-*`); None where the header has none (a ground site's).
    pub observer: Option<([f64; 3], [f64; 3])>,
}

/// The WCS keywords the deprojection reads (`TanWcs::from_header`).
const WCS_KEYS: [&str; 18] = [
    "CTYPE1", "CTYPE2", "CUNIT1", "CUNIT2", "CRPIX1", "CRPIX2", "CRVAL1", "CRVAL2", "CDELT1",
    "CDELT2", "CD1_1", "CD1_2", "CD2_1", "CD2_2", "PC1_1", "PC1_2", "PC2_1", "PC2_2",
];

impl FrameSky {
    /// Read the header of soig FITS `path`.
    pub fn read(path: &Path) -> anyhow::Result<FrameSky> {
        let file = path.display();
        let name =
            crate::fits::CfitsioName::to_read(path).with_context(|| format!("opening {file}"))?;
        let mut f = fitsio::FitsFile::open(&name.name)
            .with_context(|| format!("{file}: not a FITS file"))?;
        let hdu = f
            .primary_hdu()
            .with_context(|| format!("{file}: no primary HDU"))?;
        let mut keys: Vec<String> = WCS_KEYS.iter().map(|k| k.to_string()).collect();
        for letter in [START, END] {
            keys.extend(WCS_KEYS.iter().map(|k| format!("{k}{letter}")));
        }
        keys.extend(
            ["DATE-OBS", "EXPTIME", "NAXIS1", "NAXIS2", "GAIN", "MAGZERO"].map(String::from),
        );
        for axis in ["X", "Y", "Z"] {
            keys.push(format!("OBSPOS-{axis}"));
            keys.push(format!("OBSVEL-{axis}"));
        }
        keys.extend(["GEOA11", "GEOA12", "GEOA13", "GEOA21", "GEOA22", "GEOA23"].map(String::from));
        let mut cards = HashMap::new();
        for k in keys {
            if let Ok(v) = hdu.read_key::<String>(&mut f, &k) {
                cards.insert(k, v.trim().to_string());
            }
        }
        let card = |k: &str| cards.get(k).cloned();
        let wcs = |letter: &str| {
            TanWcs::from_header(|k| card(&format!("{k}{letter}")))
                .map_err(|e| anyhow::anyhow!("{file}: WCS{letter}: {e}"))
        };
        let mid =
            wcs("")?.ok_or_else(|| anyhow::anyhow!("{file}: no celestial WCS (CTYPE1/CTYPE2)"))?;
        let start_end = match (wcs("S")?, wcs("E")?) {
            (Some(s), Some(e)) => Some((s, e)),
            (None, None) => None,
            _ => anyhow::bail!("{file}: the WCS at the exposure's start (S) or end (E) alone"),
        };
        let number = |k: &str| -> anyhow::Result<f64> {
            card(k)
                .and_then(|v| v.parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    anyhow::anyhow!("{file}: header keyword {k} missing or not a number")
                })
        };
        let date = card("DATE-OBS").unwrap_or_default();
        let start = crate::export::tdm::parse_utc(&date).ok_or_else(|| {
            anyhow::anyhow!(
                "{file}: header keyword DATE-OBS = {date:?} is not YYYY-MM-DDThh:mm:ss.ffffff"
            )
        })?;
        let exposure_s = number("EXPTIME")?;
        let a = [
            [number("GEOA11")?, number("GEOA12")?, number("GEOA13")?],
            [number("GEOA21")?, number("GEOA22")?, number("GEOA23")?],
        ];
        let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
        if det == 0.0 || !det.is_finite() {
            anyhow::bail!("{file}: the GEOA matrix (PNG pixel of an image pixel) is singular");
        }
        let inv = [
            [a[1][1] / det, -a[0][1] / det],
            [-a[1][0] / det, a[0][0] / det],
        ];
        let png_to_image = [
            [
                inv[0][0],
                inv[0][1],
                -(inv[0][0] * a[0][2] + inv[0][1] * a[1][2]),
            ],
            [
                inv[1][0],
                inv[1][1],
                -(inv[1][0] * a[0][2] + inv[1][1] * a[1][2]),
            ],
        ];
        let vector = |what: &str| -> Option<[f64; 3]> {
            let v = ["X", "Y", "Z"].map(|a| number(&format!("{what}-{a}")).ok());
            Some([v[0]?, v[1]?, v[2]?])
        };
        let observer = vector("OBSPOS").zip(vector("OBSVEL"));
        let size = [number("NAXIS1")?, number("NAXIS2")?];
        Ok(FrameSky {
            mid,
            start_end,
            start,
            exposure_s,
            png_to_image,
            image_to_png: a,
            size,
            gain: number("GAIN").ok(),
            zero_point_mag: number("MAGZERO").ok(),
            observer,
        })
    }

    /// The original image's pixel (0-based centres) of PNG pixel-edge coordinates `p`.
    pub fn image_pixel(&self, p: [f64; 2]) -> [f64; 2] {
        let (u, v) = (p[0] - 0.5, p[1] - 0.5);
        let m = &self.png_to_image;
        [
            m[0][0] * u + m[0][1] * v + m[0][2],
            m[1][0] * u + m[1][1] * v + m[1][2],
        ]
    }

    /// (RA, Dec), degrees, of PNG pixel-edge coordinates `p` at the exposure's start (`at_end`
    /// false) or end: through the WCS of that instant where the pointing moves.
    pub fn radec(&self, p: [f64; 2], at_end: bool) -> [f64; 2] {
        self.radec_image(self.image_pixel(p), at_end)
    }

    /// (RA, Dec), degrees, of the original image's pixel `p` (0-based centres) at the
    /// exposure's start (`at_end` false) or end.
    pub fn radec_image(&self, [x, y]: [f64; 2], at_end: bool) -> [f64; 2] {
        let wcs = match (&self.start_end, at_end) {
            (Some((s, _)), false) => s,
            (Some((_, e)), true) => e,
            (None, _) => &self.mid,
        };
        let (ra, dec) = wcs.sky(x, y);
        [ra, dec]
    }

    /// Whether PNG pixel-edge point `p` lies within `margin` pixels of the original image's
    /// edge (or beyond it): a streak's half-level end there is where the edge cut it, not
    /// where the object was at an instant.
    pub fn at_edge(&self, p: [f64; 2], margin: f64) -> bool {
        let [x, y] = self.image_pixel(p);
        // Pixel centres at integers: the image spans [-0.5, size - 0.5].
        x < margin - 0.5
            || y < margin - 0.5
            || x > self.size[0] - 0.5 - margin
            || y > self.size[1] - 0.5 - margin
    }

    /// (RA, Dec), degrees, of the original image's pixel `p` at `t_s` seconds after the
    /// exposure's start: through the WCS at the start, middle and end, interpolated in time by
    /// the parabola through the three (exact at those instants; a fixed pointing has one WCS).
    /// The boresight's path over an exposure is a smooth arc of at most a few degrees, so the
    /// parabola's error near an instant it goes through is of the order of the third derivative
    /// times the distance in time to it.
    pub fn radec_image_at(&self, p: [f64; 2], t_s: f64) -> [f64; 2] {
        match &self.start_end {
            None => self.radec_image(p, false),
            Some((s, e)) => {
                let at = |w: &TanWcs| {
                    let (ra, dec) = w.sky(p[0], p[1]);
                    [ra, dec]
                };
                super::sky_track::interpolate([at(s), at(&self.mid), at(e)], self.exposure_s, t_s)
            }
        }
    }

    /// The exposure's start (`at_end` false) or end.
    pub fn time(&self, at_end: bool) -> Epoch {
        if at_end {
            self.start + Duration::from_seconds(self.exposure_s)
        } else {
            self.start
        }
    }

    /// The observer's GCRS position, km, at the exposure's start or end: mid-exposure's moved
    /// by its velocity (a low orbit's 8 m/s^2 bends it by under 0.1 km over 5 s, 0.5 mas of
    /// parallax at GEO).
    pub fn observer_at(&self, at_end: bool) -> Option<[f64; 3]> {
        let (p, v) = self.observer?;
        let dt = if at_end { 0.5 } else { -0.5 } * self.exposure_s;
        Some([p[0] + v[0] * dt, p[1] + v[1] * dt, p[2] + v[2] * dt])
    }

    /// The observer's GCRS position, km, `t_s` seconds after the exposure's start (as
    /// [`FrameSky::observer_at`]).
    pub fn observer_at_s(&self, t_s: f64) -> Option<[f64; 3]> {
        let (p, v) = self.observer?;
        let dt = t_s - 0.5 * self.exposure_s;
        Some([p[0] + v[0] * dt, p[1] + v[1] * dt, p[2] + v[2] * dt])
    }

    /// PNG pixel-edge coordinates of the original image's pixel `p` (0-based centres).
    pub fn png_pixel(&self, p: [f64; 2]) -> [f64; 2] {
        let a = &self.image_to_png;
        [
            a[0][0] * p[0] + a[0][1] * p[1] + a[0][2] + 0.5,
            a[1][0] * p[0] + a[1][1] * p[1] + a[1][2] + 0.5,
        ]
    }

    /// Original-image pixels per PNG pixel (the frame's mapping's linear scale).
    pub fn image_px_per_png_px(&self) -> f64 {
        let m = &self.png_to_image;
        (m[0][0] * m[1][1] - m[0][1] * m[1][0]).abs().sqrt()
    }

    /// Arcseconds per PNG pixel (the WCS's scale through the frame's mapping).
    pub fn png_scale_arcsec(&self) -> f64 {
        let m = &self.png_to_image;
        let det = (m[0][0] * m[1][1] - m[0][1] * m[1][0]).abs();
        self.mid.pixel_scale_arcsec() * det.sqrt()
    }
}

/// The one-sigma uncertainty of an end, arcsec: along and across the streak, and the RA
/// (times cos Dec) and Dec ones with their correlation (ADES `rmsRA`, `rmsDec`, `rmsCorr`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Uncertainty {
    pub along_arcsec: f64,
    pub across_arcsec: f64,
    pub ra_arcsec: f64,
    pub dec_arcsec: f64,
    pub corr: f64,
}

/// One detection's observation: its ends and their sky places at the exposure's start and
/// end, in both pairings.
#[derive(Clone, Debug)]
pub struct Observation {
    pub image: String,
    pub detector: String,
    /// Its place in the detector's list for the image.
    pub detection: usize,
    pub score: f64,
    /// The PNG box (pixel edges), as the detector gave it.
    pub detection_box: [f64; 4],
    /// The ends, PNG pixel-edge coordinates, ordered by the rule (smaller x first, then y).
    pub ends_px: [[f64; 2]; 2],
    /// Whether each end (of `ends_px`) lies where the image's edge cuts the streak
    /// ([`FrameSky::at_edge`], within `EDGE_SIGMAS` PSF sigmas plus a pixel): its place is no
    /// observation, and it is left out of the files and the residuals.
    pub cut: [bool; 2],
    /// `radec[p][k]`: (RA, Dec), degrees, at the exposure's start (k = 0) and end (k = 1) in
    /// pairing p: 0 the rule's (first end at the start), 1 the swapped.
    pub radec: [[[f64; 2]; 2]; 2],
    pub times: [Epoch; 2],
    /// Those instants, seconds after the exposure's start: 0 and `EXPTIME` for a detection;
    /// the first and last trajectory samples' for the truth's ends (the astrometric report).
    pub at_s: [f64; 2],
    /// The observer's GCRS position at those instants, km (None from a ground site).
    pub observer_km: Option<[[f64; 3]; 2]>,
    pub snr: Option<f64>,
    pub uncertainty: Option<Uncertainty>,
    /// The streak's magnitude by aperture photometry on the FITS ([`streak_magnitude`]); None
    /// where an end is cut, the light sums to nothing, or the header has no `GAIN`/`MAGZERO`.
    pub magnitude: Option<f64>,
    /// True where the streak's ends come from an axis-aligned box's diagonal.
    pub from_box: bool,
}

/// An end within this many PSF sigmas (plus a pixel) of the image's edge is cut by it: the
/// half-level end of a streak that runs out of the image lies at the edge, within a sigma.
const EDGE_SIGMAS: f64 = 2.0;

/// The end of `ends_px` taken at instant `k` (0 start, 1 end) in pairing `p`.
pub fn end_at(p: usize, k: usize) -> usize {
    if p == 0 { k } else { 1 - k }
}

/// The ends in the rule's order: the end of smaller x first, then of smaller y.
fn ordered(ends: [[f64; 2]; 2]) -> [[f64; 2]; 2] {
    let [a, b] = ends;
    if (a[0], a[1]) <= (b[0], b[1]) {
        [a, b]
    } else {
        [b, a]
    }
}

/// The observation of detection `d` (number `index` of image `image`'s list), its streak
/// `line` (None: read from the box and the image's `pixels`), in the frame `sky`.
#[allow(clippy::too_many_arguments)]
pub fn observe(
    image: &str,
    detector: &str,
    index: usize,
    d: &Detection,
    line: Option<Line>,
    pixels: &[u8],
    size: (usize, usize),
    sky: &FrameSky,
    psf_sigma_px: f64,
) -> Observation {
    let from_box = line.is_none();
    let line = line.unwrap_or_else(|| Line {
        ends: line_in_box(pixels, size.0, size.1, d),
        snr: None,
    });
    let ends = ordered(line.ends);
    let margin = EDGE_SIGMAS * psf_sigma_px + 1.0;
    let cut = ends.map(|e| sky.at_edge(e, margin));
    let radec = [
        [sky.radec(ends[0], false), sky.radec(ends[1], true)],
        [sky.radec(ends[1], false), sky.radec(ends[0], true)],
    ];
    let length = (ends[1][0] - ends[0][0]).hypot(ends[1][1] - ends[0][1]);
    let uncertainty = line
        .snr
        .filter(|s| *s > 0.0 && s.is_finite())
        .map(|snr| uncertainty(snr, length, psf_sigma_px, sky.png_scale_arcsec(), radec[0]));
    Observation {
        image: image.to_string(),
        detector: detector.to_string(),
        detection: index,
        score: d.score,
        detection_box: [d.x1, d.y1, d.x2, d.y2],
        ends_px: ends,
        cut,
        radec,
        times: [sky.time(false), sky.time(true)],
        at_s: [0.0, sky.exposure_s],
        observer_km: sky
            .observer_at(false)
            .zip(sky.observer_at(true))
            .map(|(a, b)| [a, b]),
        snr: line.snr,
        uncertainty,
        magnitude: None,
        from_box,
    }
}

/// The magnitude of the streak between original-image pixels `ends` (centres at integers) in
/// the FITS image `adu` (`width` x rows, ADU), PSF sigma `sigma` px: the ADU within 3 sigmas of
/// the segment, less the median of the band 5 to 8 sigmas from it (the background, stars in it
/// outvoted), times `GAIN`, per second of `EXPTIME`, through `MAGZERO` (the magnitude of
/// 1 e-/s). Stars inside the aperture add to it. None without a positive sum.
pub fn streak_magnitude(
    adu: &[f32],
    width: usize,
    ends: [[f64; 2]; 2],
    sigma: f64,
    sky: &FrameSky,
) -> Option<f64> {
    let (gain, zero) = (sky.gain?, sky.zero_point_mag?);
    let height = adu.len() / width.max(1);
    let (a, b) = (ends[0], ends[1]);
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    // Distance of a pixel centre from the segment.
    let dist = |x: f64, y: f64| {
        let t = if len2 > 0.0 {
            (((x - a[0]) * dx + (y - a[1]) * dy) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (x - a[0] - t * dx).hypot(y - a[1] - t * dy)
    };
    let (inner, band) = (3.0 * sigma, (5.0 * sigma, 8.0 * sigma));
    let lo = |v: f64, n: usize| (v - band.1).floor().clamp(0.0, n as f64) as usize;
    let hi = |v: f64, n: usize| ((v + band.1).ceil() + 1.0).clamp(0.0, n as f64) as usize;
    let (mut sum, mut count, mut ring) = (0.0, 0usize, Vec::new());
    for j in lo(a[1].min(b[1]), height)..hi(a[1].max(b[1]), height) {
        for i in lo(a[0].min(b[0]), width)..hi(a[0].max(b[0]), width) {
            let d = dist(i as f64, j as f64);
            let v = f64::from(adu[j * width + i]);
            if d <= inner {
                sum += v;
                count += 1;
            } else if (band.0..=band.1).contains(&d) {
                ring.push(v);
            }
        }
    }
    if ring.is_empty() || count == 0 {
        return None;
    }
    let electrons = (sum - median(&mut ring) * count as f64) * gain;
    (electrons > 0.0 && sky.exposure_s > 0.0)
        .then(|| zero - 2.5 * (electrons / sky.exposure_s).log10())
}

/// The uncertainty of an end of a line of `length_px` and matched-filter SNR `snr`, PSF sigma
/// `sigma_px`, `scale` arcsec per pixel, whose ends lie at `ends` (RA, Dec) (module docs).
pub fn uncertainty(
    snr: f64,
    length_px: f64,
    sigma_px: f64,
    scale: f64,
    ends: [[f64; 2]; 2],
) -> Uncertainty {
    let along = (2.0 * std::f64::consts::PI.sqrt() * sigma_px * length_px.max(sigma_px)).sqrt()
        / snr
        * scale;
    let across = 2.0 * std::f64::consts::SQRT_2 * sigma_px / snr * scale;
    // The streak's direction on the sky (east = RA cos Dec, north = Dec); a point: along RA.
    let dec = ends[0][1].to_radians();
    let mut dra = (ends[1][0] - ends[0][0] + 540.0).rem_euclid(360.0) - 180.0;
    dra *= dec.cos();
    let ddec = ends[1][1] - ends[0][1];
    let n = dra.hypot(ddec);
    let (ue, un) = if n > 0.0 {
        (dra / n, ddec / n)
    } else {
        (1.0, 0.0)
    };
    let (a2, c2) = (along * along, across * across);
    let var_ra = a2 * ue * ue + c2 * un * un;
    let var_dec = a2 * un * un + c2 * ue * ue;
    let cov = (a2 - c2) * ue * un;
    Uncertainty {
        along_arcsec: along,
        across_arcsec: across,
        ra_arcsec: var_ra.sqrt(),
        dec_arcsec: var_dec.sqrt(),
        corr: cov / (var_ra * var_dec).sqrt(),
    }
}

/// The streak in the axis-aligned box of `d`, pixel-edge coordinates: along the diagonal that
/// the light's xy second moment points along (its sign: y grows with x on the main diagonal),
/// between where the light along that diagonal (3 pixels across, 2 pixels along, averaged)
/// first and last reaches half its median level above the box's border; the box's corners
/// where the light shows no level above the border.
pub fn line_in_box(pixels: &[u8], w: usize, h: usize, d: &Detection) -> [[f64; 2]; 2] {
    let clamp = |v: f64, n: usize| v.clamp(0.0, n as f64);
    let (x1, y1, x2, y2) = (
        clamp(d.x1, w),
        clamp(d.y1, h),
        clamp(d.x2, w),
        clamp(d.y2, h),
    );
    let (i0, i1) = (x1.floor() as usize, (x2.ceil() as usize).min(w));
    let (j0, j1) = (y1.floor() as usize, (y2.ceil() as usize).min(h));
    if i1 <= i0 || j1 <= j0 {
        return [[x1, y1], [x2, y2]];
    }
    let at = |i: usize, j: usize| f64::from(pixels[j * w + i]);
    let mut border: Vec<f64> = Vec::new();
    for i in i0..i1 {
        border.push(at(i, j0));
        border.push(at(i, j1 - 1));
    }
    for j in j0..j1 {
        border.push(at(i0, j));
        border.push(at(i1 - 1, j));
    }
    let bg = median(&mut border);
    let (mut s, mut sx, mut sy, mut sxy) = (0.0, 0.0, 0.0, 0.0);
    for j in j0..j1 {
        for i in i0..i1 {
            let v = (at(i, j) - bg).max(0.0);
            let (x, y) = (i as f64 + 0.5, j as f64 + 0.5);
            s += v;
            sx += v * x;
            sy += v * y;
            sxy += v * x * y;
        }
    }
    let cov = if s > 0.0 {
        sxy / s - (sx / s) * (sy / s)
    } else {
        0.0
    };
    let (a, b) = if cov >= 0.0 {
        ([x1, y1], [x2, y2])
    } else {
        ([x1, y2], [x2, y1])
    };
    half_level_ends(a, b, bg, |x, y| {
        let (i, j) = (x.floor(), y.floor());
        if i < 0.0 || j < 0.0 || i >= w as f64 || j >= h as f64 {
            None
        } else {
            Some(at(i as usize, j as usize))
        }
    })
    .unwrap_or([a, b])
}

/// Where the light along the segment `a`-`b` (read by `at`, None outside the image) first and
/// last reaches half its median level above `bg`; None where it has no level above it.
fn half_level_ends(
    a: [f64; 2],
    b: [f64; 2],
    bg: f64,
    at: impl Fn(f64, f64) -> Option<f64>,
) -> Option<[[f64; 2]; 2]> {
    let len = (b[0] - a[0]).hypot(b[1] - a[1]);
    if len < 2.0 {
        return None;
    }
    let (ux, uy) = ((b[0] - a[0]) / len, (b[1] - a[1]) / len);
    let step = 0.5;
    let n = (len / step).floor() as usize + 1;
    // Three samples across (-1, 0, +1 px), their mean.
    let raw: Vec<f64> = (0..n)
        .map(|k| {
            let t = k as f64 * step;
            let (x, y) = (a[0] + ux * t, a[1] + uy * t);
            let v: Vec<f64> = [-1.0, 0.0, 1.0]
                .iter()
                .filter_map(|o| at(x - uy * o, y + ux * o))
                .collect();
            if v.is_empty() {
                bg
            } else {
                v.iter().sum::<f64>() / v.len() as f64
            }
        })
        .collect();
    // A running mean over 5 samples (2 px along): 8-bit noise would cross the level early.
    let profile: Vec<f64> = (0..n)
        .map(|k| {
            let (lo, hi) = (k.saturating_sub(2), (k + 3).min(n));
            raw[lo..hi].iter().sum::<f64>() / (hi - lo) as f64
        })
        .collect();
    let mut middle = profile[n / 4..(3 * n / 4).max(n / 4 + 1)].to_vec();
    let level = median(&mut middle) - bg;
    if level <= 0.0 {
        return None;
    }
    let half = bg + level / 2.0;
    let first = profile.iter().position(|&v| v >= half)?;
    let last = profile.iter().rposition(|&v| v >= half)?;
    // Interpolated crossings between the samples around them.
    let cross = |k0: usize, k1: usize| {
        let (v0, v1) = (profile[k0], profile[k1]);
        let f = if v1 != v0 {
            (half - v0) / (v1 - v0)
        } else {
            0.0
        };
        (k0 as f64 + f.clamp(0.0, 1.0) * (k1 as f64 - k0 as f64)) * step
    };
    let t0 = if first == 0 {
        0.0
    } else {
        cross(first - 1, first)
    };
    let t1 = if last + 1 >= n {
        len
    } else {
        cross(last, last + 1)
    };
    let point = |t: f64| [a[0] + ux * t, a[1] + uy * t];
    Some([point(t0), point(t1)])
}

/// The median of `v` (sorted in place); 0 for none.
fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bright 3 px wide line from (20.5, 30.5) to (80.5, 60.5) on a grey ground.
    fn streak_image(w: usize, h: usize, a: [f64; 2], b: [f64; 2]) -> Vec<u8> {
        let mut px = vec![20u8; w * h];
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len = dx.hypot(dy);
        for j in 0..h {
            for i in 0..w {
                let (x, y) = (i as f64 + 0.5 - a[0], j as f64 + 0.5 - a[1]);
                let t = (x * dx + y * dy) / len;
                let across = (x * dy - y * dx).abs() / len;
                if (0.0..=len).contains(&t) && across <= 1.5 {
                    px[j * w + i] = 200;
                }
            }
        }
        px
    }

    /// The diagonal of a box is chosen from its light, both ways, and the ends found within
    /// 1.5 px of the drawn ones (the 1 px sampling of a pixelated line, 0.5 px steps).
    #[test]
    fn box_diagonal_from_the_light() {
        let (w, h) = (100, 90);
        for (a, b) in [([20.5, 30.5], [80.5, 60.5]), ([20.5, 60.5], [80.5, 30.5])] {
            let px = streak_image(w, h, a, b);
            let d = Detection {
                x1: 16.0,
                y1: 27.0,
                x2: 85.0,
                y2: 64.0,
                score: 0.9,
                class: 0,
            };
            let ends = ordered(line_in_box(&px, w, h, &d));
            for (got, want) in ends.iter().zip([a, b]) {
                let err = (got[0] - want[0]).hypot(got[1] - want[1]);
                assert!(err < 1.5, "{a:?}-{b:?}: end {got:?}, drawn {want:?}");
            }
        }
    }

    /// A frame of `exposure_s` with GAIN 2 and MAGZERO 20, identity GEOA, 0.7"/px.
    fn frame(exposure_s: f64) -> FrameSky {
        let wcs = TanWcs {
            crpix: [50.0, 50.0],
            crval: [10.0, 5.0],
            cd: [[0.7 / 3600.0, 0.0], [0.0, 0.7 / 3600.0]],
        };
        FrameSky {
            mid: wcs,
            start_end: None,
            start: Epoch::from_gregorian_utc_at_midnight(2022, 1, 1),
            exposure_s,
            png_to_image: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            image_to_png: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            size: [100.0, 80.0],
            gain: Some(2.0),
            zero_point_mag: Some(20.0),
            observer: None,
        }
    }

    /// A trail of known light on a flat background gives its magnitude: 4000 ADU spread as a
    /// Gaussian line (sigma 1.5 px) from (20, 30) to (70, 50), background 100 ADU, GAIN 2,
    /// 5 s: 1600 e-/s, magnitude 20 - 2.5 log10(1600) = 11.99. The 3-sigma aperture holds
    /// 99.7% of it (0.003 mag); the tolerance, 0.01 mag, adds the sampling of the line by pixel
    /// centres.
    #[test]
    fn magnitude_of_a_known_trail() {
        let (w, h) = (100usize, 80usize);
        let (a, b) = ([20.0, 30.0], [70.0, 50.0]);
        let sigma: f64 = 1.5;
        let mut adu = vec![100.0f32; w * h];
        let steps = 2000;
        let total = 4000.0;
        for k in 0..steps {
            let t = (k as f64 + 0.5) / steps as f64;
            let (cx, cy) = (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]));
            for j in 0..h {
                for i in 0..w {
                    let d2 = (i as f64 - cx).powi(2) + (j as f64 - cy).powi(2);
                    if d2 < 100.0 {
                        let g = (-d2 / (2.0 * sigma * sigma)).exp()
                            / (2.0 * std::f64::consts::PI * sigma * sigma);
                        adu[j * w + i] += (total / steps as f64 * g) as f32;
                    }
                }
            }
        }
        let m = streak_magnitude(&adu, w, [a, b], sigma, &frame(5.0)).unwrap();
        let want = 20.0 - 2.5 * 1600f64.log10();
        assert!((m - want).abs() < 0.01, "{m} vs {want}");
        // No light: no magnitude.
        let flat = vec![100.0f32; w * h];
        assert_eq!(streak_magnitude(&flat, w, [a, b], sigma, &frame(5.0)), None);
    }

    /// The ends' order is the rule's, whatever the detector's.
    #[test]
    fn ends_ordered_by_x_then_y() {
        let (p, q) = ([5.0, 9.0], [3.0, 1.0]);
        assert_eq!(ordered([p, q]), [q, p]);
        assert_eq!(ordered([q, p]), [q, p]);
        assert_eq!(ordered([[3.0, 4.0], [3.0, 2.0]]), [[3.0, 2.0], [3.0, 4.0]]);
    }

    /// The uncertainty model: along and across as the formulas, and turned onto RA/Dec for a
    /// streak running due north (RA gets the across, Dec the along, no correlation) and at
    /// 45 degrees (both the mean of the variances, correlated).
    #[test]
    fn uncertainty_model() {
        let u = uncertainty(20.0, 100.0, 1.5, 2.0, [[10.0, 0.0], [10.0, 0.1]]);
        let along = (2.0 * std::f64::consts::PI.sqrt() * 1.5 * 100.0).sqrt() / 20.0 * 2.0;
        let across = 2.0 * 2f64.sqrt() * 1.5 / 20.0 * 2.0;
        assert!((u.along_arcsec - along).abs() < 1e-12);
        assert!((u.across_arcsec - across).abs() < 1e-12);
        assert!((u.ra_arcsec - across).abs() < 1e-12 && (u.dec_arcsec - along).abs() < 1e-12);
        assert!(u.corr.abs() < 1e-12);
        let u = uncertainty(20.0, 100.0, 1.5, 2.0, [[10.0, 0.0], [10.1, 0.1]]);
        let mean = ((along * along + across * across) / 2.0).sqrt();
        assert!((u.ra_arcsec - mean).abs() < 1e-9 && (u.dec_arcsec - mean).abs() < 1e-9);
        assert!(
            u.corr > 0.5,
            "along the NE diagonal RA and Dec errors go together"
        );
    }
}
