//! The evaluation of the paper's Table 1 on the true mesh.
//!
//! ROI faces are split to `eval.split_edge_m`. A camera of a successful
//! reconstruction (a triplet, or a Grid image with its sources; see
//! `eval.min_output_share`) measures a face when the face is front-facing
//! (true camera), the face's centroid projects into its depth map, and the
//! reconstructed depth at that pixel lies within `eval.depth_tolerance_m`
//! of the face's depth (the paper's 24 cm rule), both seen from the SfM
//! camera the depth map belongs to: the reconstructed point lies on the
//! face. A depth far behind the face (the ground behind a grass tuft) or in
//! front of it (an occluder) does not measure it.
//! Coverage: faces measured by at least c distinct cameras. Per face and
//! measuring reconstruction, f_res and f_unc follow M1
//! (docs/design.md#m1-quality-fulfillment) with the true cameras of the
//! reconstruction (a Grid image: it and its sources) (f_conf is what
//! happened, so it is not applied); each face keeps
//! the best triplet's f_res, f_unc and `alpha f_res + (1 - alpha) f_unc`,
//! multiplied by f_cov; the table reports their means over the ROI faces.
//!
//! Grass is evaluated as the surface it makes, not blade by blade. The
//! paper's evaluation mesh came from a dense reconstruction of about 500
//! images ("a guideline"): of a meadow it holds the top of the grass, not
//! each blade. A blade of the true mesh is one tilted, one-sided triangle
//! a few centimetres wide, most of it hidden by others, that no three
//! cameras all see from its front: as evaluation faces, a meadow's hundreds
//! of thousands of blades made coverage the share of blades seen, near 0
//! for every strategy. So grass faces are left out, and each ground face is
//! raised by the mean height of the grass top over it ([`grass_top`]):
//! bare ground stays where it is, a meadow becomes the surface a camera
//! sees.

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;
use serde::Serialize;
use vp_planner::quality::{CamTerm, Requirements};
use vp_scene::colmap::DepthMap;
use vp_scene::mesh_ops::{split_faces, submesh};
use vp_scene::{Camera, Material};

use super::reconstruct::Flown;
use crate::config::CampaignConfig;
use crate::error::Result;
use crate::world::{roi_faces, World};

/// The split ROI faces of the true mesh.
pub struct EvalMesh {
    /// Centroids.
    pub centroids: Vec<Point3<f64>>,
    /// Unit normals.
    pub normals: Vec<Vector3<f64>>,
    /// Whether each face is rock.
    pub rock: Vec<bool>,
}

impl EvalMesh {
    /// Splits the ROI faces of `world`'s true mesh, grass left out and the
    /// ground raised to the top of the grass on it (see the module docs).
    pub fn new(world: &World, cfg: &CampaignConfig) -> Result<Self> {
        let mesh = &world.site.mesh;
        let faces: Vec<u32> = roi_faces(mesh, &world.roi)
            .into_iter()
            .filter(|&f| mesh.material(f as usize) != Some(Material::Grass))
            .collect();
        let roi = submesh(mesh, &faces);
        let (split, _) = split_faces(&roi, cfg.eval.split_edge_m)?;
        let mut centroids = split.face_centroids();
        centroids
            .par_iter_mut()
            .enumerate()
            .filter(|(f, _)| split.material(*f) == Some(Material::Ground))
            .for_each(|(_, c)| {
                let lift = grass_top(world, c);
                if lift > 0.0 {
                    c.z += lift;
                }
            });
        Ok(EvalMesh {
            centroids,
            normals: split.face_normals(),
            rock: (0..split.n_faces())
                .map(|f| split.material(f) == Some(Material::Rock))
                .collect(),
        })
    }

    /// Number of faces.
    pub fn len(&self) -> usize {
        self.centroids.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.centroids.is_empty()
    }
}

/// Side of the 3 x 3 grid of vertical rays that measures the grass top
/// over a ground face, metres: about the evaluation faces' size.
const GRASS_TOP_SPACING: f64 = 0.1;
/// The rays start this far above the ground face, metres: over the tallest
/// blades (40 cm), under the lowest branches.
const GRASS_TOP_START: f64 = 1.0;

