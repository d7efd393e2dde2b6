//! soig's image layer: pixels and what is drawn on them, for the simulator and the detectors
//! alike. It imports soig's base and sky layers only.
//!
//! - [`imaging`]: bilinear sampling, robust statistics;
//! - [`geometry`]: the detector's frame kinds (original, padded, rotated), warps and label boxes;
//! - [`fits`]: FITS writing and reading through cfitsio, header cards;
//! - [`frames`]: real frames (FITS or PNG) and their sky region, for `soig detect`;
//! - [`enhance`]: the paper's FITS -> 8-bit conversion (stretch, CLAHE) and PNG;
//! - [`psf`]: the streak flux model shared by the renderer's labels and the streak detector;
//! - [`psf_shape`]: the PSF's shape, the sensor's Gaussian or a ground site's Moffat seeing;
//! - [`hint`]: what a detector may be told besides the pixels (predicted star trails);
//! - [`streak_label`]: the oriented box and end keypoints of a streak (YOLO-OBB, YOLO pose).

// Unit tests write their fixtures with std::fs; everything the product writes goes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![cfg_attr(test, allow(clippy::disallowed_methods))]

pub mod enhance;
pub mod fits;
pub mod frames;
pub mod geometry;
pub mod hint;
pub mod imaging;
pub mod psf;
pub mod psf_shape;
pub mod streak_label;
