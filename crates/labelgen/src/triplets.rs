//! Triplet sampling: image triplets drawn from triangulation-angle bins.
//!
//! A triplet's angle is the median, over the sparse points seen by all three
//! images, of the triangulation angle at each point (largest pairwise angle
//! between the rays to the camera centres) [vpctl]. A triplet is kept when
//! - the three images share at least `min_shared_points` sparse points, and at
//!   least `min_shared_share` of the points of the image that sees fewest;
//! - it is near-equilateral at its median point: smallest / largest pairwise
//!   angle >= `min_equilateral` (0.5) [vpctl];
//! - its angle falls in a bin (edges 4, 8, 16, 32, 64, 128 deg by default).
//!
//! Then `per_bin` triplets are drawn per bin, without replacement, with a
//! seeded RNG: same model, parameters and seed, same list.
//!
//! # Files
//! The triplet list is UTF-8 text, one triplet per line, tab-separated:
//! `bin<TAB>angle_deg<TAB>image1<TAB>image2<TAB>image3`; lines starting with
//! `#` are comments. Triplet i (0-based, in file order, comments skipped) has
//! the id [`triplet_id`]`(i)` = `t0000`, `t0001`, ... The image lists (one per
//! triplet, `<id>.txt`, one image name per line) are what COLMAP's
//! `image_undistorter --image_list_path` takes, to run the MVS per triplet.

use std::collections::{BTreeMap, HashMap};
use std::io::Write as _;
use std::path::Path;

use nalgebra::Point3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use vp_scene::colmap::Reconstruction;
use vp_scene::{fsio, Location, SceneError};

use crate::error::{LabelgenError, Result};
use vp_scene::triangulation::triangulation_angle_deg;

/// Parameters of triplet sampling.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TripletParams {
    /// Bin edges in degrees (t bins from t + 1 increasing edges). Default
    /// 4, 8, 16, 32, 64, 128 (the paper's t = 5, "from 4 deg, each doubling").
    pub bin_edges: Vec<f64>,
    /// Triplets drawn per bin (fewer when a bin has fewer candidates).
    pub per_bin: usize,
    /// RNG seed.
    pub seed: u64,
    /// Fewest sparse points all three images must share. Default 20.
    pub min_shared_points: usize,
    /// Fewest shared points as a share of the points of the image (of the
    /// three) that observes fewest. Default 0.1.
    pub min_shared_share: f64,
    /// Smallest ratio of smallest to largest pairwise angle at the median
    /// point. Default 0.5 [vpctl].
    pub min_equilateral: f64,
}

impl Default for TripletParams {
    fn default() -> Self {
        TripletParams {
            bin_edges: vec![4.0, 8.0, 16.0, 32.0, 64.0, 128.0],
            per_bin: 10,
            seed: 0,
            min_shared_points: 20,
            min_shared_share: 0.1,
            min_equilateral: 0.5,
        }
    }
}

/// One sampled triplet.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Triplet {
    /// Index of its angle bin.
    pub bin: usize,
    /// Median triangulation angle over the shared sparse points, degrees.
    pub angle_deg: f64,
    /// The three image names, as in the COLMAP model.
    pub images: [String; 3],
}

/// The id of the i-th triplet of a list (`t0000`, ...): names its image list
/// and its folder of depth maps and labels.
pub fn triplet_id(i: usize) -> String {
    format!("t{i:04}")
}

/// Angle of a triplet with camera centres `centres` over `points`: the median
/// triangulation angle (degrees) and the smallest / largest pairwise angle at
/// the median point. `None` without points.
pub fn median_angle(centres: &[Point3<f64>; 3], points: &[Point3<f64>]) -> Option<(f64, f64)> {
    let mut angles: Vec<(f64, usize)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| (triangulation_angle_deg(p, centres), i))
        .collect();
    if angles.is_empty() {
        return None;
    }
    angles.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let (angle, i) = angles[(angles.len() - 1) / 2];
    let p = &points[i];
    let pair = |a: usize, b: usize| (centres[a] - p).angle(&(centres[b] - p));
    let pairs = [pair(0, 1), pair(0, 2), pair(1, 2)];
    let max = pairs.iter().copied().fold(0.0, f64::max);
    let min = pairs.iter().copied().fold(f64::INFINITY, f64::min);
    let ratio = if max > 0.0 { min / max } else { 0.0 };
    Some((angle, ratio))
}

