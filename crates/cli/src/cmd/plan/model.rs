//! `vpctl plan`: the next triplets from an acquired model (COLMAP or
//! OpenSfM), its mesh and confidence images.

use std::io::Write;

use anyhow::Result;
use nalgebra::Point3;
use vp_planner::{ModelPlanRequest, PlanContext, PlanOutputs, PlannerConfig, RoiSpec};
use vp_scene::opensfm::ModelSource;
use vp_scene::plan::{Plan, Role};
use vp_scene::roi::Roi;
use vp_scene::{Camera, Mesh};

use super::common::required;
use super::summary;
use super::PlanArgs;

/// ROI outline for the top view: the box or polygon, else the x/y bounds of `pts`.
pub(super) fn outline(roi: &RoiSpec, pts: impl Iterator<Item = Point3<f64>>) -> Vec<[f64; 2]> {
    match roi {
        RoiSpec::Region(Roi::Box { min, max }) => {
            vec![
                [min[0], min[1]],
                [max[0], min[1]],
                [max[0], max[1]],
                [min[0], max[1]],
            ]
        }
        RoiSpec::Region(Roi::Polygon { polygon, .. }) => polygon.clone(),
        _ => {
            let mut b = vp_scene::Aabb::empty();
            pts.for_each(|p| b.grow(&p));
            if b.min.x > b.max.x {
                return Vec::new();
            }
            vec![
                [b.min.x, b.min.y],
                [b.max.x, b.min.y],
                [b.max.x, b.max.y],
                [b.min.x, b.max.y],
            ]
        }
    }
}

impl PlanArgs {
    /// `--colmap DIR` or `--opensfm DIR`.
    pub(super) fn model(&self) -> ModelSource {
        self.model.source()
    }
}

pub(super) fn plan(args: &PlanArgs, out: &mut dyn Write) -> Result<()> {
    let c = &args.common;
    let outputs = c.check_outputs()?;
    let cfg = c.config()?;
    let mesh = crate::cmd::read_mesh(required(args.mesh.as_ref(), "--mesh")?)?;
    let model = args.model();
    let roi = c.roi()?;
    let job = vp_planner::plan_from_model(&ModelPlanRequest {
        mesh: &mesh,
        model: &model,
        confidence_dir: args.confidence_dir.as_deref(),
        config: &cfg,
        roi: roi.clone(),
        // --origin wins over the model's frame.json.
        origin: c.origin()?.map(|o| (o, c.datum)),
        home: c.home(args.home_from_first_image),
        frame_unchecked: args.frame_unchecked,
    })?;
    for note in &job.notes {
        eprintln!("note: {note}");
    }
    if let Some(check) = &job.frame {
        eprintln!(
            "frame: {} (origin {:.7},{:.7},{:.2}; cameras {:.2} m apart, median)",
            job.frame_file.display(),
            check.frame.origin.lat_deg,
            check.frame.origin.lon_deg,
            check.frame.origin.alt_m,
            check.median_spacing_m
        );
    }
    let r = &job.result;
    for it in &r.iterations {
        let times: Vec<String> = it
            .time_s
            .iter()
            .map(|(m, s)| format!("{m} {s:.3} s"))
            .collect();
        eprintln!(
            "triplet {}: mean f {:.4} -> {:.4}, coverage {:.3} ({})",
            it.iteration,
            it.f_before,
            it.f_after,
            it.coverage,
            times.join(", ")
        );
    }
    let mut plan = r.plan.clone();
    if args.no_timings {
        vp_planner::strip_timings(&mut plan);
    }
    let f: Vec<(Point3<f64>, f64)> = r.sampled.iter().map(|s| (s.centroid, s.f)).collect();
    let roi_outline = outline(
        &roi.resolve(&mesh, plan.origin)?,
        r.sampled.iter().map(|s| s.centroid),
    );
    let acquired: Vec<Camera> = job.acquired.iter().map(|v| v.camera).collect();
    write_outputs(&outputs, &plan, &mesh, &cfg, &f, &roi_outline, &acquired)?;
    let members = plan
        .waypoints
        .iter()
        .filter(|w| w.role == Role::TripletMember)
        .count();
    writeln!(out, "plan: {}", outputs.plan.display())?;
    writeln!(out, "{}", job.clearance)?;
    writeln!(
        out,
        "waypoints: {} ({members} triplet members, {} bridging)",
        plan.waypoints.len(),
        plan.waypoints.len() - members
    )?;
    summary::print_home(&plan, out)?;
    summary::print_flights(&plan, &cfg.mission, out)?;
    if let (Some(a), Some(b)) = (r.iterations.first(), r.iterations.last()) {
        writeln!(out, "mean f: {:.4} -> {:.4}", a.f_before, b.f_after)?;
    }
    if !r.dropped_triplets.is_empty() {
        writeln!(
            out,
            "dropped triplets (unsafe or unreachable): {:?}",
            r.dropped_triplets
        )?;
        for (t, why) in r.dropped_triplets.iter().zip(&r.dropped_reasons) {
            writeln!(out, "  triplet {t}: {why}")?;
        }
    }
    if plan.unbridged.is_empty() {
        writeln!(out, "unbridged views: none")?;
    } else {
        writeln!(
            out,
            "unbridged views: {:?} (waypoint indices: no bridge from the previous view keeps the \
             image overlap; listed in the plan as \"unbridged\")",
            plan.unbridged
        )?;
    }
    match &r.cut_short_reason {
        Some(why) => writeln!(out, "cut short: {why}")?,
        None => writeln!(out, "cut short: no")?,
    }
    Ok(())
}

/// The plan's views and the plan itself (`vp_planner::PlanOutputs`, which
/// removes what it wrote when a later file fails).
pub(super) fn write_outputs(
    outputs: &PlanOutputs,
    plan: &Plan,
    mesh: &Mesh,
    cfg: &PlannerConfig,
    f: &[(Point3<f64>, f64)],
    roi_outline: &[[f64; 2]],
    acquired: &[Camera],
) -> Result<()> {
    outputs.write(
        plan,
        &PlanContext {
            mesh,
            config: cfg,
            fulfillment: f,
            roi_outline,
            acquired,
        },
    )?;
    Ok(())
}
