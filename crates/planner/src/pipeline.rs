//! The planning call: M1 once, M2 once, M3 k times with f(t) updates, M4
//! (and M3 again for what M4 drops, `replace.rs`).

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use nalgebra::Point3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use vp_scene::mesh_ops::submesh;
use vp_scene::plan::{IterationStatistics, Plan};
use vp_scene::raster::ConfidenceImage;
use vp_scene::raycast::RayCaster;
use vp_scene::{Camera, Mesh};

use crate::error::{PlannerError, Result};
use crate::flight_path::{Block, PathContext};
use crate::flights::assign_flights;
use crate::free_space::{free_space, observations_from_mesh, UnknownSpace};
use crate::fulfillment::{sample_triangles, Fulfillment};
use crate::inputs::{safety_for, AcquiredView, PlanInputs, PlanResult, SampledFulfillment};
use crate::quality::Requirements;
use crate::replace::{self, Chosen, Flown, M3Loop, Rounds, Searcher};
use crate::safety::Safety;
use crate::surrogate::{sample_positions, LazyLinks};
use crate::triplet::{Potential, Search};

fn secs(d: Duration) -> f64 {
    d.as_secs_f64()
}

/// `f()` and its wall time in seconds.
fn timed<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let t = Instant::now();
    let v = f();
    (v, secs(t.elapsed()))
}

/// M1: sampled triangles, f(t) with the acquired cameras, the selection T
/// and T as a mesh (face i = `selected[i]`).
fn m1(
    inputs: &PlanInputs,
    roi: &[u32],
    caster: &RayCaster,
    rng: &mut ChaCha8Rng,
) -> Result<(Fulfillment, Vec<usize>, Mesh)> {
    let cfg = inputs.config;
    let (tri_mesh, tris) = sample_triangles(inputs.mesh, roi, cfg.n_triangles, rng)?;
    let req = Requirements {
        r_desired: 1.0 / (cfg.gsd_m * cfg.gsd_m),
        accuracy: cfg.accuracy_m,
        alpha: cfg.alpha,
        bins: cfg.angle_bins()?,
    };
    let cams: Vec<Camera> = inputs.acquired.iter().map(|a| a.camera).collect();
    let confs: Vec<Option<&ConfidenceImage>> = inputs
        .acquired
        .iter()
        .map(|a| a.confidence.as_ref())
        .collect();
    let ful = Fulfillment::new(
        req,
        cfg.sigma_px,
        cfg.min_cameras as usize,
        (tri_mesh, tris),
        caster,
        &cams,
        &confs,
    );
    if ful.observers.iter().all(Vec::is_empty) {
        return Err(PlannerError::Input(format!(
            "none of the {} acquired cameras sees the region of interest",
            cams.len()
        )));
    }
    let selected = ful.select(cfg.n_selected, rng);
    let selected_mesh = submesh(
        &ful.tri_mesh,
        &selected.iter().map(|&t| t as u32).collect::<Vec<_>>(),
    );
    Ok((ful, selected, selected_mesh))
}

/// Per-triangle results of a call.
fn sampled_results(ful: &Fulfillment, selected: &[usize]) -> Vec<SampledFulfillment> {
    let in_t: std::collections::HashSet<usize> = selected.iter().copied().collect();
    (0..ful.tris.len())
        .map(|t| SampledFulfillment {
            parent: ful.tris[t].parent,
            centroid: ful.tris[t].centroid,
            normal: ful.tris[t].normal,
            f: ful.f(t),
            selected: in_t.contains(&t),
        })
        .collect()
}

/// Everything an M3 search needs besides f(t), which changes between iterations.
struct Setup<'a> {
    selected: &'a [usize],
    selected_mesh: &'a Mesh,
    surrogates: &'a [Point3<f64>],
    safety: &'a Safety,
    caster: &'a RayCaster,
    intrinsics: vp_scene::Intrinsics,
    pitch_limits: (f64, f64),
    early_stop: bool,
    deadline: Option<Instant>,
    time_budget_s: f64,
}

impl Setup<'_> {
    fn search<'b>(&'b self, ful: &'b Fulfillment, banned: &'b [bool]) -> Search<'b> {
        Search {
            ful,
            selected: self.selected,
            selected_mesh: self.selected_mesh,
            surrogates: self.surrogates,
            safety: self.safety,
            caster: self.caster,
            intrinsics: self.intrinsics,
            pitch_limits: self.pitch_limits,
            early_stop: self.early_stop,
            deadline: self.deadline,
            banned,
        }
    }
}

