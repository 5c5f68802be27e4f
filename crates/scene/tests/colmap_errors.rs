//! Bad COLMAP input: every case errors with the file and the place, never panics.

mod colmap_common;

use std::fs;
use std::path::{Path, PathBuf};

use colmap_common::data_dir;
use proptest::prelude::*;
use vp_scene::colmap::{
    parse_cameras_binary, parse_depth_map, parse_images_binary, parse_points3d_binary,
    read_depth_map, read_model, write_depth_map, DepthMap,
};
use vp_scene::SceneError;

/// A copy of a committed model in a temporary folder, to break on purpose.
fn copy_model(sub: &str) -> (tempfile::TempDir, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("model");
    fs::create_dir(&dir).unwrap();
    for e in fs::read_dir(data_dir().join(sub)).unwrap() {
        let e = e.unwrap();
        fs::copy(e.path(), dir.join(e.file_name())).unwrap();
    }
    (tmp, dir)
}

fn message(dir: &Path) -> String {
    read_model(dir).unwrap_err().to_string()
}

/// Replaces line `n` (1-based) of a text file.
fn set_line(path: &Path, n: usize, text: &str) {
    let content = fs::read_to_string(path).unwrap();
    let mut lines: Vec<&str> = content.lines().collect();
    lines[n - 1] = text;
    fs::write(path, lines.join("\n") + "\n").unwrap();
}

#[test]
fn truncated_binary_names_file_element_and_byte() {
    let (_tmp, dir) = copy_model("sfm/bin");
    let path = dir.join("images.bin");
    let bytes = fs::read(&path).unwrap();
    fs::write(&path, &bytes[..bytes.len() - 10]).unwrap();
    let m = message(&dir);
    assert!(
        m.starts_with(&format!("{}: image 3 (byte ", path.display())),
        "{m}"
    );
    assert!(m.contains("file truncated"), "{m}");

    let path = dir.join("cameras.bin");
    let full = fs::read(&path).unwrap();
    // Cut inside the parameters: count (8), id, model (4 + 4), size (8 + 8), f (8).
    fs::write(&path, &full[..40]).unwrap();
    assert_eq!(
        message(&dir),
        format!(
            "{}: camera 0 (byte 40): file truncated: camera 1 (SIMPLE_PINHOLE) parameter 1 \
             needs 8 bytes, only 0 left",
            path.display()
        )
    );
    // A cut before the first element shows in the count.
    fs::write(&path, &full[..20]).unwrap();
    let m = message(&dir);
    assert!(
        m.starts_with(&format!("{}: byte 0: file truncated", path.display())),
        "{m}"
    );
}

#[test]
fn unknown_model_id_in_binary() {
    let (_tmp, dir) = copy_model("sfm/bin");
    let path = dir.join("cameras.bin");
    let mut bytes = fs::read(&path).unwrap();
    // u64 count, u32 camera id, then the i32 model id at byte 12.
    bytes[12..16].copy_from_slice(&99i32.to_le_bytes());
    fs::write(&path, bytes).unwrap();
    assert_eq!(
        message(&dir),
        format!(
            "{}: camera 0 (byte 12): camera 1: unknown camera model id 99 (known: 0 to 17)",
            path.display()
        )
    );
}

#[test]
fn unknown_model_name_and_wrong_param_count_in_text() {
    let (_tmp, dir) = copy_model("sfm/txt");
    let path = dir.join("cameras.txt");
    set_line(&path, 4, "1 SIMPLE_PINHOLE 320 240 301.9 160");
    assert_eq!(
        message(&dir),
        format!(
            "{}: line 4: camera 1: SIMPLE_PINHOLE expects 3 parameters, found 2",
            path.display()
        )
    );
    set_line(&path, 4, "1 KANNALA 320 240 301.9 160 120");
    let m = message(&dir);
    assert!(
        m.starts_with(&format!(
            "{}: line 4: unknown camera model 'KANNALA'",
            path.display()
        )),
        "{m}"
    );
}

#[test]
fn zero_quaternion_errors_in_text_and_binary() {
    let (_tmp, dir) = copy_model("hand/colmap_txt");
    let path = dir.join("images.txt");
    set_line(&path, 5, "1 0 0 0 0 0.1 -0.2 4 1 a.jpg");
    let m = message(&dir);
    assert!(
        m.starts_with(&format!("{}: line 5: image 1: quaternion", path.display())),
        "{m}"
    );
    assert!(m.contains("is zero"), "{m}");

    let (_tmp, dir) = copy_model("hand/colmap_bin");
    let path = dir.join("images.bin");
    let mut bytes = fs::read(&path).unwrap();
    // u64 count, u32 image id, then qw qx qy qz at bytes 12..44.
    bytes[12..44].fill(0);
    fs::write(&path, bytes).unwrap();
    let m = message(&dir);
    assert!(
        m.starts_with(&format!("{}: image 0 (byte 12)", path.display())),
        "{m}"
    );
}

