//! Pinhole cameras: intrinsics, pose, projection.
//!
//! Conventions (OpenCV/COLMAP): the camera looks along +z, x to the right,
//! y down. Pixel coordinates are continuous with the top-left corner of the
//! image at (0, 0), so the centre of pixel (i, j) is (i + 0.5, j + 0.5), as in
//! COLMAP. Lens distortion is not modelled here: the planner works with the
//! pinhole approximation of every COLMAP camera model.

use nalgebra::{
    Isometry3, Matrix2x3, Point2, Point3, Rotation3, Translation3, UnitQuaternion, Vector3,
};
use serde::{Deserialize, Serialize};

use crate::error::{Result, SceneError};

/// Pinhole intrinsics in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Intrinsics {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
}

impl Intrinsics {
    /// Intrinsics from their values, checked: positive sizes, positive
    /// finite focal lengths, a finite principal point. The one validating
    /// constructor (readers and bindings build through it).
    pub fn new(width: u32, height: u32, fx: f64, fy: f64, cx: f64, cy: f64) -> Result<Self> {
        if width == 0 || height == 0 {
            return Err(SceneError::InvalidArgument(format!(
                "camera size {width}x{height}: both must be positive"
            )));
        }
        if !(fx.is_finite() && fy.is_finite() && fx > 0.0 && fy > 0.0) {
            return Err(SceneError::InvalidArgument(format!(
                "focal length ({fx}, {fy}) is not positive and finite"
            )));
        }
        if !(cx.is_finite() && cy.is_finite()) {
            return Err(SceneError::InvalidArgument(format!(
                "principal point ({cx}, {cy}) is not finite"
            )));
        }
        Ok(Intrinsics {
            width,
            height,
            fx,
            fy,
            cx,
            cy,
        })
    }

    /// Intrinsics with square pixels, the principal point at the image centre
    /// and the given horizontal field of view in degrees.
    pub fn from_hfov(width: u32, height: u32, hfov_deg: f64) -> Result<Self> {
        if width == 0 || height == 0 || !(hfov_deg > 0.0 && hfov_deg < 180.0) {
            return Err(SceneError::InvalidArgument(format!(
                "camera {width}x{height} with horizontal field of view {hfov_deg} deg"
            )));
        }
        let f = 0.5 * f64::from(width) / (0.5 * hfov_deg.to_radians()).tan();
        Ok(Intrinsics {
            width,
            height,
            fx: f,
            fy: f,
            cx: 0.5 * f64::from(width),
            cy: 0.5 * f64::from(height),
        })
    }

    /// Horizontal and vertical opening angles in radians.
    pub fn fov(&self) -> (f64, f64) {
        (
            2.0 * (0.5 * f64::from(self.width) / self.fx).atan(),
            2.0 * (0.5 * f64::from(self.height) / self.fy).atan(),
        )
    }

    /// Mean focal length in pixels.
    pub fn focal(&self) -> f64 {
        0.5 * (self.fx + self.fy)
    }

    /// Whether a pixel position lies inside the image.
    pub fn in_frame(&self, px: &Point2<f64>) -> bool {
        px.x >= 0.0 && px.y >= 0.0 && px.x < f64::from(self.width) && px.y < f64::from(self.height)
    }

    /// Same intrinsics for an image scaled by `s` (e.g. 0.5 for one pyramid level up).
    pub fn scaled(&self, s: f64) -> Intrinsics {
        Intrinsics {
            width: ((f64::from(self.width) * s).round() as u32).max(1),
            height: ((f64::from(self.height) * s).round() as u32).max(1),
            fx: self.fx * s,
            fy: self.fy * s,
            cx: self.cx * s,
            cy: self.cy * s,
        }
    }
}

/// A posed pinhole camera.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// Intrinsics.
    pub intrinsics: Intrinsics,
    /// Pose: maps camera coordinates to world coordinates.
    pub world_from_cam: Isometry3<f64>,
}

