//! The README's "Real photos: from a COLMAP model to a mission" recipe, end
//! to end on real photos, every command run as the `vpctl` binary the way a
//! user runs it: `colmap align -> colmap undistort -> mvs run -> labelgen
//! triplets -> mvs run --triplets -> labelgen run -> train -> predict -> mesh
//! build -> plan -> mission export`, and MAVSDK imports the `.plan`.
//!
//! The photos are the committed ViSP cube sequence
//! (tests/data/real-mvs/visp-cube, see its SOURCE.md): nine real photos and
//! COLMAP's model of them. Its gauge is arbitrary, so the test ties it to the
//! world through a known similarity (3 m per model unit, model +z, the
//! viewing direction, turned to down) and a geodetic origin: the image
//! positions given to `colmap align` are the model's camera centres moved by
//! that similarity, then converted to WGS84.
//!
//! The camera moved along a straight line, so camera centres (and any
//! positions of them) leave the rotation about that line undetermined:
//! `colmap align` refuses (exit 2, nothing written, the message names
//! `--gravity-from-views`), then with `--gravity-from-views` takes that
//! rotation from the cameras' mean viewing direction (turned as far down as
//! it goes) and writes the aligned model, within a few degrees of the known
//! similarity. Every other step reads what the step before it wrote, and
//! `plan` and `labelgen run` check the frame (no `--frame-unchecked`).
//!
//! MAVSDK: as in vp-mission's peer tests, `VP_MAVSDK_PYTHON` names a Python
//! with `mavsdk`; without one the import step prints why it did not run,
//! unless `VP_REQUIRE_MAVSDK` is set (scripts/test.sh sets it), which makes
//! it a failure.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

use nalgebra::{Point3, UnitQuaternion, Vector3};
use vp_scene::colmap::{self, ModelFrame};
use vp_scene::plan::GeodeticOrigin;
use vp_scene::sim3::Sim3;

mod common;

use common::{stderr, stdout, vpctl};
use vp_test_support::python::mavsdk_python;

/// Runs `vpctl` on a command line split at whitespace (the temporary paths
/// have none), asserts exit 0 and returns stdout.
fn run(line: &str) -> String {
    let args: Vec<&str> = line.split_whitespace().collect();
    let t = Instant::now();
    let o = vpctl(&args);
    assert_eq!(
        o.status.code(),
        Some(0),
        "vpctl {line}\nstdout: {}\nstderr: {}",
        stdout(&o),
        stderr(&o)
    );
    eprintln!(
        "vpctl {}: {:.1} s",
        args[..2].join(" "),
        t.elapsed().as_secs_f64()
    );
    stdout(&o)
}

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/real-mvs/visp-cube")
}

/// The known similarity from the SfM gauge to local ENU metres.
fn known_sim3() -> Sim3 {
    // Model +z (where the cameras look) becomes ENU -z: half a turn about x.
    let q = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI);
    Sim3 {
        scale: 3.0,
        rotation_wxyz: [q.w, q.i, q.j, q.k],
        translation: [5.0, -10.0, 80.0],
    }
}

const ORIGIN: GeodeticOrigin = GeodeticOrigin {
    lat_deg: 47.07,
    lon_deg: 15.44,
    alt_m: 350.0,
};

