//! The library's error type: what went wrong and with which input, so a program embedding
//! soig can tell a user's mistake (a campaign field, an input file) from a failed run.

use std::path::PathBuf;

use crate::background::FrameError;
use crate::campaign::CampaignError;
use crate::scene::NoScene;
use crate::sky::stars::CatalogError;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A campaign that does not parse or validate: file, line, field and what is allowed.
    #[error(transparent)]
    Campaign(#[from] CampaignError),
    /// A background frame that cannot be read or used, named with its path.
    #[error(transparent)]
    Frame(#[from] FrameError),
    /// An input file that cannot be read or is not what it must be (a manifest), named with
    /// its path.
    #[error("{}: {message}", path.display())]
    Input { path: PathBuf, message: String },
    /// A star catalogue that cannot be read or parsed (path and line).
    #[error(transparent)]
    Catalog(#[from] CatalogError),
    /// No acceptable scene for an image within the campaign's draw budget.
    #[error(transparent)]
    NoScene(#[from] NoScene),
    /// Anything else while running (writing outputs, training, detecting), with its context.
    #[error(transparent)]
    Run(anyhow::Error),
}

impl Error {
    pub(crate) fn input(path: impl Into<PathBuf>, message: impl std::fmt::Display) -> Error {
        Error::Input {
            path: path.into(),
            message: message.to_string(),
        }
    }
}

/// A run's error keeps its kind when it is one of ours.
impl From<anyhow::Error> for Error {
    fn from(e: anyhow::Error) -> Error {
        let e = match e.downcast::<Error>() {
            Ok(ours) => return ours,
            Err(e) => e,
        };
        let e = match e.downcast::<CampaignError>() {
            Ok(c) => return Error::Campaign(c),
            Err(e) => e,
        };
        match e.downcast::<NoScene>() {
            Ok(n) => Error::NoScene(n),
            Err(e) => Error::Run(e),
        }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
