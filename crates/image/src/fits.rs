//! FITS images with a WCS and provenance keywords, through cfitsio (the `fitsio` crate).
//!
//! The noisy image is float32 ADU (BITPIX = -32): photons / gain is fractional and the
//! enhancement reads the full precision. The optional noise-free image is int32 photo-electrons.
//! Array row j is FITS row j + 1, so the WCS describes the same pixels as labels and PNGs.

use std::path::Path;

use fitsio::FitsFile;
use fitsio::images::{ImageDescription, ImageType};

use soig_sky::projection::{Tan, WcsValue};

/// A file name cfitsio cannot misread. cfitsio parses every name for its extended syntax
/// (`f.fits[1]`, `f.fits(template)`, a leading `!`, `-` for stdin, ...), so a folder named
/// `My Project (copy)` made it read or create another file than the one meant. soig hands it
/// `/proc/self/fd/N` instead: to read, N is the file itself, opened (as a regular file only)
/// by soig; to write, N is the file's folder and the name that follows is soig's own.
pub struct CfitsioName {
    /// Kept open while cfitsio uses `name`.
    _open: std::fs::File,
    pub name: std::path::PathBuf,
}

impl CfitsioName {
    /// The name of existing file `path`, to read: refused unless it is a regular file.
    pub fn to_read(path: &Path) -> std::io::Result<CfitsioName> {
        use std::os::fd::AsRawFd;
        let f = soig_base::hash::open_regular(path)?;
        let name = format!("/proc/self/fd/{}", f.as_raw_fd()).into();
        Ok(CfitsioName { _open: f, name })
    }

    /// The name of new file `path`, to create: its file name must be a plain one (letters,
    /// digits, `._-`, not leading `-`), as soig's are.
    pub fn to_create(path: &Path) -> std::io::Result<CfitsioName> {
        use std::os::fd::AsRawFd;
        let file = path
            .file_name()
            .and_then(|n| n.to_str())
            .filter(|n| {
                !n.starts_with('-')
                    && n.chars()
                        .all(|c| c.is_ascii_alphanumeric() || "._-".contains(c))
            })
            .ok_or_else(|| {
                std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    format!("{}: not a plain FITS file name", path.display()),
                )
            })?;
        let parent = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        let dir = std::fs::File::open(parent)?;
        let name = format!("/proc/self/fd/{}/{file}", dir.as_raw_fd()).into();
        Ok(CfitsioName { _open: dir, name })
    }
}

/// A header card value.
#[derive(Clone, Debug)]
pub enum Card {
    Int(i64),
    Real(f64),
    Str(String),
}

/// Header cards (keyword, value, comment) in writing order.
pub type Cards = Vec<(String, Card, String)>;

/// The WCS cards of a projection.
pub fn wcs_cards(tan: &Tan) -> Cards {
    cards_of(tan.wcs_cards())
}

/// Header cards of the sky layer's (keyword, value, comment) triples.
pub fn cards_of<K: Into<String>>(values: Vec<(K, WcsValue, &'static str)>) -> Cards {
    values
        .into_iter()
        .map(|(k, v, c)| {
            let v = match v {
                WcsValue::Int(i) => Card::Int(i),
                WcsValue::Real(r) => Card::Real(r),
                WcsValue::Str(s) => Card::Str(s.to_string()),
            };
            (k.into(), v, c.to_string())
        })
        .collect()
}

/// Pixel data of a FITS image.
pub enum Pixels<'a> {
    F32(&'a [f32]),
    I32(&'a [i32]),
}

/// Write a single-HDU FITS image. `path` must not exist (outputs are written into a fresh
/// directory and moved into place as a whole).
pub fn write_image(
    path: &Path,
    width: usize,
    height: usize,
    pixels: Pixels,
    cards: &Cards,
) -> Result<(), fitsio::errors::Error> {
    let data_type = match pixels {
        Pixels::F32(_) => ImageType::Float,
        Pixels::I32(_) => ImageType::Long,
    };
    let desc = ImageDescription {
        data_type,
        dimensions: &[height, width],
    };
    let safe = CfitsioName::to_create(path)?;
    let mut f = FitsFile::create(&safe.name)
        .with_custom_primary(&desc)
        .open()?;
    let hdu = f.primary_hdu()?;
    for (key, value, comment) in cards {
        match value {
            Card::Int(i) => hdu.write_key(&mut f, key, (*i, comment.as_str()))?,
            Card::Real(r) => hdu.write_key(&mut f, key, (*r, comment.as_str()))?,
            Card::Str(s) => hdu.write_key(&mut f, key, (s.as_str(), comment.as_str()))?,
        }
    }
    match pixels {
        Pixels::F32(d) => hdu.write_image(&mut f, d)?,
        Pixels::I32(d) => hdu.write_image(&mut f, d)?,
    }
    Ok(())
}

/// Read back a float image and its size (rows, cols), for checks and tests.
pub fn read_f32(path: &Path) -> Result<(Vec<f32>, usize, usize), fitsio::errors::Error> {
    read(path)
}

/// Read any 2-D image as f64 (exact for both of soig's pixel types), e.g. to compare two runs.
pub fn read_f64(path: &Path) -> Result<(Vec<f64>, usize, usize), fitsio::errors::Error> {
    read(path)
}

fn read<T: fitsio::images::ReadImage>(
    path: &Path,
) -> Result<(T, usize, usize), fitsio::errors::Error> {
    use fitsio::errors::Error;
    // The callers name the file.
    let refuse = |m: &str| Error::Message(m.to_string());
    // cfitsio's own errors print as `FitsError { status: 108, .. }`: give its words instead.
    let plain = |e: Error| match e {
        Error::Fits(f) => refuse(&format!("{} (cfitsio status {})", f.message, f.status)),
        other => other,
    };
    // Before cfitsio sees it: a device would never end, and a header that claims more pixels
    // than the file holds would have cfitsio allocate them all.
    let len = soig_base::input_file::regular(path).map_err(|why| refuse(&why))?;
    let mut head = [0u8; 9];
    let n = soig_base::hash::open_regular(path)
        .and_then(|mut f| std::io::Read::read(&mut f, &mut head))
        .map_err(|e| refuse(&e.to_string()))?;
    if n < head.len() || &head != b"SIMPLE  =" {
        return Err(refuse(&format!(
            "not a FITS file ({len} bytes, not beginning with a SIMPLE card)"
        )));
    }
    let safe = CfitsioName::to_read(path).map_err(|e| refuse(&e.to_string()))?;
    let mut f = FitsFile::open(&safe.name).map_err(plain)?;
    let hdu = f.primary_hdu().map_err(plain)?;
    let (rows, cols, bitpix) = match &hdu.info {
        fitsio::hdu::HduInfo::ImageInfo { shape, image_type } if shape.len() == 2 => {
            (shape[0], shape[1], i32::from(*image_type))
        }
        _ => return Err(refuse("not a 2-D image")),
    };
    let bytes = (rows as u64)
        .checked_mul(cols as u64)
        .and_then(|n| n.checked_mul(bitpix.unsigned_abs() as u64 / 8));
    if bytes.is_none_or(|b| b > len) {
        return Err(refuse(&format!(
            "its header claims {cols} x {rows} pixels (BITPIX {bitpix}), more than its {len} \
             bytes hold: truncated?"
        )));
    }
    let data = hdu.read_image(&mut f).map_err(plain)?;
    Ok((data, rows, cols))
}
