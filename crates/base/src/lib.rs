//! soig's base layer: what every other layer may use and which imports nothing of soig.
//! Random streams (one ChaCha stream per seed, image and purpose), sha256 of values and files,
//! progress reporting, the build identity, and input-file checks and the Python probe.

pub mod build_id;
pub mod hash;
pub mod input_file;
pub mod progress;
pub mod python;
pub mod rng;