impl Camera {
    /// A camera from intrinsics and pose.
    pub fn new(intrinsics: Intrinsics, world_from_cam: Isometry3<f64>) -> Self {
        Camera {
            intrinsics,
            world_from_cam,
        }
    }

    /// A camera at `center` looking at `target`, with image x axis horizontal
    /// (roll 0) for world up +z. Fails when `target` is (almost) straight
    /// above or below, where roll 0 is undefined; use
    /// [`Camera::from_yaw_pitch`] for nadir views.
    pub fn look_at(
        intrinsics: Intrinsics,
        center: Point3<f64>,
        target: Point3<f64>,
    ) -> Result<Self> {
        let z = target - center;
        let dist = z.norm();
        if !(dist > 0.0) {
            return Err(SceneError::InvalidArgument(
                "look_at: camera centre equals target".into(),
            ));
        }
        let z = z / dist;
        let x = z.cross(&Vector3::z());
        if x.norm() < 1e-9 {
            return Err(SceneError::InvalidArgument(
                "look_at: viewing direction is vertical; roll is undefined".into(),
            ));
        }
        let x = x.normalize();
        let y = z.cross(&x);
        let rot = Rotation3::from_basis_unchecked(&[x, y, z]);
        Ok(Camera::new(
            intrinsics,
            Isometry3::from_parts(
                Translation3::from(center.coords),
                UnitQuaternion::from_rotation_matrix(&rot),
            ),
        ))
    }

    /// A camera from a gimbal-style attitude: `yaw` is the heading of the
    /// optical axis in the world frame, counter-clockwise from +x (east) in
    /// radians; `pitch` is the elevation of the optical axis (0 horizontal,
    /// -pi/2 straight down); roll is 0. At pitch -pi/2 the image's up
    /// direction points along the yaw heading.
    pub fn from_yaw_pitch(
        intrinsics: Intrinsics,
        center: Point3<f64>,
        yaw: f64,
        pitch: f64,
    ) -> Self {
        let (sy, cy) = yaw.sin_cos();
        let (sp, cp) = pitch.sin_cos();
        let z = Vector3::new(cp * cy, cp * sy, sp);
        // Image right = heading rotated clockwise by 90 deg, horizontal.
        let x = Vector3::new(sy, -cy, 0.0);
        let y = z.cross(&x);
        let rot = Rotation3::from_basis_unchecked(&[x, y, z]);
        Camera::new(
            intrinsics,
            Isometry3::from_parts(
                Translation3::from(center.coords),
                UnitQuaternion::from_rotation_matrix(&rot),
            ),
        )
    }

    /// Inverse pose: maps world coordinates to camera coordinates.
    #[inline]
    pub fn cam_from_world(&self) -> Isometry3<f64> {
        self.world_from_cam.inverse()
    }

    /// Projection centre in the world frame.
    #[inline]
    pub fn center(&self) -> Point3<f64> {
        Point3::from(self.world_from_cam.translation.vector)
    }

    /// Unit optical axis (+z of the camera) in the world frame.
    pub fn axis(&self) -> Vector3<f64> {
        self.world_from_cam.rotation * Vector3::z()
    }

    /// Heading (rad, counter-clockwise from +x) and elevation (rad) of the optical axis.
    pub fn yaw_pitch(&self) -> (f64, f64) {
        let a = self.axis();
        (a.y.atan2(a.x), a.z.clamp(-1.0, 1.0).asin())
    }

    /// Pixel of a world point, or `None` when the point is not in front of the camera.
    /// The pixel may lie outside the image; see [`Camera::project_in_frame`].
    #[inline]
    pub fn project(&self, p_world: &Point3<f64>) -> Option<Point2<f64>> {
        let p = self.world_from_cam.inverse_transform_point(p_world);
        if p.z <= 0.0 {
            return None;
        }
        let k = &self.intrinsics;
        Some(Point2::new(
            k.fx * p.x / p.z + k.cx,
            k.fy * p.y / p.z + k.cy,
        ))
    }

