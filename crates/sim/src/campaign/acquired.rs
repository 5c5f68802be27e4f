//! What one planning iteration of a campaign planned from, written so that
//! a user can run `vpctl plan` on it by hand: the COLMAP model of the images
//! acquired so far (as `vpctl sim fly` writes one), their predicted
//! confidence, the planning mesh and the region of interest.
//!
//! The report holds one folder per iteration of every triplet strategy,
//! `plans/<strategy>/iter<i>-acquired/`:
//!
//! - `sparse/`: `cameras.txt`, `images.txt`, `points3D.txt` (PINHOLE
//!   cameras, SfM poses, sparse points with their tracks) and `frame.json`
//!   (the site's geodetic origin; the model is in its local ENU frame);
//! - `confidence/<image name>.vpconf`: the forest's prediction per image
//!   (strategies with prediction only, `F...`);
//! - `mesh.ply`: the planning mesh the iteration planned on (sparse and
//!   fused dense points, 3D mesher);
//! - `roi.json`: the region of interest (`vpctl plan --roi`).
//!
//! The campaign's planner also saw the fused dense points as free-space
//! observations, which the sparse model does not carry, and plans with the
//! strategy's triplets per iteration and its own seed: a plan made by hand
//! from these files is comparable, not identical.

use std::path::Path;

use vp_scene::colmap::{self, ModelFrame, Reconstruction};
use vp_scene::image_files::confidence_file;
use vp_scene::io::{write_mesh, MeshFormat};
use vp_scene::raster::ConfidenceImage;
use vp_scene::roi::Roi;
use vp_scene::{Aabb, Mesh, SceneError};

use crate::error::{Result, SimError};

/// What one iteration planned from (see the module docs).
#[derive(Debug, Clone)]
pub struct AcquiredModel {
    /// The sparse model of the images acquired before the iteration.
    pub model: Reconstruction,
    /// Its geodetic frame (`frame.json`).
    pub frame: ModelFrame,
    /// Per image name, the predicted confidence (empty without prediction).
    pub confidence: Vec<(String, ConfidenceImage)>,
    /// The planning mesh.
    pub mesh: Mesh,
    /// The region of interest.
    pub roi: Aabb,
}

impl AcquiredModel {
    /// Writes the folder `dir` (created; see the module docs).
    pub fn write(&self, dir: &Path) -> Result<()> {
        let sparse = dir.join("sparse");
        for d in [dir, &sparse] {
            std::fs::create_dir_all(d).map_err(|e| SceneError::io(d, e))?;
        }
        colmap::write_text(&sparse, &self.model)?;
        self.frame.save(&sparse)?;
        let conf_dir = dir.join("confidence");
        for (name, c) in &self.confidence {
            let file = confidence_file(&conf_dir, name)?;
            if let Some(parent) = file.parent() {
                std::fs::create_dir_all(parent).map_err(|e| SceneError::io(parent, e))?;
            }
            c.save(&file)?;
        }
        write_mesh(
            &dir.join("mesh.ply"),
            &self.mesh,
            MeshFormat::PlyBinaryLittleEndian,
        )?;
        let roi = serde_json::to_string_pretty(&Roi::from_aabb(&self.roi))
            .map_err(|e| SimError::Campaign(format!("region of interest to JSON: {e}")))?;
        let path = dir.join("roi.json");
        std::fs::write(&path, format!("{roi}\n")).map_err(|e| SceneError::io(&path, e))?;
        Ok(())
    }
}
