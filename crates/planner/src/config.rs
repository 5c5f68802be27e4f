//! Planner configuration: every parameter of the paper with its default,
//! readable from TOML (`vpctl plan --config plan.toml`).
//!
//! Missing keys take their defaults, unknown keys are refused (a typo must
//! not silently fall back to a default). [`PlannerConfig::default_toml`] is
//! the commented file `vpctl config --defaults` prints.

use std::path::Path;

use serde::{Deserialize, Serialize};
use vp_scene::config_file::{read_section, ConfigSection};
use vp_scene::flight_time::FlightParams;
use vp_scene::plan::AltitudeLimits;
use vp_scene::raster::AngleBins;
use vp_scene::{Aabb, Intrinsics};

use crate::error::{PlannerError, Result};
use crate::free_space::UnknownSpace;
use crate::position::SafetyConfig;

/// Camera of the new views.
///
/// The default is a DJI Phantom 4 Pro class camera (1" sensor 13.2 x 8.8 mm,
/// 8.8 mm lens, 5472 x 3648 px): f = 5472 * 8.8 / 13.2 = 3648 px, horizontal
/// field of view 73.7 deg, vertical 53.1 deg; GSD 13.7 mm at 50 m.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraConfig {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Focal length, pixels (square pixels, principal point at the centre).
    pub focal_px: f64,
}

impl Default for CameraConfig {
    fn default() -> Self {
        CameraConfig {
            width: 5472,
            height: 3648,
            focal_px: 3648.0,
        }
    }
}

impl CameraConfig {
    /// Pinhole intrinsics with the principal point at the image centre.
    pub fn intrinsics(&self) -> Intrinsics {
        Intrinsics {
            width: self.width,
            height: self.height,
            fx: self.focal_px,
            fy: self.focal_px,
            cx: 0.5 * f64::from(self.width),
            cy: 0.5 * f64::from(self.height),
        }
    }
}

/// All planner parameters. Field docs name the paper's symbol.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlannerConfig {
    /// c: number of cameras that must see a triangle for f_cov = 1.
    pub min_cameras: u32,
    /// gsd_d: desired ground sampling distance, metres (r_d = 1 / gsd_d^2).
    pub gsd_m: f64,
    /// a_d: desired 3D accuracy, metres.
    pub accuracy_m: f64,
    /// alpha: weight of f_res against f_unc.
    pub alpha: f64,
    /// sigma_px: pixel noise for the first-order covariance, pixels.
    pub sigma_px: f64,
    /// N_t: triangles sampled from the split region of interest.
    pub n_triangles: usize,
    /// N_p: free-space surrogate positions.
    pub n_surrogates: usize,
    /// N_v: triangles selected for planning (the set T).
    pub n_selected: usize,
    /// phi: field of view of the inverse-visibility cameras, degrees.
    pub inverse_fov_deg: f64,
    /// b: number of triangulation-angle bins.
    pub n_bins: usize,
    /// gamma_max: upper edge of the last angle bin, degrees.
    pub gamma_max_deg: f64,
    /// k: triplets planned per call.
    pub n_triplets: usize,
    /// o_min: minimum image overlap with an earlier image along the path.
    pub min_overlap: f64,
    /// Minimum distance of every waypoint and path segment to the mesh, metres.
    pub safety_distance_m: f64,
    /// Added to `safety_distance_m` in every check against the mesh and the
    /// free space, metres: a mesh reconstructed from photos is off by
    /// decimetres (`vpctl mesh build`'s cell is 0.5 m), and the safety
    /// distance is owed to the real surface. 0 trusts the mesh exactly.
    pub geometry_margin_m: f64,
    /// Position uncertainty (`[safety]`): the GNSS class, the tracking
    /// error and, from the model, the alignment residual; its margin is
    /// added to the clearance ([`crate::position`]).
    pub safety: SafetyConfig,
    /// Lowest gimbal pitch (elevation of the optical axis), degrees; -90 is nadir.
    pub gimbal_pitch_min_deg: f64,
    /// Highest gimbal pitch, degrees.
    pub gimbal_pitch_max_deg: f64,
    /// Camera of the new views.
    pub camera: CameraConfig,
    /// Flight volume `[[xmin, ymin, zmin], [xmax, ymax, zmax]]`; default: the
    /// mesh's x/y bounds, z from the lowest mesh point to 60 m above the highest.
    pub flight_volume: Option<[[f64; 3]; 2]>,
    /// Geofence: inclusion polygon of (x, y) corners, metres; default none.
    pub geofence: Option<Vec<[f64; 2]>>,
    /// Altitude band (z, metres); default: the flight volume's z range.
    pub altitude_limits: Option<AltitudeLimits>,
    /// Space no camera has observed: an obstacle (`"occupied"`, default:
    /// waypoints and segments keep the safety distance to it too) or free
    /// (`"free"`, the paper's behaviour).
    pub unknown_space: UnknownSpace,
    /// Voxel edge of the free-space map, metres.
    pub free_space_voxel_m: f64,
    /// Treat space above the highest observed point as free (nothing floats
    /// over the observed tops: no wires, no overhanging structures), in the
    /// columns two acquired images picture just above that point (anything
    /// taller standing there would have been seen; `free_space`).
    pub free_above_observed: bool,
    /// Wall-clock budget of one planning call, seconds; default unbounded.
    pub time_budget_s: Option<f64>,
    /// M3 visits surrogates by decreasing potential gain and stops early
    /// (the paper's heuristic); false searches every surrogate.
    pub m3_early_stop: bool,
    /// Seed of every random choice.
    pub seed: u64,
    /// The flight-time model and the battery limit (`[mission]`).
    pub mission: FlightParams,
}

