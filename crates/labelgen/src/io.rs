//! Files of a labelling run: the depth-map layout read by
//! [`load_reconstructions`], and the label files written by [`write_labels`].
//!
//! # Depth maps
//! `<depth-dir>/<triplet id>/level<L>/<image name>.geometric.bin` (COLMAP's
//! dense depth-map format; `.photometric.bin` is taken when no geometric map
//! is there), for L = 1, 2, 3, ... (pyramid level 1 = full resolution, each
//! level halving it; any size is accepted as long as it is the image scaled
//! by one factor). Triplet ids are `t0000`, `t0001`, ... in the order of the
//! triplet list. A COLMAP dense workspace per triplet and level has its maps
//! in `stereo/depth_maps/`: link or copy that folder to
//! `<triplet id>/level<L>`. Every triplet needs at least one level; a level
//! folder needs a map for each of the three images. Each level is an
//! independent reconstruction with id `<triplet id>/level<L>`.
//!
//! # Labels
//! `<out-dir>/<triplet id>/level<L>/<image name>.vplabel` (vp-scene's label
//! image format: label and triangulation angle per pixel, at the depth
//! map's size, i.e. the image at that pyramid level), and
//! `<out-dir>/summary.json` ([`LabelSummary`]).

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use vp_scene::colmap::{read_depth_map, DepthMap, Reconstruction};
use vp_scene::{fsio, Camera, SceneError};

use crate::error::{LabelgenError, Result};
use crate::measurement::{TripletReconstruction, View};
use crate::summary::LabelSummary;
use crate::triplets::{triplet_id, Triplet};
use crate::ReconLabels;

/// Highest pyramid level looked for.
pub const MAX_LEVEL: u32 = 8;

/// Path of the depth map of `image` for triplet `id` at `level`, geometric form.
pub fn depth_map_path(depth_dir: &Path, id: &str, level: u32, image: &str) -> PathBuf {
    depth_dir
        .join(id)
        .join(format!("level{level}"))
        .join(format!("{image}.geometric.bin"))
}

/// The camera of `image` in `model` with intrinsics scaled to `depth`'s size,
/// after checking that the depth map fits the image and holds only finite,
/// non-negative depths. `path` names the map in errors.
pub fn view_from_depth(
    model: &Reconstruction,
    image: &str,
    depth: DepthMap,
    path: &Path,
) -> Result<View> {
    let Some(img) = model.images.values().find(|i| i.name == image) else {
        return Err(LabelgenError::input(
            path,
            format!("image {image:?} is not in the COLMAP model"),
        ));
    };
    let full: Camera = model.camera_of(img.id)?;
    let k = full.intrinsics;
    let s = f64::from(depth.width) / f64::from(k.width);
    if depth.width == 0 || (f64::from(k.height) * s - f64::from(depth.height)).abs() > 1.0 {
        return Err(LabelgenError::input(
            path,
            format!(
                "depth map is {}x{} but image {image:?} is {}x{}: not the image at some scale",
                depth.width, depth.height, k.width, k.height
            ),
        ));
    }
    if let Some(i) = depth
        .data
        .iter()
        .position(|d| !(d.is_finite() && *d >= 0.0))
    {
        let w = depth.width as usize;
        return Err(LabelgenError::input(
            path,
            format!(
                "pixel ({}, {}): depth {} (expected finite and >= 0)",
                i % w,
                i / w,
                depth.data[i]
            ),
        ));
    }
    let mut intrinsics = k.scaled(s);
    intrinsics.width = depth.width;
    intrinsics.height = depth.height;
    Ok(View {
        name: image.to_string(),
        camera: Camera::new(intrinsics, full.world_from_cam),
        depth,
    })
}

