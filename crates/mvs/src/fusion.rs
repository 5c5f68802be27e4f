//! Fusion of the filtered depth maps into one point cloud with normals and
//! colours, and its binary PLY file (the layout of COLMAP's `fused.ply`).

use std::io::Write as _;
use std::path::Path;

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

use crate::error::Result;
use crate::geometric::consistent_pixel;
use crate::params::MvsParams;
use crate::patchmatch::DepthNormalMap;
use crate::view::{unproject, View};

/// A fused point.
#[derive(Debug, Clone, PartialEq)]
pub struct FusedPoint {
    /// World position: mean of the fused pixels' points.
    pub position: Point3<f64>,
    /// Unit world normal: normalised mean of the fused pixels' normals.
    pub normal: Vector3<f64>,
    /// Mean colour of the fused pixels.
    pub color: [u8; 3],
    /// Number of pixels fused (reference included).
    pub n_pixels: usize,
    /// The views whose pixels were fused, the reference first: who saw the
    /// point (what COLMAP writes to `fused.ply.vis`), so a free-space map
    /// carves only rays that really reached it.
    pub views: Vec<usize>,
}

/// Rows of a reference whose consistent source pixels are found at once
/// (in parallel) before they are grouped (in order): 64 rows of a 2000 px
/// image with 8 sources hold 4 MB of matches.
const FUSE_ROWS: usize = 64;

/// No consistent pixel in that source.
const NO_MATCH: u32 = u32::MAX;

/// Fuses the geometric maps: every kept pixel not yet used starts a point
/// with the pixels of its sources that agree with it (and are themselves
/// kept and unused); the group becomes a point when it has at least
/// `min_fused_pixels` members. Views in index order, pixels row-major:
/// deterministic. A simplification of COLMAP's stereo_fusion, which grows
/// each group recursively from the members' own sources.
///
/// # Performance
/// The agreement test ([`consistent_pixel`]) is most of the work, and it
/// does not depend on which pixels are used: it runs for a block of rows
/// in parallel, then the block is grouped in order. No pixel of the
/// reference is used while it is the reference (its sources are other
/// views), so its unused pixels are known before the block starts: the
/// same points as testing pixel by pixel.
pub fn fuse(
    views: &[View],
    maps: &[Option<DepthNormalMap>],
    sources: &[Vec<usize>],
    params: &MvsParams,
) -> Vec<FusedPoint> {
    let mut fusion = Fusion::new(maps);
    let mut points = Vec::new();
    for r in 0..maps.len() {
        fusion.view(views, maps, sources, params, r, &mut |p| points.push(p));
    }
    points
}

/// [`fuse`], handing each point to `emit` as it is made, in [`fuse`]'s
/// order, and each map to `done` (view index, map) as soon as no later
/// view reads it, as its reference or as a source: the maps let go while
/// the cloud grows, and the cloud is whatever `emit` keeps of it (a
/// workspace run keeps the 27 bytes a point of `fused.ply`, [`FusedPly`],
/// not the 130-180 of a [`FusedPoint`] with its views), so that fusion's
/// memory stays below the matching's. The same points as [`fuse`].
pub fn fuse_releasing(
    views: &[View],
    mut maps: Vec<Option<DepthNormalMap>>,
    sources: &[Vec<usize>],
    params: &MvsParams,
    done: &mut dyn FnMut(usize, DepthNormalMap) -> Result<()>,
    emit: &mut dyn FnMut(FusedPoint),
) -> Result<()> {
    // The last view (in fusion's order) that reads each map.
    let mut last: Vec<usize> = (0..maps.len()).collect();
    for (r, src) in sources.iter().enumerate() {
        for &s in src {
            if let Some(l) = last.get_mut(s) {
                *l = (*l).max(r);
            }
        }
    }
    let mut fusion = Fusion::new(&maps);
    for r in 0..maps.len() {
        fusion.view(views, &maps, sources, params, r, emit);
        for (m, _) in last.iter().enumerate().filter(|&(_, &l)| l == r) {
            fusion.used[m] = Vec::new();
            if let Some(map) = maps[m].take() {
                done(m, map)?;
            }
        }
    }
    Ok(())
}

/// Fusion's state: which pixels of each map are used.
struct Fusion {
    used: Vec<Vec<bool>>,
}

impl Fusion {
    fn new(maps: &[Option<DepthNormalMap>]) -> Self {
        let used = maps
            .iter()
            .map(|m| {
                m.as_ref()
                    .map_or_else(Vec::new, |m| vec![false; m.depth.len()])
            })
            .collect();
        Fusion { used }
    }

