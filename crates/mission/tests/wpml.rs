//! DJI WPML (`.kmz`): DJI's own exports read, and vpctl's missions checked
//! against their structure and against the `.plan` export of the same plan.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use vp_mission::export::{export_files, DjiOptions, ExportFormat};
use vp_mission::fly::Flight;
use vp_mission::wpml::{Drone, WpmlHeights};
use vp_mission::wpml_read::{read_kmz, read_kmz_file, Kmz};
use vp_mission::xml::Element;
use vp_mission::{export_qgc, Autopilot, MissionOptions, QgcOptions};
use vp_scene::datum::geoid_height_m;
use vp_scene::plan::{GeodeticOrigin, Home, Plan, PlannedView, Role, VerticalDatum};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/dji-wpml")
        .join(name)
}

/// A plan of seven photos at different headings and pitches, 30-45 m above
/// a take-off point 3 m below the origin, altitudes above mean sea level.
fn plan() -> Plan {
    let origin = GeodeticOrigin::new(47.397_742, 8.545_594, 488.0).unwrap();
    let mut p = Plan::new(Some(origin));
    p.vertical_datum = Some(VerticalDatum::Egm96);
    p.home = Some(Home {
        position: GeodeticOrigin {
            alt_m: 485.0,
            ..origin
        },
        source: "test".into(),
    });
    for i in 0..7 {
        let f = f64::from(i);
        p.waypoints.push(PlannedView {
            position: [f * 15.0 - 40.0, (f * 0.7).sin() * 30.0, 27.0 + f * 2.0],
            yaw_deg: f * 50.0 - 170.0,
            pitch_deg: -90.0 + f * 9.0,
            roll_deg: 0.0,
            role: Role::Grid,
            triplet_id: None,
            expected_gain: None,
            angle_bin_deg: None,
        });
    }
    p
}

fn kmz(plan: &Plan, heights: WpmlHeights) -> Kmz {
    let dji = DjiOptions {
        drone: Some(Drone::M3e),
        heights,
        split: false,
        time_ms: 1_700_000_000_000,
    };
    let opts = MissionOptions::for_autopilot(Autopilot::Px4);
    let files = export_files(plan, ExportFormat::Wpml, &opts, &dji, Path::new("m.kmz")).unwrap();
    assert_eq!(files.len(), 1);
    read_kmz(&files[0].1, Path::new("m.kmz")).unwrap()
}

/// The names of the children of every element named `parent`.
fn child_names(root: &Element, parent: &str) -> BTreeSet<String> {
    root.descendants()
        .into_iter()
        .filter(|e| e.name == parent)
        .flat_map(|e| e.children.iter().map(|c| c.name.clone()))
        .collect()
}

#[test]
fn djis_two_reference_missions_are_read() {
    let w = read_kmz_file(&data("waypoint.kmz")).unwrap();
    assert_eq!(w.wpml_namespace, "http://www.dji.com/wpmz/1.0.6");
    assert_eq!(w.template_type, "waypoint");
    assert_eq!(w.enums, (77, 1, 67));
    assert_eq!(w.waylines.len(), 1);
    let line = &w.waylines[0];
    assert_eq!(line.height_mode, "relativeToStartPoint");
    assert_eq!(line.points.len(), 6);
    assert!((line.distance_m - 183.631).abs() < 1e-3);
    assert!((line.points[0].lat_deg - 22.578_839_083_348).abs() < 1e-12);
    assert!((line.points[0].lon_deg - 113.938_831_009_663).abs() < 1e-12);
    assert!((line.points[0].execute_height_m - 54.346_750_023).abs() < 1e-9);
    let indices: Vec<u32> = line.points.iter().map(|p| p.index).collect();
    assert_eq!(indices, vec![0, 1, 2, 3, 4, 5]);
    assert!(line.points[0].actions.iter().any(|a| a == "takePhoto"));
    assert!(line.points[0].actions.iter().any(|a| a == "gimbalRotate"));
    assert!(line.points[0].gimbal_pitch_deg.is_some());

    let m = read_kmz_file(&data("mapping3d.kmz")).unwrap();
    assert_eq!(m.template_type, "mapping3d");
    assert_eq!(m.enums, (67, 1, 53));
    assert_eq!(m.waylines.len(), 5, "nadir plus four obliques");
    assert!(m.waylines.iter().all(|l| l.height_mode == "WGS84"));
    let ids: Vec<u32> = m.waylines.iter().map(|l| l.id).collect();
    assert_eq!(ids, vec![0, 1, 2, 3, 4]);
}