fn validate(params: &TripletParams) -> Result<()> {
    let e = &params.bin_edges;
    if e.len() < 2
        || e.iter().any(|x| !(x.is_finite() && *x >= 0.0))
        || e.windows(2).any(|w| w[0] >= w[1])
    {
        return Err(LabelgenError::InvalidArgument(format!(
            "bin edges {e:?}: need at least two finite, non-negative, increasing values"
        )));
    }
    if !(0.0..=1.0).contains(&params.min_shared_share)
        || !(0.0..=1.0).contains(&params.min_equilateral)
    {
        return Err(LabelgenError::InvalidArgument(
            "min_shared_share and min_equilateral must lie in [0, 1]".into(),
        ));
    }
    Ok(())
}

/// Every triplet of `model` that passes the overlap, equilateral and bin
/// tests, ordered by image ids.
pub fn candidate_triplets(model: &Reconstruction, params: &TripletParams) -> Result<Vec<Triplet>> {
    validate(params)?;
    // Sorted, deduplicated sparse point ids per image.
    let mut seen: BTreeMap<u32, Vec<u64>> = model.images.keys().map(|&i| (i, Vec::new())).collect();
    let mut pairs: HashMap<(u32, u32), usize> = HashMap::new();
    for (id, pt) in &model.points {
        let mut imgs: Vec<u32> = pt.track.iter().map(|t| t.0).collect();
        imgs.sort_unstable();
        imgs.dedup();
        for (a, &i) in imgs.iter().enumerate() {
            if let Some(list) = seen.get_mut(&i) {
                list.push(*id);
            }
            for &j in &imgs[a + 1..] {
                *pairs.entry((i, j)).or_default() += 1;
            }
        }
    }
    let ok_pair = |i: u32, j: u32| {
        pairs
            .get(&(i, j))
            .is_some_and(|&n| n >= params.min_shared_points.max(1))
    };
    let ids: Vec<u32> = seen.keys().copied().collect();
    let mut out = Vec::new();
    for (a, &i) in ids.iter().enumerate() {
        for (b, &j) in ids.iter().enumerate().skip(a + 1) {
            if !ok_pair(i, j) {
                continue;
            }
            let ij = intersect(&seen[&i], &seen[&j]);
            for &k in &ids[b + 1..] {
                if !(ok_pair(i, k) && ok_pair(j, k)) {
                    continue;
                }
                let shared = intersect(&ij, &seen[&k]);
                let fewest = [i, j, k].iter().map(|x| seen[x].len()).min().unwrap_or(0);
                if shared.len() < params.min_shared_points.max(1)
                    || (shared.len() as f64) < params.min_shared_share * fewest as f64
                {
                    continue;
                }
                let centres = [i, j, k].map(|x| model.images[&x].center());
                let points: Vec<Point3<f64>> = shared.iter().map(|p| model.points[p].xyz).collect();
                let Some((angle, ratio)) = median_angle(&centres, &points) else {
                    continue;
                };
                if ratio < params.min_equilateral {
                    continue;
                }
                let Some(bin) = params
                    .bin_edges
                    .windows(2)
                    .position(|e| angle >= e[0] && angle < e[1])
                else {
                    continue;
                };
                out.push(Triplet {
                    bin,
                    angle_deg: angle,
                    images: [i, j, k].map(|x| model.images[&x].name.clone()),
                });
            }
        }
    }
    Ok(out)
}

fn intersect(a: &[u64], b: &[u64]) -> Vec<u64> {
    let (mut i, mut j, mut out) = (0, 0, Vec::new());
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                out.push(a[i]);
                i += 1;
                j += 1;
            }
        }
    }
    out
}

