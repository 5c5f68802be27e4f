//! The acquired views of a COLMAP model, with their confidence images: the
//! one way `vpctl plan` and the Python bindings turn files into
//! [`AcquiredView`]s, so that both plan from the same inputs.

use std::path::{Path, PathBuf};

use vp_scene::colmap::Reconstruction;
use vp_scene::raster::ConfidenceImage;

use crate::error::Result;
use crate::pipeline::AcquiredView;

/// Where the confidence image of `image_name` lives in `dir`:
/// `<dir>/<image name with extension .vpconf>`.
pub fn confidence_path(dir: &Path, image_name: &str) -> PathBuf {
    dir.join(Path::new(image_name).with_extension("vpconf"))
}

/// One view per image of `rec`, in image-id order (COLMAP ids follow
/// capture order in practice, so the last view is where the path starts),
/// each with its confidence image from `confidence_dir` (see
/// [`confidence_path`]) or none (the paper's NP variant). A missing or
/// malformed confidence file is an error naming the file.
pub fn acquired_from_model(
    rec: &Reconstruction,
    confidence_dir: Option<&Path>,
) -> Result<Vec<AcquiredView>> {
    let mut views = Vec::with_capacity(rec.images.len());
    for (&id, image) in &rec.images {
        let camera = rec.camera_of(id)?;
        let confidence = match confidence_dir {
            None => None,
            Some(dir) => Some(ConfidenceImage::load(&confidence_path(dir, &image.name))?),
        };
        views.push(AcquiredView { camera, confidence });
    }
    Ok(views)
}
