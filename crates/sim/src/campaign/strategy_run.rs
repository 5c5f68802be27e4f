//! One triplet strategy on one site: plan from what is known, fly the
//! plan, check the flown path against the truth, reconstruct each triplet,
//! learn from it, repeat (split from `run.rs`, which runs the sites).

use std::collections::BTreeMap;

use nalgebra::Point3;
use vp_planner::{plan, AcquiredView, PlanInputs, RoiSpec, SafetyConfig};
use vp_scene::colmap::ModelFrame;
use vp_scene::plan::{Plan, Role};
use vp_scene::roi::Roi;
use vp_scene::sim3::Sim3;
use vp_scene::Camera;

use super::acquired::AcquiredModel;
use super::crash::PathCheck;
use super::images::acquire;
use super::reconstruct::Flown;
use super::seen::SfmState;
use super::site::{fly_with_error, image_id, name_hash, with_home, SiteRun, MESH_TOLERANCE_M};
use super::triplet_outcomes::{DepthErrorHistogram, TripletOutcome};
use crate::config::CampaignConfig;
use crate::config::Strategy;
use crate::error::{Result, SimError};
use crate::gnss::{aabb_through, camera_through, mesh_through};
use crate::sfm::sfm_cameras;
use crate::world::{Acquired, World};
use vp_scene::hash::mix64;

/// Everything one triplet strategy produced on one site.
pub(super) struct StrategyRun {
    pub(super) flown: Vec<Flown>,
    pub(super) plans: Vec<Plan>,
    /// What each iteration planned from (when artifacts are kept).
    pub(super) acquired: Vec<AcquiredModel>,
    /// The flown paths against the true mesh.
    pub(super) check: PathCheck,
    /// Every flown triplet's planned angle and outcome, in flight order.
    pub(super) outcomes: Vec<TripletOutcome>,
    /// The depth errors of the flown triplets' rock pixels (Fig. 6).
    pub(super) rock_errors: DepthErrorHistogram,
}

impl StrategyRun {
    /// Keeps flown triplet `t` of `plan` (iteration `iteration` of
    /// `strategy` on site `site`) with its outcome.
    fn record(
        &mut self,
        strategy: &str,
        (site, iteration): (u64, usize),
        (plan, t): (&Plan, u32),
        fl: Flown,
    ) {
        self.outcomes.push(TripletOutcome {
            strategy: strategy.to_string(),
            site,
            iteration,
            triplet: t,
            planned_angle_deg: planned_angle(plan, t),
            stats: fl.stats,
            success: fl.success,
        });
        self.rock_errors.merge(&fl.rock_errors);
        self.flown.push(fl);
    }
}

/// One progress line per triplet the planner left out, with its reason.
fn report_dropped(result: &vp_planner::PlanResult, progress: &mut dyn FnMut(&str)) {
    for (t, why) in result.dropped_triplets.iter().zip(&result.dropped_reasons) {
        progress(&format!("    dropped triplet {t}: {why}"));
    }
}

/// The angle bin centre (degrees) triplet `t` of `plan` was planned for.
fn planned_angle(plan: &Plan, t: u32) -> Option<f64> {
    plan.waypoints
        .iter()
        .find(|w| w.triplet_id == Some(t))
        .and_then(|w| w.angle_bin_deg)
}

/// One progress line per flown triplet: its planned angle bin and what came out.
fn triplet_line(plan: &Plan, t: u32, fl: &Flown, tolerance_m: f64) -> String {
    let bin = planned_angle(plan, t).unwrap_or(f64::NAN);
    let s = &fl.stats;
    format!(
        "    triplet {t} ({bin:.1} deg): {}; {} ROI px, depth at {:.0} %, within {:.2} m of the truth at {:.0} %",
        if fl.success { "output" } else { "nothing" },
        s.pixels,
        100.0 * s.output as f64 / s.pixels.max(1) as f64,
        tolerance_m,
        100.0 * s.measured_share(),
    )
}

/// A plan's cameras in flight order, and its triplets' cameras (indices
/// into them) by triplet id.
fn plan_cameras(world: &World, plan: &Plan) -> (Vec<Camera>, BTreeMap<u32, Vec<usize>>) {
    let mut triplets: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
    let mut cams = Vec::new();
    for w in &plan.waypoints {
        if let (Role::TripletMember, Some(t)) = (w.role, w.triplet_id) {
            triplets.entry(t).or_default().push(cams.len());
        }
        cams.push(w.to_camera(world.intrinsics));
    }
    (cams, triplets)
}

/// The seed of everything random in one triplet strategy on one site (the
/// planner, SfM's noise of its images, the matcher): it depends on the
/// strategy's shape (iterations x triplets), not on whether it predicts,
/// so F5x4 and NP5x4 differ only in the prediction.
pub(super) fn strategy_seed(cfg_seed: u64, site_seed: u64, strategy: &Strategy) -> u64 {
    let shape = format!("{}x{}", strategy.iterations, strategy.per_iteration);
    mix64(cfg_seed ^ mix64(site_seed) ^ name_hash(&shape))
}

