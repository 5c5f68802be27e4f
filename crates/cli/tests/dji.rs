//! Flying a plan on DJI drones: `vpctl mission export` to a DJI WPML `.kmz`
//! (DJI Pilot 2), a Litchi CSV (checked with the independent `litchi-wp`
//! parser) and a KML preview; bad input refused with exit 2 and nothing
//! written. The README's "fly it" commands are the ones run here.

use std::path::Path;
use std::process::Command;

use vp_scene::plan::{GeodeticOrigin, Home, Plan, PlannedView, Role, VerticalDatum};
use vp_test_support::python::litchi_python;

mod common;
use common::vpctl;

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// A plan of `n` photos 25-40 m above a known take-off point (EGM96).
fn plan(n: usize, home: bool) -> Plan {
    let origin = GeodeticOrigin::new(46.03, 10.35, 400.0).unwrap();
    let mut p = Plan::new(Some(origin));
    p.vertical_datum = Some(VerticalDatum::Egm96);
    if home {
        p.home = Some(Home::origin_on_ground(origin));
    }
    for i in 0..n {
        let f = i as f64;
        p.waypoints.push(PlannedView {
            position: [
                (f % 12.0) * 10.0,
                (f / 12.0).floor() * 10.0,
                25.0 + (f % 4.0) * 5.0,
            ],
            yaw_deg: f * 37.0 % 360.0,
            pitch_deg: -90.0 + (f % 5.0) * 10.0,
            roll_deg: 0.0,
            role: Role::Grid,
            triplet_id: None,
            expected_gain: None,
            angle_bin_deg: None,
        });
    }
    p
}

