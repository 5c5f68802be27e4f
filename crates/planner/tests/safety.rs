//! The safety invariant: no waypoint and no path segment closer to the mesh
//! than the safety distance; geofence and altitude limits hold.

mod common;

use common::{assert_home_ways, assert_safe, initial_views, site, test_config};
use nalgebra::Point3;
use vp_planner::flight_path::PathContext;
use vp_planner::{safety_for, PlanInputs, PlannerConfig, PlannerError, RoiSpec};
use vp_scene::plan::{AltitudeLimits, Plan, PlannedView, Role};
use vp_scene::procedural::shapes;
use vp_scene::raycast::RayCaster;
use vp_scene::roi::Roi;

/// Plans one random case and checks it; `true` when a plan came out,
/// `false` when the planner refused (safe, but no plan). With `home`, the
/// flights take off at an open spot of the site drawn from the seed, and
/// their ways from and to it are checked too.
fn run_case(
    seed: u64,
    roi_centre: (f64, f64),
    roi_half: f64,
    safety: f64,
    fence_half: f64,
    ceiling: f64,
    home: bool,
) -> bool {
    let s = site(seed, 20_000);
    let home = home
        .then(|| common::open_home(&s.mesh, seed, 0.9 * fence_half, ceiling))
        .flatten();
    let cfg = PlannerConfig {
        seed,
        safety_distance_m: safety,
        geofence: Some(vec![
            [-fence_half, -fence_half],
            [fence_half, -fence_half],
            [fence_half, fence_half],
            [-fence_half, fence_half],
        ]),
        altitude_limits: Some(AltitudeLimits {
            min_m: s.flight_volume.min.z,
            max_m: ceiling,
        }),
        n_surrogates: 400,
        n_triangles: 200,
        n_selected: 40,
        ..test_config(&s)
    };
    let roi = Roi::Box {
        min: [roi_centre.0 - roi_half, roi_centre.1 - roi_half, -100.0],
        max: [roi_centre.0 + roi_half, roi_centre.1 + roi_half, 100.0],
    };
    let acquired = initial_views(&s);
    match vp_planner::plan(&PlanInputs {
        mesh: &s.mesh,
        acquired: &acquired,
        roi: RoiSpec::Region(roi),
        config: &cfg,
        origin: None,
        observations: None,
        home,
    }) {
        Ok(r) => {
            // The vehicle leaves from the last acquired image without a
            // home; with one, from home (its ways are checked below).
            let vehicle = acquired.last().map(|a| a.camera.center());
            assert_safe(&r.plan, &s.mesh, &cfg, vehicle.filter(|_| home.is_none()));
            if let Some(h) = &home {
                assert_home_ways(&r.plan, &s.mesh, &cfg, h);
            }
            if r.plan.waypoints.is_empty() {
                eprintln!(
                    "seed {seed} (home {home:?}): no waypoints: dropped {:?}, cut short: {:?}; \
                     first reason: {:?}",
                    r.dropped_triplets,
                    r.cut_short_reason,
                    r.dropped_reasons.first()
                );
            }
            !r.plan.waypoints.is_empty()
        }
        // Refusing is safe; bad inputs (e.g. no free space under a low
        // ceiling) too. But a planner that always refused would pass the
        // safety checks: `random_cases` counts refusals against a bar.
        Err(e @ (PlannerError::Refused(_) | PlannerError::Input(_))) => {
            eprintln!("seed {seed} (home {home:?}): refused: {e}");
            false
        }
        Err(e) => panic!("unexpected error {e}"),
    }
}

/// Runs `n` random cases (seeded) and returns how many produced a plan;
/// every plan is checked for safety.
fn random_cases(n: usize, seed: u64) -> usize {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .filter(|_| {
            run_case(
                rng.random_range(0..100_000),
                (rng.random_range(-15.0..15.0), rng.random_range(-15.0..15.0)),
                rng.random_range(3.0..12.0),
                rng.random_range(2.0..8.0),
                rng.random_range(18.0..30.0),
                rng.random_range(30.0..60.0),
                rng.random_bool(0.5),
            )
        })
        .count()
}

/// The safety property on 16 random sites (half of them flown from a home),
/// and most of them must give a plan: refusing everything is safe but useless.
#[test]
fn planned_paths_keep_the_safety_distance() {
    let n = 16;
    let planned = random_cases(n, 3);
    println!("{planned} of {n} random cases produced a plan");
    assert!(
        planned * 4 >= n * 3,
        "only {planned} of {n} cases produced a plan"
    );
}

