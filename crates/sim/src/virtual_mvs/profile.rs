//! Truth curves of the virtual MVS: per material, the probability that a
//! pixel is reconstructed as a function of its triangulation angle and its
//! ground sampling distance.

use serde::{Deserialize, Serialize};
use vp_scene::Material;

use crate::error::{Result, SimError};

/// Success probability of one material: a piecewise-linear curve over the
/// triangulation angle (clamped at both ends), times a resolution factor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialCurve {
    /// Increasing triangulation angles of the knots, degrees.
    pub angles_deg: Vec<f64>,
    /// Success probability at each knot, in [0, 1].
    pub success: Vec<f64>,
    /// Exponent e of the resolution factor `min(1, (gsd / gsd_ref)^e)`:
    /// positive means fine resolution (close-ups) hurts, as for grass that is
    /// easy from far away and hard up close (paper, Fig. 4); negative means
    /// coarse resolution hurts; 0 switches the factor off.
    pub gsd_exponent: f64,
}

impl MaterialCurve {
    /// A curve through `(angle_deg, success)` knots.
    pub fn new(knots: &[(f64, f64)], gsd_exponent: f64) -> Self {
        MaterialCurve {
            angles_deg: knots.iter().map(|k| k.0).collect(),
            success: knots.iter().map(|k| k.1).collect(),
            gsd_exponent,
        }
    }

    /// The curve's value at `angle_deg` (linear between knots, clamped outside).
    pub fn at_angle(&self, angle_deg: f64) -> f64 {
        let a = &self.angles_deg;
        let i = a.partition_point(|&x| x <= angle_deg);
        if i == 0 {
            return self.success[0];
        }
        if i == a.len() {
            return self.success[a.len() - 1];
        }
        let t = (angle_deg - a[i - 1]) / (a[i] - a[i - 1]);
        self.success[i - 1] + t * (self.success[i] - self.success[i - 1])
    }

    fn validate(&self, name: &str) -> Result<()> {
        let bad = |m: String| {
            Err(SimError::InvalidArgument(format!(
                "profile curve '{name}': {m}"
            )))
        };
        if self.angles_deg.is_empty() || self.angles_deg.len() != self.success.len() {
            return bad(format!(
                "{} angles and {} success values: need the same non-zero number",
                self.angles_deg.len(),
                self.success.len()
            ));
        }
        if let Some(i) =
            (1..self.angles_deg.len()).find(|&i| !(self.angles_deg[i] > self.angles_deg[i - 1]))
        {
            let (a, b) = (self.angles_deg[i - 1], self.angles_deg[i]);
            return bad(format!("angles must increase, found {a} then {b}"));
        }
        if let Some(a) = self.angles_deg.iter().find(|a| !a.is_finite()) {
            return bad(format!("angle {a} is not finite"));
        }
        if let Some(s) = self.success.iter().find(|s| !(0.0..=1.0).contains(*s)) {
            return bad(format!("success probability {s} is outside [0, 1]"));
        }
        if !self.gsd_exponent.is_finite() {
            return bad(format!("gsd_exponent {} is not finite", self.gsd_exponent));
        }
        Ok(())
    }
}

/// How a dense MVS algorithm behaves: success curves per material, depth
/// noise, outliers, and the size of failure blobs. Serialisable (TOML/JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MvsProfile {
    /// Name shown in reports ("sure-like", "pmvs-like", or the user's).
    pub name: String,
    /// Curve of [`Material::Ground`].
    pub ground: MaterialCurve,
    /// Curve of [`Material::Rock`].
    pub rock: MaterialCurve,
    /// Curve of [`Material::Grass`].
    pub grass: MaterialCurve,
    /// Curve of [`Material::Tree`].
    pub tree: MaterialCurve,
    /// Curve of [`Material::Marker`].
    pub marker: MaterialCurve,
    /// Reference ground sampling distance of the resolution factor, metres per pixel.
    pub gsd_ref_m: f64,
    /// Image noise of the matcher, pixels of the reconstructed pyramid level
    /// (sigma_px of docs/design.md#shared-geometry); depth noise follows
    /// from it by first-order propagation through the triplet.
    pub sigma_px: f64,
    /// Share of reconstructed pixels whose depth is an outlier, in [0, 1).
    pub outlier_share: f64,
    /// Typical diameter of failure blobs, pixels.
    pub blob_size_px: f64,
}