impl Default for PlannerConfig {
    /// The paper's parameters (Val Camonica experiment).
    fn default() -> Self {
        PlannerConfig {
            min_cameras: 3,
            gsd_m: 0.008,
            accuracy_m: 0.008,
            alpha: 0.5,
            sigma_px: 1.0,
            n_triangles: 2000,
            n_surrogates: 5000,
            n_selected: 200,
            inverse_fov_deg: 120.0,
            n_bins: 9,
            gamma_max_deg: 45.0,
            n_triplets: 4,
            min_overlap: 0.5,
            safety_distance_m: 5.0,
            geometry_margin_m: 0.0,
            safety: SafetyConfig::default(),
            gimbal_pitch_min_deg: -90.0,
            gimbal_pitch_max_deg: 0.0,
            camera: CameraConfig::default(),
            flight_volume: None,
            geofence: None,
            altitude_limits: None,
            unknown_space: UnknownSpace::Occupied,
            free_space_voxel_m: 1.0,
            free_above_observed: true,
            time_budget_s: None,
            m3_early_stop: true,
            seed: 0,
            mission: FlightParams::default(),
        }
    }
}

const DEFAULT_TOML: &str = r#"# vpctl planner configuration. Every key is optional; shown are the defaults
# (the paper's Val Camonica experiment). Lengths in metres, angles in degrees.

# Quality requirements.
min_cameras = 3          # c: cameras that must see a triangle (f_cov)
gsd_m = 0.008            # gsd_d: desired ground sampling distance (f_res)
accuracy_m = 0.008       # a_d: desired 3D accuracy (f_unc)
alpha = 0.5              # weight of f_res against f_unc
sigma_px = 1.0           # pixel noise of the first-order covariance

# Sampling (M1, M2).
n_triangles = 2000       # N_t: triangles sampled from the split ROI
n_surrogates = 5000      # N_p: free-space surrogate camera positions
n_selected = 200         # N_v: triangles planned for (the set T)
inverse_fov_deg = 120.0  # phi: field of view of the inverse-visibility cameras

# Triangulation-angle bins and triplets (M3).
n_bins = 9               # b
gamma_max_deg = 45.0     # upper edge of the last bin
n_triplets = 4           # k: triplets per planning call

# Flight path and safety (M4).
min_overlap = 0.5        # o_min: overlap with an earlier image
safety_distance_m = 5.0  # every waypoint and path segment keeps this to the mesh
geometry_margin_m = 0.0  # plus this: how far the mesh may be off the real surface
gimbal_pitch_min_deg = -90.0
gimbal_pitch_max_deg = 0.0
m3_early_stop = true     # the paper's early stop in M3 (a heuristic); false: search all
unknown_space = "occupied" # unobserved space is an obstacle; "free": the paper's behaviour
free_space_voxel_m = 1.0   # voxel of the observed-free-space map
free_above_observed = true # nothing floats above the highest observed point where the cameras looked
seed = 0
# time_budget_s = 10.0                          # default: unbounded
# flight_volume = [[-30, -30, 0], [30, 30, 60]] # default: from the mesh
# geofence = [[-30, -30], [30, -30], [30, 30], [-30, 30]]
# altitude_limits = { min_m = 5.0, max_m = 60.0 }

# Position uncertainty: the clearance to the mesh is safety_distance_m +
# geometry_margin_m + `sigmas` sigma of the vehicle's position error relative to the
# model (two independent GNSS errors: the model's georeference and the flight;
# the larger of horizontal and vertical; the model's alignment residual from
# frame.json; the path tracking). `vpctl plan` prints the sum.
[safety]
# gnss = "standard"      # "rtk" (2/3 cm), "standard" (1.5/3 m) or { horizontal_m = 0.5, vertical_m = 1.0 };
                         # default: the class the model's frame.json records, else "standard"
