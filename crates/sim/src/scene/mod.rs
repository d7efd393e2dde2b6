//! The scene draw (paper 3.2.1-3.2.3): which debris, when, how long, where the sensor points,
//! which stars are in the field, and the visibility checks that reject a draw. The debris
//! object is drawn once per image, from its own stream, by the campaign's weights; a rejected
//! draw retries everything else for that object on the scene stream, so a rarely visible
//! object keeps its share of the images, and the accepted scene is a pure function of (scene
//! spec, sensor, inputs, seed, image index). With `Spec::objects` (several objects per frame,
//! or none) that scene only points the sensor, and each of the frame's objects is drawn and
//! placed in the field on its own streams (`place`; in a collect, the collect's streams, judged
//! on its first frame and followed through the others). The campaign file is never seen here: the
//! config layer (`experiment`) builds the values.
//!
//! - `spec`: the values a draw reads; `accepted`: the scene it gives; `rejection`: why not;
//! - `draw`: one image's draw and its retries; `place`: the extra objects of a frame;
//!   `object_draws`: which debris object and its tumble, for both;
//! - `catalogue`: a catalogue scene's objects where their orbits put them, and its stare;
//! - `pointing`: where the sensor points; `trajectory`: the debris path over the exposure;
//!   `visibility`: the checks and the signal-to-noise gate.

mod accepted;
mod catalogue;
mod draw;
mod object_draws;
mod place;
mod pointing;
mod rejection;
mod scintillation;
mod spec;
mod trajectory;
mod visibility;

pub use accepted::{
    CollectFrame, Exposure, Geometry, Object, Scene, TrajectorySample, Tumble, psf_of,
};
pub use catalogue::Unseen;
pub use draw::{choose_debris, draw};
pub use place::object_track_id;
pub use rejection::{NoScene, Rejection};
pub use soig_sky::pointing::{Pointing, SurveyTrack, TargetTrack};
pub use spec::{
    Body, CatalogueScene, Gate, Generated, Inputs, ObjectCount, PointingMode, SnrDefinition, Spec,
    StarField, TumbleRange, julian_year,
};
pub use trajectory::{
    MAX_SAMPLE_SPACING_PSF_SIGMAS, MAX_TRAJECTORY_SAMPLES, max_sample_spacing_px, sample_time_s,
    slice_count,
};
pub use visibility::{Snr, expected_snr};

/// Most objects an image may show (each is drawn, traced and labelled: the cost grows with it).
/// The campaign's validation refuses more.
pub const MAX_OBJECTS_PER_FRAME: u32 = 100;

/// Largest boresight drift over one survey exposure (the paper's is about 0.5 deg); the
/// campaign's resolution refuses more.
pub const MAX_SURVEY_DRIFT_DEG: f64 = 2.0;

/// WGS84 equatorial radius, km.
pub const EARTH_RADIUS_KM: f64 = 6378.137;
