//! `vpctl plan grid`: a lawnmower grid flight over the region of interest.

use std::io::Write;

use anyhow::Result;
use vp_planner::grid::GridParams;
use vp_planner::GridRequest;
use vp_scene::plan::Role;

use super::model::{outline, write_outputs};
use super::summary;
use super::GridArgs;

pub(super) fn grid(g: &GridArgs, out: &mut dyn Write) -> Result<()> {
    let c = &g.common;
    let outputs = c.check_outputs()?;
    let cfg = c.config()?;
    let mesh = crate::cmd::read_mesh(&g.mesh)?;
    let roi = c.roi()?;
    let params = GridParams {
        height_m: g.height,
        gsd_m: g.gsd,
        front_overlap: g.overlap,
        side_overlap: g.side_overlap.unwrap_or(g.overlap),
        pitch_deg: g.pitch,
        yaw_deg: g.yaw,
        role: if g.initial { Role::Initial } else { Role::Grid },
    };
    let plan = vp_planner::plan_grid_job(&GridRequest {
        mesh: &mesh,
        roi: &roi,
        params: &params,
        config: &cfg,
        origin: c.origin()?.map(|o| (o, c.datum)),
        home: c.home(false),
    })?;
    let roi_outline = outline(
        &roi.resolve(&mesh, plan.origin)?,
        mesh.vertices.iter().copied(),
    );
    write_outputs(&outputs, &plan, &mesh, &cfg, &[], &roi_outline, &[])?;
    writeln!(out, "plan: {}", outputs.plan.display())?;
    writeln!(out, "waypoints: {}", plan.waypoints.len())?;
    writeln!(out, "{}", cfg.clearance_line())?;
    summary::print_grid_figures(&params.figures(cfg.camera.intrinsics()), out)?;
    summary::print_home(&plan, out)?;
    summary::print_flights(&plan, &cfg.mission, out)?;
    Ok(())
}
