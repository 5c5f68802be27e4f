use std::path::PathBuf;

use vp_scene::plan::{Flight, GeodeticOrigin, Home, PlannedView};

use super::*;

/// A 40 m x 30 m slope rising to the east, 10 x 10 squares.
fn slope() -> Mesh {
    let mut vertices = Vec::new();
    let mut faces = Vec::new();
    for j in 0..=10 {
        for i in 0..=10 {
            let (x, y) = (4.0 * f64::from(i), 3.0 * f64::from(j));
            vertices.push(Point3::new(x, y, 0.2 * x));
        }
    }
    for j in 0..10u32 {
        for i in 0..10u32 {
            let a = j * 11 + i;
            faces.push([a, a + 1, a + 12]);
            faces.push([a, a + 12, a + 11]);
        }
    }
    Mesh::new(vertices, faces, None).unwrap()
}

fn view_at(x: f64, y: f64, z: f64, role: Role) -> PlannedView {
    PlannedView {
        position: [x, y, z],
        yaw_deg: 90.0,
        pitch_deg: -60.0,
        roll_deg: 0.0,
        role,
        triplet_id: (role == Role::TripletMember).then_some(0),
        expected_gain: None,
        angle_bin_deg: None,
    }
}

/// Two flights of three triplet views each, home at the origin's foot.
fn triplet_plan() -> Plan {
    let origin = GeodeticOrigin::default();
    let mut plan = Plan::new(Some(origin));
    plan.home = Some(Home::origin_on_ground(origin));
    plan.waypoints = vec![
        view_at(10.0, 5.0, 20.0, Role::TripletMember),
        view_at(20.0, 8.0, 22.0, Role::TripletMember),
        view_at(30.0, 5.0, 24.0, Role::TripletMember),
        view_at(30.0, 25.0, 30.0, Role::TripletMember),
        view_at(20.0, 22.0, 28.0, Role::Bridge),
        view_at(10.0, 25.0, 26.0, Role::TripletMember),
    ];
    plan.flights = [0..3, 3..6]
        .into_iter()
        .map(|r| Flight {
            waypoints: r.collect(),
            distance_m: 0.0,
            duration_s: 0.0,
            from_home: true,
        })
        .collect();
    plan
}

fn view<'a>(mesh: &'a Mesh, plan: &'a Plan, f: &'a [(Point3<f64>, f64)]) -> TopView<'a> {
    TopView {
        mesh,
        fulfillment: f,
        roi_outline: &[[2.0, 2.0], [38.0, 2.0], [38.0, 28.0], [2.0, 28.0]],
        plan,
        acquired: &[],
        size: 320,
    }
}

fn texts(marks: &[Mark]) -> Vec<&str> {
    marks
        .iter()
        .filter_map(|m| match m {
            Mark::Text(t) => Some(t.as_str()),
            _ => None,
        })
        .collect()
}

#[test]
fn plan_view_marks_home_numbers_waypoints_in_flight_order_and_arrows_each_leg() {
    let mesh = slope();
    let plan = triplet_plan();
    let samples = [(Point3::new(20.0, 15.0, 4.0), 0.4)];
    let pic = top_view(&view(&mesh, &plan, &samples));
    assert_eq!(pic.kind, ViewKind::PlanOverFulfillment);
    let homes: Vec<_> = pic
        .marks
        .iter()
        .filter(|m| matches!(m, Mark::Home { .. }))
        .collect();
    assert_eq!(homes.len(), 1, "{:?}", pic.marks);
    // The home sits at the origin (x = y = 0), the map's lower left corner.
    let Mark::Home { at } = homes[0] else {
        unreachable!()
    };
    let h = f64::from(pic.image.height());
    assert!(at.0 < 20.0 && at.1 < h, "{at:?}");
    let numbers: Vec<(usize, f64, bool)> = pic
        .marks
        .iter()
        .filter_map(|m| match m {
            Mark::Waypoint {
                number,
                altitude_m,
                labelled,
                ..
            } => Some((*number, *altitude_m, *labelled)),
            _ => None,
        })
        .collect();
    assert_eq!(
        numbers.iter().map(|n| n.0).collect::<Vec<_>>(),
        [1, 2, 3, 4, 5, 6]
    );
    assert!(
        numbers.iter().all(|n| n.2),
        "all spread out, all numbered: {numbers:?}"
    );
    // Altitudes above home: home is at the origin's altitude, z = 0.
    assert!((numbers[0].1 - 20.0).abs() < 1e-6 && (numbers[3].1 - 30.0).abs() < 1e-6);
    // An arrow on each leg inside a flight, none between the flights.
    let arrows: Vec<usize> = pic
        .marks
        .iter()
        .filter_map(|m| match m {
            Mark::Arrow { from } => Some(*from),
            _ => None,
        })
        .collect();
    assert_eq!(arrows, [1, 2, 4, 5]);
    let legs = pic
        .marks
        .iter()
        .filter(|m| matches!(m, Mark::HomeLeg { .. }))
        .count();
    assert_eq!(legs, 4, "out and back for each of two flights");
    let t = texts(&pic.marks);
    assert!(
        t[0].contains("6 waypoints") && t[0].contains("2 flights"),
        "{t:?}"
    );
    assert!(
        t.iter()
            .any(|l| l.contains("path altitude above home 20 m .. 30 m")),
        "{t:?}"
    );
    assert!(t.iter().any(|l| l.contains("H home")), "{t:?}");
}