#[test]
fn a_broken_kmz_names_the_file_and_what_is_missing() {
    let e = read_kmz(b"not a zip", Path::new("x.kmz"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("x.kmz") && e.contains("ZIP"), "{e}");
}

#[test]
fn our_kmz_has_the_structure_and_elements_of_djis() {
    let ours = kmz(&plan(), WpmlHeights::RelativeToStartPoint);
    let dji = read_kmz_file(&data("waypoint.kmz")).unwrap();
    for (a, b) in [
        (&ours.template, &dji.template),
        (&ours.waylines_doc, &dji.waylines_doc),
    ] {
        assert_eq!(a.name, "kml");
        assert_eq!(a.attributes, b.attributes, "namespaces as DJI writes them");
    }
    // Every element DJI writes under these parents, we write too, except
    // the lidar settings of the payload (no lidar here).
    let optional: BTreeSet<&str> =
        ["wpml:returnMode", "wpml:samplingRate", "wpml:scanningMode"].into();
    for parent in [
        "wpml:missionConfig",
        "Folder",
        "Placemark",
        "wpml:waypointHeadingParam",
        "wpml:waypointTurnParam",
        "wpml:actionGroup",
        "wpml:actionTrigger",
        "wpml:waypointGimbalHeadingParam",
        "wpml:droneInfo",
        "wpml:payloadInfo",
        "wpml:payloadParam",
        "wpml:waylineCoordinateSysParam",
    ] {
        for (mine, theirs, file) in [
            (&ours.template, &dji.template, "template"),
            (&ours.waylines_doc, &dji.waylines_doc, "waylines"),
        ] {
            let have = child_names(mine, parent);
            for name in child_names(theirs, parent) {
                assert!(
                    optional.contains(name.as_str()) || have.contains(&name),
                    "{file}: <{parent}> lacks {name} (DJI writes it)"
                );
            }
        }
    }
    // The gimbalRotate and takePhoto parameters DJI writes.
    let params = |root: &Element, func: &str| -> BTreeSet<String> {
        root.descendants()
            .into_iter()
            .filter(|e| {
                e.name == "wpml:action" && e.text_at("wpml:actionActuatorFunc") == Some(func)
            })
            .flat_map(|e| {
                e.child("wpml:actionActuatorFuncParam")
                    .map(|p| {
                        p.children
                            .iter()
                            .map(|c| c.name.clone())
                            .collect::<Vec<_>>()
                    })
                    .unwrap_or_default()
            })
            .collect()
    };
    for func in ["gimbalRotate", "takePhoto"] {
        let mine = params(&ours.waylines_doc, func);
        for name in params(&dji.waylines_doc, func) {
            assert!(mine.contains(&name), "{func} lacks {name}");
        }
    }
    assert_eq!(ours.template_type, "waypoint");
    assert_eq!(ours.enums, (77, 0, 66));
}

#[test]
fn our_kmz_has_one_photo_per_image_at_the_plan_exports_positions() {
    let plan = plan();
    let ours = kmz(&plan, WpmlHeights::RelativeToStartPoint);
    let line = &ours.waylines[0];
    assert_eq!(line.height_mode, "relativeToStartPoint");
    assert_eq!(line.points.len(), plan.waypoints.len());
    for (i, p) in line.points.iter().enumerate() {
        assert_eq!(p.index as usize, i, "indices contiguous from 0");
        let photos = p.actions.iter().filter(|a| *a == "takePhoto").count();
        assert_eq!(photos, 1, "waypoint {i}: one takePhoto");
        assert_eq!(
            p.gimbal_pitch_deg,
            Some(plan.waypoints[i].pitch_deg),
            "waypoint {i}: gimbal at the planned pitch"
        );
    }
    let groups: Vec<u32> = ours
        .waylines_doc
        .descendants()
        .into_iter()
        .filter(|e| e.name == "wpml:actionGroupId")
        .map(|e| e.text.parse().unwrap())
        .collect();
    assert_eq!(groups, (0..7).collect::<Vec<u32>>());

    // The .plan export of the same plan: same positions, same heights.
    let opts = MissionOptions::for_autopilot(Autopilot::Px4);
    let qgc: serde_json::Value =
        serde_json::from_str(&export_qgc(&plan, &opts, &QgcOptions::default()).unwrap()).unwrap();
    let wps: Vec<&serde_json::Value> = qgc["mission"]["items"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|i| i["command"] == 16)
        .collect();
    assert_eq!(wps.len(), line.points.len());
    for (i, (p, q)) in line.points.iter().zip(wps).enumerate() {
        let (lat, lon) = (
            q["params"][4].as_f64().unwrap(),
            q["params"][5].as_f64().unwrap(),
        );
        assert!((p.lat_deg - lat).abs() < 1e-6, "waypoint {i} latitude");
        assert!((p.lon_deg - lon).abs() < 1e-6, "waypoint {i} longitude");
        let h = q["Altitude"].as_f64().unwrap();
        assert!(
            (p.execute_height_m - h).abs() < 1e-3,
            "waypoint {i}: {} vs {h}",
            p.execute_height_m
        );
        // Heading: WPML's [-180, 180] is the .plan's compass heading.
        let heading = q["params"][3].as_f64().unwrap();
        let d = (p.heading_deg.unwrap() - heading).rem_euclid(360.0);
        assert!(!(1e-2..=360.0 - 1e-2).contains(&d), "waypoint {i} heading");
    }
    assert!(line.distance_m > 0.0 && line.duration_s > line.distance_m / 5.0);
}

#[test]
fn wgs84_heights_are_the_plans_converted_through_the_geoid() {
    let plan = plan();
    let ours = kmz(&plan, WpmlHeights::Wgs84);
    assert_eq!(ours.waylines[0].height_mode, "WGS84");
    let flight = Flight::of_plan(&plan, &MissionOptions::for_autopilot(Autopilot::Px4)).unwrap();
    let tpl_heights: Vec<f64> = ours
        .template
        .descendants()
        .into_iter()
        .filter(|e| e.name == "wpml:height")
        .map(|e| e.text.parse().unwrap())
        .collect();
    for (i, (p, f)) in ours.waylines[0]
        .points
        .iter()
        .zip(&flight.points)
        .enumerate()
    {
        let n = geoid_height_m(f.lat_deg, f.lon_deg);
        // EGM96 (the plan's datum) + N = ellipsoid; N is about 48 m here.
        assert!(n > 40.0);
        assert!(
            (p.execute_height_m - (f.alt_m + n)).abs() < 2e-3,
            "waypoint {i}"
        );
        assert!(
            (tpl_heights[i] - f.alt_m).abs() < 2e-3,
            "template EGM96 {i}"
        );
    }
    assert_eq!(
        ours.template
            .text_at("Document/Folder/wpml:waylineCoordinateSysParam/wpml:heightMode"),
        Some("EGM96")
    );

    // A plan that does not say its datum cannot give ellipsoidal heights.
    let mut unknown = plan.clone();
    unknown.vertical_datum = None;
    let dji = DjiOptions {
        drone: Some(Drone::M30t),
        heights: WpmlHeights::Wgs84,
        ..DjiOptions::default()
    };
    let e = export_files(
        &unknown,
        ExportFormat::Wpml,
        &MissionOptions::for_autopilot(Autopilot::Px4),
        &dji,
        Path::new("m.kmz"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("datum") && e.contains("relative"), "{e}");
}

#[test]
fn drones_have_their_documented_enums_and_unknown_ones_are_refused() {
    let enums = |s: &str| s.parse::<Drone>().unwrap().enums();
    assert_eq!(enums("M3E"), (77, 0, 66));
    assert_eq!(enums("m3t"), (77, 1, 67));
    assert_eq!(enums("m30"), (67, 0, 52));
    assert_eq!(enums("M30T"), (67, 1, 53));
    assert_eq!(enums("m300"), (60, 0, 42));
    assert_eq!(enums("m350"), (89, 0, 42));
    assert_eq!(enums("m3d"), (91, 0, 80));
    assert_eq!(enums("m3td"), (91, 1, 81));
    let e = "phantom4".parse::<Drone>().unwrap_err().to_string();
    assert!(e.contains("phantom4") && e.contains("m3e"), "{e}");
}