/// Mean height of the grass over the ground around `p` (a ground point):
/// vertical rays on a 3 x 3 grid around it, each adding its first hit's
/// height above the bare ground when that hit is grass and nothing when it
/// is the ground itself or anything else (a marker, a trunk). 0 on bare
/// ground; gaps in a meadow lower it, as they lower what a camera sees.
fn grass_top(world: &World, p: &Point3<f64>) -> f64 {
    let down = -Vector3::z();
    let mut sum = 0.0;
    for i in -1..=1 {
        for j in -1..=1 {
            let (x, y) = (
                p.x + f64::from(i) * GRASS_TOP_SPACING,
                p.y + f64::from(j) * GRASS_TOP_SPACING,
            );
            let origin = Point3::new(x, y, p.z + GRASS_TOP_START);
            let Some(hit) = world
                .caster
                .closest_hit(&origin, &down, 2.0 * GRASS_TOP_START)
            else {
                continue;
            };
            if world.site.mesh.material(hit.face as usize) == Some(Material::Grass) {
                sum += (hit.point.z - world.site.surface_height(x, y)).max(0.0);
            }
        }
    }
    sum / 9.0
}

/// Table-1 figures of one image set, in percent (success in percent too).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct Scores {
    /// Share of ROI faces measured by at least c cameras.
    pub coverage: f64,
    /// Mean f_res (times f_cov).
    pub f_res: f64,
    /// Mean f_unc (times f_cov).
    pub f_unc: f64,
    /// Mean f.
    pub f: f64,
    /// Coverage of the rock faces alone.
    pub rock_coverage: f64,
    /// Triplets with any 3D output over triplets flown (None for none flown).
    pub triplet_success: Option<f64>,
    /// Distinct images.
    pub n_images: usize,
    /// Smallest distance of the flown paths to the true surface, metres
    /// (infinite when nothing was flown; see [`super::crash`]).
    pub min_clearance_m: f64,
    /// Waypoints and segments of the flown paths closer than the safety
    /// distance to the true surface.
    pub safety_violations: usize,
}

/// Whether the depth map `depth` of the SfM camera `sfm` holds a depth
/// within `tol` of point `p`'s at the pixel `p` projects to: the 24 cm
/// rule, on the face and not anywhere behind it.
pub fn measures(sfm: &Camera, depth: &DepthMap, p: &Point3<f64>, tol: f64) -> bool {
    let Some(px) = sfm.project_in_frame(p) else {
        return false;
    };
    let (x, y) = (px.x as usize, px.y as usize);
    if x >= depth.width as usize || y >= depth.height as usize {
        return false;
    }
    let z = f64::from(depth.data[y * depth.width as usize + x]);
    let face_z = (p - sfm.center()).dot(&sfm.axis());
    z > 0.0 && (z - face_z).abs() <= tol
}

