//! The held-out world, the initial flight, and the images acquired in it:
//! true and SfM-estimated poses, predicted confidence. What SfM and vp-mvs
//! make of the images (the planning mesh) is [`super::sfm`].

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use rayon::prelude::*;
use vp_forest::Forest;
use vp_scene::clearance::Clearance;
use vp_scene::procedural::{generate_site, Site};
use vp_scene::raster::ConfidenceImage;
use vp_scene::raycast::RayCaster;
use vp_scene::{Aabb, Camera, Intrinsics, Mesh};

use crate::config::CampaignConfig;
use super::curves::CurveAccumulator;
use super::features::FeatureMask;
use super::sfm::SparseCandidates;
use crate::error::{Result, SimError};
use crate::noise::gaussian;
use crate::render::render;
use vp_scene::hash::mix64;

/// A held-out site with its ray caster and region of interest.
pub struct World {
    /// The true site.
    pub site: Site,
    /// Ray caster of the true mesh.
    pub caster: RayCaster,
    /// Distance queries to the true mesh (the crash check).
    pub clearance: Clearance,
    /// The region of interest: the rock's box grown by the margin, all heights.
    pub roi: Aabb,
    /// Camera of every flight.
    pub intrinsics: Intrinsics,
    /// The surface points SfM may triangulate (one SfM simulator for the
    /// planning geometry and every reconstruction's depth range).
    pub candidates: SparseCandidates,
}

impl World {
    /// Generates the site of `seed` and its ROI.
    pub fn new(cfg: &CampaignConfig, seed: u64) -> Result<Self> {
        let mut params = cfg.site.clone();
        params.seed = seed;
        let site = generate_site(&params)?;
        let caster = RayCaster::new(&site.mesh);
        let rb = site.rock_bounds;
        let m = cfg.roi_margin_m;
        let b = site.mesh.bounds();
        let roi = Aabb {
            min: Point3::new(rb.min.x - m, rb.min.y - m, b.min.z - 1.0),
            max: Point3::new(rb.max.x + m, rb.max.y + m, b.max.z + 1.0),
        };
        let candidates = SparseCandidates::of_site(&site.mesh, cfg, seed);
        Ok(World {
            candidates,
            clearance: Clearance::new(&site.mesh),
            site,
            caster,
            roi,
            intrinsics: cfg.planner.camera.intrinsics(),
        })
    }

    /// The true world as the matcher sees it.
    pub fn scene(&self) -> super::reconstruct::Scene<'_> {
        super::reconstruct::Scene {
            mesh: &self.site.mesh,
            caster: &self.caster,
            texture_seed: self.site.params.seed,
            candidates: &self.candidates,
        }
    }

    /// Where the simulated vehicle takes off: the ground straight below the
    /// site's origin (the generator puts the origin on the terrain, so this
    /// is the origin up to the terrain's height there).
    pub fn home(&self) -> vp_scene::plan::Home {
        let ground_z = self
            .caster
            .closest_hit(
                &Point3::new(0.0, 0.0, self.site.mesh.bounds().max.z + 1.0),
                &-nalgebra::Vector3::z(),
                f64::INFINITY,
            )
            .map_or(0.0, |h| h.point.z);
        let frame = vp_scene::geodesy::LocalFrame::new(self.site.origin);
        let position = frame.map_or(self.site.origin, |f| f.to_geodetic([0.0, 0.0, ground_z]));
        vp_scene::plan::Home {
            position,
            source: "the simulated take-off point, on the ground below the site's origin".into(),
        }
    }

    /// Lowest ground point of the site (flight heights refer to it).
    pub fn ground_min_z(&self) -> f64 {
        self.site.mesh.bounds().min.z
    }
}

/// An acquired image: where it really was, where SfM thinks it was, where
/// a feature detector fires on it, and its predicted confidence (for F
/// strategies).
#[derive(Debug, Clone)]
pub struct Acquired {
    /// The true camera (renders, virtual MVS).
    pub truth: Camera,
    /// The camera as SfM estimated it (the planner's, the matcher's and
    /// labelgen's input).
    pub sfm: Camera,
    /// Where FAST fires on the rendered image (which sparse points SfM
    /// gets from it).
    pub features: FeatureMask,
    /// Predicted confidence, when the strategy predicts.
    pub confidence: Option<ConfidenceImage>,
}

/// Seeded Gaussian noise of a 3D position, a pure function of the position
/// (standard deviation `sigma` per axis).
pub fn point_noise(seed: u64, p: &Point3<f64>, sigma: f64) -> Vector3<f64> {
    let q = |v: f64| (v * 1e4).round() as i64;
    let (a, b, c) = (q(p.x), q(p.y), q(p.z));
    Vector3::new(
        gaussian(seed ^ 0x78, a, b, c),
        gaussian(seed ^ 0x79, a, b, c),
        gaussian(seed ^ 0x7a, a, b, c),
    ) * sigma
}

