//! The full COLMAP camera models: projection of a normalised pinhole
//! coordinate through the lens into a pixel, and back.
//!
//! A "normalised pinhole coordinate" `(u, v)` is the direction `(u, v, 1)`
//! in the camera frame (x right, y down, z forward). Pixels follow COLMAP:
//! the top-left image corner is `(0, 0)`, pixel centres are at `+0.5`.
//!
//! The formulas follow COLMAP's camera models (its `models.h`): an additive
//! distortion in the normalised image plane for the perspective models, in
//! the equidistant fisheye plane (`theta = atan(r)`) for the fisheye models,
//! and closed forms for `FOV`, `SIMPLE_DIVISION` / `DIVISION` and `EUCM`.
//! Where the model has no closed-form inverse, [`ColmapCamera::cam_from_img`]
//! inverts the distortion by Newton's method, as COLMAP's
//! `IterativeUndistortion` does.

use super::model::{CameraModel, ColmapCamera};

/// How a model bends rays before its additive distortion.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Projection {
    /// Pinhole plane `(u, v)`, then additive distortion.
    Perspective,
    /// Equidistant fisheye plane `theta * (u, v) / r`, then additive distortion.
    Fisheye,
    /// `FOV` (Devernay and Faugeras), closed form both ways.
    Fov,
    /// Fitzgibbon's division model, closed form both ways.
    Division,
    /// Enhanced unified camera model, closed form both ways.
    Eucm,
}

fn projection(model: CameraModel) -> Option<Projection> {
    use CameraModel as M;
    Some(match model {
        M::SimplePinhole | M::Pinhole | M::SimpleRadial | M::Radial | M::OpenCv | M::FullOpenCv => {
            Projection::Perspective
        }
        M::OpenCvFisheye
        | M::SimpleRadialFisheye
        | M::RadialFisheye
        | M::ThinPrismFisheye
        | M::RadTanThinPrismFisheye
        | M::SimpleFisheye
        | M::Fisheye => Projection::Fisheye,
        M::Fov => Projection::Fov,
        M::SimpleDivision | M::Division => Projection::Division,
        M::Eucm => Projection::Eucm,
        M::Equirectangular => return None,
    })
}

/// The additive distortion `(du, dv)` of the model at `(u, v)` (in the plane
/// its [`Projection`] names); zero for models without one.
fn distortion(model: CameraModel, k: &[f64], u: f64, v: f64) -> (f64, f64) {
    use CameraModel as M;
    let (u2, v2, uv) = (u * u, v * v, u * v);
    let r2 = u2 + v2;
    match model {
        // In the fisheye plane r is theta: same polynomial, other plane.
        M::SimpleRadial | M::SimpleRadialFisheye => (u * k[0] * r2, v * k[0] * r2),
        M::Radial | M::RadialFisheye => {
            let radial = k[0] * r2 + k[1] * r2 * r2;
            (u * radial, v * radial)
        }
        M::OpenCv => {
            let radial = k[0] * r2 + k[1] * r2 * r2;
            (
                u * radial + 2.0 * k[2] * uv + k[3] * (r2 + 2.0 * u2),
                v * radial + 2.0 * k[3] * uv + k[2] * (r2 + 2.0 * v2),
            )
        }
        M::FullOpenCv => {
            // k1, k2, p1, p2, k3, k4, k5, k6
            let (r4, r6) = (r2 * r2, r2 * r2 * r2);
            let radial = (1.0 + k[0] * r2 + k[1] * r4 + k[4] * r6)
                / (1.0 + k[5] * r2 + k[6] * r4 + k[7] * r6);
            (
                u * radial + 2.0 * k[2] * uv + k[3] * (r2 + 2.0 * u2) - u,
                v * radial + 2.0 * k[3] * uv + k[2] * (r2 + 2.0 * v2) - v,
            )
        }
        M::OpenCvFisheye => {
            let radial =
                k[0] * r2 + k[1] * r2 * r2 + k[2] * r2 * r2 * r2 + k[3] * r2 * r2 * r2 * r2;
            (u * radial, v * radial)
        }
        M::ThinPrismFisheye => {
            // k1, k2, p1, p2, k3, k4, sx1, sy1
            let (r4, r6, r8) = (r2 * r2, r2 * r2 * r2, r2 * r2 * r2 * r2);
            let radial = k[0] * r2 + k[1] * r4 + k[4] * r6 + k[5] * r8;
            (
                u * radial + 2.0 * k[2] * uv + k[3] * (r2 + 2.0 * u2) + k[6] * r2,
                v * radial + 2.0 * k[3] * uv + k[2] * (r2 + 2.0 * v2) + k[7] * r2,
            )
        }
        M::RadTanThinPrismFisheye => {
            // k0..k5, p0, p1, s0..s3 (Project Aria's Fisheye624)
            let mut th_radial = 1.0;
            let mut power = 1.0;
            for c in &k[..6] {
                power *= r2;
                th_radial += c * power;
            }
            let (x, y) = (th_radial * u, th_radial * v);
            let (x2, y2, xy) = (x * x, y * y, x * y);
            let rr2 = x2 + y2;
            let rr4 = rr2 * rr2;
            let (p0, p1) = (k[6], k[7]);
            let xd = x + 2.0 * p1 * xy + p0 * (rr2 + 2.0 * x2) + k[8] * rr2 + k[9] * rr4;
            let yd = y + 2.0 * p0 * xy + p1 * (rr2 + 2.0 * y2) + k[10] * rr2 + k[11] * rr4;
            (xd - u, yd - v)
        }
        _ => (0.0, 0.0),
    }
}