/// The long run of the same property (`cargo test -- --ignored`; a named
/// step of scripts/test.sh).
#[test]
#[ignore = "long: 200 random sites; run by scripts/test.sh"]
fn planned_paths_keep_the_safety_distance_long() {
    let n = 200;
    let planned = random_cases(n, 7);
    println!("{planned} of {n} random cases produced a plan");
    assert!(
        planned * 4 >= n * 3,
        "only {planned} of {n} cases produced a plan"
    );
}

fn wall_scene() -> (vp_scene::Mesh, PlannerConfig) {
    let mut mesh = shapes::plane(100.0, 100.0, 10, 10);
    mesh.append(&shapes::box_mesh(
        Point3::new(-1.0, -50.0, 0.0),
        Point3::new(1.0, 50.0, 20.0),
    ));
    let cfg = PlannerConfig {
        flight_volume: Some([[-50.0, -50.0, 0.0], [50.0, 50.0, 60.0]]),
        safety: vp_planner::SafetyConfig::exact(),
        ..PlannerConfig::default()
    };
    (mesh, cfg)
}

fn view(x: f64, z: f64) -> PlannedView {
    PlannedView {
        position: [x, 0.0, z],
        yaw_deg: 0.0,
        pitch_deg: -90.0,
        roll_deg: 0.0,
        role: Role::TripletMember,
        triplet_id: Some(0),
        expected_gain: None,
        angle_bin_deg: None,
    }
}

/// Runs `f` with the path builder of `mesh` and `cfg` (bridging views when
/// an image overlaps no earlier one by `min_overlap`); `f` also gets the
/// plan to fill, with the altitude limits set, for [`assert_safe`].
fn with_path<R>(
    mesh: &vp_scene::Mesh,
    cfg: &PlannerConfig,
    min_overlap: f64,
    f: impl FnOnce(&PathContext, Plan) -> R,
) -> R {
    let caster = RayCaster::new(mesh);
    let safety = safety_for(mesh, cfg);
    let ctx = PathContext {
        mesh,
        caster: &caster,
        safety: &safety,
        intrinsics: cfg.camera.intrinsics(),
        min_overlap,
        home: None,
    };
    let mut plan = Plan::new(None);
    plan.altitude_limits = Some(safety.altitude);
    f(&ctx, plan)
}

/// The wall scene under a 22 m ceiling: the wall (20 m + the safety
/// distance) cannot be climbed over.
fn wall_under_low_ceiling() -> (vp_scene::Mesh, PlannerConfig) {
    let (mesh, mut cfg) = wall_scene();
    cfg.altitude_limits = Some(AltitudeLimits {
        min_m: 0.0,
        max_m: 22.0,
    });
    (mesh, cfg)
}

#[test]
fn blocked_segment_climbs_over_the_wall() {
    let (mesh, cfg) = wall_scene();
    with_path(&mesh, &cfg, 0.5, |ctx, mut plan| {
        let out = ctx
            .make_safe(&[view(-20.0, 10.0), view(20.0, 10.0)])
            .unwrap();
        assert_eq!(out.len(), 4, "climb and descend waypoints inserted");
        assert!(out[1].position[2] >= 25.0 && out[1].role == Role::Bridge);
        plan.waypoints = out;
        assert_safe(&plan, &mesh, &cfg, None);
    });
}

#[test]
fn blocked_segment_under_a_low_ceiling_refuses_the_plan_naming_it() {
    let (mesh, cfg) = wall_under_low_ceiling();
    with_path(&mesh, &cfg, 0.5, |ctx, _| {
        let e = ctx
            .make_safe(&[view(-30.0, 10.0), view(-20.0, 10.0), view(20.0, 10.0)])
            .unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, PlannerError::Refused(_)), "{msg}");
        assert!(
            msg.contains("segment 1 -> 2") && msg.contains("altitude limit 22.0 m"),
            "{msg}"
        );
    });
}

