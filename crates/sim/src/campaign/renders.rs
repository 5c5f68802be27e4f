//! The renders of one site's cameras, each made once (issue 36: a campaign
//! rendered every acquired image twice, once to acquire it and once to
//! match it).
//!
//! A render is a pure function of the mesh, the camera and the render
//! parameters (the sensor noise is seeded by the camera's pose), so a kept
//! render is byte for byte the one a second call would make. What is kept
//! is for the caller to bound: every runner clears the store where its
//! renders will not be asked for again (after a flight is acquired and
//! reconstructed, after a random triplet's levels).

use std::collections::HashMap;

use vp_scene::Camera;

use crate::config::CampaignConfig;
use crate::error::Result;
use crate::render::{render, RenderParams, Rendered};
use crate::sfm::FeatureMask;
use crate::world::Scene;

/// One camera's image as the simulated drone took it: the render (from the
/// TRUE camera) and where FAST fires on it.
pub struct Shot {
    /// The render, with the renderer's depth and face per pixel.
    pub image: Rendered,
    /// Where FAST fires on `image.rgb` (which sparse points SfM gets from it).
    pub features: FeatureMask,
}

/// A camera's exact bits: its size, intrinsics and pose (rotation
/// quaternion, translation). Two cameras with equal keys render the same
/// bytes; any difference, even -0.0 against 0.0, only costs a render.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
struct CameraKey([u64; 13]);

impl CameraKey {
    fn of(cam: &Camera) -> Self {
        let k = &cam.intrinsics;
        let q = cam.world_from_cam.rotation.coords;
        let t = cam.world_from_cam.translation.vector;
        CameraKey([
            u64::from(k.width),
            u64::from(k.height),
            k.fx.to_bits(),
            k.fy.to_bits(),
            k.cx.to_bits(),
            k.cy.to_bits(),
            q.x.to_bits(),
            q.y.to_bits(),
            q.z.to_bits(),
            q.w.to_bits(),
            t.x.to_bits(),
            t.y.to_bits(),
            t.z.to_bits(),
        ])
    }
}

/// The scene and the shots of its cameras kept so far. The render
/// parameters are fixed here, from the campaign's `render` with the
/// scene's texture seed, so that every shot of one store is of the same
/// parameters and the camera alone tells two shots apart.
///
/// # Memory
/// A kept shot costs 12 bytes a pixel (RGB 3, depth 4, face 4, feature
/// mask 1): 460 kB at the demo's and paper's 240 x 160.
pub struct Renders<'a> {
    scene: Scene<'a>,
    params: RenderParams,
    kept: HashMap<CameraKey, Shot>,
}

impl<'a> Renders<'a> {
    /// An empty store of `scene`'s shots with `cfg`'s render parameters.
    pub fn new(scene: Scene<'a>, cfg: &CampaignConfig) -> Self {
        Renders {
            scene,
            params: RenderParams {
                texture_seed: scene.texture_seed,
                ..cfg.render.clone()
            },
            kept: HashMap::new(),
        }
    }

    /// The scene the shots are of.
    pub fn scene(&self) -> &Scene<'a> {
        &self.scene
    }

    /// The shots of `cams` (true cameras), in their order: the kept ones,
    /// and the others rendered now and kept.
    pub fn shots<'s>(&'s mut self, cams: &[&Camera]) -> Result<Vec<&'s Shot>> {
        for cam in cams {
            let key = CameraKey::of(cam);
            if !self.kept.contains_key(&key) {
                let image = render(self.scene.mesh, self.scene.caster, cam, &self.params)?;
                let features = FeatureMask::detect(&image.rgb);
                self.kept.insert(key, Shot { image, features });
            }
        }
        Ok(cams
            .iter()
            .map(|cam| &self.kept[&CameraKey::of(cam)])
            .collect())
    }

    /// How many shots are kept.
    pub fn len(&self) -> usize {
        self.kept.len()
    }

    /// Whether no shot is kept.
    pub fn is_empty(&self) -> bool {
        self.kept.is_empty()
    }

    /// Drops every kept shot (their cameras will not be asked for again).
    pub fn clear(&mut self) {
        self.kept.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sfm::SparseCandidates;
    use crate::test_scenes::{intrinsics, tiled_plane, triplet};
    use vp_scene::raycast::RayCaster;

    /// A kept shot must be the bytes a fresh render would give, or the
    /// campaign's outputs would change with the store.
    #[test]
    fn a_kept_shot_has_the_bytes_of_a_fresh_render_and_is_made_once() {
        let mesh = tiled_plane(20.0, 2.0);
        let caster = RayCaster::new(&mesh);
        let cfg = CampaignConfig::quick();
        let candidates = SparseCandidates::new(&mesh, cfg.sfm.points_per_m2, 11);
        let scene = Scene {
            mesh: &mesh,
            caster: &caster,
            texture_seed: 9,
            candidates: &candidates,
        };
        let cams = triplet(intrinsics(48, 32), 15.0, 20.0);
        let mut renders = Renders::new(scene, &cfg);
        let first: Vec<Rendered> = renders
            .shots(&[&cams[0], &cams[1]])
            .unwrap()
            .iter()
            .map(|s| s.image.clone())
            .collect();
        assert_eq!(renders.len(), 2);
        // Asked again, with one new camera: one more render, the kept two as they were.
        let again = renders.shots(&[&cams[1], &cams[2], &cams[0]]).unwrap();
        assert_eq!(again[0].image, first[1]);
        assert_eq!(again[2].image, first[0]);
        assert_eq!(renders.len(), 3);
        let params = RenderParams {
            texture_seed: 9,
            ..cfg.render.clone()
        };
        for cam in &cams {
            let fresh = render(&mesh, &caster, cam, &params).unwrap();
            let kept = &renders.shots(&[cam]).unwrap()[0];
            assert_eq!(kept.image, fresh);
            assert_eq!(kept.features, FeatureMask::detect(&fresh.rgb));
        }
        renders.clear();
        assert!(renders.is_empty());
    }
}
