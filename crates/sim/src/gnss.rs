//! Position error of a simulated flight: where the vehicle really is when
//! it flies a planned path by GNSS, what its GNSS wrote into the photos,
//! and the georeference of a model aligned to those positions.
//!
//! The error of a GNSS class ([`vp_planner::GnssClass`]: RTK about 2 cm /
//! 3 cm, standard about 1.5 m / 3 m) is a slowly varying bias plus white
//! noise. The bias is a first-order Gauss-Markov process per axis (time
//! constant `time_constant_s`, minutes), drawn from its stationary
//! distribution at the start of each flight: consecutive waypoints share
//! most of it, two flights on different days share none. The white part is
//! `white_share` of the class's sigma (the receiver's epoch-to-epoch
//! noise, which the autopilot's filter smooths away but the photo's tag
//! keeps). The autopilot holds its *estimate* on the waypoint up to a
//! path-tracking error, so the vehicle really is at
//! `planned + tracking - bias`, and the photo says `planned + tracking +
//! white`.
//!
//! The georeference of the first flight's model is what `vpctl colmap
//! align --positions` computes from those tagged positions: the same code
//! ([`vp_scene::colmap::align_to_positions`]), fitting the model's camera
//! centres (the true ones: SfM's relative poses are exact up to a
//! similarity here) to the noisy positions. Its similarity maps the true
//! world into the model's frame.
//!
//! Every draw is a pure hash of (seed, waypoint, axis) ([`crate::noise`]).

use std::path::Path;

use nalgebra::{Isometry3, Point3, Translation3, Vector3};
use serde::{Deserialize, Serialize};
use vp_scene::colmap::{
    align_to_positions, AlignParams, Alignment, PositionResidual, Reconstruction,
};
use vp_scene::gnss::GnssClass;
use vp_scene::sim3::Sim3;
use vp_scene::{Aabb, Camera, Mesh};

use crate::error::{Result, SimError};
use crate::noise::gaussian;
use vp_scene::hash::mix64;

/// The simulated vehicle's position error (`[flight_error]` of a campaign).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FlightError {
    /// Fly the planned path exactly and georeference without error
    /// (false), as before issue 39.
    pub enabled: bool,
    /// The GNSS class of the vehicle and of the photos' tags.
    pub gnss: GnssClass,
    /// Correlation time of the bias, seconds.
    pub time_constant_s: f64,
    /// Share of the class's sigma that is white noise (the rest is bias;
    /// the total variance is the class's).
    pub white_share: f64,
    /// Path-tracking error of the autopilot, 1-sigma per axis, metres.
    pub tracking_m: f64,
    /// The planner keeps the position margin (`[safety]`, from this
    /// class); false plans without it, to measure the risk it removes.
    pub position_margin: bool,
    /// A measurement switch: the planner plans on the TRUE surface (moved
    /// into the model's georeferenced frame) instead of the mesh of what
    /// was seen, so that a flown path inside the safety distance can only
    /// come from position error, not from a surface no image showed
    /// (that risk is the unknown-space rule's, issue 16).
    pub plan_on_true_surface: bool,
}

impl Default for FlightError {
    fn default() -> Self {
        FlightError {
            enabled: true,
            gnss: GnssClass::Standard,
            time_constant_s: 300.0,
            white_share: 0.2,
            tracking_m: 0.2,
            position_margin: true,
            plan_on_true_surface: false,
        }
    }
}

/// A path as flown: per waypoint, where the vehicle really was and the
/// position its GNSS tagged the photo with.
#[derive(Debug, Clone, PartialEq)]
pub struct FlownPath {
    /// True positions.
    pub truth: Vec<Point3<f64>>,
    /// GNSS positions (what an image's EXIF says).
    pub tagged: Vec<Point3<f64>>,
}

impl FlightError {
    /// Checks the values; the message names the key.
    pub fn validate(&self) -> Result<()> {
        let (h, v) = self.gnss.sigmas_m();
        let bad = |k: &str, x: f64| {
            Err(SimError::InvalidArgument(format!(
                "[flight_error] {k} = {x}: must be finite and >= 0"
            )))
        };
        for (k, x) in [
            ("gnss.horizontal_m", h),
            ("gnss.vertical_m", v),
            ("tracking_m", self.tracking_m),
        ] {
            if !(x.is_finite() && x >= 0.0) {
                return bad(k, x);
            }
        }
        if !(self.time_constant_s.is_finite() && self.time_constant_s > 0.0) {
            return bad("time_constant_s", self.time_constant_s);
        }
        if !(0.0..=1.0).contains(&self.white_share) {
            return Err(SimError::InvalidArgument(format!(
                "[flight_error] white_share = {}: must be in [0, 1]",
                self.white_share
            )));
        }
        Ok(())
    }

    /// 1-sigma per axis of the bias and of the white noise (x, y, z).
    fn sigmas(&self) -> (Vector3<f64>, Vector3<f64>) {
        if !self.enabled {
            return (Vector3::zeros(), Vector3::zeros());
        }
        let (h, v) = self.gnss.sigmas_m();
        // The horizontal figure is a 2D RMS: each axis carries half its variance.
        let total = Vector3::new(
            h / std::f64::consts::SQRT_2,
            h / std::f64::consts::SQRT_2,
            v,
        );
        let w = self.white_share;
        (total * (1.0 - w * w).sqrt(), total * w)
    }