/// Inverts `x + distortion(x) = target` by Newton's method with a
/// central-difference Jacobian (COLMAP's `IterativeUndistortion`).
fn undistort_iterative(model: CameraModel, k: &[f64], target: (f64, f64)) -> Option<(f64, f64)> {
    const ITERATIONS: usize = 100;
    const REL_STEP: f64 = 1e-6;
    let (mut x, mut y) = target;
    for _ in 0..ITERATIONS {
        let sx = (REL_STEP * x.abs()).max(f64::EPSILON);
        let sy = (REL_STEP * y.abs()).max(f64::EPSILON);
        let (dx, dy) = distortion(model, k, x, y);
        let (ax, ay) = distortion(model, k, x - sx, y);
        let (bx, by) = distortion(model, k, x + sx, y);
        let (cx, cy) = distortion(model, k, x, y - sy);
        let (ex, ey) = distortion(model, k, x, y + sy);
        let j00 = 1.0 + (bx - ax) / (2.0 * sx);
        let j01 = (ex - cx) / (2.0 * sy);
        let j10 = (by - ay) / (2.0 * sx);
        let j11 = 1.0 + (ey - cy) / (2.0 * sy);
        let det = j00 * j11 - j01 * j10;
        if det.abs() < f64::MIN_POSITIVE || !det.is_finite() {
            return None;
        }
        let (rx, ry) = (x + dx - target.0, y + dy - target.1);
        let stepx = (j11 * rx - j01 * ry) / det;
        let stepy = (-j10 * rx + j00 * ry) / det;
        x -= stepx;
        y -= stepy;
        if !(x.is_finite() && y.is_finite()) {
            return None;
        }
        if stepx * stepx + stepy * stepy < 1e-26 {
            break;
        }
    }
    Some((x, y))
}

fn fisheye_from_normal(u: f64, v: f64) -> (f64, f64) {
    let r = u.hypot(v);
    if r > f64::EPSILON {
        let s = r.atan() / r;
        (u * s, v * s)
    } else {
        (u, v)
    }
}

fn normal_from_fisheye(uu: f64, vv: f64) -> Option<(f64, f64)> {
    let theta = uu.hypot(vv);
    if theta >= std::f64::consts::FRAC_PI_2 {
        return None;
    }
    let tc = theta * theta.cos();
    if tc > f64::EPSILON {
        let s = theta.sin() / tc;
        Some((uu * s, vv * s))
    } else {
        Some((uu, vv))
    }
}

