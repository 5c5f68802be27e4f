//! What the simulated reconstruction of one strategy has seen: SfM's
//! sparse points with their tracks ([`crate::sfm`]), and the dense points
//! of the flown vp-mvs depth maps.
//!
//! Dense points:
//! vp-mvs's fused points of every flown image set (pixels of at least two
//! views that agree, as COLMAP's stereo_fusion keeps them), with their
//! normals, observed from the views fused into them, thinned to one per
//! `sfm.dense_spacing_m` cube that holds at least `sfm.dense_min_points`
//! of them (a voxel grid with a minimum count, as PCL's VoxelGrid offers):
//! a surface fills its cubes with many points, a stray match does not.
//! Keeping the first point of every cube instead would favour outliers,
//! which land in empty cubes while inliers land in full ones.
//!
//! From this state come the planning mesh (the 3D mesher) and the
//! observation rays that carve the planner's free space: what the planner
//! knows is what was seen, never the true mesh.

use std::collections::hash_map::Entry;
use std::collections::HashMap;

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;
use vp_scene::colmap::Reconstruction;
use vp_scene::raycast::FACE_VISIBILITY_EPSILON;
use vp_scene::surface::{reconstruct_surface, SurfaceSample};
use vp_scene::{Camera, Mesh};

use super::reconstruct::Flown;
use crate::config::CampaignConfig;
use crate::error::{Result, SimError};
use crate::sfm::SparseCandidates;
use crate::world::{Acquired, World};

/// An observation ray: camera centre, observed point.
pub type Observation = (Point3<f64>, Point3<f64>);

/// The seen state of one strategy's flights (see the module docs).
#[derive(Debug, Clone)]
pub struct SfmState {
    /// The world's candidates.
    candidates: SparseCandidates,
    /// Per candidate, the acquired images (indices into `centres`) observing it.
    seen_by: Vec<Vec<u32>>,
    /// SfM centres of the acquired images.
    centres: Vec<Point3<f64>>,
    /// Per thinning cube, in the order the cubes were first hit: how many
    /// fused points fell in it, and the first of them.
    dense: Vec<(usize, SurfaceSample)>,
    /// Index into `dense` of each cube.
    dense_cells: HashMap<[i64; 3], usize>,
}

impl SfmState {
    /// Nothing acquired yet; the candidates of `world`.
    pub fn new(world: &World) -> Self {
        SfmState {
            seen_by: vec![Vec::new(); world.candidates.len()],
            candidates: world.candidates.clone(),
            centres: Vec::new(),
            dense: Vec::new(),
            dense_cells: HashMap::new(),
        }
    }

    /// Adds the images of `acquired`: which candidates each one observes.
    pub fn add_images(&mut self, world: &World, acquired: &[Acquired]) {
        for a in acquired {
            let id = self.centres.len() as u32;
            self.centres.push(a.sfm.center());
            let obs = self
                .candidates
                .observed(&world.caster, &a.truth, &a.features);
            for (seen, o) in self.seen_by.iter_mut().zip(obs) {
                if o {
                    seen.push(id);
                }
            }
        }
    }

    /// Adds the fused points of `flown` to the thinning cubes of side
    /// `spacing_m`.
    pub fn add_fused(&mut self, flown: &[Flown], spacing_m: f64) {
        for p in flown.iter().flat_map(|fl| &fl.fused) {
            let c = p.position.coords.map(|c| (c / spacing_m).floor() as i64);
            match self.dense_cells.entry([c.x, c.y, c.z]) {
                Entry::Occupied(e) => self.dense[*e.get()].0 += 1,
                Entry::Vacant(e) => {
                    e.insert(self.dense.len());
                    self.dense.push((1, p.clone()));
                }
            }
        }
    }

    /// The dense points: one per cube holding at least `min_points`.
    fn dense(&self, min_points: usize) -> impl Iterator<Item = &SurfaceSample> {
        self.dense
            .iter()
            .filter(move |(n, _)| *n >= min_points)
            .map(|(_, p)| p)
    }

    /// Sparse points SfM has (seen by at least `min_views` images), with
    /// their noisy positions and observing centres.
    pub fn sparse(&self, cfg: &CampaignConfig) -> Vec<(Point3<f64>, Vec<Point3<f64>>)> {
        self.tracks(cfg)
            .map(|(p, seen)| {
                let from = seen.iter().map(|&j| self.centres[j as usize]).collect();
                (p, from)
            })
            .collect()
    }

