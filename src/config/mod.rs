//! The config layer: the campaign file (parsed, composed, validated, resolved and hashed) and
//! the values the simulator works on, built from it once (`experiment::of`), and what a run of
//! it will cost (`work`).

pub mod campaign;
pub mod experiment;
pub mod work;
