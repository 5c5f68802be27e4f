//! One module per subcommand group.

pub mod colmap;
pub mod depth;
pub mod mesh;
pub mod render;
pub mod scene;

use vp_scene::SceneError;
use vp_sim::SimError;

/// Exit code for an error: 2 when the user's input is at fault (bad file,
/// bad argument, refusing to overwrite, missing file), 1 otherwise.
pub fn exit_code(e: &anyhow::Error) -> u8 {
    let scene_code = |se: &SceneError| match se {
        SceneError::Io { source, .. } if source.kind() != std::io::ErrorKind::NotFound => 1,
        _ => 2,
    };
    for cause in e.chain() {
        if let Some(se) = cause.downcast_ref::<SceneError>() {
            return scene_code(se);
        }
        // SimError::Scene is transparent: the chain skips the SceneError inside.
        match cause.downcast_ref::<SimError>() {
            Some(SimError::InvalidArgument(_)) => return 2,
            Some(SimError::Scene(se)) => return scene_code(se),
            None => {}
        }
    }
    1
}
