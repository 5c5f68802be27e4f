//! The simulated take-off point is a spot an operator could stand on: open
//! ground beside the rock, nothing overhead. `World::home` is what the
//! report's missions and `vpctl sim fly`'s `frame.json` (so the README's
//! loop, `vpctl plan`) take off from.

use nalgebra::{Point3, Vector3};
use vp_scene::geodesy::LocalFrame;
use vp_scene::Material;
use vp_sim::campaign::CampaignConfig;
use vp_sim::world::World;

/// The demo's sites, bare or with a meadow and trees at the rock.
fn config(meadow: f64, trees_at_rock: usize) -> CampaignConfig {
    let mut c = CampaignConfig::quick();
    c.site.meadow = meadow;
    c.site.n_trees_at_rock = trees_at_rock;
    c
}

/// Checks one site's take-off point by rays, not by the clearance query
/// the spot was chosen with: what is straight below it, that nothing
/// overhangs it within the planner's take-off clearance, and that it lies
/// outside the rock's footprint by the region of interest's margin.
fn check(world: &World, margin: f64, label: &str) {
    let home = world.home();
    let frame = LocalFrame::new(world.site.origin).expect("the site's origin is valid");
    let enu = frame.to_enu(home.position);
    let spot = Point3::new(enu[0], enu[1], enu[2]);
    let down = world
        .caster
        .closest_hit(
            &Point3::new(spot.x, spot.y, spot.z + 50.0),
            &-Vector3::z(),
            f64::INFINITY,
        )
        .unwrap_or_else(|| panic!("{label}: nothing below the take-off point {spot:?}"));
    let material = world.site.mesh.material(down.face as usize);
    assert!(
        matches!(material, Some(Material::Ground | Material::Grass)),
        "{label}: the take-off point {spot:?} is on {material:?} ({})",
        home.source
    );
    assert!(
        (down.point.z - spot.z).abs() < 0.05,
        "{label}: {spot:?} is not on the surface below it ({:?})",
        down.point
    );
    // Nothing overhead: rays straight up from the column's rim and centre,
    // from the height the planner checks the column from.
    let r = vp_planner::home_way::TAKEOFF_CLEARANCE_M;
    let from = spot.z + vp_planner::home_way::COLUMN_CHECK_FROM_M;
    for k in 0..=8 {
        let a = f64::from(k) * std::f64::consts::TAU / 8.0;
        let rim = if k == 8 { 0.0 } else { r };
        let o = Point3::new(spot.x + rim * a.cos(), spot.y + rim * a.sin(), from);
        let hit = world.caster.closest_hit(&o, &Vector3::z(), f64::INFINITY);
        assert!(
            hit.is_none(),
            "{label}: something overhangs the take-off point {spot:?} at {:?}",
            hit.map(|h| h.point)
        );
    }
    let rb = world.site.rock_bounds;
    let outside = (rb.min.x - spot.x)
        .max(spot.x - rb.max.x)
        .max(rb.min.y - spot.y)
        .max(spot.y - rb.max.y);
    assert!(
        outside >= margin - 1e-6,
        "{label}: the take-off point {spot:?} is {outside:.2} m outside the rock's footprint"
    );
}

#[test]
fn the_simulated_take_off_point_is_open_ground_beside_the_rock() {
    let mut fallbacks = 0;
    for (meadow, trees) in [(0.0, 0), (1.0, 0), (0.3, 4)] {
        let cfg = config(meadow, trees);
        for seed in 0..16 {
            let world = World::new(&cfg, seed).expect("a site of the quick preset");
            let label = format!("site {seed}, meadow {meadow}, {trees} trees at the rock");
            if world.takeoff_spot().is_none() {
                fallbacks += 1;
                continue;
            }
            check(&world, cfg.roi_margin_m, &label);
        }
    }
    // A site with no open spot on the region's edge falls back to the
    // ground below the origin; the quick preset's sites all have one.
    assert_eq!(fallbacks, 0, "sites without an open take-off spot");
}