/// M3 with its surrogates' links.
struct M3<'a, 's> {
    setup: &'a Setup<'s>,
    links: &'a mut LazyLinks,
    /// Wall time of every search so far, seconds.
    time_s: f64,
}

impl Searcher for M3<'_, '_> {
    /// Best-triplet searches with f(t) updates; returns why it stopped
    /// early, if it did.
    fn search(
        &mut self,
        ful: &mut Fulfillment,
        banned: &[bool],
        n: usize,
        next_id: u32,
        out: &mut M3Loop,
    ) -> Option<String> {
        let setup = self.setup;
        let over = || setup.deadline.is_some_and(|d| Instant::now() >= d);
        for (it, id) in (0..n).zip(next_id..) {
            let done = out.chosen.len();
            if over() {
                return Some(format!(
                    "time budget of {} s spent after {done} triplets",
                    setup.time_budget_s
                ));
            }
            let tm = Instant::now();
            let outcome = setup.search(ful, banned).run_lazy(self.links);
            out.visited.push(outcome.visited);
            let Some(best) = outcome.best else {
                return Some(if outcome.timed_out {
                    format!("time budget spent during triplet search {done}")
                } else {
                    format!("no triplet with a positive gain after {done} triplets")
                });
            };
            let mut chosen = Chosen {
                id,
                best,
                m3_s: 0.0,
            };
            let mut stats = replace::add(ful, &chosen, setup.caster);
            chosen.m3_s = secs(tm.elapsed());
            stats.time_s.insert("m3".into(), chosen.m3_s);
            self.time_s += chosen.m3_s;
            out.iterations.push(stats);
            out.chosen.push(chosen);
            if outcome.timed_out && it + 1 < n {
                return Some(format!(
                    "time budget spent during triplet search {}",
                    done + 1
                ));
            }
        }
        None
    }
}

/// Surrogate positions, their links to T (segments tested on demand) and
/// the hypothetical fulfillment per link.
type M2Out = (Vec<Point3<f64>>, LazyLinks);

/// M2: free-space surrogates linked by inverse visibility, and the part of
/// M3's potential gains that does not change between iterations. The
/// segment tests of the links wait until M3 needs them (see
/// [`crate::triplet::Search::run_lazy`]).
fn m2(
    inputs: &PlanInputs,
    ful: &Fulfillment,
    selected: &[usize],
    safety: &Safety,
    caster: &RayCaster,
    rng: &mut ChaCha8Rng,
) -> Result<M2Out> {
    let cfg = inputs.config;
    let surrogates = sample_positions(safety, caster, inputs.mesh, cfg.n_surrogates, rng)?;
    let t_geo: Vec<_> = selected
        .iter()
        .map(|&t| (ful.tris[t].centroid, ful.tris[t].normal))
        .collect();
    // f(t) only grows during a call (cameras are only added), so a link whose
    // best hypothetical fulfillment does not exceed f(t) now never carries a
    // potential gain: it is dropped before its segment test.
    let pot = Potential::new(ful, cfg.camera.focal_px);
    let links = LazyLinks::new(&surrogates, &t_geo, cfg.inverse_fov_deg, |s, i| {
        let t = selected[i];
        let v = pot.value(&surrogates[s], t);
        (v > ful.f(t)).then_some(v)
    });
    Ok((surrogates, links))
}

/// Adds the observed-free space to `safety` when unknown space counts as
/// an obstacle.
fn with_free_space(safety: Safety, inputs: &PlanInputs, caster: &RayCaster) -> Result<Safety> {
    let cfg = inputs.config;
    if cfg.unknown_space == UnknownSpace::Free {
        return Ok(safety);
    }
    let cams: Vec<Camera> = inputs.acquired.iter().map(|a| a.camera).collect();
    let from_mesh;
    let observations = if let Some(o) = inputs.observations {
        o
    } else {
        from_mesh = observations_from_mesh(&cams, caster);
        &from_mesh
    };
    let fs = free_space(
        &safety.volume,
        cfg.clearance_m(),
        cfg.free_space_voxel_m,
        cfg.free_above_observed,
        observations,
        &cams,
    )?;
    Ok(safety.with_free_space(fs))
}

/// Validates the inputs; returns the last acquired view (where the path
/// starts without a home).
fn checked_start<'a>(inputs: &PlanInputs<'a>) -> Result<&'a AcquiredView> {
    inputs.config.validate()?;
    if inputs.mesh.n_faces() == 0 {
        return Err(PlannerError::Input("the mesh has no faces".into()));
    }
    inputs.acquired.last().ok_or_else(|| {
        PlannerError::Input("no acquired cameras: planning starts from an initial flight".into())
    })
}

