//! OpenSfM camera models as the COLMAP camera with the same projection.
//!
//! OpenSfM (`opensfm/src/geometry/camera_instances.h`,
//! `transformations_functions.h`, `opensfm/features.py`) projects a point
//! of the camera frame (x right, y down, z forward, as COLMAP) in three
//! steps: a projection (perspective `x/z`, or fisheye `theta * (x, y)/r`
//! with `theta = atan2(r, z)`), a distortion of that 2D point, and an
//! affine map to *normalised image coordinates*: `focal * p + c`, where
//! the unit is the image's larger side, the origin its centre, and `c` the
//! principal point's offset (0 for the models without one). A pixel of
//! index `i` has the normalised coordinate `(i + 0.5 - width / 2) /
//! max(width, height)` (`normalized_image_coordinates`). COLMAP puts the
//! image corner at 0 and pixel centres at `i + 0.5`, so a normalised `n`
//! is COLMAP's `n * size + width / 2`: focal lengths scale by `size` and
//! the principal point is `width / 2 + c_x * size`.
//!
//! The distortions then match COLMAP's models term for term:
//!
//! | OpenSfM | parameters | COLMAP |
//! |---|---|---|
//! | `perspective` | `focal, k1, k2` | `RADIAL` |
//! | `simple_radial` | `focal_x, focal_y, c_x, c_y, k1` | `OPENCV` (`k2 = p1 = p2 = 0`) |
//! | `radial` | `focal_x, focal_y, c_x, c_y, k1, k2` | `OPENCV` (`p1 = p2 = 0`) |
//! | `brown` | `focal_x, focal_y, c_x, c_y, k1, k2, k3, p1, p2` | `OPENCV`, or `FULL_OPENCV` when `k3 != 0` |
//! | `fisheye` | `focal, k1, k2` | `RADIAL_FISHEYE` |
//! | `fisheye_opencv` | `focal_x, focal_y, c_x, c_y, k1..k4` | `OPENCV_FISHEYE` |
//!
//! Brown's tangential terms are OpenCV's (`2 p1 x y + p2 (r^2 + 2 x^2)`,
//! `p1 (r^2 + 2 y^2) + 2 p2 x y`), as COLMAP's. `fisheye62`, `fisheye624`,
//! `dual` and the panoramas (`spherical`, `equirectangular`) have no
//! COLMAP twin that vpctl could check term for term, and are refused.

use crate::colmap::{CameraModel, ColmapCamera};

/// The projection types OpenSfM writes that vpctl reads.
pub const SUPPORTED: [&str; 6] = [
    "perspective",
    "brown",
    "fisheye",
    "fisheye_opencv",
    "radial",
    "simple_radial",
];

/// A camera of `reconstruction.json`, as OpenSfM names its parameters.
/// Missing optional parameters are 0, as in OpenSfM's `camera_from_json`.
#[derive(Debug, Clone, PartialEq)]
pub struct OpenSfmCamera {
    /// The camera's key in `cameras`.
    pub key: String,
    /// `projection_type` (`perspective` when absent, as OpenSfM reads it).
    pub projection: String,
    /// Image width, pixels.
    pub width: u64,
    /// Image height, pixels.
    pub height: u64,
    /// Named parameters (`focal`, `focal_x`, `c_x`, `k1`, `p1`, ...).
    pub params: Vec<(String, f64)>,
}

impl OpenSfmCamera {
    /// Parameter `name`, 0 when absent.
    pub fn get(&self, name: &str) -> f64 {
        self.params
            .iter()
            .find(|(n, _)| n == name)
            .map_or(0.0, |(_, v)| *v)
    }

    /// Whether the parameter is present.
    pub fn has(&self, name: &str) -> bool {
        self.params.iter().any(|(n, _)| n == name)
    }

