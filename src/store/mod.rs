//! The store: the rules of soig's output safety, and the only code that writes files.

pub mod disk;
pub mod fs;
pub mod journal;
pub mod manifest;
pub mod output;