/// The plan file of what is flown: the waypoints cut into flights, the
/// rules they keep, the figures, and the triplets dropped.
fn plan_file(
    inputs: &PlanInputs,
    safety: &Safety,
    ctx: &PathContext,
    flown: &Flown,
    cut: Option<String>,
) -> Result<Plan> {
    let cfg = inputs.config;
    let mut plan = Plan::new(inputs.origin);
    let path = &flown.path;
    let flights = assign_flights(safety, inputs.home.as_ref(), &path.waypoints, &cfg.mission)?;
    (plan.waypoints, plan.flights) = (flights.waypoints, flights.flights);
    plan.unbridged = path.unbridged.iter().map(|&i| flights.index[i]).collect();
    plan.geofence.clone_from(&safety.geofence);
    plan.altitude_limits = Some(safety.altitude);
    plan.safety_distance_m = Some(cfg.safety_distance_m);
    plan.statistics.iterations.clone_from(&flown.m3.iterations);
    plan.cut_short = cut.is_some();
    plan.cut_short_reason = cut;
    plan.dropped_triplets = replace::for_plan(ctx, &flown.dropped, &plan.waypoints);
    Ok(plan)
}

/// With a home, a plan left without a waypoint because every triplet chosen
/// was dropped is refused: there is nothing to fly, and an empty mission
/// would only fail at the upload. The words lead with the ways from home
/// when any was blocked (the usual cause: a home at the edge of what the
/// first flight observed), and say what to change. Without a home (the
/// simulated campaigns) the empty plan is returned, its drops listed.
fn nothing_to_fly(inputs: &PlanInputs, flown: &Flown, plan: &Plan) -> Option<PlannerError> {
    let home = inputs.home?;
    if !plan.waypoints.is_empty() || flown.dropped.is_empty() {
        return None;
    }
    let n = flown.dropped.len();
    let from_home: Vec<&str> = flown
        .dropped
        .iter()
        .zip(&plan.dropped_triplets)
        .filter(|((d, _), _)| matches!(d.block, Block::Home { .. }))
        .map(|(_, t)| t.reason.as_str())
        .collect();
    Some(PlannerError::Refused(match from_home.first() {
        Some(first) => format!(
            "no planned view can be flown from home at ({:.2}, {:.2}, {:.2}): each of the {n} \
             triplets chosen was dropped, {} of them for the way from home (the first: {first}). \
             Take off from an open spot that the first flight observed (`--home`), or extend \
             the first flight over the space around home, then plan again",
            home.x,
            home.y,
            home.z,
            from_home.len()
        ),
        None => format!(
            "every triplet chosen was dropped ({n}), nothing is left to fly: {}",
            replace::reasons(&plan.dropped_triplets).join("; ")
        ),
    }))
}

/// M4's path builder for `inputs`.
fn path_context<'a>(
    inputs: &PlanInputs<'a>,
    caster: &'a RayCaster,
    safety: &'a Safety,
) -> PathContext<'a> {
    PathContext {
        mesh: inputs.mesh,
        caster,
        safety,
        intrinsics: inputs.config.camera.intrinsics(),
        min_overlap: inputs.config.min_overlap,
        home: inputs.home,
    }
}

/// Adds the times of M1 and M2 to the first iteration's figures, M4's to the last's.
fn with_module_times(iterations: &mut [IterationStatistics], times: &BTreeMap<String, f64>) {
    if let Some(s) = iterations.first_mut() {
        for m in ["m1", "m2"] {
            s.time_s.insert(m.into(), times[m]);
        }
    }
    if let Some(s) = iterations.last_mut() {
        s.time_s.insert("m4".into(), times["m4"]);
    }
}

