//! Reconstructing flown images: vp-mvs on the rendered images (the
//! default), or the virtual MVS with its triplet gate as a fast stand-in for
//! unit tests (`mvs = "virtual"`).
//!
//! With vp-mvs nothing about the outcome is planted and the matcher gets
//! only what a user has: the images are rendered from the true poses
//! (texture, sun, shadows, sensor noise), PatchMatch matches them with SfM's
//! estimates of the poses (the same ones labelgen and the planner get, with
//! `sfm.*` noise), and each view's depth range is COLMAP's rule
//! ([`crate::sfm::features::colmap_depth_range`]: 1st to 99th percentile of the
//! depths of the sparse points the view observes, times 0.75 and 1.25) over
//! the simulated SfM of the image set ([`crate::sfm::SparseCandidates`]:
//! surface points where FAST fires on the renders, seen by at least
//! `sfm.min_views` of the set's images). A view without sparse points is
//! not matched. Only the measurement looks at the truth: each depth, a
//! point along the SfM camera's ray, is expressed in the true camera and
//! compared with the renderer's depth.

use nalgebra::Point2;
use vp_mvs::{MvsParams, View};
use vp_scene::colmap::DepthMap;
use vp_scene::raster::RgbImage;
use vp_scene::surface::SurfaceSample;
use vp_scene::{Aabb, Camera};

use super::curves::CurveAccumulator;
use super::depth_maps::{depth_in_truth, depth_of, zero_depth};
use super::gate::gate_stats;
pub use super::gate::GateStats;
use super::renders::Renders;
pub use super::triplet_outcomes::OutputStats;
use super::triplet_outcomes::{in_region, reference_rock_errors, rock_errors, DepthErrorHistogram};
use crate::config::{CampaignConfig, MvsKind};
use crate::error::{Result, SimError};
use crate::sfm::sparse_depth_ranges;
use crate::sfm::FeatureMask;
use crate::virtual_mvs::{level_camera, triplet_truth, PixelStatus, PixelTruth, VirtualMvs};
use crate::world::Scene;

/// One reconstructed image set: a flown triplet, or one reference image of
/// the Grid with the sources it was matched against.
#[derive(Debug, Clone)]
pub struct Flown {
    /// Identities of the images (distinct images have distinct ids).
    pub ids: Vec<u64>,
    /// The true cameras, at full resolution.
    pub cams: Vec<Camera>,
    /// SfM's estimates of `cams`: the cameras the depth maps belong to.
    pub sfm: Vec<Camera>,
    /// One depth map per camera at full resolution (0 = no depth), along
    /// the SfM camera's axis; a camera used only as a source has an empty
    /// (0 x 0) map.
    pub depth: Vec<DepthMap>,
    /// vp-mvs's fused points started by this set's reference pixels, as
    /// mesher samples seen from the cameras fused into them (empty with
    /// the virtual MVS, which has no point cloud).
    pub fused: Vec<SurfaceSample>,
    /// What came out.
    pub stats: OutputStats,
    /// Whether the set counts as having produced 3D output (see
    /// [`Matcher::succeeded`]).
    pub success: bool,
    /// The gate's view (virtual MVS only).
    pub gate: Option<GateStats>,
    /// The depth errors of its reference images' rock pixels in the ROI.
    pub rock_errors: DepthErrorHistogram,
}

/// A triplet reconstructed at one pyramid level, with the renderer's truth.
pub struct TripletRun {
    /// Depth maps at the level's resolution (all zero when nothing came
    /// out), along the SfM cameras' axes: what a user gets.
    pub depth: [DepthMap; 3],
    /// The same depths expressed in the true cameras (the point on the SfM
    /// ray, its depth in the true camera): what the truth is compared with.
    pub depth_in_truth: [DepthMap; 3],
    /// The simulated SfM of the triplet: (candidate index, noisy position,
    /// observing views) of every sparse point two of its images observe.
    pub sparse: Vec<(usize, nalgebra::Point3<f64>, Vec<usize>)>,
    /// Truth per pixel at the level (geometry; the virtual MVS adds its decision).
    pub truth: [Vec<PixelTruth>; 3],
    /// The images at the level's resolution (what the forest learns from).
    pub images: [RgbImage; 3],
    /// vp-mvs's fused points (see [`Flown::fused`]).
    pub fused: Vec<SurfaceSample>,
    /// Counted over every pixel with a surface, or those in `region`.
    pub stats: OutputStats,
    /// The gate's view (virtual MVS only).
    pub gate: Option<GateStats>,
    /// The depth errors of its rock pixels in `region` (see [`rock_errors`]).
    pub rock_errors: DepthErrorHistogram,
}