#[test]
fn readme_real_photo_recipe_runs_end_to_end_on_the_visp_cube_photos() {
    let start = Instant::now();
    // Before the work: a required but missing MAVSDK fails at once.
    let mavsdk = mavsdk_python();
    let data = data();
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path().to_str().unwrap();
    let d = data.to_str().unwrap();

    // 1. colmap align with the positions of the known similarity: refused,
    // the cameras lie on a line; aligned with --gravity-from-views.
    let rec = colmap::read_model(&data.join("sparse")).unwrap();
    align_with_gravity_from_views(tmp.path(), &data, &rec);

    // 2. colmap undistort: a PINHOLE camera stays as it is; frame.json kept.
    let text = run(&format!(
        "colmap undistort --colmap {t}/aligned --images {d}/images --out {t}/dense"
    ));
    assert!(
        text.contains("PINHOLE 387x288 -> PINHOLE 387x288")
            && text.contains("wrote 9 undistorted images"),
        "{text}"
    );
    assert!(tmp.path().join("dense/sparse/frame.json").is_file());

    // 3. vp-mvs on the whole workspace: depth maps and fused points, in metres.
    // Fewer iterations, sources and a smaller window than the defaults keep
    // this at seconds in a debug build; the images and model stay real.
    std::fs::write(
        tmp.path().join("mvs.toml"),
        "iterations = 2\ncoarse_levels = 0\nmax_sources = 3\ntop_k_sources = 2\n\
         geom_consistency = false\nwindow_radius = 3\n",
    )
    .unwrap();
    run(&format!(
        "mvs run --workspace {t}/dense --config {t}/mvs.toml"
    ));
    check_depth_maps_in_metres(&tmp.path().join("dense"));

    // 4. Training labels without ground truth: triplets, their depth maps
    // (pyramid level 3), the voting. The frame is checked now.
    run(&format!(
        "labelgen triplets --model {t}/dense/sparse --out {t}/triplets.txt --per-bin 2 --min-equilateral 0.45 --seed 0"
    ));
    run(&format!(
        "mvs run --workspace {t}/dense --triplets {t}/triplets.txt --levels 3 --out {t}/depth --config {t}/mvs.toml"
    ));
    run(&format!(
        "labelgen run --model {t}/dense/sparse --triplets {t}/triplets.txt --depth-dir {t}/depth --out-dir {t}/labels"
    ));
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(tmp.path().join("labels/summary.json")).unwrap(),
    )
    .unwrap();
    assert!(
        summary["positive"].as_u64().unwrap_or(0) > 10_000,
        "{summary}"
    );

    // 5. Train the confidence forest, predict confidence for every photo.
    std::fs::write(
        tmp.path().join("forest.toml"),
        "n_tests = 50\nn_thresholds = 10\n",
    )
    .unwrap();
    run(&format!(
        "train --images {t}/dense/images --labels {t}/labels --out {t}/forest.vpforest --trees 2 --max-depth 4 --config {t}/forest.toml --seed 0"
    ));
    run(&format!(
        "predict --forest {t}/forest.vpforest --out {t}/conf --no-previews {t}/dense/images"
    ));
    for im in rec.images.values() {
        assert!(
            tmp.path()
                .join("conf")
                .join(format!("{}.vpconf", im.name))
                .is_file(),
            "{}",
            im.name
        );
    }

    // 6. A mesh of the fused points (posters on a table: a height field),
    // the plan, the mission.
    run(&format!(
        "mesh build --points {t}/dense/fused.ply --method height-field --out {t}/site.ply"
    ));
    let volume = write_plan_config(tmp.path());
    let text = run(&format!(
        "plan --mesh {t}/site.ply --colmap {t}/dense/sparse --confidence-dir {t}/conf --config {t}/plan.toml --out {t}/plan.json"
    ));
    eprintln!("{text}");
    let origin = ModelFrame::load(&tmp.path().join("dense/sparse"))
        .unwrap()
        .origin;
    let n_waypoints = check_plan(&tmp.path().join("plan.json"), &volume, &origin);
    let items = export_with_a_home(tmp.path(), &origin, n_waypoints);

    // 7. MAVSDK, an independent implementation, imports the .plan.
    if let Some(py) = mavsdk {
        mavsdk_imports(&py, &tmp.path().join("mission.plan"), items.len());
    }
    eprintln!("whole recipe: {:.1} s", start.elapsed().as_secs_f64());
}