#[test]
fn a_triplet_behind_an_unclimbable_wall_is_dropped_not_the_plan() {
    let (mesh, cfg) = wall_under_low_ceiling();
    let in_triplet = |x: f64, t: u32| PlannedView {
        triplet_id: Some(t),
        ..view(x, 10.0)
    };
    let start = view(-35.0, 10.0).to_camera(cfg.camera.intrinsics());
    let views = vec![
        in_triplet(-30.0, 0),
        in_triplet(-25.0, 0),
        in_triplet(-20.0, 0),
        in_triplet(20.0, 1),
        in_triplet(25.0, 1),
        in_triplet(30.0, 1),
    ];
    // No bridging views (overlap 0): this test is about routing.
    with_path(&mesh, &cfg, 0.0, |ctx, mut plan| {
        let path = ctx.build(&start, &[], views);
        assert_eq!(path.dropped_triplets, vec![1]);
        // The reason names the blocked view, the waypoint the segment
        // starts at (by its index among the flown waypoints, where an
        // operator finds it) and the limit that stopped the climb, so an
        // operator knows what to change; it named "segment 2 -> 3", an
        // index of the planner's own list that appeared nowhere.
        let why = &path.dropped_reasons[0];
        assert!(
            path.dropped_reasons.len() == 1
                && why.contains("its view at (20.00, 0.00, 10.00)")
                && why.contains("from waypoint 2 (triplet 0) at (-20.00, 0.00, 10.00)")
                && why.contains("altitude limit 22.0 m"),
            "{:?}",
            path.dropped_reasons
        );
        let xs: Vec<f64> = path.waypoints.iter().map(|w| w.position[0]).collect();
        assert_eq!(xs, vec![-30.0, -25.0, -20.0]);
        plan.waypoints = path.waypoints;
        assert_safe(&plan, &mesh, &cfg, None);
    });
}

/// The path's first triplet (the nearest home, where the mission begins)
/// stands behind a wall from home that no climb under the ceiling clears:
/// the mission could not fly out to it. It is dropped like a triplet
/// behind a wall on the path (the plan was refused), and the flight from
/// home to the rest keeps every rule.
#[test]
fn a_first_triplet_unreachable_from_home_is_dropped_not_the_plan() {
    let (_, cfg) = wall_under_low_ceiling();
    // A wall at x = 0 from y = -50 to 0 only: home (20, -20) and
    // triplet 1 (y = 40) on one side, triplet 0 on the other; the path
    // from triplet 0 to triplet 1 goes around the wall's end.
    let mut mesh = shapes::plane(100.0, 100.0, 10, 10);
    mesh.append(&shapes::box_mesh(
        Point3::new(-1.0, -50.0, 0.0),
        Point3::new(1.0, 0.0, 20.0),
    ));
    let home = Point3::new(20.0, -20.0, 0.0);
    let at = |x: f64, y: f64, t: u32| PlannedView {
        position: [x, y, 10.0],
        triplet_id: Some(t),
        ..view(x, 10.0)
    };
    let start = at(-35.0, -20.0, 9).to_camera(cfg.camera.intrinsics());
    let views = vec![
        at(-30.0, -20.0, 0),
        at(-25.0, -20.0, 0),
        at(-20.0, -20.0, 0),
        at(20.0, 40.0, 1),
        at(15.0, 40.0, 1),
        at(25.0, 40.0, 1),
    ];
    with_path(&mesh, &cfg, 0.0, |ctx, mut plan| {
        // Without a home both triplets are flown.
        assert!(ctx.build(&start, &[], views.clone()).dropped.is_empty());
        let ctx = PathContext {
            home: Some(home),
            ..*ctx
        };
        let path = ctx.build(&start, &[], views);
        assert_eq!(path.dropped_triplets, vec![0]);
        let why = &path.dropped_reasons[0];
        assert!(
            why.contains("no safe way between home at (20.00, -20.00, 0.00) and its view at (-20.00, -20.00, 10.00)")
                && why.contains("level leg")
                && why.contains("altitude limit 22.0 m"),
            "{why}"
        );
        let flights = vp_planner::flights::assign_flights(
            ctx.safety,
            Some(&home),
            &path.waypoints,
            &vp_scene::flight_time::FlightParams::default(),
        )
        .unwrap();
        (plan.waypoints, plan.flights) = (flights.waypoints, flights.flights);
        let flown: Vec<_> = plan.waypoints.iter().filter_map(|w| w.triplet_id).collect();
        assert_eq!(flown, vec![1, 1, 1]);
        assert_safe(&plan, &mesh, &cfg, None);
        assert_home_ways(&plan, &mesh, &cfg, &home);
    });
}

