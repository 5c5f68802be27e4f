//! `vpctl colmap undistort|align` as a user runs them: outputs, files and exit codes.

use std::fmt::Write as _;
use std::path::Path;

mod common;

use common::{jpeg_with_gps, scene_data, stderr, stdout, vpctl};

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
fn sfm_positions(offsets: &[[f64; 3]; 4]) -> String {
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
fn sfm_geodetic(offsets: &[[f64; 3]; 4]) -> Vec<(String, vp_scene::plan::GeodeticOrigin)> {
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

/// The `sfm` model (text) with its images renamed from `.png` to `.jpg`, in
/// `dir/model`: the same cameras, for photos that carry EXIF.
fn sfm_model_with_jpgs(dir: &Path) -> std::path::PathBuf {
    let src = scene_data("colmap/sfm/txt");
    let model = dir.join("model");
    std::fs::create_dir_all(&model).unwrap();
    for f in ["cameras.txt", "images.txt", "points3D.txt"] {
        let text = std::fs::read_to_string(src.join(f)).unwrap();
        std::fs::write(model.join(f), text.replace(".png", ".jpg")).unwrap();
    }
    model
}

/// Writes the `sfm` views as JPEGs whose EXIF GPS tags hold `positions`
/// (`None`: no EXIF; `Some((g, false))`: GPS without altitude).
fn write_sfm_photos(photos: &Path, positions: &[Option<([f64; 3], bool)>; 4]) {
    std::fs::create_dir_all(photos).unwrap();
    for (i, p) in positions.iter().enumerate() {
        let bytes = match p {
            Some((g, altitude)) => jpeg_with_gps(32, 24, Some(*g), *altitude),
            None => jpeg_with_gps(32, 24, None, true),
        };
        std::fs::write(photos.join(format!("view_{i:02}.jpg")), bytes).unwrap();
    }
}

fn lat_lon_alt(g: &vp_scene::plan::GeodeticOrigin) -> [f64; 3] {
    [g.lat_deg, g.lon_deg, g.alt_m]
}

#[test]
fn colmap_align_exif_reads_gps_tags_and_matches_the_csv_alignment() {
    let dir = tempfile::tempdir().unwrap();
    let model = sfm_model_with_jpgs(dir.path());
    let noise = [
        [0.03, -0.02, 0.01],
        [-0.01, 0.03, -0.02],
        [0.02, -0.03, 0.02],
        [0.02, 0.01, 0.03],
    ];
    let geo = sfm_geodetic(&noise);
    let photos = dir.path().join("photos");
    let with_gps: Vec<_> = geo
        .iter()
        .map(|(_, g)| Some((lat_lon_alt(g), true)))
        .collect();
    write_sfm_photos(&photos, &with_gps.try_into().unwrap());
    // A photo without EXIF (listed, skipped) and a file that is no photo
    // (ignored), as a camera's card holds them.
    std::fs::write(photos.join("phone.jpg"), jpeg_with_gps(32, 24, None, true)).unwrap();
    std::fs::write(photos.join("notes.txt"), "flight 1\n").unwrap();
    let out = dir.path().join("aligned");
    let o = vpctl(&[
        "colmap",
        "align",
        "--colmap",
        model.to_str().unwrap(),
        "--exif",
        photos.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    eprintln!("{text}");
    assert!(
        text.contains("exif: 4 photo(s) with a GPS position, 1 skipped")
            && text.contains("skipped phone.jpg: no EXIF data")
            && text.contains("positions: 4 of 4 used (0 outliers"),
        "{text}"
    );
    let frame = vp_scene::colmap::ModelFrame::load(&out).unwrap();
    assert_eq!(frame.residuals.len(), 4);
    for r in &frame.residuals {
        // 3-4 cm of noise per position; the model's own error adds a little.
        assert!(r.inlier && r.residual_m < 0.1, "{r:?}");
    }
    assert!(frame.rms_m < 0.1, "rms {}", frame.rms_m);
    // The origin is the first photo by name, read back to 1e-7 degrees
    // (seconds are stored to 1/10000") and 1 mm.
    let first = &geo[0].1;
    assert!((frame.origin.lat_deg - first.lat_deg).abs() < 1e-7);
    assert!((frame.origin.lon_deg - first.lon_deg).abs() < 1e-7);
    assert!((frame.origin.alt_m - first.alt_m).abs() < 1e-3);
    // Metric scale: aligned distances equal the true ones within 1 %.
    let scale_error = scale_error(&out, "jpg");
    eprintln!(
        "exif: scale error {:.4} %, rms {:.4} m",
        100.0 * scale_error,
        frame.rms_m
    );
    assert!(scale_error < 0.01, "scale error {scale_error}");
    let rec = vp_scene::colmap::read_model(&out).unwrap();
    vp_scene::colmap::check_frame(&out, &rec).unwrap();
    // The same positions as a CSV give the same transform: one code path.
    let csv = sfm_positions(&noise).replace(".png", ".jpg");
    std::fs::write(dir.path().join("pos.csv"), csv).unwrap();
    let out_csv = dir.path().join("aligned_csv");
    let o = vpctl(&[
        "colmap",
        "align",
        "--colmap",
        model.to_str().unwrap(),
        "--positions",
        dir.path().join("pos.csv").to_str().unwrap(),
        "--out",
        out_csv.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv_frame = vp_scene::colmap::ModelFrame::load(&out_csv).unwrap();
    assert!(
        (csv_frame.sim3.scale / frame.sim3.scale - 1.0).abs() < 1e-3,
        "{:?} vs {:?}",
        csv_frame.sim3,
        frame.sim3
    );
    for (a, b) in csv_frame.residuals.iter().zip(&frame.residuals) {
        assert_eq!(a.name, b.name);
        assert!(
            (a.residual_m - b.residual_m).abs() < 0.005,
            "{a:?} vs {b:?}"
        );
    }
}

#[test]
fn colmap_align_exif_refuses_photos_without_enough_gps_with_exit_2_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let model = sfm_model_with_jpgs(dir.path());
    let out = dir.path().join("aligned");
    let align = |photos: &Path, extra: &[&str]| {
        let mut args = vec![
            "colmap",
            "align",
            "--colmap",
            model.to_str().unwrap(),
            "--exif",
            photos.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        vpctl(&args)
    };
    // No photo has GPS: the error names the folder and each photo's problem.
    let none = dir.path().join("no_gps");
    write_sfm_photos(&none, &[None, None, None, None]);
    let o = align(&none, &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("no_gps")
            && err.contains("no photo has an EXIF GPS position")
            && err.contains("view_00.jpg: no EXIF data"),
        "{err}"
    );
    assert!(!out.exists(), "nothing written");
    // Two usable positions: one photo has GPS but no altitude, one a
    // truncated EXIF block. Both listed; the alignment's own refusal.
    let geo = sfm_geodetic(&[[0.0; 3]; 4]);
    let two = dir.path().join("two");
    write_sfm_photos(
        &two,
        &[
            Some((lat_lon_alt(&geo[0].1), true)),
            Some((lat_lon_alt(&geo[1].1), true)),
            Some((lat_lon_alt(&geo[2].1), false)),
            None,
        ],
    );
    let mut cut = jpeg_with_gps(32, 24, Some(lat_lon_alt(&geo[3].1)), true);
    // A corrupt EXIF block: the TIFF magic number and the IFD0 offset
    // overwritten (APP1 length intact).
    for b in &mut cut[14..22] {
        *b = 0xFF;
    }
    std::fs::write(two.join("view_03.jpg"), cut).unwrap();
    let o = align(&two, &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let (text, err) = (stdout(&o), stderr(&o));
    assert!(err.contains("two") && err.contains("at least 3"), "{err}");
    assert!(
        text.contains("exif: 2 photo(s) with a GPS position, 2 skipped")
            && text.contains("skipped view_02.jpg: no GPS altitude")
            && text.contains("skipped view_03.jpg: EXIF unreadable"),
        "{text}"
    );
    assert!(!out.exists(), "nothing written");
    // A folder that does not exist; --exif and --positions together.
    let o = align(&dir.path().join("missing"), &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("missing"), "{}", stderr(&o));
    let o = align(&none, &["--positions", "pos.csv"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("cannot be used with"), "{}", stderr(&o));
    assert!(!out.exists(), "nothing written");
}

/// Relative error of the distance between the first and last view of the
/// sfm model (`view_00` and `view_03`, photos ending in `ext`) in the aligned
/// model at `out`, against the rendered cameras' true distance.
fn scale_error(out: &Path, ext: &str) -> f64 {
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
