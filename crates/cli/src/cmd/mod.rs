//! One module per subcommand group.

pub mod colmap;
pub mod depth;
pub mod labelgen;
pub mod mesh;
pub mod scene;

use vp_scene::SceneError;

/// Exit code for an error: 2 when the user's input is at fault (bad file,
/// bad argument, refusing to overwrite, missing file), 1 otherwise.
pub fn exit_code(e: &anyhow::Error) -> u8 {
    for cause in e.chain() {
        if let Some(le) = cause.downcast_ref::<vp_labelgen::LabelgenError>() {
            return if le.is_input_error() { 2 } else { 1 };
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