#[test]
fn non_unit_quaternion_is_normalised() {
    let (_tmp, dir) = copy_model("hand/colmap_txt");
    let path = dir.join("images.txt");
    let good = read_model(&dir).unwrap();
    // Image 7's quaternion scaled by 3.
    let content = fs::read_to_string(&path).unwrap();
    let n = content.lines().position(|l| l.ends_with("d.jpg")).unwrap() + 1;
    let (q, t) = vp_scene_qt(&good.images[&7].cam_from_world);
    set_line(
        &path,
        n,
        &format!(
            "7 {} {} {} {} {} {} {} 11 d.jpg",
            3.0 * q[0],
            3.0 * q[1],
            3.0 * q[2],
            3.0 * q[3],
            t[0],
            t[1],
            t[2]
        ),
    );
    let rec = read_model(&dir).unwrap();
    let d = rec.images[&7]
        .cam_from_world
        .rotation
        .angle_to(&good.images[&7].cam_from_world.rotation);
    assert!(d < 1e-12, "{d}");
}

fn vp_scene_qt(p: &nalgebra::Isometry3<f64>) -> ([f64; 4], [f64; 3]) {
    let q = p.rotation.quaternion();
    let t = p.translation.vector;
    ([q.w, q.i, q.j, q.k], [t.x, t.y, t.z])
}

#[test]
fn bad_number_names_the_line() {
    let (_tmp, dir) = copy_model("hand/colmap_txt");
    let path = dir.join("points3D.txt");
    let content = fs::read_to_string(&path).unwrap();
    fs::write(&path, content.replacen("255 0 10", "255 0 1O", 1)).unwrap();
    let m = message(&dir);
    assert!(m.starts_with(&format!("{}: line ", path.display())), "{m}");
    assert!(m.contains("bad B '1O'"), "{m}");
}

#[test]
fn missing_files_and_folders() {
    let (tmp, dir) = copy_model("sfm/bin");
    fs::remove_file(dir.join("points3D.bin")).unwrap();
    let m = message(&dir);
    assert!(
        m.contains("incomplete COLMAP model: missing points3D.bin"),
        "{m}"
    );
    let nowhere = tmp.path().join("nowhere");
    let e = read_model(&nowhere).unwrap_err();
    assert!(matches!(e, SceneError::Io { .. }), "{e}");
    assert!(e.to_string().contains("nowhere"), "{e}");
    // The mapper's output folder with its numbered sub-model.
    let (_tmp2, dir2) = copy_model("sfm/bin");
    let parent = dir2.parent().unwrap().join("sparse");
    fs::create_dir(&parent).unwrap();
    fs::rename(&dir2, parent.join("0")).unwrap();
    let m = message(&parent);
    assert!(m.contains("a model exists in"), "{m}");
}

#[test]
fn both_forms_present_reads_binary() {
    let (_tmp, dir) = copy_model("hand/colmap_bin");
    for e in fs::read_dir(data_dir().join("hand/colmap_txt")).unwrap() {
        let e = e.unwrap();
        fs::copy(e.path(), dir.join(e.file_name())).unwrap();
    }
    // Break the text form: a binary read does not notice.
    fs::write(dir.join("cameras.txt"), "garbage\n").unwrap();
    assert!(read_model(&dir).is_ok());
}

#[test]
fn dangling_references_name_file_and_place() {
    // Image refers to an unknown camera.
    let (_tmp, dir) = copy_model("hand/colmap_txt");
    let path = dir.join("images.txt");
    let content = fs::read_to_string(&path).unwrap();
    let n = content.lines().position(|l| l.ends_with("d.jpg")).unwrap() + 1;
    fs::write(&path, content.replace(" 11 d.jpg", " 12 d.jpg")).unwrap();
    assert_eq!(
        message(&dir),
        format!(
            "{}: line {n}: image 7: refers to unknown camera 12",
            path.display()
        )
    );

    // Track refers to an unknown image and to a 2D point out of range.
    let (_tmp, dir) = copy_model("hand/colmap_txt");
    let path = dir.join("points3D.txt");
    let content = fs::read_to_string(&path).unwrap();
    let n = content.lines().position(|l| l.starts_with("10 ")).unwrap() + 1;
    let line = content.lines().nth(n - 1).unwrap().to_string();
    set_line(&path, n, &format!("{line} 99 0"));
    assert_eq!(
        message(&dir),
        format!(
            "{}: line {n}: point 10: track refers to unknown image 99",
            path.display()
        )
    );
    set_line(&path, n, &format!("{line} 7 0"));
    let m = message(&dir);
    assert!(
        m.starts_with(&format!(
            "{}: line {n}: point 10: track refers to 2D point 0 of image 7",
            path.display()
        )),
        "{m}"
    );

    // Binary: a 2D point observes a 3D point that does not exist.
    let (_tmp, dir) = copy_model("hand/colmap_bin");
    let path = dir.join("points3D.bin");
    let rec = read_model(&dir).unwrap();
    let mut rec2 = rec.clone();
    rec2.points.remove(&3);
    fs::write(&path, vp_scene::colmap::points3d_to_bytes(&rec2)).unwrap();
    let m = message(&dir);
    assert!(m.contains("images.bin: image "), "{m}");
    assert!(m.contains("refers to unknown 3D point 3"), "{m}");
}

