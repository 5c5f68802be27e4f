//! The campaign configuration: training sites, held-out sites, flights,
//! strategies, SfM noise, the virtual MVS and the evaluation. TOML-loadable;
//! missing keys take the defaults of [`CampaignConfig::demo`], unknown keys
//! are refused (a typo must not silently fall back to a default).

use std::path::Path;

use serde::{Deserialize, Serialize};
use vp_forest::TrainParams;
use vp_labelgen::LabelParams;
use vp_planner::PlannerConfig;
use vp_scene::config_file::ConfigSection;
use vp_scene::procedural::SiteParams;
use vp_scene::surface::SurfaceParams;

mod presets;
mod strategy;

pub use presets::PRESETS;
pub use strategy::Strategy;

use crate::error::{Result, SimError};
use vp_mvs::MvsParams;

use crate::render::RenderParams;
use crate::virtual_mvs::MvsProfile;

/// Which multi-view stereo reconstructs the flown and training images.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum MvsKind {
    /// vp-mvs (PatchMatch) on the rendered images: the experiment.
    #[default]
    Patchmatch,
    /// vp-mvs's semi-global matcher (`[patchmatch.sgm]` parameters) on the
    /// rendered images: the second matcher of the paper's claim that
    /// confidence depends on the matcher (SURE-like, narrow angles best).
    Sgm,
    /// The virtual MVS of `profile` and `gate`: success drawn from planted
    /// curves. A fast stand-in for unit tests only.
    Virtual,
}

/// The sections only the virtual MVS (`mvs = "virtual"`) reads.
const VIRTUAL_ONLY: [&str; 2] = ["profile", "gate"];

/// Everything a campaign needs. See the module docs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CampaignConfig {
    /// Seed of every random choice of the campaign (sites have their own seeds).
    pub seed: u64,
    /// Seeds of the held-out sites flown and evaluated (never trained on).
    pub held_out_seeds: Vec<u64>,
    /// Triplet strategies, named as in the paper: `F<i>x<k>` plans k triplets
    /// per iteration for i iterations with confidence prediction, `NP<i>x<k>`
    /// the same without (confidence 1). Grid and Init are always evaluated,
    /// and each strategy is also combined with Grid (`G+<name>`).
    pub strategies: Vec<String>,
    /// Shape of the held-out sites (the seed is taken from `held_out_seeds`).
    pub site: SiteParams,
    /// Margin around the rock's footprint that the region of interest adds, metres
    /// (the paper: the rock and a few metres of the surrounding vegetation).
    pub roi_margin_m: f64,
    /// The multi-view stereo that reconstructs every flown and training
    /// image set: `"patchmatch"` (vp-mvs on the rendered images, the
    /// default), `"sgm"` (vp-mvs's semi-global matcher, `[patchmatch.sgm]`)
    /// or `"virtual"` (success drawn from `profile` and `gate`: a fast
    /// stand-in for unit tests, whose outcome was written in advance).
    pub mvs: MvsKind,
    /// vp-mvs parameters (`seed` is set per reconstruction; `max_sources`
    /// bounds the neighbours each Grid image is matched against).
    pub patchmatch: MvsParams,
    /// The virtual MVS (truth curves, noise); used only with `mvs = "virtual"`.
    pub profile: MvsProfile,
    /// Triplet-level matching failure of the virtual MVS; used only with
    /// `mvs = "virtual"`.
    pub gate: MatchingGate,
    /// Lighting of the rendered images.
    pub render: RenderParams,
    /// Training campaign.
    pub training: TrainingConfig,
    /// Initial flight (paper: 19 images in a grid at 50 m).
    pub init: InitFlight,
    /// The Grid baseline (paper: 80 % overlap).
    pub grid: GridBaseline,
    /// Simulated SfM: pose and point noise, views needed per point.
    pub sfm: SfmConfig,
    /// The vehicle's position error (GNSS class, bias, tracking) and the
    /// georeference error of the model aligned to its photos' positions;
    /// whether the planner keeps the position margin.
    pub flight_error: crate::gnss::FlightError,
    /// The 3D mesher that turns what was seen into the planning mesh.
    pub surface: SurfaceParams,
    /// Planner parameters (the camera of every flight is `planner.camera`;
    /// `n_triplets` and `seed` are set per strategy and iteration).
    pub planner: PlannerConfig,
    /// Grid step of the confidence prediction, pixels (paper: 8).
    pub confidence_step: u32,
    /// Evaluation (the paper's Table 1).
    pub eval: EvalConfig,
}

