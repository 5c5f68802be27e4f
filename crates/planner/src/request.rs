//! The front door for planning a mission from an acquired model: the one
//! library entry `vpctl plan` and the Python `vpctl.planner.plan` both call,
//! so that the same model plans the same way from a notebook and from the
//! command line (the frame check, the free space carved by the model's
//! tracks, the take-off point).
//!
//! [`plan_from_model`] reads the model (a COLMAP folder or an OpenSfM
//! reconstruction, [`ModelSource`]), checks its frame (COLMAP's
//! `frame.json`, OpenSfM's geodetic reference; unless told the model is
//! already metric, gravity-aligned ENU), reads the
//! confidence images, turns the tracks into observation rays, plans (M1-M4)
//! and records the vertical datum and the home in the plan. [`resolve_home`]
//! is the take-off rule shared with `plan grid`. [`PlanOutputs::write`]
//! writes the plan and its views with the rollback the CLI relies on.

use std::path::{Path, PathBuf};

use nalgebra::{Point3, Vector3};
use vp_scene::colmap::FrameCheck;
use vp_scene::geodesy::LocalFrame;
use vp_scene::opensfm::ModelSource;
use vp_scene::plan::{GeodeticOrigin, Home, Plan, VerticalDatum};
use vp_scene::raycast::RayCaster;
use vp_scene::{Camera, Mesh};

use crate::error::{PlannerError, Result};
use crate::free_space::observations_from_model;
use crate::grid::GridParams;
use crate::inputs::{AcquiredView, PlanInputs, PlanResult, RoiSpec};
use crate::output::{write_frusta_ply, write_plan_glb, write_top_view_png, SceneView, TopView};
use crate::PlannerConfig;

/// Where the vehicle takes off.
#[derive(Debug, Clone, PartialEq)]
pub enum HomeSpec {
    /// Not given: the plan records no home, and a mission cannot be
    /// exported from it until one is given (`mission export --home`).
    Unset,
    /// A position (`--home LAT,LON,ALT[,DATUM]`); without a datum, the
    /// altitude is in the plan's own datum.
    At {
        /// Latitude, longitude, altitude.
        position: GeodeticOrigin,
        /// What the altitude is measured from, if said.
        datum: Option<VerticalDatum>,
    },
    /// The first image's (by name) projection centre, dropped along gravity
    /// onto the mesh: the operator launched under the first photo.
    FirstImage,
}

/// A planning job on an acquired model, as `vpctl plan` takes it.
pub struct ModelPlanRequest<'a> {
    /// The planning mesh, in the model's frame.
    pub mesh: &'a Mesh,
    /// The model: a COLMAP folder (text or binary) with `frame.json`, or
    /// an OpenSfM reconstruction with its geodetic reference.
    pub model: &'a ModelSource,
    /// Confidence images (`<image>.vpconf`); `None` plans without prediction (NP).
    pub confidence_dir: Option<&'a Path>,
    /// Planner parameters.
    pub config: &'a PlannerConfig,
    /// Region of interest.
    pub roi: RoiSpec,
    /// A geodetic origin that overrides `frame.json`'s, with its datum.
    pub origin: Option<(GeodeticOrigin, Option<VerticalDatum>)>,
    /// The take-off point.
    pub home: HomeSpec,
    /// Skip the frame check: the model is already metric, gravity-aligned
    /// local ENU (then the origin comes only from `origin`).
    pub frame_unchecked: bool,
}

/// What [`plan_from_model`] produced.
pub struct ModelPlan {
    /// The planner's result; `result.plan` carries the datum and the home.
    pub result: PlanResult,
    /// The acquired views planned from (cameras and confidence).
    pub acquired: Vec<AcquiredView>,
    /// The frame check, when it ran.
    pub frame: Option<FrameCheck>,
    /// The clearance planned with and where it comes from
    /// ([`PlannerConfig::clearance_line`]), the alignment residual of the
    /// model's frame included.
    pub clearance: String,
    /// The file the frame came from (`frame.json`, `reconstruction.json`,
    /// `reference_lla.json`).
    pub frame_file: PathBuf,
    /// What the model's reader wants the user to know.
    pub notes: Vec<String>,
}

