//! The one error type of `vp-sim`.

use vp_scene::SceneError;

/// Errors of `vp-sim`.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A parameter or argument is out of range; the message names it and its value.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// An error from vp-scene (file IO, formats, geometry).
    #[error(transparent)]
    Scene(#[from] SceneError),
}

/// Result with [`SimError`].
pub type Result<T, E = SimError> = std::result::Result<T, E>;
