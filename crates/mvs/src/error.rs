//! The one error type of `vp-mvs`.

use std::path::PathBuf;

use vp_scene::SceneError;

/// Errors of `vp-mvs`.
#[derive(Debug, thiserror::Error)]
pub enum MvsError {
    /// Reading the sparse model or writing an output file failed.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// An input file exists but cannot be used: an unreadable image, an
    /// image whose size differs from its camera, a distorted camera model, a
    /// malformed `patch-match.cfg`.
    #[error("{}: {message}", path.display())]
    Input {
        /// The file at fault.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
    /// A parameter or a request that cannot be served (bad depth range,
    /// fewer than two images, an unknown image name).
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// A config file does not parse.
    #[error("{}: {message}", path.display())]
    Config {
        /// The config file.
        path: PathBuf,
        /// The TOML error.
        message: String,
    },
    /// Creating an output directory failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The directory or file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}

impl MvsError {
    /// Whether the user's input is at fault (exit code 2 in the CLI) rather
    /// than the machine (an I/O failure while writing).
    pub fn is_input_error(&self) -> bool {
        match self {
            MvsError::Scene(e) => e.is_input_error(),
            MvsError::Io { source, .. } => source.kind() == std::io::ErrorKind::NotFound,
            _ => true,
        }
    }
}

/// Result alias of `vp-mvs`.
pub type Result<T, E = MvsError> = std::result::Result<T, E>;
