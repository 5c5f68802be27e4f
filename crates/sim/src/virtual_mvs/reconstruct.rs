//! The virtual MVS: depth maps of a camera triplet as a dense MVS algorithm
//! would produce them, with known truth per pixel.

use nalgebra::{Point2, Point3, Vector3};
use rayon::prelude::*;
use vp_scene::colmap::DepthMap;
use vp_scene::raycast::{RayCaster, FACE_VISIBILITY_EPSILON};
use vp_scene::{Camera, Material, Mesh};

use super::profile::MvsProfile;
use crate::error::{Result, SimError};
use crate::noise::{gaussian, hash3, uniform_field, unit};
use vp_scene::hash::mix64;
use vp_scene::triangulation::{point_covariance, sigma_along, triangulation_angle_deg};

/// Deepest pyramid level accepted (level L has 2^-(L-1) of the resolution).
pub const MAX_LEVEL: u8 = 6;
/// Pixels per side of the grid that estimates a triplet's typical ground
/// sampling distance (sets the failure blob size in metres).
const GSD_PROBE: u32 = 24;
/// Relative depth error of an outlier: uniform in [MIN, MAX), either sign.
const OUTLIER_ERROR: (f64, f64) = (0.1, 0.4);

/// Stream constants of the per-pixel randomness.
const STREAM_FIELD: u64 = 0x0066_6965_6c64;
const STREAM_NOISE: u64 = 0x006e_6f69_7365;
const STREAM_OUTLIER: u64 = 0x006f_7574_6c69_6572;

/// The camera of pyramid level `level` (1 = full resolution): intrinsics
/// scaled by 2^-(level-1), same pose.
pub fn level_camera(camera: &Camera, level: u8) -> Result<Camera> {
    if !(1..=MAX_LEVEL).contains(&level) {
        return Err(SimError::InvalidArgument(format!(
            "pyramid level {level} is outside 1..={MAX_LEVEL}"
        )));
    }
    let s = 0.5f64.powi(i32::from(level) - 1);
    Ok(Camera::new(
        camera.intrinsics.scaled(s),
        camera.world_from_cam,
    ))
}

/// What happened at one pixel of a virtual reconstruction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PixelStatus {
    /// The pixel ray hits no surface.
    NoSurface,
    /// The surface point is outside the frame of, or occluded in, another
    /// camera of the triplet (or the triplet cannot triangulate it): no MVS
    /// can reconstruct it.
    NotVisible,
    /// All three cameras see the point; no MVS decision was made (the
    /// geometry-only truth of [`triplet_truth`]).
    Visible,
    /// Reconstructable, but the MVS failed here (a hole).
    Failed,
    /// Reconstructed with a depth within the predicted noise.
    Reconstructed,
    /// Reconstructed with a wrong depth.
    Outlier,
}

/// Ground truth of one pixel of a virtual reconstruction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelTruth {
    /// Outcome.
    pub status: PixelStatus,
    /// Material of the surface under the pixel (None without surface).
    pub material: Option<Material>,
    /// True depth along the optical axis (0 without surface).
    pub true_depth: f32,
    /// Depth written to the depth map (0 for no output).
    pub depth: f32,
    /// Triangulation angle at the surface point, degrees (0 unless visible in all three).
    pub angle_deg: f32,
    /// Success probability from the profile (0 unless visible in all three).
    pub probability: f32,
    /// Predicted standard deviation of the depth, metres (0 unless visible in all three).
    pub sigma_depth: f32,
}

impl PixelTruth {
    fn empty(status: PixelStatus) -> Self {
        PixelTruth {
            status,
            material: None,
            true_depth: 0.0,
            depth: 0.0,
            angle_deg: 0.0,
            probability: 0.0,
            sigma_depth: 0.0,
        }
    }
}

/// One image's result with its truth, from [`VirtualMvs::reconstruct_with_truth`].
#[derive(Debug, Clone)]
pub struct MvsView {
    /// The depth map, as [`VirtualMvs::reconstruct`] returns it.
    pub depth: DepthMap,
    /// Truth per pixel, row-major.
    pub truth: Vec<PixelTruth>,
}

/// A virtual dense MVS algorithm with the behaviour of an [`MvsProfile`].
#[derive(Debug, Clone)]
pub struct VirtualMvs {
    profile: MvsProfile,
}

/// Everything a pixel evaluation needs, shared by all pixels of one run.
struct Run<'a> {
    /// The virtual MVS's curves; `None` for the geometry-only truth.
    profile: Option<&'a MvsProfile>,
    sigma_px: f64,
    mesh: &'a Mesh,
    caster: &'a RayCaster,
    cams: [Camera; 3],
    seed: u64,
    blob_wavelength: f64,
}

impl VirtualMvs {
    /// A virtual MVS behaving as `profile` says; fails when the profile is invalid.
    pub fn new(profile: MvsProfile) -> Result<Self> {
        profile.validate()?;
        Ok(VirtualMvs { profile })
    }