/// What the flights so far left: the acquired images and what SfM and
/// vp-mvs made of them.
#[derive(Clone)]
pub(super) struct Known {
    acquired: Vec<Acquired>,
    /// The image name of each of `acquired` (in the acquired models).
    names: Vec<String>,
    sfm: SfmState,
    /// Seed of the site's SfM model (its georeferencing error).
    sfm_seed: u64,
    /// The model's georeference: the similarity from the true world into
    /// the model's frame, as `colmap align` fitted it to the first
    /// flight's GNSS positions (what the planner sees is in that frame).
    georef: Sim3,
    /// RMS residual of that alignment, metres.
    alignment_rms_m: f64,
}

impl Known {
    /// What SfM and vp-mvs know after the flight of `acquired`, reconstructed as `flown`.
    pub(super) fn new(
        world: &World,
        cfg: &CampaignConfig,
        acquired: Vec<Acquired>,
        flown: &[Flown],
        sfm_seed: u64,
        (georef, alignment_rms_m): (Sim3, f64),
    ) -> Self {
        let mut sfm = SfmState::new(world);
        sfm.add_images(world, &acquired);
        sfm.add_fused(flown, cfg.sfm.dense_spacing_m);
        let names = (0..acquired.len())
            .map(|i| format!("init_{i:04}.png"))
            .collect();
        Known {
            acquired,
            names,
            sfm,
            sfm_seed,
            georef,
            alignment_rms_m,
        }
    }

    /// What is known as the report shows it: the COLMAP model of the
    /// acquired images, their confidence if the strategy plans with
    /// `prediction` (the initial images have one for every strategy),
    /// `mesh` (planned on) and the ROI.
    fn model(
        &self,
        world: &World,
        cfg: &CampaignConfig,
        mesh: &vp_scene::Mesh,
        prediction: bool,
    ) -> Result<AcquiredModel> {
        let views: Vec<(String, Camera)> = self
            .names
            .iter()
            .cloned()
            .zip(self.acquired.iter().map(|a| a.sfm))
            .collect();
        Ok(AcquiredModel {
            model: self.sfm.colmap_model(cfg, &views)?,
            frame: ModelFrame {
                home: Some(world.home()),
                gnss: Some(cfg.flight_error.gnss),
                ..ModelFrame::identity(world.site.origin)
            },
            confidence: self
                .names
                .iter()
                .zip(&self.acquired)
                .filter(|_| prediction)
                .filter_map(|(n, a)| a.confidence.clone().map(|c| (n.clone(), c)))
                .collect(),
            mesh: mesh.clone(),
            roi: world.roi,
        })
    }
}

/// Plans iteration `it` of `strategy` from what is known.
fn plan_iteration(
    world: &World,
    cfg: &CampaignConfig,
    strategy: &Strategy,
    known: &Known,
    it: usize,
    base: u64,
) -> Result<(vp_planner::PlanResult, vp_scene::Mesh)> {
    // The planner sees the model in its georeferenced frame.
    let g = &known.georef;
    let seen = if cfg.flight_error.plan_on_true_surface {
        world.site.mesh.clone()
    } else {
        known.sfm.planning_mesh(cfg)?
    };
    let mesh = mesh_through(g, &seen);
    let views: Vec<AcquiredView> = known
        .acquired
        .iter()
        .map(|a| AcquiredView {
            camera: camera_through(g, &a.sfm),
            confidence: if strategy.prediction {
                a.confidence.clone()
            } else {
                None
            },
        })
        .collect();
    let mut pc = cfg.planner.clone();
    pc.n_triplets = strategy.per_iteration;
    pc.seed = mix64(base ^ 0x706c_616e ^ it as u64);
    if cfg.flight_error.position_margin {
        // What `plan_from_model` takes from the model's frame.json.
        pc.safety.alignment_rms_m = Some(known.alignment_rms_m);
        pc.safety.model_gnss = Some(cfg.flight_error.gnss);
    } else {
        pc.safety = SafetyConfig::exact();
    }
    let observations: Vec<_> = known
        .sfm
        .observations(cfg)
        .into_iter()
        .map(|(c, p)| (g.apply(&c), g.apply(&p)))
        .collect();
    let inputs = PlanInputs {
        mesh: &mesh,
        acquired: &views,
        // The region as drawn on the georeferenced model (the truth's box
        // would sit off the model by the georeference error).
        roi: RoiSpec::Region(Roi::from_aabb(&aabb_through(g, &world.roi))),
        config: &pc,
        origin: Some(world.site.origin),
        observations: Some(&observations),
        home: None,
    };
    let result = plan(&inputs).map_err(|e| {
        SimError::Campaign(format!(
            "site {}, {} iteration {}: {e}",
            world.site.params.seed,
            strategy.name,
            it + 1
        ))
    })?;
    Ok((result, seen))
}

