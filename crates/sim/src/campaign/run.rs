//! The campaign runner: per held-out site, the initial flight, the Grid
//! baseline and every triplet strategy, each evaluated on its own images.

use std::collections::BTreeMap;

use nalgebra::Point3;
use vp_forest::Forest;
use vp_planner::grid::{grid_views, GridParams};
use vp_planner::{plan, AcquiredView, PlanInputs, RoiSpec};
use vp_scene::colmap::ModelFrame;
use vp_scene::plan::{Plan, Role};
use vp_scene::roi::Roi;
use vp_scene::{Aabb, Camera};

use super::acquired::AcquiredModel;
use super::config::CampaignConfig;
use super::crash::PathCheck;
use super::curves::CurveAccumulator;
use super::eval::{evaluate, EvalMesh, Scores};
use super::fly::{Flown, Matcher, MvsKind};
use super::report::{aggregate, CampaignReport, SiteArtifacts, SiteResult, StrategyArtifacts};
use super::sfm::SfmState;
use super::strategies::Strategy;
use super::training::train_forest_with_stats;
use super::world::{acquire, init_cameras, sfm_cameras, Acquired, World};
use crate::error::{Result, SimError};
use crate::noise::mix64;

/// Source tags of image ids: init, grid, then one per strategy.
const SOURCE_INIT: u64 = 0;
const SOURCE_GRID: u64 = 1;
/// A true surface point counts as in the planning mesh within this, metres.
const MESH_TOLERANCE_M: f64 = 0.5;

fn image_id(source: u64, index: usize) -> u64 {
    source << 32 | index as u64
}

/// Hash of a name, for seeds.
fn name_hash(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    })
}

/// Flies a flight that is not a set of triplets (the initial images, the
/// Grid): checks its path (waypoints in order, from its first) against the
/// truth and reconstructs it with SfM's estimates `sfm` of its cameras:
/// with vp-mvs as the paper's Grid, every image against its best
/// overlapping neighbours; with the virtual MVS (triplets only), sliding
/// triplets (i, i+1, i+2) along the flight in order.
#[allow(clippy::too_many_arguments)]
fn fly_flight(
    world: &World,
    matcher: &Matcher<'_>,
    cfg: &CampaignConfig,
    (name, cams, sfm): (&str, &[Camera], &[Camera]),
    source: u64,
    seed: u64,
    curves: &mut CurveAccumulator,
    progress: &mut dyn FnMut(&str),
) -> Result<(Vec<Flown>, PathCheck)> {
    let mut check = PathCheck::default();
    let path: Vec<Point3<f64>> = cams.iter().map(Camera::center).collect();
    let label = format!("site {} {name}", world.site.params.seed);
    check_path(&mut check, world, cfg, (None, &path), &label, progress);
    let scene = world.scene();
    let ids: Vec<u64> = (0..cams.len()).map(|i| image_id(source, i)).collect();
    let flown = if cfg.mvs == MvsKind::Patchmatch {
        matcher.image_set(&scene, (cams, sfm), &ids, &world.roi, mix64(seed ^ source))?
    } else {
        (0..cams.len().saturating_sub(2))
            .map(|i| {
                matcher.fly_triplet(
                    &scene,
                    [cams[i], cams[i + 1], cams[i + 2]],
                    [sfm[i], sfm[i + 1], sfm[i + 2]],
                    [ids[i], ids[i + 1], ids[i + 2]],
                    &world.roi,
                    mix64(seed ^ mix64(source << 40 | i as u64)),
                    curves,
                )
            })
            .collect::<Result<Vec<_>>>()?
    };
    let tol = cfg.eval.depth_tolerance_m;
    let site = world.site.params.seed;
    progress(&flight_line(site, name, cams.len(), &flown, tol));
    Ok((flown, check))
}

