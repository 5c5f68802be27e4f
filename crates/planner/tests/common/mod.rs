//! Shared fixtures: small procedural sites and an initial grid flight.
#![allow(dead_code)]

use vp_planner::grid::{grid_views, GridParams};
use vp_planner::{AcquiredView, PlanInputs, PlanResult, PlannerConfig, RoiSpec};
use vp_scene::plan::Role;
use vp_scene::procedural::{generate_site, Site, SiteParams};
use vp_scene::roi::Roi;
use vp_scene::{Aabb, Intrinsics};

/// A small site (about `faces` faces).
pub fn site(seed: u64, faces: usize) -> Site {
    generate_site(&SiteParams {
        seed,
        target_faces: faces,
        ..SiteParams::default()
    })
    .unwrap()
}

/// Small planning parameters for tests, with the site's flight volume.
pub fn test_config(site: &Site) -> PlannerConfig {
    let v = site.flight_volume;
    PlannerConfig {
        n_triangles: 300,
        n_surrogates: 600,
        n_selected: 60,
        n_triplets: 2,
        flight_volume: Some([v.min.into(), v.max.into()]),
        // The tests check exact geometry at the safety distance; the
        // position margin is vp_planner::position's (and vp-sim's
        // position_error test's).
        safety: vp_planner::SafetyConfig::exact(),
        ..PlannerConfig::default()
    }
}

/// Camera of the initial flight: narrower than the planner's default, so a
/// grid at 50 m takes about as many images as the paper's (19).
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

/// The paper's initial flight: a nadir grid 50 m above the lowest point of
/// a 44 m square around the rock, 80 % overlap (18 images).
pub fn initial_views(site: &Site) -> Vec<AcquiredView> {
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
        .unwrap()
        .iter()
        .map(|v| AcquiredView {
            camera: v.to_camera(k),
            confidence: None,
        })
        .collect()
}

/// Plans on `site` with the rock as ROI.
pub fn plan_rock(
    site: &Site,
    acquired: &[AcquiredView],
    cfg: &PlannerConfig,
) -> vp_planner::Result<PlanResult> {
    vp_planner::plan(&PlanInputs {
        mesh: &site.mesh,
        acquired,
        roi: RoiSpec::Region(Roi::from_aabb(&site.rock_bounds)),
        config: cfg,
        origin: Some(site.origin),
        observations: None,
        home: None,
    })
}
