//! The offline training campaign: procedural training sites, random camera
//! triplets over the triangulation-angle range reconstructed by the
//! campaign's MVS at each pyramid level on SfM's noisy poses and the depth
//! ranges of SfM's sparse points, vp-labelgen labels (on the same poses,
//! stage 3 on the 3D mesh of the sparse points, as a user has them),
//! vp-forest training on the rendered pixels. The held-out sites are never
//! among them.

use std::collections::BTreeMap;

use nalgebra::{Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vp_forest::{Forest, TrainingSet};
use vp_labelgen::{generate_labels, MissingPartMeshes, TripletReconstruction, View};
use vp_scene::colmap::DepthMap;
use vp_scene::procedural::{generate_site, Site};
use vp_scene::raster::{Label, LabelImage, RgbImage};
use vp_scene::raycast::RayCaster;
use vp_scene::surface::{reconstruct_surface, SurfaceSample};
use vp_scene::{Camera, Intrinsics};

use super::curves::CurveAccumulator;
use super::label_quality::LabelQuality;
use super::reconstruct::Matcher;
use super::renders::Renders;
use crate::config::CampaignConfig;
use crate::error::{Result, SimError};
use crate::sfm::{sfm_camera, SparseCandidates};
use crate::virtual_mvs::{level_camera, PixelTruth};
use crate::world::Scene;
use vp_scene::hash::mix64;

/// Margin around the rock within which training triplets focus, metres:
/// the rock and the vegetation around it, as the ROI of a flight.
const FOCUS_MARGIN_M: f64 = 6.0;
/// Smallest training triangulation angle, degrees.
const MIN_ANGLE_DEG: f64 = 2.0;

/// What the training campaign did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct TrainingStats {
    /// Training sites.
    pub sites: usize,
    /// Triplets flown.
    pub triplets: usize,
    /// Triplet reconstructions (one per level) that produced 3D output.
    pub successful_triplets: usize,
    /// Positive labelled pixels.
    pub positives: usize,
    /// Negative labelled pixels.
    pub negatives: usize,
    /// labelgen's labels against the renderer's truth, per material.
    pub label_quality: LabelQuality,
}

/// A random triplet around a random focus point near the rock: centre at a
/// random distance and elevation, cameras on a circle perpendicular to the
/// viewing direction, sized for a triangulation angle drawn log-uniformly
/// between 2 deg and `max_angle_deg`, all looking at the focus.
fn random_triplet(
    site: &Site,
    caster: &RayCaster,
    k: Intrinsics,
    cfg: &CampaignConfig,
    rng: &mut ChaCha8Rng,
) -> Option<[Camera; 3]> {
    let t = &cfg.training;
    let rb = site.rock_bounds;
    let x = rng.random_range(rb.min.x - FOCUS_MARGIN_M..rb.max.x + FOCUS_MARGIN_M);
    let y = rng.random_range(rb.min.y - FOCUS_MARGIN_M..rb.max.y + FOCUS_MARGIN_M);
    let top = site.mesh.bounds().max.z + 10.0;
    let hit = caster.closest_hit(&Point3::new(x, y, top), &-Vector3::z(), f64::INFINITY)?;
    let focus = hit.point;
    let angle = (MIN_ANGLE_DEG.ln()
        + rng.random::<f64>() * (t.max_angle_deg.ln() - MIN_ANGLE_DEG.ln()))
    .exp();
    let d = rng.random_range(t.distance_m[0]..=t.distance_m[1]);
    let el = rng.random_range(25f64..80.0).to_radians();
    let az = rng.random_range(0.0..std::f64::consts::TAU);
    let dir = Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
    let centre = focus + dir * d;
    let u = dir.cross(&Vector3::z()).normalize();
    let v = dir.cross(&u);
    let r = 2.0 * d * (0.5 * angle.to_radians()).tan() / 3f64.sqrt();
    let mut cams = Vec::with_capacity(3);
    for phi in [90.0f64, 210.0, 330.0] {
        let p = phi.to_radians();
        let c = centre + (u * p.cos() + v * p.sin()) * r;
        if c.z < site.surface_height(c.x, c.y) + 1.0 {
            return None;
        }
        cams.push(Camera::look_at(k, c, focus).ok()?);
    }
    Some([cams[0], cams[1], cams[2]])
}

