//! `vp-scene`: the shared ground of vpctl.
//!
//! Everything the other crates exchange lives here: the [`Mesh`] with
//! per-face [`Material`]s, posed pinhole [`Camera`]s, file formats
//! ([`io`] for PLY/OBJ, [`colmap`] for COLMAP models and depth maps), ray
//! casting for visibility ([`raycast`], obvhs CWBVH), clearance to obstacles
//! ([`clearance`], parry3d), the mesh operations of the paper
//! ([`mesh_ops`]), 2.5D and 3D surface reconstruction from points
//! ([`height_field`], [`surface`]), triangulation angle and uncertainty ([`triangulation`]),
//! raster types ([`raster`]), the plan file ([`plan`]) and
//! deterministic procedural scenes ([`procedural`]) that feed every crate's
//! tests and the simulator, and the one seeded hash ([`hash`], SplitMix64).
//!
//! World frame: local ENU, metres, z up. Poses are named by what they map
//! (`world_from_cam`).
#![warn(missing_docs, unreachable_pub)]
// A library tells its caller (returned warnings, reports, progress callbacks);
// only the CLI and the Python bindings print (docs/design.md).
#![deny(clippy::print_stderr, clippy::print_stdout)]

pub mod binfile;
pub mod camera;
pub mod clearance;
pub mod colmap;
pub mod config_file;
pub mod datum;
pub mod error;
pub mod flight_time;
pub mod fsio;
pub mod geodesy;
pub mod gnss;
pub mod hash;
pub mod height_field;
pub mod image_files;
pub mod io;
pub mod mesh;
pub mod mesh_inspect;
pub mod mesh_ops;
pub mod occupancy;
pub mod opensfm;
pub mod outdir;
pub mod plan;
pub mod procedural;
pub mod raster;
pub mod raycast;
pub mod roi;
pub mod roi_file;
mod roi_kml;
pub mod sim3;
pub mod surface;
pub mod triangulation;

pub use camera::{Camera, Intrinsics};
pub use error::{Location, Result, SceneError};
pub use mesh::{Aabb, Material, Mesh};
