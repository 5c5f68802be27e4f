//! Shared fixtures: small procedural sites and an initial grid flight.
#![allow(dead_code)]

use nalgebra::{Point2, Point3, Vector3};
use vp_planner::home_way::{COLUMN_CHECK_FROM_M, TAKEOFF_CLEARANCE_M};
use vp_planner::{AcquiredView, PlanInputs, PlanResult, PlannerConfig, RoiSpec};
use vp_scene::clearance::Clearance;
use vp_scene::plan::Plan;
use vp_scene::procedural::{generate_site, Site, SiteParams};
use vp_scene::raycast::RayCaster;
use vp_scene::roi::{point_in_polygon, Roi};

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

/// Exact distances (parry), not the bounded checks the planner uses; the
/// first segment leads from `start` (the vehicle's position) when given.
pub fn assert_safe(
    plan: &Plan,
    mesh: &vp_scene::Mesh,
    cfg: &PlannerConfig,
    start: Option<Point3<f64>>,
) {
    let c = Clearance::new(mesh);
    let d = cfg.safety_distance_m;
    let lim = plan.altitude_limits.unwrap();
    for (i, w) in plan.waypoints.iter().enumerate() {
        let p = Point3::from(w.position);
        assert!(
            c.distance(&p) >= d,
            "waypoint {i} at {p:?}: {} m",
            c.distance(&p)
        );
        assert!(
            p.z >= lim.min_m && p.z <= lim.max_m,
            "waypoint {i} altitude {}",
            p.z
        );
        if let Some(g) = &plan.geofence {
            assert!(
                point_in_polygon(&Point2::new(p.x, p.y), g),
                "waypoint {i} outside the geofence"
            );
        }
    }
    for (i, s) in plan.waypoints.windows(2).enumerate() {
        let (a, b) = (Point3::from(s[0].position), Point3::from(s[1].position));
        let dist = c.segment_distance(&a, &b);
        assert!(dist >= d, "segment {i}: {dist} m");
    }
    if let (Some(a), Some(w)) = (start, plan.waypoints.first()) {
        let dist = c.segment_distance(&a, &Point3::from(w.position));
        assert!(dist >= d, "leg from the vehicle: {dist} m");
    }
}

/// Exact distances again, for the ways between `home` and each flight's
/// first and last waypoints as the vehicle flies them: the column straight
/// up from home keeps the take-off clearance, the level leg at the
/// waypoint's height keeps the safety distance (a transit view, when the
/// plan has one, is that first or last waypoint).
pub fn assert_home_ways(
    plan: &Plan,
    mesh: &vp_scene::Mesh,
    cfg: &PlannerConfig,
    home: &Point3<f64>,
) {
    let c = Clearance::new(mesh);
    let base = home + Vector3::z() * COLUMN_CHECK_FROM_M;
    for (f, flight) in plan.flights.iter().enumerate() {
        assert!(flight.from_home, "flight {f} does not start at home");
        let ends = [flight.waypoints.first(), flight.waypoints.last()];
        for &i in ends.into_iter().flatten() {
            let w = Point3::from(plan.waypoints[i].position);
            let above = Point3::new(base.x, base.y, w.z.max(base.z));
            let column = c.segment_distance(&base, &above);
            assert!(
                column >= TAKEOFF_CLEARANCE_M,
                "flight {f}: the climb from home to waypoint {i} comes {column} m from the mesh"
            );
            let leg = c.segment_distance(&above, &w);
            assert!(
                leg >= cfg.safety_distance_m,
                "flight {f}: the level leg between home and waypoint {i} comes {leg} m from the mesh"
            );
        }
    }
}

/// A take-off point on the bare ground of `mesh`, drawn from `seed` within
/// `half` of the origin, where nothing overhangs the climb to `ceiling`
/// (an operator picks an open spot); `None` after 50 draws.
pub fn open_home(mesh: &vp_scene::Mesh, seed: u64, half: f64, ceiling: f64) -> Option<Point3<f64>> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x686f_6d65);
    let (caster, c) = (RayCaster::new(mesh), Clearance::new(mesh));
    (0..50).find_map(|_| {
        let (x, y) = (rng.random_range(-half..half), rng.random_range(-half..half));
        let hit = caster.closest_hit(&Point3::new(x, y, 1000.0), &-Vector3::z(), f64::INFINITY)?;
        if mesh.material(hit.face as usize) != Some(vp_scene::Material::Ground) {
            return None;
        }
        let base = hit.point + Vector3::z() * COLUMN_CHECK_FROM_M;
        let clear =
            c.segment_distance(&base, &Point3::new(x, y, ceiling)) >= 2.0 * TAKEOFF_CLEARANCE_M;
        clear.then_some(hit.point)
    })
}
