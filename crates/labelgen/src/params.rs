//! Parameters of the three labelling stages, with their defaults
//! (docs/design.md#training-labels-labelgen).

use serde::{Deserialize, Serialize};

use crate::error::{LabelgenError, Result};

/// Parameters of label generation (stages 1-3). Every field has a default;
/// a TOML/JSON config may give any subset.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LabelParams {
    /// alpha_min, degrees: a reference supports a query measurement only if
    /// the angle at the query point between the rays to the two triplets'
    /// mean centres exceeds it (or the resolution test below holds). Two
    /// references closer than this (and within s_min in resolution) are
    /// "similar viewpoints" and count once. Default 10 deg [vpctl; the paper
    /// gives no value].
    pub alpha_min_deg: f64,
    /// s_min: the other way a reference is "different enough": its resolution
    /// at the query point (mean focal length at depthmap resolution over the
    /// distance from its mean centre) exceeds the query's by this factor
    /// (one-sided, as in the paper). Default 1.5 [vpctl].
    pub s_min: f64,
    /// sigma_px, pixels of the depthmap: the image noise propagated to first
    /// order through the triplet's three cameras into a 3D covariance per
    /// measurement. Default 1 px (as M1's f_unc).
    pub sigma_px: f64,
    /// k: the uncertainty bound of a measurement is `k * sigma_ray`, sigma_ray
    /// the standard deviation of its 3D covariance along the pixel's ray. Two
    /// measurements agree when their distance along the query ray is within
    /// the query's bound. Default 3 (about 99.7% of Gaussian errors along the
    /// ray fall inside).
    pub k_sigma: f64,
    /// Smallest support (stage 1) a reference measurement needs to vote in
    /// stage 2 and to augment depthmaps in stage 3. Default 1 (the paper).
    pub min_support: u16,
    /// Largest half-width, in query pixels, of the square into which one
    /// reference measurement is splatted in a query z-buffer. A coarser
    /// reference (pyramid level 2, 3) covers several query pixels per
    /// measurement; the splat covers them so that it leaves no gaps. Default 4.
    pub max_splat_radius: u32,
    /// Shrink iterations of the stage-3 meshes. Default 3 (the paper).
    pub mesh_iterations: usize,
}

impl Default for LabelParams {
    fn default() -> Self {
        LabelParams {
            alpha_min_deg: 10.0,
            s_min: 1.5,
            sigma_px: 1.0,
            k_sigma: 3.0,
            min_support: 1,
            max_splat_radius: 4,
            mesh_iterations: 3,
        }
    }
}

/// `vpctl labelgen --params` (the whole file) and a campaign's
/// `[training.labels]`; missing keys take [`LabelParams::default`].
impl vp_scene::config_file::ConfigSection for LabelParams {
    type Error = LabelgenError;

    fn check(&self, place: &str) -> Result<()> {
        self.validate().map_err(|e| match e {
            LabelgenError::InvalidArgument(m) => {
                LabelgenError::InvalidArgument(format!("{place}: {m}"))
            }
            other => other,
        })
    }
}

impl LabelParams {
    /// Reads a TOML parameter file (any subset of the keys; the rest keep
    /// their defaults) and validates it. The old JSON form is refused with a
    /// message saying so.
    pub fn load(path: &std::path::Path) -> Result<Self> {
        vp_scene::config_file::load_section(path, "")
    }

    /// Checks every value is in its valid range.
    pub fn validate(&self) -> Result<()> {
        let bad = |what: &str, v: f64| {
            Err(LabelgenError::InvalidArgument(format!(
                "{what} = {v} is out of range"
            )))
        };
        if !(self.alpha_min_deg >= 0.0 && self.alpha_min_deg < 180.0) {
            return bad("alpha_min_deg (0 <= alpha < 180)", self.alpha_min_deg);
        }
        if !(self.s_min >= 1.0 && self.s_min.is_finite()) {
            return bad("s_min (>= 1)", self.s_min);
        }
        if !(self.sigma_px > 0.0 && self.sigma_px.is_finite()) {
            return bad("sigma_px (> 0)", self.sigma_px);
        }
        if !(self.k_sigma > 0.0 && self.k_sigma.is_finite()) {
            return bad("k_sigma (> 0)", self.k_sigma);
        }
        if self.min_support == 0 {
            return bad("min_support (>= 1)", 0.0);
        }
        if self.max_splat_radius > 64 {
            return bad("max_splat_radius (<= 64)", f64::from(self.max_splat_radius));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression (found by fuzzing, `tests/fuzz`): a value out of range in a
    /// parameter file was reported without the file's name.
    #[test]
    fn out_of_range_value_in_a_file_names_the_file_and_the_key() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("labels.toml");
        std::fs::write(&path, "alpha_min_deg = -1e30\n").unwrap();
        let m = LabelParams::load(&path).unwrap_err().to_string();
        assert!(
            m.contains("labels.toml") && m.contains("alpha_min_deg"),
            "{m}"
        );
    }
}
