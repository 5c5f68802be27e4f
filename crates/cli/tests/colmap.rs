//! `vpctl colmap undistort|align` as a user runs them: outputs, files and exit codes.

use std::fmt::Write as _;
use std::path::Path;

mod common;

use common::{scene_data, stderr, stdout, vpctl};

#[test]
fn colmap_undistort_writes_a_pinhole_workspace_and_refuses_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let data = scene_data("colmap/undistort/input");
    let (model, images) = (data.join("model"), data.join("images"));
    let ws = dir.path().join("ws");
    let run = |model: &Path, out: &Path| {
        vpctl(&[
            "colmap",
            "undistort",
            "--colmap",
            model.to_str().unwrap(),
            "--images",
            images.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let o = run(&model, &ws);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("camera 3: SIMPLE_RADIAL 160x120 -> PINHOLE 167x122"),
        "{text}"
    );
    assert!(text.contains("wrote 11 undistorted images"), "{text}");
    let o = vpctl(&["colmap", "info", ws.join("sparse").to_str().unwrap()]);
    assert!(stdout(&o).contains("images: 11"), "{}", stdout(&o));
    assert!(ws.join("stereo/patch-match.cfg").is_file());
    // Refuses to overwrite: exit 2, names the folder.
    let o = run(&model, &ws);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("already exists"), "{}", stderr(&o));
    // An unknown camera model: exit 2, names the file and line, writes nothing.
    let bad = dir.path().join("bad");
    std::fs::create_dir(&bad).unwrap();
    for f in ["images.txt", "points3D.txt"] {
        std::fs::copy(model.join(f), bad.join(f)).unwrap();
    }
    let cams = std::fs::read_to_string(model.join("cameras.txt"))
        .unwrap()
        .replace("RADIAL_FISHEYE", "KANNALA_BRANDT");
    std::fs::write(bad.join("cameras.txt"), cams).unwrap();
    let out = dir.path().join("ws2");
    let o = run(&bad, &out);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("cameras.txt") && err.contains("line 9") && err.contains("KANNALA_BRANDT"),
        "{err}"
    );
    assert!(!out.exists());
    // An equirectangular camera has no pinhole: exit 2, names cameras.txt.
    let cams = "1 EQUIRECTANGULAR 160 120 160 120\n";
    let pano = dir.path().join("pano");
    std::fs::create_dir(&pano).unwrap();
    std::fs::write(pano.join("cameras.txt"), cams).unwrap();
    std::fs::write(
        pano.join("images.txt"),
        "1 1 0 0 0 0 0 0 1 m00_simple_pinhole.png\n\n",
    )
    .unwrap();
    std::fs::write(pano.join("points3D.txt"), "").unwrap();
    let o = run(&pano, &out);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("cameras.txt") && stderr(&o).contains("EQUIRECTANGULAR"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
}

/// Positions CSV of the `sfm` model's four views (rendered from known
/// centres, reconstructed by COLMAP; see scene's data README): the true
/// centres in ENU metres at `origin`, plus `offsets` (noise, outliers).
fn sfm_positions(offsets: &[[f64; 3]; 4]) -> String {
    let frame = vp_mission::geodesy::LocalFrame::new(vp_scene::plan::GeodeticOrigin {
        lat_deg: 47.07,
        lon_deg: 15.44,
        alt_m: 350.0,
    })
    .unwrap();
    let mut csv = String::from("name,lat,lon,alt\n");
    for (i, az) in [-24.0f64, -8.0, 8.0, 24.0].iter().enumerate() {
        let az = az.to_radians();
        let enu = [
            8.0 * az.cos() - 2.0 + offsets[i][0],
            8.0 * az.sin() + offsets[i][1],
            5.0 + offsets[i][2],
        ];
        let g = frame.to_geodetic(enu);
        writeln!(
            csv,
            "view_{i:02}.png,{:.10},{:.10},{:.4}",
            g.lat_deg, g.lon_deg, g.alt_m
        )
        .unwrap();
    }
    csv
}

