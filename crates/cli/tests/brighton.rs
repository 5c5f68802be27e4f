//! A real drone flight end to end: `scripts/brighton.sh` (the README's
//! real-photo recipe) on the 18 Brighton Beach photos (DJI Phantom 3,
//! FC300S 4000x2250, EXIF GPS and DJI XMP) — COLMAP 3.8's SfM on the CPU,
//! `colmap align --exif`, `colmap undistort`, `mvs run`, `mesh build`,
//! `predict`, `plan --home` (DJI's take-off altitude below the first photo)
//! `--glb`, `mission export` to a `.plan` and a `.kmz` — then checks what an
//! operator relies on: COLMAP registered the flight (at least 15 of the 18
//! photos, whichever it registers: its mapper is not deterministic), the
//! plan has waypoints, every exported waypoint flies above the take-off
//! point, every waypoint keeps the safety distance from the reconstructed
//! mesh (measured here by brute force, not by the planner) and the `.kmz`
//! holds DJI's files.
//!
//! Downscaled so that it takes minutes: features and the dense workspace at
//! 800 px (`brighton.sh OUT 800`, a fifth of the photos' 4000 px), 2000 SIFT
//! features per photo (COLMAP's default is 8192), a smaller PatchMatch (3
//! iterations, no coarse level, 4 sources, best 2, 1 geometric iteration),
//! the `quick` simulator forest, a small planner (400 triangles, 60 planned
//! for, 2 triplets). Unobserved space counts as free, as in the script: the
//! first photos look down on a tree canopy, where dense stereo keeps almost
//! no depth, and the take-off point is below the first photo.
//!
//! `scripts/test.sh` runs it in its own step with `--ignored --nocapture`,
//! so that the test command prints its step times. The photos live in
//! `../shared/data/brighton-beach` (never committed): where that is absent,
//! or COLMAP or GNU time is not installed, the test says so in one line and
//! passes — unless `VP_REQUIRE_COLMAP` is set (scripts/test.sh sets it;
//! .ci/run installs both), which makes a missing tool a failure.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use nalgebra::{Point3, Vector3};
use vp_scene::colmap::{self, ModelFrame};
use vp_scene::io::read_mesh;
use vp_scene::plan::Plan;

const SAFETY_M: f64 = 5.0;
/// Fewest of the 18 photos COLMAP must register (its mapper is not
/// deterministic: what follows holds for any registered set this large).
const MIN_REGISTERED: usize = 15;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The photos, or `None` (with the one line saying why) when the test cannot run.
fn photos() -> Option<PathBuf> {
    let photos = root().join("../shared/data/brighton-beach/images");
    if !photos.is_dir() {
        println!(
            "skipped: {} is absent (shared/ beside the clone)",
            photos.display()
        );
        return None;
    }
    // The script runs COLMAP and times every step with GNU time.
    let colmap_found = Command::new("colmap").arg("help").output().is_ok();
    let time_found = Path::new("/usr/bin/time").is_file();
    if !(colmap_found && time_found) {
        let missing = if colmap_found { "GNU time" } else { "colmap" };
        assert!(
            std::env::var_os("VP_REQUIRE_COLMAP").is_none(),
            "VP_REQUIRE_COLMAP is set but {missing} is not installed: apt-get install -y colmap time"
        );
        println!("skipped: {missing} is not installed (apt-get install -y colmap time)");
        return None;
    }
    Some(photos)
}

/// Closest point on triangle `abc` to `p` (Ericson, Real-Time Collision
/// Detection 5.1.5), as a distance.
fn point_triangle_distance(
    p: &Point3<f64>,
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: &Point3<f64>,
) -> f64 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.norm();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.norm();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return (ap - ab * (d1 / (d1 - d3))).norm();
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.norm();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return (ap - ac * (d2 / (d2 - d6))).norm();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (bp - (c - b) * w).norm();
    }
    let denom = 1.0 / (va + vb + vc);
    let closest: Vector3<f64> = ab * (vb * denom) + ac * (vc * denom);
    (ap - closest).norm()
}

#[test]
fn point_triangle_distance_is_exact_on_the_regions_of_a_triangle() {
    let (a, b, c) = (
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(2.0, 0.0, 0.0),
        Point3::new(0.0, 2.0, 0.0),
    );
    let d = |x: f64, y: f64, z: f64| point_triangle_distance(&Point3::new(x, y, z), &a, &b, &c);
    assert!((d(0.5, 0.5, 3.0) - 3.0).abs() < 1e-12); // face
    assert!((d(-3.0, -4.0, 0.0) - 5.0).abs() < 1e-12); // vertex a
    assert!((d(1.0, -2.0, 0.0) - 2.0).abs() < 1e-12); // edge ab
    assert!((d(2.0, 2.0, 0.0) - 2f64.sqrt()).abs() < 1e-12); // edge bc
    assert!((d(5.0, 0.0, 0.0) - 3.0).abs() < 1e-12); // vertex b
}

