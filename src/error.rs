//! The library's top-level error: what went wrong with one recording, and where.

use std::path::{Path, PathBuf};

use crate::avar::AvarError;
use crate::io::InputError;
use crate::psd::PsdError;
use crate::report::OutputError;

/// Why one recording could not be analysed, or its results not written.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Input(#[from] InputError),
    #[error("{path}: Welch PSD: {source}")]
    Psd { path: PathBuf, source: PsdError },
    #[error("{path}: column {channel:?}: Allan variance: {source}")]
    Avar {
        path: PathBuf,
        channel: String,
        source: AvarError,
    },
    #[error(transparent)]
    Output(#[from] OutputError),
}

impl Error {
    pub fn path(&self) -> &Path {
        match self {
            Error::Input(e) => e.path(),
            Error::Psd { path, .. } | Error::Avar { path, .. } => path,
            Error::Output(e) => &e.path,
        }
    }

    pub fn column(&self) -> Option<&str> {
        match self {
            Error::Input(e) => e.column(),
            Error::Avar { channel, .. } => Some(channel),
            _ => None,
        }
    }

    pub fn row(&self) -> Option<u64> {
        match self {
            Error::Input(e) => e.row(),
            _ => None,
        }
    }
}