    /// Pixel of a world point if it is in front of the camera and inside the image.
    #[inline]
    pub fn project_in_frame(&self, p_world: &Point3<f64>) -> Option<Point2<f64>> {
        self.project(p_world)
            .filter(|px| self.intrinsics.in_frame(px))
    }

    /// The world point at pixel `px` and depth `depth` (distance along the
    /// optical axis, the convention of COLMAP depth maps).
    pub fn unproject(&self, px: &Point2<f64>, depth: f64) -> Point3<f64> {
        let k = &self.intrinsics;
        let p = Point3::new(
            (px.x - k.cx) / k.fx * depth,
            (px.y - k.cy) / k.fy * depth,
            depth,
        );
        self.world_from_cam.transform_point(&p)
    }

    /// The image corners (top left, top right, bottom right, bottom left)
    /// at `depth` along the optical axis: with the centre, the pyramid that
    /// camera pictures draw (PLY pyramids, glTF frusta).
    pub fn frustum_corners(&self, depth: f64) -> [Point3<f64>; 4] {
        let (w, h) = (
            f64::from(self.intrinsics.width),
            f64::from(self.intrinsics.height),
        );
        [(0.0, 0.0), (w, 0.0), (w, h), (0.0, h)]
            .map(|(x, y)| self.unproject(&Point2::new(x, y), depth))
    }

    /// Ray through pixel `px`: origin (camera centre) and unit direction in the world frame.
    pub fn ray(&self, px: &Point2<f64>) -> (Point3<f64>, Vector3<f64>) {
        let k = &self.intrinsics;
        let d = Vector3::new((px.x - k.cx) / k.fx, (px.y - k.cy) / k.fy, 1.0).normalize();
        (self.center(), self.world_from_cam.rotation * d)
    }

    /// Whether a world point lies in the viewing frustum (in front, inside the image).
    pub fn in_frustum(&self, p_world: &Point3<f64>) -> bool {
        self.project_in_frame(p_world).is_some()
    }

    /// Ground sampling distance at a world point on a surface with unit normal
    /// `normal`: metres per pixel along the surface, `d / (f cos theta)`^(1/2)
    /// squared-area form, i.e. `sqrt(1 / r)` with `r = f^2 cos(theta) / d^2`
    /// pixels per square metre (the paper's resolution measure). Returns
    /// infinity for a surface seen edge-on or from behind.
    pub fn gsd_at(&self, p: &Point3<f64>, normal: &Vector3<f64>) -> f64 {
        let r = self.resolution_at(p, normal);
        if r > 0.0 {
            (1.0 / r).sqrt()
        } else {
            f64::INFINITY
        }
    }

    /// Pixels covered by one square metre of surface at `p` with unit normal
    /// `normal`: `f^2 cos(theta) / d^2` (f_res, docs/design.md#shared-geometry).
    /// Zero when seen from behind.
    pub fn resolution_at(&self, p: &Point3<f64>, normal: &Vector3<f64>) -> f64 {
        let to_cam = self.center() - p;
        let d2 = to_cam.norm_squared();
        let cos = normal.dot(&to_cam) / d2.sqrt();
        if cos <= 0.0 || d2 == 0.0 {
            return 0.0;
        }
        let f = self.intrinsics.focal();
        f * f * cos / d2
    }