/// The campaign's MVS, as configured.
pub struct Matcher<'a> {
    cfg: &'a CampaignConfig,
    virtual_mvs: Option<VirtualMvs>,
}

/// Halves an image `level - 1` times with a triangle filter (level 1: as is),
/// the pyramid COLMAP's `max_image_size` and labelgen's levels assume.
pub fn image_at_level(img: &RgbImage, level: u8) -> RgbImage {
    if level <= 1 {
        return img.clone();
    }
    let s = 1u32 << (level - 1);
    image::imageops::resize(
        img,
        (img.width() / s).max(1),
        (img.height() / s).max(1),
        image::imageops::FilterType::Triangle,
    )
}

impl<'a> Matcher<'a> {
    /// The matcher of `cfg` (`cfg.mvs`).
    pub fn new(cfg: &'a CampaignConfig) -> Result<Self> {
        let virtual_mvs = match cfg.mvs {
            MvsKind::Virtual => Some(VirtualMvs::new(cfg.profile.clone())?),
            MvsKind::Patchmatch | MvsKind::Sgm => None,
        };
        Ok(Matcher { cfg, virtual_mvs })
    }

    /// Whether a reconstruction with these statistics produced 3D output
    /// ("succeeded to produce any 3D output", paper Sec. 4): at least
    /// `eval.min_output_share` of its counted pixels measured within the
    /// tolerance. A few stray points do not make a reconstruction.
    pub fn succeeded(&self, s: &OutputStats) -> bool {
        s.measured > 0 && s.measured_share() >= self.cfg.eval.min_output_share
    }

    fn params(&self, seed: u64) -> MvsParams {
        let mut p = MvsParams {
            seed,
            ..self.cfg.patchmatch.clone()
        };
        if self.cfg.mvs == MvsKind::Sgm {
            p.algorithm = vp_mvs::Algorithm::Sgm;
        }
        p
    }

    /// Reconstructs the triplet `cams` (true cameras, full resolution: the
    /// renders and the truth) with SfM's estimates `sfm` of them (the
    /// matching) at pyramid `level`; `region` limits the pixels the
    /// statistics count. Adds every pixel the three cameras see to
    /// `curves`' measured side. The full-resolution shots come from
    /// `renders` (kept there for whoever asks for them next).
    pub fn triplet(
        &self,
        renders: &mut Renders<'_>,
        (cams, sfm): ([&Camera; 3], [&Camera; 3]),
        level: u8,
        region: Option<&Aabb>,
        seed: u64,
        curves: &mut CurveAccumulator,
    ) -> Result<TripletRun> {
        let level_cams = [
            level_camera(cams[0], level)?,
            level_camera(cams[1], level)?,
            level_camera(cams[2], level)?,
        ];
        let level_sfm = [
            level_camera(sfm[0], level)?,
            level_camera(sfm[1], level)?,
            level_camera(sfm[2], level)?,
        ];
        let scene = *renders.scene();
        let shots = renders.shots(&cams)?;
        let images: [RgbImage; 3] = [0, 1, 2].map(|v| image_at_level(&shots[v].image.rgb, level));
        // SfM of the triplet's full-resolution images.
        let observed: Vec<(&Camera, &FeatureMask)> = cams
            .into_iter()
            .zip(shots.iter().map(|s| &s.features))
            .collect();
        let sparse = scene.candidates.tracks(
            scene.caster,
            &observed,
            self.cfg.sfm.min_views,
            self.cfg.sfm.point_noise_m,
        );
        let (depth, depth_in_truth, truth, gate, fused) = if let Some(mvs) = &self.virtual_mvs {
            let (depth, truth, gate) =
                self.virtual_triplet(mvs, &scene, cams, &level_cams, level, seed)?;
            (depth.clone(), depth, truth, gate, Vec::new())
        } else {
            let ranges = sparse_depth_ranges(&sparse, &sfm);
            let (depth, truth, fused) = self.patchmatch_triplet(
                &scene,
                cams,
                (&level_cams, &level_sfm),
                &images,
                &ranges,
                (level, seed),
            )?;
            let in_truth =
                [0, 1, 2].map(|v| depth_in_truth(&depth[v], &level_sfm[v], &level_cams[v]));
            (depth, in_truth, truth, None, fused)
        };
        let stats = self.measure(&level_cams, &depth_in_truth, &truth, region);
        let rock_errors = rock_errors(&level_cams, &depth_in_truth, &truth, region);
        self.add_measured(&depth_in_truth, &truth, curves);
        Ok(TripletRun {
            depth,
            depth_in_truth,
            sparse,
            truth,
            images,
            fused,
            stats,
            gate,
            rock_errors,
        })
    }