impl MvsProfile {
    /// A semi-global-matching-like algorithm (SURE, paper Fig. 4): confidence
    /// highest at small angles for every material; smooth surfaces (rock,
    /// marker) stay reconstructable across angles, ground moderately, grass and
    /// trees drop to nearly zero above about 30 deg and are harder up close.
    pub fn sure_like() -> Self {
        MvsProfile {
            name: "sure-like".into(),
            ground: MaterialCurve::new(
                &[
                    (0.0, 0.86),
                    (5.0, 0.82),
                    (10.0, 0.76),
                    (20.0, 0.62),
                    (30.0, 0.48),
                    (45.0, 0.32),
                    (90.0, 0.1),
                ],
                0.0,
            ),
            rock: MaterialCurve::new(
                &[
                    (0.0, 0.96),
                    (5.0, 0.94),
                    (10.0, 0.92),
                    (20.0, 0.88),
                    (30.0, 0.83),
                    (45.0, 0.76),
                    (90.0, 0.5),
                ],
                0.0,
            ),
            grass: MaterialCurve::new(
                &[
                    (0.0, 0.82),
                    (5.0, 0.72),
                    (10.0, 0.52),
                    (20.0, 0.22),
                    (30.0, 0.04),
                    (40.0, 0.0),
                ],
                0.5,
            ),
            tree: MaterialCurve::new(
                &[
                    (0.0, 0.72),
                    (5.0, 0.6),
                    (10.0, 0.4),
                    (20.0, 0.14),
                    (30.0, 0.02),
                    (40.0, 0.0),
                ],
                0.5,
            ),
            marker: MaterialCurve::new(
                &[
                    (0.0, 0.97),
                    (5.0, 0.96),
                    (10.0, 0.94),
                    (20.0, 0.9),
                    (30.0, 0.86),
                    (45.0, 0.8),
                    (90.0, 0.55),
                ],
                0.0,
            ),
            gsd_ref_m: 0.02,
            sigma_px: 1.0,
            outlier_share: 0.01,
            blob_size_px: 8.0,
        }
    }

    /// A patch-expansion-like algorithm (PMVS, paper Fig. 4): flat in angle on
    /// smooth surfaces, and more fragile than SURE on non-planar structures.
    pub fn pmvs_like() -> Self {
        MvsProfile {
            name: "pmvs-like".into(),
            ground: MaterialCurve::new(
                &[
                    (0.0, 0.72),
                    (10.0, 0.7),
                    (20.0, 0.62),
                    (30.0, 0.5),
                    (45.0, 0.34),
                    (90.0, 0.1),
                ],
                0.0,
            ),
            rock: MaterialCurve::new(&[(0.0, 0.86), (45.0, 0.86), (90.0, 0.6)], 0.0),
            grass: MaterialCurve::new(
                &[
                    (0.0, 0.55),
                    (5.0, 0.44),
                    (10.0, 0.28),
                    (20.0, 0.07),
                    (30.0, 0.0),
                ],
                0.6,
            ),
            tree: MaterialCurve::new(
                &[
                    (0.0, 0.45),
                    (5.0, 0.34),
                    (10.0, 0.2),
                    (20.0, 0.04),
                    (30.0, 0.0),
                ],
                0.6,
            ),
            marker: MaterialCurve::new(&[(0.0, 0.9), (45.0, 0.9), (90.0, 0.65)], 0.0),
            gsd_ref_m: 0.02,
            sigma_px: 1.0,
            outlier_share: 0.01,
            blob_size_px: 12.0,
        }
    }

    /// The curve of `material`.
    pub fn curve(&self, material: Material) -> &MaterialCurve {
        match material {
            Material::Ground => &self.ground,
            Material::Rock => &self.rock,
            Material::Grass => &self.grass,
            Material::Tree => &self.tree,
            Material::Marker => &self.marker,
        }
    }

