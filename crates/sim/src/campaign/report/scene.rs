//! `scene.glb` of the report: the first held-out site in 3D for any glTF
//! viewer — the true mesh by material, the initial flight as the acquired
//! cameras, and every strategy's planned views (all iterations) as frusta
//! with its flight path. Assembled by vp-planner's
//! [`plan_scene`](vp_planner::output::plan_scene), as `vpctl plan --glb`.

use std::path::Path;

use vp_planner::output::{write_plan_glb, SceneView};
use vp_scene::plan::Plan;
use vp_scene::Camera;

use super::results::CampaignReport;
use crate::error::Result;

/// Depth of the camera frusta, metres (as `vpctl plan`'s PLY and GLB).
const FRUSTUM_DEPTH_M: f64 = 2.0;

/// The strategy whose views are the acquired cameras.
const ACQUIRED: &str = "Init";

/// Writes `scene.glb` into `dir` when the report has site artifacts.
pub fn write_scene_glb(report: &CampaignReport, dir: &Path) -> Result<()> {
    let Some(a) = &report.artifacts else {
        return Ok(());
    };
    let k = report.config.planner.camera.intrinsics();
    let acquired: Vec<Camera> = a
        .strategies
        .iter()
        .filter(|s| s.name == ACQUIRED)
        .flat_map(|s| s.plans.iter().flat_map(|p| &p.waypoints))
        .map(|w| w.to_camera(k))
        .collect();
    // Each strategy's iterations as one plan: one path through all of them.
    let merged: Vec<(String, Plan)> = a
        .strategies
        .iter()
        .filter(|s| s.name != ACQUIRED && !s.plans.is_empty())
        .map(|s| {
            let mut all = Plan::new(None);
            for p in &s.plans {
                all.waypoints.extend(p.waypoints.iter().cloned());
            }
            (s.name.clone(), all)
        })
        .collect();
    let plans: Vec<(&str, &Plan)> = merged.iter().map(|(n, p)| (n.as_str(), p)).collect();
    let view = SceneView {
        mesh: &a.mesh,
        acquired: &acquired,
        plans: &plans,
        intrinsics: k,
        frustum_depth: FRUSTUM_DEPTH_M,
    };
    write_plan_glb(&dir.join("scene.glb"), &view, true)?;
    Ok(())
}
