//! The surface points SfM may triangulate, and which of them a set of
//! images gives it.
//!
//! [`SparseCandidates`]: a fixed, seeded sample of the true
//! surface (area-uniform, `sfm.points_per_m2`); an image observes a
//! candidate when it is in the frame, front-facing, unoccluded and a
//! feature detector fires within a pixel of where it projects on the
//! rendered image ([`super::features`]: FAST-9 at OpenCV's default
//! threshold), so untextured or low-contrast surfaces give SfM no points.
//! SfM knows a candidate once at least `sfm.min_views` images observe it,
//! at its position plus seeded noise (`sfm.point_noise_m`), observed from
//! the SfM estimates of those images' centres.

use std::collections::BTreeMap;

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;
use vp_scene::raycast::{RayCaster, FACE_VISIBILITY_EPSILON};
use vp_scene::surface::SurfaceSample;
use vp_scene::{Camera, Mesh};

use super::features::FeatureMask;
use super::point_noise;
use crate::config::CampaignConfig;
use crate::noise::{hash3, unit};
use vp_scene::hash::mix64;

/// The surface points SfM may triangulate, drawn once per world (see the
/// module docs), with the seed of their SfM noise.
#[derive(Debug, Clone)]
pub struct SparseCandidates {
    /// True positions and their faces' normals.
    pub(crate) points: Vec<(Point3<f64>, Vector3<f64>)>,
    /// Seeds the SfM noise: a point's estimate is the same whenever it is
    /// asked for (mesh, free space, depth ranges, every iteration).
    seed: u64,
}

impl SparseCandidates {
    /// The candidates of `mesh`: `points_per_m2` per square metre of
    /// surface in expectation, drawn with `seed`.
    pub fn new(mesh: &Mesh, points_per_m2: f64, seed: u64) -> Self {
        let points = (0..mesh.n_faces())
            .into_par_iter()
            .flat_map_iter(|f| {
                // A face gets floor(area * density) points, one more with the
                // remaining probability: area-uniform in expectation.
                let s = mix64(seed ^ mix64(f as u64 ^ 0x0073_7061_7273));
                let expect = mesh.face_area(f) * points_per_m2;
                let n =
                    expect.floor() as usize + usize::from(unit(hash3(s, 0, 0, 0)) < expect.fract());
                let [a, b, c] = mesh.triangle(f);
                let normal = mesh.face_normal(f);
                (0..n).map(move |i| {
                    let (mut u, mut v) = (
                        unit(hash3(s, 1, i as i64, 0)),
                        unit(hash3(s, 2, i as i64, 0)),
                    );
                    if u + v > 1.0 {
                        (u, v) = (1.0 - u, 1.0 - v);
                    }
                    (a + (b - a) * u + (c - a) * v, normal)
                })
            })
            .collect();
        SparseCandidates { points, seed }
    }

    /// The candidates of the site of `site_seed` in the campaign `cfg`
    /// (held-out or training site alike).
    pub fn of_site(mesh: &Mesh, cfg: &CampaignConfig, site_seed: u64) -> Self {
        let seed = mix64(cfg.seed ^ mix64(site_seed ^ 0x0073_666d));
        Self::new(mesh, cfg.sfm.points_per_m2, seed)
    }

    /// Number of candidates.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Per candidate, whether the image of the true camera `truth` with
    /// detector response `features` observes it: in the frame,
    /// front-facing, unoccluded, and a corner within a pixel of its
    /// projection.
    pub fn observed(
        &self,
        caster: &RayCaster,
        truth: &Camera,
        features: &FeatureMask,
    ) -> Vec<bool> {
        let c = truth.center();
        let probes: Vec<Point3<f64>> = self
            .points
            .iter()
            .map(|(p, n)| p + n * FACE_VISIBILITY_EPSILON)
            .collect();
        let vis = caster.visible_points(truth, &probes);
        self.points
            .iter()
            .zip(vis)
            .map(|((p, n), v)| {
                v && n.dot(&(c - p)) > 0.0
                    && truth
                        .project_in_frame(p)
                        .is_some_and(|px| features.fires_near(&px))
            })
            .collect()
    }

    /// SfM of one image set: every candidate at least `min_views` of the
    /// images observe, as (candidate index, noisy position, indices of the
    /// observing images). `images` are the true cameras with the detector
    /// response of their renders.
    pub fn tracks(
        &self,
        caster: &RayCaster,
        images: &[(&Camera, &FeatureMask)],
        min_views: usize,
        sigma_m: f64,
    ) -> Vec<(usize, Point3<f64>, Vec<usize>)> {
        let mut seen: Vec<Vec<usize>> = vec![Vec::new(); self.points.len()];
        for (v, (cam, features)) in images.iter().enumerate() {
            for (s, o) in seen.iter_mut().zip(self.observed(caster, cam, features)) {
                if o {
                    s.push(v);
                }
            }
        }
        seen.into_iter()
            .enumerate()
            .filter(|(_, s)| s.len() >= min_views.max(2))
            .map(|(i, s)| (i, self.noisy(i, sigma_m), s))
            .collect()
    }

