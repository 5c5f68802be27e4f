//! The one error type of `vp-forest`.

use vp_scene::SceneError;

/// Errors of `vp-forest`.
#[derive(Debug, thiserror::Error)]
pub enum ForestError {
    /// Reading or writing a file failed, or a file is malformed: a model
    /// file with the wrong magic, an unsupported format version, truncation,
    /// a checksum mismatch or an inconsistent tree is a
    /// [`SceneError::Parse`] naming the byte.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// Training parameters out of range.
    #[error("invalid training parameters: {0}")]
    InvalidParams(String),
    /// Inputs that cannot be used (mismatched sizes, missing classes, empty data).
    #[error("invalid input: {0}")]
    InvalidInput(String),
}

impl ForestError {
    /// Whether the user's input is at fault (exit code 2 in `vpctl`): every
    /// error but an I/O failure on an existing file.
    pub fn is_input_error(&self) -> bool {
        match self {
            ForestError::Scene(e) => e.is_input_error(),
            ForestError::InvalidParams(_) | ForestError::InvalidInput(_) => true,
        }
    }
}

/// Result alias of `vp-forest`.
pub type Result<T, E = ForestError> = std::result::Result<T, E>;
