//! Stage 3, missing parts: pixels where the MVS produced nothing although it
//! should have been possible become negatives.
//!
//! A hole pixel of a query view is a negative when
//! 1. the surface along its ray (first hit on the input mesh) is visible in
//!    all three images of the triplet (inside the frame, in front, not
//!    occluded), and
//! 2. the evidence agrees that a surface is there: the depthmap augmentation
//!    (the median of the depths that supported reference measurements give
//!    the pixel through the query z-buffers) and both auxiliary meshes (the
//!    input mesh shrunk by neighbour smoothing and expanded again,
//!    [`vp_scene::mesh_ops::shrink_and_expand`]) put the surface at the same
//!    place along the ray within the uncertainty bound `k * sigma_ray` of the
//!    augmented point under the triplet's cameras.
//!
//! The label's angle is the triplet's triangulation angle at the mesh point.

use nalgebra::Point2;
use vp_scene::mesh_ops::shrink_and_expand;
use vp_scene::raycast::RayCaster;
use vp_scene::Mesh;

use vp_scene::triangulation::triangulation_angle_deg;

use crate::measurement::{pixel_point, ray_scale, sigma_along_ray, Prepared};
use crate::params::LabelParams;

/// The surface meshes of stage 3: the input mesh (for visibility) and its
/// shrunk and expanded versions, each with a BVH.
pub struct MissingPartMeshes {
    mesh: RayCaster,
    shrunk: RayCaster,
    expanded: RayCaster,
}

impl MissingPartMeshes {
    /// Builds the shrunk and expanded meshes (`iterations` of smoothing, the
    /// paper's 3) and the BVHs of all three.
    pub fn new(mesh: &Mesh, iterations: usize) -> Self {
        let se = shrink_and_expand(mesh, iterations);
        MissingPartMeshes {
            mesh: RayCaster::new(mesh),
            shrunk: RayCaster::new(&se.shrunk),
            expanded: RayCaster::new(&se.expanded),
        }
    }
}

/// A hole pixel whose mesh surface is visible in all three images.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Candidate {
    /// Linear pixel index in the query view.
    pub idx: usize,
    /// Triangulation angle at the mesh point, degrees.
    pub angle: f32,
}

/// Hole pixels of view `v` of `qp` that pass test 1.
pub(crate) fn candidates(
    qp: &Prepared<'_>,
    v: usize,
    meshes: &MissingPartMeshes,
) -> Vec<Candidate> {
    let view = &qp.rec.views[v];
    let w = view.depth.width as usize;
    let mut out = Vec::new();
    for (idx, &d) in view.depth.data.iter().enumerate() {
        if d > 0.0 {
            continue;
        }
        let px = Point2::new((idx % w) as f64 + 0.5, (idx / w) as f64 + 0.5);
        let (o, dir) = view.camera.ray(&px);
        let Some(hit) = meshes.mesh.closest_hit(&o, &dir, f64::INFINITY) else {
            continue;
        };
        let x = hit.point;
        let visible = qp.cameras.iter().all(|c| {
            let to_cam = c.center() - x;
            let dist = to_cam.norm();
            // Lift the point off its own surface towards the camera so that
            // f32 round-off in the BVH does not make it occlude itself.
            let lifted = x + to_cam * (1e-3f64.max(1e-4 * dist) / dist);
            c.project_in_frame(&x).is_some() && !meshes.mesh.occluded(&c.center(), &lifted)
        });
        if visible {
            out.push(Candidate {
                idx,
                angle: triangulation_angle_deg(&x, &qp.centres) as f32,
            });
        }
    }
    out
}

/// Test 2 for one candidate, given the augmentation depths collected from
/// the references (query optical-axis depths; reordered in place).
pub(crate) fn is_missing(
    qp: &Prepared<'_>,
    v: usize,
    cand: &Candidate,
    augmentation: &mut [f32],
    meshes: &MissingPartMeshes,
    params: &LabelParams,
) -> bool {
    if augmentation.is_empty() {
        return false;
    }
    let mid = augmentation.len() / 2;
    let (_, &mut d_aug, _) = augmentation.select_nth_unstable_by(mid, f32::total_cmp);
    let view = &qp.rec.views[v];
    let w = view.depth.width as usize;
    let (x, y) = (cand.idx % w, cand.idx / w);
    let p = pixel_point(&view.camera, x, y, f64::from(d_aug));
    let (o, dir) = view
        .camera
        .ray(&Point2::new(x as f64 + 0.5, y as f64 + 0.5));
    let Some(sigma) = sigma_along_ray(&qp.cameras, &p, &dir, params.sigma_px) else {
        return false;
    };
    let bound = params.k_sigma * sigma;
    let t_aug = f64::from(d_aug) * ray_scale(&view.camera, x, y);
    let agrees = |caster: &RayCaster| {
        caster
            .closest_hit(&o, &dir, f64::INFINITY)
            .is_some_and(|h| (h.t - t_aug).abs() <= bound)
    };
    agrees(&meshes.shrunk) && agrees(&meshes.expanded)
}
