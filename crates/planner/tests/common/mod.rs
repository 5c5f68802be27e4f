//! Shared fixtures: small procedural sites and an initial grid flight.
#![allow(dead_code)]

use vp_planner::{AcquiredView, PlanInputs, PlanResult, PlannerConfig, RoiSpec};
use vp_scene::procedural::{generate_site, Site, SiteParams};
use vp_scene::roi::Roi;

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

/// The paper's initial flight over the rock (one home for the fixture in
/// `vp-test-support`).
pub use vp_test_support::rock::initial_views;

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