/// Triplet-level matching failure [vpctl]: a dense matcher such as SURE does
/// not fail pixel by pixel only. At wide angles "matching becomes much more
/// difficult and only flat surfaces survive" (paper, Sec. 4): the whole
/// triplet produces nothing. The virtual MVS models this on top of the
/// per-pixel profile: a triplet yields no 3D output when, among the pixels
/// that all three images see, the share whose profile success probability
/// is at least `matchable_probability` is below `min_matchable_share`, or
/// when the median triangulation angle of those pixels on non-flat materials
/// (grass, trees) exceeds `max_nonflat_median_angle_deg`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MatchingGate {
    /// Switch the gate off (pixel-level failures only).
    pub enabled: bool,
    /// Success probability from which a pixel counts as matchable.
    pub matchable_probability: f64,
    /// Smallest share of matchable overlapping pixels for any output.
    pub min_matchable_share: f64,
    /// Largest median angle on non-flat materials, degrees.
    pub max_nonflat_median_angle_deg: f64,
    /// The median-angle rule applies when at least this share of the
    /// overlapping pixels is non-flat.
    pub nonflat_min_share: f64,
}

impl Default for MatchingGate {
    fn default() -> Self {
        MatchingGate {
            enabled: true,
            matchable_probability: 0.4,
            min_matchable_share: 0.5,
            max_nonflat_median_angle_deg: 30.0,
            nonflat_min_share: 0.3,
        }
    }
}

/// The offline training campaign (paper: Val Camonica training sites).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrainingConfig {
    /// Seeds of the training sites (must differ from every held-out seed).
    pub site_seeds: Vec<u64>,
    /// Shape of the training sites (seed from `site_seeds`).
    pub site: SiteParams,
    /// Random triplets per training site.
    pub triplets_per_site: usize,
    /// Largest triangulation angle a training triplet is drawn with, degrees
    /// (angles are drawn uniformly in log space from 2 deg).
    pub max_angle_deg: f64,
    /// Distance of a training triplet's centre from its focus point, metres: [min, max].
    pub distance_m: [f64; 2],
    /// Image width of the training cameras, pixels.
    pub width: u32,
    /// Image height of the training cameras, pixels.
    pub height: u32,
    /// Horizontal field of view of the training cameras, degrees.
    pub hfov_deg: f64,
    /// Pyramid levels each triplet is reconstructed at (paper: 1, 2, 3).
    pub levels: Vec<u8>,
    /// Label generation parameters.
    pub labels: LabelParams,
    /// Labelled pixels kept per label image, a uniform subset that keeps
    /// the class ratio (bounds memory).
    pub max_per_label_image: usize,
    /// Forest parameters.
    pub forest: TrainParams,
}

/// The initial flight: a nadir grid of `nx` x `ny` images, `spacing_m`
/// apart, `height_m` above the lowest ground point, centred on the ROI.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct InitFlight {
    /// Height above the lowest point of the site, metres (paper: 50).
    pub height_m: f64,
    /// Images along x.
    pub nx: usize,
    /// Images along y.
    pub ny: usize,
    /// Distance between neighbouring images, metres.
    pub spacing_m: f64,
}

