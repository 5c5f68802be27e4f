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
    /// Splits the ROI faces of `world`'s true mesh.
    pub fn new(world: &World, cfg: &CampaignConfig) -> Result<Self> {
        let faces = roi_faces(&world.site.mesh, &world.roi);
        let roi = submesh(&world.site.mesh, &faces);
        let (split, _) = split_faces(&roi, cfg.eval.split_edge_m)?;
        Ok(EvalMesh {
            centroids: split.face_centroids(),
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
}
