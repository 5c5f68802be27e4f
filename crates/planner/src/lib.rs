//! `vp-planner`: view planning for multi-view stereo after Mostegel et al.
//!
//! [`plan`] runs the paper's pipeline on a mesh and the acquired views:
//! [`fulfillment`] (M1, quality fulfillment f(t) of sampled triangles),
//! [`surrogate`] (M2, free-space surrogate cameras linked by inverse
//! visibility), [`triplet`] (M3, best camera triplet, k times) and
//! [`flight_path`] (M4, order, overlap, bridging views, safe segments).
//! [`grid`] plans the lawnmower baseline, [`output`] writes the camera PLY and
//! the PNG top view, [`config`] holds every parameter with the paper's defaults.
//!
//! Confidence arrives as one `ConfidenceImage` per acquired image (or none:
//! the paper's NP variant, confidence 1); the planner never sees the forest.
#![warn(missing_docs, unreachable_pub)]
// A library tells its caller (returned warnings, reports, progress callbacks);
// only the CLI and the Python bindings print (docs/design.md).
#![deny(clippy::print_stderr, clippy::print_stdout)]

pub mod acquired;
pub mod config;
pub mod error;
pub mod flight_path;
pub mod flights;
pub mod free_space;
pub mod fulfillment;
pub mod grid;
pub mod home_way;
pub mod oblique;
pub mod output;
pub mod position;
pub mod quality;
pub mod request;
pub mod safety;
pub mod surrogate;
pub mod top_view;
pub mod triplet;

mod inputs;
mod pipeline;
mod replace;

pub use acquired::acquired_from_model;
pub use config::{CameraConfig, PlannerConfig};
pub use error::{PlannerError, Result};
pub use free_space::{Observation, UnknownSpace};
pub use grid::plan_grid;
pub use inputs::{safety_for, AcquiredView, PlanInputs, PlanResult, RoiSpec, SampledFulfillment};
pub use pipeline::{plan, strip_timings};
pub use position::{GnssClass, GnssSigmas, SafetyConfig};
pub use request::{
    plan_from_model, plan_grid_job, resolve_home, GridRequest, HomeSpec, ModelPlan,
    ModelPlanRequest, PlanContext, PlanOutputs,
};
