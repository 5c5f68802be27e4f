//! Training data on disk, laid out as `vpctl labelgen run` writes it: label
//! images `<labels dir>/<triplet>/level<L>/<image name>.vplabel` (one per
//! image of each triplet and pyramid level; the image name may hold
//! sub-folders) next to a folder of the images themselves.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use image::imageops::{self, FilterType};
use vp_scene::image_files::{files_with_extensions, image_name_of_label, LABEL_EXTENSION};
use vp_scene::raster::{load_rgb, LabelImage, RgbImage};
use vp_scene::SceneError;

use crate::error::{ForestError, Result};
use crate::TrainingSet;

/// Image name and label size (largest first): the order of the groups.
type GroupKey = (String, std::cmp::Reverse<(u32, u32)>);

/// One image at one size with the label images of that size.
#[derive(Debug, Clone)]
pub struct LabelledImage {
    /// The image's file name (as in the label file names).
    pub name: String,
    /// The image, scaled to the label images' size when they are smaller
    /// (pyramid levels 2, 3, ... of the MVS).
    pub image: RgbImage,
    /// Label images, in sorted path order.
    pub labels: Vec<LabelImage>,
    /// Where each label image was read from.
    pub label_paths: Vec<PathBuf>,
}

/// Loads every label image under `labels_dir` and pairs it with its image in
/// `images_dir`. Label images smaller than their image pair with the image
/// scaled to their size (a triangle filter, as an image pyramid would).
/// The result is sorted by image name, then by size (largest first), so the
/// same folders always give the same training set.
///
/// # Errors
/// No label files, a missing or unreadable image (named with the label file
/// that needs it), an unreadable label file, or a label image larger than
/// its image.
pub fn load_label_dir(images_dir: &Path, labels_dir: &Path) -> Result<Vec<LabelledImage>> {
    let mut paths = files_with_extensions(labels_dir, &[LABEL_EXTENSION])?;
    if paths.is_empty() {
        return Err(ForestError::InvalidInput(format!(
            "{}: no .{LABEL_EXTENSION} files in this folder or below",
            labels_dir.display()
        )));
    }
    paths.sort();
    let mut groups: BTreeMap<GroupKey, Vec<(PathBuf, LabelImage)>> = BTreeMap::new();
    for path in paths {
        let name = image_name(labels_dir, &path)?;
        let label = LabelImage::load(&path)?;
        let size = std::cmp::Reverse((label.width(), label.height()));
        groups.entry((name, size)).or_default().push((path, label));
    }
    let mut images: BTreeMap<String, RgbImage> = BTreeMap::new();
    let mut out = Vec::with_capacity(groups.len());
    for ((name, std::cmp::Reverse((w, h))), labels) in groups {
        if !images.contains_key(&name) {
            let image_path = images_dir.join(&name);
            let image = load_rgb(&image_path).map_err(|e| match e {
                SceneError::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
                    ForestError::InvalidInput(format!(
                        "{}: its image {} does not exist",
                        labels[0].0.display(),
                        image_path.display()
                    ))
                }
                other => other.into(),
            })?;
            images.insert(name.clone(), image);
        }
        let full = &images[&name];
        let (iw, ih) = full.dimensions();
        if w > iw || h > ih {
            return Err(ForestError::InvalidInput(format!(
                "{}: label image is {w}x{h}, larger than its image {name} ({iw}x{ih})",
                labels[0].0.display()
            )));
        }
        let image = if (w, h) == (iw, ih) {
            full.clone()
        } else {
            imageops::resize(full, w, h, FilterType::Triangle)
        };
        let (label_paths, labels) = labels.into_iter().unzip();
        out.push(LabelledImage {
            name,
            image,
            labels,
            label_paths,
        });
    }
    Ok(out)
}

impl TrainingSet {
    /// The training set of a label folder: the one entry `vpctl train`, the
    /// Python `vpctl.forest.train_dirs` and the Dask workers' `TrainingData`
    /// call, so that the same folders and seed give the same samples.
    /// Images from `images_dir`, `<image name>.vplabel` files found under
    /// `labels_dir` (as `vpctl labelgen run` writes them); with
    /// `max_per_label_image`, at most that many pixels per label image,
    /// drawn with `seed`.
    pub fn from_label_dir(
        images_dir: &Path,
        labels_dir: &Path,
        max_per_label_image: Option<usize>,
        seed: u64,
    ) -> Result<TrainingSet> {
        let labelled = load_label_dir(images_dir, labels_dir)?;
        let mut set = match max_per_label_image {
            Some(cap) => TrainingSet::with_cap_per_label_image(cap, seed),
            None => TrainingSet::new(),
        };
        set.add_labelled(&labelled)?;
        Ok(set)
    }