#[test]
fn colmap_align_recovers_metric_scale_and_flags_a_bad_position() {
    let dir = tempfile::tempdir().unwrap();
    let model = scene_data("colmap/sfm/txt");
    // 3 cm noise; view_02's position is 40 m off (a GPS glitch).
    let noise = [
        [0.03, -0.02, 0.01],
        [-0.01, 0.03, -0.02],
        [40.0, -10.0, 5.0],
        [0.02, 0.01, 0.03],
    ];
    std::fs::write(dir.path().join("pos.csv"), sfm_positions(&noise)).unwrap();
    let out = dir.path().join("aligned");
    let align = |csv: &str, out: &Path| {
        vpctl(&[
            "colmap",
            "align",
            "--colmap",
            model.to_str().unwrap(),
            "--positions",
            dir.path().join(csv).to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let o = align("pos.csv", &out);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    eprintln!("{text}");
    assert!(
        text.contains("positions: 3 of 4 used (1 outliers"),
        "{text}"
    );
    assert!(
        text.contains("view_02.png") && text.contains("(outlier)"),
        "{text}"
    );
    let frame = vp_scene::colmap::ModelFrame::load(&out).unwrap();
    assert!(frame.rms_m < 0.1, "rms {}", frame.rms_m);
    // Scale: aligned distances equal the true ones within 1 %.
    let rec = vp_scene::colmap::read_model(&out).unwrap();
    let c = |n: &str| {
        rec.images
            .values()
            .find(|im| im.name == n)
            .unwrap()
            .center()
    };
    let truth = |az: f64| {
        let a = az.to_radians();
        nalgebra::Point3::new(8.0 * a.cos() - 2.0, 8.0 * a.sin(), 5.0)
    };
    let true_d = (truth(-24.0) - truth(24.0)).norm();
    let d = (c("view_00.png") - c("view_03.png")).norm();
    let scale_error = (d / true_d - 1.0).abs();
    eprintln!(
        "scale error {:.4} %, rms {:.4} m",
        100.0 * scale_error,
        frame.rms_m
    );
    assert!(scale_error < 0.01, "scale error {scale_error}");
    // The aligned model plans: its frame passes the check.
    vp_scene::colmap::check_frame(&out, &rec).unwrap();
    // No overwrite.
    let o = align("pos.csv", &out);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn colmap_align_refuses_bad_positions_with_exit_2_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("aligned");
    let run = |model: &Path, csv: &str, body: &str| {
        let path = dir.path().join(csv);
        std::fs::write(&path, body).unwrap();
        vpctl(&[
            "colmap",
            "align",
            "--colmap",
            model.to_str().unwrap(),
            "--positions",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let sfm = scene_data("colmap/sfm/txt");
    let good = sfm_positions(&[[0.0; 3]; 4]);
    // Too few positions of model images.
    let two: String = good.lines().take(3).collect::<Vec<_>>().join("\n") + "\n";
    let o = run(&sfm, "two.csv", &two);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("two.csv") && stderr(&o).contains("at least 3"),
        "{}",
        stderr(&o)
    );
    // Inconsistent positions: no similarity explains most of them.
    let wild = "view_00.png,47.0,15.0,300\nview_01.png,47.001,15.0,300\n\
                view_02.png,47.0,15.0001,450\nview_03.png,47.0004,15.003,301\n";
    let o = run(&sfm, "wild.csv", wild);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("wild.csv") && stderr(&o).contains("inconsistent"),
        "{}",
        stderr(&o)
    );
    // A malformed line names the file and line.
    let o = run(
        &sfm,
        "bad.csv",
        "view_00.png,47.0,15.0,300\nview_01.png,north,15,300\n",
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("bad.csv") && stderr(&o).contains("line 2"),
        "{}",
        stderr(&o)
    );
    // A model that cannot be aligned: the real visp-cube photos were taken
    // along a straight line, so the rotation about it is undetermined.
    let cube =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/real-mvs/visp-cube/sparse");
    let mut csv = String::new();
    for (k, i) in [17, 23, 30, 36, 43, 49, 56, 62, 69].iter().enumerate() {
        writeln!(
            csv,
            "cube_{i}.png,{},{},300",
            47.0 + 1e-5 * k as f64,
            15.0 + 2e-5 * (k % 3) as f64
        )
        .unwrap();
    }
    let o = run(&cube, "cube.csv", &csv);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("lie on a line"), "{}", stderr(&o));
    assert!(!out.exists(), "nothing written");
}
