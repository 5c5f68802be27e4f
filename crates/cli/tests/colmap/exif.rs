//! `vpctl colmap align --exif`: positions from the photos' EXIF GPS tags.

use std::path::Path;

use crate::common::{jpeg_with_exif, jpeg_with_gps, scene_data, stderr, stdout, vpctl};
use crate::{scale_error, sfm_geodetic, sfm_positions};

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

/// `vpctl colmap align --colmap MODEL --exif PHOTOS --out OUT [EXTRA...]`.
fn align_exif(model: &Path, photos: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
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
    let o = align_exif(&model, &photos, &out, &[]);
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
    let align = |photos: &Path, extra: &[&str]| align_exif(&model, photos, &out, extra);
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

/// The `sfm` photos as a drone writes them: each with its camera model and
/// DJI's height above take-off (the photo's GPS altitude minus
/// `takeoff_alt[i]`), aligned with `colmap align --exif` into `out`.
fn align_drone_photos(
    dir: &Path,
    cameras: [&str; 4],
    takeoff_alt: [f64; 4],
    out: &Path,
) -> std::process::Output {
    let model = sfm_model_with_jpgs(dir);
    let geo = sfm_geodetic(&[[0.0; 3]; 4]);
    let photos = dir.join("photos");
    std::fs::create_dir_all(&photos).unwrap();
    for (i, (_, g)) in geo.iter().enumerate() {
        let rel = g.alt_m - takeoff_alt[i];
        let bytes = jpeg_with_exif(
            32,
            24,
            Some(lat_lon_alt(g)),
            true,
            Some(cameras[i]),
            Some(rel),
        );
        std::fs::write(photos.join(format!("view_{i:02}.jpg")), bytes).unwrap();
    }
    align_exif(&model, &photos, out, &[])
}

/// Issue 38's bad input: photos from two camera models in one folder (a
/// phone's beside the drone's) are refused with exit 2, naming each model
/// with its photos and the ways on, and nothing is written.
#[test]
fn colmap_align_exif_refuses_photos_of_two_camera_models() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("aligned");
    let o = align_drone_photos(
        dir.path(),
        ["FC300S", "FC300S", "iPhone 12", "FC300S"],
        [158.5; 4],
        &out,
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("2 camera models")
            && err.contains("FC300S: 3 (view_00.jpg, view_01.jpg, view_03.jpg)")
            && err.contains("iPhone 12: 1 (view_02.jpg)")
            && err.contains("--positions"),
        "{err}"
    );
    assert!(!out.exists(), "a refused alignment wrote {}", out.display());
}

/// One take-off point: its altitude (the photos' GPS altitude minus their
/// height above take-off) is recorded in frame.json. Photos from two
/// take-off points 5.5-6 m apart in height: no one home is right for all, so
/// none is recorded, and a warning says to give the home to `plan`.
#[test]
fn colmap_align_exif_records_one_take_off_point_and_not_two() {
    let dir = tempfile::tempdir().unwrap();
    let one = dir.path().join("one");
    let o = align_drone_photos(
        dir.path(),
        ["FC300S"; 4],
        [158.5, 158.6, 158.4, 158.5],
        &one,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let t = vp_scene::colmap::ModelFrame::load(&one)
        .unwrap()
        .takeoff_alt_m
        .expect("a take-off altitude");
    // The median of the four, to the millimetre the EXIF altitude keeps.
    assert!((t - 158.5).abs() < 2e-3, "{t}");
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));

    let two = dir.path().join("two");
    let o = align_drone_photos(
        dir.path(),
        ["FC300S"; 4],
        [158.5, 158.5, 164.5, 164.0],
        &two,
    );
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("no take-off altitude recorded")
            && err.contains("158.50 m (view_00.jpg)")
            && err.contains("164.50 m (view_02.jpg)")
            && err.contains("plan --home"),
        "{err}"
    );
    let frame = vp_scene::colmap::ModelFrame::load(&two).unwrap();
    assert_eq!(frame.takeoff_alt_m, None);
}