#[test]
fn each_kind_of_view_has_its_own_footer() {
    let mesh = slope();
    let triplets = triplet_plan();
    let samples = [(Point3::new(20.0, 15.0, 4.0), 0.4)];
    // A triplet plan drawn without f(t) (the campaign's plan views).
    let pic = top_view(&view(&mesh, &triplets, &[]));
    assert_eq!(pic.kind, ViewKind::Plan);
    let all = texts(&pic.marks).join("\n");
    assert!(
        !all.contains("grid plan") && !all.contains("no f(t)"),
        "{all}"
    );
    assert!(all.contains("f(t) not drawn"), "{all}");
    // A fulfillment map: no waypoint count, no plan legend.
    let empty = Plan::new(None);
    let pic = top_view(&view(&mesh, &empty, &samples));
    assert_eq!(pic.kind, ViewKind::FulfillmentMap);
    let all = texts(&pic.marks).join("\n");
    assert!(
        !all.contains("waypoint") && !all.contains("flight order"),
        "{all}"
    );
    assert!(
        all.starts_with("fulfillment map: f(t) of 1 sampled triangles"),
        "{all}"
    );
    assert!(!pic
        .marks
        .iter()
        .any(|m| matches!(m, Mark::Home { .. } | Mark::Waypoint { .. })));
    // A grid plan without home says so, and numbers its views.
    let mut grid = Plan::new(None);
    grid.waypoints = (0..4)
        .map(|i| view_at(5.0 + 10.0 * f64::from(i), 15.0, 25.0, Role::Grid))
        .collect();
    let pic = top_view(&view(&mesh, &grid, &[]));
    assert_eq!(pic.kind, ViewKind::GridPlan);
    let all = texts(&pic.marks).join("\n");
    assert!(
        all.starts_with("grid plan: 4 waypoints in 1 flight"),
        "{all}"
    );
    assert!(
        all.contains("a grid plan has no f(t)") && all.contains("no home in the plan"),
        "{all}"
    );
    assert!(
        all.contains("path height z (no home) 25 m .. 25 m"),
        "{all}"
    );
}

#[test]
fn crowded_numbers_are_thinned_but_the_first_and_last_stay() {
    let mesh = slope();
    let mut plan = Plan::new(None);
    // 30 views 0.2 m apart: their numbers would overlap.
    plan.waypoints = (0..30)
        .map(|i| view_at(10.0 + 0.2 * f64::from(i), 15.0, 20.0, Role::TripletMember))
        .collect();
    let pic = top_view(&view(&mesh, &plan, &[]));
    let labelled: Vec<usize> = pic
        .marks
        .iter()
        .filter_map(|m| match m {
            Mark::Waypoint {
                number,
                labelled: true,
                ..
            } => Some(*number),
            _ => None,
        })
        .collect();
    assert!(labelled.len() < 10, "{labelled:?}");
    assert_eq!(labelled.first(), Some(&1));
    assert_eq!(labelled.last(), Some(&30));
}

/// The golden picture of [`triplet_plan`] over one f(t) sample; after a
/// deliberate change of the drawing, look at the new picture and refresh it with
/// `VP_PLANNER_UPDATE_GOLDEN=1 cargo test -p vp-planner top_view`.
#[test]
fn plan_view_equals_its_golden_png() {
    let mesh = slope();
    let plan = triplet_plan();
    let samples = [(Point3::new(20.0, 15.0, 4.0), 0.4)];
    let img = render_top_view(&view(&mesh, &plan, &samples));
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/top_view_golden.png");
    if std::env::var_os("VP_PLANNER_UPDATE_GOLDEN").is_some() {
        img.save(&path).unwrap();
    }
    let want = image::open(&path)
        .unwrap_or_else(|e| {
            panic!(
                "{}: {e}; make it with VP_PLANNER_UPDATE_GOLDEN=1",
                path.display()
            )
        })
        .to_rgb8();
    assert_eq!(img.dimensions(), want.dimensions());
    let differ = img
        .pixels()
        .zip(want.pixels())
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(differ, 0, "{differ} pixels differ from {}", path.display());
}

#[test]
fn faces_take_the_f_of_the_nearest_sample_and_far_faces_stay_unshaded() {
    // A strip of 10 unit squares along x; samples on the first two only.
    let mut vertices = Vec::new();
    let mut faces = Vec::new();
    for i in 0..=10 {
        vertices.push(Point3::new(f64::from(i), 0.0, 0.0));
        vertices.push(Point3::new(f64::from(i), 1.0, 0.0));
    }
    for i in 0..10u32 {
        let (a, b, c, d) = (2 * i, 2 * i + 2, 2 * i + 3, 2 * i + 1);
        faces.push([a, b, c]);
        faces.push([a, c, d]);
    }
    let mesh = Mesh::new(vertices, faces, None).unwrap();
    let samples = [
        (Point3::new(0.5, 0.5, 0.0), 0.2),
        (Point3::new(1.5, 0.5, 0.0), 0.9),
    ];
    let f = face_fulfillment(&mesh, &samples);
    assert_eq!(f[0], Some(0.2));
    assert_eq!(f[2], Some(0.9));
    assert_eq!(f[19], None, "9 m from any sample");
    assert!(face_fulfillment(&mesh, &[]).iter().all(Option::is_none));
}
