//! What the simulated reconstruction has seen: SfM's sparse points with
//! their tracks, and the dense points of the flown vp-mvs depth maps.
//!
//! Sparse points ([`SparseCandidates`], the one SfM simulator of the
//! campaign: the held-out flights, each reconstruction's depth range and
//! the training sites' stage-3 mesh): a fixed, seeded sample of the true
//! surface (area-uniform, `sfm.points_per_m2`); an image observes a
//! candidate when it is in the frame, front-facing, unoccluded and a
//! feature detector fires within a pixel of where it projects on the
//! rendered image ([`super::features`]: FAST-9 at OpenCV's default
//! threshold), so untextured or low-contrast surfaces give SfM no points.
//! SfM knows a candidate once at least `sfm.min_views` images observe it,
//! at its position plus seeded noise (`sfm.point_noise_m`), observed from
//! the SfM estimates of those images' centres. Dense points:
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
use vp_scene::raycast::{RayCaster, FACE_VISIBILITY_EPSILON};
use vp_scene::surface::{reconstruct_surface, SurfaceSample};
use vp_scene::{Camera, Mesh};

use crate::config::CampaignConfig;
use super::features::FeatureMask;
use super::reconstruct::Flown;
use super::world::{point_noise, Acquired, World};
use crate::error::{Result, SimError};
use crate::noise::{hash3, unit};
use vp_scene::hash::mix64;

/// An observation ray: camera centre, observed point.
pub type Observation = (Point3<f64>, Point3<f64>);

/// The surface points SfM may triangulate, drawn once per world (see the
/// module docs), with the seed of their SfM noise.
#[derive(Debug, Clone)]
pub struct SparseCandidates {
    /// True positions and their faces' normals.
    points: Vec<(Point3<f64>, Vector3<f64>)>,
    /// Seeds the SfM noise: a point's estimate is the same whenever it is
    /// asked for (mesh, free space, depth ranges, every iteration).
    seed: u64,
}

impl SparseCandidates {
    /// The candidates of `mesh`: `points_per_m2` per square metre of
    /// surface in expectation, drawn with `seed`.
    pub fn new(mesh: &Mesh, points_per_m2: f64, seed: u64) -> Self {
        let points = (0..mesh.n_faces())
            .into_par_iter()
            .flat_map_iter(|f| {
                // A face gets floor(area * density) points, one more with the
                // remaining probability: area-uniform in expectation.
                let s = mix64(seed ^ mix64(f as u64 ^ 0x0073_7061_7273));
                let expect = mesh.face_area(f) * points_per_m2;
                let n =
                    expect.floor() as usize + usize::from(unit(hash3(s, 0, 0, 0)) < expect.fract());
                let [a, b, c] = mesh.triangle(f);
                let normal = mesh.face_normal(f);
                (0..n).map(move |i| {
                    let (mut u, mut v) = (
                        unit(hash3(s, 1, i as i64, 0)),
                        unit(hash3(s, 2, i as i64, 0)),
                    );
                    if u + v > 1.0 {
                        (u, v) = (1.0 - u, 1.0 - v);
                    }
                    (a + (b - a) * u + (c - a) * v, normal)
                })
            })
            .collect();
        SparseCandidates { points, seed }
    }

    /// The candidates of the site of `site_seed` in the campaign `cfg`
    /// (held-out or training site alike).
    pub fn of_site(mesh: &Mesh, cfg: &CampaignConfig, site_seed: u64) -> Self {
        let seed = mix64(cfg.seed ^ mix64(site_seed ^ 0x0073_666d));
        Self::new(mesh, cfg.sfm.points_per_m2, seed)
    }

    /// Number of candidates.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Per candidate, whether the image of the true camera `truth` with
    /// detector response `features` observes it: in the frame,
    /// front-facing, unoccluded, and a corner within a pixel of its
    /// projection.
    pub fn observed(
        &self,
        caster: &RayCaster,
        truth: &Camera,
        features: &FeatureMask,
    ) -> Vec<bool> {
        let c = truth.center();
        let probes: Vec<Point3<f64>> = self
            .points
            .iter()
            .map(|(p, n)| p + n * FACE_VISIBILITY_EPSILON)
            .collect();
        let vis = caster.visible_points(truth, &probes);
        self.points
            .iter()
            .zip(vis)
            .map(|((p, n), v)| {
                v && n.dot(&(c - p)) > 0.0
                    && truth
                        .project_in_frame(p)
                        .is_some_and(|px| features.fires_near(&px))
            })
            .collect()
    }

    /// SfM of one image set: every candidate at least `min_views` of the
    /// images observe, as (candidate index, noisy position, indices of the
    /// observing images). `images` are the true cameras with the detector
    /// response of their renders.
    pub fn tracks(
        &self,
        caster: &RayCaster,
        images: &[(&Camera, &FeatureMask)],
        min_views: usize,
        sigma_m: f64,
    ) -> Vec<(usize, Point3<f64>, Vec<usize>)> {
        let mut seen: Vec<Vec<usize>> = vec![Vec::new(); self.points.len()];
        for (v, (cam, features)) in images.iter().enumerate() {
            for (s, o) in seen.iter_mut().zip(self.observed(caster, cam, features)) {
                if o {
                    s.push(v);
                }
            }
        }
        seen.into_iter()
            .enumerate()
            .filter(|(_, s)| s.len() >= min_views.max(2))
            .map(|(i, s)| (i, self.noisy(i, sigma_m), s))
            .collect()
    }