/// The camera as SfM estimates it: the true pose moved by the
/// georeferencing error of the SfM model of `seed`, one rigid transform
/// for every image of that model (rotation about the site's origin with
/// `sfm.rotation_noise_deg` per axis, shift with `sfm.position_noise_m`
/// per axis). The images' poses relative to each other are exact: bundle
/// adjustment leaves sub-pixel reprojection errors, so the error a matcher
/// sees is not epipolar; the planner and the evaluation see the shift.
/// (Independent centimetre noise per camera, as before issue 34, would be a
/// 1-2 % depth error at the campaign's short baselines: no SfM model has
/// relative poses that poor.)
pub fn sfm_camera(cam: &Camera, cfg: &CampaignConfig, seed: u64) -> Camera {
    let s = mix64(seed ^ 0x0073_666d);
    let g = |k: i64| gaussian(s, k, 0, 0);
    let dp = Vector3::new(g(0), g(1), g(2)) * cfg.sfm.position_noise_m;
    let dr = Vector3::new(g(3), g(4), g(5)) * cfg.sfm.rotation_noise_deg.to_radians();
    let georef =
        Isometry3::from_parts(Translation3::from(dp), UnitQuaternion::from_scaled_axis(dr));
    Camera::new(cam.intrinsics, georef * cam.world_from_cam)
}

/// SfM's estimates of `cams`, all in the SfM model of `seed`
/// ([`sfm_camera`]): the one pose set a reconstruction, labelgen and the
/// planner share.
pub fn sfm_cameras(cams: &[Camera], cfg: &CampaignConfig, seed: u64) -> Vec<Camera> {
    cams.iter().map(|c| sfm_camera(c, cfg, seed)).collect()
}

/// The initial flight: a nadir grid centred on the ROI (see [`crate::config::InitFlight`]).
pub fn init_cameras(world: &World, cfg: &CampaignConfig) -> Vec<Camera> {
    let i = &cfg.init;
    let cx = 0.5 * (world.roi.min.x + world.roi.max.x);
    let cy = 0.5 * (world.roi.min.y + world.roi.max.y);
    let z = world.ground_min_z() + i.height_m;
    let mut cams = Vec::with_capacity(i.nx * i.ny);
    for row in 0..i.ny {
        for col in 0..i.nx {
            // Serpentine order, as flown.
            let c = if row % 2 == 0 { col } else { i.nx - 1 - col };
            let x = cx + (c as f64 - 0.5 * (i.nx as f64 - 1.0)) * i.spacing_m;
            let y = cy + (row as f64 - 0.5 * (i.ny as f64 - 1.0)) * i.spacing_m;
            cams.push(Camera::from_yaw_pitch(
                world.intrinsics,
                Point3::new(x, y, z),
                std::f64::consts::FRAC_PI_2,
                -std::f64::consts::FRAC_PI_2,
            ));
        }
    }
    cams
}

/// Renders each camera's image (`cams`: true, `sfm`: SfM's estimate of
/// the same), finds its features and predicts its confidence (when a
/// forest is given); adds the learned confidence per material to `curves`.
pub fn acquire(
    world: &World,
    cams: &[Camera],
    sfm: &[Camera],
    forest: Option<&Forest>,
    cfg: &CampaignConfig,
    curves: &mut CurveAccumulator,
) -> Result<Vec<Acquired>> {
    if cams.len() != sfm.len() {
        return Err(SimError::Campaign(format!(
            "{} cameras but {} SfM estimates",
            cams.len(),
            sfm.len()
        )));
    }
    let mut rp = cfg.render.clone();
    rp.texture_seed = world.site.params.seed;
    let mut out = Vec::with_capacity(cams.len());
    for (cam, sfm) in cams.iter().zip(sfm) {
        let img = render(&world.site.mesh, &world.caster, cam, &rp)?;
        let confidence = match forest {
            Some(forest) => {
                let conf = forest
                    .predict_image(&img.rgb, cfg.confidence_step)
                    .map_err(|e| {
                        SimError::InvalidArgument(format!("confidence prediction: {e}"))
                    })?;
                curves.add_learned(&img, &world.site.mesh, &conf);
                Some(conf)
            }
            None => None,
        };
        out.push(Acquired {
            truth: *cam,
            sfm: *sfm,
            features: FeatureMask::detect(&img.rgb),
            confidence,
        });
    }
    Ok(out)
}

/// Faces of `mesh` whose centroid lies inside `roi`, and whether each is rock.
pub fn roi_faces(mesh: &Mesh, roi: &Aabb) -> Vec<u32> {
    (0..mesh.n_faces())
        .into_par_iter()
        .filter(|&f| roi.contains(&mesh.face_centroid(f)))
        .map(|f| f as u32)
        .collect()
}
