//! Stage 2, weighted voting, and the assembly of a view's label image.
//!
//! Reference measurements with support >= `min_support` vote on every query
//! measurement (paper Fig. 2), at most once per reference reconstruction:
//! - positive when the reference's z-buffered measurement at the query pixel
//!   lies within the query's uncertainty bound along the query ray;
//! - negative when it lies in front of the query point beyond the bound (the
//!   reference blocks the query's line of sight), or when the query point lies
//!   in front of a reference measurement beyond the bound on that reference's
//!   own ray (the query blocks the reference's line of sight).
//!
//! A vote weighs `support / sigma_ray` of the voting measurement (support x
//! inverse 3D uncertainty). Label: positive if the positive sum exceeds the
//! negative sum, negative if below; ties and pixels without votes stay
//! unlabelled [vpctl]. Sums run over references in id order, so the floating
//! point result does not depend on the input order.

use nalgebra::Point3;
use vp_scene::raster::{Label, LabelImage};

use crate::measurement::{ray_scale, splat, Prepared};
use crate::missing::{candidates, is_missing, MissingPartMeshes};
use crate::params::LabelParams;

/// Counts of one labelled view, by origin of the label.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ViewCounts {
    /// Pixels with a measurement.
    pub measured: usize,
    /// Positive labels (stage 2).
    pub positive: usize,
    /// Negative labels from voting (stage 2).
    pub negative_voted: usize,
    /// Negative labels for missing parts (stage 3).
    pub negative_missing: usize,
}

/// Weight of the strongest reference measurement whose line of sight the
/// query point `p` blocks, or 0.
fn blocks_reference(
    p: &Point3<f64>,
    bound: f64,
    rp: &Prepared<'_>,
    support: &[Vec<u16>; 3],
    params: &LabelParams,
) -> f32 {
    let mut best = 0.0f32;
    for (rv, (cam, sup)) in rp.cameras.iter().zip(support).enumerate() {
        let Some(px) = cam.project_in_frame(p) else {
            continue;
        };
        let (x, y) = (px.x as usize, px.y as usize);
        let depth = &rp.rec.views[rv].depth;
        let ridx = y * depth.width as usize + x;
        let s = sup[ridx];
        let sigma = rp.data[rv].sigma[ridx];
        if s < params.min_support || sigma <= 0.0 {
            continue;
        }
        let t_query = (p - cam.center()).norm();
        // The nearest reference surface around the pixel: at a depth edge the
        // query point may project next to the pixel that saw it.
        let w = depth.width as usize;
        let t_ref = neighbourhood(x, y, w, depth.height as usize)
            .map(|(nx, ny)| (nx, ny, depth.data[ny * w + nx]))
            .filter(|&(_, _, d)| d > 0.0)
            .map(|(nx, ny, d)| f64::from(d) * ray_scale(cam, nx, ny))
            .fold(f64::INFINITY, f64::min);
        if t_ref.is_finite() && t_ref > t_query + bound {
            best = best.max(f32::from(s) / sigma);
        }
    }
    best
}

/// Pixels of the 3x3 neighbourhood of (x, y) inside a w x h image.
fn neighbourhood(x: usize, y: usize, w: usize, h: usize) -> impl Iterator<Item = (usize, usize)> {
    (y.saturating_sub(1)..(y + 2).min(h))
        .flat_map(move |ny| (x.saturating_sub(1)..(x + 2).min(w)).map(move |nx| (nx, ny)))
}

/// Whether a reference depth `dz` (query optical axis) in front of query
/// pixel `idx` matches the query's own depth at a neighbouring pixel: then it
/// is the other side of a depth edge seen at sub-pixel offset, not a
/// free-space violation.
fn edge_explains(
    cam: &vp_scene::Camera,
    depth: &[f32],
    idx: usize,
    w: usize,
    h: usize,
    dz: f32,
    bound: f64,
) -> bool {
    neighbourhood(idx % w, idx / w, w, h).any(|(nx, ny)| {
        let d = depth[ny * w + nx];
        d > 0.0 && (f64::from(d) - f64::from(dz)).abs() * ray_scale(cam, nx, ny) <= bound
    })
}

/// The label image of view `v` of reconstruction `q`, given every
/// reconstruction's stage-1 support and the references of `q` (id order).
pub(crate) fn label_view(
    prepared: &[Prepared<'_>],
    supports: &[[Vec<u16>; 3]],
    q: usize,
    v: usize,
    refs: &[usize],
    meshes: Option<&MissingPartMeshes>,
    params: &LabelParams,
) -> (LabelImage, ViewCounts) {
    let qp = &prepared[q];
    let cam = &qp.cameras[v];
    let depth = &qp.rec.views[v].depth;
    let (w, h) = (depth.width as usize, depth.height as usize);
    let n = w * h;
    let mut pos = vec![0f32; n];
    let mut neg = vec![0f32; n];
    let holes = meshes.map(|m| candidates(qp, v, m)).unwrap_or_default();
    let mut augmentation: Vec<Vec<f32>> = vec![Vec::new(); holes.len()];
    for &r in refs {
        let rp = &prepared[r];
        let sup = &supports[r];
        let zb = splat(cam, rp, params.max_splat_radius, |rv, ridx| {
            let s = sup[rv][ridx];
            (s >= params.min_support).then(|| f32::from(s) / rp.data[rv].sigma[ridx])
        });
        for idx in 0..n {
            let Some(p) = qp.point(v, idx) else { continue };
            let bound = params.k_sigma * f64::from(qp.data[v].sigma[idx]);
            let mut blocked = 0.0f32;
            if let Some((dz, wz)) = zb.get(idx) {
                let along =
                    (f64::from(dz) - f64::from(depth.data[idx])) * ray_scale(cam, idx % w, idx / w);
                if along.abs() <= bound {
                    pos[idx] += wz;
                    continue;
                }
                if along < -bound && !edge_explains(cam, &depth.data, idx, w, h, dz, bound) {
                    blocked = wz;
                }
            }
            blocked = blocked.max(blocks_reference(&p, bound, rp, sup, params));
            neg[idx] += blocked;
        }
        for (hole, aug) in holes.iter().zip(&mut augmentation) {
            if let Some((dz, _)) = zb.get(hole.idx) {
                aug.push(dz);
            }
        }
    }
    let mut labels = LabelImage::new(w as u32, h as u32);
    let mut counts = ViewCounts::default();
    let angles = &qp.data[v].angle;
    for idx in 0..n {
        if qp.data[v].sigma[idx] <= 0.0 {
            continue;
        }
        counts.measured += 1;
        let label = if pos[idx] > neg[idx] {
            counts.positive += 1;
            Label::Positive
        } else if pos[idx] < neg[idx] {
            counts.negative_voted += 1;
            Label::Negative
        } else {
            continue;
        };
        // Angles are finite and non-negative for every measurement (set
        // together with sigma), so `set` cannot fail here.
        let _ = labels.set((idx % w) as u32, (idx / w) as u32, label, angles[idx]);
    }
    if let Some(m) = meshes {
        for (hole, aug) in holes.iter().zip(&mut augmentation) {
            if is_missing(qp, v, hole, aug, m, params) {
                counts.negative_missing += 1;
                let _ = labels.set(
                    (hole.idx % w) as u32,
                    (hole.idx / w) as u32,
                    Label::Negative,
                    hole.angle,
                );
            }
        }
    }
    (labels, counts)
}
