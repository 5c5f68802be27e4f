//! Similarity transforms in 3D (scale, rotation, translation) and their
//! least-squares estimate from point pairs (Umeyama 1991): what ties a
//! sparse model to the world (`colmap::align_to_positions`) and what a
//! model's `frame.json` records.

use nalgebra::{Matrix3, Point3, Rotation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// A similarity transform `x -> scale * rotation * x + translation`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Sim3 {
    /// Scale factor.
    pub scale: f64,
    /// Rotation as a unit quaternion `[w, x, y, z]`.
    pub rotation_wxyz: [f64; 4],
    /// Translation.
    pub translation: [f64; 3],
}

impl Sim3 {
    /// The rotation as a unit quaternion.
    #[must_use]
    pub fn rotation(&self) -> UnitQuaternion<f64> {
        let [w, x, y, z] = self.rotation_wxyz;
        UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z))
    }

    /// Applies the transform to a point.
    pub fn apply(&self, p: &Point3<f64>) -> Point3<f64> {
        let t = Vector3::from(self.translation);
        Point3::from(self.rotation() * (p.coords * self.scale) + t)
    }
}

/// Least-squares similarity from `src` to `dst` (Umeyama 1991). `None` when
/// the source points are degenerate (coincident).
pub fn umeyama(src: &[Point3<f64>], dst: &[Point3<f64>]) -> Option<Sim3> {
    let n = src.len() as f64;
    if src.len() < 3 || src.len() != dst.len() {
        return None;
    }
    let ms = src.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n;
    let md = dst.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n;
    let mut cov = Matrix3::zeros();
    let mut var_s = 0.0;
    for (s, d) in src.iter().zip(dst) {
        let (a, b) = (s.coords - ms, d.coords - md);
        cov += b * a.transpose();
        var_s += a.norm_squared();
    }
    cov /= n;
    var_s /= n;
    if var_s <= f64::EPSILON {
        return None;
    }
    let svd = cov.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let mut sgn = Matrix3::identity();
    if (u.determinant() * vt.determinant()) < 0.0 {
        sgn[(2, 2)] = -1.0;
    }
    let r = u * sgn * vt;
    let d = svd.singular_values;
    let trace = d[0] * sgn[(0, 0)] + d[1] * sgn[(1, 1)] + d[2] * sgn[(2, 2)];
    let scale = trace / var_s;
    if !(scale.is_finite() && scale > 0.0) {
        return None;
    }
    let t = md - scale * (r * ms);
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    Some(Sim3 {
        scale,
        rotation_wxyz: [q.w, q.i, q.j, q.k],
        translation: [t.x, t.y, t.z],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn umeyama_recovers_a_known_similarity() {
        let truth = Sim3 {
            scale: 2.5,
            rotation_wxyz: {
                let q = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1);
                [q.w, q.i, q.j, q.k]
            },
            translation: [10.0, -4.0, 3.0],
        };
        let src: Vec<_> = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.2],
            [0.0, 2.0, 0.0],
            [1.0, 1.0, 1.0],
        ]
        .iter()
        .map(|p| Point3::from(*p))
        .collect();
        let dst: Vec<_> = src.iter().map(|p| truth.apply(p)).collect();
        let est = umeyama(&src, &dst).unwrap();
        assert!((est.scale - 2.5).abs() < 1e-9);
        for p in &src {
            assert!((est.apply(p) - truth.apply(p)).norm() < 1e-9);
        }
    }
}
