//! Virtual multi-view stereo: what stands in for a real dense MVS algorithm
//! (SURE, PMVS) in the simulated world.
//!
//! [`MvsProfile`] holds the truth curves (success probability per material
//! over triangulation angle and resolution); [`VirtualMvs`] turns a camera
//! triplet into one depth map per image that behaves accordingly.

mod profile;
mod reconstruct;

#[cfg(test)]
mod tests;

pub use profile::{MaterialCurve, MvsProfile};
pub use reconstruct::{
    level_camera, triplet_truth, MvsView, PixelStatus, PixelTruth, VirtualMvs, MAX_LEVEL,
};
