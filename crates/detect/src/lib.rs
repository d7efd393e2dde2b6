//! soig's detectors: YOLOv8 through ONNX Runtime, and a classical streak detector that needs no
//! model. Both return `Detection`s in the same frame; [`metrics`] scores them as Ultralytics and
//! pycocotools do. It imports soig's base and image layers only: a detector sees pixels and the
//! image layer's `hint`, never the simulator (which its tests use to draw streaks to find).

// Unit tests write their fixtures with std::fs; everything the product writes goes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![cfg_attr(test, allow(clippy::disallowed_methods))]

/// An axis-aligned box in pixel-edge coordinates (the image spans [0, width] x [0, height],
/// Ultralytics' xyxy convention) with a confidence score and class.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Detection {
    pub x1: f64,
    pub y1: f64,
    pub x2: f64,
    pub y2: f64,
    pub score: f64,
    pub class: u32,
}

pub mod detector;
pub mod metrics;
pub mod streak;
pub mod yolo;

pub use detector::{Detector, Found, Stars, StreakDetector};