    /// SfM's estimate of candidate `i`: its position plus seeded noise.
    pub(crate) fn noisy(&self, i: usize, sigma_m: f64) -> Point3<f64> {
        let p = &self.points[i].0;
        p + point_noise(mix64(self.seed ^ 0x0070_6e6f_6973), p, sigma_m)
    }
}

/// The depth range of each image of a set from the sparse points it
/// observes ([`SparseCandidates::tracks`]), seen from the image's SfM
/// camera `sfm[v]`, by COLMAP's rule ([`super::features::colmap_depth_range`]).
pub fn sparse_depth_ranges(
    tracks: &[(usize, Point3<f64>, Vec<usize>)],
    sfm: &[&Camera],
) -> Vec<Option<(f64, f64)>> {
    let mut depths: Vec<Vec<f64>> = vec![Vec::new(); sfm.len()];
    for (_, p, views) in tracks {
        for &v in views {
            depths[v].push((sfm[v].cam_from_world() * p).z);
        }
    }
    depths
        .into_iter()
        .map(super::features::colmap_depth_range)
        .collect()
}

/// Adds a triplet's sparse points (SfM of its images, `campaign::reconstruct::TripletRun::sparse`)
/// to the site's, each candidate once, observed from the SfM centres
/// `sfm_centres` of the views that see it.
pub fn track_samples(
    sparse: &[(usize, Point3<f64>, Vec<usize>)],
    sfm_centres: &[Point3<f64>; 3],
    out: &mut BTreeMap<usize, SurfaceSample>,
) {
    for (i, p, views) in sparse {
        let e = out.entry(*i).or_insert_with(|| SurfaceSample {
            position: *p,
            normal: None,
            seen_from: Vec::new(),
        });
        e.seen_from.extend(views.iter().map(|&v| sfm_centres[v]));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vp_scene::raster::RgbImage;
    use vp_scene::Material;

    /// Issue 34: SfM's sparse points came from exact visibility on the true
    /// mesh whatever the texture. Now an image observes a candidate only
    /// where a feature detector fires on it: a flat, untextured image of
    /// the same view observes none, the rendered (textured) one many.
    #[test]
    fn sparse_points_need_texture_where_the_detector_fires() {
        let mesh = crate::test_scenes::uniform_plane(60.0, Material::Ground);
        let caster = RayCaster::new(&mesh);
        let candidates = SparseCandidates::new(&mesh, 0.5, 3);
        let k = crate::test_scenes::intrinsics(240, 160);
        let cam = Camera::from_yaw_pitch(
            k,
            Point3::new(30.0, 30.0, 25.0),
            0.0,
            -std::f64::consts::FRAC_PI_2,
        );
        let rp = crate::render::RenderParams {
            texture_seed: 5,
            ..crate::render::RenderParams::default()
        };
        let textured = crate::render::render(&mesh, &caster, &cam, &rp).unwrap();
        let flat = RgbImage::from_pixel(240, 160, image::Rgb([120, 110, 90]));
        let count = |img: &RgbImage| {
            let mask = FeatureMask::detect(img);
            candidates
                .observed(&caster, &cam, &mask)
                .into_iter()
                .filter(|&o| o)
                .count()
        };
        let in_view = candidates
            .points
            .iter()
            .filter(|(p, _)| cam.project_in_frame(p).is_some())
            .count();
        assert_eq!(count(&flat), 0, "sparse points on an untextured surface");
        let on_texture = count(&textured.rgb);
        assert!(
            on_texture > in_view / 4 && on_texture <= in_view,
            "{on_texture} of {in_view} candidates in view observed on the textured render"
        );
        // Tracks need two observing images.
        let mask = FeatureMask::detect(&textured.rgb);
        let one = candidates.tracks(&caster, &[(&cam, &mask)], 2, 0.0);
        assert!(one.is_empty());
        let two = candidates.tracks(&caster, &[(&cam, &mask), (&cam, &mask)], 2, 0.0);
        assert_eq!(two.len(), on_texture);
    }

    /// COLMAP's rule over the depths each view's sparse points have in its
    /// SfM camera, and no range for a view without points.
    #[test]
    fn depth_ranges_come_from_each_views_sparse_points() {
        let k = crate::test_scenes::intrinsics(64, 48);
        let down = |z: f64| {
            Camera::from_yaw_pitch(
                k,
                Point3::new(0.0, 0.0, z),
                0.0,
                -std::f64::consts::FRAC_PI_2,
            )
        };
        let (a, b, c) = (down(10.0), down(20.0), down(30.0));
        let tracks: Vec<(usize, Point3<f64>, Vec<usize>)> = (0..4)
            .map(|i| (i, Point3::new(0.0, 0.0, f64::from(i as u32)), vec![0, 1]))
            .collect();
        let r = sparse_depth_ranges(&tracks, &[&a, &b, &c]);
        // View 0 at 10 m: depths 7..10; view 1 at 20 m: 17..20.
        let close = |r: Option<(f64, f64)>, lo: f64, hi: f64| {
            r.is_some_and(|(a, b)| (a - lo).abs() < 1e-9 && (b - hi).abs() < 1e-9)
        };
        assert!(close(r[0], 7.0 * 0.75, 10.0 * 1.25), "{:?}", r[0]);
        assert!(close(r[1], 17.0 * 0.75, 20.0 * 1.25), "{:?}", r[1]);
        assert_eq!(r[2], None);
    }
}
