//! One module per subcommand group.

pub mod colmap;
pub mod depth;
pub mod mesh;
pub mod plan;
pub mod scene;

use vp_scene::SceneError;

/// Exit code for an error: 2 when the user's input is at fault (bad file,
/// bad argument, refusing to overwrite, missing file), 1 otherwise.
pub fn exit_code(e: &anyhow::Error) -> u8 {
    for cause in e.chain() {
        if let Some(pe) = cause.downcast_ref::<vp_planner::PlannerError>() {
            return if pe.is_input_error() { 2 } else { 1 };
        }
        if let Some(se) = cause.downcast_ref::<SceneError>() {
            return match se {
                SceneError::Io { source, .. } if source.kind() != std::io::ErrorKind::NotFound => 1,
                _ => 2,
            };
        }
    }
    1
}
