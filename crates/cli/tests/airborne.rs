//! The simulated loop with an airborne origin, as `colmap align` makes it
//! on real photos: a simulated first flight is georegistered from its
//! image positions (origin at the first photo, 30 m up), planned with the
//! take-off point under the first photo, and exported. Every waypoint must
//! fly at its true height above the simulated ground at the take-off
//! point: a check against the simulator's own mesh, which the chain
//! (align, home from the first image, relative heights) never sees.

use std::fmt::Write as _;
use std::path::Path;
use std::process::Output;

use nalgebra::{Point3, Vector3};
use vp_scene::colmap::{read_model, ModelFrame};
use vp_scene::geodesy::LocalFrame;
use vp_scene::io::{read_mesh, write_mesh, MeshFormat};
use vp_scene::plan::Plan;

mod common;
use common::vpctl_in as vpctl;

fn ok(o: &Output) -> String {
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success(),
        "{out}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    out
}

#[test]
fn an_airborne_origin_from_align_flies_every_waypoint_at_its_true_height() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("site.toml"),
        // The camera stated: `plan` fills a missing one from the planner's
        // defaults, `sim fly` from the demo preset.
        "[site]\nseed = 3\ntarget_faces = 8000\nsize = 40.0\n\
         [planner.camera]\nwidth = 240\nheight = 160\nfocal_px = 320.0\n",
    )
    .unwrap();
    fly_a_grid(d);
    let (sim, first_c) = write_positions(d);
    ok(&vpctl(
        d,
        &[
            "colmap",
            "align",
            "--colmap",
            "f/sparse",
            "--positions",
            "pos.csv",
            "--datum",
            "egm96",
            // The positions written below are exact: RTK is their class.
            "--gnss",
            "rtk",
            "--out",
            "a",
        ],
    ));
    // The aligned frame's origin, in the simulator's frame: in the air.
    let aligned = ModelFrame::load(&d.join("a")).unwrap();
    let s = Vector3::from(sim.to_enu(aligned.origin));
    let mesh = read_mesh(&d.join("site.ply")).unwrap();
    let ground = vp_planner::request::ground_below(&mesh, first_c).expect("ground");
    assert!(
        s.z - ground.z > 20.0,
        "the origin should be in the air: {s:?}"
    );
    // The mesh in the aligned frame (the same frame, moved to the origin).
    let mut moved = mesh.clone();
    for v in &mut moved.vertices {
        *v -= s;
    }
    write_mesh(
        &d.join("moved.ply"),
        &moved,
        MeshFormat::PlyBinaryLittleEndian,
    )
    .unwrap();
    let out = ok(&vpctl(
        d,
        &[
            "plan",
            "--mesh",
            "moved.ply",
            "--colmap",
            "a",
            "--config",
            "site.toml",
            "--home-from-first-image",
            "--out",
            "p.json",
        ],
    ));
    assert!(out.contains("first image"), "{out}");
    // The class recorded by align sets the position part of the clearance.
    assert!(
        out.contains("RTK GNSS 0.02/0.03 m (from frame.json)"),
        "{out}"
    );
    let plan = Plan::load(&d.join("p.json")).unwrap();
    assert!(!plan.waypoints.is_empty(), "{out}");
    ok(&vpctl(
        d,
        &["mission", "export", "p.json", "--out", "m.plan"],
    ));
    let qgc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("m.plan")).unwrap()).unwrap();
    let heights: Vec<f64> = qgc["mission"]["items"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|i| i["command"] == 16)
        .map(|i| i["params"][6].as_f64().unwrap())
        .collect();
    assert_eq!(heights.len(), plan.waypoints.len());
    for (w, h) in plan.waypoints.iter().zip(&heights) {
        // True height above the take-off ground, in the simulator's frame.
        let truth = w.position[2] + s.z - ground.z;
        assert!(truth > 2.0, "{truth}");
        assert!(
            (h - truth).abs() < 0.05,
            "exported {h} m, truly {truth:.3} m above home"
        );
    }
}

/// The site, a 35 m grid over it and its simulated flight with exact poses
/// (`f/sparse`, origin on the ground).
fn fly_a_grid(d: &Path) {
    ok(&vpctl(
        d,
        &[
            "scene",
            "generate",
            "--config",
            "site.toml",
            "--out",
            "site.ply",
        ],
    ));
    ok(&vpctl(
        d,
        &[
            "plan",
            "grid",
            "--mesh",
            "site.ply",
            "--config",
            "site.toml",
            "--height",
            "35",
            "--overlap",
            "0.8",
            "--out",
            "g.json",
        ],
    ));
    ok(&vpctl(
        d,
        &[
            "sim",
            "fly",
            "g.json",
            "--site",
            "site.toml",
            "--out",
            "f",
            "--exact",
            "--output-type",
            "bin",
        ],
    ));
}

/// Writes `pos.csv`, the photos' GPS positions (the simulator's exact camera
/// centres); returns the simulator's frame and the first photo's centre.
fn write_positions(d: &Path) -> (LocalFrame, Point3<f64>) {
    // The photos' GPS positions: the simulator's exact camera centres.
    let sim = LocalFrame::new(ModelFrame::load(&d.join("f/sparse")).unwrap().origin).unwrap();
    let rec = read_model(&d.join("f/sparse")).unwrap();
    let mut csv = String::from("name,lat,lon,alt\n");
    let mut first: Option<(String, Point3<f64>)> = None;
    for (&id, im) in &rec.images {
        let c = rec.camera_of(id).unwrap().center();
        let g = sim.to_geodetic([c.x, c.y, c.z]);
        writeln!(
            csv,
            "{},{:.10},{:.10},{:.4}",
            im.name, g.lat_deg, g.lon_deg, g.alt_m
        )
        .unwrap();
        if first.as_ref().is_none_or(|(n, _)| im.name < *n) {
            first = Some((im.name.clone(), c));
        }
    }
    let (_, first_c) = first.expect("images");
    std::fs::write(d.join("pos.csv"), csv).unwrap();
    (sim, first_c)
}
