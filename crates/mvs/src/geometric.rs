//! Geometric consistency between the views' depth maps (forward-backward
//! reprojection) and the filter built on it.

use rayon::prelude::*;
use vp_scene::triangulation::triangulation_angle_deg;

use crate::params::MvsParams;
use crate::patchmatch::DepthNormalMap;
use crate::view::{unproject, View};

/// The pixel of `source`'s map that agrees with pixel (x, y) of
/// `reference` at depth `d`: the point projects into the source, the
/// source's depth there projects back within `max_reproj_error_px` of
/// (x, y), and the two depths (in the reference frame) differ by at most
/// `max_depth_diff`. Returns the source pixel's index.
pub(crate) fn consistent_pixel(
    reference: &View,
    source: &View,
    source_map: &DepthNormalMap,
    x: usize,
    y: usize,
    d: f32,
    params: &MvsParams,
) -> Option<usize> {
    let p = unproject(&reference.camera, x, y, f64::from(d));
    let q = source.camera.project(&p)?;
    let (w, h) = (source_map.width as usize, source_map.height as usize);
    if !(q.x >= 0.0 && q.y >= 0.0) {
        return None;
    }
    let (qx, qy) = (q.x as usize, q.y as usize);
    if qx >= w || qy >= h {
        return None;
    }
    let idx = qy * w + qx;
    let ds = source_map.depth[idx];
    if !(ds > 0.0) {
        return None;
    }
    let back = unproject(&source.camera, qx, qy, f64::from(ds));
    let back_cam = reference
        .camera
        .world_from_cam
        .inverse_transform_point(&back);
    if !(back_cam.z > 0.0) {
        return None;
    }
    let k = reference.camera.intrinsics;
    let u = k.fx * back_cam.x / back_cam.z + k.cx;
    let v = k.fy * back_cam.y / back_cam.z + k.cy;
    let err = (u - (x as f64 + 0.5)).hypot(v - (y as f64 + 0.5));
    let ddiff = (back_cam.z - f64::from(d)).abs() / f64::from(d);
    (err <= f64::from(params.max_reproj_error_px) && ddiff <= f64::from(params.max_depth_diff))
        .then_some(idx)
}

/// Which pixels of `views[reference]`'s map keep their depth in the
/// geometric filter: those where at least `min_consistent_sources` of
/// `sources` (views with a map in `maps`) agree ([`consistent_pixel`]) and
/// the triangulation angle between the reference and the agreeing sources
/// is at least `min_triangulation_angle_deg`. `None` when the reference
/// has no map.
///
/// A mask rather than a filtered copy: every view's mask is computed from
/// the unfiltered maps, then applied in place ([`apply_keep`]), so a
/// workspace never holds the maps twice.
pub fn geometric_keep(
    views: &[View],
    maps: &[Option<DepthNormalMap>],
    reference: usize,
    sources: &[usize],
    params: &MvsParams,
) -> Option<Vec<bool>> {
    let map = maps.get(reference)?.as_ref()?;
    let view = &views[reference];
    let w = map.width as usize;
    let min_angle_deg = params.min_triangulation_angle_deg;
    let mut keep = vec![false; map.depth.len()];
    keep.par_chunks_mut(w)
        .zip(map.depth.par_chunks(w))
        .enumerate()
        .for_each(|(y, (keep, depth))| {
            let mut centres = Vec::with_capacity(sources.len() + 1);
            for x in 0..w {
                let d = depth[x];
                if !(d > 0.0) {
                    continue;
                }
                centres.clear();
                centres.push(view.camera.center());
                for &s in sources {
                    let Some(Some(sm)) = maps.get(s) else {
                        continue;
                    };
                    if consistent_pixel(view, &views[s], sm, x, y, d, params).is_some() {
                        centres.push(views[s].camera.center());
                    }
                }
                let p = unproject(&view.camera, x, y, f64::from(d));
                keep[x] = centres.len() > params.min_consistent_sources
                    && triangulation_angle_deg(&p, &centres) >= min_angle_deg;
            }
        });
    Some(keep)
}

/// Clears depth and normal of `map` where `keep` is false.
pub fn apply_keep(map: &mut DepthNormalMap, keep: &[bool]) {
    for ((d, n), &k) in map.depth.iter_mut().zip(&mut map.normal).zip(keep) {
        if !k {
            *d = 0.0;
            *n = [0.0; 3];
        }
    }
}

/// The photometric map of `views[reference]` after the geometric filter
/// ([`geometric_keep`]), as a copy.
pub fn geometric_filter(
    views: &[View],
    maps: &[Option<DepthNormalMap>],
    reference: usize,
    sources: &[usize],
    params: &MvsParams,
) -> Option<DepthNormalMap> {
    let keep = geometric_keep(views, maps, reference, sources, params)?;
    let mut out = maps[reference].clone()?;
    apply_keep(&mut out, &keep);
    Some(out)
}
