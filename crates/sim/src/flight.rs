//! Flying a plan in the simulated world (`vpctl sim fly`): the images a
//! drone would bring back and the COLMAP model SfM would make of them, so
//! that the manual loop `scene generate -> plan grid -> sim fly -> predict
//! -> plan -> sim fly` runs without a drone.
//!
//! The world is a campaign's site ([`CampaignConfig::site`], its own seed);
//! the camera is the campaign's `planner.camera`; the lighting its `render`
//! section. Poses and points are what the campaign's one SfM simulator
//! gives ([`crate::sfm`]: [`crate::sfm::sfm_camera`] poses with `sfm`
//! noise, or exact): the world's sparse candidates
//! ([`crate::sfm::SparseCandidates`], `sfm.points_per_m2`) that a feature
//! detector fires on in at least `sfm.min_views` rendered images, thinned
//! to at most [`FlyOptions::max_points`], each with its track.

use std::path::{Path, PathBuf};

use nalgebra::Point3;
use vp_scene::colmap::{self, ModelFrame, Reconstruction};
use vp_scene::gnss::GnssClass;
use vp_scene::outdir::OutDir;
use vp_scene::plan::Plan;
use vp_scene::raster::{save_rgb, RgbImage};
use vp_scene::{Camera, SceneError};

use crate::config::CampaignConfig;
use crate::error::{Result, SimError};
use crate::render::render;
use crate::sfm::features::FeatureMask;
use crate::sfm::sfm_camera;
use crate::world::World;
use vp_scene::hash::mix64;

/// Options of [`fly`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlyOptions {
    /// Exact poses and points instead of the campaign's SfM noise.
    pub exact: bool,
    /// Largest number of sparse points written (SfM's points are thinned
    /// evenly to this many).
    pub max_points: usize,
}

impl Default for FlyOptions {
    fn default() -> Self {
        FlyOptions {
            exact: false,
            max_points: 20_000,
        }
    }
}

/// What a flight brought back.
pub struct Flight {
    /// Image names (as in the model) and rendered images, in flight order.
    pub images: Vec<(String, RgbImage)>,
    /// The sparse model: PINHOLE cameras, SfM poses, sparse points.
    pub model: Reconstruction,
    /// The model's geodetic frame (`frame.json`): the site's origin,
    /// identity transform (the model is already in the site's ENU frame).
    pub frame: ModelFrame,
    /// Sparse points with fewer than `min_views` views were left out; this
    /// many surface points were candidates.
    pub candidate_points: usize,
}

