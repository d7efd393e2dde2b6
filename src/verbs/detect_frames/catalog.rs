//! `soig detect --catalog`: the catalogued stars' trails in a frame, for the star-aware streak
//! detector, from what the frame's FITS header says about it and a star catalogue (the CSV
//! formats `stars.source = "catalog"` reads: Gaia archive or VizieR columns).
//!
//! - Where the sky lies: the primary TAN WCS (at mid-exposure in soig's FITS).
//! - When: `DATE-OBS` (else `MJD-OBS`), the start of the exposure, moves the catalogue's stars
//!   to the frame's epoch by their proper motions; `EXPTIME` (else `EXPOSURE`), its length.
//! - How the camera moved over the exposure: the WCS at its start and end (alternate WCS `S`
//!   and `E`, `sky::motion`), which soig writes for survey and track images. A header without
//!   them is taken as fixed on the sky (sidereal tracking): every star is a point at its WCS
//!   position, which real frames taken while the pointing drifted do not follow.
//! - How bright: `MAGZERO` (the magnitude of 1 e-/s) gives each trail's expected electrons; a
//!   frame without it gets none (the detector measures a trail's level on the frame itself).
//!
//! Each star is placed as the renderer places it (`render::sources`): at time nodes 4 px of
//! drift apart, linear in between, exposed while it is within 8 PSF sigmas of the frame.

use std::path::Path;

use anyhow::{Context, bail};
use hifitime::Epoch;

use crate::detect::streak::StarTrail;
use crate::frames::Frame;
use crate::hint::PredictedTrail;
use crate::sky::motion::{Camera, ExposureMotion};
use crate::sky::photometry::photon_rate;
use crate::sky::radec_unit;
use crate::sky::stars::StarCatalog;
use crate::sky::wcs::TanWcs;

/// Spacing of the time nodes along a trail, pixels of drift (the renderer's).
const NODE_SPACING_PX: f64 = 4.0;

/// Most pixels the stars may drift over one exposure: 100 000 time nodes, about 15 MB of
/// cameras. soig's own images drift at most `MAX_SURVEY_DRIFT_DEG` (72 000 px at 0.1"/px); a
/// header with a tiny CD and start and end WCS far apart would ask for terabytes.
const MAX_DRIFT_PX: f64 = 400_000.0;

/// The dates a header may give, MJD (1900-01-01 to 2200-01-01): an exposure's start outside
/// them is a broken header, and far outside them overflows the time scales.
const MJD_RANGE: std::ops::RangeInclusive<f64> = 15_020.0..=124_593.0;

/// What a frame's header says of its sky over the exposure.
#[derive(Clone, Debug)]
pub struct FrameSky {
    pub wcs: TanWcs,
    /// None: the header says nothing of a motion (taken as fixed on the sky).
    pub motion: Option<ExposureMotion>,
    pub start: Epoch,
    pub exposure_s: f64,
    pub zero_point_mag: Option<f64>,
}

