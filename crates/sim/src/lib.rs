//! `vp-sim`: the simulated world that stands in for a drone.
//!
//! - [`render::render`]: ray-cast RGB images of a procedural site with
//!   per-material solid textures, sun shading, shadows and sensor noise,
//!   plus exact depth and face ids. vp-mvs matches these images in every
//!   campaign; nothing decides its success but the images.
//! - [`virtual_mvs::triplet_truth`]: per pixel of a triplet, what the renderer knows
//!   (visibility in all three views, triangulation angle, first-order depth
//!   sigma), the truth vp-mvs's output is measured against.
//! - [`virtual_mvs::VirtualMvs`]: a fast stand-in for unit tests (`mvs = "virtual"`):
//!   one depth map per image of a camera triplet, failing
//!   with a probability that depends on material, triangulation angle and
//!   resolution ([`virtual_mvs::MvsProfile`]: SURE-like and PMVS-like presets), in
//!   spatially coherent blobs, with depth noise from the triplet's first-order
//!   3D uncertainty and a share of outliers.
//!
//! - [`config`]: what a run is asked to do ([`config::CampaignConfig`],
//!   TOML-loadable, with presets); [`world`]: the procedural site with its
//!   ray caster, clearance and ROI; [`sfm`]: the one SfM simulator (the
//!   poses and sparse points a user's SfM would give of rendered images).
//! - [`flight::fly`]: a plan flown in the simulated world: its images and
//!   the COLMAP model SfM would give (`vpctl sim fly`).
//! - [`gnss`]: the position error of a flight (GNSS bias and noise,
//!   path tracking) and the georeference of a model aligned to it.
//! - [`campaign`]: closed-loop acquisition campaigns (training, flights with
//!   every strategy of the paper, Table-1 evaluation, report).
//!
//! Every random choice is a pure hash of (seed, coordinates) ([`noise`]), so
//! the output is bit-identical for a seed on any thread count.
#![warn(missing_docs, unreachable_pub)]
// A library tells its caller (returned warnings, reports, progress callbacks);
// only the CLI and the Python bindings print (docs/design.md).
#![deny(clippy::print_stderr, clippy::print_stdout)]

pub mod campaign;
pub mod config;
pub mod error;
pub mod flight;
pub mod gnss;
pub mod noise;
pub mod render;
pub mod sfm;
pub mod texture;
pub mod virtual_mvs;
pub mod world;

#[cfg(test)]
mod render_tests;
#[cfg(test)]
mod test_scenes;

pub use error::{Result, SimError};
pub use render::{look_at_camera, material_shares, render, RenderParams, Rendered};
pub use virtual_mvs::{MaterialCurve, MvsProfile, VirtualMvs};