/// Step 1: `colmap align` with positions from the known similarity. The
/// cameras lie on a line, so it refuses; with `--gravity-from-views` it takes
/// the rotation about the line from the cameras' mean viewing direction and
/// writes `tmp/aligned`, which matches the known similarity.
fn align_with_gravity_from_views(tmp: &Path, data: &Path, rec: &colmap::Reconstruction) {
    let (t, d) = (tmp.to_str().unwrap(), data.to_str().unwrap());
    let sim = known_sim3();
    let frame = vp_mission::geodesy::LocalFrame::new(ORIGIN).unwrap();
    let mut csv = String::from("name,lat,lon,alt\n");
    // In model order: the first line, the first camera, is the origin of
    // the frame `colmap align` writes.
    for im in rec.images.values() {
        let g = frame.to_geodetic(sim.apply(&im.center()).coords.into());
        writeln!(
            csv,
            "{},{:.10},{:.10},{:.4}",
            im.name, g.lat_deg, g.lon_deg, g.alt_m
        )
        .unwrap();
    }
    std::fs::write(tmp.join("positions.csv"), csv).unwrap();
    let model = format!("{d}/sparse");
    let (positions, out) = (format!("{t}/positions.csv"), format!("{t}/aligned"));
    let args = [
        "colmap",
        "align",
        "--colmap",
        &model,
        "--positions",
        &positions,
        "--out",
        &out,
    ];
    let o = vpctl(&args);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("positions.csv")
            && stderr(&o).contains("lie on a line")
            && stderr(&o).contains("--gravity-from-views"),
        "{}",
        stderr(&o)
    );
    assert!(!tmp.join("aligned").exists(), "nothing written");
    let text = run(&format!("{} --gravity-from-views", args.join(" ")));
    assert!(
        text.contains("strip: cameras on a line") && text.contains("positions: 9 of 9 used"),
        "{text}"
    );
    let aligned = ModelFrame::load(&tmp.join("aligned")).unwrap();
    // The origin is the first position: the first camera moved by the known
    // similarity.
    let first = rec.images.values().next().unwrap();
    let g = frame.to_geodetic(sim.apply(&first.center()).coords.into());
    assert!(
        (aligned.origin.lat_deg - g.lat_deg).abs() < 1e-9
            && (aligned.origin.lon_deg - g.lon_deg).abs() < 1e-9,
        "{aligned:?}"
    );
    let frame = aligned;
    // The known similarity is recovered: metric scale, and the mean view,
    // which the known rotation turns to within a few degrees of straight
    // down, turned straight down.
    assert!((frame.sim3.scale / 3.0 - 1.0).abs() < 0.01, "{frame:?}");
    assert!(frame.rms_m < 0.01, "{frame:?}");
    let strip = frame.strip.expect("strip recorded in frame.json");
    assert!(strip.view_tilt_deg > 45.0, "{strip:?}");
    let q = |s: &Sim3| {
        let [w, x, y, z] = s.rotation_wxyz;
        UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z))
    };
    let angle = q(&frame.sim3).angle_to(&q(&sim)).to_degrees();
    eprintln!(
        "colmap align --gravity-from-views: scale {:.5}, rms {:.5} m, {strip:?}, {angle:.2} degrees from the known rotation",
        frame.sim3.scale, frame.rms_m
    );
    assert!(angle < 5.0, "{angle} degrees from the known rotation");
}

/// A geometric depth map per image, in metres.
fn check_depth_maps_in_metres(dense: &Path) {
    let fused = dense.join("fused.ply");
    assert!(fused.is_file());
    let n_maps = std::fs::read_dir(dense.join("stereo/depth_maps"))
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .ends_with(".geometric.bin")
        })
        .count();
    assert_eq!(n_maps, 9, "a geometric depth map per image");
    // Depths in metres: the sparse points cube_17 sees lie at a median depth
    // of 20.69 model units (SOURCE.md), 62.1 m at 3 m per unit.
    let map =
        colmap::read_depth_map(&dense.join("stereo/depth_maps/cube_17.png.geometric.bin")).unwrap();
    let mut depths: Vec<f32> = map.data.iter().copied().filter(|z| *z > 0.0).collect();
    assert!(
        depths.len() * 2 > map.data.len(),
        "most pixels have a depth"
    );
    depths.sort_by(f32::total_cmp);
    let median = f64::from(depths[depths.len() / 2]);
    assert!(
        (median / (3.0 * 20.69) - 1.0).abs() < 0.1,
        "median depth {median} m"
    );
}

/// The planner config: small numbers, the photos' camera, a flight volume
/// around the aligned cameras (returned).
fn write_plan_config(tmp: &Path) -> [[f64; 3]; 2] {
    let moved = colmap::read_model(&tmp.join("dense/sparse")).unwrap();
    let (mut lo, mut hi) = (Point3::from([f64::MAX; 3]), Point3::from([f64::MIN; 3]));
    for c in moved.images.values().map(colmap::ColmapImage::center) {
        lo = lo.inf(&c);
        hi = hi.sup(&c);
    }
    let volume = [
        [lo.x - 40.0, lo.y - 40.0, lo.z - 30.0],
        [hi.x + 40.0, hi.y + 40.0, hi.z + 20.0],
    ];
    // `unknown_space = "free"`: these photos look at the cube from one side
    // and never picture the space around their own positions, so with
    // "occupied" no leg out of the last camera's position is known free and
    // both triplets are dropped with that reason (the safe answer, but the
    // recipe's later steps need waypoints; docs/campaign-findings.md).
    std::fs::write(
        tmp.join("plan.toml"),
        format!(
            "n_triangles = 300\nn_surrogates = 600\nn_selected = 60\nn_triplets = 2\n\
             gsd_m = 0.05\naccuracy_m = 0.05\nunknown_space = \"free\"\n\
             flight_volume = [[{}, {}, {}], [{}, {}, {}]]\n\
             [camera]\nwidth = 387\nheight = 288\nfocal_px = 592.37\n",
            volume[0][0], volume[0][1], volume[0][2], volume[1][0], volume[1][1], volume[1][2]
        ),
    )
    .unwrap();
    volume
}