impl FrameSky {
    /// Read from a frame; `Err` naming the file and the keyword when `--catalog` cannot be
    /// used on it.
    pub fn of(frame: &Frame) -> anyhow::Result<FrameSky> {
        let file = frame.path.display();
        if matches!(frame.pixels, crate::frames::RegionPixels::Gray(_)) {
            bail!(
                "{file}: --catalog needs the frame's WCS and exposure time, and a PNG has none: \
                 give the FITS frame instead"
            );
        }
        let Some(wcs) = frame.wcs else {
            match &frame.wcs_problem {
                Some(p) => {
                    bail!("{file}: --catalog needs the frame's WCS, which cannot be read: {p}")
                }
                None => bail!(
                    "{file}: --catalog needs the frame's WCS: the header has no CTYPE1/CTYPE2 (a TAN WCS with CRVAL, CRPIX and CD or CDELT)"
                ),
            }
        };
        let card = |k: &str| frame.header.get(k).map(|v| v.trim().to_string());
        let number = |k: &str| -> anyhow::Result<Option<f64>> {
            match card(k) {
                None => Ok(None),
                Some(v) => match v.replace(['D', 'd'], "E").parse::<f64>() {
                    Ok(x) if x.is_finite() => Ok(Some(x)),
                    _ => bail!("{file}: header keyword {k} = {v:?} is not a finite number"),
                },
            }
        };
        let start = match (card("DATE-OBS"), number("MJD-OBS")?) {
            (Some(d), _) => parse_date(&d).with_context(|| {
                format!("{file}: header keyword DATE-OBS = {d:?} is not an ISO date and time")
            })?,
            (None, Some(mjd)) => Epoch::from_mjd_utc(mjd),
            (None, None) => bail!(
                "{file}: --catalog needs the exposure's start (header keyword DATE-OBS or MJD-OBS) to move the catalogue's stars to it"
            ),
        };
        let mjd = start.to_mjd_utc_days();
        if !MJD_RANGE.contains(&mjd) {
            let (key, v) = match card("DATE-OBS") {
                Some(d) => ("DATE-OBS", d),
                None => ("MJD-OBS", card("MJD-OBS").unwrap_or_default()),
            };
            bail!(
                "{file}: header keyword {key} = {v}: the exposure's start must lie between 1900 and 2200 (MJD {} to {})",
                MJD_RANGE.start(),
                MJD_RANGE.end()
            );
        }
        // EXPTIME, else EXPOSURE (NEOSSat's, and older FITS writers').
        let (key, exposure_s) = match (number("EXPTIME")?, number("EXPOSURE")?) {
            (Some(t), _) => ("EXPTIME", t),
            (None, Some(t)) => ("EXPOSURE", t),
            (None, None) => bail!(
                "{file}: --catalog needs the exposure time: header keywords EXPTIME and EXPOSURE are missing"
            ),
        };
        if exposure_s < 0.0 {
            bail!("{file}: header keyword {key} = {exposure_s} is negative");
        }
        let motion = ExposureMotion::from_header(|k| card(k), &wcs)
            .map_err(|e| anyhow::anyhow!("{file}: {e}"))?;
        if let Some(m) = &motion {
            let scale_arcsec = wcs.pixel_scale_arcsec();
            let drift_px = m.drift_deg() * 3600.0 / scale_arcsec;
            if drift_px.is_nan() || drift_px > MAX_DRIFT_PX {
                bail!(
                    "{file}: the start and end WCS (alternate WCS S and E) move the pointing {:.6} deg over the exposure, {drift_px:.3e} px at the CD's {scale_arcsec:.3e} arcsec/px: more than the {MAX_DRIFT_PX} px of drift --catalog predicts trails for",
                    m.drift_deg()
                );
            }
        }
        Ok(FrameSky {
            wcs,
            motion,
            start,
            exposure_s,
            zero_point_mag: number("MAGZERO")?,
        })
    }

    /// Every star of `catalog` that can put light in the `x0..x1` x `y0..y1` pixels of the
    /// file (half-open), with a PSF of `psf_sigma_px`.
    pub fn predict(
        &self,
        catalog: &StarCatalog,
        region: crate::frames::Region,
        psf_sigma_px: f64,
    ) -> Vec<PredictedTrail> {
        let scale_deg = self.wcs.pixel_scale_arcsec() / 3600.0;
        let margin = 8.0 * psf_sigma_px + 1.0;
        let (x0, y0) = (
            region.x0 as f64 - 0.5 - margin,
            region.y0 as f64 - 0.5 - margin,
        );
        let (x1, y1) = (
            region.x1 as f64 - 0.5 + margin,
            region.y1 as f64 - 0.5 + margin,
        );
        let near = |(x, y): (f64, f64)| x > x0 && y > y0 && x < x1 && y < y1;
        // The cone around the mid-exposure tangent point that holds every star the frame can
        // see at some time: its farthest corner, the margin and the drift.
        let corner = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)]
            .iter()
            .map(|&(x, y)| (x + 1.0 - self.wcs.crpix[0]).hypot(y + 1.0 - self.wcs.crpix[1]))
            .fold(0.0, f64::max);
        let drift_deg = self.motion.as_ref().map_or(0.0, |m| m.drift_deg());
        let radius = corner * scale_deg * 1.01 + drift_deg;
        let at = crate::scene::julian_year(
            self.start + hifitime::Duration::from_seconds(self.exposure_s / 2.0),
        );
        let stars = catalog.stars_in_cone(
            self.wcs.crval[0],
            self.wcs.crval[1],
            radius,
            f64::INFINITY,
            at,
        );
        let rate = |mag: f64| self.zero_point_mag.map(|z| photon_rate(mag, z));
        let mut out = Vec::new();
        match &self.motion {
            None => {
                let camera = Camera::of(&self.wcs);
                for s in stars {
                    let Some(p) = camera.pixel(radec_unit(s.ra_deg, s.dec_deg)) else {
                        continue;
                    };
                    if near(p) {
                        out.push(PredictedTrail {
                            ra_deg: s.ra_deg,
                            dec_deg: s.dec_deg,
                            mag: s.mag,
                            nodes: vec![[p.0, p.1]],
                            times_s: vec![0.5 * self.exposure_s],
                            electrons: rate(s.mag).map(|r| r * self.exposure_s),
                        });
                    }
                }
            }
            Some(motion) => {
                // The renderer's time grid: nodes 4 px of drift apart.
                let nodes = ((drift_deg / scale_deg / NODE_SPACING_PX).ceil() as usize + 1).max(2);
                let step = self.exposure_s / (nodes - 1) as f64;
                let cameras: Vec<Camera> = (0..nodes)
                    .map(|i| motion.camera_at(i as f64 / (nodes - 1) as f64))
                    .collect();
                for s in stars {
                    let v = radec_unit(s.ra_deg, s.dec_deg);
                    let path: Vec<(f64, f64)> = cameras
                        .iter()
                        .map(|c| c.pixel(v).unwrap_or((f64::NAN, f64::NAN)))
                        .collect();
                    let (Some(a), Some(b)) = (
                        path.iter().position(|&p| near(p)),
                        path.iter().rposition(|&p| near(p)),
                    ) else {
                        continue;
                    };
                    // One node of slack on each side covers a trail entering between nodes.
                    let (a, b) = (a.saturating_sub(1), (b + 1).min(nodes - 1));
                    out.push(PredictedTrail {
                        ra_deg: s.ra_deg,
                        dec_deg: s.dec_deg,
                        mag: s.mag,
                        nodes: path[a..=b].iter().map(|&(x, y)| [x, y]).collect(),
                        times_s: (a..=b).map(|k| k as f64 * step).collect(),
                        electrons: rate(s.mag).map(|r| r * (b - a) as f64 * step),
                    });
                }
            }
        }
        out
    }
}