/// Renders every waypoint of `plans` (in order; image names
/// `<label>_<index>.png` with the label given per plan) over the campaign
/// site of `cfg` and builds the sparse model SfM would give. `progress`
/// hears one line per rendered image.
pub fn fly(
    cfg: &CampaignConfig,
    plans: &[(String, Plan)],
    opts: &FlyOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<Flight> {
    let n_views: usize = plans.iter().map(|(_, p)| p.waypoints.len()).sum();
    if n_views == 0 {
        return Err(SimError::InvalidArgument(
            "the plans have no waypoints: nothing to fly".into(),
        ));
    }
    let world = World::new(cfg, cfg.site.seed)?;
    let k = world.intrinsics;
    let mut rp = cfg.render.clone();
    rp.texture_seed = world.site.params.seed;
    let mut named: Vec<(String, Camera)> = Vec::with_capacity(n_views);
    let mut images = Vec::with_capacity(n_views);
    // Each plan is a flight with the vehicle's position error (`[flight_error]`,
    // unless --exact): the images are taken where the vehicle really was.
    let mut tags = Vec::with_capacity(n_views);
    for (p, (label, plan)) in plans.iter().enumerate() {
        let planned: Vec<Camera> = plan.waypoints.iter().map(|w| w.to_camera(k)).collect();
        let centres: Vec<Point3<f64>> = planned.iter().map(Camera::center).collect();
        let m = &cfg.planner.mission;
        let flown = if opts.exact {
            crate::gnss::FlownPath {
                truth: centres.clone(),
                tagged: centres,
            }
        } else {
            cfg.flight_error.fly(
                &centres,
                m.cruise_speed_m_s,
                m.hover_per_photo_s,
                mix64(cfg.seed ^ 0x666c_7900 ^ p as u64),
            )
        };
        tags.extend(flown.tagged);
        for (i, (planned, truth)) in planned.iter().zip(&flown.truth).enumerate() {
            let cam = crate::gnss::moved_to(planned, truth);
            let name = format!("{label}_{i:04}.png");
            let r = render(&world.site.mesh, &world.caster, &cam, &rp)?;
            progress(&format!("rendered {name} ({}/{n_views})", images.len() + 1));
            images.push((name.clone(), r.rgb));
            named.push((name, cam));
        }
    }
    // SfM as the campaign simulates it (one SfM simulator): the world's
    // sparse candidates that a feature detector fires on in at least
    // `sfm.min_views` of the rendered images, thinned evenly to
    // `max_points`, at SfM's noisy positions (exact with `--exact`).
    let features: Vec<FeatureMask> = images
        .iter()
        .map(|(_, rgb)| FeatureMask::detect(rgb))
        .collect();
    let views: Vec<(&Camera, &FeatureMask)> = named.iter().map(|(_, c)| c).zip(&features).collect();
    let min_views = cfg.sfm.min_views.max(2);
    let sigma = if opts.exact {
        0.0
    } else {
        cfg.sfm.point_noise_m
    };
    let tracks = world
        .candidates
        .tracks(&world.caster, &views, min_views, sigma);
    let candidate_points = world.candidates.len();
    let stride = tracks.len().div_ceil(opts.max_points.max(1)).max(1);
    let mut model = Reconstruction::default();
    let ids: Vec<u32> = named
        .iter()
        .map(|(name, cam)| model.add_pinhole_image(name, cam))
        .collect();
    for (i, xyz, seen) in tracks.into_iter().step_by(stride) {
        // Observed where the feature fired: the true point in the true image.
        let truth = world.candidates.points[i].0;
        let observations: Vec<_> = seen
            .iter()
            .filter_map(|&v| named[v].1.project(&truth).map(|xy| (ids[v], xy)))
            .collect();
        model.add_point(xyz, &observations)?;
    }
    if !opts.exact {
        for (img, (_, cam)) in model.images.values_mut().zip(&named) {
            img.cam_from_world = sfm_camera(cam, cfg, cfg.seed).cam_from_world();
        }
    }
    let mut frame = ModelFrame {
        home: Some(world.home()),
        // The simulated vehicle's class (exact poses: as good as RTK).
        gnss: Some(if opts.exact || !cfg.flight_error.enabled {
            GnssClass::Rtk
        } else {
            cfg.flight_error.gnss
        }),
        ..ModelFrame::identity(world.site.origin)
    };
    if !opts.exact && cfg.flight_error.enabled {
        let truth: Vec<Camera> = named.iter().map(|(_, c)| *c).collect();
        let names: Vec<&String> = named.iter().map(|(n, _)| n).collect();
        model = georeferenced(&model, &mut frame, (&truth, &names), &tags, cfg.seed)?;
    }
    Ok(Flight {
        images,
        model,
        frame,
        candidate_points,
    })
}

/// `model` (in the true world) georeferenced as `colmap align
/// --positions` would from the photos' GNSS `tags`; `frame` records the
/// transform and the residuals by image name.
fn georeferenced(
    model: &Reconstruction,
    frame: &mut ModelFrame,
    (truth, names): (&[Camera], &[&String]),
    tags: &[Point3<f64>],
    seed: u64,
) -> Result<Reconstruction> {
    let al = crate::gnss::georeference(truth, tags, seed)?;
    frame.sim3 = al.sim3;
    frame.rms_m = al.rms_m;
    frame.residuals = al
        .residuals
        .into_iter()
        .map(|mut r| {
            // The alignment names images img_<index>; the model by their flight names.
            if let Some(n) = r
                .name
                .strip_prefix("img_")
                .and_then(|x| x.strip_suffix(".png"))
                .and_then(|x| x.parse::<usize>().ok())
                .and_then(|i| names.get(i))
            {
                r.name.clone_from(n);
            }
            r
        })
        .collect();
    Ok(colmap::transform_reconstruction(model, &frame.sim3))
}

/// A `vpctl sim fly` job: plans flown in order over a campaign config's
/// site, written as `images/` and a COLMAP `sparse/` model with its
/// `frame.json`. `#[non_exhaustive]` with a constructor: a new option is a
/// new field with a default.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct FlightRequest {
    /// Plan files (JSON), flown in order; their file stems name the images.
    pub plans: Vec<PathBuf>,
    /// The campaign config (TOML) whose site, render, SfM and camera
    /// sections describe the world.
    pub site: PathBuf,
    /// Exact poses, point budget.
    pub options: FlyOptions,
    /// Write the model in COLMAP's binary encoding instead of text.
    pub binary: bool,
    /// The output folder.
    pub out: PathBuf,
    /// Replace an earlier `sim fly` output in `out` (only vpctl's files).
    pub force: bool,
}

impl FlightRequest {
    /// Noisy poses, 20 000 points at most, a text model, no overwriting.
    pub fn new(plans: Vec<PathBuf>, site: impl Into<PathBuf>, out: impl Into<PathBuf>) -> Self {
        FlightRequest {
            plans,
            site: site.into(),
            options: FlyOptions::default(),
            binary: false,
            out: out.into(),
            force: false,
        }
    }
}