/// Loads every level of every triplet (layout in the module docs).
pub fn load_reconstructions(
    model: &Reconstruction,
    triplets: &[Triplet],
    depth_dir: &Path,
) -> Result<Vec<TripletReconstruction>> {
    let mut out = Vec::new();
    let names: HashSet<&str> = model.images.values().map(|i| i.name.as_str()).collect();
    for (i, t) in triplets.iter().enumerate() {
        let id = triplet_id(i);
        if let Some(bad) = t.images.iter().find(|n| !names.contains(n.as_str())) {
            return Err(LabelgenError::InvalidArgument(format!(
                "triplet {id} names image {bad:?}, which is not in the COLMAP model"
            )));
        }
        let before = out.len();
        for level in 1..=MAX_LEVEL {
            let dir = depth_dir.join(&id).join(format!("level{level}"));
            if !dir.is_dir() {
                continue;
            }
            let mut views = Vec::with_capacity(3);
            for name in &t.images {
                let geometric = depth_map_path(depth_dir, &id, level, name);
                let photometric = dir.join(format!("{name}.photometric.bin"));
                let path = if geometric.is_file() || !photometric.is_file() {
                    geometric
                } else {
                    photometric
                };
                if !path.is_file() {
                    return Err(LabelgenError::from(SceneError::io(
                        &path,
                        std::io::Error::new(
                            std::io::ErrorKind::NotFound,
                            format!("no depth map for image {name:?}"),
                        ),
                    )));
                }
                let depth = read_depth_map(&path)?;
                views.push(view_from_depth(model, name, depth, &path)?);
            }
            let views: [View; 3] = views
                .try_into()
                .map_err(|_| LabelgenError::InvalidArgument("three views".into()))?;
            out.push(TripletReconstruction {
                id: format!("{id}/level{level}"),
                views,
            });
        }
        if out.len() == before {
            let dir = depth_dir.join(&id);
            return Err(LabelgenError::from(SceneError::io(
                &dir,
                std::io::Error::new(
                    std::io::ErrorKind::NotFound,
                    format!(
                        "no depth maps for triplet {id} (expected level1/, level2/, ... folders)"
                    ),
                ),
            )));
        }
    }
    Ok(out)
}

/// Path of the label file of one view.
pub fn label_path(out_dir: &Path, id: &str, image: &str) -> Result<PathBuf> {
    Ok(vp_scene::image_files::label_file(&out_dir.join(id), image)?)
}

/// Writes every label image and `summary.json` under `out_dir`, each file
/// atomically. Checks first that nothing would be overwritten (unless
/// `force`), so a refusal leaves no output at all.
pub fn write_labels(out_dir: &Path, labels: &[ReconLabels], force: bool) -> Result<LabelSummary> {
    let summary_path = out_dir.join("summary.json");
    fsio::check_overwrite(&summary_path, force)?;
    let summary = write_label_images(out_dir, labels, force)?;
    write_summary(out_dir, &summary)?;
    Ok(summary)
}

/// Writes the label images of `labels` only (no `summary.json`), each file
/// atomically, after checking that none would be overwritten (unless
/// `force`); returns their summary. For runs labelled in parts: combine the
/// parts' summaries with [`LabelSummary::combine`] and write them with
/// [`write_summary`].
pub fn write_label_images(
    out_dir: &Path,
    labels: &[ReconLabels],
    force: bool,
) -> Result<LabelSummary> {
    let mut files = Vec::new();
    for rl in labels {
        for (name, img) in rl.names.iter().zip(&rl.labels) {
            files.push((label_path(out_dir, &rl.id, name)?, img));
        }
    }
    for (p, _) in &files {
        fsio::check_overwrite(p, force)?;
    }
    for (p, img) in &files {
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent).map_err(|e| SceneError::io(parent, e))?;
        }
        img.save(p)?;
    }
    Ok(LabelSummary::of(labels))
}

/// Writes `<out_dir>/summary.json` atomically.
pub fn write_summary(out_dir: &Path, summary: &LabelSummary) -> Result<()> {
    let json = serde_json::to_string_pretty(summary)
        .map_err(|e| LabelgenError::InvalidArgument(format!("summary: {e}")))?;
    fsio::write_atomic(&out_dir.join("summary.json"), |w| {
        use std::io::Write as _;
        w.write_all(json.as_bytes())?;
        w.write_all(b"\n")
    })?;
    Ok(())
}
