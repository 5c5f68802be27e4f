//! The elements of a COLMAP sparse model: camera models, cameras, images,
//! 2D and 3D points, and the pose convention (qvec, tvec).

use std::fmt;

use nalgebra::{Isometry3, Point2, Point3, Quaternion, Translation3, UnitQuaternion};

use crate::camera::Intrinsics;
use crate::error::{Result, SceneError};

/// Every camera model COLMAP knows, with its numeric id (as stored in
/// `cameras.bin`) and its name (as written in `cameras.txt`).
///
/// Ids 0–10 exist since COLMAP 3.0, 11 since 3.11, 12–17 since 4.x.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum CameraModel {
    /// `f, cx, cy`.
    SimplePinhole,
    /// `fx, fy, cx, cy`.
    Pinhole,
    /// `f, cx, cy, k`.
    SimpleRadial,
    /// `f, cx, cy, k1, k2`.
    Radial,
    /// `fx, fy, cx, cy, k1, k2, p1, p2`.
    OpenCv,
    /// `fx, fy, cx, cy, k1, k2, k3, k4`.
    OpenCvFisheye,
    /// `fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6`.
    FullOpenCv,
    /// `fx, fy, cx, cy, omega`.
    Fov,
    /// `f, cx, cy, k`.
    SimpleRadialFisheye,
    /// `f, cx, cy, k1, k2`.
    RadialFisheye,
    /// `fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, sx1, sy1`.
    ThinPrismFisheye,
    /// `fx, fy, cx, cy, k0..k5, p0, p1, s0..s3` (Project Aria's Fisheye624).
    RadTanThinPrismFisheye,
    /// `f, cx, cy, k` (Fitzgibbon's one-parameter division model).
    SimpleDivision,
    /// `fx, fy, cx, cy, k`.
    Division,
    /// `f, cx, cy` (equidistant fisheye without distortion).
    SimpleFisheye,
    /// `fx, fy, cx, cy` (equidistant fisheye without distortion).
    Fisheye,
    /// `fx, fy, cx, cy, alpha, beta` (enhanced unified camera model).
    Eucm,
    /// `w, h` (full-sphere panorama; has no pinhole approximation).
    Equirectangular,
}

impl CameraModel {
    /// All models in id order.
    pub const ALL: [CameraModel; 18] = [
        CameraModel::SimplePinhole,
        CameraModel::Pinhole,
        CameraModel::SimpleRadial,
        CameraModel::Radial,
        CameraModel::OpenCv,
        CameraModel::OpenCvFisheye,
        CameraModel::FullOpenCv,
        CameraModel::Fov,
        CameraModel::SimpleRadialFisheye,
        CameraModel::RadialFisheye,
        CameraModel::ThinPrismFisheye,
        CameraModel::RadTanThinPrismFisheye,
        CameraModel::SimpleDivision,
        CameraModel::Division,
        CameraModel::SimpleFisheye,
        CameraModel::Fisheye,
        CameraModel::Eucm,
        CameraModel::Equirectangular,
    ];

    /// COLMAP's numeric model id.
    pub fn id(self) -> i32 {
        self as i32
    }

    /// The model with COLMAP id `id`, if there is one.
    pub fn from_id(id: i32) -> Option<Self> {
        usize::try_from(id)
            .ok()
            .and_then(|i| Self::ALL.get(i).copied())
    }