tracking_m = 0.3         # the autopilot's path-tracking error, 1 sigma
sigmas = 3.0             # standard deviations the margin holds (one-sided: 0.13 % of flights beyond it)

# Camera of the new views: DJI Phantom 4 Pro class (1" sensor, 8.8 mm lens).
[camera]
width = 5472
height = 3648
focal_px = 3648.0

# Flight time and batteries: a conservative survey setting for a Phantom 4 Pro
# class aircraft (docs/formats.md lists other aircraft). Every leg starts and
# ends at rest; a flight takes off at home and returns to it.
[mission]
cruise_speed_m_s = 5.0   # horizontal speed between waypoints
climb_rate_m_s = 3.0
descent_rate_m_s = 2.0
acceleration_m_s2 = 2.0  # and braking
hover_per_photo_s = 2.0  # settle, gimbal, shoot
takeoff_landing_s = 10.0 # fixed cost of one take-off and one landing
reserve_s = 120.0        # kept back from max_flight_time_s
# max_flight_time_s = 1500.0 # one battery; splits the plan into flights (--max-flight-time)
"#;

/// `vpctl plan --config`: a planner file, or the `[planner]` section of a
/// campaign config; missing keys take [`PlannerConfig::default`].
impl ConfigSection for PlannerConfig {
    type Error = PlannerError;

    fn check(&self, place: &str) -> Result<()> {
        self.validate()
            .map_err(|e| PlannerError::Config(format!("{place}: {e}")))
    }
}

