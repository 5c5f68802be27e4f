//! Position uncertainty in the clearance: how far the vehicle may really be
//! from where the plan puts it, relative to the real surface.
//!
//! A plan is made in the model's frame and flown by GNSS. Two independent
//! errors of the same GNSS class separate the flown path from the surface:
//! the model's georeference (aligned to the photos' GNSS positions by
//! `vpctl colmap align`: their slowly varying bias does not average out
//! over one flight, and the alignment residuals do not show it) and the
//! vehicle's own position error when it flies the plan (another bias,
//! drawn on another day). On top come what the alignment residuals do show
//! (a poor fit, a distorted model) and the autopilot's path-tracking error.
//!
//! The margin is `sigmas` (the `[safety]` key, default [`DEFAULT_SIGMAS`])
//! times the one-dimensional standard deviation of that relative error in
//! its worst direction:
//!
//! ```text
//! sigma_h = sqrt(2) * horizontal_m / sqrt(2)   (per horizontal axis: horizontal_m is the 2D RMS)
//! sigma_v = sqrt(2) * vertical_m
//! position = sigmas * sqrt(max(sigma_h, sigma_v)^2 + alignment_rms^2 + tracking^2)
//! ```
//!
//! The clearance structure is a ball (one distance to the mesh in every
//! direction), so horizontal and vertical cannot be kept apart: the larger
//! of the two is used, conservatively (for standard GNSS the vertical one).

use serde::{Deserialize, Serialize};
pub use vp_scene::gnss::{GnssClass, GnssSigmas};

/// Standard deviations of the margin. The error is mostly a bias that
/// holds for a whole flight, so the tail is a per-flight risk: 3 leaves a
/// one-sided 0.13 % of flights reaching into the safety distance at their
/// closest point (the safety distance itself still between them and the
/// surface). 2 leaves 2.3 % of flights: about one flight in forty, too
/// many for a vehicle flown every day. Over 200 random simulated sites with
/// standard GNSS, 3 kept every flown path outside the safety distance of
/// the true surface (docs/campaign-findings.md).
pub const DEFAULT_SIGMAS: f64 = 3.0;

/// The `[safety]` section of the planner config.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SafetyConfig {
    /// The GNSS class of the vehicle and of the photos the model was
    /// aligned to; `None` (not in the file): the class the model's
    /// `frame.json` records, else standard GNSS.
    pub gnss: Option<GnssClass>,
    /// The class `frame.json` records, set by [`crate::plan_from_model`];
    /// not a config key.
    #[serde(skip)]
    pub model_gnss: Option<GnssClass>,
    /// The autopilot's path-tracking error, 1-sigma, metres.
    pub tracking_m: f64,
    /// How many standard deviations of the position error the margin holds.
    pub sigmas: f64,
    /// RMS residual of the model's alignment (`frame.json`'s `rms_m`), set
    /// by [`crate::plan_from_model`] from the model; not a config key.
    #[serde(skip)]
    pub alignment_rms_m: Option<f64>,
}

impl Default for SafetyConfig {
    fn default() -> Self {
        SafetyConfig {
            gnss: None,
            model_gnss: None,
            tracking_m: 0.3,
            sigmas: DEFAULT_SIGMAS,
            alignment_rms_m: None,
        }
    }
}

impl SafetyConfig {
    /// No position margin: the vehicle is where the plan says (tests of
    /// exact geometry, and the simulator's "margin off" comparison).
    pub fn exact() -> Self {
        SafetyConfig {
            gnss: Some(GnssClass::Custom(GnssSigmas {
                horizontal_m: 0.0,
                vertical_m: 0.0,
            })),
            model_gnss: None,
            tracking_m: 0.0,
            sigmas: DEFAULT_SIGMAS,
            alignment_rms_m: None,
        }
    }

    /// The class in effect: the config's, else the model's, else standard.
    pub fn gnss_class(&self) -> GnssClass {
        self.gnss.or(self.model_gnss).unwrap_or_default()
    }

    /// The position term of the clearance, metres (see the module doc).
    pub fn position_margin_m(&self) -> f64 {
        let (h, v) = self.gnss_class().sigmas_m();
        let sigma_h = h; // sqrt(2) independent errors of horizontal_m / sqrt(2) per axis
        let sigma_v = std::f64::consts::SQRT_2 * v;
        let worst = sigma_h.max(sigma_v);
        let rms = self.alignment_rms_m.unwrap_or(0.0);
        self.sigmas * (worst * worst + rms * rms + self.tracking_m * self.tracking_m).sqrt()
    }

    /// Checks the values; the message names the key.
    pub fn validate(&self) -> Result<(), String> {
        let (h, v) = self.gnss_class().sigmas_m();
        let ok = |x: f64| x.is_finite() && x >= 0.0;
        if !ok(h) || !ok(v) {
            return Err(format!(
                "[safety] gnss = {{ horizontal_m = {h}, vertical_m = {v} }}: both must be finite and >= 0"
            ));
        }
        if !ok(self.tracking_m) {
            return Err(format!(
                "[safety] tracking_m = {}: must be finite and >= 0",
                self.tracking_m
            ));
        }
        if !(self.sigmas.is_finite() && self.sigmas > 0.0) {
            return Err(format!(
                "[safety] sigmas = {}: must be finite and > 0 (default {DEFAULT_SIGMAS})",
                self.sigmas
            ));
        }
        Ok(())
    }

    /// Where the position term comes from, for the clearance line.
    pub fn describe(&self) -> String {
        let rms = self
            .alignment_rms_m
            .map_or("no alignment residual".to_string(), |r| {
                format!("alignment residual {r:.2} m")
            });
        let from = match (self.gnss, self.model_gnss) {
            (Some(_), _) => "",
            (None, Some(_)) => " (from frame.json)",
            (None, None) => " (default)",
        };
        format!(
            "{}{from}, {rms}, tracking {} m, {} sigma",
            self.gnss_class().label(),
            self.tracking_m,
            self.sigmas
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standard_gnss_margin_is_twice_the_vertical_difference_of_two_biases() {
        let s = SafetyConfig {
            tracking_m: 0.0,
            ..SafetyConfig::default()
        };
        // sqrt(2) * 3 m vertical, 3 sigma.
        assert!((s.position_margin_m() - 3.0 * 2f64.sqrt() * 3.0).abs() < 1e-9);
        let two = SafetyConfig {
            sigmas: 2.0,
            ..s.clone()
        };
        assert!((two.position_margin_m() - 2.0 * 2f64.sqrt() * 3.0).abs() < 1e-9);
        let rtk = SafetyConfig {
            gnss: Some(GnssClass::Rtk),
            alignment_rms_m: Some(0.03),
            ..SafetyConfig::default()
        };
        let m = rtk.position_margin_m();
        assert!(m > 0.9 && m < 0.95, "{m}");
    }

    #[test]
    fn the_section_parses_names_and_numbers_and_refuses_typos() {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct W {
            safety: SafetyConfig,
        }
        let w: W = toml::from_str("[safety]\ngnss = \"rtk\"\n").unwrap();
        assert_eq!(w.safety.gnss, Some(GnssClass::Rtk));
        let w: W =
            toml::from_str("[safety]\ngnss = { horizontal_m = 0.5, vertical_m = 1.0 }\n").unwrap();
        assert_eq!(w.safety.gnss_class().sigmas_m(), (0.5, 1.0));
        assert!(toml::from_str::<W>("[safety]\ngnss = \"gps\"\n").is_err());
        assert!(toml::from_str::<W>("[safety]\ngnsss = \"rtk\"\n").is_err());
    }
}
