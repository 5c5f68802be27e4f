//! `vpctl plan`, `vpctl plan grid` and `vpctl config --defaults` as a user runs them.

mod common;
use common::vpctl;

use std::path::Path;
use std::process::Output;

use common::plan_fixture as fixture;
use vp_scene::colmap;
use vp_scene::plan::{Plan, Role};

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn plan_writes_plan_ply_and_png_and_refuses_to_overwrite() {
    let dir = tempfile::tempdir().unwrap();
    let site = fixture(dir.path());
    let p = |f: &str| dir.path().join(f).to_str().unwrap().to_string();
    let b = site.rock_bounds;
    let roi = format!(
        "{},{},{},{},{},{}",
        b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z
    );
    let args = |out: &str| {
        vec![
            "plan".to_string(),
            "--mesh".into(),
            p("site.ply"),
            "--colmap".into(),
            p("model"),
            "--config".into(),
            p("plan.toml"),
            "--roi-box".into(),
            roi.clone(),
            "--out".into(),
            p(out),
            "--no-timings".into(),
        ]
    };
    let mut a = args("a.json");
    a.extend(["--ply".into(), p("cams.ply"), "--png".into(), p("top.png")]);
    let run = |v: &[String]| vpctl(&v.iter().map(String::as_str).collect::<Vec<_>>());
    let o = run(&a);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("waypoints:") && out.contains("6 triplet members"),
        "{out}"
    );
    assert!(stderr(&o).contains("triplet 1: mean f"), "{}", stderr(&o));
    let plan = Plan::load(&dir.path().join("a.json")).unwrap();
    assert_eq!(
        plan.waypoints
            .iter()
            .filter(|w| w.role == Role::TripletMember)
            .count(),
        6
    );
    assert_eq!(plan.safety_distance_m, Some(5.0));
    let png = std::fs::read(dir.path().join("top.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    // The top view had no title, legend or colour key: the panel below
    // the map holds the legend swatches (triplet orange) and the f(t) ramp
    // from red to green.
    let img = vp_scene::raster::load_rgb(&dir.path().join("top.png")).unwrap();
    let panel: Vec<[u8; 3]> = (img.height() - 60..img.height())
        .flat_map(|y| (0..img.width()).map(move |x| (x, y)))
        .map(|(x, y)| img.get_pixel(x, y).0)
        .collect();
    for colour in [[255, 150, 0], [255, 0, 40], [0, 255, 40], [235, 235, 235]] {
        assert!(panel.contains(&colour), "{colour:?} in the legend panel");
    }
    // The acquired cameras (blue squares) are on the map, not only in
    // the legend: the top view showed only the plan.
    let acquired = [90, 160, 255];
    assert!(panel.contains(&acquired), "acquired in the legend");
    let on_map = (0..img.height() - 80)
        .flat_map(|y| (0..img.width()).map(move |x| (x, y)))
        .filter(|&(x, y)| img.get_pixel(x, y).0 == acquired)
        .count();
    let model = vp_scene::colmap::read_model(&dir.path().join("model")).unwrap();
    assert!(
        on_map >= model.images.len() * 4,
        "{on_map} blue pixels for {} acquired cameras",
        model.images.len()
    );
    let cams = vp_scene::io::read_mesh(&dir.path().join("cams.ply")).unwrap();
    assert_eq!(cams.n_faces(), 6 * plan.waypoints.len());
    // Same inputs, same bytes.
    let o = run(&args("b.json"));
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(dir.path().join("a.json")).unwrap(),
        std::fs::read(dir.path().join("b.json")).unwrap()
    );
    // No overwrite without --force, and exit 2.
    let o = run(&a);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("a.json"), "{}", stderr(&o));
}

