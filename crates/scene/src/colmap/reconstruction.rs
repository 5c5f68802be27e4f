//! The sparse model as a whole: lookups, statistics and the consistency
//! checks that tie cameras, images and 3D points together.

use std::collections::BTreeMap;

use nalgebra::{Point2, Point3};

use super::model::{CameraModel, ColmapCamera, ColmapImage, Point2D, Point3D};
use crate::camera::Camera;
use crate::error::{Location, Result, SceneError};

/// Why a distorted camera is refused, and what to do.
pub(crate) fn distorted_message(cam: &ColmapCamera) -> String {
    format!(
        "camera {} is {} with lens distortion: vpctl plans, labels and predicts with \
         pinhole cameras and does not approximate a distorted one silently; undistort \
         the model and images first: vpctl colmap undistort --colmap MODEL --images IMAGES \
         --out WORKSPACE (then use WORKSPACE/sparse and WORKSPACE/images)",
        cam.id, cam.model
    )
}

/// A COLMAP sparse model.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Reconstruction {
    /// Cameras by id.
    pub cameras: BTreeMap<u32, ColmapCamera>,
    /// Registered images by id.
    pub images: BTreeMap<u32, ColmapImage>,
    /// 3D points by id.
    pub points: BTreeMap<u64, Point3D>,
}

/// The three files of a sparse model, to say which one a problem lies in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ModelFile {
    Cameras,
    Images,
    Points,
}

impl ModelFile {
    pub(crate) fn stem(self) -> &'static str {
        match self {
            ModelFile::Cameras => "cameras",
            ModelFile::Images => "images",
            ModelFile::Points => "points3D",
        }
    }
}

/// A broken cross-reference or invariant, found by [`Reconstruction::check`].
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Inconsistency {
    /// The file holding the element at fault.
    pub file: ModelFile,
    /// Id of the element at fault (camera, image or point id).
    pub id: u64,
    /// The element at fault in words (e.g. "image 3").
    pub element: String,
    /// What is wrong.
    pub message: String,
}

impl Reconstruction {
    /// Adds an image named `name` taken by `cam`, with a PINHOLE camera of
    /// its own; both get the id one above the largest so far (1 in an empty
    /// model). Returns the image id.
    pub fn add_pinhole_image(&mut self, name: &str, cam: &Camera) -> u32 {
        let next = |last: Option<u32>| last.map_or(1, |id| id + 1);
        let camera_id = next(self.cameras.keys().next_back().copied());
        let id = next(self.images.keys().next_back().copied());
        let k = cam.intrinsics;
        self.cameras.insert(
            camera_id,
            ColmapCamera {
                id: camera_id,
                model: CameraModel::Pinhole,
                width: u64::from(k.width),
                height: u64::from(k.height),
                params: vec![k.fx, k.fy, k.cx, k.cy],
            },
        );
        self.images.insert(
            id,
            ColmapImage {
                id,
                camera_id,
                name: name.to_owned(),
                cam_from_world: cam.cam_from_world(),
                points2d: Vec::new(),
            },
        );
        id
    }

    /// Adds a 3D point at `xyz` (grey, reprojection error 0) observed at
    /// `observations` (image id, pixel): each becomes a 2D point of its
    /// image and an element of the track. The id is one above the largest
    /// so far. Refuses an unknown image id, changing nothing.
    pub fn add_point(
        &mut self,
        xyz: Point3<f64>,
        observations: &[(u32, Point2<f64>)],
    ) -> Result<u64> {
        if let Some((id, _)) = observations
            .iter()
            .find(|(id, _)| !self.images.contains_key(id))
        {
            return Err(SceneError::InvalidArgument(format!(
                "a 3D point observed in image {id}, which the model does not have"
            )));
        }
        let id = self.points.keys().next_back().map_or(1, |id| id + 1);
        let mut track = Vec::with_capacity(observations.len());
        for &(image_id, xy) in observations {
            if let Some(img) = self.images.get_mut(&image_id) {
                track.push((image_id, img.points2d.len() as u32));
                img.points2d.push(Point2D {
                    xy,
                    point3d_id: Some(id),
                });
            }
        }
        self.points.insert(
            id,
            Point3D {
                id,
                xyz,
                rgb: [128, 128, 128],
                error: 0.0,
                track,
            },
        );
        Ok(id)
    }

