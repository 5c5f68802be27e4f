//! The campaign runner: per held-out site, the initial flight, the Grid
//! baseline and every triplet strategy, each evaluated on its own images.

use nalgebra::Point3;
use vp_forest::Forest;
use vp_planner::grid::{grid_views, GridParams};
use vp_planner::oblique::oblique_views;
use vp_scene::plan::{Plan, Role};
use vp_scene::{Aabb, Camera};

use super::acquired::AcquiredModel;
use super::crash::PathCheck;
use super::curves::CurveAccumulator;
use super::eval::{evaluate, EvalMesh, Scores};
use super::images::{acquire, init_cameras};
use super::reconstruct::{Flown, Matcher};
use super::renders::Renders;
use super::report::{aggregate, CampaignReport, SiteArtifacts, SiteResult, StrategyArtifacts};
use super::site::{fly_with_error, image_id, SiteRun};
use super::strategy_run::{run_strategy, Known};
use super::training::{measure_out_of_sample, train_forest_with_stats, TrainingStats};
use super::triplet_outcomes::DepthErrorHistogram;
use crate::config::CampaignConfig;
use crate::config::MvsKind;
use crate::config::Strategy;
use crate::error::Result;
use crate::sfm::sfm_cameras;
use crate::world::World;
use vp_scene::hash::mix64;
use vp_scene::sim3::Sim3;

/// Source tags of image ids: init, grid, then one per strategy.
const SOURCE_INIT: u64 = 0;
const SOURCE_GRID: u64 = 1;
/// The oblique baseline's source tag, above any strategy's (`2 + i`).
const SOURCE_OBLIQUE: u64 = 0xFFFF;
/// Flies a flight that is not a set of triplets (the initial images, the
/// Grid): checks its path (waypoints in order, from its first) against the
/// truth and reconstructs it with SfM's estimates `sfm` of its cameras:
/// with vp-mvs as the paper's Grid, every image against its best
/// overlapping neighbours; with the virtual MVS (triplets only), sliding
/// triplets (i, i+1, i+2) along the flight in order. Its shots come from
/// `site.renders` (the initial flight's from acquiring it) and are dropped
/// after: no later flight flies these cameras.
fn fly_flight(
    site: &mut SiteRun<'_>,
    (name, cams, sfm): (&str, &[Camera], &[Camera]),
    source: u64,
    seed: u64,
) -> Result<(Vec<Flown>, PathCheck)> {
    let (world, matcher, cfg) = (site.world, site.matcher, site.cfg);
    let mut check = PathCheck::default();
    let path: Vec<Point3<f64>> = cams.iter().map(Camera::center).collect();
    let label = format!("site {} {name}", world.site.params.seed);
    site.check_path(&mut check, (None, &path), &label);
    let ids: Vec<u64> = (0..cams.len()).map(|i| image_id(source, i)).collect();
    // Real matchers reconstruct the whole image set, as a user's would;
    // the virtual MVS draws each triplet's outcome.
    let flown = if cfg.mvs == MvsKind::Virtual {
        (0..cams.len().saturating_sub(2))
            .map(|i| {
                matcher.fly_triplet(
                    &mut site.renders,
                    (
                        [cams[i], cams[i + 1], cams[i + 2]],
                        [sfm[i], sfm[i + 1], sfm[i + 2]],
                    ),
                    [ids[i], ids[i + 1], ids[i + 2]],
                    &world.roi,
                    mix64(seed ^ mix64(source << 40 | i as u64)),
                    site.curves,
                )
            })
            .collect::<Result<Vec<_>>>()?
    } else {
        let seed = mix64(seed ^ source);
        matcher.image_set(&mut site.renders, (cams, sfm), &ids, &world.roi, seed)?
    };
    site.renders.clear();
    let tol = cfg.eval.depth_tolerance_m;
    let site_seed = world.site.params.seed;
    (site.progress)(&flight_line(site_seed, name, cams.len(), &flown, tol));
    Ok((flown, check))
}