/// Tag of the random stream of the out-of-sample triplets.
const OUT_OF_SAMPLE_TAG: u64 = 0x006f_6f73_616d;

/// The fixed random triplets of held-out site `seed` on which the measured
/// curves are measured out of sample (issue 34, item 7): drawn as training
/// triplets are, at the training camera, from the campaign seed and the
/// site's seed only. No planner chose them, no forest trained on them, and
/// every strategy of a campaign is compared against the same set.
pub(crate) fn out_of_sample_triplets(
    site: &Site,
    caster: &RayCaster,
    cfg: &CampaignConfig,
    seed: u64,
) -> Result<Vec<[Camera; 3]>> {
    let t = &cfg.training;
    let k = Intrinsics::from_hfov(t.width, t.height, t.hfov_deg)?;
    let mut rng = ChaCha8Rng::seed_from_u64(mix64(cfg.seed ^ mix64(seed ^ OUT_OF_SAMPLE_TAG)));
    let per_site = t.triplets_per_site;
    let mut out = Vec::with_capacity(per_site);
    let mut attempts = 0;
    while out.len() < per_site && attempts < 20 * per_site {
        attempts += 1;
        if let Some(cams) = random_triplet(site, caster, k, cfg, &mut rng) {
            out.push(cams);
        }
    }
    Ok(out)
}

/// The matcher's seed for triplet `n` of site `site` at `level`: one
/// formula for training and the out-of-sample set (whose campaign seed
/// carries [`OUT_OF_SAMPLE_TAG`]), so that the two draws never share seeds.
fn triplet_seed(campaign_seed: u64, site: u64, n: usize, level: u8) -> u64 {
    mix64(campaign_seed ^ mix64(site ^ mix64((n as u64) << 8 | u64::from(level))))
}

/// Reconstructs the [`out_of_sample_triplets`] of held-out site `seed`
/// with `matcher` on SfM's poses at every training level, as training does,
/// and adds what they measured to `curves` (only there); returns how many
/// triplets were flown. Each triplet is rendered once for all its levels
/// (its shots are dropped after: `renders` holds three at most).
pub(crate) fn measure_out_of_sample(
    renders: &mut Renders<'_>,
    site: &Site,
    matcher: &Matcher,
    cfg: &CampaignConfig,
    seed: u64,
    curves: &mut CurveAccumulator,
) -> Result<usize> {
    let triplets = out_of_sample_triplets(site, renders.scene().caster, cfg, seed)?;
    for (n, cams) in triplets.iter().enumerate() {
        let sfm = cams.each_ref().map(|c| sfm_camera(c, cfg, seed));
        for &level in &cfg.training.levels {
            let tseed = triplet_seed(cfg.seed ^ OUT_OF_SAMPLE_TAG, seed, n, level);
            matcher.triplet(
                renders,
                ([&cams[0], &cams[1], &cams[2]], [&sfm[0], &sfm[1], &sfm[2]]),
                level,
                None,
                tseed,
                curves,
            )?;
        }
        renders.clear();
    }
    Ok(triplets.len())
}

/// One triplet at one level: its images, truth and depth maps (in the true
/// cameras, for the label quality).
type LevelRun = ([RgbImage; 3], [Vec<PixelTruth>; 3], [DepthMap; 3]);

