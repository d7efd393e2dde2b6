//! The config layer: the campaign file (parsed, composed, validated, resolved and hashed) and
//! the values the simulator works on, built from it once (`experiment::of`).

pub mod campaign;
pub mod experiment;
