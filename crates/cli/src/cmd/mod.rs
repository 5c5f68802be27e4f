//! One module per subcommand group.

pub mod colmap;
pub mod demo;
pub mod depth;
pub mod forest;
pub mod labelgen;
pub mod mesh;
pub mod mission;
pub mod mvs;
pub mod plan;
pub mod render;
pub mod scene;

use vp_mission::MissionError;
use vp_scene::SceneError;
use vp_sim::SimError;

/// Exit code for an error: 2 when the user's input is at fault (bad file,
/// bad argument, refusing to overwrite, missing file, bad URL), 1 otherwise
/// (I/O failures, a vehicle that does not answer or rejects the mission).
pub fn exit_code(e: &anyhow::Error) -> u8 {
    for cause in e.chain() {
        if let Some(me) = cause.downcast_ref::<vp_mvs::MvsError>() {
            return match me {
                vp_mvs::MvsError::Scene(se) => scene_exit_code(se),
                _ if me.is_input_error() => 2,
                _ => 1,
            };
        }
        if let Some(le) = cause.downcast_ref::<vp_labelgen::LabelgenError>() {
            return if le.is_input_error() { 2 } else { 1 };
        }
        if let Some(fe) = cause.downcast_ref::<vp_forest::ForestError>() {
            return match fe {
                vp_forest::ForestError::Scene(se) => scene_exit_code(se),
                _ => 2,
            };
        }
        if let Some(pe) = cause.downcast_ref::<vp_planner::PlannerError>() {
            return if pe.is_input_error() { 2 } else { 1 };
        }
        if let Some(se) = cause.downcast_ref::<SceneError>() {
            return scene_exit_code(se);
        }
        if let Some(me) = cause.downcast_ref::<MissionError>() {
            return match me {
                MissionError::Scene(se) => scene_exit_code(se),
                MissionError::InvalidInput(_) | MissionError::BadUrl { .. } => 2,
                _ => 1,
            };
        }
        // SimError::Scene is transparent: the chain skips the SceneError inside.
        if let Some(se) = cause.downcast_ref::<SimError>() {
            return match se {
                SimError::Scene(se) => scene_exit_code(se),
                _ if se.is_input_error() => 2,
                _ => 1,
            };
        }
        if let Some(fe) = cause.downcast_ref::<vp_forest::ForestError>() {
            return match fe {
                vp_forest::ForestError::Scene(se) => scene_exit_code(se),
                _ => 2,
            };
        }
    }
    1
}

fn scene_exit_code(e: &SceneError) -> u8 {
    match e {
        SceneError::Io { source, .. } if source.kind() != std::io::ErrorKind::NotFound => 1,
        _ => 2,
    }
}
