//! Real frames for `soig detect`: a FITS image of any numeric type (cfitsio converts every
//! BITPIX to f32 and applies BSCALE/BZERO) in the first HDU that holds a 2-D image, or a PNG
//! (any colour type, taken as greyscale: an image already enhanced for a detector).
//!
//! A raw frame's prescan and overscan columns are not sky: its sky pixels are the IRAF section
//! `TRIMSEC`, else `DATASEC` (`[x1:x2,y1:y2]`, 1-based, inclusive), else the whole image.
//! Detectors run on that region only; every position they report is put back into the file's
//! own pixel grid, the one its WCS (`sky::wcs`) describes.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use fitsio::FitsFile;
use fitsio::hdu::HduInfo;

use rand::RngExt;
use soig_base::rng::{PixelPurpose, pixel_stream};
use soig_sky::wcs::TanWcs;

/// A frame that cannot be read, with its path.
#[derive(Debug, thiserror::Error)]
#[error("{}: {message}", path.display())]
pub struct FrameError {
    pub path: PathBuf,
    pub message: String,
}

/// The sky pixels of a frame, 0-based and half-open: columns `x0..x1`, rows `y0..y1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Region {
    pub x0: usize,
    pub y0: usize,
    pub x1: usize,
    pub y1: usize,
}

impl Region {
    pub fn width(&self) -> usize {
        self.x1 - self.x0
    }
    pub fn height(&self) -> usize {
        self.y1 - self.y0
    }
}

/// The region's pixels, row-major.
#[derive(Clone, Debug)]
pub enum RegionPixels {
    /// A FITS image's values (ADU or whatever unit it holds); non-finite values as read.
    Values(Vec<f32>),
    /// A PNG's grey levels.
    Gray(Vec<u8>),
}

/// A real frame, read.
#[derive(Clone, Debug)]
pub struct Frame {
    pub path: PathBuf,
    /// Size of the file's image, pixels.
    pub width: usize,
    pub height: usize,
    /// Where its sky pixels are, and which keyword said so (`None`: the whole image).
    pub region: Region,
    pub region_keyword: Option<&'static str>,
    pub pixels: RegionPixels,
    /// The frame's TAN WCS, if it has one this reader can apply...
    pub wcs: Option<TanWcs>,
    /// ...and why not, when the header has a WCS that cannot be applied.
    pub wcs_problem: Option<String>,
    /// The header cards read (`HEADER_KEYS`: sections, WCS, the alternate WCS of the
    /// exposure's start and end, its timing, zero point): keyword -> value as text. Empty for
    /// a PNG.
    pub header: HashMap<String, String>,
}

/// Header keywords read besides the WCS.
const SECTION_KEYS: [&str; 2] = ["TRIMSEC", "DATASEC"];
const WCS_KEYS: [&str; 20] = [
    "CTYPE1", "CTYPE2", "CUNIT1", "CUNIT2", "CRPIX1", "CRPIX2", "CRVAL1", "CRVAL2", "CDELT1",
    "CDELT2", "CD1_1", "CD1_2", "CD2_1", "CD2_2", "PC1_1", "PC1_2", "PC2_1", "PC2_2", "PV2_1",
    "A_ORDER",
];

/// The keywords of an exposure's timing and photometry (`soig detect --catalog`).
const EXPOSURE_KEYS: [&str; 5] = ["DATE-OBS", "MJD-OBS", "EXPTIME", "EXPOSURE", "MAGZERO"];

/// Every keyword read from a FITS header: sections, WCS, the alternate WCS of the exposure's
/// start and end (`sky::motion`), timing and zero point.
fn header_keys() -> Vec<String> {
    let mut keys: Vec<String> = SECTION_KEYS
        .iter()
        .chain(WCS_KEYS.iter())
        .chain(EXPOSURE_KEYS.iter())
        .map(|k| k.to_string())
        .collect();
    for letter in [soig_sky::motion::START, soig_sky::motion::END] {
        keys.extend(WCS_KEYS.iter().map(|k| format!("{k}{letter}")));
    }
    keys
}

impl Frame {
    /// Read a FITS or PNG frame, told apart by their first bytes, not by the file name.
    pub fn read(path: &Path) -> Result<Frame, FrameError> {
        let err = |message: String| FrameError {
            path: path.to_path_buf(),
            message,
        };
        let mut head = [0u8; 8];
        {
            use std::io::Read;
            let mut f = soig_base::hash::open_regular(path)
                .map_err(|e| err(format!("cannot open: {e}")))?;
            let n = f
                .read(&mut head)
                .map_err(|e| err(format!("cannot read: {e}")))?;
            if n < head.len() {
                return Err(err("too short to be a FITS or PNG file".into()));
            }
        }
        if &head == b"SIMPLE  " {
            read_fits(path).map_err(err)
        } else if head == *b"\x89PNG\r\n\x1a\n" {
            read_png(path).map_err(err)
        } else {
            Err(err(
                "neither a FITS file (no SIMPLE card) nor a PNG: soig detect reads those two"
                    .into(),
            ))
        }
    }
}

