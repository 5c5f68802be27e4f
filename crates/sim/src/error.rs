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
    /// An error from the forest (training, prediction, model files).
    #[error("forest: {0}")]
    Forest(#[from] vp_forest::ForestError),
    /// An error from the planner.
    #[error("planner: {0}")]
    Planner(#[from] vp_planner::PlannerError),
    /// An error from label generation.
    #[error("label generation: {0}")]
    Labelgen(#[from] vp_labelgen::LabelgenError),
    /// An error from vp-mvs.
    #[error("mvs: {0}")]
    Mvs(#[from] vp_mvs::MvsError),
    /// A campaign step failed (the message names the site, strategy and step).
    #[error("campaign: {0}")]
    Campaign(String),
    /// An error from the mission export.
    #[error("mission: {0}")]
    Mission(#[from] vp_mission::MissionError),
}

impl SimError {
    /// Whether the user's input (a config, a file, an argument) is at fault
    /// rather than the run: such errors exit with code 2 in `vpctl`.
    pub fn is_input_error(&self) -> bool {
        match self {
            SimError::Scene(e) => e.is_input_error(),
            SimError::InvalidArgument(_) => true,
            SimError::Forest(e) => e.is_input_error(),
            SimError::Mission(e) => e.is_input_error(),
            SimError::Planner(e) => e.is_input_error(),
            SimError::Labelgen(e) => e.is_input_error(),
            SimError::Mvs(e) => e.is_input_error(),
            SimError::Campaign(_) => false,
        }
    }
}

/// Result with [`SimError`].
pub type Result<T, E = SimError> = std::result::Result<T, E>;
