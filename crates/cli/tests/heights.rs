//! Mission heights: relative altitudes are heights above the take-off
//! point, never above the plan's origin. Regression of a real-photo run
//! where `colmap align` put the origin at the first photo, 40 m up, and
//! `mission export` wrote every waypoint 10-18 m below the launch point.

use std::path::Path;

use vp_scene::plan::{GeodeticOrigin, Home, Plan, PlannedView, Role, VerticalDatum};

mod common;
use common::vpctl;

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// The origin of `colmap align`: the first photo's GPS position, in the air.
const AIRBORNE: GeodeticOrigin = GeodeticOrigin {
    lat_deg: 50.82,
    lon_deg: -0.14,
    alt_m: 198.3,
};

/// A plan whose waypoints fly 22-30 m above ground, with the ground 40 m
/// below the origin: ENU z from -18 to -10, as the real-photo run planned.
fn airborne_plan(z: &[f64]) -> Plan {
    let mut plan = Plan::new(Some(AIRBORNE));
    plan.vertical_datum = Some(VerticalDatum::Egm96);
    for (i, &z) in z.iter().enumerate() {
        plan.waypoints.push(PlannedView {
            position: [i as f64 * 8.0, 4.0, z],
            yaw_deg: 90.0,
            pitch_deg: -60.0,
            roll_deg: 0.0,
            role: Role::TripletMember,
            triplet_id: Some(0),
            expected_gain: None,
            angle_bin_deg: None,
        });
    }
    plan
}

fn save(plan: &Plan, path: &Path) -> String {
    plan.save(path, true).unwrap();
    path.to_str().unwrap().to_string()
}

/// Heights above home of the waypoints (MAV_CMD_NAV_WAYPOINT = 16) of a QGC plan.
fn waypoint_heights(qgc: &Path) -> Vec<f64> {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(qgc).unwrap()).unwrap();
    v["mission"]["items"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|i| i["command"] == 16)
        .map(|i| i["params"][6].as_f64().unwrap())
        .collect()
}