#[test]
#[ignore = "long run (minutes, COLMAP included): scripts/test.sh runs it in its own step, printing its step times"]
fn brighton_beach_photos_to_a_plan_and_a_kmz() {
    let Some(photos) = photos() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("run");
    // Smaller than the defaults so that this takes minutes in a debug build.
    std::fs::write(
        tmp.path().join("mvs.toml"),
        "iterations = 3\ncoarse_levels = 0\nmax_sources = 4\ntop_k_sources = 2\n\
         geom_iterations = 1\n",
    )
    .unwrap();
    std::fs::write(
        tmp.path().join("plan.toml"),
        format!(
            "n_triangles = 400\nn_surrogates = 1000\nn_selected = 60\nn_triplets = 2\n\
             gsd_m = 0.01\naccuracy_m = 0.02\nsafety_distance_m = {SAFETY_M}\n\
             unknown_space = \"free\"\n\
             [camera]\nwidth = 4000\nheight = 2250\nfocal_px = 2985.0\n"
        ),
    )
    .unwrap();
    let start = Instant::now();
    let o = Command::new("bash")
        .arg(root().join("scripts/brighton.sh"))
        .arg(&out)
        .arg("800")
        .env("VPCTL", env!("CARGO_BIN_EXE_vpctl"))
        .env("PHOTOS", &photos)
        .env("MAX_FEATURES", "2000")
        .env("MIN_REGISTERED", MIN_REGISTERED.to_string())
        .env("FOREST_PRESET", "quick")
        .env("MVS_CONFIG", tmp.path().join("mvs.toml"))
        .env("PLAN_CONFIG", tmp.path().join("plan.toml"))
        .output()
        .unwrap();
    // The step times, peak memory and sizes the script printed.
    println!("{}", String::from_utf8_lossy(&o.stdout));
    assert!(
        o.status.success(),
        "brighton.sh failed\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    println!(
        "brighton.sh at 800 px: {:.0} s",
        start.elapsed().as_secs_f64()
    );

    // COLMAP registered the flight: the model the script went on with (the
    // largest of the mapper's; brighton.sh stops with "COLMAP registered N
    // of 18 photos, fewer than 15" below MIN_REGISTERED).
    let sparse = colmap::read_model(&out.join("aligned")).unwrap();
    assert!(
        sparse.images.len() >= MIN_REGISTERED,
        "COLMAP registered {} of 18 photos",
        sparse.images.len()
    );
    // The plan has waypoints and a home on the ground below the first photo.
    let plan = Plan::load(&out.join("plan.json")).unwrap();
    assert!(!plan.waypoints.is_empty(), "no waypoints planned");
    let home = plan.home.as_ref().expect("a home").position;
    let origin = ModelFrame::load(&out.join("dense/sparse")).unwrap().origin;
    let home_z = vp_mission::geodesy::LocalFrame::new(origin)
        .unwrap()
        .to_enu(home)[2];

    // Every waypoint keeps the safety distance from the mesh, measured
    // brute force over every triangle, independently of the planner.
    let mesh = read_mesh(&out.join("site.ply")).unwrap();
    assert!(mesh.faces.len() > 1000, "{} faces", mesh.faces.len());
    let v = |i: u32| &mesh.vertices[i as usize];
    for w in &plan.waypoints {
        let p = Point3::from(w.position);
        let d = mesh
            .faces
            .iter()
            .map(|f| point_triangle_distance(&p, v(f[0]), v(f[1]), v(f[2])))
            .fold(f64::INFINITY, f64::min);
        assert!(
            d >= SAFETY_M - 1e-6,
            "waypoint {p:?} is {d:.3} m from the mesh"
        );
        assert!(
            w.position[2] > home_z,
            "waypoint {p:?} below home z {home_z}"
        );
    }

    // The .plan: every waypoint above the take-off point (relative heights).
    let qgc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("mission.plan")).unwrap()).unwrap();
    let heights: Vec<f64> = qgc["mission"]["items"]
        .as_array()
        .expect("mission items")
        .iter()
        .filter(|i| i["command"] == 16)
        .map(|i| i["params"][6].as_f64().unwrap())
        .collect();
    assert_eq!(heights.len(), plan.waypoints.len());
    assert!(heights.iter().all(|h| *h > 0.0), "{heights:?}");
    println!(
        "{} of 18 photos registered; {} waypoints at {:.1} to {:.1} m above home",
        sparse.images.len(),
        heights.len(),
        heights.iter().copied().fold(f64::INFINITY, f64::min),
        heights.iter().copied().fold(0.0, f64::max)
    );

    check_kmz_and_glb(&out);
}

/// The .kmz: a zip with DJI's two WPML files; the glTF view.
fn check_kmz_and_glb(out: &Path) {
    let kmz = std::fs::read(out.join("mission.kmz")).unwrap();
    assert!(kmz.starts_with(b"PK"), "not a zip");
    for name in ["wpmz/template.kml", "wpmz/waylines.wpml"] {
        assert!(
            kmz.windows(name.len()).any(|w| w == name.as_bytes()),
            "{name} missing from the .kmz"
        );
    }
    let glb = std::fs::read(out.join("plan.glb")).unwrap();
    assert!(glb.starts_with(b"glTF"), "plan.glb is not binary glTF");
}