/// Step 6, the mission: the origin of `colmap align` is the first photo, in
/// the air, so without a take-off point the export is refused (it once put
/// every waypoint below the launch point) and nothing is written; planned
/// again with `--home-from-first-image`, the mission flies above it.
fn export_with_a_home(
    tmp: &Path,
    origin: &GeodeticOrigin,
    n_waypoints: usize,
) -> Vec<serde_json::Value> {
    let t = tmp.to_str().unwrap();
    let o = common::vpctl(&[
        "mission",
        "export",
        &format!("{t}/plan.json"),
        "--out",
        &format!("{t}/mission.plan"),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("no home"), "{}", stderr(&o));
    assert!(!tmp.join("mission.plan").exists());
    // With the take-off point under the first photo: heights above it.
    let text = run(&format!(
        "plan --mesh {t}/site.ply --colmap {t}/dense/sparse --confidence-dir {t}/conf --config {t}/plan.toml --home-from-first-image --out {t}/plan.json --force"
    ));
    assert!(
        text.contains("home: ") && text.contains("first image"),
        "{text}"
    );
    run(&format!(
        "mission export {t}/plan.json --out {t}/mission.plan"
    ));
    let qgc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(tmp.join("mission.plan")).unwrap()).unwrap();
    assert_eq!(qgc["fileType"], "Plan", "{qgc}");
    let items = qgc["mission"]["items"].as_array().expect("mission items");
    assert!(items.len() > n_waypoints, "{qgc}");
    check_heights_above_home(&tmp.join("plan.json"), items, origin);
    items.clone()
}

/// Every waypoint of the exported mission flies at its planned ENU height
/// minus the home's, so above the take-off point (curvature over the few
/// metres of this scene is far below the 1 cm tolerance).
fn check_heights_above_home(plan: &Path, items: &[serde_json::Value], origin: &GeodeticOrigin) {
    let plan = vp_scene::plan::Plan::load(plan).unwrap();
    let home = plan.home.expect("the plan records its home").position;
    let home_z = vp_mission::geodesy::LocalFrame::new(*origin)
        .unwrap()
        .to_enu(home)[2];
    let heights: Vec<f64> = items
        .iter()
        .filter(|i| i["command"] == 16)
        .map(|i| i["params"][6].as_f64().unwrap())
        .collect();
    assert_eq!(heights.len(), plan.waypoints.len());
    for (h, w) in heights.iter().zip(&plan.waypoints) {
        assert!(*h > 0.0, "waypoint at {h} m above home: {heights:?}");
        assert!(
            (h - (w.position[2] - home_z)).abs() < 0.01,
            "{h} vs {:?}, home z {home_z}",
            w.position
        );
    }
    eprintln!(
        "mission heights above home: {:.2} to {:.2} m",
        heights.iter().copied().fold(f64::INFINITY, f64::min),
        heights.iter().copied().fold(0.0, f64::max)
    );
}

/// MAVSDK's QGC importer reads the `.plan`: as many items as it holds.
fn mavsdk_imports(py: &str, plan: &Path, n_items: usize) {
    let script =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../mission/tests/mavsdk/mavsdk_peer.py");
    let o = Command::new(py)
        .arg(script)
        .arg("import")
        .arg(plan)
        .stderr(Stdio::null())
        .output()
        .unwrap();
    let out = stdout(&o);
    assert!(o.status.success(), "MAVSDK importer failed: {out}");
    let v: serde_json::Value = serde_json::from_str(out.lines().last().unwrap()).unwrap();
    let got = v["items"].as_array().expect("imported items");
    assert_eq!(got.len(), n_items, "{out}");
    println!("MAVSDK imported {} items from the .plan", got.len());
}

/// The plan has waypoints, inside the flight volume, and the model's origin
/// (`origin`); returns how many.
fn check_plan(path: &Path, volume: &[[f64; 3]; 2], origin: &GeodeticOrigin) -> usize {
    let plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let waypoints = plan["waypoints"].as_array().expect("waypoints");
    assert!(!waypoints.is_empty(), "{plan}");
    for w in waypoints {
        let p: Vec<f64> = (0..3).map(|i| w["position"][i].as_f64().unwrap()).collect();
        assert!(
            (0..3).all(|i| (volume[0][i]..=volume[1][i]).contains(&p[i])),
            "waypoint {p:?} outside the flight volume {volume:?}"
        );
    }
    assert!(
        (plan["origin"]["lat_deg"].as_f64().unwrap() - origin.lat_deg).abs() < 1e-9
            && (plan["origin"]["lon_deg"].as_f64().unwrap() - origin.lon_deg).abs() < 1e-9,
        "{plan}"
    );
    waypoints.len()
}