/// The Grid baseline: a nadir lawnmower over the ROI footprint plus a margin.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GridBaseline {
    /// Height above the lowest point of the footprint, metres.
    pub height_m: f64,
    /// Front and side overlap (paper: 0.8).
    pub overlap: f64,
    /// Margin added around the ROI footprint, metres.
    pub margin_m: f64,
    /// Also fly the industry's oblique pattern (`Oblique` in Table 1):
    /// the nadir grid plus four routes at 45 deg down toward the four
    /// headings, at this height and margin, with as many images as the
    /// largest triplet strategy flies (or the most that five routes at
    /// one overlap allow within that count; see `vp_planner::oblique`).
    pub oblique: bool,
}

/// The simulated structure from motion.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SfmConfig {
    /// Standard deviation of the SfM model's georeferencing shift per
    /// axis, metres (one shift for all its images; see `sfm::sfm_camera`).
    pub position_noise_m: f64,
    /// Standard deviation of the SfM model's georeferencing rotation per
    /// axis, degrees (one rotation about the origin for all its images).
    pub rotation_noise_deg: f64,
    /// Standard deviation of point (planning-mesh vertex) noise, metres.
    pub point_noise_m: f64,
    /// Acquired images that must see a surface point for SfM to have it.
    pub min_views: usize,
    /// Candidate sparse points per square metre of true surface.
    pub points_per_m2: f64,
    /// vp-mvs's fused points are thinned to one per cube of this side
    /// (metres, the first in flight order kept) before they join the
    /// planning geometry: the mesher's cost and its sample spacing stay
    /// those of the site, not of the closest image.
    pub dense_spacing_m: f64,
    /// A thinning cube joins the planning geometry once this many fused
    /// points fell in it.
    pub dense_min_points: usize,
}

/// The evaluation of the paper's Table 1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EvalConfig {
    /// ROI faces are split to this longest edge, metres (paper: 0.08).
    pub split_edge_m: f64,
    /// A reconstructed depth measures a face when it is at most this much
    /// in front of the face's depth (or beyond it), metres (paper: 0.24).
    pub depth_tolerance_m: f64,
    /// c: cameras with successful depth a face needs to count as covered.
    pub min_cameras: usize,
    /// A reconstruction "produced 3D output" (the paper's triplet success)
    /// when at least this share of its images' ROI pixels holds a depth
    /// within `depth_tolerance_m` of the truth [vpctl: 0.01; the paper
    /// counts any output, and a few stray points are not a reconstruction].
    pub min_output_share: f64,
}

/// Sections default to the demo preset's values.
macro_rules! default_from_demo {
    ($($t:ident => $field:ident),* $(,)?) => {
        $(impl Default for $t {
            fn default() -> Self {
                CampaignConfig::demo().$field
            }
        })*
    };
}

default_from_demo!(
    TrainingConfig => training,
    InitFlight => init,
    GridBaseline => grid,
    SfmConfig => sfm,
    EvalConfig => eval,
);

impl Default for CampaignConfig {
    /// The demo preset ([`CampaignConfig::demo`]).
    fn default() -> Self {
        Self::demo()
    }
}

/// The campaign config file as a whole (section `""`): missing keys take
/// the demo preset's values ([`CampaignConfig::default`]).
impl ConfigSection for CampaignConfig {
    type Error = SimError;

    /// Every validation error names the file and section, whichever layer
    /// found it (the site's own checks report a scene error).
    fn check(&self, place: &str) -> Result<()> {
        self.validate().map_err(|e| match e {
            _ if place.is_empty() => e,
            SimError::InvalidArgument(m) => SimError::InvalidArgument(format!("{place}: {m}")),
            other => SimError::InvalidArgument(format!("{place}: {other}")),
        })
    }
}

impl CampaignConfig {
    /// Parses a TOML text; `path` names the file in errors. Every missing
    /// key, at any depth, takes the demo's value: a `[planner]` section that
    /// names only `gsd_m` keeps the demo's camera, not the planner crate's
    /// (`vpctl plan --config` reads that section on its own, with the
    /// planner's defaults).
    pub fn from_toml(text: &str, path: &Path) -> Result<Self> {
        let cfg: Self = vp_scene::config_file::read_section_over(&Self::demo(), text, path, "")?;
        let given: toml::Table = vp_scene::config_file::parse_toml(text, path)?;
        cfg.refuse_unused_virtual(|k| given.contains_key(k), &format!("{}: ", path.display()))?;
        Ok(cfg)
    }