    /// The posed pinhole camera of image `image_id` (`world_from_cam` the
    /// inverse of its pose). Refuses a camera with lens distortion
    /// ([`ColmapCamera::is_distorted`]): vpctl projects with pinholes, so a
    /// distorted model must be undistorted first (`vpctl colmap undistort`)
    /// rather than approximated silently.
    pub fn camera_of(&self, image_id: u32) -> Result<Camera> {
        let image = self.images.get(&image_id).ok_or_else(|| {
            SceneError::InvalidArgument(format!("no image with id {image_id} in the model"))
        })?;
        let cam = self.cameras.get(&image.camera_id).ok_or_else(|| {
            SceneError::InvalidArgument(format!(
                "image {image_id} refers to camera {}, which is not in the model",
                image.camera_id
            ))
        })?;
        if cam.is_distorted() {
            return Err(SceneError::InvalidArgument(distorted_message(cam)));
        }
        Ok(Camera::new(cam.pinhole()?, image.cam_from_world.inverse()))
    }

    /// Mean number of observations per 3D point (0 without points).
    pub fn mean_track_length(&self) -> f64 {
        if self.points.is_empty() {
            return 0.0;
        }
        let total: usize = self.points.values().map(|p| p.track.len()).sum();
        total as f64 / self.points.len() as f64
    }

    /// Mean number of 2D features that observe a 3D point, per image (0
    /// without images).
    pub fn mean_observations_per_image(&self) -> f64 {
        if self.images.is_empty() {
            return 0.0;
        }
        let total: usize = self
            .images
            .values()
            .map(|im| {
                im.points2d
                    .iter()
                    .filter(|p| p.point3d_id.is_some())
                    .count()
            })
            .sum();
        total as f64 / self.images.len() as f64
    }

    /// Mean reprojection error over the points that carry one (COLMAP writes
    /// a negative error when it is unknown); `None` when no point has one.
    pub fn mean_reprojection_error(&self) -> Option<f64> {
        let errs: Vec<f64> = self
            .points
            .values()
            .map(|p| p.error)
            .filter(|e| *e >= 0.0 && e.is_finite())
            .collect();
        (!errs.is_empty()).then(|| errs.iter().sum::<f64>() / errs.len() as f64)
    }

    /// Checks the model's invariants: each camera has its model's parameter
    /// count; each image's camera exists; each 2D point's 3D point exists and
    /// lists that observation in its track; each track element names an
    /// existing image and 2D point that observes the 3D point.
    pub fn validate(&self) -> Result<()> {
        match self.check() {
            None => Ok(()),
            Some(e) => Err(SceneError::InvalidArgument(format!(
                "COLMAP model: {}: {}: {}",
                e.file.stem(),
                e.element,
                e.message
            ))),
        }
    }

