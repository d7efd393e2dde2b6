//! The product: an image's files (`artifacts`, from the `records` Python returns too), the dataset's split and layout, collects, the
//! exports (COCO, DS9), the star trails a detector is told of, light curves, a shard's share
//! of the images, and the streak-shaped label sets. Every file goes through the store.

pub(crate) mod artifacts;
pub mod collect;
pub mod dataset;
pub mod export;
pub mod light_curve;
pub mod observations;
pub mod population_omm;
pub mod records;
pub mod shard;
pub(crate) mod site_cards;
pub mod sky_track;
pub mod star_trails;
pub mod streak_labels;
pub mod truth_sidecar;
