//! Measurements of a triplet reconstruction: per depthmap pixel a 3D point,
//! its triangulation angle and its 3D uncertainty; and the z-buffer that
//! projects one reconstruction's measurements into another's image.
//!
//! A measurement is never stored as a point: the depth and the camera give it
//! back in a few operations, so a reconstruction costs 12 bytes per pixel
//! (depth, sigma, angle) in memory.

use nalgebra::{Point2, Point3, Vector3};
use vp_scene::colmap::DepthMap;
use vp_scene::triangulation::{point_covariance, sigma_along, triangulation_angle_deg};
use vp_scene::{Aabb, Camera};

use crate::error::{LabelgenError, Result};
use crate::params::LabelParams;

/// One image of a triplet reconstruction: its name, its camera at the
/// depthmap's resolution, and the depthmap (depth along the optical axis,
/// 0 where the MVS produced nothing).
#[derive(Debug, Clone)]
pub struct View {
    /// Image name as in the COLMAP model; two reconstructions sharing a name
    /// are not independent.
    pub name: String,
    /// The camera with intrinsics scaled to the depthmap's size.
    pub camera: Camera,
    /// The depthmap.
    pub depth: DepthMap,
}

/// One reconstruction: the MVS output of one triplet at one pyramid level.
#[derive(Debug, Clone)]
pub struct TripletReconstruction {
    /// Unique id (e.g. `t0003/level2`); labels are reported under it and
    /// references are visited in the order of their ids, which makes the
    /// result independent of the order of the input.
    pub id: String,
    /// The three views.
    pub views: [View; 3],
}

impl TripletReconstruction {
    /// Checks sizes and values: each depthmap matches its camera's size, has
    /// only finite non-negative depths; the three names differ.
    pub fn validate(&self) -> Result<()> {
        for v in &self.views {
            let k = v.camera.intrinsics;
            if (k.width, k.height) != (v.depth.width, v.depth.height)
                || v.depth.data.len() != k.width as usize * k.height as usize
            {
                return Err(LabelgenError::InvalidArgument(format!(
                    "{} image {}: depthmap is {}x{} but the camera is {}x{}",
                    self.id, v.name, v.depth.width, v.depth.height, k.width, k.height
                )));
            }
            if let Some(i) = v
                .depth
                .data
                .iter()
                .position(|d| !(d.is_finite() && *d >= 0.0))
            {
                return Err(LabelgenError::InvalidArgument(format!(
                    "{} image {}: depth {} at pixel ({}, {}) (expected finite and >= 0)",
                    self.id,
                    v.name,
                    v.depth.data[i],
                    i % k.width as usize,
                    i / k.width as usize
                )));
            }
        }
        let [a, b, c] = &self.views;
        if a.name == b.name || a.name == c.name || b.name == c.name {
            return Err(LabelgenError::InvalidArgument(format!(
                "{}: a triplet needs three different images",
                self.id
            )));
        }
        Ok(())
    }

    /// Whether the two reconstructions share no image (the paper's
    /// "independent image sets").
    pub fn independent_of(&self, other: &TripletReconstruction) -> bool {
        self.views
            .iter()
            .all(|a| other.views.iter().all(|b| a.name != b.name))
    }
}

/// Standard deviation along unit direction `dir` of `p` triangulated from
/// `cameras` (see [`vp_scene::triangulation`]); `None` when they cannot fix
/// the point.
pub(crate) fn sigma_along_ray(
    cameras: &[Camera],
    p: &Point3<f64>,
    dir: &Vector3<f64>,
    sigma_px: f64,
) -> Option<f64> {
    point_covariance(cameras, p, sigma_px).map(|cov| sigma_along(&cov, dir))
}

/// Length of the ray through pixel centre (x, y) per unit of depth: depth
/// times this is the distance from the camera centre.
#[inline]
pub(crate) fn ray_scale(camera: &Camera, x: usize, y: usize) -> f64 {
    let k = &camera.intrinsics;
    let u = (x as f64 + 0.5 - k.cx) / k.fx;
    let v = (y as f64 + 0.5 - k.cy) / k.fy;
    (u * u + v * v + 1.0).sqrt()
}