/// Plans the next triplets from an acquired model (see the module doc).
/// Errors name the model, the frame file or the confidence file at fault.
pub fn plan_from_model(req: &ModelPlanRequest) -> Result<ModelPlan> {
    let posed = req.model.read_posed(req.frame_unchecked)?;
    let (rec, frame) = (posed.reconstruction, posed.frame);
    if let Some(dir) = req.confidence_dir {
        check_confidence_dir(dir)?;
    }
    let acquired = crate::acquired_from_model(&rec, req.confidence_dir)?;
    let observations = observations_from_model(&rec)?;
    let (origin, datum) = match (req.origin, &frame) {
        (Some((o, d)), _) => (Some(o), d),
        (None, Some(f)) => (Some(f.frame.origin), f.frame.vertical_datum),
        (None, None) => (None, None),
    };
    let first_image = rec
        .images
        .iter()
        .min_by(|a, b| a.1.name.cmp(&b.1.name))
        .map(|(&id, im)| (im.name.clone(), id));
    let first_center = match &first_image {
        Some((name, id)) => Some((name.clone(), rec.camera_of(*id)?.center())),
        None => None,
    };
    let frame_home = frame.as_ref().and_then(|f| f.frame.home.clone());
    let home = match (&req.home, frame_home) {
        // The frame's own take-off point, unless --origin moved the frame.
        (HomeSpec::Unset, Some(h)) if req.origin.is_none() => Some(h),
        (spec, _) => resolve_home(
            req.mesh,
            origin,
            datum,
            spec,
            first_center.as_ref().map(|(n, c)| (n.as_str(), *c)),
        )?,
    };
    // The model's alignment residual joins the position margin.
    let mut config = req.config.clone();
    config.safety.alignment_rms_m = frame.as_ref().map(|f| f.frame.rms_m);
    config.safety.model_gnss = frame.as_ref().and_then(|f| f.frame.gnss);
    let clearance = config.clearance_line();
    let result = crate::plan(&PlanInputs {
        mesh: req.mesh,
        acquired: &acquired,
        roi: req.roi.clone(),
        config: &config,
        origin,
        // A model without tracks: the planner carves from rays to the mesh.
        observations: (!observations.is_empty()).then_some(&observations[..]),
        home: home_enu(origin, home.as_ref())?,
    });
    let mut result = refuse_if_uncertain(result, &config)?;
    result.plan.vertical_datum = datum;
    result.plan.home = home;
    Ok(ModelPlan {
        result,
        acquired,
        frame,
        clearance,
        frame_file: posed.frame_file,
        notes: posed.notes,
    })
}

/// A refusal, or a plan whose every triplet was dropped as unsafe or
/// unreachable, while the position margin is part of the clearance: an
/// input error (exit 2) that gives the numbers and what would lower them.
fn refuse_if_uncertain(result: Result<PlanResult>, config: &PlannerConfig) -> Result<PlanResult> {
    let position = config.safety.position_margin_m();
    let why = match &result {
        Err(PlannerError::Refused(m)) => m.clone(),
        Ok(r) if r.plan.waypoints.is_empty() && !r.dropped_triplets.is_empty() => format!(
            "all {} triplets were dropped: {}",
            r.dropped_triplets.len(),
            r.dropped_reasons.join("; ")
        ),
        _ => return result,
    };
    if position <= 0.0 {
        return result;
    }
    Err(PlannerError::Input(format!(
        "no safe plan with the position uncertainty: {}, of which {position:.2} m is the \
         position margin; {why}. A more precise position (`[safety] gnss = \"rtk\"` in the \
         planner config, with a model aligned to RTK positions) or a smaller safety_distance_m \
         lowers it",
        config.clearance_line()
    )))
}

/// A grid flight job, as `vpctl plan grid` takes it.
pub struct GridRequest<'a> {
    /// The mesh to fly over.
    pub mesh: &'a Mesh,
    /// Region of interest.
    pub roi: &'a RoiSpec,
    /// The grid's height or GSD, overlaps and angles.
    pub params: &'a GridParams,
    /// Planner parameters (camera, safety).
    pub config: &'a PlannerConfig,
    /// Geodetic origin of the mesh's frame, with its datum.
    pub origin: Option<(GeodeticOrigin, Option<VerticalDatum>)>,
    /// The take-off point ([`HomeSpec::FirstImage`] is refused: a grid has
    /// no acquired images).
    pub home: HomeSpec,
}