    /// Jacobian of the projection (pixels per metre) with respect to the
    /// world point, at `p`. Used for first-order uncertainty propagation.
    pub fn projection_jacobian(&self, p_world: &Point3<f64>) -> Matrix2x3<f64> {
        let r = self.world_from_cam.rotation.inverse().to_rotation_matrix();
        let p = self.world_from_cam.inverse_transform_point(p_world);
        let k = &self.intrinsics;
        let iz = 1.0 / p.z;
        let d = Matrix2x3::new(
            k.fx * iz,
            0.0,
            -k.fx * p.x * iz * iz,
            0.0,
            k.fy * iz,
            -k.fy * p.y * iz * iz,
        );
        d * r.matrix()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn k() -> Intrinsics {
        Intrinsics::from_hfov(640, 480, 90.0).unwrap()
    }

    #[test]
    fn project_unproject_round_trip() {
        let cam = Camera::look_at(
            k(),
            Point3::new(10.0, -5.0, 30.0),
            Point3::new(0.0, 0.0, 0.0),
        )
        .unwrap();
        let p = Point3::new(1.0, 2.0, 0.5);
        let px = cam.project(&p).unwrap();
        let depth = cam.cam_from_world().transform_point(&p).z;
        let q = cam.unproject(&px, depth);
        assert!((p - q).norm() < 1e-9);
        let (o, d) = cam.ray(&px);
        let along = (p - o).normalize();
        assert!((along - d).norm() < 1e-9);
    }

    #[test]
    fn look_at_centres_the_target_with_zero_roll() {
        let cam = Camera::look_at(
            k(),
            Point3::new(0.0, -20.0, 10.0),
            Point3::new(0.0, 0.0, 0.0),
        )
        .unwrap();
        let px = cam.project(&Point3::origin()).unwrap();
        assert!((px.x - 320.0).abs() < 1e-9 && (px.y - 240.0).abs() < 1e-9);
        // Image x axis is horizontal: a point to the right (east) is at the same image row.
        let right = cam.project(&Point3::new(1.0, 0.0, 0.0)).unwrap();
        assert!((right.y - 240.0).abs() < 1e-9 && right.x > 320.0);
        // Above the target is up in the image (smaller y).
        assert!(cam.project(&Point3::new(0.0, 0.0, 1.0)).unwrap().y < 240.0);
    }

    #[test]
    fn yaw_pitch_round_trip() {
        let cam = Camera::from_yaw_pitch(k(), Point3::new(1.0, 2.0, 3.0), 0.7, -0.4);
        let (yaw, pitch) = cam.yaw_pitch();
        assert!((yaw - 0.7).abs() < 1e-12 && (pitch + 0.4).abs() < 1e-12);
        let nadir = Camera::from_yaw_pitch(
            k(),
            Point3::new(0.0, 0.0, 50.0),
            0.0,
            -std::f64::consts::FRAC_PI_2,
        );
        let px = nadir.project(&Point3::new(0.0, 0.0, 0.0)).unwrap();
        assert!((px.x - 320.0).abs() < 1e-9 && (px.y - 240.0).abs() < 1e-9);
        // Heading east at nadir: east is up in the image.
        assert!(nadir.project(&Point3::new(5.0, 0.0, 0.0)).unwrap().y < 240.0);
    }

    #[test]
    fn gsd_of_nadir_view_is_distance_over_focal() {
        let cam = Camera::from_yaw_pitch(
            k(),
            Point3::new(0.0, 0.0, 50.0),
            0.0,
            -std::f64::consts::FRAC_PI_2,
        );
        let gsd = cam.gsd_at(&Point3::origin(), &Vector3::z());
        assert!((gsd - 50.0 / cam.intrinsics.fx).abs() < 1e-12);
        assert!(cam.gsd_at(&Point3::origin(), &-Vector3::z()).is_infinite());
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let cam = Camera::look_at(
            k(),
            Point3::new(3.0, -8.0, 12.0),
            Point3::new(0.0, 1.0, 0.0),
        )
        .unwrap();
        let p = Point3::new(0.5, 0.7, 0.2);
        let j = cam.projection_jacobian(&p);
        let h = 1e-6;
        for axis in 0..3 {
            let mut q = p;
            q[axis] += h;
            let d = (cam.project(&q).unwrap() - cam.project(&p).unwrap()) / h;
            assert!((d.x - j[(0, axis)]).abs() < 1e-3 && (d.y - j[(1, axis)]).abs() < 1e-3);
        }
    }
}
