//! The acquired views of a COLMAP model, with their confidence images: the
//! one way `vpctl plan` and the Python bindings turn files into
//! [`AcquiredView`]s, so that both plan from the same inputs.

use std::path::Path;

use vp_scene::colmap::Reconstruction;
use vp_scene::image_files::confidence_file;
use vp_scene::raster::ConfidenceImage;
use vp_scene::{Location, SceneError};

use crate::error::Result;
use crate::inputs::AcquiredView;

/// One view per image of `rec`, in image-id order (COLMAP ids follow
/// capture order in practice, so the last view is where the path starts),
/// each with its confidence image from `confidence_dir` (see
/// [`vp_scene::image_files::confidence_file`]) or none (the paper's NP variant). A missing or
/// malformed confidence file is an error naming the file.
pub fn acquired_from_model(
    rec: &Reconstruction,
    confidence_dir: Option<&Path>,
) -> Result<Vec<AcquiredView>> {
    let mut views = Vec::with_capacity(rec.images.len());
    for (&id, image) in &rec.images {
        let camera = rec.camera_of(id)?;
        let confidence = match confidence_dir {
            None => None,
            Some(dir) => {
                let path = confidence_file(dir, &image.name)?;
                let conf = ConfidenceImage::load(&path)?;
                let k = &camera.intrinsics;
                // The planner samples confidence at the camera's pixels: an
                // image predicted at another size would be read at the wrong
                // places without any error. A 1x1 image is a constant, which
                // fits every size.
                let constant = (conf.width(), conf.height()) == (1, 1);
                if !constant && (conf.width(), conf.height()) != (k.width, k.height) {
                    return Err(SceneError::parse(
                        &path,
                        Location::Header,
                        format!(
                            "confidence image is {}x{} but the camera of image {} is {}x{}: \
                             predict on the images the model was made from (undistorted, \
                             full size)",
                            conf.width(),
                            conf.height(),
                            image.name,
                            k.width,
                            k.height
                        ),
                    )
                    .into());
                }
                Some(conf)
            }
        };
        views.push(AcquiredView { camera, confidence });
    }
    Ok(views)
}

#[cfg(test)]
mod tests {
    use super::*;
    use vp_scene::colmap::{CameraModel, ColmapCamera, ColmapImage};
    use vp_scene::{Camera, Intrinsics};

    fn model() -> Reconstruction {
        let k = Intrinsics::from_hfov(40, 30, 60.0).unwrap();
        let mut rec = Reconstruction::default();
        rec.cameras.insert(
            1,
            ColmapCamera {
                id: 1,
                model: CameraModel::Pinhole,
                width: 40,
                height: 30,
                params: vec![k.fx, k.fy, k.cx, k.cy],
            },
        );
        for (id, x) in [(2u32, 5.0), (1, -5.0)] {
            let cam = Camera::look_at(
                k,
                nalgebra::Point3::new(x, 0.0, 20.0),
                nalgebra::Point3::new(x, 1.0, 0.0),
            )
            .unwrap();
            rec.images.insert(
                id,
                ColmapImage {
                    id,
                    camera_id: 1,
                    name: format!("img{id}.jpg"),
                    cam_from_world: cam.cam_from_world(),
                    points2d: Vec::new(),
                },
            );
        }
        rec
    }

    #[test]
    fn views_follow_image_ids_and_missing_confidence_names_the_file() {
        let rec = model();
        let views = acquired_from_model(&rec, None).unwrap();
        assert_eq!(views.len(), 2);
        assert!(
            (views[0].camera.center().x + 5.0).abs() < 1e-9,
            "id 1 first"
        );
        assert!(views.iter().all(|v| v.confidence.is_none()));
        let dir = tempfile::tempdir().unwrap();
        let err = acquired_from_model(&rec, Some(dir.path())).unwrap_err();
        assert!(err.to_string().contains("img1.jpg.vpconf"), "{err}");
        assert!(err.is_input_error());
        ConfidenceImage::constant(0.5)
            .save(&confidence_file(dir.path(), "img1.jpg").unwrap())
            .unwrap();
        ConfidenceImage::constant(0.25)
            .save(&confidence_file(dir.path(), "img2.jpg").unwrap())
            .unwrap();
        let views = acquired_from_model(&rec, Some(dir.path())).unwrap();
        let c: Vec<f32> = views
            .iter()
            .map(|v| v.confidence.as_ref().unwrap().values()[0])
            .collect();
        assert_eq!(c, vec![0.5, 0.25]);
        // Regression: a confidence image predicted on a downscaled photo was
        // sampled at the camera's pixels without an error.
        let half = ConfidenceImage::zeros(20, 15, 1, vp_scene::raster::AngleBins::paper()).unwrap();
        let path = confidence_file(dir.path(), "img2.jpg").unwrap();
        half.save(&path).unwrap();
        let err = acquired_from_model(&rec, Some(dir.path())).unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains("img2.jpg.vpconf") && msg.contains("20x15") && msg.contains("40x30"),
            "{msg}"
        );
        assert!(err.is_input_error());
    }
}
