//! Shared fixtures: small procedural sites and an initial grid flight.
#![allow(dead_code)]

use vp_planner::grid::{grid_views, GridParams};
use vp_planner::{AcquiredView, PlannerConfig};
use vp_scene::plan::Role;
use vp_scene::procedural::{generate_site, Site, SiteParams};

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
        ..PlannerConfig::default()
    }
}

/// The paper's initial flight: a nadir grid at `height` m above the lowest
/// point of the rock, as acquired views without confidence.
pub fn initial_views(site: &Site, cfg: &PlannerConfig, height: f64, overlap: f64) -> Vec<AcquiredView> {
    let params = GridParams {
        height_m: height,
        front_overlap: overlap,
        side_overlap: overlap,
        role: Role::Initial,
        ..GridParams::default()
    };
    let k = cfg.camera.intrinsics();
    grid_views(&site.rock_bounds, &params, k)
        .unwrap()
        .iter()
        .map(|v| AcquiredView {
            camera: v.to_camera(k),
            confidence: None,
        })
        .collect()
}