/// Per-pixel data derived from one view's depthmap.
#[derive(Debug, Clone)]
pub(crate) struct ViewData {
    /// Standard deviation along the pixel ray, metres; 0 where the pixel
    /// has no usable measurement.
    pub sigma: Vec<f32>,
    /// Triangulation angle at the measurement, degrees.
    pub angle: Vec<f32>,
}

/// A reconstruction with the per-measurement quantities computed once.
#[derive(Debug)]
pub(crate) struct Prepared<'a> {
    pub rec: &'a TripletReconstruction,
    pub cameras: [Camera; 3],
    pub centres: [Point3<f64>; 3],
    /// Mean camera centre of the triplet.
    pub mean_centre: Point3<f64>,
    /// Mean focal length at depthmap resolution, pixels.
    pub mean_focal: f64,
    pub data: [ViewData; 3],
    /// Bounds of all measurements.
    pub bounds: Aabb,
}

impl<'a> Prepared<'a> {
    pub(crate) fn new(rec: &'a TripletReconstruction, params: &LabelParams) -> Self {
        let cameras = rec.views.clone().map(|v| v.camera);
        let centres = cameras.map(|c| c.center());
        let mean_centre =
            Point3::from((centres[0].coords + centres[1].coords + centres[2].coords) / 3.0);
        let mean_focal = cameras.iter().map(|c| c.intrinsics.focal()).sum::<f64>() / 3.0;
        let mut bounds = Aabb::empty();
        let data = std::array::from_fn(|i| {
            let v = &rec.views[i];
            let w = v.depth.width as usize;
            let n = v.depth.data.len();
            let mut sigma = vec![0f32; n];
            let mut angle = vec![f32::NAN; n];
            for (idx, &d) in v.depth.data.iter().enumerate() {
                if d <= 0.0 {
                    continue;
                }
                let (x, y) = (idx % w, idx / w);
                let p = pixel_point(&v.camera, x, y, f64::from(d));
                let (_, dir) = v.camera.ray(&Point2::new(x as f64 + 0.5, y as f64 + 0.5));
                if let Some(s) = sigma_along_ray(&cameras, &p, &dir, params.sigma_px) {
                    sigma[idx] = s as f32;
                    angle[idx] = triangulation_angle_deg(&p, &centres) as f32;
                    bounds.grow(&p);
                }
            }
            ViewData { sigma, angle }
        });
        Prepared {
            rec,
            cameras,
            centres,
            mean_centre,
            mean_focal,
            data,
            bounds,
        }
    }

    /// Whether the two reconstructions' measurements can overlap in space,
    /// with a margin for their uncertainty.
    pub(crate) fn may_overlap(&self, other: &Prepared<'_>, margin: f64) -> bool {
        (0..3).all(|k| {
            self.bounds.min[k] - margin <= other.bounds.max[k]
                && other.bounds.min[k] - margin <= self.bounds.max[k]
        })
    }

    /// Resolution of this triplet at `p`: mean focal over distance from the mean centre.
    pub(crate) fn resolution_at(&self, p: &Point3<f64>) -> f64 {
        self.mean_focal / (self.mean_centre - p).norm()
    }

    /// The measurement of view `v` at linear pixel index `idx`, if any.
    #[inline]
    pub(crate) fn point(&self, v: usize, idx: usize) -> Option<Point3<f64>> {
        if self.data[v].sigma[idx] <= 0.0 {
            return None;
        }
        let view = &self.rec.views[v];
        let w = view.depth.width as usize;
        Some(pixel_point(
            &view.camera,
            idx % w,
            idx / w,
            f64::from(view.depth.data[idx]),
        ))
    }
}

/// The world point at pixel centre (x, y) with depth `d`.
#[inline]
pub(crate) fn pixel_point(camera: &Camera, x: usize, y: usize, d: f64) -> Point3<f64> {
    camera.unproject(&Point2::new(x as f64 + 0.5, y as f64 + 0.5), d)
}

/// The nearest reference measurement per query pixel: depth along the
/// query's optical axis and the voter's weight.
pub(crate) struct ZBuffer {
    pub depth: Vec<f32>,
    pub weight: Vec<f32>,
}

