//! soig: a space optical image generator. A campaign file becomes a reproducible experiment:
//! scenes of space debris seen from a satellite, photon-mapped images, enhanced PNGs, an
//! Ultralytics dataset, detectors and their metrics, and a manifest hashing every artifact.
//!
//! # Layers
//!
//! Imports go one way, top to bottom (no module imports one above it, and there is no cycle):
//!
//! ```text
//! verbs          merge (of shards)   pipeline (run, train)   study   compare   tables   detect_frames   convert   main.rs: the CLI
//! config layer   campaign (file, defaults, compose, validate, resolve)  experiment (-> values)
//! product        simulate (one image in memory)   artifacts (its files)   dataset   collect   train
//!                shard (a share of the images)
//! core           render -> scene -> sighting, sensor -> background     geometry (frames, label box)
//!                enhance (+ clahe)   detect (streak, yolo)   metrics   report
//! leaves         sky (orbit, frames, ephemeris, apparent, stars, projection, photometry, vec3, wcs)
//!                imaging   rng   fits   frames   hash   python   plot   progress   input_file
//! at the side    store: fs (the file primitives), manifest, output (whole-or-nothing
//!                directories), journal (resume), disk (free space)   error
//! ```
//!
//! The core never sees the campaign file: the config layer builds a [`Sensor`], a
//! [`scene::Spec`], [`render::Settings`] and [`enhance::Settings`] once, gathered in an
//! [`Experiment`], and [`simulate::image`] turns (experiment, inputs, index) into the image's
//! products in memory. `soig run`, `soig study`, the benchmarks and an embedding program all
//! go through it.
//!
//! # Embedding
//!
//! ```no_run
//! use soig::{Campaign, Experiment};
//!
//! let campaign = Campaign::load("campaigns/quickstart.toml".as_ref())?;
//! let experiment = crate::experiment::of(&campaign);
//! let inputs = soig::experiment::inputs(&campaign)?;
//! let image = soig::simulate::image(&experiment, &inputs, 0)?;
//! println!("{} at SNR {:.2}", image.exposure.truth.object, image.exposure.truth.snr);
//! # Ok::<(), soig::Error>(())
//! ```
//!
//! `examples/render_one.rs` builds its campaign in code; [`run`] writes a whole campaign with a
//! [`Progress`] callback of the caller's.

// The layers below, re-exported: `soig::rng`, `soig::sky`, ... name the same modules as before.
pub use soig_base::{build_id, hash, input_file, progress, python, rng};
pub use soig_sky as sky;
pub use soig_image::{enhance, fits, frames, geometry, hint, imaging, psf};
pub use soig_detect::{self as detect, metrics};
pub use soig_sim::{background, noise, render, scene, sensor, sighting, simulate};

pub use artifacts::{Provenance, provenance_cards};
pub use campaign::{Campaign, CampaignError};
pub use error::{Error, Result};
pub use manifest::{Manifest, verify};
pub use pipeline::{RunOptions, RunSummary, run, run_with, train};
pub use progress::{Progress, Silent};
pub use sensor::Sensor;
pub use simulate::{Experiment, ImageProducts};
// The store's modules under their old paths: `soig::output`, `soig::manifest`, ...
pub use store::{disk, journal, manifest, output};

pub(crate) mod artifacts;
pub mod campaign;
pub mod collect;
pub mod compare;
pub mod convert;
pub mod dataset;
pub mod detect_frames;
pub mod error;
pub mod experiment;
pub mod export;
pub mod launch;
pub mod light_curve;
pub mod merge;
pub mod pipeline;
pub(crate) mod plot;
pub mod report;
pub mod shard;
pub mod star_trails;
pub mod store;
pub mod study;
pub mod summary;
pub mod sweep;
pub mod tables;
pub(crate) mod train;
