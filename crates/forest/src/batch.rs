//! Prediction of many image files at once, for `vpctl predict` and the
//! Python bindings alike: each image's confidence file is named by the one
//! rule of [`vp_scene::image_files`] (`<out>/<image name>.vpconf`, the name
//! the planner looks for), and every image is predicted before anything is
//! written, so a bad image leaves no output behind.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use vp_scene::fsio;
use vp_scene::image_files::{confidence_file, sidecar};
use vp_scene::raster::{confidence_preview, encode_png, load_rgb, ConfidenceImage};
use vp_scene::SceneError;

use crate::error::{ForestError, Result};
use crate::Forest;

/// Options of [`predict_files`].
#[derive(Debug, Clone)]
pub struct BatchOptions {
    /// Grid step in pixels (the paper: 8).
    pub step: u32,
    /// Also write a preview per image (`<image name>.preview.png`: the photo
    /// beside the colour-mapped confidence of every angle bin, with a colour
    /// key; see [`vp_scene::raster::confidence_preview`]).
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
    /// The preview written, if previews were asked for.
    pub preview_file: Option<PathBuf>,
}

impl Predicted {
    /// Mean confidence over grid nodes and bins.
    pub fn mean_confidence(&self) -> f64 {
        mean_of(self.confidence.values())
    }
}

fn mean_of(v: &[f32]) -> f64 {
    v.iter().map(|&x| f64::from(x)).sum::<f64>() / v.len().max(1) as f64
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
    predict_files_with_progress(forest, images, out_dir, options, &mut |_| {})
}

/// [`predict_files`], calling `progress` with a message ending in `(i/n)`
/// after each image is predicted, and once before the files are written.
pub fn predict_files_with_progress(
    forest: &Forest,
    images: &[(PathBuf, String)],
    out_dir: &Path,
    options: &BatchOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<Predicted>> {
    if images.is_empty() {
        return Err(ForestError::InvalidInput(
            "no images to predict (folders are searched for .png, .jpg, .jpeg, .tif, .tiff, \
             .pgm, .ppm files)"
                .to_string(),
        ));
    }
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
        let preview = if options.previews {
            Some(sidecar(out_dir, name, "preview.png")?)
        } else {
            None
        };
        for p in std::iter::once(&conf).chain(&preview) {
            fsio::check_overwrite(p, options.force)?;
        }
        jobs.push((path, name, conf, preview));
    }
    let mut predicted = Vec::with_capacity(jobs.len());
    for (path, name, conf, preview) in jobs {
        let image = load_rgb(path)?;
        let confidence = forest.predict_image(&image, options.step)?;
        // Encoded now, so that only the PNG bytes wait for the writing,
        // not the photos.
        let preview = match preview {
            Some(file) => {
                let mean = mean_of(confidence.values());
                let title = format!("{name}: mean confidence {mean:.2}");
                let png = encode_png(&confidence_preview(&confidence, &image, &title), &file)?;
                Some((file, png))
            }
            None => None,
        };
        predicted.push((
            Predicted {
                image: path.clone(),
                name: name.clone(),
                confidence_file: conf,
                confidence,
                preview_file: preview.as_ref().map(|(f, _)| f.clone()),
            },
            preview,
        ));
        progress(&format!(
            "predicted {name} ({}/{})",
            predicted.len(),
            images.len()
        ));
    }
    progress(&format!("writing {} confidence files", predicted.len()));
    for (p, preview) in &predicted {
        for file in std::iter::once(&p.confidence_file).chain(preview.iter().map(|(f, _)| f)) {
            if let Some(parent) = file.parent() {
                std::fs::create_dir_all(parent).map_err(|e| SceneError::io(parent, e))?;
            }
        }
        p.confidence.save(&p.confidence_file)?;
        if let Some((file, png)) = preview {
            fsio::write_file_atomic(file, png)?;
        }
    }
    Ok(predicted.into_iter().map(|(p, _)| p).collect())
}

/// Most images [`report`] lists one by one; beyond, it sums them up (a log
/// of `vpctl predict` on 5,000 images had 10,000 lines).
pub const LIST_UP_TO: usize = 20;

/// What `vpctl predict` prints of `predicted` (written to `out_dir`): a
/// line per image and its preview for up to [`LIST_UP_TO`] images, else
/// three summary lines: the count, the mean confidence with the lowest
/// and highest image, and where the files are.
pub fn report(predicted: &[Predicted], out_dir: &Path) -> Vec<String> {
    if predicted.len() <= LIST_UP_TO {
        let mut lines = Vec::new();
        for p in predicted {
            let (gw, gh) = p.confidence.grid_size();
            lines.push(format!(
                "{}: {gw}x{gh} nodes x {} bins, mean confidence {:.3} -> {}",
                p.image.display(),
                p.confidence.bins().len(),
                p.mean_confidence(),
                p.confidence_file.display()
            ));
            if let Some(f) = &p.preview_file {
                lines.push(format!("  preview: {}", f.display()));
            }
        }
        return lines;
    }
    let means: Vec<f64> = predicted.iter().map(Predicted::mean_confidence).collect();
    let by = |better: fn(f64, f64) -> bool| {
        let mut at = 0;
        for (i, &m) in means.iter().enumerate() {
            if better(m, means[at]) {
                at = i;
            }
        }
        format!("{:.3} {}", means[at], predicted[at].name)
    };
    let n = predicted.len();
    let previews = predicted
        .iter()
        .filter(|p| p.preview_file.is_some())
        .count();
    vec![
        format!(
            "predicted {n} images: mean confidence {:.3} (lowest {}, highest {})",
            means.iter().sum::<f64>() / n as f64,
            by(|a, b| a < b),
            by(|a, b| a > b)
        ),
        format!(
            "written: {n} confidence files <image name>.vpconf{} in {}",
            if previews > 0 {
                format!(" and {previews} previews <image name>.preview.png")
            } else {
                String::new()
            },
            out_dir.display()
        ),
        format!("(listed one by one up to {LIST_UP_TO} images)"),
    ]
}
