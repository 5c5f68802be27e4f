//! The one error type of `vp-forest`.

use std::path::PathBuf;

use vp_scene::SceneError;

/// Errors of `vp-forest`.
#[derive(Debug, thiserror::Error)]
pub enum ForestError {
    /// Reading or writing a file, or a shared raster type, failed.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A model file is not a valid vp-forest model: wrong magic, unsupported
    /// format version, truncation, checksum mismatch or an inconsistent tree.
    #[error("{}: byte {offset}: {message}", path.display())]
    Model {
        /// The model file.
        path: PathBuf,
        /// Byte offset at which the problem was found.
        offset: u64,
        /// What is wrong.
        message: String,
    },
    /// Training parameters out of range.
    #[error("invalid training parameters: {0}")]
    InvalidParams(String),
    /// Inputs that cannot be used (mismatched sizes, missing classes, empty data).
    #[error("invalid input: {0}")]
    InvalidInput(String),
}

/// Result alias of `vp-forest`.
pub type Result<T, E = ForestError> = std::result::Result<T, E>;
