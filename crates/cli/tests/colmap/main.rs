//! `vpctl colmap undistort|align` as a user runs them: outputs, files and exit codes
//! (`align --exif` in `exif.rs`).

use std::fmt::Write as _;
use std::path::Path;

#[path = "../common/mod.rs"]
mod common;
mod exif;

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
    assert!(
        stderr(&o).contains("earlier `vpctl colmap undistort`") && stderr(&o).contains("--force"),
        "{}",
        stderr(&o)
    );
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
pub(crate) fn sfm_positions(offsets: &[[f64; 3]; 4]) -> String {
    let mut csv = String::from("name,lat,lon,alt\n");
    for (name, g) in sfm_geodetic(offsets) {
        writeln!(
            csv,
            "{name},{:.10},{:.10},{:.4}",
            g.lat_deg, g.lon_deg, g.alt_m
        )
        .unwrap();
    }
    csv
}

/// The positions of [`sfm_positions`], as image names and WGS84 positions.
pub(crate) fn sfm_geodetic(
    offsets: &[[f64; 3]; 4],
) -> Vec<(String, vp_scene::plan::GeodeticOrigin)> {
    let frame = vp_mission::geodesy::LocalFrame::new(vp_scene::plan::GeodeticOrigin {
        lat_deg: 47.07,
        lon_deg: 15.44,
        alt_m: 350.0,
    })
    .unwrap();
    [-24.0f64, -8.0, 8.0, 24.0]
        .iter()
        .enumerate()
        .map(|(i, az)| {
            let az = az.to_radians();
            let enu = [
                8.0 * az.cos() - 2.0 + offsets[i][0],
                8.0 * az.sin() + offsets[i][1],
                5.0 + offsets[i][2],
            ];
            (format!("view_{i:02}.png"), frame.to_geodetic(enu))
        })
        .collect()
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
    let scale_error = scale_error(&out, "png");
    eprintln!(
        "scale error {:.4} %, rms {:.4} m",
        100.0 * scale_error,
        frame.rms_m
    );
    assert!(scale_error < 0.01, "scale error {scale_error}");
    // The aligned model plans: its frame passes the check.
    let rec = vp_scene::colmap::read_model(&out).unwrap();
    vp_scene::colmap::check_frame(&out, &rec).unwrap();
    // No overwrite.
    let o = align("pos.csv", &out);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    // Cameras not on a line: --gravity-from-views changes nothing, says so.
    let strip_out = dir.path().join("aligned_flag");
    let o = vpctl(&[
        "colmap",
        "align",
        "--colmap",
        model.to_str().unwrap(),
        "--positions",
        dir.path().join("pos.csv").to_str().unwrap(),
        "--out",
        strip_out.to_str().unwrap(),
        "--gravity-from-views",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("--gravity-from-views not used"),
        "{}",
        stdout(&o)
    );
    let flagged = vp_scene::colmap::ModelFrame::load(&strip_out).unwrap();
    assert_eq!(flagged.sim3, frame.sim3);
    assert!(flagged.strip.is_none());
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
    assert!(
        stderr(&o).contains("lie on a line") && stderr(&o).contains("--gravity-from-views"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists(), "nothing written");
}

#[test]
fn colmap_align_gravity_from_views_refuses_a_strip_looking_along_itself() {
    let dir = tempfile::tempdir().unwrap();
    // Five cameras on the model's z axis, each looking along +z: the
    // viewing direction cannot fix the rotation about the line.
    let model = dir.path().join("model");
    std::fs::create_dir_all(&model).unwrap();
    std::fs::write(
        model.join("cameras.txt"),
        "1 PINHOLE 640 480 500 500 320 240\n",
    )
    .unwrap();
    let mut images = String::new();
    let mut csv = String::new();
    for k in 0..5 {
        writeln!(images, "{} 1 0 0 0 0 0 {} 1 s_{k}.jpg\n", k + 1, -2 * k).unwrap();
        writeln!(csv, "s_{k}.jpg,47.0,{},300", 15.0 + 1e-4 * f64::from(k)).unwrap();
    }
    std::fs::write(model.join("images.txt"), images).unwrap();
    std::fs::write(model.join("points3D.txt"), "").unwrap();
    std::fs::write(dir.path().join("pos.csv"), csv).unwrap();
    let out = dir.path().join("aligned");
    let align = |extra: &[&str]| {
        let mut args = vec![
            "colmap",
            "align",
            "--colmap",
            model.to_str().unwrap(),
            "--positions",
            dir.path().join("pos.csv").to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]
        .into_iter()
        .map(String::from)
        .collect::<Vec<_>>();
        args.extend(extra.iter().map(|s| (*s).to_owned()));
        vpctl(&args.iter().map(String::as_str).collect::<Vec<_>>())
    };
    let o = align(&[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("--gravity-from-views"),
        "{}",
        stderr(&o)
    );
    let o = align(&["--gravity-from-views"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("pos.csv") && stderr(&o).contains("look along it"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists(), "nothing written");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        2,
        "no temporary folder left"
    );
}

/// Relative error of the distance between the first and last view of the
/// sfm model (`view_00` and `view_03`, photos ending in `ext`) in the aligned
/// model at `out`, against the rendered cameras' true distance.
pub(crate) fn scale_error(out: &Path, ext: &str) -> f64 {
    let rec = vp_scene::colmap::read_model(out).unwrap();
    let c = |n: String| {
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
    let d = (c(format!("view_00.{ext}")) - c(format!("view_03.{ext}"))).norm();
    (d / (truth(-24.0) - truth(24.0)).norm() - 1.0).abs()
}

/// Copies the files of folder `from` into a new folder `to`.
fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
}

/// Regression (issue 39): `colmap align ... --out . --force` deleted every
/// file in the current folder, the model it read included.
#[test]
fn colmap_align_never_deletes_what_it_did_not_write() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    copy_dir(&scene_data("colmap/sfm/txt"), &d.join("in/model"));
    std::fs::write(d.join("in/pos.csv"), sfm_positions(&[[0.0; 3]; 4])).unwrap();
    common::assert_output_guards(
        d,
        &[
            "colmap",
            "align",
            "--colmap",
            "in/model",
            "--positions",
            "in/pos.csv",
        ],
        "in/model",
    );
}

/// Regression (issue 39): `colmap undistort --force` replaced its output
/// folder whole, whatever else it held.
#[test]
fn colmap_undistort_never_deletes_what_it_did_not_write() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = scene_data("colmap/undistort/input");
    copy_dir(&data.join("model"), &d.join("in/model"));
    copy_dir(&data.join("images"), &d.join("in/images"));
    common::assert_output_guards(
        d,
        &[
            "colmap",
            "undistort",
            "--colmap",
            "in/model",
            "--images",
            "in/images",
        ],
        "in",
    );
}
