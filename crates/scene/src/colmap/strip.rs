//! Alignment of a single strip (`vpctl colmap align --gravity-from-views`):
//! camera centres on a line fix scale, translation and the line's
//! direction, but not the rotation about the line. Cameras that look down
//! (nadir or oblique) fix it: the rotation that turns their mean viewing
//! direction as far down as possible.

use nalgebra::{Matrix3, Point3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::sim3::Sim3;

/// Centroid and scatter matrix (sum of outer products of the centred
/// points) of a non-empty point set.
pub(super) fn mean_and_scatter(points: &[Point3<f64>]) -> (Vector3<f64>, Matrix3<f64>) {
    let n = points.len() as f64;
    let m = points.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n;
    let mut cov = Matrix3::zeros();
    for p in points {
        let a = p.coords - m;
        cov += a * a.transpose();
    }
    (m, cov)
}

/// Centroid and unit principal direction of a point set.
fn principal_axis(points: &[Point3<f64>]) -> (Vector3<f64>, Vector3<f64>) {
    let (m, cov) = mean_and_scatter(points);
    let eig = cov.symmetric_eigen();
    let i = eig.eigenvalues.imax();
    (m, eig.eigenvectors.column(i).normalize())
}

/// The angle of the rotation about the unit axis `u` that turns `v` as far
/// towards ENU down (-z) as possible; `None` if `v` or down is (nearly)
/// parallel to `u`, so that no rotation about `u` moves them.
fn roll_down(v: &Vector3<f64>, u: &Vector3<f64>) -> Option<f64> {
    let p = v - u * v.dot(u);
    let down = -Vector3::z();
    let g = down - u * down.dot(u);
    if p.norm() < 1e-9 || g.norm() < 1e-9 {
        return None;
    }
    Some(u.dot(&p.cross(&g)).atan2(p.dot(&g)))
}

/// A similarity from points on a line to points on a line: the line onto
/// the line (scale and offset along it by least squares), then the rotation
/// about it that makes `view` (a model direction) point as far down as
/// possible. `None` for coincident points.
pub(super) fn fit_strip(
    src: &[Point3<f64>],
    dst: &[Point3<f64>],
    view: &Vector3<f64>,
) -> Option<Sim3> {
    let (ms, us) = principal_axis(src);
    let (md, mut ud) = principal_axis(dst);
    let a_s: Vec<f64> = src.iter().map(|p| (p.coords - ms).dot(&us)).collect();
    let mut a_d: Vec<f64> = dst.iter().map(|p| (p.coords - md).dot(&ud)).collect();
    let mut cross: f64 = a_s.iter().zip(&a_d).map(|(s, d)| s * d).sum();
    if cross < 0.0 {
        ud = -ud;
        for d in &mut a_d {
            *d = -*d;
        }
        cross = -cross;
    }
    let var: f64 = a_s.iter().map(|s| s * s).sum();
    if var <= f64::EPSILON {
        return None;
    }
    let scale = cross / var;
    if !(scale.is_finite() && scale > 0.0) {
        return None;
    }
    let r0 = UnitQuaternion::rotation_between(&us, &ud).unwrap_or_else(|| {
        // Opposite directions: half a turn about any perpendicular axis.
        let axis = us.cross(&Vector3::x()).try_normalize(1e-6);
        let axis = axis.unwrap_or_else(|| us.cross(&Vector3::y()).normalize());
        UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_unchecked(axis), std::f64::consts::PI)
    });
    let theta = roll_down(&(r0 * view), &ud)?;
    let r = UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_unchecked(ud), theta) * r0;
    let t = md - scale * (r * ms);
    Some(Sim3 {
        scale,
        rotation_wxyz: [r.w, r.i, r.j, r.k],
        translation: [t.x, t.y, t.z],
    })
}

/// The cameras lie on a line and their direction is taken from the mean
/// viewing direction ([`super::AlignParams::gravity_from_views`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StripFit {
    /// Angle of the aligned mean viewing direction below the horizon
    /// (degrees; 90 is straight down).
    pub view_tilt_deg: f64,
    /// Angle between the mean viewing direction and the line (degrees).
    pub view_to_line_deg: f64,
}

/// Below this angle (degrees) between the mean viewing direction and the
/// cameras' line, or between the positions' line and the vertical, the
/// viewing direction does not fix the rotation about the line.
const MIN_STRIP_ANGLE_DEG: f64 = 10.0;

/// The unit mean viewing direction (model frame) of cameras on a line, and
/// its angle to the line; an error message when it cannot fix the rotation
/// about the line: the views disagree, look along the line, the positions
/// run vertically, or the cameras could not be turned to look down.
pub(super) fn strip_view(
    src: &[Point3<f64>],
    dst: &[Point3<f64>],
    views: &[Vector3<f64>],
) -> std::result::Result<(Vector3<f64>, StripFit), String> {
    let n = views.len() as f64;
    let mean = views.iter().fold(Vector3::zeros(), |a, v| a + v) / n;
    if mean.norm() < 0.5 {
        return Err(format!(
            "the cameras lie on a line and their viewing directions disagree (mean of the unit \
             directions {:.2} long), so --gravity-from-views cannot tell down",
            mean.norm()
        ));
    }
    let view = mean.normalize();
    let (_, us) = principal_axis(src);
    let (_, ud) = principal_axis(dst);
    let to_line = view.dot(&us).abs().min(1.0).acos().to_degrees();
    if to_line < MIN_STRIP_ANGLE_DEG {
        return Err(format!(
            "the cameras lie on a line and look along it ({to_line:.1} degrees from it), so \
             --gravity-from-views cannot fix the rotation about the line"
        ));
    }
    let from_vertical = ud.z.abs().min(1.0).acos().to_degrees();
    if from_vertical < MIN_STRIP_ANGLE_DEG {
        return Err(format!(
            "the positions lie on a nearly vertical line ({from_vertical:.1} degrees from it), \
             so --gravity-from-views cannot fix the rotation about it"
        ));
    }
    if let Some(s) = fit_strip(src, dst, &view) {
        let tilt = (-(s.rotation() * view).z).asin().to_degrees();
        if tilt <= 0.0 {
            return Err(format!(
                "the cameras lie on a line and cannot be turned to look below the horizon \
                 (best {tilt:.1} degrees), so --gravity-from-views does not apply"
            ));
        }
    }
    Ok((
        view,
        StripFit {
            view_tilt_deg: f64::NAN,
            view_to_line_deg: to_line,
        },
    ))
}