    /// The profile (the truth curves).
    pub fn profile(&self) -> &MvsProfile {
        &self.profile
    }

    /// Reconstructs `triplet` at pyramid `level` (1, 2, 3, ...: intrinsics
    /// scaled by 2^-(level-1)) and returns one depth map per image, at that
    /// level's resolution, depths along each camera's optical axis (0 = none).
    ///
    /// A pixel can succeed only when its surface point is visible in all
    /// three cameras. It succeeds with the profile's probability for its
    /// material, its own triangulation angle and ground sampling distance;
    /// the decision thresholds a smooth world-space random field, so failures
    /// form blobs of about `blob_size_px` pixels that all three images agree
    /// on. A success carries Gaussian depth noise with the first-order sigma
    /// of the point along the viewing ray (pixel noise `sigma_px` in all
    /// three images); a share `outlier_share` of successes gets a depth
    /// 10-40 % off instead. Same inputs and seed, same bytes.
    ///
    /// The failure field depends on `seed` and `level` only: give each
    /// triplet its own seed, or two triplets fail on the same surface
    /// patches (a real MVS run on independent image sets would not).
    ///
    /// # Performance
    /// One closest-hit ray and two occlusion rays per pixel, parallel over rows.
    pub fn reconstruct(
        &self,
        mesh: &Mesh,
        caster: &RayCaster,
        triplet: [&Camera; 3],
        level: u8,
        seed: u64,
    ) -> Result<[DepthMap; 3]> {
        let run = prepare(Some(&self.profile), mesh, caster, triplet, level, seed)?;
        Ok([0, 1, 2].map(|v| run.view(v, false).depth))
    }

    /// [`VirtualMvs::reconstruct`] with the truth of every pixel (status,
    /// material, true depth, angle, probability, predicted sigma): the same
    /// depth maps, for evaluation and tests.
    pub fn reconstruct_with_truth(
        &self,
        mesh: &Mesh,
        caster: &RayCaster,
        triplet: [&Camera; 3],
        level: u8,
        seed: u64,
    ) -> Result<[MvsView; 3]> {
        let run = prepare(Some(&self.profile), mesh, caster, triplet, level, seed)?;
        Ok([0, 1, 2].map(|v| run.view(v, true)))
    }
}

/// The geometry of a triplet at pyramid `level` as the renderer knows it,
/// per pixel of each image: surface, material, true depth and, where all
/// three cameras see the point, its triangulation angle and the predicted
/// depth sigma for `sigma_px` pixels of image noise (status
/// [`PixelStatus::Visible`]). What a real matcher's output is measured
/// against; `depth` and `probability` stay 0.
pub fn triplet_truth(
    mesh: &Mesh,
    caster: &RayCaster,
    triplet: [&Camera; 3],
    level: u8,
    sigma_px: f64,
) -> Result<[Vec<PixelTruth>; 3]> {
    let mut run = prepare(None, mesh, caster, triplet, level, 0)?;
    run.sigma_px = sigma_px;
    Ok([0, 1, 2].map(|v| run.view(v, true).truth))
}

fn prepare<'a>(
    profile: Option<&'a MvsProfile>,
    mesh: &'a Mesh,
    caster: &'a RayCaster,
    triplet: [&Camera; 3],
    level: u8,
    seed: u64,
) -> Result<Run<'a>> {
    if caster.n_faces() != mesh.n_faces() {
        return Err(SimError::InvalidArgument(format!(
            "ray caster has {} faces but the mesh has {}: build the caster from this mesh",
            caster.n_faces(),
            mesh.n_faces()
        )));
    }
    let cams = [
        level_camera(triplet[0], level)?,
        level_camera(triplet[1], level)?,
        level_camera(triplet[2], level)?,
    ];
    // The blob size matters only to the virtual decision: skip its probe rays otherwise.
    let blob_wavelength = match profile {
        Some(p) => 2.0 * p.blob_size_px * typical_gsd(caster, &cams),
        None => 1.0,
    };
    Ok(Run {
        profile,
        sigma_px: profile.map_or(1.0, |p| p.sigma_px),
        mesh,
        caster,
        cams,
        seed: mix64(seed ^ mix64(u64::from(level))),
        blob_wavelength,
    })
}

/// Median distance over focal length of a coarse grid of hits of the three
/// cameras: metres per pixel at the triplet's typical surface. 1 m over the
/// focal length when no probe ray hits.
fn typical_gsd(caster: &RayCaster, cams: &[Camera; 3]) -> f64 {
    let mut gsds: Vec<f64> = Vec::new();
    for cam in cams {
        let k = cam.intrinsics;
        for j in 0..GSD_PROBE {
            for i in 0..GSD_PROBE {
                let px = Point2::new(
                    (f64::from(i) + 0.5) / f64::from(GSD_PROBE) * f64::from(k.width),
                    (f64::from(j) + 0.5) / f64::from(GSD_PROBE) * f64::from(k.height),
                );
                let (o, d) = cam.ray(&px);
                if let Some(hit) = caster.closest_hit(&o, &d, f64::INFINITY) {
                    gsds.push(hit.t / k.focal());
                }
            }
        }
    }
    if gsds.is_empty() {
        return 1.0 / cams[0].intrinsics.focal();
    }
    gsds.sort_by(f64::total_cmp);
    gsds[gsds.len() / 2]
}