/// The ROI's footprint plus the Grid's margin, at the ground's lowest point.
fn grid_footprint(world: &World, cfg: &CampaignConfig) -> Aabb {
    let m = cfg.grid.margin_m;
    let z = world.ground_min_z();
    Aabb {
        min: Point3::new(world.roi.min.x - m, world.roi.min.y - m, z),
        max: Point3::new(world.roi.max.x + m, world.roi.max.y + m, z),
    }
}

/// The Grid baseline's cameras: nadir lawnmower over the ROI footprint plus margin.
fn grid_cameras(world: &World, cfg: &CampaignConfig) -> Result<Vec<Camera>> {
    let params = GridParams {
        height_m: cfg.grid.height_m,
        gsd_m: None,
        front_overlap: cfg.grid.overlap,
        side_overlap: cfg.grid.overlap,
        pitch_deg: -90.0,
        yaw_deg: 0.0,
        role: Role::Grid,
    };
    let views = grid_views(&grid_footprint(world, cfg), &params, world.intrinsics)?;
    Ok(views
        .iter()
        .map(|v| v.to_camera(world.intrinsics))
        .collect())
}

/// The oblique baseline's cameras (`[grid] oblique`): five routes over the
/// Grid's footprint at its height, 45 deg down, with at most as many
/// images as the largest of `strategies` flies, so that the comparison
/// with planned triplets is at an equal image count.
fn oblique_cameras(
    world: &World,
    cfg: &CampaignConfig,
    strategies: &[Strategy],
) -> Result<Vec<Camera>> {
    let budget = strategies
        .iter()
        .map(|s| 3 * s.iterations * s.per_iteration)
        .max()
        .unwrap_or(0);
    let fp = grid_footprint(world, cfg);
    let views = oblique_views(&fp, cfg.grid.height_m, -45.0, world.intrinsics, budget)?;
    Ok(views
        .iter()
        .map(|v| v.to_camera(world.intrinsics))
        .collect())
}

