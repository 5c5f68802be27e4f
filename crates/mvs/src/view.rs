//! A view: a posed pinhole camera with its image (grey for matching, colour
//! for fusion) and the depth range to search.

use nalgebra::{Matrix3, Point3, Vector3};
use vp_scene::raster::RgbImage;
use vp_scene::Camera;

use crate::error::{MvsError, Result};

/// A grey image in [0, 1], row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct GreyImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Intensities, `data[y * width + x]`.
    pub data: Vec<f32>,
}

impl GreyImage {
    /// Luma (Rec. 601) of an RGB image.
    pub fn from_rgb(rgb: &RgbImage) -> Self {
        let data = rgb
            .pixels()
            .map(|p| {
                (0.299 * f32::from(p[0]) + 0.587 * f32::from(p[1]) + 0.114 * f32::from(p[2]))
                    / 255.0
            })
            .collect();
        GreyImage {
            width: rgb.width(),
            height: rgb.height(),
            data,
        }
    }

    /// Intensity at integer pixel (x, y); `None` outside.
    #[inline]
    pub fn at(&self, x: i32, y: i32) -> Option<f32> {
        (x >= 0 && y >= 0 && (x as u32) < self.width && (y as u32) < self.height)
            .then(|| self.data[y as usize * self.width as usize + x as usize])
    }

    /// Bilinear intensity at continuous image coordinates (pixel (i, j) has
    /// its centre at (i + 0.5, j + 0.5)); `None` outside the span of the
    /// pixel centres.
    #[inline]
    pub fn sample(&self, u: f32, v: f32) -> Option<f32> {
        let fx = u - 0.5;
        let fy = v - 0.5;
        if !(fx >= 0.0 && fy >= 0.0) {
            return None;
        }
        let (x0, y0) = (fx as usize, fy as usize);
        let (w, h) = (self.width as usize, self.height as usize);
        if w == 0 || h == 0 {
            return None;
        }
        // Up to the last pixel centre itself: a position exactly on the
        // last row or column (a rectified pair maps rows onto rows exactly)
        // is inside, its next row or column weighted 0.
        if !(fx <= (w - 1) as f32 && fy <= (h - 1) as f32) {
            return None;
        }
        let (ax, ay) = (fx - x0 as f32, fy - y0 as f32);
        let (dx, dy) = (usize::from(x0 + 1 < w), if y0 + 1 < h { w } else { 0 });
        let i = y0 * w + x0;
        let d = &self.data;
        let top = d[i] + ax * (d[i + dx] - d[i]);
        let bottom = d[i + dy] + ax * (d[i + dy + dx] - d[i + dy]);
        Some(top + ay * (bottom - top))
    }
}

/// One image of the reconstruction.
#[derive(Debug, Clone)]
pub struct View {
    /// Image name (relative path under `images/`).
    pub name: String,
    /// Posed pinhole camera; its size equals the image's.
    pub camera: Camera,
    /// Grey image for matching.
    pub grey: GreyImage,
    /// Colour image for the fused points.
    pub rgb: RgbImage,
    /// Depth range searched, along the optical axis (min, max), metres.
    pub depth_range: (f64, f64),
}

impl View {
    /// A view from a camera, a colour image and a depth range; checks that
    /// the sizes agree and the range is usable.
    pub fn new(name: &str, camera: Camera, rgb: RgbImage, depth_range: (f64, f64)) -> Result<Self> {
        let k = camera.intrinsics;
        if (rgb.width(), rgb.height()) != (k.width, k.height) {
            return Err(MvsError::InvalidArgument(format!(
                "image '{name}' is {}x{} but its camera is {}x{}",
                rgb.width(),
                rgb.height(),
                k.width,
                k.height
            )));
        }
        check_depth_range(depth_range)
            .map_err(|m| MvsError::InvalidArgument(format!("image '{name}': {m}")))?;
        Ok(View {
            name: name.to_string(),
            grey: GreyImage::from_rgb(&rgb),
            camera,
            rgb,
            depth_range,
        })
    }

