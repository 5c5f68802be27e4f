//! Errors of `vp-planner`.

use vp_scene::SceneError;

/// Errors of planning.
#[derive(Debug, thiserror::Error)]
pub enum PlannerError {
    /// Reading or writing a file, or a scene-level check, failed.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A configuration value is out of range or a config file is malformed.
    #[error("config: {0}")]
    Config(String),
    /// The inputs cannot be planned for (empty region of interest, no camera
    /// sees it, no free space at the safety distance, ...).
    #[error("bad input: {0}")]
    Input(String),
    /// A safe flight path could not be found; names the segment at fault.
    #[error("plan refused: {0}")]
    Refused(String),
    /// Writing an output image failed.
    #[error("{path}: {message}")]
    Output {
        /// The file concerned.
        path: std::path::PathBuf,
        /// What went wrong.
        message: String,
    },
}

impl PlannerError {
    /// Whether the user's input is at fault (exit code 2 in `vpctl`).
    pub fn is_input_error(&self) -> bool {
        match self {
            PlannerError::Scene(e) => e.is_input_error(),
            PlannerError::Config(_) | PlannerError::Input(_) => true,
            PlannerError::Refused(_) | PlannerError::Output { .. } => false,
        }
    }
}

/// Result alias of `vp-planner`.
pub type Result<T> = std::result::Result<T, PlannerError>;