/// The Grid baseline's cameras: nadir lawnmower over the ROI footprint plus margin.
fn grid_cameras(world: &World, cfg: &CampaignConfig) -> Result<Vec<Camera>> {
    let m = cfg.grid.margin_m;
    let fp = Aabb {
        min: Point3::new(
            world.roi.min.x - m,
            world.roi.min.y - m,
            world.ground_min_z(),
        ),
        max: Point3::new(
            world.roi.max.x + m,
            world.roi.max.y + m,
            world.ground_min_z(),
        ),
    };
    let params = GridParams {
        height_m: cfg.grid.height_m,
        gsd_m: None,
        front_overlap: cfg.grid.overlap,
        side_overlap: cfg.grid.overlap,
        pitch_deg: -90.0,
        yaw_deg: 0.0,
        role: Role::Grid,
    };
    let views = grid_views(&fp, &params, world.intrinsics)?;
    Ok(views
        .iter()
        .map(|v| v.to_camera(world.intrinsics))
        .collect())
}

/// A plan holding `cams` as views of `role` (for the report's missions).
fn plan_of(world: &World, cams: &[Camera], role: Role) -> Plan {
    let mut p = Plan::new(Some(world.site.origin));
    p.home = Some(world.home());
    p.waypoints = cams
        .iter()
        .map(|c| vp_scene::plan::PlannedView::from_camera(c, role))
        .collect();
    p
}

/// `plan` with the simulated take-off point as its home (the missions of
/// the report are exported from it).
fn with_home(plan: Plan, world: &World) -> Plan {
    Plan {
        home: Some(world.home()),
        ..plan
    }
}

/// Everything one triplet strategy produced on one site.
struct StrategyRun {
    flown: Vec<Flown>,
    plans: Vec<Plan>,
    /// What each iteration planned from (when artifacts are kept).
    acquired: Vec<AcquiredModel>,
    /// The flown paths against the true mesh.
    check: PathCheck,
}

/// One progress line per flown triplet: its planned angle bin and what came out.
/// One progress line per triplet the planner left out, with its reason.
fn report_dropped(result: &vp_planner::PlanResult, progress: &mut dyn FnMut(&str)) {
    for (t, why) in result.dropped_triplets.iter().zip(&result.dropped_reasons) {
        progress(&format!("    dropped triplet {t}: {why}"));
    }
}