#[test]
fn bad_inputs_exit_2_without_output() {
    let dir = tempfile::tempdir().unwrap();
    fixture(dir.path());
    let p = |f: &str| dir.path().join(f).to_str().unwrap().to_string();
    std::fs::write(dir.path().join("bad.toml"), "alpha = 3.0\n").unwrap();
    let o = vpctl(&[
        "plan",
        "--mesh",
        &p("site.ply"),
        "--colmap",
        &p("model"),
        "--config",
        &p("bad.toml"),
        "--out",
        &p("x.json"),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("bad.toml") && stderr(&o).contains("alpha = 3"),
        "{}",
        stderr(&o)
    );
    // ROI outside the mesh.
    let o = vpctl(&[
        "plan",
        "--mesh",
        &p("site.ply"),
        "--colmap",
        &p("model"),
        "--config",
        &p("plan.toml"),
        "--roi-box",
        "500,500,0,600,600,10",
        "--out",
        &p("x.json"),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("selects no face"), "{}", stderr(&o));
    // An empty confidence folder: the error says to run `vpctl predict`;
    // one image's confidence missing: the error names its file.
    std::fs::create_dir(dir.path().join("conf")).unwrap();
    let plan_conf = || {
        vpctl(&[
            "plan",
            "--mesh",
            &p("site.ply"),
            "--colmap",
            &p("model"),
            "--config",
            &p("plan.toml"),
            "--confidence-dir",
            &p("conf"),
            "--out",
            &p("x.json"),
        ])
    };
    let o = plan_conf();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("vpctl predict"), "{}", stderr(&o));
    std::fs::write(dir.path().join("conf/other.jpg.vpconf"), b"").unwrap();
    let o = plan_conf();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("img_001.jpg.vpconf"), "{}", stderr(&o));
    assert!(!dir.path().join("x.json").exists());
}

