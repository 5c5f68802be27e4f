//! `--colmap DIR` or `--opensfm DIR`: the one way the commands that read an
//! acquired sparse model (`plan`, `labelgen triplets`, `labelgen run`) take
//! it, so that each reads it as a [`ModelSource`].

use std::path::PathBuf;

use clap::Args;
use vp_scene::opensfm::ModelSource;

/// The acquired sparse model, of either kind.
#[derive(Debug, Args)]
pub struct SparseModelArgs {
    /// COLMAP sparse model folder (cameras, images, points3D; .bin or .txt).
    #[arg(
        long = "colmap",
        aliases = ["model", "cameras"],
        value_name = "DIR",
        required_unless_present = "opensfm"
    )]
    colmap: Option<PathBuf>,
    /// Or an OpenSfM reconstruction: an OpenDroneMap project folder, its
    /// `opensfm` folder or `reconstruction.json`; georeferenced by its
    /// `reference_lla`, so no `colmap align` (docs/formats.md).
    #[arg(long, value_name = "DIR", conflicts_with = "colmap")]
    opensfm: Option<PathBuf>,
}

impl SparseModelArgs {
    /// The model named.
    pub fn source(&self) -> ModelSource {
        match (&self.colmap, &self.opensfm) {
            (_, Some(dir)) => ModelSource::OpenSfm(dir.clone()),
            // clap requires one of the two (a subcommand of `plan` neither).
            (dir, None) => ModelSource::Colmap(dir.clone().unwrap_or_default()),
        }
    }
}
