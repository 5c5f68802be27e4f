//! The one error type of `vp-labelgen`.

use std::path::PathBuf;

use vp_scene::SceneError;

/// Errors of `vp-labelgen`.
#[derive(Debug, thiserror::Error)]
pub enum LabelgenError {
    /// A file could not be read, parsed or written (names the file and place).
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// An input file is readable but does not fit the rest of the input: a
    /// depth map of the wrong size, for an image the model does not know, with
    /// NaN or negative depths, a triplet naming an unknown image, ...
    #[error("{}: {message}", path.display())]
    Input {
        /// The file at fault.
        path: PathBuf,
        /// What is wrong, in words a user understands.
        message: String,
    },
    /// A parameter or an in-memory input is outside its valid range.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
}

impl LabelgenError {
    /// Shorthand for [`LabelgenError::Input`].
    pub fn input(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        LabelgenError::Input {
            path: path.into(),
            message: message.into(),
        }
    }

    /// Whether the user's input is at fault (as opposed to a failure of the
    /// machine, e.g. a disk error): the CLI exits with 2 for these.
    pub fn is_input_error(&self) -> bool {
        match self {
            LabelgenError::Scene(e) => e.is_input_error(),
            _ => true,
        }
    }
}

/// Result alias of `vp-labelgen`.
pub type Result<T, E = LabelgenError> = std::result::Result<T, E>;