#[test]
fn grid_and_config_defaults() {
    let dir = tempfile::tempdir().unwrap();
    fixture(dir.path());
    let p = |f: &str| dir.path().join(f).to_str().unwrap().to_string();
    let o = vpctl(&[
        "plan",
        "grid",
        "--mesh",
        &p("site.ply"),
        "--height",
        "50",
        "--overlap",
        "0.5",
        "--out",
        &p("grid.json"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let plan = Plan::load(&dir.path().join("grid.json")).unwrap();
    // Default camera at 50 m: 75 m x 50 m footprint, steps 37.5 m and 25 m
    // over the 60 m site: 1 line of ceil((60-50)/25)+1 = 2 images.
    assert_eq!(plan.waypoints.len(), 2);
    assert!(plan
        .waypoints
        .iter()
        .all(|w| w.role == Role::Grid && (w.pitch_deg + 90.0).abs() < 1e-9));
    let o = vpctl(&["config", "--defaults"]);
    assert!(o.status.success());
    let text = String::from_utf8(o.stdout).unwrap();
    let cfg = vp_planner::PlannerConfig::from_toml(&text, Path::new("-")).unwrap();
    assert_eq!(cfg, vp_planner::PlannerConfig::default());
}

#[test]
fn plan_refuses_a_distorted_model_and_points_at_colmap_undistort() {
    // Regression: every COLMAP camera was approximated as a pinhole, so a
    // RADIAL/OPENCV model from real photos planned with the wrong geometry.
    let dir = tempfile::tempdir().unwrap();
    fixture(dir.path());
    let p = |f: &str| dir.path().join(f).to_str().unwrap().to_string();
    let cams = dir.path().join("model/cameras.txt");
    let text = std::fs::read_to_string(&cams).unwrap();
    let line = text.lines().find(|l| !l.starts_with('#')).unwrap();
    let distorted = line.replace("PINHOLE", "OPENCV") + " -0.05 0.01 0 0";
    std::fs::write(&cams, text.replace(line, &distorted)).unwrap();
    let o = vpctl(&[
        "plan",
        "--mesh",
        &p("site.ply"),
        "--colmap",
        &p("model"),
        "--config",
        &p("plan.toml"),
        "--out",
        &p("x.json"),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("OPENCV") && err.contains("vpctl colmap undistort") && err.contains("model"),
        "{err}"
    );
    assert!(!dir.path().join("x.json").exists());
}

#[test]
fn plan_refuses_a_model_without_frame_unless_told() {
    // Regression: a raw COLMAP model (arbitrary scale and orientation) was
    // planned as if metric ENU, and no error said so.
    let dir = tempfile::tempdir().unwrap();
    fixture(dir.path());
    let p = |f: &str| dir.path().join(f).to_str().unwrap().to_string();
    std::fs::remove_file(dir.path().join("model/frame.json")).unwrap();
    let args = |extra: &[&str]| {
        let mut v = vec![
            "plan".to_string(),
            "--mesh".into(),
            p("site.ply"),
            "--colmap".into(),
            p("model"),
            "--config".into(),
            p("plan.toml"),
            "--out".into(),
            p("x.json"),
            "--no-timings".into(),
        ];
        v.extend(extra.iter().map(|s| (*s).to_string()));
        v
    };
    let run = |v: &[String]| vpctl(&v.iter().map(String::as_str).collect::<Vec<_>>());
    let o = run(&args(&[]));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("frame.json")
            && err.contains("vpctl colmap align")
            && err.contains("--frame-unchecked"),
        "{err}"
    );
    assert!(!dir.path().join("x.json").exists());
    // An overlap no bridge reaches, so that some views stay unbridged.
    let toml = dir.path().join("plan.toml");
    let cfg = std::fs::read_to_string(&toml).unwrap() + "min_overlap = 0.999\n";
    std::fs::write(&toml, cfg).unwrap();
    let o = run(&args(&["--frame-unchecked"]));
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    // Regression: views that could not be bridged appeared neither in the
    // output nor in the plan JSON.
    let plan = Plan::load(&dir.path().join("x.json")).unwrap();
    assert!(!plan.unbridged.is_empty(), "{text}");
    assert!(
        text.contains(&format!("unbridged views: {:?}", plan.unbridged)),
        "{text}"
    );
    // A frame whose scale is implausible (cameras 1000x too far apart).
    colmap::ModelFrame::identity(vp_scene::plan::GeodeticOrigin::default())
        .save(&dir.path().join("model"))
        .unwrap();
    let model = colmap::read_model(&dir.path().join("model")).unwrap();
    let far = colmap::transform_reconstruction(
        &model,
        &vp_scene::sim3::Sim3 {
            scale: 1000.0,
            rotation_wxyz: [1.0, 0.0, 0.0, 0.0],
            translation: [0.0; 3],
        },
    );
    colmap::write_text(&dir.path().join("model"), &far).unwrap();
    let o = run(&args(&["--force"]));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("implausible scale"), "{}", stderr(&o));
}

/// Regression (issue 40): a triplet dropped as unreachable was not
/// replaced (k = 4 asked, 3 flown), "mean f" and `statistics.iterations`
/// still counted it, and its reason cited "segment 10 -> 11", numbers that
/// appear in no output. On a site where M4 drops a triplet (a random case
/// of the planner's safety test), the plan now flies k triplets, its
/// figures are those of the flown ones, and a reason names waypoints of
/// the plan file.
#[test]
fn a_dropped_triplet_is_replaced_and_the_summary_counts_only_what_is_flown() {
    let dir = tempfile::tempdir().unwrap();
    let site = common::plan_fixture_seeded(dir.path(), 80557);
    let p = |f: &str| dir.path().join(f).to_str().unwrap().to_string();
    let (fence, v) = (28.802_337_047_640_44, site.flight_volume);
    std::fs::write(
        dir.path().join("drop.toml"),
        format!(
            "n_triangles = 200\nn_surrogates = 400\nn_selected = 40\nn_triplets = 4\n\
             seed = 80557\nsafety_distance_m = 7.435409014953079\n\
             flight_volume = [[{}, {}, {}], [{}, {}, {}]]\n\
             geofence = [[-{fence}, -{fence}], [{fence}, -{fence}], [{fence}, {fence}], [-{fence}, {fence}]]\n\
             altitude_limits = {{ min_m = {}, max_m = 47.597875864562276 }}\n\
             [safety]\ngnss = {{ horizontal_m = 0.0, vertical_m = 0.0 }}\ntracking_m = 0.0\n",
            v.min.x, v.min.y, v.min.z, v.max.x, v.max.y, v.max.z, v.min.z
        ),
    )
    .unwrap();
    let (cx, cy, h) = (
        -7.936_663_369_069_961,
        -7.972_792_518_331_621,
        8.606_707_443_950_37,
    );
    let roi = format!("{},{},-100,{},{},100", cx - h, cy - h, cx + h, cy + h);
    let o = vpctl(&[
        "plan",
        "--mesh",
        &p("site.ply"),
        "--colmap",
        &p("model"),
        "--config",
        &p("drop.toml"),
        "--roi-box",
        &roi,
        "--out",
        &p("plan.json"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let plan = Plan::load(&dir.path().join("plan.json")).unwrap();
    assert!(
        !plan.dropped_triplets.is_empty(),
        "the site no longer drops a triplet: the test checks nothing\n{out}"
    );
    let mut flown: Vec<u32> = plan.waypoints.iter().filter_map(|w| w.triplet_id).collect();
    flown.sort_unstable();
    flown.dedup();
    // k asked = k flown, or the summary says why not.
    if flown.len() < 4 {
        assert!(out.contains("not replaced"), "{out}");
    } else {
        assert!(out.contains("cut short: no"), "{out}");
    }
    for d in &plan.dropped_triplets {
        assert!(!flown.contains(&d.triplet_id), "{d:?}");
        if let Some(by) = d.replaced_by {
            assert!(flown.contains(&by), "{d:?}");
            assert!(
                out.contains(&format!("triplet {}: ", d.triplet_id))
                    && out.contains(&format!("replaced by triplet {by}")),
                "{out}"
            );
        }
        // Every waypoint a reason names is that waypoint of the plan file.
        for (at, _) in d.reason.match_indices("waypoint ") {
            let rest = &d.reason[at + "waypoint ".len()..];
            let n: usize = rest[..rest.find(' ').unwrap()].parse().unwrap();
            let t: u32 = rest[rest.find("(triplet ").unwrap() + 9..rest.find(')').unwrap()]
                .parse()
                .unwrap();
            assert_eq!(plan.waypoints[n].triplet_id, Some(t), "{}", d.reason);
        }
        assert!(!d.reason.contains(" -> "), "{}", d.reason);
    }
    // The figures are those of the flown triplets only.
    let its = &plan.statistics.iterations;
    let mut ids: Vec<u32> = its.iter().map(|i| i.iteration).collect();
    ids.sort_unstable();
    assert_eq!(ids, flown);
    let (a, b) = (its[0].f_before, its[its.len() - 1].f_after);
    assert!(out.contains(&format!("mean f: {a:.4} -> {b:.4}")), "{out}");
}

/// Issue 32: `plan --config` read a campaign file through the simulator's
/// campaign config, so a key the file left out took the demo preset's value
/// (a 240 x 160 px camera, 4 m safety distance, 0.5 m margin) instead of the
/// planner's documented default. It reads the `[planner]` section alone now,
/// and a typo anywhere in the file is still refused.
#[test]
fn a_campaign_files_planner_section_takes_the_planners_defaults() {
    let dir = tempfile::tempdir().unwrap();
    fixture(dir.path());
    let p = |f: &str| dir.path().join(f).to_str().unwrap().to_string();
    let grid = |config: &str| {
        vpctl(&[
            "plan",
            "grid",
            "--mesh",
            &p("site.ply"),
            "--config",
            &p(config),
            "--height",
            "30",
            "--overlap",
            "0.5",
            "--out",
            &p("g.json"),
            "--force",
        ])
    };
    std::fs::write(
        dir.path().join("c.toml"),
        "[site]\nseed = 2\n[planner]\nn_triangles = 300\n",
    )
    .unwrap();
    let o = grid("c.toml");
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    let d = vp_planner::PlannerConfig::default();
    assert!(
        stdout.contains(&format!(
            "safety {:.2} + margin {:.2}",
            d.safety_distance_m, d.geometry_margin_m
        )),
        "{stdout}"
    );
    // The planner's default camera: its footprint at 30 m, half overlap.
    let k = d.camera;
    let across = 30.0 * f64::from(k.width.min(k.height)) / k.focal_px * 0.5;
    let along = 30.0 * f64::from(k.width.max(k.height)) / k.focal_px * 0.5;
    assert!(
        [across, along]
            .iter()
            .any(|s| stdout.contains(&format!("lines {s:.1} m apart"))),
        "{stdout}"
    );
    // A typo in another section of the campaign file is still refused.
    std::fs::write(
        dir.path().join("t.toml"),
        "[planner]\nn_triangles = 300\n[render]\nsizee = 3\n",
    )
    .unwrap();
    let o = grid("t.toml");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("t.toml: line 4: column 1: unknown field `sizee`"),
        "{}",
        stderr(&o)
    );
}