    /// The virtual MVS on a triplet, its gate applied.
    fn virtual_triplet(
        &self,
        mvs: &VirtualMvs,
        scene: &Scene<'_>,
        cams: [&Camera; 3],
        level_cams: &[Camera; 3],
        level: u8,
        seed: u64,
    ) -> Result<Triplet> {
        let views = mvs.reconstruct_with_truth(scene.mesh, scene.caster, cams, level, seed)?;
        let gate = gate_stats(
            &views.each_ref().map(|v| v.truth.as_slice()),
            &self.cfg.gate,
        );
        let pass = self.cfg.gate.passes(&gate);
        let [a, b, c] = views;
        let depth = if pass {
            [a.depth, b.depth, c.depth]
        } else {
            level_cams.each_ref().map(zero_depth)
        };
        Ok((depth, [a.truth, b.truth, c.truth], Some(gate)))
    }

    /// vp-mvs on a triplet's images (each view against the other two) with
    /// the SfM cameras and depth ranges, and the renderer's truth at the
    /// level (true cameras).
    fn patchmatch_triplet(
        &self,
        scene: &Scene<'_>,
        cams: [&Camera; 3],
        (level_cams, level_sfm): (&[Camera; 3], &[Camera; 3]),
        images: &[RgbImage; 3],
        ranges: &[Option<(f64, f64)>],
        (level, seed): (u8, u64),
    ) -> Result<PatchmatchTriplet> {
        let truth = triplet_truth(
            scene.mesh,
            scene.caster,
            cams,
            level,
            self.cfg.training.labels.sigma_px,
        )?;
        let mut views = Vec::with_capacity(3);
        for (v, cam) in level_sfm.iter().enumerate() {
            let Some(range) = ranges[v] else {
                // SfM has no point in this view: COLMAP has no depth range
                // for it, and nothing is matched.
                return Ok((level_cams.each_ref().map(zero_depth), truth, Vec::new()));
            };
            views.push(View::new(&format!("v{v}"), *cam, images[v].clone(), range)?);
        }
        let sources = vec![vec![1, 2], vec![0, 2], vec![0, 1]];
        let out = vp_mvs::reconstruct(&views, &sources, &self.params(seed), &mut |_| {})?;
        let depth = [0, 1, 2].map(|v| depth_of(out.geometric[v].as_ref(), &level_sfm[v]));
        Ok((depth, truth, fused_samples(&out.fused, level_sfm)))
    }

    /// Counts the pixels of `depth` against the truth (see [`OutputStats`]).
    fn measure(
        &self,
        cams: &[Camera; 3],
        depth: &[DepthMap; 3],
        truth: &[Vec<PixelTruth>; 3],
        region: Option<&Aabb>,
    ) -> OutputStats {
        let tol = self.cfg.eval.depth_tolerance_m as f32;
        let mut s = OutputStats::default();
        for v in 0..3 {
            for (i, t) in truth[v].iter().enumerate() {
                if t.status == PixelStatus::NoSurface
                    || !in_region(&cams[v], i, t.true_depth, region)
                {
                    continue;
                }
                s.pixels += 1;
                let z = depth[v].data[i];
                if z > 0.0 {
                    s.output += 1;
                    s.measured += usize::from((z - t.true_depth).abs() <= tol);
                }
            }
        }
        s
    }