#[test]
fn depth_map_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("x.geometric.bin");
    let e = read_depth_map(&path).unwrap_err();
    assert!(matches!(e, SceneError::Io { .. }) && e.to_string().contains("x.geometric.bin"));
    let good = fs::read(data_dir().join("depth/ramp_5x3.geometric.bin")).unwrap();
    fs::write(&path, &good[..good.len() - 1]).unwrap();
    assert_eq!(
        read_depth_map(&path).unwrap_err().to_string(),
        format!(
            "{}: byte 6: header says 5x3x1 float32 = 60 bytes of data, file has 59",
            path.display()
        )
    );
    let bad = DepthMap {
        width: 2,
        height: 2,
        data: vec![1.0; 3],
    };
    assert!(write_depth_map(&path, &bad).is_err());
    // The failed write left the previous file alone.
    assert_eq!(fs::read(&path).unwrap().len(), good.len() - 1);
}

#[test]
fn depth_map_round_trip() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("a.photometric.bin");
    let d = read_depth_map(&data_dir().join("depth/ramp_5x3.geometric.bin")).unwrap();
    write_depth_map(&path, &d).unwrap();
    assert_eq!(
        fs::read(&path).unwrap(),
        fs::read(data_dir().join("depth/ramp_5x3.geometric.bin")).unwrap()
    );
}

fn sfm_file(name: &str) -> Vec<u8> {
    fs::read(data_dir().join("sfm/bin").join(name)).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn truncated_binary_never_panics(cut in 0.0f64..1.0, which in 0usize..4) {
        let p = Path::new("t.bin");
        let result = match which {
            0 => { let b = sfm_file("cameras.bin"); parse_cameras_binary(p, &b[..(cut * b.len() as f64) as usize]).map(|_| ()) }
            1 => { let b = sfm_file("images.bin"); parse_images_binary(p, &b[..(cut * b.len() as f64) as usize]).map(|_| ()) }
            2 => { let b = sfm_file("points3D.bin"); parse_points3d_binary(p, &b[..(cut * b.len() as f64) as usize]).map(|_| ()) }
            _ => {
                let b = fs::read(data_dir().join("depth/ramp_5x3.geometric.bin")).unwrap();
                parse_depth_map(p, &b[..(cut * b.len() as f64) as usize]).map(|_| ())
            }
        };
        let e = result.expect_err("a truncated file must not parse");
        prop_assert!(e.to_string().starts_with("t.bin: "), "{}", e);
    }

    #[test]
    fn corrupted_binary_never_panics(pos in 0.0f64..1.0, byte in any::<u8>(), which in 0usize..3) {
        let name = ["cameras.bin", "images.bin", "points3D.bin"][which];
        let mut b = sfm_file(name);
        let i = ((pos * b.len() as f64) as usize).min(b.len() - 1);
        b[i] = byte;
        let p = Path::new("c.bin");
        // Either still valid or a located error; never a panic.
        let r = match which {
            0 => parse_cameras_binary(p, &b).map(|_| ()),
            1 => parse_images_binary(p, &b).map(|_| ()),
            _ => parse_points3d_binary(p, &b).map(|_| ()),
        };
        if let Err(e) = r {
            prop_assert!(e.to_string().starts_with("c.bin: "), "{}", e);
        }
    }
}

/// Regression: a track element naming an image that does not exist was
/// blamed on images.txt ("2D point observes 3D point 10, whose track does
/// not list it") because the images were checked first; the broken line is
/// in points3D.txt.
#[test]
fn broken_track_is_blamed_on_points3d() {
    let (_tmp, dir) = copy_model("hand/colmap_txt");
    let path = dir.join("points3D.txt");
    let content = fs::read_to_string(&path).unwrap();
    let n = content.lines().position(|l| l.starts_with("10 ")).unwrap() + 1;
    let line = content.lines().nth(n - 1).unwrap();
    // POINT3D_ID X Y Z R G B ERROR then (IMAGE_ID, POINT2D_IDX) pairs: break the first image id.
    let mut fields: Vec<String> = line.split_whitespace().map(str::to_string).collect();
    fields[8] = "99".to_string();
    set_line(&path, n, &fields.join(" "));
    assert_eq!(
        message(&dir),
        format!(
            "{}: line {n}: point 10: track refers to unknown image 99",
            path.display()
        )
    );
}