/// Most pixels of a frame `soig detect` or `enhance` reads: 8192 x 8192, a large survey CCD,
/// ~1.5 GB in the f32 and f64 copies processing makes. A 388 kB PNG can claim 20000 x 20000
/// (10 GB to decode), so the claim is checked before anything is allocated.
pub const MAX_FRAME_PIXELS: u64 = 1 << 26;

/// Refuse a frame of `width` x `height` pixels beyond [`MAX_FRAME_PIXELS`].
fn check_pixels(width: u64, height: u64) -> Result<(), String> {
    if width.saturating_mul(height) > MAX_FRAME_PIXELS {
        return Err(format!(
            "{width} x {height} pixels, more than the {MAX_FRAME_PIXELS} (8192 x 8192) soig reads"
        ));
    }
    Ok(())
}

fn read_png(path: &Path) -> Result<Frame, String> {
    let open = || {
        image::ImageReader::new(std::io::BufReader::new(
            soig_base::hash::open_regular(path).map_err(|e| format!("cannot open: {e}"))?,
        ))
        .with_guessed_format()
        .map_err(|e| format!("cannot read: {e}"))
    };
    let (w, h) = open()?
        .into_dimensions()
        .map_err(|e| format!("not a readable PNG ({e})"))?;
    check_pixels(w.into(), h.into())?;
    let img = open()?
        .decode()
        .map_err(|e| format!("not a readable PNG ({e})"))?
        .to_luma8();
    let (width, height) = (img.width() as usize, img.height() as usize);
    Ok(Frame {
        path: path.to_path_buf(),
        width,
        height,
        region: Region {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        },
        region_keyword: None,
        pixels: RegionPixels::Gray(img.into_raw()),
        wcs: None,
        wcs_problem: None,
        header: HashMap::new(),
    })
}

fn read_fits(path: &Path) -> Result<Frame, String> {
    let safe = crate::fits::CfitsioName::to_read(path).map_err(|e| format!("cannot open: {e}"))?;
    let mut f =
        FitsFile::open(&safe.name).map_err(|e| format!("not a readable FITS file ({e})"))?;
    // The first HDU holding a 2-D image (a compressed or extension image included).
    let mut found = None;
    for i in 0.. {
        let Ok(hdu) = f.hdu(i) else { break };
        let size = match &hdu.info {
            HduInfo::ImageInfo { shape, .. }
                if shape.len() == 2 && shape[0] > 0 && shape[1] > 0 =>
            {
                Some((shape[0], shape[1]))
            }
            _ => None,
        };
        if let Some((rows, cols)) = size {
            found = Some((hdu, rows, cols));
            break;
        }
    }
    let (hdu, height, width) = found.ok_or_else(|| "no HDU holds a 2-D image".to_string())?;
    check_pixels(width as u64, height as u64)?;
    let mut header = HashMap::new();
    for key in header_keys() {
        if let Ok(v) = hdu.read_key::<String>(&mut f, &key) {
            header.insert(key, v);
        }
    }
    let values: Vec<f32> = hdu
        .read_image(&mut f)
        .map_err(|e| format!("cannot read its image ({e})"))?;
    let (region, region_keyword) = match SECTION_KEYS.iter().find_map(|k| {
        header
            .get(*k)
            .filter(|v| !v.trim().is_empty())
            .map(|v| (*k, v))
    }) {
        Some((key, text)) => (section(key, text, width, height)?, Some(key)),
        None => (
            Region {
                x0: 0,
                y0: 0,
                x1: width,
                y1: height,
            },
            None,
        ),
    };
    let mut pixels = Vec::with_capacity(region.width() * region.height());
    for y in region.y0..region.y1 {
        pixels.extend_from_slice(&values[y * width + region.x0..y * width + region.x1]);
    }
    if !pixels.iter().any(|v| v.is_finite()) {
        return Err("no pixel of its image is a finite number: nothing to detect on".into());
    }
    // Some writers (NEOSSat's) append their own units to extra WCS keywords; a distortion
    // keyword means the plain TAN reader would be wrong.
    let (wcs, wcs_problem) = if header.contains_key("A_ORDER") || header.contains_key("PV2_1") {
        (
            None,
            Some("the header has distortion terms (SIP A_ORDER or PV), not read".to_string()),
        )
    } else {
        match TanWcs::from_header(|k| header.get(k).cloned()) {
            Ok(w) => (w, None),
            Err(problem) => (None, Some(problem)),
        }
    };
    Ok(Frame {
        path: path.to_path_buf(),
        width,
        height,
        region,
        region_keyword,
        pixels: RegionPixels::Values(pixels),
        wcs,
        wcs_problem,
        header,
    })
}

