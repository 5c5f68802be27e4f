//! The offline training campaign: procedural training sites, random camera
//! triplets over the triangulation-angle range, the virtual MVS, vp-labelgen
//! labels, vp-forest training. The held-out sites are never among them.

use std::collections::BTreeMap;

use nalgebra::{Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vp_forest::{Forest, TrainingSet};
use vp_labelgen::{generate_labels, MissingPartMeshes, TripletReconstruction, View};
use vp_scene::procedural::{generate_site, Site};
use vp_scene::raster::RgbImage;
use vp_scene::raycast::RayCaster;
use vp_scene::{Camera, Intrinsics};

use super::config::CampaignConfig;
use super::fly::reconstruct_gated;
use crate::error::{Result, SimError};
use crate::mvs::{level_camera, VirtualMvs};
use crate::noise::mix64;
use crate::render::render;

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
    /// Triplets the virtual MVS produced output for.
    pub successful_triplets: usize,
    /// Positive labelled pixels.
    pub positives: usize,
    /// Negative labelled pixels.
    pub negatives: usize,
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

/// Halves an image `level - 1` times (level 1: as is).
fn image_at_level(img: &RgbImage, level: u8) -> RgbImage {
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

/// Flies the training triplets of one site and labels them; adds the
/// labelled images to `set`.
fn train_site(
    cfg: &CampaignConfig,
    seed: u64,
    set: &mut TrainingSet,
    stats: &mut TrainingStats,
    progress: &mut dyn FnMut(&str),
) -> Result<()> {
    let t = &cfg.training;
    let mut params = t.site.clone();
    params.seed = seed;
    let site = generate_site(&params)?;
    let caster = RayCaster::new(&site.mesh);
    let k = Intrinsics::from_hfov(t.width, t.height, t.hfov_deg)?;
    let mvs = VirtualMvs::new(cfg.profile.clone())?;
    let mut rng = ChaCha8Rng::seed_from_u64(mix64(cfg.seed ^ mix64(seed ^ 0x0074_7261_696e)));
    let mut rp = cfg.render.clone();
    rp.texture_seed = seed;
    let mut recs = Vec::new();
    let mut images: BTreeMap<String, RgbImage> = BTreeMap::new();
    let mut attempts = 0;
    let mut n = 0;
    while n < t.triplets_per_site && attempts < 20 * t.triplets_per_site {
        attempts += 1;
        let Some(cams) = random_triplet(&site, &caster, k, cfg, &mut rng) else {
            continue;
        };
        for (v, cam) in cams.iter().enumerate() {
            let img = render(&site.mesh, &caster, cam, &rp)?;
            images.insert(format!("t{n:03}_c{v}"), img.rgb);
        }
        for &level in &t.levels {
            let tseed = mix64(cfg.seed ^ mix64(seed ^ mix64((n as u64) << 8 | u64::from(level))));
            let (depth, _) = reconstruct_gated(
                &mvs,
                &cfg.gate,
                &site.mesh,
                &caster,
                [&cams[0], &cams[1], &cams[2]],
                level,
                tseed,
            )?;
            stats.triplets += 1;
            stats.successful_triplets += usize::from(depth.is_some());
            let depth = depth.unwrap_or_else(|| {
                cams.map(|c| {
                    let lk = c.intrinsics.scaled(0.5f64.powi(i32::from(level) - 1));
                    vp_scene::colmap::DepthMap {
                        width: lk.width,
                        height: lk.height,
                        data: vec![0.0; (lk.width * lk.height) as usize],
                    }
                })
            });
            let [d0, d1, d2] = depth;
            let view = |v: usize, d: vp_scene::colmap::DepthMap| -> Result<View> {
                Ok(View {
                    name: format!("t{n:03}_c{v}"),
                    camera: level_camera(&cams[v], level)?,
                    depth: d,
                })
            };
            recs.push(TripletReconstruction {
                id: format!("t{n:03}/level{level}"),
                views: [view(0, d0)?, view(1, d1)?, view(2, d2)?],
            });
        }
        n += 1;
    }
    progress(&format!(
        "training site {seed}: {n} triplets flown, labelling"
    ));
    let meshes = MissingPartMeshes::new(&site.mesh, t.labels.mesh_iterations);
    let labels = generate_labels(&recs, Some(&meshes), &t.labels)?;
    for rl in &labels {
        let level: u8 = rl
            .id
            .rsplit("level")
            .next()
            .and_then(|l| l.parse().ok())
            .unwrap_or(1);
        for (name, label) in rl.names.iter().zip(&rl.labels) {
            let Some(img) = images.get(name) else {
                return Err(SimError::InvalidArgument(format!(
                    "training: no image named {name}"
                )));
            };
            let img = image_at_level(img, level);
            stats.positives += label.count(vp_scene::raster::Label::Positive);
            stats.negatives += label.count(vp_scene::raster::Label::Negative);
            set.add_image(&img, std::slice::from_ref(label))?;
        }
    }
    stats.sites += 1;
    Ok(())
}

/// Runs the training campaign of `cfg` and trains the forest; `progress`
/// hears one line per site and one for the training.
pub fn train_forest_with_stats(
    cfg: &CampaignConfig,
    progress: &mut dyn FnMut(&str),
) -> Result<(Forest, TrainingStats)> {
    cfg.validate()?;
    let t = &cfg.training;
    let mut set =
        TrainingSet::with_cap_per_label_image(t.max_per_label_image, mix64(cfg.seed ^ 0x0063_6170));
    let mut stats = TrainingStats::default();
    for &seed in &t.site_seeds {
        train_site(cfg, seed, &mut set, &mut stats, progress)?;
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
/// `vpctl demo --save-model` writes and `--model` reuses.
pub fn train_forest(cfg: &CampaignConfig) -> Result<Forest> {
    Ok(train_forest_with_stats(cfg, &mut |_| {})?.0)
}
