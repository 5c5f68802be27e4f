//! Flight time and batteries: `--max-flight-time` splits a plan into
//! flights that each start and end at home, fit the limit and together fly
//! every image once; the legs to and from home (straight up, then level)
//! keep the safety distance,
//! checked here by brute force against every triangle of the mesh
//! (independently of the planner's clearance tree); the export writes one
//! mission per flight; bad limits are refused with nothing written.

use std::path::Path;
use std::process::Output;

use nalgebra::{Point3, Vector3};
use vp_scene::geodesy::LocalFrame;
use vp_scene::plan::{GeodeticOrigin, Plan};
use vp_scene::Mesh;

mod common;

use common::vpctl_in as vpctl;

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

const ORIGIN: GeodeticOrigin = GeodeticOrigin {
    lat_deg: 46.03,
    lon_deg: 10.35,
    alt_m: 400.0,
};
/// The planner's default safety distance, metres.
const SAFETY_M: f64 = 5.0;
/// The default `[mission] reserve_s`.
const RESERVE_S: f64 = 120.0;

/// A generated site in `dir` (seed 7: bare ground at its south-east
/// corner) and a home on its ground 3 m in from that corner, as
/// `LAT,LON,ALT`, with the home's ENU position.
fn site(dir: &Path) -> (Mesh, String, Point3<f64>) {
    std::fs::write(dir.join("rtk.toml"), "[safety]\ngnss = \"rtk\"\n").unwrap();
    std::fs::write(
        dir.join("site.toml"),
        "[site]\nseed = 7\ntarget_faces = 6000\nsize = 40.0\n\
         [planner.camera]\nwidth = 240\nheight = 160\nfocal_px = 320.0\n",
    )
    .unwrap();
    let o = vpctl(
        dir,
        &[
            "scene",
            "generate",
            "--config",
            "site.toml",
            "--out",
            "site.ply",
        ],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let mesh = vp_scene::io::read_mesh(&dir.join("site.ply")).unwrap();
    let b = mesh.bounds();
    let at = Point3::new(b.max.x - 3.0, b.min.y + 3.0, 0.0);
    let ground = vp_planner::request::ground_below(&mesh, at).expect("ground below home");
    let g = LocalFrame::new(ORIGIN)
        .unwrap()
        .to_geodetic([ground.x, ground.y, ground.z]);
    let home = format!("{:.9},{:.9},{:.3}", g.lat_deg, g.lon_deg, g.alt_m);
    (mesh, home, ground)
}

fn grid(dir: &Path, home: &str, out: &str, extra: &[&str]) -> Output {
    let mut args = vec![
        "plan",
        "grid",
        "--mesh",
        "site.ply",
        "--height",
        "20",
        "--origin",
        "46.03,10.35,400",
        "--home",
        home,
        // Exact geometry: these tests are about flight time and the legs
        // home, not about the position margin (standard GNSS by default).
        "--config",
        "rtk.toml",
        "--out",
        out,
    ];
    args.extend_from_slice(extra);
    vpctl(dir, &args)
}

/// Distance from `p` to triangle `abc` (closest point by Voronoi regions,
/// Ericson, Real-Time Collision Detection 5.1.5).
fn point_triangle(p: &Point3<f64>, a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> f64 {
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
        return (p - (a + ab * (d1 / (d1 - d3)))).norm();
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.norm();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return (p - (a + ac * (d2 / (d2 - d6)))).norm();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (p - (b + (c - b) * w)).norm();
    }
    let denom = 1.0 / (va + vb + vc);
    (p - (a + ab * (vb * denom) + ac * (vc * denom))).norm()
}

/// Smallest distance from the segment `a-b` (sampled every 0.25 m) to the mesh.
fn segment_clearance(mesh: &Mesh, a: &Point3<f64>, b: &Point3<f64>) -> f64 {
    let n = ((b - a).norm() / 0.25).ceil().max(1.0) as usize;
    let tris: Vec<[Point3<f64>; 3]> = (0..mesh.n_faces()).map(|f| mesh.triangle(f)).collect();
    (0..=n)
        .map(|i| a + (b - a) * (i as f64 / n as f64))
        .map(|p| {
            tris.iter()
                .map(|t| point_triangle(&p, &t[0], &t[1], &t[2]))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn a_split_plan_flies_every_image_once_within_the_limit_with_clear_legs_home() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (mesh, home, home_enu) = site(d);
    let o = grid(d, &home, "one.json", &[]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let stdout = text(&o.stdout);
    assert!(
        stdout.contains("flights: 1 (") && stdout.contains("GSD"),
        "{stdout}"
    );
    let one = Plan::load(&d.join("one.json")).unwrap();
    assert_eq!(one.flights.len(), 1);
    let total = one.flights[0].duration_s;

    // A battery for about 40 % of the whole: at least three flights.
    let limit = RESERVE_S + 0.4 * total;
    let o = grid(
        d,
        &home,
        "split.json",
        &["--max-flight-time", &format!("{limit:.0}")],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let split = Plan::load(&d.join("split.json")).unwrap();
    assert_eq!(
        split.waypoints, one.waypoints,
        "splitting must not move a waypoint"
    );
    assert!(split.flights.len() >= 3, "{:?}", split.flights.len());
    let flown: Vec<usize> = split
        .flights
        .iter()
        .flat_map(|f| f.waypoints.clone())
        .collect();
    assert_eq!(flown, (0..split.waypoints.len()).collect::<Vec<_>>());
    // The take-off column is checked from 3.5 m up with 0.5 m clearance
    // (nothing overhangs the take-off point), the level leg at the
    // waypoint's height with the safety distance.
    let base = home_enu + Vector3::z() * 3.5;
    for (i, f) in split.flights.iter().enumerate() {
        assert!(f.from_home);
        assert!(
            f.duration_s <= limit.round() - RESERVE_S + 1e-9,
            "flight {i}: {} s over the limit",
            f.duration_s
        );
        for w in [f.waypoints[0], f.waypoints[f.waypoints.len() - 1]] {
            // As flown: straight up from home to the waypoint's height, then level.
            let p = Point3::from(split.waypoints[w].position);
            let above = Point3::new(base.x, base.y, p.z.max(base.z));
            let column = segment_clearance(&mesh, &base, &above);
            let level = segment_clearance(&mesh, &above, &p);
            assert!(
                column >= 0.5 - 0.05 && level >= SAFETY_M - 0.05,
                "flight {i}: home - waypoint {w}: column {column:.2} m, level leg {level:.2} m \
                 from the mesh"
            );
        }
    }

    // One mission per flight, every photo once.
    let o = vpctl(d, &["mission", "export", "split.json", "--out", "m.plan"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(!d.join("m.plan").exists());
    let mut photos = 0;
    for i in 1..=split.flights.len() {
        let qgc: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join(format!("m-{i}.plan"))).unwrap())
                .unwrap();
        photos += qgc["mission"]["items"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|it| it["command"] == 2000)
            .count();
    }
    assert_eq!(photos, split.waypoints.len());
    assert!(!d
        .join(format!("m-{}.plan", split.flights.len() + 1))
        .exists());
    // Printing several missions to standard output is refused.
    let o = vpctl(d, &["mission", "export", "split.json"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains("--out"), "{}", text(&o.stderr));
}

#[test]
fn limits_that_cannot_work_are_refused_with_nothing_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (_, home, _) = site(d);
    // Less than the reserve: no time to fly.
    let o = grid(d, &home, "a.json", &["--max-flight-time", "100"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains("reserve"), "{}", text(&o.stderr));
    // Shorter than one waypoint from home and back.
    let o = grid(d, &home, "b.json", &["--max-flight-time", "135"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains("alone"), "{}", text(&o.stderr));
    // A split needs a home.
    let o = vpctl(
        d,
        &[
            "plan",
            "grid",
            "--mesh",
            "site.ply",
            "--height",
            "25",
            "--max-flight-time",
            "900",
            "--config",
            "rtk.toml",
            "--out",
            "c.json",
        ],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains("--home"), "{}", text(&o.stderr));
    for f in ["a.json", "b.json", "c.json"] {
        assert!(!d.join(f).exists(), "{f} written");
    }
}