    /// COLMAP's name of the model, as in `cameras.txt`.
    pub fn name(self) -> &'static str {
        match self {
            CameraModel::SimplePinhole => "SIMPLE_PINHOLE",
            CameraModel::Pinhole => "PINHOLE",
            CameraModel::SimpleRadial => "SIMPLE_RADIAL",
            CameraModel::Radial => "RADIAL",
            CameraModel::OpenCv => "OPENCV",
            CameraModel::OpenCvFisheye => "OPENCV_FISHEYE",
            CameraModel::FullOpenCv => "FULL_OPENCV",
            CameraModel::Fov => "FOV",
            CameraModel::SimpleRadialFisheye => "SIMPLE_RADIAL_FISHEYE",
            CameraModel::RadialFisheye => "RADIAL_FISHEYE",
            CameraModel::ThinPrismFisheye => "THIN_PRISM_FISHEYE",
            CameraModel::RadTanThinPrismFisheye => "RAD_TAN_THIN_PRISM_FISHEYE",
            CameraModel::SimpleDivision => "SIMPLE_DIVISION",
            CameraModel::Division => "DIVISION",
            CameraModel::SimpleFisheye => "SIMPLE_FISHEYE",
            CameraModel::Fisheye => "FISHEYE",
            CameraModel::Eucm => "EUCM",
            CameraModel::Equirectangular => "EQUIRECTANGULAR",
        }
    }

    /// The model named `name` (COLMAP spelling, exact case).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// Checks a parameter count against [`CameraModel::num_params`]; the
    /// one message every reader and check uses.
    pub fn check_param_count(self, found: usize) -> std::result::Result<(), String> {
        if found == self.num_params() {
            Ok(())
        } else {
            Err(format!(
                "{self} expects {} parameters, found {found}",
                self.num_params()
            ))
        }
    }

    /// Number of parameters COLMAP stores for the model.
    pub fn num_params(self) -> usize {
        match self {
            CameraModel::Equirectangular => 2,
            CameraModel::SimplePinhole | CameraModel::SimpleFisheye => 3,
            CameraModel::Pinhole
            | CameraModel::SimpleRadial
            | CameraModel::SimpleRadialFisheye
            | CameraModel::SimpleDivision
            | CameraModel::Fisheye => 4,
            CameraModel::Radial
            | CameraModel::RadialFisheye
            | CameraModel::Fov
            | CameraModel::Division => 5,
            CameraModel::Eucm => 6,
            CameraModel::OpenCv | CameraModel::OpenCvFisheye => 8,
            CameraModel::FullOpenCv | CameraModel::ThinPrismFisheye => 12,
            CameraModel::RadTanThinPrismFisheye => 16,
        }
    }

    /// Whether the model has a single focal length `f` (then the parameters
    /// start `f, cx, cy`) rather than `fx, fy, cx, cy`.
    pub(crate) fn single_focal(self) -> bool {
        matches!(
            self,
            CameraModel::SimplePinhole
                | CameraModel::SimpleRadial
                | CameraModel::Radial
                | CameraModel::SimpleRadialFisheye
                | CameraModel::RadialFisheye
                | CameraModel::SimpleDivision
                | CameraModel::SimpleFisheye
        )
    }
}

impl fmt::Display for CameraModel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One COLMAP camera (a set of intrinsics shared by one or more images).
#[derive(Debug, Clone, PartialEq)]
pub struct ColmapCamera {
    /// Camera id.
    pub id: u32,
    /// Camera model.
    pub model: CameraModel,
    /// Image width in pixels.
    pub width: u64,
    /// Image height in pixels.
    pub height: u64,
    /// Model parameters in COLMAP's order; length `model.num_params()`.
    pub params: Vec<f64>,
}

impl ColmapCamera {
    /// The pinhole approximation of the camera: focal lengths and principal
    /// point taken from the model's parameters, distortion dropped. For every
    /// perspective and fisheye model this is the model's first-order
    /// behaviour at the principal point (for inspection: ground resolution,
    /// field of view). Projecting with it is wrong for a distorted camera,
    /// which is why [`Reconstruction::camera_of`](super::Reconstruction::camera_of)
    /// refuses one. Fails for `EQUIRECTANGULAR` (no pinhole
    /// exists), for a wrong parameter count, a size that does not fit `u32`,
    /// or a non-positive or non-finite focal length.
    pub fn pinhole(&self) -> Result<Intrinsics> {
        let what = || format!("camera {} ({})", self.id, self.model);
        if self.model == CameraModel::Equirectangular {
            return Err(SceneError::InvalidArgument(format!(
                "{}: an equirectangular panorama has no pinhole approximation",
                what()
            )));
        }
        self.model
            .check_param_count(self.params.len())
            .map_err(|m| SceneError::InvalidArgument(format!("camera {}: {m}", self.id)))?;
        let (Ok(width), Ok(height)) = (u32::try_from(self.width), u32::try_from(self.height))
        else {
            return Err(SceneError::InvalidArgument(format!(
                "{}: image size {}x{} is too large",
                what(),
                self.width,
                self.height
            )));
        };
        let p = &self.params;
        let (fx, fy, cx, cy) = if self.model.single_focal() {
            (p[0], p[0], p[1], p[2])
        } else {
            (p[0], p[1], p[2], p[3])
        };
        Intrinsics::new(width, height, fx, fy, cx, cy).map_err(|e| match e {
            SceneError::InvalidArgument(m) => {
                SceneError::InvalidArgument(format!("{}: {m}", what()))
            }
            other => other,
        })
    }
}