/// An IRAF image section `[x1:x2,y1:y2]` (1-based, inclusive) inside a `width` x `height` image.
fn section(key: &str, text: &str, width: usize, height: usize) -> Result<Region, String> {
    let bad = || {
        format!(
            "{key} = '{text}' is not an image section [x1:x2,y1:y2] inside its {width} x {height} image"
        )
    };
    let inner = text
        .trim()
        .strip_prefix('[')
        .and_then(|t| t.strip_suffix(']'))
        .ok_or_else(bad)?;
    let ranges: Vec<(usize, usize)> = inner
        .split(',')
        .map(|r| {
            let (a, b) = r.split_once(':')?;
            Some((a.trim().parse().ok()?, b.trim().parse().ok()?))
        })
        .collect::<Option<_>>()
        .ok_or_else(bad)?;
    let [(x1, x2), (y1, y2)] = ranges[..] else {
        return Err(bad());
    };
    if x1 < 1 || y1 < 1 || x1 > x2 || y1 > y2 || x2 > width || y2 > height {
        return Err(bad());
    }
    Ok(Region {
        x0: x1 - 1,
        y0: y1 - 1,
        x1: x2,
        y1: y2,
    })
}

/// A FITS region ready for the enhancement: each non-finite value (no data: a registered or
/// mosaicked frame's margins, masked pixels) replaced by a finite value of the region drawn at
/// random (a seeded stream, so the same frame gives the same image), and, before a square
/// root, the minimum raised to 0 when it is negative (values the square root would clip).
/// Returns (values, non-finite count, pedestal added).
///
/// Why drawn values: a margin set to one value (the finite median, as before) is a flat field
/// whose edge against the sky's noise the CLAHE tiles and the streak detector's background
/// mesh both see: 102 false boxes on 40 independent survey frames rotated 20 degrees onto a
/// canvas with NaN corners, against 1 on the same frames unrotated. Drawn from the frame's own
/// values the margin has the sky's level, spread and tail (hot pixels, stars: a fill cut at a
/// few sigma left a step at the join, issue #30), so nothing marks where the data end.
pub fn ready_for_enhancement(values: &[f32], sqrt: bool) -> (Vec<f32>, usize, f64) {
    let non_finite = values.iter().filter(|v| !v.is_finite()).count();
    let mut out = values.to_vec();
    // The draws need the finite values apart: a copy only for a frame that has holes.
    if non_finite > 0 {
        let finite: Vec<f32> = values.iter().copied().filter(|v| v.is_finite()).collect();
        let mut rng = pixel_stream(0, 0, PixelPurpose::Enhance);
        for v in out.iter_mut().filter(|v| !v.is_finite()) {
            *v = match finite.len() {
                0 => 0.0,
                n => finite[rng.random_range(0..n)],
            };
        }
    }
    let min = out.iter().copied().fold(f32::INFINITY, f32::min);
    let pedestal = if sqrt && min < 0.0 {
        -(min as f64)
    } else {
        0.0
    };
    if pedestal > 0.0 {
        out.iter_mut()
            .for_each(|v| *v = (*v as f64 + pedestal) as f32);
    }
    (out, non_finite, pedestal)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ready_for_enhancement_fills_non_finite_and_lifts_negative_frames_for_the_square_root() {
        let (v, n, p) = ready_for_enhancement(&[-2.0, f32::NAN, 1.0, 5.0, f32::INFINITY], true);
        assert_eq!((n, p), (2, 2.0));
        // The finite values lifted by the pedestal; the NaN and the infinity take finite values
        // of the frame, lifted too.
        assert_eq!((v[0], v[2], v[3]), (0.0, 3.0, 7.0));
        assert!(
            [0.0, 3.0, 7.0].contains(&v[1]) && [0.0, 3.0, 7.0].contains(&v[4]),
            "{v:?}"
        );
        // Nothing finite: zeros.
        let (v, n, _) = ready_for_enhancement(&[f32::NAN, f32::NEG_INFINITY], false);
        assert_eq!((v, n), (vec![0.0, 0.0], 2));
        let (v, _, p) = ready_for_enhancement(&[-2.0, 1.0], false);
        assert_eq!((v, p), (vec![-2.0, 1.0], 0.0));
    }

    #[test]
    fn sections_are_one_based_and_inclusive() {
        let r = section("TRIMSEC", "[41:1064,1:1020]", 1078, 1020).unwrap();
        assert_eq!((r.x0, r.x1, r.y0, r.y1), (40, 1064, 0, 1020));
        assert_eq!((r.width(), r.height()), (1024, 1020));
        for bad in [
            "41:1064,1:1020",
            "[0:10,1:5]",
            "[5:4,1:5]",
            "[1:2000,1:5]",
            "[1:5]",
            "[a:b,1:2]",
        ] {
            let e = section("DATASEC", bad, 1078, 1020).unwrap_err();
            assert!(e.contains("DATASEC") && e.contains(bad), "{e}");
        }
    }

    #[test]
    fn reads_the_neossat_fixture_with_its_wcs() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../tests/fixtures/neossat/NEOS_SCI_2024239174545_cord.fits");
        let f = Frame::read(&path).unwrap();
        assert_eq!((f.width, f.height), (512, 512));
        assert_eq!(f.region_keyword, Some("TRIMSEC"));
        assert_eq!((f.region.width(), f.region.height()), (512, 512));
        let w = f.wcs.expect("the frame has a TAN WCS");
        assert_eq!(w.crpix, [262.0, 249.0]);
        assert_eq!(w.cd[0][1], -0.00082815);
        assert!(f.wcs_problem.is_none());
    }
}