/// The grid flight of `req`, with its datum and home recorded (the one
/// entry `vpctl plan grid` and Python's `plan_grid` call).
pub fn plan_grid_job(req: &GridRequest) -> Result<Plan> {
    let (origin, datum) = match req.origin {
        Some((o, d)) => (Some(o), d),
        None => (None, None),
    };
    let home = resolve_home(req.mesh, origin, datum, &req.home, None)?;
    let mut plan = crate::plan_grid(
        req.mesh,
        req.roi,
        req.params,
        req.config,
        origin,
        home_enu(origin, home.as_ref())?.as_ref(),
    )?;
    plan.vertical_datum = datum;
    plan.home = home;
    Ok(plan)
}

/// The take-off point of a plan with geodetic `origin` in `datum`, from
/// `spec`. `first_image` is the first image's name and projection centre
/// (ENU), for [`HomeSpec::FirstImage`]. The home's altitude is in the
/// plan's datum; the first image's projection onto the mesh is refused when
/// no mesh lies below it.
pub fn resolve_home(
    mesh: &Mesh,
    origin: Option<GeodeticOrigin>,
    datum: Option<VerticalDatum>,
    spec: &HomeSpec,
    first_image: Option<(&str, Point3<f64>)>,
) -> Result<Option<Home>> {
    let need_origin = || {
        origin.ok_or_else(|| {
            PlannerError::Input(
                "a home needs the plan's geodetic origin: plan on a model aligned by `vpctl \
                 colmap align` (its frame.json), or pass --origin LAT,LON,ALT"
                    .into(),
            )
        })
    };
    match spec {
        HomeSpec::Unset => Ok(None),
        HomeSpec::At { position, datum: d } => {
            need_origin()?;
            Ok(Some(Home::in_datum(*position, *d, datum, "--home")?))
        }
        HomeSpec::FirstImage => {
            let origin = need_origin()?;
            let Some((name, c)) = first_image else {
                return Err(PlannerError::Input(
                    "--home-from-first-image: there is no acquired image to drop (a grid has \
                     none): give --home LAT,LON,ALT"
                        .into(),
                ));
            };
            let ground = ground_below(mesh, c).ok_or_else(|| {
                PlannerError::Input(format!(
                    "--home-from-first-image: no mesh surface below image {name} (at {:.1}, \
                     {:.1}, {:.1} m ENU): the mesh does not reach the take-off point; give \
                     --home LAT,LON,ALT instead",
                    c.x, c.y, c.z
                ))
            })?;
            let frame = LocalFrame::new(origin)?;
            let position = frame.to_geodetic([ground.x, ground.y, ground.z]);
            Ok(Some(Home {
                position,
                source: format!(
                    "first image {name} projected along gravity onto the mesh ({:.1} m below it)",
                    c.z - ground.z
                ),
            }))
        }
    }
}

/// Where `home` lies in the ENU frame of `origin` (both in the plan's datum).
pub fn home_enu(
    origin: Option<GeodeticOrigin>,
    home: Option<&Home>,
) -> Result<Option<Point3<f64>>> {
    match (origin, home) {
        (Some(o), Some(h)) => Ok(Some(Point3::from(LocalFrame::new(o)?.to_enu(h.position)))),
        _ => Ok(None),
    }
}

/// The highest mesh point straight below `p` (or above it, when `p` is
/// under the surface), `None` when the vertical line misses the mesh.
pub fn ground_below(mesh: &Mesh, p: Point3<f64>) -> Option<Point3<f64>> {
    let caster = RayCaster::new(mesh);
    let bounds = mesh.bounds();
    let top = bounds.max.z.max(p.z) + 1.0;
    let from = Point3::new(p.x, p.y, top);
    let reach = top - bounds.min.z.min(p.z) + 1.0;
    caster
        .closest_hit(&from, &-Vector3::z(), reach)
        .map(|h| h.point)
}

/// Refuses a confidence folder without any `.vpconf`, saying where they come from.
fn check_confidence_dir(dir: &Path) -> Result<()> {
    fn has_vpconf(dir: &Path, depth: usize) -> bool {
        std::fs::read_dir(dir).is_ok_and(|entries| {
            entries.flatten().any(|e| {
                let p = e.path();
                p.extension().is_some_and(|x| x == "vpconf")
                    || (depth < 8 && p.is_dir() && has_vpconf(&p, depth + 1))
            })
        })
    }
    let fix = format!(
        "run `vpctl predict --forest FOREST --out {} IMAGES` on the model's images first, or \
         leave the confidence folder out to plan without prediction (NP)",
        dir.display()
    );
    if !dir.is_dir() {
        return Err(PlannerError::Input(format!(
            "confidence folder {}: no such folder; {fix}",
            dir.display()
        )));
    }
    if !has_vpconf(dir, 0) {
        return Err(PlannerError::Input(format!(
            "confidence folder {}: no confidence images (.vpconf) in it; {fix}",
            dir.display()
        )));
    }
    Ok(())
}

