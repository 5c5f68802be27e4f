//! Rectification of a calibrated pair (Fusiello, Trucco & Verri 2000,
//! "A compact algorithm for rectification of stereo pairs"): both cameras
//! keep their centres and get one common orientation whose x axis is the
//! baseline, and one common focal length, so that a world point lands on the
//! same row in both rectified images and its disparity is `f * B / Z`.

use nalgebra::{Matrix3, Vector3};
use vp_scene::Camera;

use crate::view::GreyImage;

/// The rectified geometry of one (reference, source) pair. Rectified pixel
/// (i, j) of the reference has its centre at `(i + 0.5, j + 0.5)` and looks
/// along `(i + 0.5 - cx, j + 0.5 - cy, f)` in the rectified frame; the
/// source's grid is the same with `cx + d_min`, so that a disparity index
/// `k` in `0..n_disp` means the true disparity `d_min + k` and the matching
/// source pixel is column `i - k` (the reference is the left image).
#[derive(Debug, Clone)]
pub(crate) struct Rectification {
    pub width: usize,
    pub height: usize,
    /// Focal length of both rectified cameras, pixels.
    pub f: f64,
    pub cx: f64,
    pub cy: f64,
    /// Smallest disparity searched (pixels, reference grid).
    pub d_min: i32,
    /// Number of disparities searched.
    pub n_disp: usize,
    /// Distance between the camera centres.
    pub baseline: f64,
    /// Rotation from the reference camera's frame to the rectified frame.
    pub rect_from_ref: Matrix3<f64>,
    /// Rotation from the source camera's frame to the rectified frame.
    pub rect_from_src: Matrix3<f64>,
}

/// Why a pair cannot be rectified.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum RectifyError {
    /// The centres coincide, or the baseline is along the reference's
    /// viewing direction (the epipole lies in the image: no row structure).
    Degenerate(String),
    /// The depth range needs more disparities than allowed.
    TooManyDisparities(usize),
}

/// Most the rectified image may grow over the original along each axis
/// before its focal length shrinks instead.
const MAX_GROWTH: f64 = 2.0;

/// Most the focal length may shrink; a pair that needs more (the epipole
/// near the image) has no usable row structure.
const MAX_SHRINK: f64 = 4.0;

fn rotation(camera: &Camera) -> Matrix3<f64> {
    camera
        .cam_from_world()
        .rotation
        .to_rotation_matrix()
        .into_inner()
}

impl Rectification {
    /// Rectifies `reference` against `source` for depths (along the
    /// reference's axis) in `depth_range`; the disparity interval covers
    /// that range over the whole reference image, plus 2 px on each side.
    pub fn new(
        reference: &Camera,
        source: &Camera,
        depth_range: (f64, f64),
        max_disparities: usize,
    ) -> Result<Self, RectifyError> {
        let b = source.center() - reference.center();
        let baseline = b.norm();
        let k = reference.intrinsics;
        if !(baseline > 1e-9) {
            return Err(RectifyError::Degenerate(
                "the two cameras share their centre (no baseline)".into(),
            ));
        }
        let r_ref = rotation(reference);
        // Fusiello et al.: x along the baseline, y orthogonal to x and to
        // the reference's old optical axis, z completing the frame.
        let x = b / baseline;
        let old_z: Vector3<f64> = r_ref.row(2).transpose();
        let y = old_z.cross(&x);
        if y.norm() < 0.1 {
            return Err(RectifyError::Degenerate(format!(
                "the baseline is within {:.1} deg of the viewing direction: the epipole lies \
                 in the image",
                y.norm().asin().to_degrees()
            )));
        }
        let y = y.normalize();
        let z = x.cross(&y);
        let r_new = Matrix3::from_rows(&[x.transpose(), y.transpose(), z.transpose()]);
        let rect_from_ref = r_new * r_ref.transpose();
        let rect_from_src = r_new * rotation(source).transpose();
        // The reference image's corners bound the rectified grid, at the
        // reference's focal length; where the baseline has a component
        // along the view (the epipole near the image) the grid grows, and
        // the focal length shrinks to keep it within MAX_GROWTH per axis.
        let f0 = 0.5 * (k.fx + k.fy);
        let mut corners = [(0.0, 0.0); 4];
        for (c, (px, py)) in corners.iter_mut().zip([
            (0.0, 0.0),
            (f64::from(k.width), 0.0),
            (0.0, f64::from(k.height)),
            (f64::from(k.width), f64::from(k.height)),
        ]) {
            let r = rect_from_ref * Vector3::new((px - k.cx) / k.fx, (py - k.cy) / k.fy, 1.0);
            if !(r.z > 1e-6) {
                return Err(RectifyError::Degenerate(
                    "an image corner looks backwards after rectification".into(),
                ));
            }
            *c = (r.x / r.z, r.y / r.z);
        }
        let span = |a: fn(&(f64, f64)) -> f64| {
            let lo = corners.iter().map(a).fold(f64::MAX, f64::min);
            let hi = corners.iter().map(a).fold(f64::MIN, f64::max);
            (lo, hi)
        };
        let ((ulo, uhi), (vlo, vhi)) = (span(|c| c.0), span(|c| c.1));
        let grow = ((uhi - ulo) * f0 / (MAX_GROWTH * f64::from(k.width)))
            .max((vhi - vlo) * f0 / (MAX_GROWTH * f64::from(k.height)))
            .max(1.0);
        if grow > MAX_SHRINK {
            return Err(RectifyError::Degenerate(format!(
                "the rectified image would need {grow:.1}x less resolution: the baseline points \
                 too nearly along the view"
            )));
        }
        let f = f0 / grow;
        let (umin, vmin) = (f * ulo, f * vlo);
        let (width, height) = ((f * uhi - umin).ceil(), (f * vhi - vmin).ceil());
        // Disparities of a grid of reference pixels at both ends of the
        // depth range: d = f B / Z in the rectified frame.
        let (mut dlo, mut dhi) = (f64::MAX, f64::MIN);
        for j in 0..=8 {
            for i in 0..=8 {
                let px = f64::from(i) / 8.0 * f64::from(k.width);
                let py = f64::from(j) / 8.0 * f64::from(k.height);
                let ray = Vector3::new((px - k.cx) / k.fx, (py - k.cy) / k.fy, 1.0);
                for depth in [depth_range.0, depth_range.1] {
                    let zr = (rect_from_ref * (ray * depth)).z;
                    if zr > 0.0 {
                        let d = f * baseline / zr;
                        (dlo, dhi) = (dlo.min(d), dhi.max(d));
                    }
                }
            }
        }
        let d_min = (dlo.floor() - 2.0).max(0.0);
        let n = dhi.ceil() + 2.0 - d_min + 1.0;
        if !(n <= max_disparities as f64) {
            return Err(RectifyError::TooManyDisparities(if n.is_finite() {
                n as usize
            } else {
                usize::MAX
            }));
        }
        Ok(Rectification {
            width: width as usize,
            height: height as usize,
            f,
            cx: -umin,
            cy: -vmin,
            d_min: d_min as i32,
            n_disp: n as usize,
            baseline,
            rect_from_ref,
            rect_from_src,
        })
    }

