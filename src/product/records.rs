//! What one image's files say, derived in one place: the truth sidecar, the noise-free counts,
//! the label text and boxes. The writer (`artifacts::write_image`) writes these and Python's
//! `Campaign.image` returns them, so the two cannot drift apart (issue #42); the FITS cards are
//! `artifacts::provenance_cards`, used by both too.

use serde::Serialize;

use crate::render::{Exposure, FrameTruth, Truth};
use crate::simulate::{FinalImage, ImageProducts};

/// An image's truth sidecar as `soig run` writes it: the one object of a campaign without
/// `[objects]`, or the frame and each of its objects.
#[derive(Serialize)]
#[serde(untagged)]
pub enum TruthRecord<'a> {
    One(&'a Truth),
    Frame(Box<FrameTruth<'a>>),
}

/// The truth sidecar of an image.
pub fn truth(products: &ImageProducts) -> TruthRecord<'_> {
    let exposure = &products.exposure;
    match (&exposure.objects, &products.scene.placed) {
        (Some(objects), Some(_)) => TruthRecord::Frame(Box::new(FrameTruth::of_scene(
            &exposure.truth,
            objects.iter().map(|o| &o.truth),
            &products.scene,
        ))),
        _ => TruthRecord::One(&exposure.truth),
    }
}

/// The noise-free FITS's pixels: photo-electrons as int32 (FITS has no unsigned 32-bit
/// image), clamped at i32::MAX.
pub fn clean_counts(exposure: &Exposure) -> Vec<i32> {
    exposure
        .electrons
        .iter()
        .map(|&v| v.min(i32::MAX as u32) as i32)
        .collect()
}

/// The YOLO label file's text: one line per labelled object, none for an empty frame.
pub fn label_text(product: &FinalImage) -> String {
    let frame = &product.frame;
    product
        .labels
        .iter()
        .map(|b| b.yolo_line(frame.width, frame.height))
        .collect()
}

/// The label boxes in pixel-edge coordinates (pixel i spans [i, i + 1); the boxes' pixel
/// centres are at half a pixel less): x_min, y_min, x_max, y_max.
pub fn label_edges(product: &FinalImage) -> Vec<[f64; 4]> {
    product
        .labels
        .iter()
        .map(|b| [b.x_min + 0.5, b.y_min + 0.5, b.x_max + 0.5, b.y_max + 0.5])
        .collect()
}