#[test]
fn unbridged_images_are_named_by_their_place_in_the_routed_path() {
    let (mesh, cfg) = wall_scene();
    let start = view(-35.0, 10.0).to_camera(cfg.camera.intrinsics());
    let views: Vec<PlannedView> = [-30.0, -25.0, 25.0, 30.0]
        .into_iter()
        .map(|x| view(x, 10.0))
        .collect();
    // No overlap can reach 101 %: every image after the first is unbridged.
    with_path(&mesh, &cfg, 1.01, |ctx, _| {
        let path = ctx.build(&start, &[], views);
        // The wall is climbed between -25 and 25: two detour waypoints there.
        assert_eq!(path.waypoints.len(), 6);
        assert_eq!(path.unbridged, vec![1, 4, 5]);
        for &i in &path.unbridged {
            assert_eq!(path.waypoints[i].role, Role::TripletMember);
        }
    });
}

/// With `unknown_space = "occupied"` every waypoint and segment of a plan
/// keeps the safety distance to space the initial flight never looked
/// through; with `"free"` (the paper) some do not: the risk the default
/// removes. Observed space here: rays from the initial cameras to the mesh.
#[test]
fn occupied_unknown_space_keeps_plans_in_observed_free_space() {
    use vp_planner::free_space::{free_space, observations_from_mesh};
    use vp_planner::UnknownSpace;
    let (mut inside_free_policy, mut plans) = (0, 0);
    for seed in [3, 5, 11] {
        let s = site(seed, 20_000);
        let acquired = initial_views(&s);
        let caster = RayCaster::new(&s.mesh);
        let cams: Vec<_> = acquired.iter().map(|a| a.camera).collect();
        let base = test_config(&s);
        let volume = base.flight_volume_aabb().unwrap();
        let d = base.safety_distance_m;
        let fs = free_space(
            &volume,
            d,
            1.0,
            true,
            &observations_from_mesh(&cams, &caster),
            &cams,
        )
        .unwrap();
        for unknown in [UnknownSpace::Occupied, UnknownSpace::Free] {
            let cfg = PlannerConfig {
                unknown_space: unknown,
                seed,
                ..base.clone()
            };
            let r = common::plan_rock(&s, &acquired, &cfg).unwrap();
            let start = acquired.last().map(|a| a.camera.center());
            let pts: Vec<Point3<f64>> = start
                .into_iter()
                .chain(r.plan.waypoints.iter().map(|w| Point3::from(w.position)))
                .collect();
            let unsafe_legs = pts
                .windows(2)
                .filter(|w| !fs.segment_is_clear(&w[0], &w[1], d))
                .count();
            if unknown == UnknownSpace::Occupied {
                plans += usize::from(!r.plan.waypoints.is_empty());
                assert_eq!(unsafe_legs, 0, "seed {seed}: a leg near unobserved space");
            } else {
                inside_free_policy += unsafe_legs;
            }
        }
    }
    println!(
        "\"free\" policy: {inside_free_policy} legs within the safety distance of unobserved space"
    );
    assert!(
        plans >= 2,
        "only {plans} of 3 sites gave a plan under \"occupied\""
    );
    assert!(
        inside_free_policy > 0,
        "the \"free\" policy never approached unobserved space"
    );
}

/// A random case of [`run_case`] (seed, ROI centre and half-size, safety
/// distance, geofence half-size, ceiling) planned with k = 4.
fn plan_case(
    seed: u64,
    roi_centre: (f64, f64),
    roi_half: f64,
    safety: f64,
    fence_half: f64,
    ceiling: f64,
) -> (vp_planner::PlanResult, vp_scene::Mesh, PlannerConfig) {
    let s = site(seed, 20_000);
    let cfg = PlannerConfig {
        seed,
        safety_distance_m: safety,
        geofence: Some(vec![
            [-fence_half, -fence_half],
            [fence_half, -fence_half],
            [fence_half, fence_half],
            [-fence_half, fence_half],
        ]),
        altitude_limits: Some(AltitudeLimits {
            min_m: s.flight_volume.min.z,
            max_m: ceiling,
        }),
        n_surrogates: 400,
        n_triangles: 200,
        n_selected: 40,
        n_triplets: 4,
        ..test_config(&s)
    };
    let roi = Roi::Box {
        min: [roi_centre.0 - roi_half, roi_centre.1 - roi_half, -100.0],
        max: [roi_centre.0 + roi_half, roi_centre.1 + roi_half, 100.0],
    };
    let acquired = initial_views(&s);
    let r = vp_planner::plan(&PlanInputs {
        mesh: &s.mesh,
        acquired: &acquired,
        roi: RoiSpec::Region(roi),
        config: &cfg,
        origin: None,
        observations: None,
        home: None,
    })
    .unwrap();
    assert_safe(
        &r.plan,
        &s.mesh,
        &cfg,
        acquired.last().map(|a| a.camera.center()),
    );
    (r, s.mesh, cfg)
}

