//! The geometric term of PatchMatch's geometric pass (COLMAP's
//! geometric consistency, Schönberger et al. 2016): how far a depth,
//! carried into a source and back through that source's photometric
//! depth, lands from where it started.

use nalgebra::RealField;

use crate::maps::DepthNormalMap;
use crate::view::Relative;

/// What the geometric pass starts from: the photometric pass's results.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Photometric<'a> {
    /// Every view's unfiltered photometric map (`RawState::unfiltered`).
    pub maps: &'a [Option<DepthNormalMap>],
    /// Whether the reference's photometric pass scored exactly the sources
    /// of the geometric pass. Then, when every source is averaged (at most
    /// `top_k_sources` of them: a triplet's two), the reference map's costs
    /// are its planes' photometric costs, and the geometric pass's seed
    /// adds only the geometric term (`Problem::seed_photo`, patchmatch.rs).
    pub same_sources: bool,
}

/// A source's depth map from the photometric pass, for the geometric term.
pub(crate) struct GeomSource<'a> {
    pub depth: &'a [f32],
    /// Its normals (source camera frame), for [`surface_depth`].
    pub normal: &'a [[f32; 3]],
    pub width: usize,
    pub height: usize,
    /// Rotation from the source back to the reference frame (R^T).
    pub rot_back: [[f32; 3]; 3],
}

/// Forward-backward reprojection error (pixels) of depth `d` at pixel
/// (x, y) through source `g`, capped at `cap` (`geom_max_error_px`); `k`:
/// the reference's intrinsics (fx, fy, cx, cy).
pub(crate) fn reprojection_error(
    k: &[f32; 4],
    cap: f32,
    rel: &Relative,
    g: &GeomSource,
    xy: (usize, usize),
    ray: &[f32; 3],
    d: f32,
) -> f32 {
    reprojection(k, rel, g, xy, ray, d).map_or(cap, |(e, _)| e.min(cap))
}

/// Whether source `g`'s depth agrees with depth `d` at pixel (x, y) as the
/// geometric filter requires (`geometric::consistent_pixel`, in f32):
/// the forward-backward reprojection error is at most `max_px` pixels and
/// the depth carried back differs from `d` by at most `max_diff` of it.
#[allow(clippy::too_many_arguments)]
pub(crate) fn agrees(
    k: &[f32; 4],
    (max_px, max_diff): (f32, f32),
    rel: &Relative,
    g: &GeomSource,
    xy: (usize, usize),
    ray: &[f32; 3],
    d: f32,
) -> bool {
    reprojection(k, rel, g, xy, ray, d)
        .is_some_and(|(e, back)| e <= max_px && (back - d).abs() <= max_diff * d)
}

/// The forward-backward reprojection error (pixels) of depth `d` at pixel
/// (x, y) through source `g`, and the depth carried back into the
/// reference; `None` where the point or its return leaves a camera's front
/// or the source's map, or the source has no depth there.
fn reprojection(
    k: &[f32; 4],
    rel: &Relative,
    g: &GeomSource,
    (x, y): (usize, usize),
    ray: &[f32; 3],
    d: f32,
) -> Option<(f32, f32)> {
    let p = [ray[0] * d, ray[1] * d, d];
    let r = &rel.rot;
    let t = &rel.trans;
    let xs: [f32; 3] =
        std::array::from_fn(|i| r[i][0] * p[0] + r[i][1] * p[1] + r[i][2] * p[2] + t[i]);
    if !(xs[2] > 0.0) {
        return None;
    }
    let ks = &rel.k;
    let u = ks[0] * xs[0] / xs[2] + ks[2];
    let v = ks[1] * xs[1] / xs[2] + ks[3];
    if !(u >= 0.0 && v >= 0.0) || u as usize >= g.width || v as usize >= g.height {
        return None;
    }
    let (qx, qy) = (u as usize, v as usize);
    let at = qy * g.width + qx;
    let ds = g.depth[at];
    if !(ds > 0.0) {
        return None;
    }
    // The source's surface point on the ray through (u, v) itself.
    let centre = [
        (qx as f32 + 0.5 - ks[2]) / ks[0],
        (qy as f32 + 0.5 - ks[3]) / ks[1],
    ];
    let exact = [(u - ks[2]) / ks[0], (v - ks[3]) / ks[1]];
    let ([sx, sy], sd) = g
        .normal
        .get(at)
        .and_then(|&n| surface_depth(n, ds, centre, exact))
        .map_or((centre, ds), |dq| (exact, dq));
    let q = [sx * sd - t[0], sy * sd - t[1], sd - t[2]];
    let b = &g.rot_back;
    let xr: [f32; 3] = std::array::from_fn(|i| b[i][0] * q[0] + b[i][1] * q[1] + b[i][2] * q[2]);
    if !(xr[2] > 0.0) {
        return None;
    }
    let du = k[0] * xr[0] / xr[2] + k[2] - (x as f32 + 0.5);
    let dv = k[1] * xr[1] / xr[2] + k[3] - (y as f32 + 0.5);
    Some(((du * du + dv * dv).sqrt(), xr[2]))
}

/// The depth, on the ray (x, y, 1) of camera coordinates `exact`, of the
/// plane of a depth map's pixel: depth `d` on the ray through the pixel's
/// centre `centre`, normal `n`. The forward-backward check reads a
/// source's depth map at the pixel its point falls in; taking that
/// pixel's centre instead of the point's own ray moves the point up to
/// half a pixel sideways and, on a slanted surface, along the depth too,
/// so that two depths that agree could read up to 0.7 px and more than
/// the depth bound apart. `None` where the plane does not cross the ray
/// in front of the camera (a zero normal: no plane). In f32 here, in f64
/// in the geometric filter (`geometric::consistent_pixel`).
pub(crate) fn surface_depth<T: RealField + Copy>(
    n: [T; 3],
    d: T,
    centre: [T; 2],
    exact: [T; 2],
) -> Option<T> {
    let num = d * (n[0] * centre[0] + n[1] * centre[1] + n[2]);
    let dq = num / (n[0] * exact[0] + n[1] * exact[1] + n[2]);
    (dq.is_finite() && dq > T::zero()).then_some(dq)
}