    /// Flies `planned` (GNSS targets, in flight order) at `speed_m_s` with
    /// `hover_s` at each waypoint; `seed` draws this flight's errors.
    pub fn fly(
        &self,
        planned: &[Point3<f64>],
        speed_m_s: f64,
        hover_s: f64,
        seed: u64,
    ) -> FlownPath {
        let (bias_sigma, white_sigma) = self.sigmas();
        let track = if self.enabled { self.tracking_m } else { 0.0 };
        let s = mix64(seed ^ 0x676e_7373);
        let draw = |kind: i64, i: usize| {
            Vector3::new(
                gaussian(s, kind, i as i64, 0),
                gaussian(s, kind, i as i64, 1),
                gaussian(s, kind, i as i64, 2),
            )
        };
        let mut bias = draw(0, 0).component_mul(&bias_sigma);
        let mut out = FlownPath {
            truth: Vec::with_capacity(planned.len()),
            tagged: Vec::with_capacity(planned.len()),
        };
        for (i, p) in planned.iter().enumerate() {
            if i > 0 {
                let dt = (p - planned[i - 1]).norm() / speed_m_s.max(1e-6) + hover_s;
                let phi = (-dt / self.time_constant_s).exp();
                let step = draw(1, i).component_mul(&bias_sigma);
                bias = bias * phi + step * (1.0 - phi * phi).sqrt();
            }
            let tracking = draw(2, i) * track;
            let white = draw(3, i).component_mul(&white_sigma);
            out.truth.push(p + tracking - bias);
            out.tagged.push(p + tracking + white);
        }
        out
    }
}

/// `cam` with its centre moved to `center` (attitude kept: heading and
/// gimbal come from the compass and the IMU, not from GNSS).
pub fn moved_to(cam: &Camera, center: &Point3<f64>) -> Camera {
    let mut iso = cam.world_from_cam;
    iso.translation = Translation3::from(center.coords);
    Camera::new(cam.intrinsics, iso)
}

/// `cam` in the frame `sim` maps into (centre and attitude).
pub fn camera_through(sim: &Sim3, cam: &Camera) -> Camera {
    let c = sim.apply(&cam.center());
    let r = sim.rotation() * cam.world_from_cam.rotation;
    Camera::new(
        cam.intrinsics,
        Isometry3::from_parts(Translation3::from(c.coords), r),
    )
}

/// `mesh` in the frame `sim` maps into.
pub fn mesh_through(sim: &Sim3, mesh: &Mesh) -> Mesh {
    let mut m = mesh.clone();
    for v in &mut m.vertices {
        *v = sim.apply(v);
    }
    m
}

/// The box holding `aabb`'s corners in the frame `sim` maps into: a region
/// drawn on the georeferenced model, as a user draws it.
pub fn aabb_through(sim: &Sim3, aabb: &Aabb) -> Aabb {
    let (a, b) = (aabb.min, aabb.max);
    let mut out = Aabb::empty();
    for i in 0..8 {
        out.grow(&sim.apply(&Point3::new(
            if i & 1 == 0 { a.x } else { b.x },
            if i & 2 == 0 { a.y } else { b.y },
            if i & 4 == 0 { a.z } else { b.z },
        )));
    }
    out
}

/// The identity similarity (no georeference error).
pub fn identity_sim3() -> Sim3 {
    Sim3 {
        scale: 1.0,
        rotation_wxyz: [1.0, 0.0, 0.0, 0.0],
        translation: [0.0; 3],
    }
}

/// The georeference `vpctl colmap align --positions` would give the model
/// of the images `truth` (true cameras) tagged with `tagged` positions:
/// the similarity from the true world into the model's frame, with its
/// residuals. `seed` seeds the RANSAC. Fewer than 3 images, or images on
/// a line, fix no rotation (`colmap align` refuses them): the model is
/// then only shifted by the mean of the tags' offsets, as a user would
/// place it by hand.
pub fn georeference(truth: &[Camera], tagged: &[Point3<f64>], seed: u64) -> Result<Alignment> {
    let mut rec = Reconstruction::default();
    let mut positions = Vec::with_capacity(truth.len());
    for (i, (cam, p)) in truth.iter().zip(tagged).enumerate() {
        let name = format!("img_{i:04}.png");
        rec.add_pinhole_image(&name, cam);
        positions.push((name, *p));
    }
    let params = AlignParams {
        seed,
        ..AlignParams::default()
    };
    match align_to_positions(
        &rec,
        &positions,
        &params,
        Path::new("the simulated GNSS positions"),
    ) {
        Ok(al) => Ok(al),
        Err(_) if !truth.is_empty() => Ok(shift_only(truth, &positions)),
        Err(e) => Err(e.into()),
    }
}

/// The alignment that only shifts the model by the mean offset of the tags.
fn shift_only(truth: &[Camera], positions: &[(String, Point3<f64>)]) -> Alignment {
    let n = truth.len() as f64;
    let mean = truth
        .iter()
        .zip(positions)
        .fold(Vector3::zeros(), |acc, (c, (_, p))| acc + (p - c.center()))
        / n;
    let sim3 = Sim3 {
        translation: mean.into(),
        ..identity_sim3()
    };
    let residuals: Vec<PositionResidual> = truth
        .iter()
        .zip(positions)
        .map(|(c, (name, p))| PositionResidual {
            name: name.clone(),
            residual_m: (sim3.apply(&c.center()) - p).norm(),
            inlier: true,
        })
        .collect();
    let rms_m = (residuals
        .iter()
        .map(|r| r.residual_m * r.residual_m)
        .sum::<f64>()
        / n)
        .sqrt();
    Alignment {
        sim3,
        residuals,
        rms_m,
        unmatched: Vec::new(),
        strip: None,
    }
}

#[cfg(test)]
#[path = "gnss_tests.rs"]
mod tests;