    /// The truth: probability that the MVS reconstructs a pixel whose surface
    /// point (visible in all three images) has `material`, triangulation
    /// angle `angle_deg` and ground sampling distance `gsd_m` (metres per
    /// pixel in the query image at its pyramid level; pass `None` to read the
    /// curve at the reference resolution).
    pub fn success_probability(
        &self,
        material: Material,
        angle_deg: f64,
        gsd_m: Option<f64>,
    ) -> f64 {
        let curve = self.curve(material);
        let mut p = curve.at_angle(angle_deg);
        if let Some(gsd) = gsd_m {
            if curve.gsd_exponent != 0.0 && gsd > 0.0 {
                p *= (gsd / self.gsd_ref_m).powf(curve.gsd_exponent).min(1.0);
            }
        }
        p.clamp(0.0, 1.0)
    }

    /// Checks every curve and parameter; the error names the field.
    pub fn validate(&self) -> Result<()> {
        for m in Material::ALL {
            self.curve(m).validate(m.name())?;
        }
        let bad = |m: String| {
            Err(SimError::InvalidArgument(format!(
                "profile '{}': {m}",
                self.name
            )))
        };
        if !(self.gsd_ref_m > 0.0 && self.gsd_ref_m.is_finite()) {
            return bad(format!("gsd_ref_m = {} must be positive", self.gsd_ref_m));
        }
        if !(self.sigma_px >= 0.0 && self.sigma_px.is_finite()) {
            return bad(format!("sigma_px = {} must be >= 0", self.sigma_px));
        }
        if !(0.0..1.0).contains(&self.outlier_share) {
            return bad(format!(
                "outlier_share = {} is outside [0, 1)",
                self.outlier_share
            ));
        }
        if !(self.blob_size_px >= 1.0 && self.blob_size_px.is_finite()) {
            return bad(format!("blob_size_px = {} must be >= 1", self.blob_size_px));
        }
        Ok(())
    }
}

impl Default for MvsProfile {
    /// [`MvsProfile::sure_like`], the algorithm of the paper's acquisition experiment.
    fn default() -> Self {
        MvsProfile::sure_like()
    }
}

#[cfg(test)]
// Exact values are the point: clamping and flat curves.
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;

    #[test]
    fn presets_have_the_paper_shape() {
        for p in [MvsProfile::sure_like(), MvsProfile::pmvs_like()] {
            p.validate().unwrap();
            for m in [Material::Grass, Material::Tree] {
                assert!(
                    p.success_probability(m, 35.0, None) < 0.05,
                    "{} {m:?}",
                    p.name
                );
                assert!(p.success_probability(m, 3.0, None) > 0.3);
            }
            for m in [Material::Rock, Material::Marker] {
                assert!(p.success_probability(m, 40.0, None) > 0.7);
            }
        }
        let sure = MvsProfile::sure_like();
        let pmvs = MvsProfile::pmvs_like();
        // SURE: highest at small angles; PMVS: flat on smooth surfaces.
        assert!(
            sure.success_probability(Material::Rock, 2.0, None)
                > sure.success_probability(Material::Rock, 30.0, None)
        );
        assert_eq!(
            pmvs.success_probability(Material::Rock, 2.0, None),
            pmvs.success_probability(Material::Rock, 30.0, None)
        );
        // SURE more robust than PMVS on non-planar structures.
        assert!(
            sure.success_probability(Material::Grass, 10.0, None)
                > pmvs.success_probability(Material::Grass, 10.0, None)
        );
        // Grass is harder up close.
        assert!(
            sure.success_probability(Material::Grass, 5.0, Some(0.005))
                < 0.6 * sure.success_probability(Material::Grass, 5.0, Some(0.02))
        );
    }

    #[test]
    fn curve_interpolates_and_clamps() {
        let c = MaterialCurve::new(&[(10.0, 0.8), (20.0, 0.4)], 0.0);
        assert_eq!(c.at_angle(0.0), 0.8);
        assert!((c.at_angle(15.0) - 0.6).abs() < 1e-12);
        assert_eq!(c.at_angle(50.0), 0.4);
    }

    #[test]
    fn profile_round_trips_through_toml_and_bad_curves_are_named() {
        let p = MvsProfile::pmvs_like();
        let text = toml::to_string(&p).unwrap();
        let back: MvsProfile = toml::from_str(&text).unwrap();
        assert_eq!(p, back);
        let mut bad = p;
        bad.grass.success[1] = 1.5;
        let msg = bad.validate().unwrap_err().to_string();
        assert!(msg.contains("grass") && msg.contains("1.5"), "{msg}");
    }
}