    /// SfM's estimate of candidate `i`: its position plus seeded noise.
    fn noisy(&self, i: usize, sigma_m: f64) -> Point3<f64> {
        let p = &self.points[i].0;
        p + point_noise(mix64(self.seed ^ 0x0070_6e6f_6973), p, sigma_m)
    }
}

/// The depth range of each image of a set from the sparse points it
/// observes ([`SparseCandidates::tracks`]), seen from the image's SfM
/// camera `sfm[v]`, by COLMAP's rule ([`super::features::colmap_depth_range`]).
pub fn sparse_depth_ranges(
    tracks: &[(usize, Point3<f64>, Vec<usize>)],
    sfm: &[&Camera],
) -> Vec<Option<(f64, f64)>> {
    let mut depths: Vec<Vec<f64>> = vec![Vec::new(); sfm.len()];
    for (_, p, views) in tracks {
        for &v in views {
            depths[v].push((sfm[v].cam_from_world() * p).z);
        }
    }
    depths
        .into_iter()
        .map(super::features::colmap_depth_range)
        .collect()
}

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

#[cfg(test)]
mod tests {
    use super::*;
    use vp_scene::raster::RgbImage;
    use vp_scene::Material;

    /// Issue 34: SfM's sparse points came from exact visibility on the true
    /// mesh whatever the texture. Now an image observes a candidate only
    /// where a feature detector fires on it: a flat, untextured image of
    /// the same view observes none, the rendered (textured) one many.
    #[test]
    fn sparse_points_need_texture_where_the_detector_fires() {
        let mesh = crate::test_scenes::uniform_plane(60.0, Material::Ground);
        let caster = RayCaster::new(&mesh);
        let candidates = SparseCandidates::new(&mesh, 0.5, 3);
        let k = crate::test_scenes::intrinsics(240, 160);
        let cam = Camera::from_yaw_pitch(
            k,
            Point3::new(30.0, 30.0, 25.0),
            0.0,
            -std::f64::consts::FRAC_PI_2,
        );
        let rp = crate::render::RenderParams {
            texture_seed: 5,
            ..crate::render::RenderParams::default()
        };
        let textured = crate::render::render(&mesh, &caster, &cam, &rp).unwrap();
        let flat = RgbImage::from_pixel(240, 160, image::Rgb([120, 110, 90]));
        let count = |img: &RgbImage| {
            let mask = FeatureMask::detect(img);
            candidates
                .observed(&caster, &cam, &mask)
                .into_iter()
                .filter(|&o| o)
                .count()
        };
        let in_view = candidates
            .points
            .iter()
            .filter(|(p, _)| cam.project_in_frame(p).is_some())
            .count();
        assert_eq!(count(&flat), 0, "sparse points on an untextured surface");
        let on_texture = count(&textured.rgb);
        assert!(
            on_texture > in_view / 4 && on_texture <= in_view,
            "{on_texture} of {in_view} candidates in view observed on the textured render"
        );
        // Tracks need two observing images.
        let mask = FeatureMask::detect(&textured.rgb);
        let one = candidates.tracks(&caster, &[(&cam, &mask)], 2, 0.0);
        assert!(one.is_empty());
        let two = candidates.tracks(&caster, &[(&cam, &mask), (&cam, &mask)], 2, 0.0);
        assert_eq!(two.len(), on_texture);
    }

    /// COLMAP's rule over the depths each view's sparse points have in its
    /// SfM camera, and no range for a view without points.
    #[test]
    fn depth_ranges_come_from_each_views_sparse_points() {
        let k = crate::test_scenes::intrinsics(64, 48);
        let down = |z: f64| {
            Camera::from_yaw_pitch(
                k,
                Point3::new(0.0, 0.0, z),
                0.0,
                -std::f64::consts::FRAC_PI_2,
            )
        };
        let (a, b, c) = (down(10.0), down(20.0), down(30.0));
        let tracks: Vec<(usize, Point3<f64>, Vec<usize>)> = (0..4)
            .map(|i| (i, Point3::new(0.0, 0.0, f64::from(i as u32)), vec![0, 1]))
            .collect();
        let r = sparse_depth_ranges(&tracks, &[&a, &b, &c]);
        // View 0 at 10 m: depths 7..10; view 1 at 20 m: 17..20.
        let close = |r: Option<(f64, f64)>, lo: f64, hi: f64| {
            r.is_some_and(|(a, b)| (a - lo).abs() < 1e-9 && (b - hi).abs() < 1e-9)
        };
        assert!(close(r[0], 7.0 * 0.75, 10.0 * 1.25), "{:?}", r[0]);
        assert!(close(r[1], 17.0 * 0.75, 20.0 * 1.25), "{:?}", r[1]);
        assert_eq!(r[2], None);
    }
}