/// Runs one triplet strategy from the initial flight.
pub(super) fn run_strategy(
    site: &mut SiteRun<'_>,
    strategy: &Strategy,
    source: u64,
    init: &Known,
    keep_artifacts: bool,
) -> Result<StrategyRun> {
    let (world, matcher, cfg, forest) = (site.world, site.matcher, site.cfg, site.forest);
    let site_seed = world.site.params.seed;
    let base = strategy_seed(cfg.seed, site_seed, strategy);
    let mut known = init.clone();
    let mut out = StrategyRun {
        flown: Vec::new(),
        plans: Vec::new(),
        acquired: Vec::new(),
        check: PathCheck::default(),
        outcomes: Vec::new(),
        rock_errors: DepthErrorHistogram::default(),
    };
    // Where the vehicle is: the end of the initial flight, then of each plan.
    let mut vehicle = init.acquired.last().map(|a| a.truth.center());
    let mut next_index = 0usize;
    for it in 0..strategy.iterations {
        let (result, mesh) = plan_iteration(world, cfg, strategy, &known, it, base)?;
        if keep_artifacts {
            out.acquired
                .push(known.model(world, cfg, &mesh, strategy.prediction)?);
        }
        let q = known.sfm.mesh_quality(world, cfg, &mesh, MESH_TOLERANCE_M);
        (site.progress)(&format!(
            "  site {site_seed} {} iteration {}: planning mesh of {} faces, {:.2} m mean ({:.2} m 95th pct) from the truth, {:.0} % of the surface within {MESH_TOLERANCE_M} m, {} under canopies; {} dense points, {:.1} % farther than {MESH_TOLERANCE_M} m",
            strategy.name,
            it + 1,
            mesh.n_faces(),
            q.mean_distance_m,
            q.p95_distance_m,
            100.0 * q.completeness,
            q.under_canopy_completeness
                .map_or("nothing".to_string(), |c| format!("{:.0} %", 100.0 * c)),
            q.dense_points,
            100.0 * q.dense_outlier_share,
        ));
        let (planned, triplets) = plan_cameras(world, &result.plan);
        // Flown with the vehicle's position error: the true cameras and path.
        let (new_cams, _) = fly_with_error(cfg, &planned, base ^ 0x666c_7974 ^ it as u64);
        let path: Vec<Point3<f64>> = new_cams.iter().map(Camera::center).collect();
        let label = format!("site {site_seed} {} iteration {}", strategy.name, it + 1);
        site.check_path(&mut out.check, (vehicle, &path), &label);
        vehicle = path.last().copied().or(vehicle);
        let first_flown = out.flown.len();
        // SfM's estimates of the new images: the poses they are matched
        // with now and planned with in the next iteration.
        let new_sfm = sfm_cameras(&new_cams, cfg, known.sfm_seed);
        // The triplets' shots are kept for acquiring the images after
        // (`acquire` finds them and renders only the bridges); after the
        // last iteration nothing is acquired, so nothing is kept.
        let last = it + 1 == strategy.iterations;
        for (t, members) in &triplets {
            let &[a, b, c] = members.as_slice() else {
                continue;
            };
            let i = next_index;
            next_index += 3;
            let ids = [i, i + 1, i + 2].map(|k| image_id(source, k));
            let fl = matcher.fly_triplet(
                &mut site.renders,
                (
                    [new_cams[a], new_cams[b], new_cams[c]],
                    [new_sfm[a], new_sfm[b], new_sfm[c]],
                ),
                ids,
                &world.roi,
                mix64(base ^ mix64(i as u64)),
                site.curves,
            )?;
            if last {
                site.renders.clear();
            }
            let tol = cfg.eval.depth_tolerance_m;
            (site.progress)(&triplet_line(&result.plan, *t, &fl, tol));
            out.record(&strategy.name, (site_seed, it + 1), (&result.plan, *t), fl);
        }
        (site.progress)(&format!(
            "  site {site_seed} {} iteration {}/{}: {} triplets planned ({} images with bridges, {} dropped as unreachable), {} of {} flown so far succeeded",
            strategy.name,
            it + 1,
            strategy.iterations,
            triplets.len(),
            new_cams.len(),
            result.dropped_triplets.len(),
            out.flown.iter().filter(|f| f.success).count(),
            out.flown.len()
        ));
        report_dropped(&result, site.progress);
        out.plans.push(with_home(result.plan, world));
        if !last {
            let pred = strategy.prediction.then_some(forest);
            let (cams, sfm) = (new_cams.as_slice(), new_sfm.as_slice());
            let new = acquire(&mut site.renders, (cams, sfm), pred, cfg, site.curves)?;
            site.renders.clear();
            known.sfm.add_images(world, &new);
            known
                .names
                .extend((0..new.len()).map(|j| format!("iter{}_{j:04}.png", it + 1)));
            known
                .sfm
                .add_fused(&out.flown[first_flown..], cfg.sfm.dense_spacing_m);
            known.acquired.extend(new);
        }
        if triplets.is_empty() {
            break;
        }
    }
    Ok(out)
}