fn fov_distort(omega: f64, u: f64, v: f64) -> (f64, f64) {
    const EPS: f64 = 1e-4;
    let r2 = u * u + v * v;
    let w2 = omega * omega;
    let factor = if w2 < EPS {
        1.0 + w2 / 12.0 - w2 * r2 / 3.0
    } else if r2 < EPS {
        let t = (omega / 2.0).tan();
        -2.0 * t * (4.0 * r2 * t * t - 3.0) / (3.0 * omega)
    } else {
        let r = r2.sqrt();
        (r * 2.0 * (omega / 2.0).tan()).atan() / (r * omega)
    };
    (u * factor, v * factor)
}

fn fov_undistort(omega: f64, u: f64, v: f64) -> (f64, f64) {
    const EPS: f64 = 1e-4;
    let r2 = u * u + v * v;
    let w2 = omega * omega;
    let factor = if w2 < EPS {
        w2 * r2 / 3.0 - w2 / 12.0 + 1.0
    } else if r2 < EPS {
        omega * (w2 * r2 + 3.0) / (6.0 * (omega / 2.0).tan())
    } else {
        let r = r2.sqrt();
        (r * omega).tan() / (r * 2.0 * (omega / 2.0).tan())
    };
    (u * factor, v * factor)
}

impl ColmapCamera {
    /// Focal lengths and principal point `(fx, fy, cx, cy)` of the model's
    /// parameters (`None` for `EQUIRECTANGULAR` or a wrong parameter count).
    pub fn focal_and_principal_point(&self) -> Option<(f64, f64, f64, f64)> {
        if self.model == CameraModel::Equirectangular
            || self.params.len() != self.model.num_params()
        {
            return None;
        }
        let p = &self.params;
        Some(if self.model.single_focal() {
            (p[0], p[0], p[1], p[2])
        } else {
            (p[0], p[1], p[2], p[3])
        })
    }

    /// The model's parameters after focal length and principal point.
    pub fn extra_params(&self) -> &[f64] {
        let skip = if self.model.single_focal() { 3 } else { 4 };
        self.params.get(skip..).unwrap_or(&[])
    }

    /// Whether projecting with the camera differs from its pinhole
    /// approximation ([`ColmapCamera::pinhole`]): every fisheye, `FOV`,
    /// `EUCM` and `EQUIRECTANGULAR` camera, and every perspective or
    /// division model with a non-zero distortion parameter.
    pub fn is_distorted(&self) -> bool {
        let plain = matches!(
            projection(self.model),
            Some(Projection::Perspective | Projection::Division)
        );
        !plain || self.extra_params().iter().any(|&k| k != 0.0)
    }

    /// The pixel a normalised pinhole coordinate `(u, v)` (the ray
    /// `(u, v, 1)` in the camera frame) projects to through the full camera
    /// model, distortion included. `None` where the model cannot project it
    /// (outside a division or EUCM model's domain, an equirectangular camera,
    /// a wrong parameter count).
    pub fn img_from_cam(&self, u: f64, v: f64) -> Option<(f64, f64)> {
        let (fx, fy, cx, cy) = self.focal_and_principal_point()?;
        let k = self.extra_params();
        let (xd, yd) = match projection(self.model)? {
            Projection::Perspective => {
                let (du, dv) = distortion(self.model, k, u, v);
                (u + du, v + dv)
            }
            Projection::Fisheye => {
                let (uu, vv) = fisheye_from_normal(u, v);
                let (du, dv) = distortion(self.model, k, uu, vv);
                (uu + du, vv + dv)
            }
            Projection::Fov => fov_distort(k[0], u, v),
            Projection::Division => {
                let rho2 = u * u + v * v;
                let disc2 = 1.0 - 4.0 * rho2 * k[0];
                if disc2 < 0.0 {
                    return None;
                }
                let s = 2.0 / (1.0 + disc2.sqrt());
                (u * s, v * s)
            }
            Projection::Eucm => {
                let (alpha, beta) = (k[0], k[1]);
                let rho2 = beta * (u * u + v * v) + 1.0;
                if rho2 < 0.0 {
                    return None;
                }
                let den = alpha * rho2.sqrt() + (1.0 - alpha);
                if den <= f64::EPSILON {
                    return None;
                }
                (u / den, v / den)
            }
        };
        let (x, y) = (fx * xd + cx, fy * yd + cy);
        (x.is_finite() && y.is_finite()).then_some((x, y))
    }