/// One labelled image of a training site, with the renderer's truth under
/// each pixel (for scoring the labels and the forest, never for training).
pub struct LabelledView {
    /// The rendered image at the reconstruction's level.
    pub image: RgbImage,
    /// labelgen's labels, with each pixel's triangulation angle.
    pub label: LabelImage,
    /// The renderer's truth per pixel (row-major).
    pub truth: Vec<PixelTruth>,
    /// The depth the matcher wrote per pixel, in the truth's frame.
    pub depth: Vec<f32>,
}

/// Flies the training triplets of one site and labels them, as the
/// training campaign does: the labelled images, in a fixed order.
pub(crate) fn label_site(
    cfg: &CampaignConfig,
    seed: u64,
    stats: &mut TrainingStats,
    curves: &mut CurveAccumulator,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<LabelledView>> {
    let t = &cfg.training;
    let mut params = t.site.clone();
    params.seed = seed;
    let site = generate_site(&params)?;
    let caster = RayCaster::new(&site.mesh);
    let candidates = SparseCandidates::of_site(&site.mesh, cfg, seed);
    let scene = Scene {
        mesh: &site.mesh,
        caster: &caster,
        texture_seed: seed,
        candidates: &candidates,
    };
    let k = Intrinsics::from_hfov(t.width, t.height, t.hfov_deg)?;
    let matcher = Matcher::new(cfg)?;
    // One render per training camera for all the levels, three at a time.
    let mut renders = Renders::new(scene, cfg);
    let mut rng = ChaCha8Rng::seed_from_u64(mix64(cfg.seed ^ mix64(seed ^ 0x0074_7261_696e)));
    let mut recs = Vec::new();
    // Per reconstruction id: each view's image at the level and its truth.
    let mut runs: BTreeMap<String, LevelRun> = BTreeMap::new();
    let mut points = BTreeMap::new();
    let mut attempts = 0;
    let mut n = 0;
    // `stats` counts over every site; the progress line says this site's.
    let succeeded_before = stats.successful_triplets;
    let per_site = t.triplets_per_site;
    while n < per_site && attempts < 20 * per_site {
        attempts += 1;
        let Some(cams) = random_triplet(&site, &caster, k, cfg, &mut rng) else {
            continue;
        };
        // SfM's estimate of the three poses: what vp-mvs and labelgen work with.
        let sfm = cams.each_ref().map(|c| sfm_camera(c, cfg, seed));
        for &level in &t.levels {
            let tseed = triplet_seed(cfg.seed, seed, n, level);
            let run = matcher.triplet(
                &mut renders,
                ([&cams[0], &cams[1], &cams[2]], [&sfm[0], &sfm[1], &sfm[2]]),
                level,
                None,
                tseed,
                curves,
            )?;
            stats.triplets += 1;
            stats.successful_triplets += usize::from(matcher.succeeded(&run.stats));
            if level == t.levels[0] {
                let centres = sfm.each_ref().map(Camera::center);
                crate::sfm::track_samples(&run.sparse, &centres, &mut points);
            }
            let id = format!("t{n:03}/level{level}");
            let view = |v: usize, d: DepthMap| -> Result<View> {
                Ok(View {
                    name: format!("t{n:03}_c{v}"),
                    camera: level_camera(&sfm[v], level)?,
                    depth: d,
                })
            };
            let [d0, d1, d2] = run.depth.clone();
            recs.push(TripletReconstruction {
                id: id.clone(),
                views: [view(0, d0)?, view(1, d1)?, view(2, d2)?],
            });
            runs.insert(id, (run.images, run.truth, run.depth_in_truth));
        }
        renders.clear();
        n += 1;
        progress(&format!("training site {seed}: triplets ({n}/{per_site})"));
    }
    progress(&format!(
        "training site {seed}: {n} triplets reconstructed, {} with output; labelling",
        stats.successful_triplets - succeeded_before
    ));
    // Stage 3's mesh as a user has it: `vpctl mesh build`'s 3D mesher on
    // the sparse points. Too few or degenerate points (a tiny test site):
    // no mesh, and missing parts stay unlabelled, as for a user without one.
    let points: Vec<SurfaceSample> = points.into_values().collect();
    let meshes = match reconstruct_surface(&points, &cfg.surface) {
        Ok(mesh) => Some(MissingPartMeshes::new(&mesh, t.labels.mesh_iterations)),
        Err(e) => {
            progress(&format!(
                "training site {seed}: no stage-3 mesh from {} sparse points ({e}); \
                 missing parts stay unlabelled",
                points.len()
            ));
            None
        }
    };
    let labels = generate_labels(&recs, meshes.as_ref(), &t.labels)?;
    let out = labelled_views(labels, runs, stats, t.labels.k_sigma as f32, &t.forest.bins)?;
    stats.sites += 1;
    Ok(out)
}

/// labelgen's labels joined with the images and the truth of their
/// reconstructions, counted into `stats`.
fn labelled_views(
    labels: Vec<vp_labelgen::ReconLabels>,
    mut runs: BTreeMap<String, LevelRun>,
    stats: &mut TrainingStats,
    k_sigma: f32,
    bins: &vp_scene::raster::AngleBins,
) -> Result<Vec<LabelledView>> {
    let mut out = Vec::with_capacity(3 * labels.len());
    for rl in labels {
        let Some((images, truth, depth)) = runs.remove(&rl.id) else {
            return Err(SimError::Campaign(format!(
                "training: labels for unknown reconstruction {}",
                rl.id
            )));
        };
        for (((image, label), truth), depth) in
            images.into_iter().zip(rl.labels).zip(truth).zip(depth)
        {
            stats
                .label_quality
                .add(&label, &truth, &depth.data, k_sigma, bins);
            stats.positives += label.count(Label::Positive);
            stats.negatives += label.count(Label::Negative);
            out.push(LabelledView {
                image,
                label,
                truth,
                depth: depth.data,
            });
        }
    }
    Ok(out)
}

/// Flies and labels the training triplets of one site; adds the labelled
/// images to `set`.
fn train_site(
    cfg: &CampaignConfig,
    seed: u64,
    set: &mut TrainingSet,
    stats: &mut TrainingStats,
    curves: &mut CurveAccumulator,
    progress: &mut dyn FnMut(&str),
) -> Result<()> {
    for v in label_site(cfg, seed, stats, curves, progress)? {
        set.add_image(&v.image, std::slice::from_ref(&v.label))?;
    }
    Ok(())
}

/// Runs the training campaign of `cfg` and trains the forest; `progress`
/// hears one line per site and one for the training.
pub fn train_forest_with_stats(
    cfg: &CampaignConfig,
    curves: &mut CurveAccumulator,
    progress: &mut dyn FnMut(&str),
) -> Result<(Forest, TrainingStats)> {
    cfg.validate()?;
    let t = &cfg.training;
    let mut set =
        TrainingSet::with_cap_per_label_image(t.max_per_label_image, mix64(cfg.seed ^ 0x0063_6170));
    let mut stats = TrainingStats::default();
    for &seed in &t.site_seeds {
        // Said first: the site and the first MVS runs were the demo's silent 18 s.
        progress(&format!("training site {seed}: generating the site"));
        train_site(cfg, seed, &mut set, &mut stats, curves, progress)?;
    }
    progress(&format!(
        "training the forest on {} labelled pixels ({} positive, {} negative available)",
        set.len(),
        stats.positives,
        stats.negatives
    ));
    let forest = vp_forest::train(&set, &t.forest, mix64(cfg.seed ^ 0x666f_7265_7374))?;
    Ok((forest, stats))
}

/// [`train_forest_with_stats`] without progress or statistics: the forest
/// `vpctl demo --save-forest` writes and `--forest` reuses.
pub fn train_forest(cfg: &CampaignConfig) -> Result<Forest> {
    let mut curves = CurveAccumulator::new(cfg.training.forest.bins.clone());
    Ok(train_forest_with_stats(cfg, &mut curves, &mut |_| {})?.0)
}
