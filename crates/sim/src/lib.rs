//! `vp-sim`: the simulated world that stands in for a drone and a real
//! dense MVS algorithm.
//!
//! - [`render::render`]: ray-cast RGB images of a procedural site with
//!   per-material solid textures and sun shading, plus exact depth and face ids.
//! - [`mvs::VirtualMvs`]: one depth map per image of a camera triplet, failing
//!   with a probability that depends on material, triangulation angle and
//!   resolution ([`mvs::MvsProfile`]: SURE-like and PMVS-like presets), in
//!   spatially coherent blobs, with depth noise from the triplet's first-order
//!   3D uncertainty and a share of outliers.
//!
//! - [`campaign`]: closed-loop acquisition campaigns (training, flights with
//!   every strategy of the paper, Table-1 evaluation, report).
//!
//! Every random choice is a pure hash of (seed, coordinates) ([`noise`]), so
//! the output is bit-identical for a seed on any thread count.
#![warn(missing_docs)]

pub mod campaign;
pub mod error;
pub mod mvs;
pub mod noise;
pub mod render;
pub mod texture;

#[cfg(test)]
mod render_tests;
#[cfg(test)]
mod test_scenes;

pub use error::{Result, SimError};
pub use mvs::{MaterialCurve, MvsProfile, VirtualMvs};
pub use render::{render, RenderParams, Rendered};