/// What [`write_flight`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct FlightSummary {
    /// The images folder and how many images it holds.
    pub images_dir: PathBuf,
    /// Images written.
    pub images: usize,
    /// The model folder.
    pub sparse_dir: PathBuf,
    /// Sparse points in the model.
    pub points: usize,
    /// Views a sparse point needs (the config's `sfm.min_views`, at least 2).
    pub min_views: usize,
}

/// Flies `req` (the one entry `vpctl sim fly` and Python's `vpctl.sim.fly`
/// call): reads the config and the plans, checks the output folder before
/// rendering, and writes the images and the model through an
/// [`OutDir`], so a failure leaves no partial folder. Two plans with the
/// same file stem are refused (their image names would clash).
pub fn write_flight(req: &FlightRequest, progress: &mut dyn FnMut(&str)) -> Result<FlightSummary> {
    let text = vp_scene::fsio::read_text(&req.site)?;
    let mut cfg = CampaignConfig::from_toml(&text, &req.site)?;
    // The site is the one `vpctl scene generate --config` makes from the
    // same file: its `[site]` section with the site's own defaults, so the
    // world flown is the mesh a user plans on.
    cfg.site = vp_scene::config_file::read_section(&text, &req.site, "site")?;
    let inputs: Vec<&Path> = req
        .plans
        .iter()
        .map(PathBuf::as_path)
        .chain([req.site.as_path()])
        .collect();
    let out_dir = OutDir::check(&req.out, "sim fly", &inputs, req.force)?;
    let mut loaded: Vec<(String, Plan)> = Vec::with_capacity(req.plans.len());
    for p in &req.plans {
        let plan = Plan::load(p)?;
        let label = p
            .file_stem()
            .map_or_else(|| "view".into(), |s| s.to_string_lossy().into_owned());
        if loaded.iter().any(|(l, _)| *l == label) {
            return Err(SimError::InvalidArgument(format!(
                "two plans are named {label}: image names would clash; rename one"
            )));
        }
        loaded.push((label, plan));
    }
    let flight = fly(&cfg, &loaded, &req.options, progress)?;
    out_dir.write(|stage| -> Result<()> {
        let images = stage.join("images");
        std::fs::create_dir_all(&images).map_err(|e| SceneError::io(&images, e))?;
        for (name, img) in &flight.images {
            save_rgb(img, &images.join(name))?;
        }
        let sparse = stage.join("sparse");
        if req.binary {
            colmap::write_binary(&sparse, &flight.model)?;
        } else {
            colmap::write_text(&sparse, &flight.model)?;
        }
        flight.frame.save(&sparse)?;
        Ok(())
    })?;
    Ok(FlightSummary {
        images_dir: req.out.join("images"),
        images: flight.images.len(),
        sparse_dir: req.out.join("sparse"),
        points: flight.model.points.len(),
        min_views: cfg.sfm.min_views.max(2),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use vp_scene::plan::{PlannedView, Role};

    fn nadir_plan(cfg: &CampaignConfig) -> Plan {
        let mut plan = Plan::new(None);
        let z = 20.0;
        for (i, x) in [-4.0, 0.0, 4.0].into_iter().enumerate() {
            let cam = Camera::from_yaw_pitch(
                cfg.planner.camera.intrinsics(),
                Point3::new(x, 0.0, z),
                0.0,
                -std::f64::consts::FRAC_PI_2,
            );
            let mut v = PlannedView::from_camera(&cam, Role::Grid);
            v.triplet_id = Some(i as u32);
            plan.waypoints.push(v);
        }
        plan
    }

    #[test]
    fn a_flight_gives_one_image_per_waypoint_and_points_seen_twice() {
        let cfg = CampaignConfig::quick();
        let plan = nadir_plan(&cfg);
        let f = fly(
            &cfg,
            &[("grid".into(), plan)],
            &FlyOptions::default(),
            &mut |_| {},
        )
        .unwrap();
        assert_eq!(f.images.len(), 3);
        assert_eq!(f.model.images.len(), 3);
        // SfM's points: `sfm.points_per_m2` (0.5) candidates on ~150 m^2 seen
        // by two or more of these small images where a corner fires (24 at
        // the time of writing; face centroids gave hundreds before).
        assert!(f.model.points.len() > 10, "{}", f.model.points.len());
        assert!(f.model.points.values().all(|p| p.track.len() >= 2));
        f.model.validate().unwrap();
        assert_eq!(f.model.images[&1].name, "grid_0000.png");
    }
}
