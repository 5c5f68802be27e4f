//! Flying images and reconstructing them: vp-mvs on the rendered images (the
//! default), or the virtual MVS with its triplet gate as a fast stand-in for
//! unit tests (`mvs = "virtual"`).
//!
//! With vp-mvs nothing about the outcome is planted: the images are rendered
//! (texture, sun, shadows, sensor noise), PatchMatch matches them with the
//! true poses (bundle adjustment leaves sub-pixel reprojection errors; the
//! centimetre noise of `sfm.*` is a georeferencing error the planner sees,
//! not an epipolar one), and what comes out is measured against the
//! renderer's depth. The depth range of each view is the 2nd to 98th
//! percentile of its true depths grown by `patchmatch.depth_range_margin`,
//! as a user derives it from the sparse points the view sees.

use nalgebra::Point2;
use serde::{Deserialize, Serialize};
use vp_mvs::{MvsParams, View};
use vp_scene::colmap::DepthMap;
use vp_scene::raster::RgbImage;
use vp_scene::raycast::RayCaster;
use vp_scene::surface::SurfaceSample;
use vp_scene::{Aabb, Camera, Material, Mesh};

use super::config::{CampaignConfig, MatchingGate};
use super::curves::CurveAccumulator;
use crate::error::{Result, SimError};
use crate::mvs::{level_camera, triplet_truth, PixelStatus, PixelTruth, VirtualMvs};
use crate::render::{render, RenderParams};

/// Which multi-view stereo reconstructs the flown and training images.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum MvsKind {
    /// vp-mvs (PatchMatch) on the rendered images: the experiment.
    #[default]
    Patchmatch,
    /// The virtual MVS of `profile` and `gate`: success drawn from planted
    /// curves. A fast stand-in for unit tests only.
    Virtual,
}

/// What the gate saw of one triplet (virtual MVS only).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct GateStats {
    /// Pixels (over the three images) whose surface point all three see.
    pub overlap_pixels: usize,
    /// Share of them with success probability >= the gate's threshold.
    pub matchable_share: f64,
    /// Share of them on non-flat materials (grass, trees).
    pub nonflat_share: f64,
    /// Median triangulation angle of the non-flat ones, degrees (0 if none).
    pub nonflat_median_angle_deg: f64,
}

impl MatchingGate {
    /// Whether a triplet with these statistics produces any output.
    pub fn passes(&self, s: &GateStats) -> bool {
        if s.overlap_pixels == 0 {
            return false;
        }
        if !self.enabled {
            return true;
        }
        if s.matchable_share < self.min_matchable_share {
            return false;
        }
        !(s.nonflat_share >= self.nonflat_min_share
            && s.nonflat_median_angle_deg > self.max_nonflat_median_angle_deg)
    }
}

/// What came out of one reconstruction, counted over its views' pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct OutputStats {
    /// Pixels whose true surface point lies in the region counted (the
    /// ROI for flights, anywhere for training).
    pub pixels: usize,
    /// Of them, pixels with any depth.
    pub output: usize,
    /// Of them, pixels whose depth is within `eval.depth_tolerance_m` of the
    /// true depth (the paper's 24 cm rule).
    pub measured: usize,
}

impl OutputStats {
    /// Share of the pixels measured within the tolerance (0 without pixels).
    pub fn measured_share(&self) -> f64 {
        self.measured as f64 / self.pixels.max(1) as f64
    }
}

/// One reconstructed image set: a flown triplet, or one reference image of
/// the Grid with the sources it was matched against.
#[derive(Debug, Clone)]
pub struct Flown {
    /// Identities of the images (distinct images have distinct ids).
    pub ids: Vec<u64>,
    /// The true cameras, at full resolution.
    pub cams: Vec<Camera>,
    /// One depth map per camera at full resolution (0 = no depth); a camera
    /// used only as a source has an empty (0 x 0) map.
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
}