/// One 2D feature of an image, possibly observing a 3D point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point2D {
    /// Pixel position (COLMAP convention: top-left image corner at (0, 0)).
    pub xy: Point2<f64>,
    /// The 3D point it observes; `None` is COLMAP's `-1`.
    pub point3d_id: Option<u64>,
}

/// One registered image.
#[derive(Debug, Clone, PartialEq)]
pub struct ColmapImage {
    /// Image id.
    pub id: u32,
    /// Id of the camera (intrinsics) the image was taken with.
    pub camera_id: u32,
    /// File name relative to the image folder.
    pub name: String,
    /// Pose: maps world coordinates to camera coordinates (COLMAP's qvec, tvec).
    pub cam_from_world: Isometry3<f64>,
    /// 2D features; a 3D point's track refers to them by index.
    pub points2d: Vec<Point2D>,
}

impl ColmapImage {
    /// Projection centre in the world frame.
    pub fn center(&self) -> Point3<f64> {
        Point3::from(self.cam_from_world.inverse().translation.vector)
    }
}

/// One triangulated 3D point.
#[derive(Debug, Clone, PartialEq)]
pub struct Point3D {
    /// Point id.
    pub id: u64,
    /// Position in the world frame.
    pub xyz: Point3<f64>,
    /// Colour.
    pub rgb: [u8; 3],
    /// Mean reprojection error in pixels (COLMAP writes -1 when unknown).
    pub error: f64,
    /// Observations: (image id, index into that image's `points2d`).
    pub track: Vec<(u32, u32)>,
}

/// Builds `cam_from_world` from COLMAP's `qvec` (w, x, y, z) and `tvec`.
/// A quaternion that is unit to rounding is kept bit for bit, so that reading
/// and writing a model loses nothing; others are normalised. A zero or
/// non-finite quaternion is an error (the message is returned).
pub(crate) fn pose_from_qt(
    q: [f64; 4],
    t: [f64; 3],
) -> std::result::Result<Isometry3<f64>, String> {
    if q.iter().chain(t.iter()).any(|v| !v.is_finite()) {
        return Err(format!("pose qvec {q:?} tvec {t:?} is not finite"));
    }
    let quat = Quaternion::new(q[0], q[1], q[2], q[3]);
    let n2 = quat.norm_squared();
    if n2 < 1e-20 {
        return Err(format!("quaternion {q:?} is zero and has no rotation"));
    }
    let rot = if (n2 - 1.0).abs() < 1e-12 {
        UnitQuaternion::new_unchecked(quat)
    } else {
        UnitQuaternion::new_normalize(quat)
    };
    Ok(Isometry3::from_parts(
        Translation3::new(t[0], t[1], t[2]),
        rot,
    ))
}

