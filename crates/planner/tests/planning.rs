//! End-to-end planning on small procedural sites.

mod common;

use common::{initial_views, site, test_config};
use vp_planner::{plan, PlanInputs, RoiSpec};
use vp_scene::mesh_ops::Roi;

#[test]
fn planning_raises_mean_fulfilment_on_the_roi() {
    let s = site(1, 30_000);
    let cfg = test_config(&s);
    let acquired = initial_views(&s, &cfg, 40.0, 0.6);
    eprintln!("{} initial views", acquired.len());
    let t = std::time::Instant::now();
    let r = plan(&PlanInputs {
        mesh: &s.mesh,
        acquired: &acquired,
        roi: RoiSpec::Region(Roi::from_aabb(&s.rock_bounds)),
        config: &cfg,
        origin: Some(s.origin),
    })
    .unwrap();
    eprintln!("{:?} {:?} {:?} visited {:?} gains {:?} t {:?}", r.iterations, r.module_time_s, r.cut_short_reason, r.visited, r.triplet_gains, t.elapsed());
    let first = &r.iterations[0];
    let last = r.iterations.last().unwrap();
    assert!(last.f_after > first.f_before, "{first:?} {last:?}");
}