    /// The first broken invariant, if any (see [`Reconstruction::validate`]).
    pub(crate) fn check(&self) -> Option<Inconsistency> {
        let bad = |file: ModelFile, id: u64, message: String| {
            let kind = match file {
                ModelFile::Cameras => "camera",
                ModelFile::Images => "image",
                ModelFile::Points => "point",
            };
            Some(Inconsistency {
                file,
                id,
                element: format!("{kind} {id}"),
                message,
            })
        };
        for cam in self.cameras.values() {
            if let Err(m) = cam.model.check_param_count(cam.params.len()) {
                return bad(ModelFile::Cameras, u64::from(cam.id), m);
            }
        }
        // Track elements naming an image or 2D point that does not exist are
        // points3D problems: check them before the images' references, which
        // would otherwise blame images for a broken track.
        for point in self.points.values() {
            for &(image_id, idx) in &point.track {
                let Some(image) = self.images.get(&image_id) else {
                    return bad(
                        ModelFile::Points,
                        point.id,
                        format!("track refers to unknown image {image_id}"),
                    );
                };
                if image.points2d.get(idx as usize).is_none() {
                    return bad(
                        ModelFile::Points,
                        point.id,
                        format!(
                            "track refers to 2D point {idx} of image {image_id}, which has only {}",
                            image.points2d.len()
                        ),
                    );
                }
            }
        }
        for image in self.images.values() {
            if !self.cameras.contains_key(&image.camera_id) {
                return bad(
                    ModelFile::Images,
                    u64::from(image.id),
                    format!("refers to unknown camera {}", image.camera_id),
                );
            }
            for (idx, p2) in image.points2d.iter().enumerate() {
                let Some(pid) = p2.point3d_id else { continue };
                let listed = self.points.get(&pid).map(|p| {
                    p.track
                        .iter()
                        .any(|&(im, i)| im == image.id && i as usize == idx)
                });
                match listed {
                    Some(true) => {}
                    Some(false) => {
                        return bad(
                            ModelFile::Images,
                            u64::from(image.id),
                            format!(
                            "2D point {idx} observes 3D point {pid}, whose track does not list it"
                        ),
                        )
                    }
                    None => {
                        return bad(
                            ModelFile::Images,
                            u64::from(image.id),
                            format!("2D point {idx} refers to unknown 3D point {pid}"),
                        )
                    }
                }
            }
        }
        for point in self.points.values() {
            for &(image_id, idx) in &point.track {
                // Existence was checked above.
                let Some(p2) = self
                    .images
                    .get(&image_id)
                    .and_then(|im| im.points2d.get(idx as usize))
                else {
                    continue;
                };
                if p2.point3d_id != Some(point.id) {
                    return bad(
                        ModelFile::Points,
                        point.id,
                        format!(
                            "track lists 2D point {idx} of image {image_id}, which observes {}",
                            p2.point3d_id.map_or_else(
                                || "no 3D point".to_string(),
                                |p| format!("3D point {p}")
                            )
                        ),
                    );
                }
            }
        }
        None
    }
}

/// Elements by id, and where each was found in its file: what the text and
/// binary readers both return, so that [`Reconstruction::check`]'s findings
/// can be placed.
pub(crate) type Located<K, V> = (BTreeMap<K, V>, BTreeMap<K, Location>);

/// Inserts an element read at `place`, refusing an id seen before: the one
/// duplicate check of both readers. The error is the message; each reader
/// places it.
pub(crate) fn insert_unique<K: Ord + Copy + std::fmt::Display, V>(
    located: &mut Located<K, V>,
    kind: &str,
    id: K,
    value: V,
    place: Location,
) -> std::result::Result<(), String> {
    if located.0.contains_key(&id) {
        return Err(format!("duplicate {kind} id {id}"));
    }
    located.0.insert(id, value);
    located.1.insert(id, place);
    Ok(())
}

#[cfg(test)]
mod tests {
    use nalgebra::{Point2, Point3};

    use super::*;
    use crate::camera::Intrinsics;

    #[test]
    fn built_models_are_consistent_and_round_trip_through_text() {
        let k = Intrinsics::from_hfov(64, 48, 60.0).unwrap();
        let down = -std::f64::consts::FRAC_PI_2;
        let mut rec = Reconstruction::default();
        let a = rec.add_pinhole_image(
            "a.png",
            &Camera::from_yaw_pitch(k, Point3::new(0.0, 0.0, 10.0), 0.0, down),
        );
        let b = rec.add_pinhole_image(
            "b.png",
            &Camera::from_yaw_pitch(k, Point3::new(1.0, 0.0, 10.0), 0.0, down),
        );
        assert_eq!((a, b), (1, 2));
        let p = Point3::new(0.5, 0.0, 0.0);
        let xy = |id: u32| rec.camera_of(id).unwrap().project(&p).unwrap();
        let obs = [(a, xy(a)), (b, xy(b))];
        assert_eq!(rec.add_point(p, &obs).unwrap(), 1);
        assert_eq!(rec.points[&1].track, vec![(1, 0), (2, 0)]);
        assert_eq!(rec.images[&2].points2d[0].point3d_id, Some(1));
        rec.validate().unwrap();
        // An unknown image is refused and changes nothing.
        let before = rec.clone();
        assert!(rec.add_point(p, &[(7, Point2::new(1.0, 1.0))]).is_err());
        assert_eq!(rec, before);
        let dir = tempfile::tempdir().unwrap();
        super::super::write_text(dir.path(), &rec).unwrap();
        let back = super::super::read_model(dir.path()).unwrap();
        assert_eq!(back.images[&2].name, "b.png");
        assert_eq!(back.points[&1].track, rec.points[&1].track);
    }
}