#[test]
fn an_airborne_origin_without_home_is_refused_and_a_home_gives_heights_above_ground() {
    let dir = tempfile::tempdir().unwrap();
    let plan = save(
        &airborne_plan(&[-18.0, -14.0, -10.0]),
        &dir.path().join("p.json"),
    );
    let out = dir.path().join("m.plan");
    let o = vpctl(&["mission", "export", &plan, "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    let e = text(&o.stderr);
    assert!(
        e.contains("p.json") && e.contains("no home") && e.contains("--home"),
        "{e}"
    );
    assert!(!out.exists(), "nothing written");

    // The launch point, 40 m below the first photo.
    let home = format!(
        "{},{},{}",
        AIRBORNE.lat_deg,
        AIRBORNE.lon_deg,
        AIRBORNE.alt_m - 40.0
    );
    let o = vpctl(&[
        "mission",
        "export",
        &plan,
        "--home",
        &home,
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let h = waypoint_heights(&out);
    for (got, want) in h.iter().zip([22.0, 26.0, 30.0]) {
        // Earth curvature over 16 m: well below a millimetre.
        assert!((got - want).abs() < 0.01, "{h:?}");
    }
}

#[test]
fn the_plans_own_home_is_used_and_a_datum_converts_through_the_geoid() {
    let dir = tempfile::tempdir().unwrap();
    let mut p = airborne_plan(&[-10.0]);
    let ground = GeodeticOrigin {
        alt_m: AIRBORNE.alt_m - 40.0,
        ..AIRBORNE
    };
    p.home = Some(Home {
        position: ground,
        source: "test".into(),
    });
    let plan = save(&p, &dir.path().join("p.json"));
    let out = dir.path().join("m.plan");
    let o = vpctl(&["mission", "export", &plan, "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!((waypoint_heights(&out)[0] - 30.0).abs() < 0.01);

    // The same ground given as a height above the ellipsoid: the geoid is
    // about 46 m above it at Brighton, so the same number is a home 46 m
    // lower, and the waypoint 46 m higher above it.
    let n = vp_scene::datum::geoid_height_m(AIRBORNE.lat_deg, AIRBORNE.lon_deg);
    let home = format!(
        "{},{},{},ellipsoid",
        ground.lat_deg, ground.lon_deg, ground.alt_m
    );
    let o = vpctl(&[
        "mission",
        "export",
        &plan,
        "--home",
        &home,
        "--out",
        out.to_str().unwrap(),
        "--force",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        (waypoint_heights(&out)[0] - (30.0 + n)).abs() < 0.01,
        "geoid {n}"
    );

    // A plan that does not say its datum takes no home in a stated one.
    p.vertical_datum = None;
    let plan = save(&p, &dir.path().join("q.json"));
    let o = vpctl(&["mission", "export", &plan, "--home", &home]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains("datum"), "{}", text(&o.stderr));
}

#[test]
fn waypoints_below_home_or_above_the_ceiling_and_far_homes_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let ground = format!(
        "{},{},{}",
        AIRBORNE.lat_deg,
        AIRBORNE.lon_deg,
        AIRBORNE.alt_m - 40.0
    );
    // Waypoint 1 is 5 m below the launch point.
    let low = save(
        &airborne_plan(&[-10.0, -45.0]),
        &dir.path().join("low.json"),
    );
    let o = vpctl(&["mission", "export", &low, "--home", &ground]);
    assert_eq!(o.status.code(), Some(2));
    let e = text(&o.stderr);
    assert!(e.contains("waypoint 1") && e.contains("BELOW"), "{e}");

    // Waypoint 2 is 130 m above it: over the default 120 m ceiling.
    let high = save(
        &airborne_plan(&[-10.0, 0.0, 90.0]),
        &dir.path().join("high.json"),
    );
    let o = vpctl(&["mission", "export", &high, "--home", &ground]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("waypoint 2") && text(&o.stderr).contains("ceiling of 120"));
    let o = vpctl(&[
        "mission",
        "export",
        &high,
        "--home",
        &ground,
        "--ceiling",
        "150",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));

    // Latitude and longitude swapped: thousands of kilometres away.
    let swapped = format!(
        "{},{},{}",
        AIRBORNE.lon_deg,
        AIRBORNE.lat_deg,
        AIRBORNE.alt_m - 40.0
    );
    let o = vpctl(&[
        "mission",
        "export",
        &high,
        "--home",
        &swapped,
        "--ceiling",
        "150",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("from the nearest waypoint"),
        "{}",
        text(&o.stderr)
    );
}

#[test]
fn out_of_range_mission_values_are_refused_with_the_allowed_range() {
    let dir = tempfile::tempdir().unwrap();
    let ground = format!(
        "{},{},{}",
        AIRBORNE.lat_deg,
        AIRBORNE.lon_deg,
        AIRBORNE.alt_m - 40.0
    );
    let plan = save(&airborne_plan(&[-10.0]), &dir.path().join("p.json"));
    for (flag, value, says) in [
        (
            "--hold",
            "-1",
            "hold time -1 s is out of range: allowed 0 to 60 s",
        ),
        (
            "--speed",
            "50",
            "speed 50 m/s is out of range: allowed 0.5 to 20 m/s",
        ),
        ("--takeoff", "-10", "take-off height -10 m"),
        (
            "--takeoff",
            "500",
            "take-off height 500 m above home is out of range",
        ),
        ("--ceiling", "1200", "ceiling 1200 m"),
        ("--min-height", "-3", "minimum height -3 m"),
    ] {
        let o = vpctl(&["mission", "export", &plan, "--home", &ground, flag, value]);
        assert_eq!(
            o.status.code(),
            Some(2),
            "{flag} {value}: {}",
            text(&o.stderr)
        );
        assert!(
            text(&o.stderr).contains(says),
            "{flag} {value}: {}",
            text(&o.stderr)
        );
    }
}

/// `mission upload` reads the vehicle's HOME_POSITION: a vehicle whose home
/// is 30 m from the plan's would fly every waypoint 30 m off, so the upload
/// is refused (exit 2, the vehicle's mission untouched) unless
/// --accept-home-offset; a vehicle at the plan's home uploads and says so.
#[test]
fn upload_compares_the_vehicles_home_with_the_plans() {
    use vp_mission::sim_vehicle::{spawn_udp_vehicle, VehicleConfig};
    let dir = tempfile::tempdir().unwrap();
    let mut p = airborne_plan(&[-10.0, -12.0]);
    let ground = GeodeticOrigin {
        alt_m: AIRBORNE.alt_m - 40.0,
        ..AIRBORNE
    };
    p.home = Some(Home {
        position: ground,
        source: "test".into(),
    });
    let plan = save(&p, &dir.path().join("p.json"));
    let elsewhere = GeodeticOrigin {
        lat_deg: ground.lat_deg + 30.0 / 111_200.0,
        ..ground
    };
    let upload = |home: GeodeticOrigin, extra: &[&str]| {
        let vehicle = spawn_udp_vehicle(
            "127.0.0.1:0",
            VehicleConfig {
                home,
                reports_home: true,
                ..VehicleConfig::default()
            },
        )
        .unwrap();
        let url = format!("udpout:{}", vehicle.addr());
        let mut args = vec!["mission", "upload", plan.as_str(), "--url", url.as_str()];
        args.extend_from_slice(extra);
        let o = vpctl(&args);
        (o, vehicle.mission().len())
    };
    let (o, items) = upload(elsewhere, &[]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    let e = text(&o.stderr);
    assert!(
        e.contains("30.0 m") && e.contains("--accept-home-offset"),
        "{e}"
    );
    assert_eq!(
        items, 0,
        "a refused upload must not touch the vehicle's mission"
    );
    let (o, items) = upload(elsewhere, &["--accept-home-offset"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(text(&o.stdout).contains("ACCEPTED"), "{}", text(&o.stdout));
    assert!(items > 0);
    let (o, _) = upload(ground, &[]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        text(&o.stdout).contains("home: vehicle home 0.0 m"),
        "{}",
        text(&o.stdout)
    );
}