    /// Adds every [`LabelledImage`] of [`load_label_dir`].
    pub fn add_labelled(&mut self, images: &[LabelledImage]) -> Result<()> {
        for li in images {
            self.add_image(&li.image, &li.labels).map_err(|e| match e {
                ForestError::InvalidInput(m) => {
                    ForestError::InvalidInput(format!("image {}: {m}", li.name))
                }
                other => other,
            })?;
        }
        Ok(())
    }
}

/// The image a label file under `root` belongs to (the one naming rule:
/// [`vp_scene::image_files::image_name_of_label`]).
fn image_name(root: &Path, path: &Path) -> Result<String> {
    image_name_of_label(root, path).ok_or_else(|| {
        ForestError::InvalidInput(format!(
            "{}: a label file name must be <image name>.{LABEL_EXTENSION}",
            path.display()
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::{label_image, texture_image};
    use vp_scene::raster::{save_rgb, Label};

    fn rule(noisy: bool, _angle: f32) -> Label {
        if noisy {
            Label::Positive
        } else {
            Label::Negative
        }
    }

    #[test]
    fn pairs_levels_with_scaled_images_in_sorted_order() {
        let dir = tempfile::tempdir().unwrap();
        let (images, labels) = (dir.path().join("img"), dir.path().join("lab"));
        for d in ["t0001/level1", "t0000/level1", "t0000/level2"] {
            std::fs::create_dir_all(labels.join(d)).unwrap();
        }
        std::fs::create_dir_all(&images).unwrap();
        let tex = texture_image(64, 48, 16, 1);
        save_rgb(&tex.image, &images.join("a.png")).unwrap();
        let full = label_image(&tex, 4, 45.0, 2, rule);
        full.save(&labels.join("t0001/level1/a.png.vplabel"))
            .unwrap();
        full.save(&labels.join("t0000/level1/a.png.vplabel"))
            .unwrap();
        LabelImage::new(32, 24)
            .save(&labels.join("t0000/level2/a.png.vplabel"))
            .unwrap();

        let got = load_label_dir(&images, &labels).unwrap();
        assert_eq!(got.len(), 2, "one group per size");
        assert_eq!(got[0].image.dimensions(), (64, 48));
        assert_eq!(got[0].labels.len(), 2);
        assert!(got[0].label_paths[0].ends_with("t0000/level1/a.png.vplabel"));
        assert_eq!(got[1].image.dimensions(), (32, 24));
        assert_eq!(got[0].image, tex.image, "full size is not resampled");

        let mut set = TrainingSet::new();
        set.add_labelled(&got).unwrap();
        assert_eq!(set.n_label_images(), 3);
        assert_eq!(
            set.len(),
            2 * full.count(Label::Positive) + 2 * full.count(Label::Negative)
        );
    }

    #[test]
    fn a_missing_image_is_named_with_the_label_file() {
        let dir = tempfile::tempdir().unwrap();
        let label = dir.path().join("b.jpg.vplabel");
        LabelImage::new(8, 8).save(&label).unwrap();
        let err = load_label_dir(&dir.path().join("nowhere"), dir.path())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("b.jpg.vplabel") && err.contains("does not exist"),
            "{err}"
        );
    }

    #[test]
    fn an_empty_folder_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let err = load_label_dir(dir.path(), dir.path()).unwrap_err();
        assert!(err.to_string().contains("no .vplabel files"), "{err}");
    }

    #[test]
    fn a_label_larger_than_its_image_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        save_rgb(&RgbImage::new(8, 8), &dir.path().join("c.png")).unwrap();
        LabelImage::new(16, 8)
            .save(&dir.path().join("c.png.vplabel"))
            .unwrap();
        let err = load_label_dir(dir.path(), dir.path()).unwrap_err();
        assert!(err.to_string().contains("larger than its image"), "{err}");
    }
}
