//! The paper's initial flight over the procedural rock: what the planner
//! starts from in its tests, its bench and the CLI tests.

use vp_planner::grid::{grid_views, GridParams};
use vp_planner::AcquiredView;
use vp_scene::plan::Role;
use vp_scene::procedural::Site;
use vp_scene::{Aabb, Camera, Intrinsics};

/// Camera of the initial flight: narrower than the planner's default, so a
/// grid at 50 m takes about as many images as the paper's (19).
#[must_use]
pub fn initial_intrinsics() -> Intrinsics {
    Intrinsics {
        width: 1200,
        height: 800,
        fx: 1800.0,
        fy: 1800.0,
        cx: 600.0,
        cy: 400.0,
    }
}

/// The cameras of the paper's initial flight: a nadir grid 50 m above the
/// lowest point of a 44 m square around the rock, 80 % overlap (18 images
/// on the test sites), with [`initial_intrinsics`].
#[must_use]
pub fn initial_cameras(site: &Site) -> Vec<Camera> {
    let params = GridParams {
        height_m: 50.0,
        front_overlap: 0.8,
        side_overlap: 0.8,
        role: Role::Initial,
        ..GridParams::default()
    };
    let b = site.rock_bounds;
    let c = nalgebra::center(&b.min, &b.max);
    let fp = Aabb {
        min: nalgebra::Point3::new(c.x - 22.0, c.y - 22.0, b.min.z),
        max: nalgebra::Point3::new(c.x + 22.0, c.y + 22.0, b.max.z),
    };
    let k = initial_intrinsics();
    grid_views(&fp, &params, k)
        .expect("the initial grid over the rock")
        .iter()
        .map(|v| v.to_camera(k))
        .collect()
}

/// [`initial_cameras`] as acquired views without confidence, as the planner
/// takes them.
#[must_use]
pub fn initial_views(site: &Site) -> Vec<AcquiredView> {
    initial_cameras(site)
        .into_iter()
        .map(|camera| AcquiredView {
            camera,
            confidence: None,
        })
        .collect()
}