impl PlannerConfig {
    /// The defaults as a commented TOML file (parses back to `Default`).
    pub fn default_toml() -> &'static str {
        DEFAULT_TOML
    }

    /// Parses TOML text (the whole file is the planner's section); `path`
    /// only names the source in errors. Missing keys take
    /// [`PlannerConfig::default`].
    pub fn from_toml(text: &str, path: &Path) -> Result<Self> {
        read_section(text, path, "")
    }

    /// Reads and validates a TOML config file.
    pub fn load(path: &Path) -> Result<Self> {
        Self::from_toml(&vp_scene::fsio::read_text(path)?, path)
    }

    /// The angle bins: b equal bins over [0, gamma_max).
    pub fn angle_bins(&self) -> Result<AngleBins> {
        Ok(AngleBins::uniform(self.n_bins, self.gamma_max_deg as f32)?)
    }

    /// Flight volume as an [`Aabb`], if configured.
    pub fn flight_volume_aabb(&self) -> Option<Aabb> {
        self.flight_volume.map(|[a, b]| Aabb {
            min: a.into(),
            max: b.into(),
        })
    }

    /// Checks every range; the message names the key and its value.
    pub fn validate(&self) -> Result<()> {
        let bad = |key: &str, v: String, want: &str| {
            Err(PlannerError::Config(format!("{key} = {v}: {want}")))
        };
        let pos = |x: f64| x.is_finite() && x > 0.0;
        if self.min_cameras < 3 {
            return bad(
                "min_cameras",
                self.min_cameras.to_string(),
                "must be >= 3 (a triplet has three cameras)",
            );
        }
        for (k, v) in [
            ("gsd_m", self.gsd_m),
            ("accuracy_m", self.accuracy_m),
            ("sigma_px", self.sigma_px),
            ("gamma_max_deg", self.gamma_max_deg),
        ] {
            if !pos(v) {
                return bad(k, v.to_string(), "must be finite and > 0");
            }
        }
        if !(0.0..=1.0).contains(&self.alpha) {
            return bad("alpha", self.alpha.to_string(), "must be in [0, 1]");
        }
        if !(0.0..=1.0).contains(&self.min_overlap) {
            return bad(
                "min_overlap",
                self.min_overlap.to_string(),
                "must be in [0, 1]",
            );
        }
        for (k, v) in [
            ("n_triangles", self.n_triangles),
            ("n_surrogates", self.n_surrogates),
            ("n_selected", self.n_selected),
            ("n_bins", self.n_bins),
            ("n_triplets", self.n_triplets),
        ] {
            if v == 0 {
                return bad(k, "0".into(), "must be at least 1");
            }
        }
        if !(self.gamma_max_deg < 120.0) {
            return bad(
                "gamma_max_deg",
                self.gamma_max_deg.to_string(),
                "must be below 120 (an equilateral triplet cannot exceed it)",
            );
        }
        if !(self.inverse_fov_deg > 0.0 && self.inverse_fov_deg < 180.0) {
            return bad(
                "inverse_fov_deg",
                self.inverse_fov_deg.to_string(),
                "must be in (0, 180)",
            );
        }
        self.mission
            .validate()
            .map_err(|e| PlannerError::Config(e.to_string()))?;
        self.validate_limits()
    }

    /// The distance every waypoint and path segment keeps to the mesh and
    /// to unobserved space: the safety distance plus the geometry margin
    /// plus the position margin ([`SafetyConfig::position_margin_m`]).
    pub fn clearance_m(&self) -> f64 {
        self.safety_distance_m + self.geometry_margin_m + self.safety.position_margin_m()
    }

    /// The clearance and where it comes from, in one line.
    pub fn clearance_line(&self) -> String {
        format!(
            "clearance {:.2} m = safety {:.2} + margin {:.2} + position {:.2} ({})",
            self.clearance_m(),
            self.safety_distance_m,
            self.geometry_margin_m,
            self.safety.position_margin_m(),
            self.safety.describe()
        )
    }

    /// The safety, camera and flight-limit part of [`PlannerConfig::validate`].
    fn validate_limits(&self) -> Result<()> {
        let bad = |key: &str, v: String, want: &str| {
            Err(PlannerError::Config(format!("{key} = {v}: {want}")))
        };
        let pos = |x: f64| x.is_finite() && x > 0.0;
        if !(self.safety_distance_m.is_finite() && self.safety_distance_m >= 0.0) {
            return bad(
                "safety_distance_m",
                self.safety_distance_m.to_string(),
                "must be finite and >= 0",
            );
        }
        if !(self.geometry_margin_m.is_finite() && self.geometry_margin_m >= 0.0) {
            return bad(
                "geometry_margin_m",
                self.geometry_margin_m.to_string(),
                "must be finite and >= 0",
            );
        }
        self.safety.validate().map_err(PlannerError::Config)?;
        if !pos(self.free_space_voxel_m) {
            return bad(
                "free_space_voxel_m",
                self.free_space_voxel_m.to_string(),
                "must be finite and > 0",
            );
        }
        let (lo, hi) = (self.gimbal_pitch_min_deg, self.gimbal_pitch_max_deg);
        if !(lo >= -90.0 && hi <= 90.0 && lo <= hi) {
            return bad(
                "gimbal_pitch_min_deg/gimbal_pitch_max_deg",
                format!("{lo}/{hi}"),
                "must satisfy -90 <= min <= max <= 90",
            );
        }
        let c = &self.camera;
        if c.width == 0 || c.height == 0 || !pos(c.focal_px) {
            return bad(
                "camera",
                format!("{}x{} f={}", c.width, c.height, c.focal_px),
                "width, height and focal_px must be positive",
            );
        }
        if let Some([a, b]) = self.flight_volume {
            if !(a.iter().chain(&b).all(|x| x.is_finite()) && (0..3).all(|i| a[i] < b[i])) {
                return bad(
                    "flight_volume",
                    format!("{a:?}..{b:?}"),
                    "must be finite with min < max on every axis",
                );
            }
        }
        if let Some(g) = &self.geofence {
            if g.len() < 3 || g.iter().flatten().any(|x| !x.is_finite()) {
                return bad(
                    "geofence",
                    format!("{} corners", g.len()),
                    "needs at least 3 finite corners",
                );
            }
        }
        if let Some(l) = self.altitude_limits {
            if !(l.min_m.is_finite() && l.max_m.is_finite() && l.min_m < l.max_m) {
                return bad(
                    "altitude_limits",
                    format!("[{}, {}]", l.min_m, l.max_m),
                    "must be finite with min_m < max_m",
                );
            }
        }
        if let Some(t) = self.time_budget_s {
            if !(t.is_finite() && t >= 0.0) {
                return bad("time_budget_s", t.to_string(), "must be finite and >= 0");
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_toml_parses_to_the_defaults() {
        let cfg =
            PlannerConfig::from_toml(PlannerConfig::default_toml(), Path::new("d.toml")).unwrap();
        assert_eq!(cfg, PlannerConfig::default());
    }

    #[test]
    fn bad_values_and_unknown_keys_are_named() {
        let err = PlannerConfig::from_toml("alpha = 2.0\n", Path::new("c.toml"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("c.toml") && err.contains("alpha = 2"), "{err}");
        let err = PlannerConfig::from_toml("\nn_triangels = 5\n", Path::new("c.toml"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("line 2") && err.contains("n_triangels"),
            "{err}"
        );
    }
}