/// COLMAP's `qvec` (w, x, y, z) and `tvec` of a pose.
pub(crate) fn qt_from_pose(pose: &Isometry3<f64>) -> ([f64; 4], [f64; 3]) {
    let q = pose.rotation.quaternion();
    let t = pose.translation.vector;
    ([q.w, q.i, q.j, q.k], [t.x, t.y, t.z])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn model_ids_names_and_param_counts_match_colmap() {
        let expected = [
            ("SIMPLE_PINHOLE", 3),
            ("PINHOLE", 4),
            ("SIMPLE_RADIAL", 4),
            ("RADIAL", 5),
            ("OPENCV", 8),
            ("OPENCV_FISHEYE", 8),
            ("FULL_OPENCV", 12),
            ("FOV", 5),
            ("SIMPLE_RADIAL_FISHEYE", 4),
            ("RADIAL_FISHEYE", 5),
            ("THIN_PRISM_FISHEYE", 12),
            ("RAD_TAN_THIN_PRISM_FISHEYE", 16),
            ("SIMPLE_DIVISION", 4),
            ("DIVISION", 5),
            ("SIMPLE_FISHEYE", 3),
            ("FISHEYE", 4),
            ("EUCM", 6),
            ("EQUIRECTANGULAR", 2),
        ];
        for (id, (name, n)) in expected.iter().enumerate() {
            let m = CameraModel::from_id(id as i32).unwrap();
            assert_eq!(m.id(), id as i32);
            assert_eq!(m.name(), *name);
            assert_eq!(m.num_params(), *n, "{name}");
            assert_eq!(CameraModel::from_name(name), Some(m));
        }
        assert_eq!(CameraModel::from_id(18), None);
        assert_eq!(CameraModel::from_id(-1), None);
        assert_eq!(CameraModel::from_name("pinhole"), None);
    }

    fn cam(model: CameraModel, params: Vec<f64>) -> ColmapCamera {
        ColmapCamera {
            id: 1,
            model,
            width: 640,
            height: 480,
            params,
        }
    }

    #[test]
    fn pinhole_reads_focal_and_principal_point_of_every_model() {
        for model in CameraModel::ALL {
            // Parameters 100, 101, 102, ...: the mapping is visible in the result.
            let params: Vec<f64> = (0..model.num_params()).map(|i| 100.0 + i as f64).collect();
            let c = cam(model, params);
            if model == CameraModel::Equirectangular {
                assert!(c.pinhole().is_err());
                continue;
            }
            let k = c.pinhole().unwrap();
            let (fx, fy, cx, cy) = if model.single_focal() {
                (100.0, 100.0, 101.0, 102.0)
            } else {
                (100.0, 101.0, 102.0, 103.0)
            };
            assert_eq!((k.fx, k.fy, k.cx, k.cy), (fx, fy, cx, cy), "{model}");
            assert_eq!((k.width, k.height), (640, 480));
        }
    }

    #[test]
    fn pinhole_of_known_cameras() {
        let k = cam(CameraModel::SimpleRadial, vec![500.0, 320.0, 240.0, -0.1])
            .pinhole()
            .unwrap();
        assert_eq!((k.fx, k.fy, k.cx, k.cy), (500.0, 500.0, 320.0, 240.0));
        let opencv = vec![510.0, 505.0, 321.0, 239.0, 0.1, -0.02, 0.001, 0.002];
        let k = cam(CameraModel::OpenCv, opencv).pinhole().unwrap();
        assert_eq!((k.fx, k.fy, k.cx, k.cy), (510.0, 505.0, 321.0, 239.0));
        let err = cam(CameraModel::Pinhole, vec![500.0, 320.0, 240.0])
            .pinhole()
            .unwrap_err();
        assert!(
            err.to_string()
                .contains("camera 1: PINHOLE expects 4 parameters, found 3"),
            "{err}"
        );
        let err = cam(CameraModel::SimplePinhole, vec![0.0, 320.0, 240.0])
            .pinhole()
            .unwrap_err();
        assert!(err.to_string().contains("focal length"), "{err}");
    }

    #[test]
    fn zero_quaternion_is_rejected_and_others_normalised() {
        assert!(pose_from_qt([0.0; 4], [0.0; 3])
            .unwrap_err()
            .contains("zero"));
        let p = pose_from_qt([2.0, 0.0, 0.0, 0.0], [1.0, 2.0, 3.0]).unwrap();
        assert!((p.rotation.angle()).abs() < 1e-15);
        let q = [0.5f64.sqrt(), 0.5f64.sqrt(), 0.0, 0.0];
        let p = pose_from_qt(q, [0.0; 3]).unwrap();
        assert_eq!(
            qt_from_pose(&p).0.map(f64::to_bits),
            q.map(f64::to_bits),
            "unit quaternion kept bit for bit"
        );
    }
}