/// Plans the next k triplets and the flight path (M1-M4;
/// docs/design.md#the-planning-call).
pub fn plan(inputs: &PlanInputs) -> Result<PlanResult> {
    let t0 = Instant::now();
    let cfg = inputs.config;
    let mesh = inputs.mesh;
    let last = checked_start(inputs)?;
    let deadline = cfg.time_budget_s.map(|s| t0 + Duration::from_secs_f64(s));
    let over = || deadline.is_some_and(|d| Instant::now() >= d);
    let mut times: BTreeMap<String, f64> = BTreeMap::new();
    // The two trees over the mesh (the ray caster's BVH, the clearance
    // BVH of the safety rules) are independent, single-threaded builds.
    let (caster, (safety, t_clear)) =
        rayon::join(|| RayCaster::new(mesh), || timed(|| safety_for(mesh, cfg)));
    let roi = inputs.roi.faces(mesh, &caster, inputs.origin)?;
    let (safety, t_free) = timed(|| with_free_space(safety, inputs, &caster));
    let safety = safety?;
    times.insert("free_space".into(), t_clear + t_free);
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let k = cfg.camera.intrinsics();

    // M1.
    let tm = Instant::now();
    let (mut ful, selected, selected_mesh) = m1(inputs, &roi, &caster, &mut rng)?;
    times.insert("m1".into(), secs(tm.elapsed()));

    // M2.
    let tm = Instant::now();
    let mut cut: Option<String> = None;
    let (surrogates, mut links) = if over() {
        cut = Some("time budget spent before M2".into());
        (
            Vec::new(),
            LazyLinks::new(&[], &[], cfg.inverse_fov_deg, |_, _| None),
        )
    } else {
        m2(inputs, &ful, &selected, &safety, &caster, &mut rng)?
    };
    times.insert("m2".into(), secs(tm.elapsed()));

    // M3, k times.
    let setup = Setup {
        selected: &selected,
        selected_mesh: &selected_mesh,
        surrogates: &surrogates,
        safety: &safety,
        caster: &caster,
        intrinsics: k,
        pitch_limits: (
            cfg.gimbal_pitch_min_deg.to_radians(),
            cfg.gimbal_pitch_max_deg.to_radians(),
        ),
        early_stop: cfg.m3_early_stop,
        deadline,
        time_budget_s: cfg.time_budget_s.unwrap_or(0.0),
    };
    let before_m3 = ful.clone();
    let mut m3 = M3Loop::default();
    let mut search = M3 {
        setup: &setup,
        links: &mut links,
        time_s: 0.0,
    };
    if cut.is_none() {
        cut = search.search(&mut ful, &[], cfg.n_triplets, 0, &mut m3);
    }
    let m3_first = search.time_s;

    // M4, and the replacement of what it drops.
    let tm = Instant::now();
    let ctx = path_context(inputs, &caster, &safety);
    let captured: Vec<Camera> = inputs.acquired.iter().map(|a| a.camera).collect();
    let rounds = Rounds {
        ctx: &ctx,
        start: &last.camera,
        captured: &captured,
        before_m3: &before_m3,
        surrogates: &surrogates,
        n_triplets: cfg.n_triplets,
        deadline,
    };
    let mut flown = rounds.fly_or_replace(&mut ful, m3, &mut search);
    let cut = flown.cut_short_reason(cut, cfg.n_triplets);
    // The replacement searches count as M3.
    let m4 = secs(tm.elapsed()) - (search.time_s - m3_first);
    times.insert("m3".into(), search.time_s);
    times.insert("m4".into(), m4);
    with_module_times(&mut flown.m3.iterations, &times);

    let mut plan = plan_file(inputs, &safety, &ctx, &flown, cut.clone())?;
    if let Some(refusal) = nothing_to_fly(inputs, &flown, &plan) {
        return Err(refusal);
    }
    plan.statistics.total_time_s = Some(secs(t0.elapsed()));
    let sampled = sampled_results(&ful, &selected);
    let unbridged = plan.unbridged.clone();
    let dropped_triplets = plan.dropped_triplets.iter().map(|d| d.triplet_id).collect();
    let dropped_reasons = replace::reasons(&plan.dropped_triplets);
    Ok(PlanResult {
        plan,
        iterations: flown.m3.iterations,
        module_time_s: times,
        selected_faces: selected.iter().map(|&t| ful.tris[t].parent).collect(),
        sampled,
        triplet_gains: flown.m3.chosen.iter().map(|c| c.best.gain).collect(),
        visited: flown.m3.visited,
        unbridged,
        dropped_triplets,
        dropped_reasons,
        cut_short: cut.is_some(),
        cut_short_reason: cut,
    })
}

/// The plan without its wall-clock timings (per-module times, total time):
/// the rest of a plan is a function of the inputs and the seed, so this is
/// what reproducibility checks and `vpctl plan --no-timings` compare byte for byte.
pub fn strip_timings(plan: &mut Plan) {
    plan.statistics.total_time_s = None;
    for it in &mut plan.statistics.iterations {
        it.time_s.clear();
    }
}