    /// Width and height in pixels.
    pub fn size(&self) -> (usize, usize) {
        (
            self.camera.intrinsics.width as usize,
            self.camera.intrinsics.height as usize,
        )
    }
}

/// Checks a depth range: finite, positive, min < max. The message says
/// what is wrong.
pub fn check_depth_range((lo, hi): (f64, f64)) -> std::result::Result<(), String> {
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(format!("depth range {lo}..{hi} is not finite"));
    }
    if !(lo > 0.0) {
        return Err(format!(
            "depth range {lo}..{hi} starts at or behind the camera (min must be > 0)"
        ));
    }
    if lo >= hi {
        return Err(format!(
            "depth range {lo}..{hi} is empty or inverted (min must be < max)"
        ));
    }
    Ok(())
}

/// The geometry of one source relative to a reference, in f32 for the hot
/// path: `X_src = rot * X_ref + trans` (camera frames).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Relative {
    pub rot: [[f32; 3]; 3],
    pub trans: [f32; 3],
    /// Source intrinsics fx, fy, cx, cy.
    pub k: [f32; 4],
}

impl Relative {
    pub(crate) fn new(reference: &Camera, source: &Camera) -> Self {
        let src_from_ref = source.cam_from_world() * reference.world_from_cam;
        let r: Matrix3<f64> = src_from_ref.rotation.to_rotation_matrix().into_inner();
        let t: Vector3<f64> = src_from_ref.translation.vector;
        let ks = source.intrinsics;
        Relative {
            rot: std::array::from_fn(|i| std::array::from_fn(|j| r[(i, j)] as f32)),
            trans: [t.x as f32, t.y as f32, t.z as f32],
            k: [ks.fx as f32, ks.fy as f32, ks.cx as f32, ks.cy as f32],
        }
    }
}

/// Intrinsics of a camera as f32 `[fx, fy, cx, cy]`.
pub(crate) fn k_of(camera: &Camera) -> [f32; 4] {
    let k = camera.intrinsics;
    [k.fx as f32, k.fy as f32, k.cx as f32, k.cy as f32]
}

/// Viewing ray (camera frame, z = 1) through the centre of pixel (x, y).
#[inline]
pub(crate) fn pixel_ray(k: &[f32; 4], x: usize, y: usize) -> [f32; 3] {
    [
        (x as f32 + 0.5 - k[2]) / k[0],
        (y as f32 + 0.5 - k[3]) / k[1],
        1.0,
    ]
}

/// World point of pixel (x, y) at depth `d` of `camera`.
pub(crate) fn unproject(camera: &Camera, x: usize, y: usize, d: f64) -> Point3<f64> {
    let k = camera.intrinsics;
    let p = Point3::new(
        (x as f64 + 0.5 - k.cx) / k.fx * d,
        (y as f64 + 0.5 - k.cy) / k.fy * d,
        d,
    );
    camera.world_from_cam * p
}

#[cfg(test)]
mod tests {
    use super::GreyImage;

    /// A position exactly on the last pixel centre (where a rectified
    /// pair's homography maps the last row) is inside; beyond it is not.
    #[test]
    fn sampling_reaches_the_last_row_and_column_and_stops_there() {
        let img = GreyImage {
            width: 3,
            height: 2,
            data: vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0],
        };
        assert_eq!(img.sample(2.5, 1.5), Some(5.0));
        assert_eq!(img.sample(2.5, 0.5), Some(2.0));
        assert_eq!(img.sample(1.5, 1.5), Some(4.0));
        assert_eq!(img.sample(2.0, 1.5), Some(4.5));
        assert_eq!(img.sample(1.0, 1.0), Some(2.0));
        assert_eq!(img.sample(2.51, 1.5), None);
        assert_eq!(img.sample(2.5, 1.51), None);
        assert_eq!(img.sample(0.49, 1.0), None);
        let empty = GreyImage {
            width: 0,
            height: 0,
            data: vec![],
        };
        assert_eq!(empty.sample(0.5, 0.5), None);
    }
}
