//! The front doors of a reconstruction: the one library entry per job that
//! `vpctl mvs run` and the Python `vpctl.mvs.reconstruct` both call, so that
//! a notebook and the command line check the same inputs, write the same
//! files and refuse the same outputs.
//!
//! [`reconstruct_workspace`] is a COLMAP dense workspace run (refusing to
//! overwrite `fused.ply` without `force`); [`reconstruct_image_sets`] runs
//! every image set (labelgen's triplets) at every pyramid level into the
//! depth folder `vpctl labelgen run --depth-dir` reads, through a
//! [`vp_scene::outdir::OutDir`]: every set is checked before the first
//! reconstruction, and a failure leaves no partial folder.
//!
//! The request structs are `#[non_exhaustive]` with a constructor: a new
//! option (a matcher choice, say) is a new field with a default, and no
//! caller breaks.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::error::{MvsError, Result};
use crate::params::MvsParams;
use crate::workspace::{run_image_set, run_workspace, RunOptions, RunSummary, Workspace};

/// The name `mvs run` records in its output folder's manifest.
const COMMAND: &str = "mvs run";

/// A workspace run, as `vpctl mvs run --workspace` takes it.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct WorkspaceRequest {
    /// The dense workspace (`images/`, `sparse/`); the maps and `fused.ply`
    /// are written into it.
    pub workspace: PathBuf,
    /// The images, depth range and parameters.
    pub options: RunOptions,
    /// Overwrite an existing `fused.ply`.
    pub force: bool,
}

impl WorkspaceRequest {
    /// All images, depth ranges from the sparse points, default parameters,
    /// no overwriting.
    pub fn new(workspace: impl Into<PathBuf>) -> Self {
        WorkspaceRequest {
            workspace: workspace.into(),
            options: RunOptions::default(),
            force: false,
        }
    }
}

/// Reconstructs the workspace of `req` ([`run_workspace`]) after refusing
/// an existing `fused.ply` without `force`. `progress` gets one line a step.
pub fn reconstruct_workspace(
    req: &WorkspaceRequest,
    progress: &mut dyn FnMut(&str),
) -> Result<RunSummary> {
    vp_scene::fsio::check_overwrite(&req.workspace.join("fused.ply"), req.force)?;
    run_workspace(&req.workspace, &req.options, progress)
}

/// One image set to reconstruct on its own: its id names its folder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ImageSet {
    /// The folder name (`t0000` for labelgen's triplets).
    pub id: String,
    /// Image names under the workspace's `images/`.
    pub images: Vec<String>,
}

impl From<(String, Vec<String>)> for ImageSet {
    fn from((id, images): (String, Vec<String>)) -> Self {
        ImageSet { id, images }
    }
}

/// Image sets at pyramid levels, as `vpctl mvs run --triplets` takes them.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct ImageSetsRequest {
    /// The dense workspace the images and cameras come from (only read).
    pub workspace: PathBuf,
    /// The sets.
    pub sets: Vec<ImageSet>,
    /// The file the sets were read from (named in errors, and an input the
    /// output folder may not hold).
    pub list: Option<PathBuf>,
    /// Pyramid levels (1 = full size, each level halving).
    pub levels: Vec<u32>,
    /// Depth range for every image, overriding the sparse points.
    pub depth_range: Option<(f64, f64)>,
    /// Parameters.
    pub params: MvsParams,
    /// Other files the job read (the config), which the output folder may
    /// not hold.
    pub inputs: Vec<PathBuf>,
    /// The output folder: `<id>/level<L>/<image>.{photometric,geometric}.bin`.
    pub out: PathBuf,
    /// Replace an earlier output of vpctl in `out`.
    pub force: bool,
}

impl ImageSetsRequest {
    /// Level 1, depth ranges from the sparse points, default parameters,
    /// no overwriting.
    pub fn new(
        workspace: impl Into<PathBuf>,
        sets: Vec<ImageSet>,
        out: impl Into<PathBuf>,
    ) -> Self {
        ImageSetsRequest {
            workspace: workspace.into(),
            sets,
            list: None,
            levels: vec![1],
            depth_range: None,
            params: MvsParams::default(),
            inputs: Vec::new(),
            out: out.into(),
            force: false,
        }
    }
}

/// Share of pixels with a geometric depth, per image, per level, per set id.
pub type SetShares = BTreeMap<String, BTreeMap<u32, Vec<f64>>>;

/// Reconstructs every set of `req` at every level into `req.out` (see the
/// module doc). `progress` gets one line per (set, level) before it runs.
/// Errors name the list and the set at fault.
pub fn reconstruct_image_sets(
    req: &ImageSetsRequest,
    progress: &mut dyn FnMut(&str),
) -> Result<SetShares> {
    let mut inputs: Vec<&Path> = vec![req.workspace.as_path()];
    inputs.extend(req.list.as_deref());
    inputs.extend(req.inputs.iter().map(PathBuf::as_path));
    let target = vp_scene::outdir::OutDir::check(&req.out, COMMAND, &inputs, req.force)?;
    req.params.validate()?;
    if let Some(bad) = req.levels.iter().find(|l| !(1..=8).contains(*l)) {
        return Err(MvsError::InvalidArgument(format!(
            "pyramid level {bad} is outside 1..=8"
        )));
    }
    let ws = Workspace::open(&req.workspace)?;
    for set in &req.sets {
        ws.select(Some(&set.images)).map_err(|e| match &req.list {
            Some(list) => MvsError::Input {
                path: list.clone(),
                message: format!("triplet {}: {e}", set.id),
            },
            None => MvsError::InvalidArgument(format!("image set {}: {e}", set.id)),
        })?;
    }
    target.write(|stage| -> Result<SetShares> {
        let mut shares = SetShares::new();
        for (i, set) in req.sets.iter().enumerate() {
            let per_level = shares.entry(set.id.clone()).or_default();
            for &level in &req.levels {
                progress(&format!(
                    "triplet {} ({}/{}) level {level}",
                    set.id,
                    i + 1,
                    req.sets.len()
                ));
                let dir = stage.join(&set.id).join(format!("level{level}"));
                let s = run_image_set(
                    &ws,
                    &set.images,
                    level,
                    req.depth_range,
                    &req.params,
                    &dir,
                    &mut |_| {},
                )?;
                per_level.insert(level, s);
            }
        }
        Ok(shares)
    })
}