/// Draws up to `per_bin` candidates per bin without replacement (seeded);
/// the result is ordered by bin, then by candidate order.
pub fn sample_triplets(model: &Reconstruction, params: &TripletParams) -> Result<Vec<Triplet>> {
    let candidates = candidate_triplets(model, params)?;
    let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
    let mut out = Vec::new();
    for bin in 0..params.bin_edges.len() - 1 {
        let in_bin: Vec<&Triplet> = candidates.iter().filter(|t| t.bin == bin).collect();
        let n = params.per_bin.min(in_bin.len());
        let mut chosen = rand::seq::index::sample(&mut rng, in_bin.len(), n).into_vec();
        chosen.sort_unstable();
        out.extend(chosen.into_iter().map(|i| in_bin[i].clone()));
    }
    Ok(out)
}

/// Writes the triplet list (format in the module docs) atomically.
pub fn write_triplet_list(path: &Path, triplets: &[Triplet]) -> Result<()> {
    for t in triplets {
        if let Some(bad) = t.images.iter().find(|n| n.contains(['\t', '\n', '\r'])) {
            return Err(LabelgenError::InvalidArgument(format!(
                "image name {bad:?} contains a tab or line break"
            )));
        }
    }
    fsio::write_atomic(path, |w| {
        writeln!(w, "# vpctl labelgen triplets v1")?;
        writeln!(w, "# bin\tangle_deg\timage1\timage2\timage3")?;
        for t in triplets {
            let [a, b, c] = &t.images;
            writeln!(w, "{}\t{:.4}\t{a}\t{b}\t{c}", t.bin, t.angle_deg)?;
        }
        Ok(())
    })?;
    Ok(())
}

/// Reads a triplet list; errors name the file and the line.
pub fn read_triplet_list(path: &Path) -> Result<Vec<Triplet>> {
    let text = fsio::read_text(path)?;
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim_end_matches('\r');
        if line.trim().is_empty() || line.starts_with('#') {
            continue;
        }
        let bad =
            |m: String| LabelgenError::from(SceneError::parse(path, Location::Line(n + 1), m));
        let f: Vec<&str> = line.split('\t').collect();
        if f.len() != 5 {
            return Err(bad(format!(
                "expected 5 tab-separated fields (bin, angle, three image names), found {}",
                f.len()
            )));
        }
        let bin = f[0]
            .trim()
            .parse()
            .map_err(|_| bad(format!("bin {:?} is not a non-negative integer", f[0])))?;
        let angle_deg: f64 = f[1]
            .trim()
            .parse()
            .map_err(|_| bad(format!("angle {:?} is not a number", f[1])))?;
        if !angle_deg.is_finite() {
            return Err(bad(format!("angle {angle_deg} is not finite")));
        }
        let images = [f[2], f[3], f[4]].map(str::to_string);
        if images.iter().any(String::is_empty)
            || images[0] == images[1]
            || images[0] == images[2]
            || images[1] == images[2]
        {
            return Err(bad(
                "a triplet needs three different, non-empty image names".into(),
            ));
        }
        out.push(Triplet {
            bin,
            angle_deg,
            images,
        });
    }
    Ok(out)
}

/// The triplet list at `path` as (id, image names) pairs: the image sets
/// `vp_mvs::reconstruct_image_sets` reconstructs into the folders
/// `vpctl labelgen run --depth-dir` reads.
pub fn read_image_sets(path: &Path) -> Result<Vec<(String, Vec<String>)>> {
    Ok(read_triplet_list(path)?
        .into_iter()
        .enumerate()
        .map(|(i, t)| (triplet_id(i), t.images.to_vec()))
        .collect())
}

/// Writes one COLMAP image list per triplet, `<dir>/<id>.txt`, creating
/// `dir`. Refuses to overwrite existing lists unless `force`.
pub fn write_image_lists(dir: &Path, triplets: &[Triplet], force: bool) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| SceneError::io(dir, e))?;
    let paths: Vec<_> = (0..triplets.len())
        .map(|i| dir.join(format!("{}.txt", triplet_id(i))))
        .collect();
    for p in &paths {
        fsio::check_overwrite(p, force)?;
    }
    for (t, p) in triplets.iter().zip(&paths) {
        fsio::write_atomic(p, |w| {
            for name in &t.images {
                writeln!(w, "{name}")?;
            }
            Ok(())
        })?;
    }
    Ok(())
}
