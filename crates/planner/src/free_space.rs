//! Observed-free space for the safety policy (`unknown_space`).
//!
//! The planner's mesh holds what was reconstructed; everything else is
//! unknown, and with `unknown_space = "occupied"` (the default) a waypoint or
//! a path segment must keep the safety distance to unknown space as well as
//! to the mesh. Free space is carved into a [`vp_scene::occupancy`] map by
//! observation rays (camera centre to observed point): the tracks of a COLMAP
//! model ([`observations_from_model`]), the simulator's sparse and dense
//! points, or, when the caller has none, rays from the acquired cameras to
//! the mesh ([`observations_from_mesh`]; weaker: a hole in the mesh lets a
//! ray carve space behind it).

use nalgebra::Point3;
use serde::{Deserialize, Serialize};
use vp_scene::colmap::Reconstruction;
use vp_scene::occupancy::{FreeSpace, OccupancyMap};
use vp_scene::raycast::RayCaster;
use vp_scene::{Aabb, Camera};

use crate::error::Result;
use crate::flight_path::grid_rays;

/// An observation ray: the centre of a camera and a point it observed.
pub type Observation = (Point3<f64>, Point3<f64>);

/// What the planner assumes about space no camera has looked through.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum UnknownSpace {
    /// Unknown space is an obstacle: positions and segments keep the
    /// safety distance to it.
    #[default]
    Occupied,
    /// Unknown space is free; only the mesh is an obstacle (the paper).
    Free,
}

/// Most voxels of the planner's free-space map (50 MB of distances).
pub const MAX_VOXELS: usize = 12_500_000;

/// Images that must picture a column above the observed top before
/// `free_above_observed` frees it: SfM triangulates a point from two.
pub const LOOKED_AT_MIN_VIEWS: usize = 2;

/// Pixel-ray grid of [`observations_from_mesh`] per camera.
const MESH_RAY_GRID: (u32, u32) = (96, 64);

/// One ray per (point, observing image) of a COLMAP model.
pub fn observations_from_model(rec: &Reconstruction) -> Result<Vec<Observation>> {
    let mut centres = std::collections::BTreeMap::new();
    for &id in rec.images.keys() {
        centres.insert(id, rec.camera_of(id)?.center());
    }
    Ok(rec
        .points
        .values()
        .flat_map(|p| {
            p.track
                .iter()
                .filter_map(|(img, _)| centres.get(img))
                .map(move |c| (*c, p.xyz))
        })
        .collect())
}

/// Rays from each camera through a regular pixel grid to the first surface
/// of the mesh behind `caster` (rays that hit nothing observe nothing).
pub fn observations_from_mesh(cameras: &[Camera], caster: &RayCaster) -> Vec<Observation> {
    let mut out = Vec::new();
    for cam in cameras {
        let rays = grid_rays(cam, MESH_RAY_GRID);
        let c = cam.center();
        out.extend(
            caster
                .closest_hits(&rays, f64::INFINITY)
                .into_iter()
                .flatten()
                .map(|h| (c, h.point)),
        );
    }
    out
}

/// Carves `observations` into a map covering `volume` grown by `margin`
/// (queries near the volume's faces must see past them), with voxels of
/// `voxel_m`, or coarser when the map would exceed [`MAX_VOXELS`] (the
/// queries stay conservative at any voxel size). With
/// `free_above_observed`, space above the highest observed point is free
/// in the columns that [`LOOKED_AT_MIN_VIEWS`] of `cameras` picture just
/// above it: nothing floats over the observed tops (no wires, no
/// overhangs), and nothing taller stands where the cameras looked
/// ([`OccupancyMap::mark_free_above`]).
pub fn free_space(
    volume: &Aabb,
    margin: f64,
    voxel_m: f64,
    free_above_observed: bool,
    observations: &[Observation],
    cameras: &[Camera],
) -> Result<FreeSpace> {
    let grown = |v: f64| Aabb {
        min: volume.min - nalgebra::Vector3::repeat(margin + v),
        max: volume.max + nalgebra::Vector3::repeat(margin + v),
    };
    // Coarser voxels (never finer) when the volume would not fit the budget.
    let e = grown(voxel_m).max - grown(voxel_m).min;
    let voxel_m = voxel_m.max((e.x * e.y * e.z / MAX_VOXELS as f64).cbrt() * 1.01);
    let mut map = OccupancyMap::new(&grown(voxel_m), voxel_m)?;
    map.carve(observations);
    if free_above_observed {
        let top = observations
            .iter()
            .map(|(_, p)| p.z)
            .filter(|z| z.is_finite())
            .fold(f64::NEG_INFINITY, f64::max);
        if top.is_finite() {
            map.mark_free_above(top, cameras, LOOKED_AT_MIN_VIEWS);
        }
    }
    Ok(map.free_space())
}