    /// The sparse points with their noisy positions and the indices of the
    /// acquired images seeing them.
    fn tracks<'a>(
        &'a self,
        cfg: &'a CampaignConfig,
    ) -> impl Iterator<Item = (Point3<f64>, &'a [u32])> + 'a {
        let sigma = cfg.sfm.point_noise_m;
        self.seen_by
            .iter()
            .enumerate()
            .filter(|(_, seen)| seen.len() >= cfg.sfm.min_views)
            .map(move |(i, seen)| (self.candidates.noisy(i, sigma), seen.as_slice()))
    }

    /// The COLMAP model SfM would give of the acquired images, as `vpctl
    /// sim fly` writes one: `images[j]` is the name and SfM camera of the
    /// j-th image added (one PINHOLE camera each), the points are
    /// [`SfmState::sparse`]'s, each observed where it projects in the SfM
    /// cameras of its track (a point left with fewer than two observations
    /// is left out, as SfM cannot triangulate it).
    pub fn colmap_model(
        &self,
        cfg: &CampaignConfig,
        images: &[(String, Camera)],
    ) -> Result<Reconstruction> {
        if images.len() != self.centres.len() {
            return Err(SimError::Campaign(format!(
                "{} image names for {} acquired images",
                images.len(),
                self.centres.len()
            )));
        }
        let mut rec = Reconstruction::default();
        let ids: Vec<u32> = images
            .iter()
            .map(|(name, cam)| rec.add_pinhole_image(name, cam))
            .collect();
        for (p, seen) in self.tracks(cfg) {
            let obs: Vec<_> = seen
                .iter()
                .filter_map(|&j| {
                    let j = j as usize;
                    images[j].1.project_in_frame(&p).map(|xy| (ids[j], xy))
                })
                .collect();
            if obs.len() >= 2 {
                rec.add_point(p, &obs)?;
            }
        }
        Ok(rec)
    }

    /// The mesher's samples: sparse points with their tracks' centres
    /// (normals left to the mesher: PCA over neighbours, signed towards the
    /// observers) and the fused dense points with their own.
    pub fn surface_samples(&self, cfg: &CampaignConfig) -> Vec<SurfaceSample> {
        let mut out: Vec<SurfaceSample> = self
            .sparse(cfg)
            .into_iter()
            .map(|(position, seen_from)| SurfaceSample {
                position,
                normal: None,
                seen_from,
            })
            .collect();
        out.extend(self.dense(cfg.sfm.dense_min_points).cloned());
        out
    }

    /// The planning mesh: the 3D mesher over [`SfmState::surface_samples`].
    pub fn planning_mesh(&self, cfg: &CampaignConfig) -> Result<Mesh> {
        let samples = self.surface_samples(cfg);
        reconstruct_surface(&samples, &cfg.surface).map_err(|e| {
            SimError::Campaign(format!(
                "planning mesh from {} seen points: {e}",
                samples.len()
            ))
        })
    }

    /// Every observation ray: sparse tracks and dense points.
    pub fn observations(&self, cfg: &CampaignConfig) -> Vec<Observation> {
        let mut out: Vec<Observation> = self
            .sparse(cfg)
            .into_iter()
            .flat_map(|(p, from)| from.into_iter().map(move |c| (c, p)))
            .collect();
        out.extend(
            self.dense(cfg.sfm.dense_min_points)
                .flat_map(|d| d.seen_from.iter().map(|c| (*c, d.position))),
        );
        out
    }
}

/// How close a planning mesh comes to the truth (per iteration, in the
/// progress output and the findings).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshQuality {
    /// Mean distance of the mesh's vertices to the true surface, metres.
    pub mean_distance_m: f64,
    /// 95th percentile of the same, metres.
    pub p95_distance_m: f64,
    /// Share of the true surface samples within `tolerance` of the mesh.
    pub completeness: f64,
    /// The same over the samples with surface above them (under tree
    /// canopies and overhangs); `None` when the site has none.
    pub under_canopy_completeness: Option<f64>,
    /// Dense points the mesher was given.
    pub dense_points: usize,
    /// Share of them farther than `tolerance` from the true surface: what
    /// the geometric filter let through.
    pub dense_outlier_share: f64,
}

impl SfmState {
    /// Compares `mesh` with the truth of `world` (completeness within
    /// `tolerance_m`).
    pub fn mesh_quality(
        &self,
        world: &World,
        cfg: &CampaignConfig,
        mesh: &Mesh,
        tolerance_m: f64,
    ) -> MeshQuality {
        let mut d: Vec<f64> = mesh
            .vertices
            .par_iter()
            .map(|v| world.clearance.distance(v))
            .collect();
        d.sort_by(f64::total_cmp);
        let mean = d.iter().sum::<f64>() / d.len().max(1) as f64;
        let p95 = d.get(d.len() * 95 / 100).copied().unwrap_or(f64::NAN);
        let planned = vp_scene::clearance::Clearance::new(mesh);
        // Straight up, tilted a little: the ray caster misses exactly
        // axis-aligned rays (see vp-planner's safety module).
        let up = Vector3::new(1e-3, 2e-3, 1.0).normalize();
        let per_point: Vec<(bool, bool)> = self
            .candidates
            .points
            .par_iter()
            .map(|(p, n)| {
                let probe = p + n * FACE_VISIBILITY_EPSILON;
                let covered = planned.point_is_clear(p, tolerance_m);
                let under = world
                    .caster
                    .closest_hit(&probe, &up, f64::INFINITY)
                    .is_some();
                (!covered, under)
            })
            .collect();
        let share = |f: &dyn Fn(&(bool, bool)) -> bool| {
            let (n, k) = per_point
                .iter()
                .filter(|x| f(x))
                .fold((0usize, 0usize), |(n, k), x| (n + 1, k + usize::from(x.0)));
            (n > 0).then(|| k as f64 / n as f64)
        };
        let dense: Vec<&SurfaceSample> = self.dense(cfg.sfm.dense_min_points).collect();
        let dense_outliers = dense
            .par_iter()
            .filter(|d| world.clearance.distance(&d.position) > tolerance_m)
            .count();
        MeshQuality {
            dense_points: dense.len(),
            dense_outlier_share: dense_outliers as f64 / dense.len().max(1) as f64,
            mean_distance_m: mean,
            p95_distance_m: p95,
            completeness: share(&|_| true).unwrap_or(0.0),
            under_canopy_completeness: share(&|x| x.1),
        }
    }
}
