//! The verbs: what each command of `soig` does, over the config, product, report and store
//! layers. Nothing below imports a verb.

pub mod compare;
pub mod convert;
pub mod detect_frames;
pub(crate) mod detect_stage;
pub mod launch;
pub mod merge;
pub mod pipeline;
pub mod plan;
pub mod study;
pub mod summary;
pub mod sweep;
pub mod tables;
pub(crate) mod train;
