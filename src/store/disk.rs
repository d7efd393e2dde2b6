//! What a run will write, said before it starts, and whether its disk holds it: a forgotten
//! `images` (4000 by default, about 20 GB with both FITS) or a full disk stops the run before
//! the first image, with both figures, instead of part way through.

use std::path::Path;

use crate::campaign::{Campaign, Stage};
use crate::geometry::FrameKind;

/// FITS files are written in 2880-byte blocks.
const FITS_BLOCK: u64 = 2880;
/// Header blocks of an image's FITS: its ~70 cards (WCS, provenance, frame) fill 2.
const FITS_HEADER_BLOCKS: u64 = 2;
/// The truth sidecar (~3 KB) and the YOLO label, with room to spare.
const TRUTH_BYTES: u64 = 8 * 1024;
/// The star list: ~100 bytes a star, a few hundred stars in the paper's field to mag 15.
const STAR_LIST_BYTES: u64 = 64 * 1024;

/// Bytes one image of the campaign writes, at most: its FITS exactly, its 8-bit PNG as if
/// incompressible (one byte a pixel plus a filter byte a row), its truth and star list bounded.
pub fn bytes_per_image(campaign: &Campaign) -> u64 {
    let c = &campaign.resolved;
    let (w, h) = (u64::from(c.sensor.width_px), u64::from(c.sensor.height_px));
    let fits = (FITS_HEADER_BLOCKS + (w * h * 4).div_ceil(FITS_BLOCK)) * FITS_BLOCK;
    let fits_files = u64::from(c.artifacts.fits) + u64::from(c.artifacts.noise_free_fits);
    let png = if c.stages.contains(&Stage::Enhance) {
        let (pw, ph) = match c.enhance.geometry {
            FrameKind::Original => (w, h),
            FrameKind::Padded => {
                let pad = 2 * u64::from(c.enhance.pad_px);
                (w + pad, h + pad)
            }
            // A square canvas of the diagonal, rounded up to 32 px (geometry::Frame::rotated).
            FrameKind::Rotated => {
                let side = ((w as f64).hypot(h as f64) / 32.0).ceil() as u64 * 32;
                (side, side)
            }
        };
        pw * ph + ph + 1024
    } else {
        0
    };
    let stars = if c.artifacts.star_list {
        STAR_LIST_BYTES
    } else {
        0
    };
    fits_files * fits + png + TRUTH_BYTES + stars
}

/// Free bytes for an unprivileged user on the filesystem that holds `path` (or, when it does
/// not exist yet, its nearest existing ancestor).
pub fn free_bytes(path: &Path) -> std::io::Result<u64> {
    let full = std::path::absolute(path)?;
    let existing = full
        .ancestors()
        .find(|p| p.exists())
        .unwrap_or(Path::new("/"));
    let s = nix::sys::statvfs::statvfs(existing).map_err(std::io::Error::from)?;
    Ok(s.blocks_available() as u64 * s.fragment_size() as u64)
}

/// Bytes for messages: megabytes below a gigabyte, else gigabytes, one decimal.
pub fn size(bytes: u64) -> String {
    if bytes < 1_000_000_000 {
        format!("{:.1} MB", bytes as f64 / 1e6)
    } else {
        format!("{:.1} GB", bytes as f64 / 1e9)
    }
}

/// Refuse a run of `images` images into `output` when its disk has less free space than they
/// need; otherwise say what is planned (through `note`).
pub fn check(
    campaign: &Campaign,
    images: u64,
    output: &Path,
    note: &dyn Fn(&str),
) -> anyhow::Result<()> {
    let need = images.saturating_mul(bytes_per_image(campaign));
    let free = free_bytes(output)
        .map_err(|e| anyhow::anyhow!("cannot read the free space for {}: {e}", output.display()))?;
    let c = &campaign.resolved;
    let plan = format!(
        "{images} images of {} x {} px: about {}",
        c.sensor.width_px,
        c.sensor.height_px,
        size(need)
    );
    if need > free {
        anyhow::bail!(
            "{}: the run would write {plan}, but its disk has {} free; lower `images` (now {}, {}) or free space",
            output.display(),
            size(free),
            c.images,
            campaign.source.display()
        );
    }
    note(&format!(
        "planned: {plan} into {} ({} free)",
        output.display(),
        size(free)
    ));
    Ok(())
}