    /// This configuration with `overrides` laid over it key by key,
    /// descending into tables present in both (arrays and values are
    /// replaced whole), then validated: what Python's dicts that name only
    /// the keys they change go through.
    pub fn with_overrides(&self, overrides: serde_json::Value) -> Result<Self> {
        let given = overrides.clone();
        let cfg: Self = vp_scene::config_file::with_overrides(self, overrides, "")?;
        cfg.refuse_unused_virtual(|k| given.get(k).is_some(), "")?;
        Ok(cfg)
    }

    /// `[profile]` and `[gate]` describe the virtual MVS only: given with
    /// another matcher they would read as planted truth that nothing uses,
    /// so naming them is an error (issue 34, item 6).
    fn refuse_unused_virtual(&self, given: impl Fn(&str) -> bool, place: &str) -> Result<()> {
        if self.mvs == MvsKind::Virtual {
            return Ok(());
        }
        for key in VIRTUAL_ONLY {
            if given(key) {
                let mvs = toml::Value::try_from(self.mvs)
                    .map(|v| v.to_string())
                    .unwrap_or_default();
                return Err(SimError::InvalidArgument(format!(
                    "{place}[{key}] configures the virtual MVS, but this config runs mvs = {mvs}, \
                     which does not use it: remove [{key}] or set mvs = \"virtual\""
                )));
            }
        }
        Ok(())
    }

    /// Checks that every key of the TOML `text` is a campaign config key
    /// (unknown keys refused with file, line, column and table), taking no
    /// value: what `scene generate` and `plan` do before reading their
    /// own section of a campaign file, so a typo elsewhere in it is not
    /// silently ignored either.
    pub fn check_keys(text: &str, path: &Path) -> Result<()> {
        vp_scene::config_file::parse_toml::<CampaignConfig>(text, path)?;
        Ok(())
    }

    /// Reads and parses a TOML file.
    pub fn load(path: &Path) -> Result<Self> {
        Self::from_toml(&vp_scene::fsio::read_text(path)?, path)
    }

    /// The configuration as a complete TOML file: every key that runs
    /// written out. `[profile]` and `[gate]` are written only with
    /// `mvs = "virtual"`, the one matcher that uses them.
    pub fn to_toml(&self) -> Result<String> {
        let text = toml::to_string(self)
            .map_err(|e| SimError::InvalidArgument(format!("configuration to TOML: {e}")))?;
        if self.mvs == MvsKind::Virtual {
            return Ok(text);
        }
        // The serializer writes each table as a `[header]` line and its
        // keys (arrays inline), in field order: drop the virtual MVS's
        // tables line by line, which keeps the order of the rest (a
        // `toml::Table` would sort the sections).
        let mut out = String::with_capacity(text.len());
        let mut dropping = false;
        for line in text.split_inclusive('\n') {
            if let Some(name) = line.strip_prefix('[') {
                let top = name.split(['.', ']']).next().unwrap_or("");
                dropping = VIRTUAL_ONLY.contains(&top);
            }
            if !dropping {
                out.push_str(line);
            }
        }
        Ok(out)
    }

    /// The strategies, parsed.
    pub fn parsed_strategies(&self) -> Result<Vec<Strategy>> {
        self.strategies.iter().map(|s| Strategy::parse(s)).collect()
    }

