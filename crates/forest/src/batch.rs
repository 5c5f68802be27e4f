//! Prediction of many image files at once, for `vpctl predict` and the
//! Python bindings alike: each image's confidence file is named by the one
//! rule of [`vp_scene::image_files`] (`<out>/<image name>.vpconf`, the name
//! the planner looks for), and every image is predicted before anything is
//! written, so a bad image leaves no output behind.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use vp_scene::fsio;
use vp_scene::image_files::{confidence_file, sidecar};
use vp_scene::raster::{load_rgb, ConfidenceImage};
use vp_scene::SceneError;

use crate::error::{ForestError, Result};
use crate::Forest;

/// Options of [`predict_files`].
#[derive(Debug, Clone)]
pub struct BatchOptions {
    /// Grid step in pixels (the paper: 8).
    pub step: u32,
    /// Also write a greyscale PNG per angle bin (`<image name>.bin<i>.png`).
    pub previews: bool,
    /// Overwrite output files that exist.
    pub force: bool,
}

/// What was written for one image.
#[derive(Debug, Clone)]
pub struct Predicted {
    /// The image file.
    pub image: PathBuf,
    /// Its name (relative path, as COLMAP names it).
    pub name: String,
    /// The confidence file written.
    pub confidence_file: PathBuf,
    /// The confidence image.
    pub confidence: ConfidenceImage,
}

impl Predicted {
    /// Mean confidence over grid nodes and bins.
    pub fn mean_confidence(&self) -> f64 {
        let v = self.confidence.values();
        v.iter().map(|&x| f64::from(x)).sum::<f64>() / v.len().max(1) as f64
    }
}

/// Predicts every `(path, image name)` of `images` (see
/// [`vp_scene::image_files::find_images`]) and writes the confidence files
/// (and previews) under `out_dir`. Refuses an empty list, two images of one
/// name, and existing outputs unless `force`, before predicting anything.
pub fn predict_files(
    forest: &Forest,
    images: &[(PathBuf, String)],
    out_dir: &Path,
    options: &BatchOptions,
) -> Result<Vec<Predicted>> {
    if images.is_empty() {
        return Err(ForestError::InvalidInput(
            "no images to predict (folders are searched for .png, .jpg, .jpeg, .tif, .tiff, \
             .pgm, .ppm files)"
                .to_string(),
        ));
    }
    let b = forest.bins().len();
    let mut seen = HashSet::new();
    let mut jobs = Vec::with_capacity(images.len());
    for (path, name) in images {
        let conf = confidence_file(out_dir, name)?;
        if !seen.insert(conf.clone()) {
            return Err(ForestError::InvalidInput(format!(
                "{}: another input image has the same name {name}, both would write {}",
                path.display(),
                conf.display()
            )));
        }
        let previews = if options.previews {
            (0..b)
                .map(|i| sidecar(out_dir, name, &format!("bin{i}.png")))
                .collect::<vp_scene::Result<Vec<_>>>()?
        } else {
            Vec::new()
        };
        for p in std::iter::once(&conf).chain(&previews) {
            fsio::check_overwrite(p, options.force)?;
        }
        jobs.push((path, name, conf, previews));
    }
    let mut predicted = Vec::with_capacity(jobs.len());
    for (path, name, conf, previews) in jobs {
        let image = load_rgb(path)?;
        let confidence = forest.predict_image(&image, options.step)?;
        predicted.push((
            Predicted {
                image: path.clone(),
                name: name.clone(),
                confidence_file: conf,
                confidence,
            },
            previews,
        ));
    }
    for (p, previews) in &predicted {
        for file in std::iter::once(&p.confidence_file).chain(previews) {
            if let Some(parent) = file.parent() {
                std::fs::create_dir_all(parent).map_err(|e| SceneError::io(parent, e))?;
            }
        }
        p.confidence.save(&p.confidence_file)?;
        for (i, file) in previews.iter().enumerate() {
            p.confidence.save_bin_png(i, file)?;
        }
    }
    Ok(predicted.into_iter().map(|(p, _)| p).collect())
}