impl Run<'_> {
    fn view(&self, v: usize, with_truth: bool) -> MvsView {
        let k = self.cams[v].intrinsics;
        let (w, h) = (k.width as usize, k.height as usize);
        let rows: Vec<(Vec<f32>, Vec<PixelTruth>)> = (0..h)
            .into_par_iter()
            .map(|y| {
                let mut depth = Vec::with_capacity(w);
                let mut truth = Vec::with_capacity(if with_truth { w } else { 0 });
                for x in 0..w {
                    let t = self.pixel(v, x as u32, y as u32);
                    depth.push(t.depth);
                    if with_truth {
                        truth.push(t);
                    }
                }
                (depth, truth)
            })
            .collect();
        let mut data = Vec::with_capacity(w * h);
        let mut truth = Vec::with_capacity(if with_truth { w * h } else { 0 });
        for (d, t) in rows {
            data.extend(d);
            truth.extend(t);
        }
        MvsView {
            depth: DepthMap {
                width: k.width,
                height: k.height,
                data,
            },
            truth,
        }
    }

    fn pixel(&self, v: usize, x: u32, y: u32) -> PixelTruth {
        let cam = &self.cams[v];
        let (o, d) = cam.ray(&Point2::new(f64::from(x) + 0.5, f64::from(y) + 0.5));
        let Some(hit) = self.caster.closest_hit(&o, &d, f64::INFINITY) else {
            return PixelTruth::empty(PixelStatus::NoSurface);
        };
        let p = hit.point;
        let material = self
            .mesh
            .material(hit.face as usize)
            .unwrap_or(Material::Ground);
        let true_depth = hit.t * d.dot(&cam.axis());
        let mut truth = PixelTruth {
            material: Some(material),
            true_depth: true_depth as f32,
            ..PixelTruth::empty(PixelStatus::NotVisible)
        };
        let mut n = self.mesh.face_normal(hit.face as usize);
        if n.dot(&d) > 0.0 {
            n = -n;
        }
        if !self.visible_in_others(v, &p, &n) {
            return truth;
        }
        let refs = [&self.cams[0], &self.cams[1], &self.cams[2]];
        let Some(cov) = point_covariance(refs, &p, self.sigma_px) else {
            return truth;
        };
        let centres = self.cams.map(|c| c.center());
        let angle = triangulation_angle_deg(&p, &centres);
        let sigma_depth = sigma_along(&cov, &d) * d.dot(&cam.axis());
        truth.angle_deg = angle as f32;
        truth.sigma_depth = sigma_depth as f32;
        let Some(profile) = self.profile else {
            truth.status = PixelStatus::Visible;
            return truth;
        };
        let gsd = hit.t / cam.intrinsics.focal();
        let prob = profile.success_probability(material, angle, Some(gsd));
        truth.probability = prob as f32;
        let u = uniform_field(
            self.seed ^ STREAM_FIELD,
            [p.x, p.y, p.z],
            self.blob_wavelength,
        );
        if !(u < prob) {
            truth.status = PixelStatus::Failed;
            return truth;
        }
        let (xi, yi, vi) = (i64::from(x), i64::from(y), v as i64);
        let h = hash3(self.seed ^ STREAM_OUTLIER, vi, xi, yi);
        if unit(h) < profile.outlier_share {
            let r = unit(mix64(h ^ 1));
            let mut err = OUTLIER_ERROR.0 + (OUTLIER_ERROR.1 - OUTLIER_ERROR.0) * r;
            if mix64(h ^ 2) & 1 == 1 {
                err = -err;
            }
            truth.status = PixelStatus::Outlier;
            truth.depth = (true_depth * (1.0 + err)) as f32;
            return truth;
        }
        let noisy = true_depth + sigma_depth * gaussian(self.seed ^ STREAM_NOISE, vi, xi, yi);
        truth.status = PixelStatus::Reconstructed;
        // A depth map cannot hold a point behind the camera; such noise is absurd anyway.
        truth.depth = noisy.max(true_depth * 1e-3) as f32;
        truth
    }

    /// Whether `p` (on a surface with normal `n` facing camera `v`) is inside
    /// the frame of, and unoccluded from, the two other cameras.
    fn visible_in_others(&self, v: usize, p: &Point3<f64>, n: &Vector3<f64>) -> bool {
        // Offset towards camera v's side: a camera behind a thin blade or
        // leaf sees the other side, and the segment test rejects it.
        let lifted = p + n * FACE_VISIBILITY_EPSILON;
        (0..3).filter(|&j| j != v).all(|j| {
            let c = &self.cams[j];
            c.project_in_frame(p).is_some() && !self.caster.occluded(&c.center(), &lifted)
        })
    }
}