    /// The parameters a projection type requires (the others default to 0).
    pub fn required(projection: &str) -> &'static [&'static str] {
        match projection {
            "perspective" | "fisheye" => &["focal"],
            _ => &["focal_x", "focal_y"],
        }
    }

    /// The COLMAP camera with the same projection (module doc), with id
    /// `id`. `Err` names what is wrong: an unknown projection type, a
    /// missing focal length, an empty image.
    pub fn to_colmap(&self, id: u32) -> Result<ColmapCamera, String> {
        if !SUPPORTED.contains(&self.projection.as_str()) {
            return Err(format!(
                "projection_type {:?} is not supported (vpctl reads {}); re-run OpenSfM's \
                 reconstruction with `camera_projection_type: BROWN` (OpenDroneMap: \
                 --camera-lens brown), or undistort it with `opensfm undistort` and pass the \
                 `undistorted` folder",
                self.projection,
                SUPPORTED.join(", ")
            ));
        }
        if self.width == 0 || self.height == 0 {
            return Err(format!(
                "image size {}x{}: a camera needs its width and height",
                self.width, self.height
            ));
        }
        for name in Self::required(&self.projection) {
            if !self.has(name) {
                return Err(format!("{} camera without {name:?}", self.projection));
            }
        }
        let size = self.width.max(self.height) as f64;
        let (w2, h2) = (self.width as f64 / 2.0, self.height as f64 / 2.0);
        let g = |n: &str| self.get(n);
        let fx = g("focal_x") * size;
        let fy = g("focal_y") * size;
        let cx = w2 + g("c_x") * size;
        let cy = h2 + g("c_y") * size;
        let (model, params) = match self.projection.as_str() {
            "perspective" => (
                CameraModel::Radial,
                vec![g("focal") * size, w2, h2, g("k1"), g("k2")],
            ),
            "fisheye" => (
                CameraModel::RadialFisheye,
                vec![g("focal") * size, w2, h2, g("k1"), g("k2")],
            ),
            "simple_radial" => (
                CameraModel::OpenCv,
                vec![fx, fy, cx, cy, g("k1"), 0.0, 0.0, 0.0],
            ),
            "radial" => (
                CameraModel::OpenCv,
                vec![fx, fy, cx, cy, g("k1"), g("k2"), 0.0, 0.0],
            ),
            "brown" if g("k3") == 0.0 => (
                CameraModel::OpenCv,
                vec![fx, fy, cx, cy, g("k1"), g("k2"), g("p1"), g("p2")],
            ),
            "brown" => (
                CameraModel::FullOpenCv,
                vec![
                    fx,
                    fy,
                    cx,
                    cy,
                    g("k1"),
                    g("k2"),
                    g("p1"),
                    g("p2"),
                    g("k3"),
                    0.0,
                    0.0,
                    0.0,
                ],
            ),
            // "fisheye_opencv", the last of SUPPORTED.
            _ => (
                CameraModel::OpenCvFisheye,
                vec![fx, fy, cx, cy, g("k1"), g("k2"), g("k3"), g("k4")],
            ),
        };
        let n_focal = if model.single_focal() { 1 } else { 2 };
        if !params[..n_focal].iter().all(|f| *f > 0.0) {
            return Err(format!(
                "focal length {} (normalised by the larger image side) must be positive",
                if self.has("focal") {
                    g("focal")
                } else {
                    g("focal_x").min(g("focal_y"))
                }
            ));
        }
        Ok(ColmapCamera {
            id,
            model,
            width: self.width,
            height: self.height,
            params,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam(projection: &str, params: &[(&str, f64)]) -> OpenSfmCamera {
        OpenSfmCamera {
            key: "c".into(),
            projection: projection.into(),
            width: 4000,
            height: 3000,
            params: params.iter().map(|(n, v)| (n.to_string(), *v)).collect(),
        }
    }

    #[test]
    fn principal_point_offset_and_focal_scale_by_the_larger_side() {
        let c = cam(
            "brown",
            &[
                ("focal_x", 0.8),
                ("focal_y", 0.81),
                ("c_x", 0.01),
                ("c_y", -0.02),
            ],
        )
        .to_colmap(1)
        .unwrap();
        assert_eq!(c.model, CameraModel::OpenCv);
        assert_eq!(&c.params[..4], &[3200.0, 3240.0, 2040.0, 1420.0]);
        assert!(
            !c.is_distorted(),
            "a brown camera without k, p is a pinhole"
        );
    }

    #[test]
    fn unknown_projection_and_missing_focal_are_refused() {
        let e = cam("dual", &[("focal", 0.8)]).to_colmap(1).unwrap_err();
        assert!(e.contains("\"dual\" is not supported"), "{e}");
        let e = cam("brown", &[("focal", 0.8)]).to_colmap(1).unwrap_err();
        assert!(e.contains("without \"focal_x\""), "{e}");
        let e = cam("perspective", &[("focal", -0.8)])
            .to_colmap(1)
            .unwrap_err();
        assert!(e.contains("must be positive"), "{e}");
    }
}