/// Scores of `flown` on `em`; also returns each face's f (0..1) for maps.
pub fn evaluate(
    em: &EvalMesh,
    flown: &[&Flown],
    cfg: &CampaignConfig,
) -> Result<(Scores, Vec<f64>)> {
    let pc = &cfg.planner;
    let req = Requirements {
        r_desired: 1.0 / (pc.gsd_m * pc.gsd_m),
        accuracy: pc.accuracy_m,
        alpha: pc.alpha,
        bins: pc.angle_bins()?,
    };
    let tol = cfg.eval.depth_tolerance_m;
    let c_min = cfg.eval.min_cameras;
    let ok: Vec<&Flown> = flown.iter().copied().filter(|f| f.success).collect();
    let per_face: Vec<(f64, f64, f64, bool)> = (0..em.len())
        .into_par_iter()
        .with_min_len(64)
        .map(|i| {
            let (p, n) = (em.centroids[i], em.normals[i]);
            let mut ids: Vec<u64> = Vec::new();
            let (mut best_res, mut best_unc, mut best_q) = (0f64, 0f64, 0f64);
            for fl in &ok {
                let mut any = false;
                for (v, cam) in fl.cams.iter().enumerate() {
                    if n.dot(&(cam.center() - p)) <= 0.0 {
                        continue;
                    }
                    if measures(&fl.sfm[v], &fl.depth[v], &p, tol) {
                        any = true;
                        ids.push(fl.ids[v]);
                    }
                }
                if any {
                    let t: Vec<CamTerm> = fl
                        .cams
                        .iter()
                        .map(|cam| CamTerm::new(cam, &p, &n, pc.sigma_px))
                        .collect();
                    let r_min = t.iter().map(|t| t.r).fold(f64::INFINITY, f64::min);
                    let f_res = req.f_res(r_min);
                    let info = t.iter().fold(nalgebra::Matrix3::zeros(), |a, t| a + t.info);
                    let f_unc = req.f_unc(&info);
                    best_res = best_res.max(f_res);
                    best_unc = best_unc.max(f_unc);
                    best_q = best_q.max(req.alpha * f_res + (1.0 - req.alpha) * f_unc);
                }
            }
            ids.sort_unstable();
            ids.dedup();
            let covered = ids.len() >= c_min;
            let cov = if covered { 1.0 } else { 0.0 };
            (best_res * cov, best_unc * cov, best_q * cov, covered)
        })
        .collect();
    let n = em.len().max(1) as f64;
    let mean =
        |k: fn(&(f64, f64, f64, bool)) -> f64| 100.0 * per_face.iter().map(k).sum::<f64>() / n;
    let n_rock = em.rock.iter().filter(|&&r| r).count().max(1) as f64;
    let rock_cov = per_face
        .iter()
        .zip(&em.rock)
        .filter(|(f, &r)| r && f.3)
        .count() as f64;
    let mut images: Vec<u64> = flown.iter().flat_map(|f| f.ids.iter().copied()).collect();
    images.sort_unstable();
    images.dedup();
    let success = (!flown.is_empty())
        .then(|| 100.0 * flown.iter().filter(|f| f.success).count() as f64 / flown.len() as f64);
    let scores = Scores {
        coverage: mean(|f| if f.3 { 1.0 } else { 0.0 }),
        f_res: mean(|f| f.0),
        f_unc: mean(|f| f.1),
        f: mean(|f| f.2),
        rock_coverage: 100.0 * rock_cov / n_rock,
        triplet_success: success,
        n_images: images.len(),
        min_clearance_m: f64::INFINITY,
        safety_violations: 0,
    };
    Ok((scores, per_face.iter().map(|f| f.2).collect()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use vp_scene::Intrinsics;

    /// Regression: a pixel whose depth lay anywhere behind a face measured
    /// it, so vegetation counted as covered when the ground behind it was
    /// reconstructed.
    #[test]
    fn a_depth_behind_the_face_does_not_measure_it() {
        let k = Intrinsics::from_hfov(64, 48, 60.0).unwrap();
        let cam = Camera::from_yaw_pitch(
            k,
            Point3::new(0.0, 0.0, 20.0),
            0.0,
            -std::f64::consts::FRAC_PI_2,
        );
        // A grass tuft 1 m above the ground, straight below the camera.
        let tuft = Point3::new(0.0, 0.0, 1.0);
        let map = |z: f32| DepthMap {
            width: 64,
            height: 48,
            data: vec![z; 64 * 48],
        };
        // The ground (20 m away) reconstructed behind the tuft (19 m).
        assert!(!measures(&cam, &map(20.0), &tuft, 0.24));
        // An occluder 1 m in front of it.
        assert!(!measures(&cam, &map(18.0), &tuft, 0.24));
        // On the face, within 24 cm either way.
        assert!(measures(&cam, &map(19.2), &tuft, 0.24));
        assert!(measures(&cam, &map(18.8), &tuft, 0.24));
        assert!(!measures(&cam, &map(0.0), &tuft, 0.24));
    }

    /// A meadow is evaluated as the top of its grass: the same faces as the
    /// bare site (no blade among them), the ground's raised by a plausible
    /// grass height, everything else where it was.
    #[test]
    fn a_meadow_is_evaluated_as_the_top_of_its_grass() {
        let mut cfg = CampaignConfig::quick();
        cfg.site.n_grass_tufts = Some(0);
        let bare = World::new(&cfg, 3).unwrap();
        cfg.site.meadow = 1.0;
        let lush = World::new(&cfg, 3).unwrap();
        let (eb, el) = (
            EvalMesh::new(&bare, &cfg).unwrap(),
            EvalMesh::new(&lush, &cfg).unwrap(),
        );
        // Without grass, the faces are the ROI's split faces, untouched.
        let faces = roi_faces(&bare.site.mesh, &bare.roi);
        let (split, _) =
            split_faces(&submesh(&bare.site.mesh, &faces), cfg.eval.split_edge_m).unwrap();
        assert!(eb.centroids == split.face_centroids());
        assert_eq!(el.len(), eb.len(), "no blade is an evaluation face");
        let lifts: Vec<f64> = el
            .centroids
            .iter()
            .zip(&eb.centroids)
            .map(|(l, b)| {
                assert_eq!((l.x, l.y), (b.x, b.y));
                l.z - b.z
            })
            .collect();
        assert!(lifts.iter().all(|&d| (0.0..0.4).contains(&d)));
        assert!(lifts.iter().zip(&el.rock).all(|(&d, &r)| !r || d == 0.0));
        let raised: Vec<f64> = lifts.iter().copied().filter(|&d| d > 0.0).collect();
        let ground = el.rock.iter().filter(|&&r| !r).count();
        assert!(
            raised.len() * 2 > ground,
            "{} of {ground} raised",
            raised.len()
        );
        let mean = raised.iter().sum::<f64>() / raised.len() as f64;
        assert!((0.05..0.3).contains(&mean), "mean grass top {mean:.3} m");
    }
}
