//! What `vpctl plan` and `vpctl plan grid` share: the planner config (a
//! planner file or a campaign config's `[planner]`), the ROI, origin,
//! home, and the output files checked before any work.

use std::path::{Path, PathBuf};

use anyhow::{bail, Result};
use vp_planner::{HomeSpec, PlanOutputs, PlannerConfig, RoiSpec};
use vp_scene::config_file::read_section;
use vp_scene::fsio;
use vp_scene::plan::GeodeticOrigin;
use vp_scene::roi::Roi;

use super::Common;

pub(super) fn required<'a>(v: Option<&'a PathBuf>, flag: &str) -> Result<&'a Path> {
    match v {
        Some(p) => Ok(p),
        None => bail!("{flag} is required"),
    }
}

impl Common {
    pub(super) fn config(&self) -> Result<PlannerConfig> {
        let mut cfg = match &self.config {
            Some(p) => load_planner_config(p)?,
            None => PlannerConfig::default(),
        };
        if let Some(t) = self.max_flight_time {
            cfg.mission.max_flight_time_s = Some(t);
        }
        cfg.validate()?;
        Ok(cfg)
    }

    pub(super) fn roi(&self) -> Result<RoiSpec> {
        if let Some(b) = &self.roi_box {
            return Ok(RoiSpec::Region(Roi::from_box(*b)?));
        }
        if let Some(p) = &self.roi_polygon {
            return Ok(RoiSpec::from_area_file(
                p,
                self.roi_name.as_deref(),
                self.roi_heights.map(|[lo, hi]| (lo, hi)),
            )?);
        }
        Ok(match &self.roi {
            Some(arg) => RoiSpec::Region(parse_roi(arg)?),
            None => RoiSpec::All,
        })
    }

    pub(super) fn origin(&self) -> Result<Option<GeodeticOrigin>> {
        self.origin
            .as_ref()
            .map(|o| Ok(GeodeticOrigin::new(o[0], o[1], o[2])?))
            .transpose()
    }

    pub(super) fn home(&self, from_first_image: bool) -> HomeSpec {
        match (self.home, from_first_image) {
            (Some(h), _) => HomeSpec::At {
                position: h.position,
                datum: h.datum,
            },
            (None, true) => HomeSpec::FirstImage,
            (None, false) => HomeSpec::Unset,
        }
    }

    /// Refuses early, before any work, when an output exists.
    pub(super) fn check_outputs(&self) -> Result<PlanOutputs> {
        let out = required(self.out.as_ref(), "--out")?;
        crate::cmd::check_extension(out, "--out", &["json"])?;
        if let Some(p) = &self.ply {
            crate::cmd::check_extension(p, "--ply", &["ply"])?;
        }
        if let Some(p) = &self.png {
            crate::cmd::check_extension(p, "--png", &["png"])?;
        }
        if let Some(p) = &self.glb {
            crate::cmd::check_extension(p, "--glb", &["glb"])?;
        }
        for (p, flag) in [
            (Some(out), "--out"),
            (self.ply.as_deref(), "--ply"),
            (self.png.as_deref(), "--png"),
            (self.glb.as_deref(), "--glb"),
        ] {
            if let Some(p) = p {
                // The flag-naming check first: it names which option the
                // missing folder belongs to.
                crate::cmd::check_output_writable(p, flag)?;
                fsio::check_output_file(p, self.force)?;
            }
        }
        Ok(PlanOutputs {
            plan: out.to_path_buf(),
            ply: self.ply.clone(),
            png: self.png.clone(),
            glb: self.glb.clone(),
            force: self.force,
        })
    }
}

/// `--roi`: inline JSON (starting with `{`) or the path of a JSON file.
pub(super) fn parse_roi(arg: &str) -> Result<Roi> {
    if arg.trim_start().starts_with('{') {
        return serde_json::from_str(arg).map_err(|e| {
            crate::cmd::UsageError(format!(
                "--roi: column {}: not a region of interest ({{\"kind\": \"box\" | \
                 \"polygon\" | \"image_polygon\", ...}}, see docs/formats.md): {e}",
                e.column()
            ))
            .into()
        });
    }
    Ok(Roi::load(Path::new(arg))?)
}

/// A planner config, or a campaign config's `[planner]` section (a file
/// with a `[site]` or `[planner]` table), so that the config `sim fly
/// --site` flies with plans with the same camera. Missing keys take the
/// planner's defaults (never the simulator's demo preset); a campaign
/// file's other sections are checked for unknown keys only.
pub fn load_planner_config(path: &Path) -> Result<PlannerConfig> {
    let text = fsio::read_text(path)?;
    let table: toml::Table = vp_scene::config_file::parse_toml(&text, path)?;
    if table.contains_key("planner") || table.contains_key("site") {
        vp_sim::campaign::CampaignConfig::check_keys(&text, path)?;
        return Ok(read_section(&text, path, "planner")?);
    }
    Ok(read_section(&text, path, "")?)
}