    /// The normalised pinhole coordinate `(u, v)` of pixel `(x, y)`: the
    /// inverse of [`ColmapCamera::img_from_cam`]. `None` where the pixel has
    /// no ray in front of the camera plane (beyond 90 degrees of a fisheye,
    /// outside an EUCM model's domain) or the iteration fails.
    pub fn cam_from_img(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        let (fx, fy, cx, cy) = self.focal_and_principal_point()?;
        let k = self.extra_params();
        let (xd, yd) = ((x - cx) / fx, (y - cy) / fy);
        let (u, v) = match projection(self.model)? {
            Projection::Perspective => undistort_iterative(self.model, k, (xd, yd))?,
            Projection::Fisheye => {
                let (uu, vv) = undistort_iterative(self.model, k, (xd, yd))?;
                normal_from_fisheye(uu, vv)?
            }
            Projection::Fov => fov_undistort(k[0], xd, yd),
            Projection::Division => {
                let den = 1.0 + k[0] * (xd * xd + yd * yd);
                (xd / den, yd / den)
            }
            Projection::Eucm => {
                let (alpha, beta) = (k[0], k[1]);
                let r2 = xd * xd + yd * yd;
                let gamma = 1.0 - alpha;
                let radicand = 1.0 - (alpha - gamma) * beta * r2;
                if radicand < 0.0 {
                    return None;
                }
                let helper_den = alpha * radicand.sqrt() + gamma;
                if helper_den < f64::EPSILON {
                    return None;
                }
                let helper = (1.0 - alpha * alpha * beta * r2) / helper_den;
                if helper < f64::EPSILON {
                    return None;
                }
                (xd / helper, yd / helper)
            }
        };
        (u.is_finite() && v.is_finite()).then_some((u, v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(model: CameraModel) -> ColmapCamera {
        let n = model.num_params();
        let nf = if model.single_focal() { 1 } else { 2 };
        let mut params = vec![0.0; n];
        for (i, p) in params.iter_mut().enumerate() {
            *p = if i < nf {
                300.0 + 10.0 * i as f64
            } else if i == nf {
                160.0
            } else if i == nf + 1 {
                120.0
            } else {
                // Small, alternating distortion terms.
                0.02 * if i % 2 == 0 { 1.0 } else { -0.5 } / (i - nf) as f64
            };
        }
        match model {
            CameraModel::Fov => params[4] = 0.8,
            CameraModel::Eucm => {
                params[4] = 0.6;
                params[5] = 1.1;
            }
            CameraModel::SimpleDivision => params[3] = -0.1,
            CameraModel::Division => params[4] = -0.1,
            _ => {}
        }
        ColmapCamera {
            id: 1,
            model,
            width: 320,
            height: 240,
            params,
        }
    }

    #[test]
    fn every_model_round_trips_pixels_through_its_rays() {
        for model in CameraModel::ALL {
            if model == CameraModel::Equirectangular {
                continue;
            }
            let cam = camera(model);
            for (x, y) in [(0.5, 0.5), (160.0, 120.0), (319.5, 10.0), (40.0, 239.5)] {
                let (u, v) = cam.cam_from_img(x, y).unwrap();
                let (x2, y2) = cam.img_from_cam(u, v).unwrap();
                assert!(
                    (x - x2).abs() < 1e-6 && (y - y2).abs() < 1e-6,
                    "{model}: ({x}, {y}) -> ({u}, {v}) -> ({x2}, {y2})"
                );
            }
        }
    }

    #[test]
    fn zero_distortion_is_not_distorted_but_fisheye_is() {
        let mut cam = camera(CameraModel::OpenCv);
        assert!(cam.is_distorted());
        for p in &mut cam.params[4..] {
            *p = 0.0;
        }
        assert!(!cam.is_distorted());
        assert!(camera(CameraModel::Fisheye).is_distorted());
        assert!(!camera(CameraModel::Pinhole).is_distorted());
    }
}
