//! soig: a space optical image generator. A campaign file becomes a reproducible experiment:
//! scenes of space debris seen from a satellite, photon-mapped images, enhanced PNGs, an
//! Ultralytics dataset, detectors and their metrics, and a manifest hashing every artifact.
//!
//! # Layers
//!
//! The layers are the workspace's crates; each names only crates below it in its Cargo.toml, so
//! an upward import does not compile (docs/architecture.md draws the graph):
//!
//! ```text
//! soig (this crate)  verbs/: plan (what a run does, from the campaign, once) pipeline (run,
//!                           train) detect_stage merge study compare tables
//!                           sweep convert launch detect_frames summary; the CLI in src/bin/soig/
//!                    report/
//!                    product/: artifacts dataset collect export star_trails light_curve shard
//!                    config/: campaign (file, defaults, compose, validate, resolve) experiment
//!                    store/: fs (the file primitives: the only code that writes) output
//!                           (whole-or-nothing directories) journal (resume) manifest disk
//! soig-sim           scene sighting sensor noise background render simulate
//! soig-detect        streak yolo metrics               (sim and detect never see each other)
//! soig-image         imaging geometry fits frames enhance psf hint
//! soig-sky           orbit frames ephemeris apparent stars projection wcs photometry pointing motion
//! soig-base          rng hash progress build_id input_file python
//! ```
//!
//! The lower crates and this crate's folders are re-exported here under their module names
//! (`soig::sky`, `soig::render`, `soig::detect`, `soig::pipeline`, ...).
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
//! use soig::Campaign;
//!
//! let campaign = Campaign::load("campaigns/quickstart.toml".as_ref())?;
//! let experiment = soig::experiment::of(&campaign);
//! let inputs = soig::experiment::inputs(&campaign)?;
//! let image = soig::simulate::image(&experiment, &inputs, 0)?;
//! println!("{} at SNR {:.2}", image.exposure.truth.object, image.exposure.truth.seen.snr);
//! # Ok::<(), soig::Error>(())
//! ```
//!
//! `examples/render_one.rs` builds its campaign in code; [`run`] writes a whole campaign with a
//! [`Progress`] callback of the caller's.

// Unit tests write their fixtures with std::fs; everything the product writes goes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![cfg_attr(test, allow(clippy::disallowed_methods))]

// The layers below, re-exported: `soig::rng`, `soig::sky`, ... name the same modules as before.
pub use soig_base::{build_id, hash, input_file, progress, python, rng};
pub use soig_detect::{self as detect, metrics};
pub use soig_image::{enhance, fits, frames, geometry, hint, imaging, psf, streak_label};
pub use soig_sim::{atmosphere, background, noise, render, scene, sensor, sighting, simulate};
pub use soig_sky as sky;

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

pub mod config;
pub mod error;
pub(crate) mod plot;
pub mod product;
pub mod report;
pub mod store;
pub mod verbs;

// The top crate's modules under the paths they had before its folders: `soig::campaign`,
// `soig::pipeline`, ...
pub use config::{campaign, experiment, work};
pub(crate) use product::artifacts;
pub use product::{
    collect, dataset, export, light_curve, observations, population_omm, shard, star_trails,
    streak_labels, truth_sidecar,
};
pub use verbs::{
    compare, convert, detect_frames, launch, merge, pipeline, study, summary, sweep, tables,
};
pub(crate) use verbs::{detect_stage, train};