impl ZBuffer {
    /// Depth at `idx`, if a measurement landed there.
    #[inline]
    pub(crate) fn get(&self, idx: usize) -> Option<(f32, f32)> {
        let d = self.depth[idx];
        d.is_finite().then(|| (d, self.weight[idx]))
    }
}

/// Projects the measurements of `reference` accepted by `weight_of` (view,
/// pixel index -> weight, `None` to skip) into `query` and keeps the nearest
/// per pixel. Each measurement covers a square of query pixels as wide as its
/// own pixel footprint appears in the query (capped by `max_radius`).
///
/// # Performance
/// One projection per reference measurement; memory two floats per query pixel.
pub(crate) fn splat<F>(
    query: &Camera,
    reference: &Prepared<'_>,
    max_radius: u32,
    weight_of: F,
) -> ZBuffer
where
    F: Fn(usize, usize) -> Option<f32>,
{
    let k = query.intrinsics;
    let (w, h) = (k.width as usize, k.height as usize);
    let mut zb = ZBuffer {
        depth: vec![f32::INFINITY; w * h],
        weight: vec![0.0; w * h],
    };
    let cam_from_world = query.cam_from_world();
    let fq = k.focal();
    for v in 0..3 {
        let view = &reference.rec.views[v];
        let kr = view.camera.intrinsics;
        let fr = kr.focal();
        // One rigid transform from the reference camera to the query camera,
        // applied to the back-projected pixel: no world point in between.
        let query_from_ref = cam_from_world * view.camera.world_from_cam;
        let rw = kr.width as usize;
        let sigma = &reference.data[v].sigma;
        for (idx, &d) in view.depth.data.iter().enumerate() {
            if sigma[idx] <= 0.0 {
                continue;
            }
            let Some(wt) = weight_of(v, idx) else {
                continue;
            };
            let d = f64::from(d);
            let p_ref = Point3::new(
                ((idx % rw) as f64 + 0.5 - kr.cx) / kr.fx * d,
                ((idx / rw) as f64 + 0.5 - kr.cy) / kr.fy * d,
                d,
            );
            let pc = query_from_ref.transform_point(&p_ref);
            if pc.z <= 0.0 {
                continue;
            }
            let u = k.fx * pc.x / pc.z + k.cx;
            let vv = k.fy * pc.y / pc.z + k.cy;
            // Footprint of one reference pixel, in query pixels.
            let footprint = d / fr * fq / pc.z;
            // Under-cover rather than over-cover: a splat spilling over a depth
            // edge would vote against the surface behind it.
            let r = ((0.5 * (footprint - 1.0)).floor() as i64).clamp(0, i64::from(max_radius));
            let (cx, cy) = (u.floor() as i64, vv.floor() as i64);
            let z = pc.z as f32;
            for yy in (cy - r).max(0)..=(cy + r).min(h as i64 - 1) {
                for xx in (cx - r).max(0)..=(cx + r).min(w as i64 - 1) {
                    let i = yy as usize * w + xx as usize;
                    if z < zb.depth[i] {
                        zb.depth[i] = z;
                        zb.weight[i] = wt;
                    }
                }
            }
        }
    }
    zb
}

#[cfg(test)]
mod tests {
    use super::*;
    use vp_scene::Intrinsics;

    fn cam(x: f64) -> Camera {
        let k = Intrinsics::from_hfov(200, 150, 60.0).unwrap();
        Camera::look_at(k, Point3::new(x, -30.0, 40.0), Point3::origin()).unwrap()
    }

    #[test]
    fn sigma_shrinks_with_wider_baseline() {
        let p = Point3::origin();
        let dir = (p - cam(0.0).center()).normalize();
        let narrow = sigma_along_ray(&[cam(-1.0), cam(0.0), cam(1.0)], &p, &dir, 1.0).unwrap();
        let wide = sigma_along_ray(&[cam(-10.0), cam(0.0), cam(10.0)], &p, &dir, 1.0).unwrap();
        assert!(wide < narrow / 5.0, "wide {wide} narrow {narrow}");
        // A single camera cannot fix depth.
        assert!(sigma_along_ray(&[cam(0.0)], &p, &dir, 1.0).is_none());
    }
}
