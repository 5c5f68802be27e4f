//! The campaign's images: the initial flight over the ROI, and the renders
//! of every acquired camera with its features and predicted confidence.

use nalgebra::Point3;
use vp_forest::Forest;
use vp_scene::Camera;

use super::curves::CurveAccumulator;
use crate::config::CampaignConfig;
use crate::error::{Result, SimError};
use crate::render::render;
use crate::sfm::FeatureMask;
use crate::world::{Acquired, World};

/// The initial flight: a nadir grid centred on the ROI (see [`crate::config::InitFlight`]).
pub fn init_cameras(world: &World, cfg: &CampaignConfig) -> Vec<Camera> {
    let i = &cfg.init;
    let cx = 0.5 * (world.roi.min.x + world.roi.max.x);
    let cy = 0.5 * (world.roi.min.y + world.roi.max.y);
    let z = world.ground_min_z() + i.height_m;
    let mut cams = Vec::with_capacity(i.nx * i.ny);
    for row in 0..i.ny {
        for col in 0..i.nx {
            // Serpentine order, as flown.
            let c = if row % 2 == 0 { col } else { i.nx - 1 - col };
            let x = cx + (c as f64 - 0.5 * (i.nx as f64 - 1.0)) * i.spacing_m;
            let y = cy + (row as f64 - 0.5 * (i.ny as f64 - 1.0)) * i.spacing_m;
            cams.push(Camera::from_yaw_pitch(
                world.intrinsics,
                Point3::new(x, y, z),
                std::f64::consts::FRAC_PI_2,
                -std::f64::consts::FRAC_PI_2,
            ));
        }
    }
    cams
}

/// Renders each camera's image (`cams`: true, `sfm`: SfM's estimate of
/// the same), finds its features and predicts its confidence (when a
/// forest is given); adds the learned confidence per material to `curves`.
pub fn acquire(
    world: &World,
    cams: &[Camera],
    sfm: &[Camera],
    forest: Option<&Forest>,
    cfg: &CampaignConfig,
    curves: &mut CurveAccumulator,
) -> Result<Vec<Acquired>> {
    if cams.len() != sfm.len() {
        return Err(SimError::Campaign(format!(
            "{} cameras but {} SfM estimates",
            cams.len(),
            sfm.len()
        )));
    }
    let mut rp = cfg.render.clone();
    rp.texture_seed = world.site.params.seed;
    let mut out = Vec::with_capacity(cams.len());
    for (cam, sfm) in cams.iter().zip(sfm) {
        let img = render(&world.site.mesh, &world.caster, cam, &rp)?;
        let confidence = match forest {
            Some(forest) => {
                let conf = forest
                    .predict_image(&img.rgb, cfg.confidence_step)
                    .map_err(|e| {
                        SimError::InvalidArgument(format!("confidence prediction: {e}"))
                    })?;
                curves.add_learned(&img, &world.site.mesh, &conf);
                Some(conf)
            }
            None => None,
        };
        out.push(Acquired {
            truth: *cam,
            sfm: *sfm,
            features: FeatureMask::detect(&img.rgb),
            confidence,
        });
    }
    Ok(out)
}