    /// Adds each pixel all three cameras see (material, angle, and whether
    /// its depth is within `k_sigma` sigma of the truth) to the measured curves.
    fn add_measured(
        &self,
        depth: &[DepthMap; 3],
        truth: &[Vec<PixelTruth>; 3],
        curves: &mut CurveAccumulator,
    ) {
        let k = self.cfg.training.labels.k_sigma as f32;
        for v in 0..3 {
            for (t, &z) in truth[v].iter().zip(&depth[v].data) {
                let Some(m) = t.material else {
                    continue;
                };
                if matches!(t.status, PixelStatus::NoSurface | PixelStatus::NotVisible) {
                    continue;
                }
                curves.add_measured(m, t.angle_deg, truly_positive(t, z, k));
            }
        }
    }

    /// Reconstructs `cams` (true cameras; `sfm` SfM's estimates of them)
    /// as the paper's Grid: every image a reference against its best
    /// overlapping neighbours (`patchmatch.max_sources`), one [`Flown`] per
    /// reference. An image SfM has no sparse point in is no reference.
    /// The shots come from `renders`. vp-mvs only.
    pub fn image_set(
        &self,
        renders: &mut Renders<'_>,
        (cams, sfm): (&[Camera], &[Camera]),
        ids: &[u64],
        region: &Aabb,
        seed: u64,
    ) -> Result<Vec<Flown>> {
        if self.virtual_mvs.is_some() {
            return Err(SimError::Campaign(
                "the virtual MVS reconstructs triplets only".into(),
            ));
        }
        if sfm.len() != cams.len() || ids.len() != cams.len() {
            return Err(SimError::Campaign(format!(
                "{} cameras, {} SfM estimates, {} ids",
                cams.len(),
                sfm.len(),
                ids.len()
            )));
        }
        let scene = *renders.scene();
        let cam_refs: Vec<&Camera> = cams.iter().collect();
        let shots = renders.shots(&cam_refs)?;
        let observed: Vec<(&Camera, &FeatureMask)> =
            cams.iter().zip(shots.iter().map(|s| &s.features)).collect();
        let sparse = scene.candidates.tracks(
            scene.caster,
            &observed,
            self.cfg.sfm.min_views,
            self.cfg.sfm.point_noise_m,
        );
        let sfm_refs: Vec<&Camera> = sfm.iter().collect();
        let sparse_ranges = sparse_depth_ranges(&sparse, &sfm_refs);
        // A view without sparse points takes part in no match; its range
        // only keeps the frustum test of its neighbours well defined.
        let ranges: Vec<(f64, f64)> = sparse_ranges
            .iter()
            .map(|r| r.unwrap_or((1.0, 2.0)))
            .collect();
        let mut views = Vec::with_capacity(cams.len());
        for (i, (cam, shot)) in sfm.iter().zip(&shots).enumerate() {
            let rgb = shot.image.rgb.clone();
            views.push(View::new(&format!("g{i}"), *cam, rgb, ranges[i])?);
        }
        let params = self.params(seed);
        let mut sources = vp_mvs::frustum_sources(sfm, &ranges, &params);
        for (i, src) in sources.iter_mut().enumerate() {
            src.retain(|&s| sparse_ranges[s].is_some());
            if sparse_ranges[i].is_none() {
                src.clear();
            }
        }
        if sources.iter().all(Vec::is_empty) {
            return Ok(Vec::new());
        }
        let out = vp_mvs::reconstruct(&views, &sources, &params, &mut |_| {})?;
        // Each fused point goes to the set of the reference that started it.
        let mut fused_by_reference: Vec<Vec<SurfaceSample>> = vec![Vec::new(); cams.len()];
        for (p, sample) in out.fused.iter().zip(fused_samples(&out.fused, sfm)) {
            fused_by_reference[p.views[0]].push(sample);
        }
        let tol = self.cfg.eval.depth_tolerance_m as f32;
        let mut flown = Vec::with_capacity(cams.len());
        for (r, src) in sources.iter().enumerate() {
            if src.is_empty() {
                continue;
            }
            let depth = depth_of(out.geometric[r].as_ref(), &sfm[r]);
            let in_truth = depth_in_truth(&depth, &sfm[r], &cams[r]);
            let truth = &shots[r].image;
            let stats = grid_stats(&in_truth, &truth.depth, &cams[r], region, tol);
            let mut group_cams = vec![cams[r]];
            let mut group_sfm = vec![sfm[r]];
            let mut group_ids = vec![ids[r]];
            let mut group_depth = vec![depth];
            for &s in src.iter().take(self.cfg.patchmatch.top_k_sources) {
                group_cams.push(cams[s]);
                group_sfm.push(sfm[s]);
                group_ids.push(ids[s]);
                group_depth.push(DepthMap {
                    width: 0,
                    height: 0,
                    data: Vec::new(),
                });
            }
            let sigma_px = self.cfg.training.labels.sigma_px;
            let rock =
                reference_rock_errors(&scene, truth, &in_truth, &group_cams, region, sigma_px);
            flown.push(Flown {
                ids: group_ids,
                cams: group_cams,
                sfm: group_sfm,
                depth: group_depth,
                fused: std::mem::take(&mut fused_by_reference[r]),
                success: self.succeeded(&stats),
                stats,
                gate: None,
                rock_errors: rock,
            });
        }
        Ok(flown)
    }

