//! soig's base layer: what every other layer may use and which imports nothing of soig.
//! Random streams (one ChaCha stream per seed, image and purpose), sha256 of values and files,
//! progress reporting, the build identity, and input-file checks and the Python probe.

// Unit tests write their fixtures with std::fs; everything the product writes goes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![cfg_attr(test, allow(clippy::disallowed_methods))]

pub mod build_id;
pub mod hash;
pub mod input_file;
pub mod progress;
pub mod python;
pub mod rng;
