//! OpenSfM's `tracks.csv`: where each point was seen in each photo. Read
//! into the points' tracks and the images' 2D points, so that an OpenSfM
//! reconstruction carries what a COLMAP model does and the planner carves
//! the free space from the same observation rays.
//!
//! Tab-separated, after an optional `OPENSFM_TRACKS_VERSION_vN` line:
//! image, track id, feature id, x, y (normalised image coordinates, see
//! `camera.rs`), then size, colour and segmentation depending on the
//! version; only the first five fields are read.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::Path;

use nalgebra::Point2;

use crate::colmap::{Point2D, Reconstruction};
use crate::error::{Location, Result, SceneError};

/// The file OpenSfM writes the tracks to, beside `reconstruction.json`.
pub const TRACKS_FILE: &str = "tracks.csv";

/// Adds the observations of `path` that tie a shot of `rec` to one of its
/// points (`point_ids`: id by track id); the others belong to images or
/// tracks OpenSfM did not reconstruct. Returns the number added. Errors
/// name the line.
pub(crate) fn add_tracks(
    path: &Path,
    rec: &mut Reconstruction,
    point_ids: &BTreeMap<String, u64>,
) -> Result<usize> {
    let text = crate::fsio::read_text(path)?;
    let image_ids: HashMap<String, u32> = rec
        .images
        .values()
        .map(|im| (im.name.clone(), im.id))
        .collect();
    let mut seen = HashSet::new();
    let mut added = 0;
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() || (i == 0 && line.starts_with("OPENSFM_TRACKS_VERSION")) {
            continue;
        }
        let bad = |m: String| SceneError::parse(path, Location::Line(i + 1), m);
        let f: Vec<&str> = line.split('\t').collect();
        if f.len() < 5 {
            return Err(bad(format!(
                "expected at least 5 tab-separated fields (image, track, feature, x, y), found {}",
                f.len()
            )));
        }
        let xy: Vec<f64> = f[3..5]
            .iter()
            .map(|v| v.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
            .collect::<Option<_>>()
            .ok_or_else(|| bad(format!("x, y {:?} are not numbers", &f[3..5])))?;
        let (Some(&image_id), Some(&point_id)) = (image_ids.get(f[0]), point_ids.get(f[1])) else {
            continue;
        };
        if !seen.insert((image_id, point_id)) {
            continue;
        }
        let (Some(image), Some(point)) =
            (rec.images.get_mut(&image_id), rec.points.get_mut(&point_id))
        else {
            continue;
        };
        let Some(cam) = rec.cameras.get(&image.camera_id) else {
            continue;
        };
        // Normalised -> COLMAP pixels (corner at 0), as for the cameras.
        let size = cam.width.max(cam.height) as f64;
        let px = Point2::new(
            xy[0] * size + cam.width as f64 / 2.0,
            xy[1] * size + cam.height as f64 / 2.0,
        );
        let idx = u32::try_from(image.points2d.len())
            .map_err(|_| bad("too many observations in one image".into()))?;
        image.points2d.push(Point2D {
            xy: px,
            point3d_id: Some(point_id),
        });
        point.track.push((image_id, idx));
        added += 1;
    }
    Ok(added)
}
