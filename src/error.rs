//! The one error type. Every error names the file, prim path or parameter that caused it.

use std::path::PathBuf;

pub type Result<T, E = Error> = std::result::Result<T, E>;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The scene (or a USD stage) is malformed. `prim` is the prim path or scene object name.
    #[error("{file}: {prim}: {message}")]
    Scene {
        file: String,
        prim: String,
        message: String,
    },
    /// USD conversion failed (Python / usd-core missing, or the converter reported an error).
    #[error("{file}: {message}")]
    Usd { file: String, message: String },
    /// A parameter is out of range or inconsistent with another.
    #[error("invalid parameter {name}: {message}")]
    Param { name: String, message: String },
    /// Embree reported an error.
    #[error("embree: {0}")]
    Embree(String),
    /// Image reading / writing / comparison failed.
    #[error("{path}: {message}")]
    Image { path: String, message: String },
    /// A large buffer could not be allocated (the message names it and its size).
    #[error("out of memory: {0}")]
    OutOfMemory(String),
    /// The render was cancelled by the caller.
    #[error("render cancelled")]
    Cancelled,
}

impl Error {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io { path: path.into(), source }
    }
    pub fn scene(file: impl Into<String>, prim: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Scene { file: file.into(), prim: prim.into(), message: message.into() }
    }
    pub fn param(name: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Param { name: name.into(), message: message.into() }
    }
    pub fn image(path: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Image { path: path.into(), message: message.into() }
    }
}
