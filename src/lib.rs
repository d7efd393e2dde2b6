//! soig: a space optical image generator. A campaign file becomes a reproducible experiment:
//! scenes of space debris seen from a satellite, photon-mapped images, enhanced PNGs, an
//! Ultralytics dataset, and a manifest hashing every artifact.
//!
//! Data flows one way: `campaign` -> `scene` -> `render` -> `fits` / `enhance` -> `dataset`,
//! driven by `pipeline`, recorded by `manifest`.

pub mod artifacts;
pub mod background;
pub mod campaign;
pub mod dataset;
pub mod detect;
pub mod enhance;
pub mod error;
pub mod experiment;
pub mod fits;
pub mod geometry;
pub mod hash;
pub mod imaging;
pub mod manifest;
pub mod metrics;
pub mod output;
pub mod pipeline;
pub mod plot;
pub mod progress;
pub mod python;
pub mod render;
pub mod report;
pub mod rng;
pub mod scene;
pub mod sensor;
pub mod simulate;
pub mod sky;
pub mod study;
pub mod train;
