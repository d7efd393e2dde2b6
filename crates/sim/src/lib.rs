//! soig's simulator: a scene drawn from its values (never from the campaign file), rendered by
//! photon mapping into an exposure with its truth. It imports soig's base, sky and image layers,
//! never the detectors (they meet in the image layer's `hint` and in the product layer above).
//!
//! - [`scene`]: the draw (which object, when, where the sensor points, which stars) and its
//!   visibility checks; [`sighting`]: an object seen from the observer over an exposure;
//! - [`sensor`], [`noise`], [`background`]: the detector, its noise, real-frame backgrounds;
//! - [`atmosphere`], [`sky_glow`]: a ground site's air (airmass, seeing, scintillation) and sky;
//! - [`render`]: photons to electrons to ADU, labels and truth;
//! - [`simulate`]: one image's products in memory, a pure function of (values, inputs, index).

// Unit tests write their fixtures with std::fs; everything the product writes goes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![cfg_attr(test, allow(clippy::disallowed_methods))]

pub mod atmosphere;
pub mod background;
pub mod noise;
pub mod observer;
pub mod render;
pub mod scene;
pub mod sensor;
pub mod sighting;
pub mod simulate;
pub mod sky_glow;