/// A triplet reconstructed at one pyramid level, with the renderer's truth.
pub struct TripletRun {
    /// Depth maps at the level's resolution (all zero when nothing came out).
    pub depth: [DepthMap; 3],
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
}

/// The world a reconstruction looks at: the true mesh, its caster and the
/// texture seed of its renders.
#[derive(Clone, Copy)]
pub struct Scene<'a> {
    /// The true mesh.
    pub mesh: &'a Mesh,
    /// Ray caster of `mesh`.
    pub caster: &'a RayCaster,
    /// Texture seed of the world.
    pub texture_seed: u64,
}

/// The campaign's MVS, as configured.
pub struct Matcher<'a> {
    cfg: &'a CampaignConfig,
    virtual_mvs: Option<VirtualMvs>,
}

/// An empty depth map of `cam`'s size.
fn zero_depth(cam: &Camera) -> DepthMap {
    let k = cam.intrinsics;
    DepthMap {
        width: k.width,
        height: k.height,
        data: vec![0.0; k.width as usize * k.height as usize],
    }
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

/// 2nd and 98th percentile of the positive values, grown by `margin` of
/// the span on both sides (the near end kept positive); `None` without
/// enough values.
fn depth_range(depths: impl Iterator<Item = f32>, margin: f64) -> Option<(f64, f64)> {
    let mut d: Vec<f32> = depths.filter(|&z| z > 0.0).collect();
    if d.len() < 16 {
        return None;
    }
    d.sort_by(f32::total_cmp);
    let lo = f64::from(d[d.len() / 50]);
    let hi = f64::from(d[d.len() - 1 - d.len() / 50]);
    let span = (hi - lo).max(0.05 * hi);
    Some(((lo - margin * span).max(0.2 * lo), hi + margin * span))
}

impl<'a> Matcher<'a> {
    /// The matcher of `cfg` (`cfg.mvs`).
    pub fn new(cfg: &'a CampaignConfig) -> Result<Self> {
        let virtual_mvs = match cfg.mvs {
            MvsKind::Virtual => Some(VirtualMvs::new(cfg.profile.clone())?),
            MvsKind::Patchmatch => None,
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
        MvsParams {
            seed,
            ..self.cfg.patchmatch.clone()
        }
    }

    fn render_params(&self, scene: &Scene<'_>) -> RenderParams {
        RenderParams {
            texture_seed: scene.texture_seed,
            ..self.cfg.render.clone()
        }
    }

    /// Reconstructs the triplet `cams` (true cameras, full resolution) at
    /// pyramid `level`; `region` limits the pixels the statistics count.
    /// Adds every pixel the three cameras see to `curves`' measured side.
    pub fn triplet(
        &self,
        scene: &Scene<'_>,
        cams: [&Camera; 3],
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
        let rp = self.render_params(scene);
        let mut images = Vec::with_capacity(3);
        for cam in cams {
            let full = render(scene.mesh, scene.caster, cam, &rp)?;
            images.push(image_at_level(&full.rgb, level));
        }
        let images: [RgbImage; 3] = images
            .try_into()
            .map_err(|_| SimError::Campaign("three renders expected".into()))?;
        let (depth, truth, gate, fused) = if let Some(mvs) = &self.virtual_mvs {
            let (depth, truth, gate) =
                self.virtual_triplet(mvs, scene, cams, &level_cams, level, seed)?;
            (depth, truth, gate, Vec::new())
        } else {
            let (depth, truth, fused) =
                self.patchmatch_triplet(scene, cams, &level_cams, &images, level, seed)?;
            (depth, truth, None, fused)
        };
        let stats = self.measure(&level_cams, &depth, &truth, region);
        self.add_measured(&depth, &truth, curves);
        Ok(TripletRun {
            depth,
            truth,
            images,
            fused,
            stats,
            gate,
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

    /// vp-mvs on a triplet's images (each view against the other two), and
    /// the renderer's truth at the level.
    fn patchmatch_triplet(
        &self,
        scene: &Scene<'_>,
        cams: [&Camera; 3],
        level_cams: &[Camera; 3],
        images: &[RgbImage; 3],
        level: u8,
        seed: u64,
    ) -> Result<PatchmatchTriplet> {
        let truth = triplet_truth(
            scene.mesh,
            scene.caster,
            cams,
            level,
            self.cfg.training.labels.sigma_px,
        )?;
        let mut views = Vec::with_capacity(3);
        for (v, cam) in level_cams.iter().enumerate() {
            let range = depth_range(
                truth[v].iter().map(|t| t.true_depth),
                self.cfg.patchmatch.depth_range_margin,
            );
            let Some(range) = range else {
                // A view that sees (almost) no surface: nothing to match.
                return Ok((level_cams.each_ref().map(zero_depth), truth, Vec::new()));
            };
            views.push(View::new(&format!("v{v}"), *cam, images[v].clone(), range)?);
        }
        let sources = vec![vec![1, 2], vec![0, 2], vec![0, 1]];
        let out = vp_mvs::reconstruct(&views, &sources, &self.params(seed), &mut |_| {})?;
        let depth = [0, 1, 2].map(|v| depth_of(out.geometric[v].as_ref(), &level_cams[v]));
        Ok((depth, truth, fused_samples(&out.fused, level_cams)))
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
            let w = cams[v].intrinsics.width as usize;
            for (i, t) in truth[v].iter().enumerate() {
                if t.status == PixelStatus::NoSurface {
                    continue;
                }
                if let Some(r) = region {
                    let px = Point2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
                    if !r.contains(&cams[v].unproject(&px, f64::from(t.true_depth))) {
                        continue;
                    }
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

    /// Reconstructs `cams` (true cameras) as the paper's Grid: every image
    /// a reference against its best overlapping neighbours
    /// (`patchmatch.max_sources`), one [`Flown`] per reference. vp-mvs only.
    pub fn image_set(
        &self,
        scene: &Scene<'_>,
        cams: &[Camera],
        ids: &[u64],
        region: &Aabb,
        seed: u64,
    ) -> Result<Vec<Flown>> {
        if self.virtual_mvs.is_some() {
            return Err(SimError::Campaign(
                "the virtual MVS reconstructs triplets only".into(),
            ));
        }
        let rp = self.render_params(scene);
        let mut renders = Vec::with_capacity(cams.len());
        let mut views = Vec::with_capacity(cams.len());
        let mut ranges = Vec::with_capacity(cams.len());
        for (i, cam) in cams.iter().enumerate() {
            let r = render(scene.mesh, scene.caster, cam, &rp)?;
            let range = depth_range(
                r.depth.data.iter().copied(),
                self.cfg.patchmatch.depth_range_margin,
            )
            .unwrap_or((1.0, 2.0));
            ranges.push(range);
            views.push(View::new(&format!("g{i}"), *cam, r.rgb.clone(), range)?);
            renders.push(r);
        }
        let params = self.params(seed);
        let sources = vp_mvs::frustum_sources(cams, &ranges, &params);
        if sources.iter().all(Vec::is_empty) {
            return Ok(Vec::new());
        }
        let out = vp_mvs::reconstruct(&views, &sources, &params, &mut |_| {})?;
        // Each fused point goes to the set of the reference that started it.
        let mut fused_by_reference: Vec<Vec<SurfaceSample>> = vec![Vec::new(); cams.len()];
        for (p, sample) in out.fused.iter().zip(fused_samples(&out.fused, cams)) {
            fused_by_reference[p.views[0]].push(sample);
        }
        let tol = self.cfg.eval.depth_tolerance_m as f32;
        let mut flown = Vec::with_capacity(cams.len());
        for (r, src) in sources.iter().enumerate() {
            if src.is_empty() {
                continue;
            }
            let depth = depth_of(out.geometric[r].as_ref(), &cams[r]);
            let truth = &renders[r].depth;
            let w = cams[r].intrinsics.width as usize;
            let mut stats = OutputStats::default();
            for (i, (&z, &t)) in depth.data.iter().zip(&truth.data).enumerate() {
                let px = Point2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
                if t <= 0.0 || !region.contains(&cams[r].unproject(&px, f64::from(t))) {
                    continue;
                }
                stats.pixels += 1;
                if z > 0.0 {
                    stats.output += 1;
                    stats.measured += usize::from((z - t).abs() <= tol);
                }
            }
            let mut group_cams = vec![cams[r]];
            let mut group_ids = vec![ids[r]];
            let mut group_depth = vec![depth];
            for &s in src.iter().take(self.cfg.patchmatch.top_k_sources) {
                group_cams.push(cams[s]);
                group_ids.push(ids[s]);
                group_depth.push(DepthMap {
                    width: 0,
                    height: 0,
                    data: Vec::new(),
                });
            }
            flown.push(Flown {
                ids: group_ids,
                cams: group_cams,
                depth: group_depth,
                fused: std::mem::take(&mut fused_by_reference[r]),
                success: self.succeeded(&stats),
                stats,
                gate: None,
            });
        }
        Ok(flown)
    }

    /// Flies one triplet at full resolution over the ROI `region`.
    pub fn fly_triplet(
        &self,
        scene: &Scene<'_>,
        cams: [Camera; 3],
        ids: [u64; 3],
        region: &Aabb,
        seed: u64,
        curves: &mut CurveAccumulator,
    ) -> Result<Flown> {
        let run = self.triplet(
            scene,
            [&cams[0], &cams[1], &cams[2]],
            1,
            Some(region),
            seed,
            curves,
        )?;
        Ok(Flown {
            ids: ids.to_vec(),
            cams: cams.to_vec(),
            success: self.succeeded(&run.stats),
            depth: run.depth.to_vec(),
            fused: run.fused,
            stats: run.stats,
            gate: run.gate,
        })
    }
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

/// The depth of a vp-mvs result, or zeros of `cam`'s size without one.
fn depth_of(map: Option<&vp_mvs::DepthNormalMap>, cam: &Camera) -> DepthMap {
    map.map_or_else(
        || zero_depth(cam),
        |m| DepthMap {
            width: m.width,
            height: m.height,
            data: m.depth.clone(),
        },
    )
}

/// Whether vp-mvs's depth `z` at a pixel with truth `t` is within the
/// uncertainty bound (`k` sigma of the triplet's first-order depth
/// uncertainty) of the true depth: what a correct positive label claims.
pub fn truly_positive(t: &PixelTruth, z: f32, k: f32) -> bool {
    z > 0.0 && (z - t.true_depth).abs() <= k * t.sigma_depth.max(1e-6)
}

/// The gate's statistics of a virtual triplet.
fn gate_stats(truth: &[&[PixelTruth]; 3], gate: &MatchingGate) -> GateStats {
    let (mut overlap, mut matchable) = (0usize, 0usize);
    let mut nonflat: Vec<f32> = Vec::new();
    for t in truth.iter().flat_map(|v| v.iter()) {
        if !matches!(
            t.status,
            PixelStatus::Failed | PixelStatus::Reconstructed | PixelStatus::Outlier
        ) {
            continue;
        }
        overlap += 1;
        if f64::from(t.probability) >= gate.matchable_probability {
            matchable += 1;
        }
        if matches!(t.material, Some(Material::Grass | Material::Tree)) {
            nonflat.push(t.angle_deg);
        }
    }
    nonflat.sort_by(f32::total_cmp);
    GateStats {
        overlap_pixels: overlap,
        matchable_share: matchable as f64 / overlap.max(1) as f64,
        nonflat_share: nonflat.len() as f64 / overlap.max(1) as f64,
        nonflat_median_angle_deg: nonflat
            .get(nonflat.len() / 2)
            .map_or(0.0, |&a| f64::from(a)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stats(matchable: f64, nonflat: f64, angle: f64) -> GateStats {
        GateStats {
            overlap_pixels: 1000,
            matchable_share: matchable,
            nonflat_share: nonflat,
            nonflat_median_angle_deg: angle,
        }
    }

    #[test]
    fn gate_fails_wide_vegetation_triplets_and_keeps_flat_ones() {
        let g = MatchingGate::default();
        // Rock at a wide angle: mostly matchable, little vegetation.
        assert!(g.passes(&stats(0.9, 0.1, 40.0)));
        // Grass seen at 35 deg: median angle over the limit.
        assert!(!g.passes(&stats(0.6, 0.5, 35.0)));
        // The same grass at 10 deg passes.
        assert!(g.passes(&stats(0.6, 0.5, 10.0)));
        // Too little matchable overlap.
        assert!(!g.passes(&stats(0.3, 0.0, 0.0)));
        // No overlap: no output, gate or not.
        let off = MatchingGate {
            enabled: false,
            ..MatchingGate::default()
        };
        assert!(off.passes(&stats(0.0, 1.0, 80.0)));
        assert!(!off.passes(&GateStats::default()));
    }

    /// A nadir grid at 20 m over textured ground: every image against its
    /// neighbours, most pixels within the 24 cm rule.
    #[test]
    fn nadir_grid_over_ground_reconstructs_most_pixels() {
        let mesh = crate::test_scenes::uniform_plane(60.0, Material::Ground);
        let caster = RayCaster::new(&mesh);
        let scene = Scene {
            mesh: &mesh,
            caster: &caster,
            texture_seed: 3,
        };
        let cfg = CampaignConfig::quick();
        let k = cfg.planner.camera.intrinsics();
        for yaw in [0.0, std::f64::consts::FRAC_PI_2] {
            let mut cams = Vec::new();
            for j in 0..3 {
                for i in 0..3 {
                    let c = nalgebra::Point3::new(
                        27.0 + 3.0 * f64::from(i),
                        28.0 + 2.0 * f64::from(j),
                        20.0,
                    );
                    cams.push(Camera::from_yaw_pitch(
                        k,
                        c,
                        yaw,
                        -std::f64::consts::FRAC_PI_2,
                    ));
                }
            }
            let ids: Vec<u64> = (0..9).collect();
            let region = Aabb {
                min: nalgebra::Point3::new(-1.0, -1.0, -1.0),
                max: nalgebra::Point3::new(61.0, 61.0, 1.0),
            };
            let m = Matcher::new(&cfg).unwrap();
            let flown = m.image_set(&scene, &cams, &ids, &region, 5).unwrap();
            let (mut px, mut out, mut ok) = (0, 0, 0);
            for f in &flown {
                px += f.stats.pixels;
                out += f.stats.output;
                ok += f.stats.measured;
            }
            let (out, ok) = (out as f64 / px as f64, ok as f64 / px as f64);
            eprintln!(
                "yaw {yaw}: {} sets, output {out:.2}, measured {ok:.2}",
                flown.len()
            );
            assert!(ok > 0.5, "yaw {yaw}: measured {ok:.2}, output {out:.2}");
        }
    }

    #[test]
    fn depth_range_spans_the_percentiles_with_margin() {
        let d: Vec<f32> = (1..=100).map(|i| i as f32).collect();
        let (lo, hi) = depth_range(d.iter().copied(), 0.1).unwrap();
        // 2nd..98th percentile = 3..98, span 95, margin 9.5.
        assert!((lo - 0.6).abs() < 1e-9, "{lo}");
        assert!((hi - 107.5).abs() < 1e-9, "{hi}");
        assert!(depth_range([0.0f32; 100].into_iter(), 0.1).is_none());
    }
}