/// The triplet ids the plan's waypoints carry, sorted.
fn flown_triplets(plan: &Plan) -> Vec<u32> {
    let mut ids: Vec<u32> = plan.waypoints.iter().filter_map(|w| w.triplet_id).collect();
    ids.sort_unstable();
    ids.dedup();
    ids
}

/// Every "waypoint N (triplet T)" a reason names is waypoint N of the plan
/// and carries triplet T.
fn assert_reason_names_plan_waypoints(plan: &Plan, reason: &str) {
    for (at, _) in reason.match_indices("waypoint ") {
        let rest = &reason[at + "waypoint ".len()..];
        let n: usize = rest[..rest.find(' ').unwrap()].parse().unwrap();
        let t: u32 = rest[rest.find("(triplet ").unwrap() + 9..rest.find(')').unwrap()]
            .parse()
            .unwrap();
        assert_eq!(plan.waypoints[n].triplet_id, Some(t), "{reason}");
    }
}

/// A triplet dropped as unreachable was not replaced (k = 4 asked, 3
/// flown), and the plan's "mean f" and `statistics.iterations` still
/// counted it: they now count only what is flown.
#[test]
fn a_dropped_triplet_is_replaced_and_the_figures_count_only_what_is_flown() {
    let (r, _, _) = plan_case(
        80_557,
        (-7.936_663_369_069_961, -7.972_792_518_331_621),
        8.606_707_443_950_37,
        7.435_409_014_953_079,
        28.802_337_047_640_44,
        47.597_875_864_562_276,
    );
    let plan = &r.plan;
    assert_eq!(
        plan.dropped_triplets.len(),
        1,
        "{:?}",
        plan.dropped_triplets
    );
    let d = &plan.dropped_triplets[0];
    let by = d.replaced_by.expect("the dropped triplet is replaced");
    // k asked = k flown; the dropped one flies nowhere, its replacement does.
    let flown = flown_triplets(plan);
    assert_eq!(flown.len(), 4, "{flown:?}");
    assert!(!flown.contains(&d.triplet_id) && flown.contains(&by));
    assert!(!plan.cut_short, "{:?}", plan.cut_short_reason);
    // The iteration figures are those of the flown triplets, chained.
    let mut its: Vec<u32> = plan
        .statistics
        .iterations
        .iter()
        .map(|i| i.iteration)
        .collect();
    its.sort_unstable();
    assert_eq!(its, flown);
    for w in plan.statistics.iterations.windows(2) {
        assert_eq!(w[0].f_after.to_bits(), w[1].f_before.to_bits());
    }
    // The last f_after is f(t) with the flown cameras only.
    let mean = r.sampled.iter().map(|t| t.f).sum::<f64>() / r.sampled.len() as f64;
    let last = plan.statistics.iterations.last().unwrap().f_after;
    assert!((last - mean).abs() < 1e-12, "{last} vs {mean}");
    assert_reason_names_plan_waypoints(plan, &d.reason);
    assert!(r.dropped_reasons[0].ends_with(&format!("replaced by triplet {by}")));
}

/// Where no replacement can be flown either, the plan says how many
/// dropped triplets were not replaced and why, and flies what it can.
#[test]
fn dropped_triplets_that_cannot_be_replaced_are_reported() {
    let (r, _, _) = plan_case(
        77_203,
        (-11.832_895_337_498_89, -11.856_656_835_595_022),
        11.894_373_307_855_85,
        7.224_836_834_398_475_5,
        18.655_221_276_537_738,
        54.108_146_887_352_94,
    );
    let plan = &r.plan;
    let flown = flown_triplets(plan);
    assert!(flown.len() < 4 && !flown.is_empty(), "{flown:?}");
    // M3 chose triplets 0-3; a replacement that is dropped too waits for
    // no replacement of its own.
    let unreplaced = plan
        .dropped_triplets
        .iter()
        .filter(|d| d.replaced_by.is_none() && d.triplet_id < 4)
        .count();
    assert_eq!(unreplaced, 4 - flown.len());
    let why = plan.cut_short_reason.as_deref().unwrap_or_default();
    assert!(
        plan.cut_short && why.starts_with(&format!("{unreplaced} dropped triplets not replaced: ")),
        "{why}"
    );
    for d in &plan.dropped_triplets {
        assert!(!flown.contains(&d.triplet_id));
        assert_reason_names_plan_waypoints(plan, &d.reason);
    }
    assert_eq!(plan.statistics.iterations.len(), flown.len());
}