    /// The rectified image of the reference (`source == false`) or of the
    /// source, resampled bilinearly from `grey` seen by `camera`, and which
    /// pixels came from inside the original image.
    pub fn resample(
        &self,
        camera: &Camera,
        grey: &GreyImage,
        source: bool,
    ) -> (Vec<f32>, Vec<bool>) {
        let (rot, cx) = if source {
            (
                self.rect_from_src.transpose(),
                self.cx + f64::from(self.d_min),
            )
        } else {
            (self.rect_from_ref.transpose(), self.cx)
        };
        let k = camera.intrinsics;
        let mut data = vec![0.0f32; self.width * self.height];
        let mut valid = vec![false; self.width * self.height];
        for (idx, (v, ok)) in data.iter_mut().zip(valid.iter_mut()).enumerate() {
            let (i, j) = (idx % self.width, idx / self.width);
            let ray = Vector3::new(
                (i as f64 + 0.5 - cx) / self.f,
                (j as f64 + 0.5 - self.cy) / self.f,
                1.0,
            );
            let o = rot * ray;
            if !(o.z > 1e-9) {
                continue;
            }
            let u = k.fx * o.x / o.z + k.cx;
            let w = k.fy * o.y / o.z + k.cy;
            if let Some(s) = grey.sample(u as f32, w as f32) {
                *v = s;
                *ok = true;
            }
        }
        (data, valid)
    }

    /// Where the ray through the centre of original reference pixel (x, y)
    /// meets the rectified grid, and the ray's z in the rectified frame per
    /// unit of original depth; `None` when it looks backwards.
    pub fn to_rectified(&self, camera: &Camera, x: usize, y: usize) -> Option<(f64, f64, f64)> {
        let k = camera.intrinsics;
        let r = self.rect_from_ref
            * Vector3::new(
                (x as f64 + 0.5 - k.cx) / k.fx,
                (y as f64 + 0.5 - k.cy) / k.fy,
                1.0,
            );
        (r.z > 1e-9).then(|| {
            (
                self.f * r.x / r.z + self.cx,
                self.f * r.y / r.z + self.cy,
                r.z,
            )
        })
    }

    /// Original depth of the reference pixel whose ray has rectified z `rz`
    /// (from [`Rectification::to_rectified`]) at disparity index `k`
    /// (fractional); `None` for a disparity at or below 0.
    pub fn depth(&self, rz: f64, k: f64) -> Option<f64> {
        let d = k + f64::from(self.d_min);
        (d > 1e-6).then(|| self.f * self.baseline / d / rz)
    }
}