fn triplet_line(plan: &Plan, t: u32, fl: &Flown, tolerance_m: f64) -> String {
    let bin = plan
        .waypoints
        .iter()
        .find(|w| w.triplet_id == Some(t))
        .and_then(|w| w.angle_bin_deg)
        .unwrap_or(f64::NAN);
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

/// One progress line for a flight reconstructed as a whole (Init, Grid).
fn flight_line(seed: u64, name: &str, images: usize, flown: &[Flown], tolerance_m: f64) -> String {
    let mut total = super::fly::OutputStats::default();
    for f in flown {
        total.pixels += f.stats.pixels;
        total.output += f.stats.output;
        total.measured += f.stats.measured;
    }
    format!(
        "  site {seed}: {name}: {images} images, {} of {} reconstructions with output; of their ROI pixels {:.0} % have depth, {:.0} % within {tolerance_m:.2} m of the truth",
        flown.iter().filter(|f| f.success).count(),
        flown.len(),
        100.0 * total.output as f64 / total.pixels.max(1) as f64,
        100.0 * total.measured_share(),
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
fn strategy_seed(cfg_seed: u64, site_seed: u64, strategy: &Strategy) -> u64 {
    let shape = format!("{}x{}", strategy.iterations, strategy.per_iteration);
    mix64(cfg_seed ^ mix64(site_seed) ^ name_hash(&shape))
}

/// What the flights so far left: the acquired images and what SfM and
/// vp-mvs made of them.
#[derive(Clone)]
struct Known {
    acquired: Vec<Acquired>,
    /// The image name of each of `acquired` (in the acquired models).
    names: Vec<String>,
    sfm: SfmState,
    /// Seed of the site's SfM model (its georeferencing error).
    sfm_seed: u64,
}

impl Known {
    /// What SfM and vp-mvs know after the flight of `acquired`, reconstructed as `flown`.
    fn new(
        world: &World,
        cfg: &CampaignConfig,
        acquired: Vec<Acquired>,
        flown: &[Flown],
        sfm_seed: u64,
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
    let mesh = known.sfm.planning_mesh(cfg)?;
    let views: Vec<AcquiredView> = known
        .acquired
        .iter()
        .map(|a| AcquiredView {
            camera: a.sfm,
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
    let observations = known.sfm.observations(cfg);
    let inputs = PlanInputs {
        mesh: &mesh,
        acquired: &views,
        roi: RoiSpec::Region(Roi::from_aabb(&world.roi)),
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
    Ok((result, mesh))
}

/// Checks a flown path against the truth and says every violation loudly.
fn check_path(
    check: &mut PathCheck,
    world: &World,
    cfg: &CampaignConfig,
    (start, path): (Option<Point3<f64>>, &[Point3<f64>]),
    label: &str,
    progress: &mut dyn FnMut(&str),
) {
    let before = check.violations.len();
    let safety_m = cfg.planner.safety_distance_m;
    check.add(&world.clearance, safety_m, start, path, label);
    for v in &check.violations[before..] {
        progress(&format!("  SAFETY VIOLATION against the true mesh: {v}"));
    }
}

/// Runs one triplet strategy from the initial flight.
#[allow(clippy::too_many_arguments)]
fn run_strategy(
    world: &World,
    matcher: &Matcher<'_>,
    forest: &Forest,
    cfg: &CampaignConfig,
    strategy: &Strategy,
    source: u64,
    init: &Known,
    keep_artifacts: bool,
    curves: &mut CurveAccumulator,
    progress: &mut dyn FnMut(&str),
) -> Result<StrategyRun> {
    let site_seed = world.site.params.seed;
    let base = strategy_seed(cfg.seed, site_seed, strategy);
    let mut known = init.clone();
    let mut out = StrategyRun {
        flown: Vec::new(),
        plans: Vec::new(),
        acquired: Vec::new(),
        check: PathCheck::default(),
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
        progress(&format!(
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
        let (new_cams, triplets) = plan_cameras(world, &result.plan);
        let path: Vec<Point3<f64>> = new_cams.iter().map(Camera::center).collect();
        let label = format!("site {site_seed} {} iteration {}", strategy.name, it + 1);
        check_path(
            &mut out.check,
            world,
            cfg,
            (vehicle, &path),
            &label,
            progress,
        );
        vehicle = path.last().copied().or(vehicle);
        let first_flown = out.flown.len();
        // SfM's estimates of the new images: the poses they are matched
        // with now and planned with in the next iteration.
        let new_sfm = sfm_cameras(&new_cams, cfg, known.sfm_seed);
        for (t, members) in &triplets {
            let &[a, b, c] = members.as_slice() else {
                continue;
            };
            let i = next_index;
            next_index += 3;
            let ids = [
                image_id(source, i),
                image_id(source, i + 1),
                image_id(source, i + 2),
            ];
            let fl = matcher.fly_triplet(
                &world.scene(),
                [new_cams[a], new_cams[b], new_cams[c]],
                [new_sfm[a], new_sfm[b], new_sfm[c]],
                ids,
                &world.roi,
                mix64(base ^ mix64(i as u64)),
                curves,
            )?;
            let tol = cfg.eval.depth_tolerance_m;
            progress(&triplet_line(&result.plan, *t, &fl, tol));
            out.flown.push(fl);
        }
        progress(&format!(
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
        report_dropped(&result, progress);
        out.plans.push(with_home(result.plan, world));
        let last = it + 1 == strategy.iterations;
        if !last {
            let pred = strategy.prediction.then_some(forest);
            let new = acquire(world, &new_cams, &new_sfm, pred, cfg, curves)?;
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

/// One progress line per strategy and site.
fn strategy_line(seed: u64, name: &str, s: &Scores) -> String {
    format!(
        "  site {seed} {name}: coverage {:.1} %, f {:.1} %, success {:.0} %, {:.1} m from the true surface at the closest, {} safety violations",
        s.coverage,
        s.f,
        s.triplet_success.unwrap_or(0.0),
        s.min_clearance_m,
        s.safety_violations
    )
}

/// `scores` with the crash check's figures.
fn with_check(mut scores: Scores, check: &PathCheck) -> Scores {
    scores.min_clearance_m = check.min_clearance_m;
    scores.safety_violations = check.violations.len();
    scores
}

fn refs(v: &[Flown]) -> Vec<&Flown> {
    v.iter().collect()
}

fn artifacts(
    name: String,
    face_f: Vec<f64>,
    plans: Vec<Plan>,
    acquired: Vec<AcquiredModel>,
) -> StrategyArtifacts {
    StrategyArtifacts {
        name,
        face_f,
        plans,
        acquired,
    }
}

/// Flies and evaluates every strategy on one held-out site.
fn run_site(
    cfg: &CampaignConfig,
    forest: &Forest,
    strategies: &[Strategy],
    seed: u64,
    keep_artifacts: bool,
    curves: &mut CurveAccumulator,
    progress: &mut dyn FnMut(&str),
) -> Result<(SiteResult, Option<SiteArtifacts>)> {
    let world = World::new(cfg, seed)?;
    let em = EvalMesh::new(&world, cfg)?;
    let matcher = Matcher::new(cfg)?;
    progress(&format!(
        "held-out site {seed}: {} faces, {} evaluation faces in the ROI",
        world.site.mesh.n_faces(),
        em.len()
    ));
    let run_seed = mix64(cfg.seed ^ mix64(seed ^ 0x7369_7465));

    let init_cams = init_cameras(&world, cfg);
    // One SfM model of the site: every image of every flight is registered
    // in it, with one georeferencing error.
    let sfm_seed = mix64(run_seed ^ 0x0073_666d);
    let init_sfm = sfm_cameras(&init_cams, cfg, sfm_seed);
    let init = acquire(&world, &init_cams, &init_sfm, Some(forest), cfg, curves)?;
    let (init_flown, init_check) = fly_flight(
        &world,
        &matcher,
        cfg,
        ("initial flight", &init_cams, &init_sfm),
        SOURCE_INIT,
        run_seed,
        curves,
        progress,
    )?;
    let known = Known::new(&world, cfg, init, &init_flown, sfm_seed);
    let grid_cams = grid_cameras(&world, cfg)?;
    let grid_sfm = sfm_cameras(&grid_cams, cfg, sfm_seed);
    let (grid_flown, grid_check) = fly_flight(
        &world,
        &matcher,
        cfg,
        ("Grid", &grid_cams, &grid_sfm),
        SOURCE_GRID,
        run_seed,
        curves,
        progress,
    )?;

    let mut scores: Vec<(String, Scores)> = Vec::new();
    let mut maps: Vec<StrategyArtifacts> = Vec::new();
    for (name, flown, check, cams, role) in [
        ("Init", &init_flown, &init_check, &init_cams, Role::Initial),
        ("Grid", &grid_flown, &grid_check, &grid_cams, Role::Grid),
    ] {
        let (s, f) = evaluate(&em, &refs(flown), cfg)?;
        scores.push((name.into(), with_check(s, check)));
        let plans = vec![plan_of(&world, cams, role)];
        maps.push(artifacts(name.into(), f, plans, Vec::new()));
    }
    let mut combos = Vec::new();
    for (i, st) in strategies.iter().enumerate() {
        let run = run_strategy(
            &world,
            &matcher,
            forest,
            cfg,
            st,
            2 + i as u64,
            &known,
            keep_artifacts,
            curves,
            progress,
        )?;
        let (s, f) = evaluate(&em, &refs(&run.flown), cfg)?;
        let s = with_check(s, &run.check);
        progress(&strategy_line(seed, &st.name, &s));
        scores.push((st.name.clone(), s));
        let mut union = refs(&grid_flown);
        union.extend(run.flown.iter());
        let (cs, cf) = evaluate(&em, &union, cfg)?;
        let cs = with_check(cs, &grid_check.merged(&run.check));
        combos.push((format!("G+{}", st.name), cs, cf));
        maps.push(artifacts(st.name.clone(), f, run.plans, run.acquired));
    }
    for (name, s, f) in combos {
        scores.push((name.clone(), s));
        maps.push(artifacts(name, f, Vec::new(), Vec::new()));
    }
    let artifacts = keep_artifacts.then(|| SiteArtifacts {
        seed,
        mesh: world.site.mesh.clone(),
        roi: world.roi,
        centroids: em.centroids.clone(),
        strategies: maps,
    });
    Ok((SiteResult { seed, scores }, artifacts))
}

/// Runs the campaign with a trained forest (see [`run_campaign`]); the
/// measured curves then come from the flown triplets only.
pub fn run_campaign_with_forest(
    cfg: &CampaignConfig,
    forest: &Forest,
    progress: &mut dyn FnMut(&str),
) -> Result<CampaignReport> {
    let curves = CurveAccumulator::new(forest.bins().clone());
    fly_held_out(cfg, forest, curves, progress)
}

/// Flies and evaluates every held-out site; `curves` may hold the training
/// triplets' measurements already.
fn fly_held_out(
    cfg: &CampaignConfig,
    forest: &Forest,
    mut curves: CurveAccumulator,
    progress: &mut dyn FnMut(&str),
) -> Result<CampaignReport> {
    cfg.validate()?;
    let strategies = cfg.parsed_strategies()?;
    let mut sites = Vec::new();
    let mut artifacts = None;
    for (i, &seed) in cfg.held_out_seeds.iter().enumerate() {
        let (r, a) = run_site(
            cfg,
            forest,
            &strategies,
            seed,
            i == 0,
            &mut curves,
            progress,
        )?;
        sites.push(r);
        if a.is_some() {
            artifacts = a;
        }
    }
    let curves = curves.curves();
    Ok(CampaignReport {
        rows: aggregate(&sites),
        sites,
        material_ranking: super::curves::material_ranking(&curves),
        curves,
        training: None,
        config: cfg.clone(),
        artifacts,
    })
}

/// The whole campaign: trains the forest on the training sites, then flies
/// and evaluates every strategy on every held-out site. `progress` hears
/// one line per step.
pub fn run_campaign(
    cfg: &CampaignConfig,
    progress: &mut dyn FnMut(&str),
) -> Result<CampaignReport> {
    Ok(run_campaign_trained(cfg, None, progress)?.0)
}

/// [`run_campaign`] with a forest trained before (`Some`: no training, the
/// measured curves come from the flown triplets only) or trained here
/// (`None`); returns the report and the forest flown with.
pub fn run_campaign_trained(
    cfg: &CampaignConfig,
    forest: Option<Forest>,
    progress: &mut dyn FnMut(&str),
) -> Result<(CampaignReport, Forest)> {
    let (forest, stats, curves) = if let Some(f) = forest {
        let curves = CurveAccumulator::new(f.bins().clone());
        (f, None, curves)
    } else {
        let mut curves = CurveAccumulator::new(cfg.training.forest.bins.clone());
        let (f, s) = train_forest_with_stats(cfg, &mut curves, progress)?;
        (f, Some(s), curves)
    };
    let mut report = fly_held_out(cfg, &forest, curves, progress)?;
    report.training = stats;
    Ok((report, forest))
}

#[cfg(test)]
#[path = "run_tests.rs"]
mod tests;
