//! The campaign's images: the initial flight over the ROI, and the shots
//! of every acquired camera with their features and predicted confidence.

use nalgebra::Point3;
use vp_forest::Forest;
use vp_scene::Camera;

use super::curves::CurveAccumulator;
use super::renders::Renders;
use crate::config::CampaignConfig;
use crate::error::{Result, SimError};
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

/// Takes each camera's shot from `renders` (`cams`: true, `sfm`: SfM's
/// estimate of the same; a shot the matcher made before is not made
/// again, and the shots stay there for a reconstruction after), keeps its
/// features and predicts its confidence (when a forest is given); adds the
/// learned confidence per material to `curves`.
pub fn acquire(
    renders: &mut Renders<'_>,
    (cams, sfm): (&[Camera], &[Camera]),
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
    let mesh = renders.scene().mesh;
    let cam_refs: Vec<&Camera> = cams.iter().collect();
    let shots = renders.shots(&cam_refs)?;
    let mut out = Vec::with_capacity(cams.len());
    for ((cam, sfm), shot) in cams.iter().zip(sfm).zip(shots) {
        let img = &shot.image;
        let confidence = match forest {
            Some(forest) => {
                let conf = forest
                    .predict_image(&img.rgb, cfg.confidence_step)
                    .map_err(|e| {
                        SimError::InvalidArgument(format!("confidence prediction: {e}"))
                    })?;
                curves.add_learned(img, mesh, &conf);
                Some(conf)
            }
            None => None,
        };
        out.push(Acquired {
            truth: *cam,
            sfm: *sfm,
            features: shot.features.clone(),
            confidence,
        });
    }
    Ok(out)
}