    /// Reconstructs one flown triplet at full resolution over the ROI
    /// `region`: `cams` true, `sfm` SfM's estimates of them; the shots
    /// come from `renders`.
    pub fn fly_triplet(
        &self,
        renders: &mut Renders<'_>,
        (cams, sfm): ([Camera; 3], [Camera; 3]),
        ids: [u64; 3],
        region: &Aabb,
        seed: u64,
        curves: &mut CurveAccumulator,
    ) -> Result<Flown> {
        let run = self.triplet(
            renders,
            ([&cams[0], &cams[1], &cams[2]], [&sfm[0], &sfm[1], &sfm[2]]),
            1,
            Some(region),
            seed,
            curves,
        )?;
        Ok(Flown {
            ids: ids.to_vec(),
            cams: cams.to_vec(),
            sfm: sfm.to_vec(),
            success: self.succeeded(&run.stats),
            depth: run.depth.to_vec(),
            fused: run.fused,
            stats: run.stats,
            gate: run.gate,
            rock_errors: run.rock_errors,
        })
    }
}

/// What came out of one Grid reference: its depths `in_truth` (expressed in
/// the true camera `cam`) against the renderer's `truth`, over the pixels
/// whose true surface lies in `region`.
fn grid_stats(
    in_truth: &DepthMap,
    truth: &DepthMap,
    cam: &Camera,
    region: &Aabb,
    tol: f32,
) -> OutputStats {
    let w = cam.intrinsics.width as usize;
    let mut stats = OutputStats::default();
    for (i, (&z, &t)) in in_truth.data.iter().zip(&truth.data).enumerate() {
        let px = Point2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
        if t <= 0.0 || !region.contains(&cam.unproject(&px, f64::from(t))) {
            continue;
        }
        stats.pixels += 1;
        if z > 0.0 {
            stats.output += 1;
            stats.measured += usize::from((z - t).abs() <= tol);
        }
    }
    stats
}

/// vp-mvs's fused points as mesher samples: position, normal, and the
/// centres of the views (indices into `cams`) fused into each.
fn fused_samples(fused: &[vp_mvs::FusedPoint], cams: &[Camera]) -> Vec<SurfaceSample> {
    fused
        .iter()
        .map(|p| SurfaceSample {
            position: p.position,
            normal: Some(p.normal),
            seen_from: p.views.iter().map(|&v| cams[v].center()).collect(),
        })
        .collect()
}

/// A triplet's depth maps, truth, and vp-mvs's fused points.
type PatchmatchTriplet = ([DepthMap; 3], [Vec<PixelTruth>; 3], Vec<SurfaceSample>);

/// A triplet's depth maps, truth, and the gate's view (virtual only).
type Triplet = ([DepthMap; 3], [Vec<PixelTruth>; 3], Option<GateStats>);

/// Whether vp-mvs's depth `z` at a pixel with truth `t` is within the
/// uncertainty bound (`k` sigma of the triplet's first-order depth
/// uncertainty) of the true depth: what a correct positive label claims.
pub fn truly_positive(t: &PixelTruth, z: f32, k: f32) -> bool {
    z > 0.0 && (z - t.true_depth).abs() <= k * t.sigma_depth.max(1e-6)
}

#[cfg(test)]
#[path = "reconstruct_tests.rs"]
mod tests;