    /// Checks ranges and the leave-one-site-out rule; the error names the key.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(SimError::InvalidArgument(m));
        if self.held_out_seeds.is_empty() {
            return bad("held_out_seeds is empty: name at least one site to fly".into());
        }
        if let Some(s) = self
            .held_out_seeds
            .iter()
            .find(|s| self.training.site_seeds.contains(s))
        {
            return bad(format!(
                "site seed {s} is both a training and a held-out site: the site flown must never be a training site"
            ));
        }
        if self.training.site_seeds.is_empty() || self.training.triplets_per_site == 0 {
            return bad("training: site_seeds and triplets_per_site must not be empty or 0".into());
        }
        let names = self.parsed_strategies()?;
        let mut seen = std::collections::BTreeSet::new();
        for n in &names {
            if !seen.insert(n.name.clone()) {
                return bad(format!("strategy {} is listed twice", n.name));
            }
        }
        self.profile.validate()?;
        self.patchmatch
            .validate()
            .map_err(|e| SimError::InvalidArgument(format!("patchmatch: {e}")))?;
        self.render.validate()?;
        self.planner
            .validate()
            .map_err(|e| SimError::InvalidArgument(format!("planner: {e}")))?;
        self.training
            .forest
            .validate()
            .map_err(|e| SimError::InvalidArgument(format!("training.forest: {e}")))?;
        self.site.validate()?;
        self.training.site.validate()?;
        let t = &self.training;
        if !(t.distance_m[0] > 0.0 && t.distance_m[1] >= t.distance_m[0]) {
            return bad(format!(
                "training.distance_m = {:?}: need 0 < min <= max",
                t.distance_m
            ));
        }
        if !(t.max_angle_deg > 2.0 && t.max_angle_deg < 120.0) {
            return bad(format!(
                "training.max_angle_deg = {} is outside (2, 120)",
                t.max_angle_deg
            ));
        }
        if t.width < 32 || t.height < 32 || !(t.hfov_deg > 1.0 && t.hfov_deg < 150.0) {
            return bad("training: width/height must be >= 32 px and hfov_deg in (1, 150)".into());
        }
        if t.levels.is_empty()
            || t.levels
                .iter()
                .any(|&l| !(1..=crate::virtual_mvs::MAX_LEVEL).contains(&l))
        {
            return bad(format!(
                "training.levels = {:?}: need levels in 1..=6",
                t.levels
            ));
        }
        if self.init.nx * self.init.ny < 3
            || !(self.init.height_m > 0.0 && self.init.spacing_m > 0.0)
        {
            return bad("init: need at least 3 images, positive height and spacing".into());
        }
        if !(0.0..0.99).contains(&self.grid.overlap) || !(self.grid.height_m > 0.0) {
            return bad(format!(
                "grid: overlap {} must be in [0, 0.99) and height {} positive",
                self.grid.overlap, self.grid.height_m
            ));
        }
        if self.grid.oblique && self.strategies.is_empty() {
            return bad(
                "grid: oblique = true flies as many images as the largest strategy, but strategies is empty".into(),
            );
        }
        let e = &self.eval;
        if !(e.split_edge_m >= 0.01)
            || !(e.depth_tolerance_m >= 0.0)
            || e.min_cameras == 0
            || !(0.0..=1.0).contains(&e.min_output_share)
        {
            return bad(
                "eval: split_edge_m >= 0.01, depth_tolerance_m >= 0, min_cameras >= 1, min_output_share in [0, 1]".into(),
            );
        }
        if self.confidence_step == 0 {
            return bad("confidence_step must be at least 1".into());
        }
        self.surface
            .validate()
            .map_err(|e| SimError::InvalidArgument(format!("surface: {e}")))?;
        self.flight_error.validate()?;
        self.sfm.validate()
    }
}

impl SfmConfig {
    /// Checks the ranges; the error names the key.
    fn validate(&self) -> Result<()> {
        let bad = |m: &str| Err(SimError::InvalidArgument(format!("sfm: {m}")));
        let positive = |x: f64| x.is_finite() && x > 0.0;
        if self.min_views == 0 {
            return bad("min_views must be at least 1");
        }
        if !positive(self.points_per_m2) || !positive(self.dense_spacing_m) {
            return bad("points_per_m2 and dense_spacing_m must be > 0");
        }
        if self.dense_min_points == 0 {
            return bad("dense_min_points must be at least 1");
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod keys_tests;