    /// The points that start at view `r`'s pixels (see [`fuse`]), each
    /// handed to `emit`.
    fn view(
        &mut self,
        views: &[View],
        maps: &[Option<DepthNormalMap>],
        sources: &[Vec<usize>],
        params: &MvsParams,
        r: usize,
        emit: &mut dyn FnMut(FusedPoint),
    ) {
        let Some(map) = &maps[r] else { return };
        let view = &views[r];
        let w = map.width as usize;
        let srcs: Vec<(usize, &DepthNormalMap)> = sources
            .get(r)
            .map_or(&[][..], Vec::as_slice)
            .iter()
            .filter_map(|&s| Some((s, maps.get(s)?.as_ref()?)))
            .collect();
        let m = srcs.len().max(1);
        let mut members: Vec<(usize, usize)> = Vec::new();
        let mut matches: Vec<u32> = Vec::new();
        for block in (0..map.depth.len()).step_by(FUSE_ROWS * w) {
            let end = (block + FUSE_ROWS * w).min(map.depth.len());
            let free = &self.used[r][block..end];
            matches.clear();
            matches.resize((end - block) * m, NO_MATCH);
            matches
                .par_chunks_mut(w * m)
                .enumerate()
                .for_each(|(row, out)| {
                    for (x, out) in out.chunks_mut(m).enumerate() {
                        let i = row * w + x;
                        let d = map.depth[block + i];
                        if !(d > 0.0) || free[i] {
                            continue;
                        }
                        let y = (block + i) / w;
                        for (o, &(s, sm)) in out.iter_mut().zip(&srcs) {
                            if let Some(j) = consistent_pixel(view, &views[s], sm, x, y, d, params)
                            {
                                *o = j as u32;
                            }
                        }
                    }
                });
            for idx in block..end {
                let d = map.depth[idx];
                if !(d > 0.0) || self.used[r][idx] {
                    continue;
                }
                members.clear();
                members.push((r, idx));
                let found = &matches[(idx - block) * m..(idx - block + 1) * m];
                for (&j, &(s, _)) in found.iter().zip(&srcs) {
                    if j != NO_MATCH && !self.used[s][j as usize] {
                        members.push((s, j as usize));
                    }
                }
                if members.len() < params.min_fused_pixels {
                    continue;
                }
                emit(fused_point(views, maps, &members));
                for &(v, j) in &members {
                    self.used[v][j] = true;
                }
            }
        }
    }
}

/// The point of a group of agreeing pixels: the mean of their points,
/// normals and colours.
fn fused_point(
    views: &[View],
    maps: &[Option<DepthNormalMap>],
    members: &[(usize, usize)],
) -> FusedPoint {
    let mut pos = Vector3::zeros();
    let mut normal = Vector3::zeros();
    let mut color = [0.0f64; 3];
    for &(v, j) in members {
        let m = maps[v].as_ref().expect("members have maps");
        let mw = m.width as usize;
        let cam = &views[v].camera;
        pos += unproject(cam, j % mw, j / mw, f64::from(m.depth[j])).coords;
        let n = m.normal[j];
        normal += cam.world_from_cam.rotation
            * Vector3::new(f64::from(n[0]), f64::from(n[1]), f64::from(n[2]));
        let px = views[v].rgb.get_pixel((j % mw) as u32, (j / mw) as u32);
        for c in 0..3 {
            color[c] += f64::from(px[c]);
        }
    }
    let k = members.len() as f64;
    FusedPoint {
        position: Point3::from(pos / k),
        normal: normal.try_normalize(0.0).unwrap_or_else(Vector3::z),
        color: color.map(|c| (c / k).round().clamp(0.0, 255.0) as u8),
        n_pixels: members.len(),
        views: members.iter().map(|&(v, _)| v).collect(),
    }
}

/// The records of a `fused.ply` (see [`FusedPly::write`]), 27 bytes a
/// point: the cloud of a workspace run held as the file will hold it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FusedPly {
    records: Vec<u8>,
}

impl FusedPly {
    /// Bytes of one point: x y z nx ny nz as float, red green blue.
    const RECORD: usize = 6 * 4 + 3;

    /// Appends `p`'s record.
    pub fn push(&mut self, p: &FusedPoint) {
        for v in [
            p.position.x,
            p.position.y,
            p.position.z,
            p.normal.x,
            p.normal.y,
            p.normal.z,
        ] {
            self.records.extend_from_slice(&(v as f32).to_le_bytes());
        }
        self.records.extend_from_slice(&p.color);
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.records.len() / Self::RECORD
    }

    /// Whether there is no point.
    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// Writes the points as a binary little-endian PLY (x y z nx ny nz as
    /// float, red green blue as uchar: the layout of COLMAP's
    /// `fused.ply`), atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        vp_scene::fsio::write_atomic(path, |w| {
            write!(
                w,
                "ply\nformat binary_little_endian 1.0\ncomment written by vp-mvs\nelement vertex {}\n\
                 property float x\nproperty float y\nproperty float z\n\
                 property float nx\nproperty float ny\nproperty float nz\n\
                 property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n",
                self.len()
            )?;
            w.write_all(&self.records)
        })?;
        Ok(())
    }
}

#[cfg(test)]
#[path = "fusion_tests.rs"]
mod tests;