/// Flies the oblique baseline (see [`oblique_cameras`]) with the vehicle's
/// position error and reconstructs it: its flights, path check and cameras.
fn fly_oblique(
    site: &mut SiteRun<'_>,
    strategies: &[Strategy],
    (run_seed, sfm_seed): (u64, u64),
) -> Result<(Vec<Flown>, PathCheck, Vec<Camera>)> {
    let planned = oblique_cameras(site.world, site.cfg, strategies)?;
    let (cams, _) = fly_with_error(site.cfg, &planned, run_seed ^ 3);
    let sfm = sfm_cameras(&cams, site.cfg, sfm_seed);
    let (flown, check) = fly_flight(site, ("Oblique", &cams, &sfm), SOURCE_OBLIQUE, run_seed)?;
    Ok((flown, check, cams))
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

/// One progress line for a flight reconstructed as a whole (Init, Grid).
fn flight_line(seed: u64, name: &str, images: usize, flown: &[Flown], tolerance_m: f64) -> String {
    let mut total = super::reconstruct::OutputStats::default();
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

/// The depth errors of the rock pixels of every reconstruction in `flown`.
fn merged_rock_errors(flown: &[Flown]) -> DepthErrorHistogram {
    let mut h = DepthErrorHistogram::default();
    for f in flown {
        h.merge(&f.rock_errors);
    }
    h
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

/// The initial flight's model georeferenced from its GNSS tags (the
/// identity without flight error): the similarity and its rms residual.
fn georeference_init(
    world: &World,
    cfg: &CampaignConfig,
    (cams, tags): (&[Camera], &[Point3<f64>]),
    (seed, run_seed): (u64, u64),
    progress: &mut dyn FnMut(&str),
) -> Result<(Sim3, f64)> {
    if !cfg.flight_error.enabled {
        return Ok((crate::gnss::identity_sim3(), 0.0));
    }
    let al = crate::gnss::georeference(cams, tags, run_seed)?;
    let roi_centre = nalgebra::center(&world.roi.min, &world.roi.max);
    progress(&format!(
        "  site {seed}: initial flight aligned to its {} GNSS positions: rms residual {:.2} m, the model {:.2} m off the truth at the ROI's centre",
        cfg.flight_error.gnss.label(),
        al.rms_m,
        (al.sim3.apply(&roi_centre) - roi_centre).norm()
    ));
    Ok((al.sim3, al.rms_m))
}

/// The initial flight: flown with the vehicle's position error, the model
/// of its images georeferenced from their GNSS tags and registered in the
/// site's SfM model (seed `sfm_seed`), the images acquired, then
/// reconstructed (from the shots acquiring left in `site.renders`): what
/// the strategies start from, its reconstructions, path check and cameras.
fn fly_init(
    site: &mut SiteRun<'_>,
    (run_seed, sfm_seed): (u64, u64),
) -> Result<(Known, Vec<Flown>, PathCheck, Vec<Camera>)> {
    let (world, cfg) = (site.world, site.cfg);
    let seed = world.site.params.seed;
    let (cams, tags) = fly_with_error(cfg, &init_cameras(world, cfg), run_seed ^ 1);
    let georef = georeference_init(world, cfg, (&cams, &tags), (seed, run_seed), site.progress)?;
    let sfm = sfm_cameras(&cams, cfg, sfm_seed);
    let forest = Some(site.forest);
    let init = acquire(&mut site.renders, (&cams, &sfm), forest, cfg, site.curves)?;
    let name = "initial flight";
    let (flown, check) = fly_flight(site, (name, &cams, &sfm), SOURCE_INIT, run_seed)?;
    let known = Known::new(world, cfg, init, &flown, sfm_seed, georef);
    Ok((known, flown, check, cams))
}

/// Flies and evaluates every strategy on one held-out site.
fn run_site(
    cfg: &CampaignConfig,
    forest: &Forest,
    strategies: &[Strategy],
    seed: u64,
    keep_artifacts: bool,
    (curves, random): (&mut CurveAccumulator, &mut CurveAccumulator),
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
    let mut site = SiteRun {
        world: &world,
        matcher: &matcher,
        cfg,
        forest,
        curves,
        renders: Renders::new(world.scene(), cfg),
        progress,
    };
    let n = measure_out_of_sample(&mut site.renders, &world.site, &matcher, cfg, seed, random)?;
    (site.progress)(&format!(
        "  site {seed}: {n} random triplets (no planner's) measured for the out-of-sample curves"
    ));
    let run_seed = mix64(cfg.seed ^ mix64(seed ^ 0x7369_7465));
    // One SfM model of the site: every image of every flight is registered
    // in it, with one georeferencing error.
    let sfm_seed = mix64(run_seed ^ 0x0073_666d);
    let (known, init_flown, init_check, init_cams) = fly_init(&mut site, (run_seed, sfm_seed))?;
    let (grid_cams, _) = fly_with_error(cfg, &grid_cameras(&world, cfg)?, run_seed ^ 2);
    let grid_sfm = sfm_cameras(&grid_cams, cfg, sfm_seed);
    let (grid_flown, grid_check) = fly_flight(
        &mut site,
        ("Grid", &grid_cams, &grid_sfm),
        SOURCE_GRID,
        run_seed,
    )?;

    let mut baselines = vec![
        ("Init", init_flown, init_check, init_cams, Role::Initial),
        ("Grid", grid_flown, grid_check, grid_cams, Role::Grid),
    ];
    if cfg.grid.oblique {
        let (flown, check, cams) = fly_oblique(&mut site, strategies, (run_seed, sfm_seed))?;
        baselines.push(("Oblique", flown, check, cams, Role::Grid));
    }
    let mut scores: Vec<(String, Scores)> = Vec::new();
    let mut maps: Vec<StrategyArtifacts> = Vec::new();
    let (mut triplets, mut rock_errors) = (Vec::new(), Vec::new());
    for (name, flown, check, cams, role) in &baselines {
        rock_errors.push(((*name).to_string(), merged_rock_errors(flown)));
        let (s, f) = evaluate(&em, &refs(flown), cfg)?;
        scores.push(((*name).into(), with_check(s, check)));
        let plans = vec![plan_of(&world, cams, *role)];
        maps.push(artifacts((*name).into(), f, plans, Vec::new()));
    }
    let (_, grid_flown, grid_check, _, _) = &baselines[1];
    let mut combos = Vec::new();
    for (i, st) in strategies.iter().enumerate() {
        let mut run = run_strategy(&mut site, st, 2 + i as u64, &known, keep_artifacts)?;
        triplets.append(&mut run.outcomes);
        rock_errors.push((st.name.clone(), std::mem::take(&mut run.rock_errors)));
        let (s, f) = evaluate(&em, &refs(&run.flown), cfg)?;
        let s = with_check(s, &run.check);
        (site.progress)(&strategy_line(seed, &st.name, &s));
        scores.push((st.name.clone(), s));
        let mut union = refs(grid_flown);
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
    let result = SiteResult {
        seed,
        scores,
        triplets,
        rock_errors,
    };
    Ok((result, artifacts))
}

/// Runs the campaign with a trained forest (see [`run_campaign`]).
pub fn run_campaign_with_forest(
    cfg: &CampaignConfig,
    forest: &Forest,
    progress: &mut dyn FnMut(&str),
) -> Result<CampaignReport> {
    fly_held_out(cfg, forest, progress)
}

/// Flies and evaluates every held-out site. The measured curves: of the
/// flown triplets and, apart, of each site's fixed random triplets (issue
/// 34, item 7); the training triplets' measurements are left out of both
/// (the forest learned from them: in sample).
fn fly_held_out(
    cfg: &CampaignConfig,
    forest: &Forest,
    progress: &mut dyn FnMut(&str),
) -> Result<CampaignReport> {
    cfg.validate()?;
    let strategies = cfg.parsed_strategies()?;
    let mut curves = CurveAccumulator::new(forest.bins().clone());
    let mut random = CurveAccumulator::new(forest.bins().clone());
    let mut sites = Vec::new();
    let mut artifacts = None;
    for (i, &seed) in cfg.held_out_seeds.iter().enumerate() {
        let (r, a) = run_site(
            cfg,
            forest,
            &strategies,
            seed,
            i == 0,
            (&mut curves, &mut random),
            progress,
        )?;
        sites.push(r);
        if a.is_some() {
            artifacts = a;
        }
    }
    let curves = curves.curves_with(Some(&random));
    Ok(CampaignReport {
        rows: aggregate(&sites),
        sites,
        material_ranking: super::curves::material_ranking(&curves),
        material_ranking_random: super::curves::material_ranking_random(&curves),
        curves,
        training: None,
        forest_fingerprint: format!("{:016x}", forest.fingerprint()),
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
    let (forest, stats) = train_campaign_forest(cfg, progress)?;
    let mut report = fly_held_out(cfg, &forest, progress)?;
    report.training = Some(stats);
    Ok(report)
}

/// The first half of [`run_campaign`]: the forest trained on the training
/// sites and what its training measured. Apart from the flights so that a
/// caller can keep the forest (hours of work on a real campaign) before
/// flying with it ([`run_campaign_with_forest`]).
pub fn train_campaign_forest(
    cfg: &CampaignConfig,
    progress: &mut dyn FnMut(&str),
) -> Result<(Forest, TrainingStats)> {
    // The training triplets' success is what the forest learned from:
    // measured in sample, so not part of the campaign's curves.
    let mut in_sample = CurveAccumulator::new(cfg.training.forest.bins.clone());
    train_forest_with_stats(cfg, &mut in_sample, progress)
}

#[cfg(test)]
#[path = "run_tests.rs"]
mod tests;