fn save(plan: &Plan, path: &Path) -> String {
    plan.save(path, true).unwrap();
    path.to_str().unwrap().to_string()
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn readme_fly_it_dji_pilot_kmz() {
    let dir = tempfile::tempdir().unwrap();
    let p = save(&plan(8, true), &dir.path().join("plan.json"));
    let out = dir.path().join("mission.kmz");
    // README: vpctl mission export plan.json --out mission.kmz --drone m3e
    let o = vpctl(&[
        "mission",
        "export",
        &p,
        "--out",
        out.to_str().unwrap(),
        "--drone",
        "m3e",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let kmz = vp_mission::wpml_read::read_kmz_file(&out).unwrap();
    assert_eq!(kmz.enums, (77, 0, 66));
    assert_eq!(kmz.waylines[0].points.len(), 8);
    assert_eq!(kmz.waylines[0].height_mode, "relativeToStartPoint");

    // README: --dji-heights wgs84 for ellipsoidal heights.
    let wgs = dir.path().join("wgs.kmz");
    let o = vpctl(&[
        "mission",
        "export",
        &p,
        "--out",
        wgs.to_str().unwrap(),
        "--drone",
        "m350",
        "--dji-heights",
        "wgs84",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let kmz = vp_mission::wpml_read::read_kmz_file(&wgs).unwrap();
    assert_eq!(kmz.waylines[0].height_mode, "WGS84");
    assert_eq!(kmz.enums.0, 89);
}

#[test]
fn readme_fly_it_px4_ardupilot_and_preview() {
    let dir = tempfile::tempdir().unwrap();
    let p = save(&plan(5, true), &dir.path().join("plan.json"));
    for (name, extra) in [
        ("mission.plan", vec![]),
        ("mission.waypoints", vec!["--autopilot", "ardupilot"]),
        ("plan-preview.kml", vec![]),
    ] {
        let out = dir.path().join(name);
        let mut args = vec!["mission", "export", &p, "--out", out.to_str().unwrap()];
        args.extend(extra);
        let o = vpctl(&args);
        assert!(o.status.success(), "{name}: {}", text(&o.stderr));
    }
    let kml = std::fs::read_to_string(dir.path().join("plan-preview.kml")).unwrap();
    let doc = vp_mission::xml::parse(&kml).unwrap();
    let photos = doc
        .descendants()
        .into_iter()
        .filter(|e| {
            e.name == "Placemark" && e.text_at("name").is_some_and(|n| n.starts_with("photo"))
        })
        .count();
    assert_eq!(photos, 5, "one placemark per photo");
    assert!(kml.contains("<LineString>") && kml.contains("<altitudeMode>absolute"));
}

#[test]
fn bad_dji_input_exits_2_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let with_home = save(&plan(3, true), &dir.path().join("plan.json"));
    let no_home = save(&plan(3, false), &dir.path().join("nohome.json"));
    let long = save(&plan(120, true), &dir.path().join("long.json"));
    let before = files_in(dir.path());
    let kmz = dir.path().join("m.kmz");
    let csv = dir.path().join("m.csv");
    let cases: Vec<(Vec<&str>, &[&str])> = vec![
        (
            vec![
                &with_home,
                "--out",
                kmz.to_str().unwrap(),
                "--drone",
                "phantom4",
            ],
            &["phantom4", "m3e"],
        ),
        (
            vec![&with_home, "--out", kmz.to_str().unwrap()],
            &["--drone"],
        ),
        (
            vec![&no_home, "--out", kmz.to_str().unwrap(), "--drone", "m3t"],
            &["nohome.json", "no home", "--home"],
        ),
        (
            vec![&no_home, "--out", csv.to_str().unwrap()],
            &["nohome.json", "no home"],
        ),
        (
            vec![&with_home, "--format", "wpml", "--drone", "m3e"],
            &["--out mission.kmz"],
        ),
        (
            vec![&long, "--out", csv.to_str().unwrap()],
            &["long.json", "120 waypoints", "99", "--split"],
        ),
    ];
    for (args, needles) in cases {
        let mut full = vec!["mission", "export"];
        full.extend(args.iter().copied());
        let o = vpctl(&full);
        let e = text(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{full:?}: {e}");
        for n in needles {
            assert!(e.contains(n), "{full:?}: {n:?} not in {e}");
        }
        assert_eq!(files_in(dir.path()), before, "{full:?} wrote something");
    }
}

const READ_WITH_LITCHI_WP: &str = r#"
import json, sys
from litchi_wp.waypoint import Waypoint
out = []
for f in sys.argv[1:]:
    wps = Waypoint.from_file(f)
    out.append([[w.lat, w.lon, w.altitude.value, w.altitude.mode.value, w.heading,
                 w.gimbal.mode.value, w.gimbal.pitchangle,
                 [[a.type.value, a.param] for a in w.actions if a.type.value != -1]]
                for w in wps])
print("JSON" + json.dumps(out))
"#;

#[test]
fn litchi_csv_round_trips_through_litchi_wp_and_long_plans_split() {
    let Some(py) = litchi_python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let plan = plan(120, true);
    let p = save(&plan, &dir.path().join("plan.json"));
    let out = dir.path().join("mission.csv");
    // README: vpctl mission export plan.json --out mission.csv --split
    let o = vpctl(&[
        "mission",
        "export",
        &p,
        "--out",
        out.to_str().unwrap(),
        "--split",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let parts = [
        dir.path().join("mission-1.csv"),
        dir.path().join("mission-2.csv"),
    ];
    assert!(!out.exists(), "split missions only");
    let o = Command::new(&py)
        .arg("-c")
        .arg(READ_WITH_LITCHI_WP)
        .args(parts.iter().map(|p| p.to_str().unwrap()))
        .output()
        .unwrap();
    let stdout = text(&o.stdout);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let json = stdout.split("JSON").nth(1).expect("litchi-wp output");
    let files: Vec<Vec<serde_json::Value>> = serde_json::from_str(json).unwrap();
    assert_eq!(files[0].len(), 99);
    assert_eq!(files[1].len(), 21);
    let flight = vp_mission::fly::Flight::of_plan(
        &plan,
        &vp_mission::MissionOptions::for_autopilot(vp_mission::Autopilot::Px4),
    )
    .unwrap();
    for (i, (w, f)) in files.concat().iter().zip(&flight.points).enumerate() {
        let v = |k: usize| w[k].as_f64().unwrap();
        assert!(
            (v(0) - f.lat_deg).abs() < 1e-7 && (v(1) - f.lon_deg).abs() < 1e-7,
            "{i}"
        );
        assert!((v(2) - f.height_above_home_m).abs() < 0.01, "{i} altitude");
        assert_eq!(w[3], 0, "{i}: altitude mode 0 (relative to take-off)");
        assert!((v(4) - f.heading_deg).abs() < 0.01, "{i} heading");
        assert_eq!(w[5], 2, "{i}: gimbal interpolate");
        assert!(
            (v(6) - plan.waypoints[i].pitch_deg).abs() < 0.01,
            "{i} pitch"
        );
        // Stay for the 2 s hold, then one photo.
        assert_eq!(w[7], serde_json::json!([[0, 2000], [1, 0]]), "{i}");
    }
}