/// Depth of the camera pyramids in the PLY and the GLB, metres.
const FRUSTUM_DEPTH_M: f64 = 2.0;
/// Longest side of the top view, pixels.
const TOP_VIEW_SIZE: u32 = 1024;

/// The files a planning job writes: the plan and, optionally, its views.
#[derive(Debug, Clone, Default)]
pub struct PlanOutputs {
    /// The plan (JSON).
    pub plan: PathBuf,
    /// The planned cameras as pyramids (PLY).
    pub ply: Option<PathBuf>,
    /// The top view (PNG).
    pub png: Option<PathBuf>,
    /// The 3D scene (glTF binary).
    pub glb: Option<PathBuf>,
    /// Overwrite existing files.
    pub force: bool,
}

/// What the views of a plan show besides the plan.
pub struct PlanContext<'a> {
    /// The planning mesh.
    pub mesh: &'a Mesh,
    /// The planner parameters (the camera of the frusta).
    pub config: &'a PlannerConfig,
    /// Sampled triangles' centroids with their f(t).
    pub fulfillment: &'a [(Point3<f64>, f64)],
    /// ROI outline corners (x, y).
    pub roi_outline: &'a [[f64; 2]],
    /// The cameras already acquired.
    pub acquired: &'a [Camera],
}

impl PlanOutputs {
    /// Writes the views first and the plan last; on a failure the files
    /// this call wrote are removed, so that no partial set is left.
    pub fn write(&self, plan: &Plan, ctx: &PlanContext) -> Result<()> {
        let mut written: Vec<&Path> = Vec::new();
        let intrinsics = ctx.config.camera.intrinsics();
        let result = (|| -> Result<()> {
            if let Some(p) = &self.ply {
                write_frusta_ply(p, plan, intrinsics, FRUSTUM_DEPTH_M, self.force)?;
                written.push(p);
            }
            if let Some(p) = &self.png {
                let view = TopView {
                    mesh: ctx.mesh,
                    fulfillment: ctx.fulfillment,
                    roi_outline: ctx.roi_outline,
                    plan,
                    acquired: ctx.acquired,
                    size: TOP_VIEW_SIZE,
                };
                write_top_view_png(p, &view, self.force)?;
                written.push(p);
            }
            if let Some(p) = &self.glb {
                let view = SceneView {
                    mesh: ctx.mesh,
                    acquired: ctx.acquired,
                    plans: &[("plan", plan)],
                    intrinsics,
                    frustum_depth: FRUSTUM_DEPTH_M,
                };
                write_plan_glb(p, &view, self.force)?;
                written.push(p);
            }
            plan.save(&self.plan, self.force)?;
            Ok(())
        })();
        if result.is_err() {
            for p in written {
                let _ = std::fs::remove_file(p);
            }
        }
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_refusal_under_position_uncertainty_is_an_input_error_with_the_numbers() {
        let mut cfg = PlannerConfig::default();
        cfg.safety.alignment_rms_m = Some(0.4);
        let e = refuse_if_uncertain(
            Err(PlannerError::Refused("segment 1 -> 2 blocked".into())),
            &cfg,
        )
        .err()
        .unwrap();
        let m = e.to_string();
        assert!(e.is_input_error(), "{m}");
        assert!(
            m.contains("clearance 17.8")
                && m.contains("safety 5.00")
                && m.contains("standard GNSS 1.5/3 m")
                && m.contains("alignment residual 0.40 m")
                && m.contains("segment 1 -> 2 blocked")
                && m.contains("gnss = \"rtk\""),
            "{m}"
        );
        // Without a position term the refusal stays what it was.
        cfg.safety = crate::SafetyConfig::exact();
        let e = refuse_if_uncertain(Err(PlannerError::Refused("x".into())), &cfg)
            .err()
            .unwrap();
        assert!(matches!(e, PlannerError::Refused(_)));
    }
}