/// An ISO date and time (`2022-01-22T10:00:00.5`, as FITS `DATE-OBS` writes it; UTC).
fn parse_date(text: &str) -> anyhow::Result<Epoch> {
    let t = text.trim().trim_end_matches('Z');
    // A bare date is midnight.
    let t = if t.len() == 10 {
        format!("{t}T00:00:00")
    } else {
        t.to_string()
    };
    Epoch::from_gregorian_str(&format!("{t} UTC"))
        .or_else(|_| Epoch::from_gregorian_str(&t))
        .map_err(|e| anyhow::anyhow!("{e}"))
}

/// The predicted trails in the detector's image of `region` (its pixels, 0-based from the
/// region's corner): only the nodes on it, as `soig run` gives them (`star_trails`).
pub fn in_region(predicted: &[PredictedTrail], region: crate::frames::Region) -> Vec<StarTrail> {
    let (ox, oy) = (region.x0 as f64, region.y0 as f64);
    let (w, h) = (region.width() as f64, region.height() as f64);
    let on = |x: f64, y: f64| x >= 0.0 && y >= 0.0 && x <= w - 1.0 && y <= h - 1.0;
    predicted
        .iter()
        .filter_map(|p| {
            p.on_image(|[x, y]| {
                let (x, y) = (x - ox, y - oy);
                on(x, y).then_some((x, y))
            })
        })
        .collect()
}

/// The star trails' direction, degrees from +x towards +y in [0, 180): the mean of their
/// chords' directions, weighted by length (doubled angles, so 1 and 179 degrees average to
/// 0). None when no trail is longer than `min_px` (stars that do not move).
pub fn trail_angle_deg(trails: &[StarTrail], min_px: f64) -> Option<f64> {
    let (mut c, mut s) = (0.0, 0.0);
    for t in trails {
        let (Some(a), Some(b)) = (t.nodes.first(), t.nodes.last()) else {
            continue;
        };
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let len = dx.hypot(dy);
        if len > min_px {
            let th = 2.0 * dy.atan2(dx);
            c += len * th.cos();
            s += len * th.sin();
        }
    }
    (c != 0.0 || s != 0.0).then(|| (s.atan2(c) / 2.0).to_degrees().rem_euclid(180.0))
}

/// Read `path` as a star catalogue at epoch `epoch_jyear` (errors name file, line and column).
pub fn read(path: &Path, epoch_jyear: f64) -> anyhow::Result<StarCatalog> {
    if !(1000.0..=3000.0).contains(&epoch_jyear) {
        bail!("--catalog-epoch {epoch_jyear}: not a Julian year between 1000 and 3000");
    }
    // A FIFO would block the read for ever, a device never end.
    crate::input_file::regular(path)
        .map_err(|why| anyhow::anyhow!("--catalog {}: {why}", path.display()))?;
    Ok(StarCatalog::from_csv_path(path, epoch_jyear)?)
}
